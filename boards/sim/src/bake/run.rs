//! `pocketsplat bake` of a mesh: in memory when the bake fits the budget (`--memory`), out of core
//! otherwise (or with `--out-of-core`), the file written under a temporary name and renamed, and
//! a summary line with the time and the peak memory.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use pocketsplat_core::bake::BakeOptions;
use pocketsplat_core::qs::write::QsBakeOptions;
use pocketsplat_core::tg::write::{write_tg_as, Layout};

use super::budget::{human, peak_rss};
use super::progress::phase_times;
use super::{bake_qs_file, estimate_bake, turned_note, BakeFormat, OocOptions};
use crate::fsutil::write_atomic;
use crate::limits::Limits;

/// Bytes an in-memory QSplat bake takes per vertex (the mesh, the points and the tree: 1.80 GB
/// for a 4 M-vertex terrain, issue 32).
const QS_BYTES_PER_VERTEX: u64 = 450;
/// Bytes an in-memory `.tg` bake takes per vertex and per triangle before its grid (the mesh,
/// the vertex normals, the triangle lists).
const TG_BYTES_PER_VERTEX: u64 = 51;
const TG_BYTES_PER_TRIANGLE: u64 = 24;

/// One bake of a mesh file.
#[derive(Clone, Debug)]
pub struct BakeJob {
    /// The mesh.
    pub mesh: PathBuf,
    /// The output.
    pub out: PathBuf,
    /// Its format.
    pub format: BakeFormat,
    /// ρ and depth (`.tg`).
    pub grid: BakeOptions,
    /// Block size, log2 (`.tg`).
    pub block_log2: u8,
    /// Layout (`.tg`).
    pub layout: Layout,
    /// Bake in memory whatever the estimate (`--force`).
    pub force: bool,
    /// Bake out of core whatever the estimate (`--out-of-core`).
    pub out_of_core: bool,
    /// The budget, spill folder and progress of an out-of-core bake.
    pub ooc: OocOptions,
}

/// What a bake did.
pub struct BakeDone {
    /// The summary line (`pocketsplat bake` prints it).
    pub summary: String,
    /// Baked out of core.
    pub out_of_core: bool,
    /// Bytes written.
    pub bytes: u64,
    /// Wall time.
    pub time: Duration,
    /// The process's peak resident size at the end.
    pub peak_rss: Option<u64>,
}

/// Whether `job` bakes in memory: `--force`, or neither `--out-of-core` nor a need over the
/// budget by the header's counts (for `.tg` the caller checks the probe's estimate too).
fn in_memory_by_counts(job: &BakeJob, limits: &Limits) -> bool {
    if job.force {
        return true;
    }
    if job.out_of_core {
        return false;
    }
    // A file whose header cannot be read bakes in memory, which reports why.
    let Ok(c) = crate::ply::read_counts(&job.mesh, limits) else {
        return true;
    };
    let need = match job.format {
        BakeFormat::QSplat => c.vertices.saturating_mul(QS_BYTES_PER_VERTEX),
        BakeFormat::TriGrid => c
            .vertices
            .saturating_mul(TG_BYTES_PER_VERTEX)
            .saturating_add(c.faces.saturating_mul(TG_BYTES_PER_TRIANGLE)),
    };
    // Loading orients the triangles first (core `bake::orient`): the mesh and the orientation's
    // tables, freed before the bake starts.
    let orient = c.vertices.saturating_mul(24).saturating_add(
        c.faces
            .saturating_mul(12 + pocketsplat_core::bake::orient::ORIENT_BYTES_PER_TRIANGLE),
    );
    need.saturating_add(c.faces.saturating_mul(13)).max(orient) <= job.ooc.budget
}

/// Bakes `job` within `limits` (its `bake` is the budget unless `--force`).
///
/// # Errors
/// Mesh import or bake errors, naming the file; a budget or disk too small; nothing is left at
/// `job.out` then.
pub fn bake(job: &BakeJob, limits: &Limits) -> Result<BakeDone> {
    let t = Instant::now();
    let in_memory = in_memory_by_counts(job, limits);
    let (what, bytes, ooc) = match job.format {
        BakeFormat::QSplat => bake_qs_job(job, limits, in_memory)?,
        BakeFormat::TriGrid => bake_tg_job(job, limits, in_memory)?,
    };
    let time = t.elapsed();
    let peak = peak_rss();
    let out_of_core = ooc.is_some();
    let summary = format!(
        "{}: {what}; {:.2} s, peak RSS {}{}",
        job.out.display(),
        time.as_secs_f64(),
        peak.map_or("unknown".into(), human),
        ooc.map_or(String::new(), |o| format!(" ({o})"))
    );
    Ok(BakeDone {
        summary,
        out_of_core,
        bytes,
        time,
        peak_rss: peak,
    })
}

