//! `pocketsplat bake MESH -o OUT`: a mesh into a `.tg` or `.qs` file, or a scene file into a pack.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Result;
use pocketsplat_core::bake::BakeOptions;
use pocketsplat_core::qs::write::QsBakeOptions;
use pocketsplat_core::tg::write::{write_tg_as, Layout};
use pocketsplat_sim::args;
use pocketsplat_sim::bake::{bake_file_within, bake_qs_file, BakeFormat};
use pocketsplat_sim::fsutil::write_atomic;
use pocketsplat_sim::scene::bake::{bake_scene, BakeOverrides};
use pocketsplat_sim::{input, limits, scene};

/// The arguments of `bake`.
#[derive(Debug, clap::Args)]
pub struct BakeArgs {
    /// The mesh, or a scene file (`.toml`: the other options are then the scene's).
    mesh: PathBuf,
    /// Output file.
    #[arg(short, long)]
    out: PathBuf,
    /// Cells per axis per subdivision: 2 (octree), 3 (tri-grid), 4, 5.
    #[arg(long, default_value_t = 3, value_parser = args::int::<u8>(2, 5))]
    rho: u8,
    /// Subdivisions (ρ^depth cells across); the paper's level L is depth L+1.
    #[arg(long, default_value_t = 6,
          value_parser = args::int::<u8>(0, u64::from(pocketsplat_core::tg::MAX_DEPTH)))]
    depth: u8,
    /// Block size in bytes (power of two, 512..=64K); each block carries a CRC.
    #[arg(long, default_value = "4096", value_parser = args::block_size)]
    block_size: u32,
    /// Output format: a tri-grid (`tg`) or a QSplat tree (`qsplat`, also `qs`; --rho, --depth and
    /// --block-size do not apply).
    #[arg(long, default_value = "tg", value_parser = super::bake_format())]
    format: BakeFormat,
    /// How a tri-grid lays out its levels: bricked (version 3, the deep levels in bricks, what
    /// `render --stream` and the handheld read from an SD card; the default), bricked:LEVEL,
    /// unbricked (version 3, every level one array: what a firmware drawing the file in place from
    /// flash walks fastest, ~3.6 % fewer instructions) or v2. `pocketsplat migrate` converts.
    #[arg(long, default_value = "bricked", value_parser = pocketsplat_sim::migrate::layout)]
    layout: Layout,
    /// Bake even when the estimate of its memory is over the `bake` limit (see --limits).
    #[arg(long)]
    force: bool,
}

impl BakeArgs {
    /// The file the command reads (what its errors name).
    pub fn input(&self) -> &std::path::Path {
        &self.mesh
    }
}

/// The `bake` command.
///
/// # Errors
/// Mesh import or bake errors, naming the file; nothing is written then.
pub fn run(args: &BakeArgs) -> Result<()> {
    if input::is_scene_file(&args.mesh) {
        return bake_scene_file(&args.mesh, &args.out, args.force);
    }
    let (mesh, out) = (&args.mesh, &args.out);
    if args.format == BakeFormat::QSplat {
        let report = bake_qs_file(mesh, &QsBakeOptions::default())?;
        write_atomic(out, &report.baked.bytes)?;
        let s = report.baked.stats;
        eprintln!(
            "{}: QSplat: {} leaves, {} interior nodes, depth {}, {} bytes ({:.2} per leaf, pointers {:.1} %{}); loaded in {:.2} s, baked in {:.2} s",
            out.display(),
            s.leaves,
            s.interior,
            s.depth,
            s.file_bytes,
            s.bytes_per_leaf(),
            100.0 * s.pointer_share(),
            if report.baked.color { ", colour" } else { "" },
            report.load.as_secs_f64(),
            report.bake.as_secs_f64()
        );
        return Ok(());
    }
    let (rho, depth) = (args.rho, args.depth);
    let block_log2 = args.block_size.trailing_zeros() as u8;
    let limit = if args.force {
        u64::MAX
    } else {
        limits::current().bake
    };
    let mut report = bake_file_within(mesh, BakeOptions { rho, depth }, block_log2, true, limit)?;
    if args.layout != Layout::Bricked {
        report.bytes = write_tg_as(&report.grid, block_log2, args.layout)?;
    }
    write_atomic(out, &report.bytes)?;
    let leaves = report.grid.levels.last().map_or(0, |l| l.attrs.len());
    let total: usize = report.grid.levels.iter().map(|l| l.attrs.len()).sum();
    eprintln!(
        "{}: rho {rho}, depth {depth}: {total} samples ({leaves} leaves), {} bytes; loaded in {:.2} s, baked in {:.2} s",
        out.display(),
        report.bytes.len(),
        report.load.as_secs_f64(),
        report.bake.as_secs_f64()
    );
    Ok(())
}

/// `pocketsplat bake scene.toml -o scene.pack`.
fn bake_scene_file(scene_path: &Path, out: &Path, force: bool) -> Result<()> {
    let t = Instant::now();
    let s = scene::SceneSpec::load(scene_path)?;
    let overrides = BakeOverrides {
        force,
        ..BakeOverrides::default()
    };
    let baked = bake_scene(&s, &overrides)?;
    write_atomic(out, &baked.bytes)?;
    for o in &baked.objects {
        eprintln!(
            "  {:<16} depth {} of {}: {:>9} samples, {:>9} bytes{}{} ({:.2} s)",
            o.name,
            o.depth_kept,
            o.depth_asked,
            o.samples,
            o.file_bytes,
            if o.saved_levels > 0 {
                format!("; {} bytes of unresolvable levels left out", o.saved_levels)
            } else {
                String::new()
            },
            if o.saved_color > 0 {
                format!("; {} bytes of colour left out", o.saved_color)
            } else {
                String::new()
            },
            o.bake_s
        );
    }
    eprintln!(
        "{}: {} objects, {} bytes, in {:.2} s",
        out.display(),
        baked.objects.len(),
        baked.bytes.len(),
        t.elapsed().as_secs_f64()
    );
    Ok(())
}
