//! `pocketsplat bake MESH -o OUT`: a mesh into a `.tg` or `.qs` file, or a scene file into a pack.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Result;
use pocketsplat_core::bake::BakeOptions;
use pocketsplat_core::tg::write::Layout;
use pocketsplat_sim::args;
use pocketsplat_sim::bake::run::{bake, job, BakeJob};
use pocketsplat_sim::bake::{BakeFormat, OocOptions};
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
    /// Bake in memory even when the estimate of its memory is over --memory (the `bake` limit).
    #[arg(long, conflicts_with = "out_of_core")]
    force: bool,
    /// Bake out of core even when the mesh would fit in memory: the PLY streamed, the mesh cut
    /// into pieces that fit --memory through spill files, the same bytes. (A bake over --memory
    /// does so by itself.)
    #[arg(long)]
    out_of_core: bool,
    /// The largest piece of an out-of-core bake, in triangles (`.tg`) or points (`.qs`); by
    /// default as large as --memory allows. Smaller pieces take more passes over the spill files.
    #[arg(long, value_name = "COUNT", value_parser = args::size::<u64>(1, 1 << 40))]
    piece_size: Option<u64>,
    /// Where an out-of-core bake's spill folder goes (default: the output's folder). It is removed
    /// when the bake ends, fails or is interrupted.
    #[arg(long, value_name = "DIR")]
    spill_dir: Option<PathBuf>,
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
    let limits = limits::current();
    let job = BakeJob {
        grid: BakeOptions {
            rho: args.rho,
            depth: args.depth,
        },
        block_log2: args.block_size.trailing_zeros() as u8,
        layout: args.layout,
        force: args.force,
        out_of_core: args.out_of_core,
        ooc: OocOptions {
            spill_dir: args.spill_dir.clone(),
            piece_limit: args.piece_size,
            progress: true,
            ..OocOptions::within(limits.bake)
        },
        ..job(&args.mesh, &args.out, args.format, limits.bake)
    };
    let done = bake(&job, &limits)?;
    eprintln!("{}", done.summary);
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
