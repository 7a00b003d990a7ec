//! Baking a mesh file into a point file: in memory (mesh → ρ-grid (`.tg`), with a progress bar, or
//! mesh → QSplat bounding-sphere tree (`.qs`), and the estimate of what a bake will need before it
//! starts), or out of core within a memory budget ([`ooc_tg`], [`ooc_qs`]: the PLY streamed, the
//! mesh cut into pieces through spill files, the same bytes). `pocketsplat bake` chooses and
//! writes; reports, scenes and tests bake through these.
//!
//! In memory the importer has wound the mesh outward, patch by patch (`TriMesh::orient`); out of
//! core the edges are not all at hand, so a pass over the spilled faces decides for the mesh
//! whole (`Facing`) and every later pass reads them turned if it winds inward: the same bytes
//! for a file wound outward or inward throughout, not for one wound both ways.

pub mod budget;
pub mod ooc_qs;
pub mod ooc_tg;
pub mod progress;
pub mod run;
mod scan;
mod spill;

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::{bail, Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use pocketsplat_core::bake::{bake_grid, BakeOptions, BakedGrid, TriMesh};
use pocketsplat_core::qs::write::{bake_qs, BakedQs, QsBakeOptions};
use pocketsplat_core::tg::write::write_tg;

use crate::ply;

/// What a bake's summary says of the mesh's winding: nothing when the file wound it outward;
/// `whole`: an out-of-core bake, which turns the mesh whole or not at all.
pub fn turned_note(turned: usize, whole: bool) -> String {
    match (turned, whole) {
        (0, _) => String::new(),
        (_, true) => "; the mesh winds inward: read turned".to_owned(),
        (1, false) => "; 1 triangle turned to wind outward".to_owned(),
        (n, false) => format!("; {n} triangles turned to wind outward"),
    }
}

/// The point formats a mesh bakes into.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BakeFormat {
    /// A ρ-grid, `.tg` (`core/src/tg/FORMAT.md`).
    #[default]
    TriGrid,
    /// A QSplat bounding-sphere tree, `.qs` (`core/src/qs/FORMAT.md`).
    QSplat,
}

impl BakeFormat {
    /// Every format, in the order `--format` lists them.
    pub const ALL: [BakeFormat; 2] = [BakeFormat::TriGrid, BakeFormat::QSplat];

    /// The name `--format` takes: `tg` or `qsplat`.
    pub fn name(self) -> &'static str {
        match self {
            BakeFormat::TriGrid => "tg",
            BakeFormat::QSplat => "qsplat",
        }
    }

    /// The format called `name` ([`BakeFormat::name`], or `qs` for QSplat).
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "qs" => Some(BakeFormat::QSplat),
            _ => Self::ALL.into_iter().find(|f| f.name() == name),
        }
    }
}

/// How an out-of-core bake runs.
#[derive(Clone, Debug)]
pub struct OocOptions {
    /// Bytes of memory it may use (`--memory`).
    pub budget: u64,
    /// Where its spill folder goes (default: the output's folder).
    pub spill_dir: Option<PathBuf>,
    /// Largest piece, in triangles (`.tg`) or points (`.qs`), instead of what the budget allows
    /// (tests cut a small mesh into many pieces this way).
    pub piece_limit: Option<u64>,
    /// Draw progress bars (on a terminal).
    pub progress: bool,
}

impl OocOptions {
    /// Within `budget` bytes, spilling beside the output, pieces as large as the budget allows.
    pub fn within(budget: u64) -> Self {
        Self {
            budget,
            spill_dir: None,
            piece_limit: None,
            progress: false,
        }
    }

    /// The folder the spill folder is made in for output `out`.
    pub fn spill_parent(&self, out: &Path) -> PathBuf {
        self.spill_dir
            .clone()
            .unwrap_or_else(|| match out.parent() {
                Some(d) if !d.as_os_str().is_empty() => d.to_owned(),
                _ => PathBuf::from("."),
            })
    }
}

