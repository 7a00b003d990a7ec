//! `pocketsplat report …`: the reports measured live ([`pocketsplat_sim::report`]).

use std::path::PathBuf;

use anyhow::Result;
use clap::Subcommand;
use pocketsplat_sim::args;
use pocketsplat_sim::render::DEFAULT_SHADOW_MAP_SIZE;
use pocketsplat_sim::report;

use super::default_models;

/// Which report.
#[derive(Debug, Subcommand)]
pub enum ReportKind {
    /// Extreme and stiff cases (cameras, scales, depths, shapes, lights, frame-rate control) against
    /// f64, each with pass/fail and its worst error; exits non-zero when a case fails. Run it in the
    /// dev profile (overflow checks on).
    Stability {
        /// Also write the page (e.g. docs/stability.md).
        #[arg(short, long)]
        out: Option<PathBuf>,
        /// Only these groups (repeatable): distance, inside, fov, axes, scale, depth, shapes, lights,
        /// lod.
        #[arg(long)]
        group: Vec<String>,
    },
    /// PSNR and coverage against the f64 reference, time and nodes per frame: standard views ×
    /// cutoffs 1, 2, 4, 8 px, tri-grid (depth 6) and octree (depth 9).
    Views {
        /// The mesh (default: the Stanford bunny in $POCKETSPLAT_MODELS or ../shared/models).
        #[arg(long)]
        mesh: Option<PathBuf>,
        /// Timed repeats per frame (the median is reported).
        #[arg(long, default_value_t = 5, value_parser = args::int::<usize>(1, 1000))]
        repeats: usize,
    },
    /// Error against run time: every view × cutoff (0.5–16 px) × method (tri-grid, octree, QSplat,
    /// brute force; a scene's tri-grid and octree packs) × kernel × shadows, measured against the
    /// f64 reference renderer. Writes DIR/results.csv, DIR/results.md and PNG plots of PSNR
    /// against time (and against ARM instructions, with --arm).
    ErrorVsTime {
        /// A mesh (PLY) or a scene file (.toml).
        scene: PathBuf,
        /// Output folder.
        #[arg(short, long)]
        out: PathBuf,
        /// The reduced sweep for CI: depth 4, cutoffs 1 and 4 px, one repeat.
        #[arg(long)]
        quick: bool,
        /// A mesh: tri-grid subdivisions (default 6, or 4 with --quick; the octree gets the
        /// nearest resolution). A scene: the deepest object (default the scene's, 4 with --quick).
        #[arg(long, value_parser = args::int::<u8>(0, u64::from(pocketsplat_core::tg::MAX_DEPTH)))]
        depth: Option<u8>,
        /// Timed repeats per frame, the median is reported (default 5, or 1 with --quick).
        #[arg(long, value_parser = args::int::<usize>(1, 1000))]
        repeats: Option<usize>,
        /// ARM instruction counts: a file `arm-bench --json` wrote (repeatable). Frames of the
        /// same baked file, view, cutoff, shadows and kernel get its count.
        #[arg(long, value_name = "FILE")]
        arm: Vec<PathBuf>,
        /// The target of the ARM counts quoted (default thumbv7m-none-eabi).
        #[arg(long, value_name = "TRIPLE")]
        arm_target: Option<String>,
        /// A further target whose counts in the --arm files are listed beside the quoted one
        /// (repeatable; e.g. thumbv6m-none-eabi, the Cortex-M0+ device build).
        #[arg(long, value_name = "TRIPLE")]
        arm_also: Vec<String>,
        /// A results.csv of an earlier run: its tri-grid frames drawn as their own curve and
        /// compared frame by frame with this run's.
        #[arg(long, value_name = "FILE")]
        baseline: Option<PathBuf>,
    },
    /// How bakes scale: generated scans of each size baked into .qs and .tg (a child process
    /// each, within --memory), wall time, peak RSS and output bytes as PREFIX.csv, PREFIX.md and
    /// PREFIX.png (scripts/bake-scale runs 1, 8, 32 and 100 M triangles).
    BakeScale {
        /// Output prefix, e.g. docs/bake-scale.
        #[arg(short, long)]
        out: PathBuf,
        /// Triangles of each mesh, comma-separated (K, M, G suffixes).
        #[arg(long, value_delimiter = ',', default_value = "1M,8M",
              value_parser = args::size::<u64>(48, 1 << 36))]
        sizes: Vec<u64>,
        /// Depth of the .tg bakes.
        #[arg(long, default_value_t = 7,
              value_parser = args::int::<u8>(1, u64::from(pocketsplat_core::tg::MAX_DEPTH)))]
        depth: u8,
        /// Where the meshes are generated and kept (several GB for 100 M triangles).
        #[arg(long, default_value = "bake-scale-work")]
        work: PathBuf,
        /// Only redraw PREFIX.md and PREFIX.png from PREFIX.csv.
        #[arg(long)]
        redraw: bool,
        /// Bake every size out of core, also those that fit in memory.
        #[arg(long)]
        out_of_core: bool,
    },
    /// The tri-grid paper's Tables 1, 3 and 4 side by side with ours, on the Stanford scans.
    Paper {
        /// Folder with the Stanford models (default: $POCKETSPLAT_MODELS or ../shared/models).
        #[arg(long)]
        models: Option<PathBuf>,
        /// Smaller bakes only (no dragon, no paper level 5).
        #[arg(long)]
        quick: bool,
    },
    /// Shadows against exact ray-cast shadows of the mesh: per standard view of the bunny and the
    /// dragon (tri-grid depth 6), off / two-pass / one-pass: lit/shadowed disagreement, PSNR and
    /// host time per frame. Prints a markdown table.
    Shadows {
        /// Folder with the Stanford models (default: $POCKETSPLAT_MODELS or ../shared/models).
        #[arg(long)]
        models: Option<PathBuf>,
        /// Timed repeats per frame (the median is reported).
        #[arg(long, default_value_t = 5, value_parser = args::int::<usize>(1, 1000))]
        repeats: usize,
        /// The bunny only, at depth 5 (a quick check, not the paper's level 5).
        #[arg(long)]
        quick: bool,
        /// Shadow-map side, texels.
        #[arg(long, default_value_t = DEFAULT_SHADOW_MAP_SIZE,
              value_parser = args::int::<usize>(
                  pocketsplat_core::scene::MIN_MAP_SIZE as u64,
                  pocketsplat_core::scene::MAX_MAP_SIZE as u64))]
        map: usize,
    },
}

