//! `pocketsplat bake MESH -o OUT.tg`: mesh → ρ-grid file, with a progress bar; with
//! `--format qsplat`, mesh → QSplat bounding-sphere tree (`.qs`).

use std::path::Path;
use std::time::{Duration, Instant};

use anyhow::{bail, Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use pocketsplat_core::bake::{bake_grid, BakeOptions, BakedGrid, TriMesh};
use pocketsplat_core::qs::write::{bake_qs, BakedQs, QsBakeOptions};
use pocketsplat_core::tg::write::write_tg;

use crate::fsutil::write_atomic;
use crate::ply;

/// What `bake` produced, for the caller to print or measure.
pub struct BakeReport {
    /// The grid.
    pub grid: BakedGrid,
    /// The file bytes.
    pub bytes: Vec<u8>,
    /// Time spent loading the mesh.
    pub load: Duration,
    /// Time spent baking (grid + serialisation), not loading.
    pub bake: Duration,
}

/// Bakes a mesh already in memory; `progress` shows a bar on stderr.
///
/// # Errors
/// When the mesh is invalid or the file cannot be laid out with this block size.
pub fn bake_mesh(
    mesh: &TriMesh,
    opts: BakeOptions,
    block_log2: u8,
    progress: bool,
) -> Result<(BakedGrid, Vec<u8>)> {
    let bar = progress.then(|| {
        let bar = ProgressBar::new(1);
        bar.set_style(
            ProgressStyle::with_template(
                "{spinner} baking {bar:40} {pos}/{len} cells ({eta} left)",
            )
            .expect("static template")
            .progress_chars("=> "),
        );
        bar
    });
    let cb = |done: u64, total: u64| {
        if let Some(bar) = &bar {
            bar.set_length(total);
            bar.set_position(done);
        }
    };
    let grid = bake_grid(mesh, opts, Some(&cb))?;
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    let bytes = write_tg(&grid, block_log2)?;
    Ok((grid, bytes))
}

/// Loads `mesh_path`, bakes it and returns everything (no file written).
///
/// # Errors
/// Mesh import or bake errors, naming the file.
pub fn bake_file(
    mesh_path: &Path,
    opts: BakeOptions,
    block_log2: u8,
    progress: bool,
) -> Result<BakeReport> {
    let t0 = Instant::now();
    let mesh = ply::load_mesh(mesh_path)?;
    let load = t0.elapsed();
    let t1 = Instant::now();
    let (grid, bytes) = bake_mesh(&mesh, opts, block_log2, progress)
        .with_context(|| format!("{}: cannot bake", mesh_path.display()))?;
    Ok(BakeReport {
        grid,
        bytes,
        load,
        bake: t1.elapsed(),
    })
}

/// What a QSplat bake produced.
pub struct QsBakeReport {
    /// The tree, its file and its statistics.
    pub baked: BakedQs,
    /// Time spent loading the mesh.
    pub load: Duration,
    /// Time spent baking (tree, quantization, layout), not loading.
    pub bake: Duration,
}

/// Loads `mesh_path` and bakes it into a `.qs` file in memory.
///
/// # Errors
/// Mesh import or bake errors, naming the file.
pub fn bake_qs_file(mesh_path: &Path, opts: &QsBakeOptions) -> Result<QsBakeReport> {
    let t0 = Instant::now();
    let mesh = ply::load_mesh(mesh_path)?;
    let load = t0.elapsed();
    let t1 = Instant::now();
    let baked =
        bake_qs(&mesh, opts).with_context(|| format!("{}: cannot bake", mesh_path.display()))?;
    Ok(QsBakeReport {
        baked,
        load,
        bake: t1.elapsed(),
    })
}

fn run_qsplat(mesh: &Path, out: &Path) -> Result<()> {
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
    Ok(())
}

/// The `bake` command.
///
/// # Errors
/// Bad arguments, mesh import or bake errors; nothing is written then.
pub fn run(
    mesh: &Path,
    out: &Path,
    rho: u8,
    depth: u8,
    block_size: u32,
    format: &str,
) -> Result<()> {
    match format {
        "tg" => {}
        "qsplat" | "qs" => return run_qsplat(mesh, out),
        _ => bail!("format {format:?} is not supported (supported: tg, qsplat)"),
    }
    if !(2..=5).contains(&rho) {
        bail!("--rho {rho}: must be 2, 3, 4 or 5");
    }
    if depth > pocketsplat_core::tg::MAX_DEPTH {
        bail!(
            "--depth {depth}: at most {}",
            pocketsplat_core::tg::MAX_DEPTH
        );
    }
    if !block_size.is_power_of_two() || !(512..=65536).contains(&block_size) {
        bail!("--block-size {block_size}: must be a power of two from 512 to 65536");
    }
    let block_log2 = block_size.trailing_zeros() as u8;
    let report = bake_file(mesh, BakeOptions { rho, depth }, block_log2, true)?;
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