/// What a bake is expected to produce and to need, estimated before it starts.
///
/// A probe bakes the same mesh a few levels deep (at most about 10⁴ cells at its last level), then
/// the count of non-empty cells is extrapolated: once cells are smaller than the surface's
/// features a surface crosses about ρ² of the ρ³ children of each cell it crosses, so each level
/// has α ≈ ρ² times the cells of the one above (Duguet & Drettakis §4.3), and never more than
/// ρ³ᴸ. Memory counts the mesh and what the baker builds from it (vertex normals, triangle lists),
/// every level twice (children's levels are concatenated into their parent's), the normal cones
/// and the file: 5 to 25 % above the peak resident size measured on the bunny (ρ 2 to 5, depth 4
/// to 10) and the dragon (ρ 3, depth 6), up to 45 % above for bakes of a few tens of MB.
#[derive(Clone, Debug, PartialEq)]
pub struct BakeEstimate {
    /// Samples (non-empty cells) per level, 0..=depth; exact down to `probe_depth`.
    pub samples: Vec<u64>,
    /// Depth of the probe: levels below it are extrapolated.
    pub probe_depth: u8,
    /// Bytes of the `.tg` file.
    pub file_bytes: u64,
    /// Bytes of memory at the peak, the mesh included.
    pub memory_bytes: u64,
}

impl BakeEstimate {
    /// Samples in all levels.
    pub fn total_samples(&self) -> u64 {
        self.samples.iter().fold(0u64, |a, &n| a.saturating_add(n))
    }

    /// `Err` naming the estimate, the `bake` limit and the ways past it when the memory is over
    /// `limit`.
    ///
    /// # Errors
    /// When `memory_bytes > limit`.
    pub fn check(&self, limit: u64, depth: u8) -> Result<()> {
        if self.memory_bytes <= limit {
            return Ok(());
        }
        bail!(
            "depth {depth} would make about {} samples, a {} file, and need about {} of memory, \
             over the limit bake={} (bake less deep, or pass --force, or raise it with --limits \
             bake=SIZE)",
            approx(self.total_samples() as f64, ""),
            approx(self.file_bytes as f64, "B"),
            approx(self.memory_bytes as f64, "B"),
            crate::args::format_size(limit)
        )
    }
}

/// The program itself, its buffers and the probe bake.
const BASE_BYTES: f64 = 16.0 * 1024.0 * 1024.0;

/// `1.2 G` style: three significant figures and a 1024-power prefix.
fn approx(v: f64, unit: &str) -> String {
    let mut v = v;
    for prefix in ["", "K", "M", "G", "T", "P", "E"] {
        if v < 1024.0 {
            return format!("{v:.3} {prefix}{unit}").replace(".000 ", " ");
        }
        v /= 1024.0;
    }
    format!("{v:.0} Z{unit}")
}

