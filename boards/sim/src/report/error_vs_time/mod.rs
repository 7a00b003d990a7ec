//! `pocketsplat report error-vs-time SUBJECT -o DIR`: image error against run time, for every way
//! the project can draw a subject.
//!
//! For each of the subject's named views the report sweeps the LOD cutoff, the methods (formats and
//! their renderers), the splat kernels and the shadow algorithms a method supports, and measures each
//! frame against the f64 reference renderer of the original meshes: PSNR, coverage mismatch and
//! holes ([`crate::metrics`]), host time per frame (median of repeats), nodes visited and splats
//! drawn, and, given `arm-bench --json` output ([`arm`]), ARM instructions per frame counted under
//! QEMU. It writes `results.csv` (one row per frame), `results.md` (the best PSNR each method
//! reaches within a time budget, the frames on ARM, then every row) and PNG plots of PSNR against
//! time on a log axis, one curve per method through its Pareto-optimal frames: one plot per view,
//! one for the mean over views (and one with the subject's own shadows), and one of PSNR against
//! ARM instructions.
//!
//! A subject is a list of named views, a reference render function and a list of [`Method`]s:
//! - a mesh ([`mesh_subject`]: tri-grid, octree, QSplat and brute force over the four standard
//!   views);
//! - a scene file ([`scene::scene_subject`]: the scene baked as a tri-grid pack and an octree pack
//!   over its named views, and the brute force over the tri-grid pack's leaves).
//!
//! Shadowed frames are compared with a reference that casts exact shadow rays (against the mesh, or
//! the scene's objects that cast shadows).
//!
//! The modules, one job each: `sweep` (subjects, methods, frame configurations, one measured frame),
//! `mesh` and [`scene`] (the two kinds of subject), [`brute`] (the brute force), `points` (Pareto
//! points, curves and the budget table), [`plot`] (the PNGs), `csv` (`results.csv` and reading it
//! back), `page` (`results.md`), [`arm`] (the `arm-bench` counts); this module runs them ([`run`]).

pub mod arm;
pub mod brute;
mod csv;
mod mesh;
mod page;
pub mod plot;
mod points;
pub mod scene;
mod sweep;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};

use crate::fsutil::write_atomic;
use page::markdown;
use points::{arm_millions, curves, mean_plot_name, mean_points, modes_plotted, Point};

pub use csv::{csv, parse_csv, CSV_HEADER};
pub use mesh::{mesh_subject, BruteMethod, MeshBakes, QsMethod, TgMethod};
pub use page::{ARM_NOT_MEASURED, BASELINE_METHOD};
pub use points::{ARM_PLOT, BUDGETS_MS};
pub use sweep::{
    measure, shadows_name, FrameConfig, Method, RefShadows, Reference, ReferenceFn, Row, Subject,
    Sweep, CUTOFFS_PX, QUICK_CUTOFFS_PX,
};

/// Tri-grid depth of the full sweep.
pub const DEPTH: u8 = 6;

/// Tri-grid depth of `--quick`.
pub const QUICK_DEPTH: u8 = 4;

/// Options of the command.
#[derive(Clone, Debug)]
pub struct Options {
    /// The reduced sweep for CI.
    pub quick: bool,
    /// A mesh's tri-grid depth (default [`DEPTH`], quick [`QUICK_DEPTH`]); for a scene, the
    /// deepest object (default the scene's depths, quick [`scene::QUICK_SCENE_DEPTH`]).
    pub depth: Option<u8>,
    /// Timed repeats (default 5, quick 1).
    pub repeats: Option<usize>,
    /// `arm-bench --json` outputs to read ARM instructions per frame from.
    pub arm: Vec<PathBuf>,
    /// The target whose counts are quoted (default [`arm::DEFAULT_TARGET`]).
    pub arm_target: Option<String>,
    /// Further targets whose counts in the `arm` files are listed beside the quoted one (the
    /// device build for a Cortex-M0+, `thumbv6m-none-eabi`).
    pub arm_also: Vec<String>,
    /// A `results.csv` of an earlier run of this report: its tri-grid frames are plotted as their
    /// own curve ([`BASELINE_METHOD`]) and compared frame by frame in `results.md`.
    pub baseline: Option<PathBuf>,
}