impl ReportKind {
    /// The mesh, scene or folder of models the report measures, when it names one.
    pub fn subject(&self) -> Option<PathBuf> {
        match self {
            ReportKind::ErrorVsTime { scene, .. } => Some(scene.clone()),
            ReportKind::Views { mesh, .. } => mesh.clone(),
            ReportKind::Paper { models, .. } | ReportKind::Shadows { models, .. } => models.clone(),
            ReportKind::Stability { .. } | ReportKind::BakeScale { .. } => None,
        }
    }
}

/// The `report` command.
///
/// # Errors
/// The report's own errors; a stability case that fails.
pub fn run(which: ReportKind) -> Result<()> {
    match which {
        ReportKind::Stability { out, group } => report::stability::command(out.as_deref(), &group),
        ReportKind::ErrorVsTime {
            scene,
            out,
            quick,
            depth,
            repeats,
            arm,
            arm_target,
            arm_also,
            baseline,
        } => {
            let opts = report::error_vs_time::Options {
                quick,
                depth,
                repeats,
                arm,
                arm_target,
                arm_also,
                baseline,
            };
            for path in report::error_vs_time::run(&scene, &out, &opts)? {
                println!("{}", path.display());
            }
            Ok(())
        }
        ReportKind::BakeScale {
            out,
            sizes,
            depth,
            work,
            redraw,
            out_of_core,
        } => {
            let o = report::bake_scale::ScaleOptions {
                sizes,
                memory: pocketsplat_sim::limits::current().bake,
                depth,
                work,
                out,
                out_of_core,
            };
            let rows = if redraw {
                let rows = report::bake_scale::read_csv(&o.out.with_extension("csv"))?;
                report::bake_scale::write_page(&rows, &o)?;
                rows
            } else {
                report::bake_scale::run(&o, &std::env::current_exe()?)?
            };
            print!("{}", report::bake_scale::table(&rows, &o));
            Ok(())
        }
        ReportKind::Paper { models, quick } => {
            print!(
                "{}",
                report::paper::run(&models.unwrap_or_else(default_models), quick)?
            );
            Ok(())
        }
        ReportKind::Views { mesh, repeats } => {
            let mesh = mesh.unwrap_or_else(|| default_models().join("bun_zipper.ply.gz"));
            print!("{}", report::views::run(&mesh, repeats)?);
            Ok(())
        }
        ReportKind::Shadows {
            models,
            repeats,
            quick,
            map,
        } => {
            let models = models.unwrap_or_else(default_models);
            print!("{}", report::shadows::run(&models, repeats, quick, map)?);
            Ok(())
        }
    }
}