/// Estimates a bake of `mesh` (see [`BakeEstimate`]).
///
/// # Errors
/// When the mesh is invalid.
///
/// # Panics
/// When `opts.rho` is outside 2..=5 or `opts.depth` above the format's maximum (as the baker).
pub fn estimate_bake(mesh: &TriMesh, opts: BakeOptions) -> Result<BakeEstimate> {
    let rho = f64::from(opts.rho);
    // Largest probe with at most ~10⁴ surface cells at its last level.
    let probe_depth = (0..=opts.depth)
        .take_while(|&k| rho.powi(2 * i32::from(k)) <= 1e4)
        .last()
        .unwrap_or(0);
    let probe = bake_grid(
        mesh,
        BakeOptions {
            rho: opts.rho,
            depth: probe_depth,
        },
        None,
    )?;
    let mut samples: Vec<f64> = probe.levels.iter().map(|l| l.attrs.len() as f64).collect();
    for level in probe_depth + 1..=opts.depth {
        let prev = samples.last().copied().unwrap_or(1.0);
        samples.push((prev * rho * rho).min(rho.powi(3 * i32::from(level))));
    }
    let colors = if mesh.colors.is_some() { 2.0 } else { 0.0 };
    let mask_file = match opts.rho {
        2 => 1.0,
        3 => 4.0,
        4 => 8.0,
        _ => 16.0,
    };
    let depth = usize::from(opts.depth);
    let (mut file, mut grid) = (0.0, 0.0);
    for (level, &n) in samples.iter().enumerate() {
        file += n * (2.0 + colors);
        grid += n * (2.0 + colors);
        if level < depth {
            file += n * mask_file;
            grid += n * 16.0;
        }
        if level + 1 < depth {
            file += n * 4.0;
        }
    }
    // Cones, block CRCs and padding: a tenth more.
    let file = file * 1.1 + 65536.0;
    let (v, t) = (mesh.positions.len() as f64, mesh.triangles.len() as f64);
    let mesh_bytes = v * (24.0 + 3.0) + t * (12.0 + 1.0);
    let baker = v * 24.0 + t * 4.0 + 2.0 * t * 4.0;
    // Normal cones (ρ = 3) are built per cell while the file is written: about 20 bytes a sample
    // at the peak, measured on the bunny at depths 6 and 7.
    let cones = if opts.rho == 3 { 20.0 } else { 0.0 } * samples.iter().sum::<f64>();
    let memory = mesh_bytes + baker + 2.0 * grid + file + cones + BASE_BYTES;
    let to_u64 = |x: f64| {
        if x >= u64::MAX as f64 {
            u64::MAX
        } else {
            x as u64
        }
    };
    Ok(BakeEstimate {
        samples: samples.into_iter().map(to_u64).collect(),
        probe_depth,
        file_bytes: to_u64(file),
        memory_bytes: to_u64(memory),
    })
}

/// The bake progress bar on stderr (drawn only when stderr is a terminal).
pub fn progress_bar(what: &str) -> ProgressBar {
    let bar = ProgressBar::new(1);
    bar.set_style(
        ProgressStyle::with_template(&format!(
            "{{spinner}} baking{what} {{bar:40}} {{pos}}/{{len}} cells ({{eta}} left)"
        ))
        .expect("static template")
        .progress_chars("=> "),
    );
    bar
}

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
    let bar = progress.then(|| progress_bar(""));
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
    bake_file_within(mesh_path, opts, block_log2, progress, u64::MAX)
}

/// [`bake_file`], refused before it starts when its [`estimate_bake`] of memory is over
/// `memory_limit` bytes.
///
/// # Errors
/// As [`bake_file`], and the estimate over the limit.
pub fn bake_file_within(
    mesh_path: &Path,
    opts: BakeOptions,
    block_log2: u8,
    progress: bool,
    memory_limit: u64,
) -> Result<BakeReport> {
    let t0 = Instant::now();
    let mesh = ply::load_mesh(mesh_path)?;
    let load = t0.elapsed();
    if memory_limit < u64::MAX {
        estimate_bake(&mesh, opts)
            .and_then(|e| e.check(memory_limit, opts.depth))
            .with_context(|| format!("{}: cannot bake", mesh_path.display()))?;
    }
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
    /// What orienting the mesh did as it was read.
    pub orientation: pocketsplat_core::bake::Orientation,
}

/// Loads `mesh_path` and bakes it into a `.qs` file in memory.
///
/// # Errors
/// Mesh import or bake errors, naming the file.
pub fn bake_qs_file(mesh_path: &Path, opts: &QsBakeOptions) -> Result<QsBakeReport> {
    let t0 = Instant::now();
    let (mesh, orientation) = ply::load_mesh_oriented(mesh_path, &crate::limits::current())?;
    let load = t0.elapsed();
    let t1 = Instant::now();
    let baked =
        bake_qs(&mesh, opts).with_context(|| format!("{}: cannot bake", mesh_path.display()))?;
    Ok(QsBakeReport {
        baked,
        load,
        bake: t1.elapsed(),
        orientation,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn format_names_round_trip() {
        for f in BakeFormat::ALL {
            assert_eq!(BakeFormat::from_name(f.name()), Some(f));
        }
        assert_eq!(BakeFormat::from_name("qs"), Some(BakeFormat::QSplat));
        assert_eq!(BakeFormat::from_name("zip"), None);
    }
}