/// Out of core: `out of core, N pieces (largest M …): phases`.
fn ooc_note(
    pieces: usize,
    largest: u64,
    unit: &str,
    phases: &[(&'static str, Duration)],
) -> String {
    format!(
        "out of core within {{budget}}, {pieces} pieces (largest {largest} {unit}): {}",
        phase_times(phases)
    )
}

fn bake_qs_job(
    job: &BakeJob,
    limits: &Limits,
    in_memory: bool,
) -> Result<(String, u64, Option<String>)> {
    let opts = QsBakeOptions::default();
    let describe = |s: &pocketsplat_core::qs::write::QsStats, color: bool| {
        format!(
            "QSplat: {} leaves, {} interior nodes, depth {}, {} bytes ({:.2} per leaf, pointers {:.1} %{})",
            s.leaves,
            s.interior,
            s.depth,
            s.file_bytes,
            s.bytes_per_leaf(),
            100.0 * s.pointer_share(),
            if color { ", colour" } else { "" },
        )
    };
    if in_memory {
        let report = bake_qs_file(&job.mesh, &opts)?;
        write_atomic(&job.out, &report.baked.bytes)?;
        let s = report.baked.stats;
        return Ok((
            format!(
                "{}; loaded in {:.2} s, baked in {:.2} s{}",
                describe(&s, report.baked.color),
                report.load.as_secs_f64(),
                report.bake.as_secs_f64(),
                turned_note(report.orientation.flipped, false)
            ),
            s.file_bytes,
            None,
        ));
    }
    let done = super::ooc_qs::bake_qs(&job.mesh, &job.out, &opts, &job.ooc, limits)?;
    let note = ooc_note(done.pieces, done.largest_piece, "points", &done.phases)
        .replace("{budget}", &human(job.ooc.budget));
    Ok((
        format!(
            "{}{}",
            describe(&done.stats, done.color),
            turned_note(usize::from(done.turned), true)
        ),
        done.stats.file_bytes,
        Some(note),
    ))
}

fn bake_tg_job(
    job: &BakeJob,
    limits: &Limits,
    in_memory: bool,
) -> Result<(String, u64, Option<String>)> {
    let (rho, depth) = (job.grid.rho, job.grid.depth);
    let describe = |grid: &pocketsplat_core::bake::BakedGrid, bytes: usize| {
        let leaves = grid.levels.last().map_or(0, |l| l.attrs.len());
        let total: usize = grid.levels.iter().map(|l| l.attrs.len()).sum();
        format!("rho {rho}, depth {depth}: {total} samples ({leaves} leaves), {bytes} bytes")
    };
    if in_memory {
        let limit = if job.force { u64::MAX } else { job.ooc.budget };
        let (mesh, orientation) = crate::ply::load_mesh_oriented(&job.mesh, limits)?;
        let fits = job.force
            || estimate_bake(&mesh, job.grid)
                .with_context(|| format!("{}: cannot bake", job.mesh.display()))?
                .memory_bytes
                <= limit;
        if fits {
            let t = Instant::now();
            let (grid, mut bytes) =
                super::bake_mesh(&mesh, job.grid, job.block_log2, job.ooc.progress)
                    .with_context(|| format!("{}: cannot bake", job.mesh.display()))?;
            drop(mesh);
            if job.layout != Layout::Bricked {
                bytes = write_tg_as(&grid, job.block_log2, job.layout)?;
            }
            write_atomic(&job.out, &bytes)?;
            return Ok((
                format!(
                    "{}; baked in {:.2} s{}",
                    describe(&grid, bytes.len()),
                    t.elapsed().as_secs_f64(),
                    turned_note(orientation.flipped, false)
                ),
                bytes.len() as u64,
                None,
            ));
        }
    }
    let done = super::ooc_tg::bake_tg(&job.mesh, &job.out, job.grid, &job.ooc, limits)?;
    let t = Instant::now();
    let bytes = write_tg_as(&done.grid, job.block_log2, job.layout)?;
    write_atomic(&job.out, &bytes)?;
    let mut phases = done.phases.clone();
    phases.push(("writing", t.elapsed()));
    let note = ooc_note(done.pieces, done.largest_piece, "triangles", &phases)
        .replace("{budget}", &human(job.ooc.budget));
    Ok((
        format!(
            "{}{}",
            describe(&done.grid, bytes.len()),
            turned_note(usize::from(done.turned), true)
        ),
        bytes.len() as u64,
        Some(note),
    ))
}

/// The job of `pocketsplat bake MESH -o OUT` with the defaults: a tri-grid of ρ 3, depth 6.
pub fn job(mesh: &Path, out: &Path, format: BakeFormat, budget: u64) -> BakeJob {
    BakeJob {
        mesh: mesh.to_owned(),
        out: out.to_owned(),
        format,
        grid: BakeOptions::default(),
        block_log2: 12,
        layout: Layout::Bricked,
        force: false,
        out_of_core: false,
        ooc: OocOptions::within(budget),
    }
}