/// The files the report writes, by name.
pub struct Outputs {
    /// `(file name, bytes)`, written together at the end.
    pub files: Vec<(String, Vec<u8>)>,
}

/// The `report error-vs-time` command: measures `input` (a mesh or a scene file) and writes the
/// report into `out_dir`. Nothing is written unless every frame and plot was made.
///
/// # Errors
/// When the input cannot be read or baked, a frame fails, an ARM count file does not fit, or a
/// file cannot be written.
pub fn run(input: &Path, out_dir: &Path, opts: &Options) -> Result<Vec<PathBuf>> {
    if out_dir.exists() && !out_dir.is_dir() {
        bail!("{}: exists and is not a folder", out_dir.display());
    }
    let ext = input
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    if ext == "pack" {
        bail!(
            "{}: a pack holds baked grids, not the meshes the f64 reference is drawn from; give \
             the scene file (.toml) it was baked from",
            input.display()
        );
    }
    let is_scene = ext == "toml";
    let depth = opts.depth.or(match (opts.quick, is_scene) {
        (true, true) => Some(scene::QUICK_SCENE_DEPTH),
        (true, false) => Some(QUICK_DEPTH),
        (false, true) => None,
        (false, false) => Some(DEPTH),
    });
    if let Some(depth) = depth {
        if !(1..=pocketsplat_core::tg::MAX_DEPTH).contains(&depth) {
            bail!(
                "--depth {depth}: must be 1..={}",
                pocketsplat_core::tg::MAX_DEPTH
            );
        }
    }
    let repeats = opts.repeats.unwrap_or(if opts.quick { 1 } else { 5 });
    if repeats == 0 {
        bail!("--repeats 0: need at least one timed frame");
    }
    let mut sweep = if opts.quick {
        Sweep::quick(repeats)
    } else {
        Sweep::full(repeats)
    };
    if is_scene && !opts.quick {
        sweep.cutoffs = scene::SCENE_CUTOFFS_PX.to_vec();
    }
    let arm = if opts.arm.is_empty() {
        arm::ArmCounts::none()
    } else {
        arm::ArmCounts::load(
            &opts.arm,
            opts.arm_target.as_deref().unwrap_or(arm::DEFAULT_TARGET),
        )?
    };
    let also = opts
        .arm_also
        .iter()
        .map(|t| arm::ArmCounts::load_where_present(&opts.arm, t))
        .collect::<Result<Vec<_>>>()?;
    let name = input
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| input.display().to_string());
    let mut command = format!(
        "pocketsplat report error-vs-time {} -o {}",
        input.display(),
        out_dir.display()
    );
    if opts.quick {
        command.push_str(" --quick");
    }
    if let Some(d) = opts.depth {
        let _ = write!(command, " --depth {d}");
    }
    if let Some(r) = opts.repeats {
        let _ = write!(command, " --repeats {r}");
    }
    for a in &opts.arm {
        let _ = write!(command, " --arm {}", a.display());
    }
    if let Some(t) = &opts.arm_target {
        let _ = write!(command, " --arm-target {t}");
    }
    for t in &opts.arm_also {
        let _ = write!(command, " --arm-also {t}");
    }
    let baseline = match &opts.baseline {
        Some(path) => {
            let _ = write!(command, " --baseline {}", path.display());
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("--baseline {}: cannot read", path.display()))?;
            let rows =
                parse_csv(&text).with_context(|| format!("--baseline {}", path.display()))?;
            let rows: Vec<Row> = rows
                .into_iter()
                .filter(|r| r.method == "trigrid")
                .map(|r| Row {
                    method: BASELINE_METHOD.to_owned(),
                    ..r
                })
                .collect();
            if rows.is_empty() {
                bail!("--baseline {}: no tri-grid frames in it", path.display());
            }
            rows
        }
        None => Vec::new(),
    };
    let outputs = if is_scene {
        let bakes = scene::bake_scene_file(input, depth)?;
        let subject = scene::scene_subject(&name, &bakes)?;
        measure_and_write(subject, &sweep, (&arm, &also), &baseline, &command)?
    } else {
        let depth = depth.expect("a mesh's depth has a default");
        let mesh = crate::ply::load_mesh(input)?;
        let bakes =
            MeshBakes::bake(&mesh, depth).with_context(|| format!("{}: bake", input.display()))?;
        let subject = mesh_subject(&name, &mesh, &bakes)?;
        measure_and_write(subject, &sweep, (&arm, &also), &baseline, &command)?
    };
    std::fs::create_dir_all(out_dir)
        .with_context(|| format!("cannot create folder {}", out_dir.display()))?;
    let mut written = Vec::new();
    for (file, bytes) in &outputs.files {
        let path = out_dir.join(file);
        write_atomic(&path, bytes)?;
        written.push(path);
    }
    Ok(written)
}

/// Checks the ARM counts fit the subject's bakes, measures and makes every output.
fn measure_and_write(
    mut subject: Subject<'_>,
    sweep: &Sweep,
    (arm, also): (&arm::ArmCounts, &[arm::ArmCounts]),
    baseline: &[Row],
    command: &str,
) -> Result<Outputs> {
    let crcs: Vec<(String, u32)> = subject
        .methods
        .iter()
        .filter_map(|m| m.file_crc().map(|c| (m.name().to_owned(), c)))
        .collect();
    // arm-bench names a tri-grid's frames by the unbricked file the firmware links: the same
    // samples, the same frames as the bricked bake measured here.
    let flash: Vec<(u32, u32)> = subject
        .methods
        .iter()
        .filter_map(|m| Some((m.flash_crc()?, m.file_crc()?)))
        .collect();
    let arm = &arm.aliased(&flash);
    let also: &[arm::ArmCounts] = &also.iter().map(|a| a.aliased(&flash)).collect::<Vec<_>>();
    arm.check_models(&crcs)?;
    let rows = measure(&mut subject, sweep, arm, |line| {
        eprintln!("measuring {line}");
    })?;
    outputs(&subject, sweep, &rows, baseline, (arm, also), command)
}

/// Every output file, in memory.
///
/// # Errors
/// When a plot cannot be drawn.
pub fn outputs(
    subject: &Subject<'_>,
    sweep: &Sweep,
    measured: &[Row],
    baseline: &[Row],
    (arm, also): (&arm::ArmCounts, &[arm::ArmCounts]),
    command: &str,
) -> Result<Outputs> {
    let mut files = vec![("results.csv".to_owned(), csv(measured).into_bytes())];
    // The plots show the baseline's tri-grid beside this run's methods; results.csv has this run.
    let plotted: Vec<Row> = measured.iter().chain(baseline).cloned().collect();
    let rows = &plotted[..];
    let mut plots = Vec::new();
    let own = shadows_name(subject.shadows);
    for shadows in modes_plotted(subject) {
        let points = mean_points(rows, shadows, |r| Some(r.ms));
        plots.push((
            mean_plot_name(subject, shadows),
            plot::plot_png(
                &format!("{}: mean over views, shadows {shadows}", subject.name),
                plot::X_HOST_MS,
                &curves(&points),
            )?,
        ));
    }
    for (view, _) in &subject.views {
        let points: Vec<Point> = rows
            .iter()
            .filter(|r| &r.view == view && r.shadows == "off")
            .map(|r| Point::of(r, r.ms))
            .collect();
        plots.push((
            format!("psnr-vs-ms-{view}.png"),
            plot::plot_png(
                &format!("{}: view {view}, shadows off", subject.name),
                plot::X_HOST_MS,
                &curves(&points),
            )?,
        ));
    }
    let on_arm = mean_points(rows, own, arm_millions);
    if !on_arm.is_empty() {
        plots.push((
            ARM_PLOT.to_owned(),
            plot::plot_png(
                &format!(
                    "{}: mean over views, shadows {own}, {}",
                    subject.name,
                    arm.target()
                ),
                plot::X_ARM_MINSTR,
                &curves(&on_arm),
            )?,
        ));
    }
    files.push((
        "results.md".to_owned(),
        markdown(subject, sweep, measured, baseline, (arm, also), command).into_bytes(),
    ));
    files.extend(plots);
    Ok(Outputs { files })
}
