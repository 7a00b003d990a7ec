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

pub mod arm;
pub mod brute;
pub mod plot;
pub mod scene;

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{bail, Context, Result};
use cpu_time::ThreadTime;
use pocketsplat_core::bake::{BakeOptions, TriMesh};
use pocketsplat_core::camera::{View, STANDARD_VIEWS};
use pocketsplat_core::qs::write::{bake_qs, QsBakeOptions};
use pocketsplat_core::qs::QSplat;
use pocketsplat_core::raster::Kernel;
use pocketsplat_core::shade::{rgb565_to_rgb888, ShadingTable};
use pocketsplat_core::tg::{TriGrid, Verify};

use crate::bake::bake_mesh;
use crate::bvh::Bvh;
use crate::fsutil::write_atomic;
use crate::metrics::{coverage_mismatch, psnr_rgb8};
use crate::qsplat::render_qs_with;
use crate::reference::{render_reference_shadowed, RefImage, ShadowLight, ShadowRays};
use crate::render::{render_tg_with, FrameBuffers, FrameReport, Settings, ShadowMode};
use crate::scene::bake::depth_near;

use brute::{kernel_name, LeafCloud};

/// Cutoffs of the full sweep, pixels.
pub const CUTOFFS_PX: [f32; 6] = [0.5, 1.0, 2.0, 4.0, 8.0, 16.0];
/// Cutoffs of `--quick`, pixels.
pub const QUICK_CUTOFFS_PX: [f32; 2] = [1.0, 4.0];
/// Tri-grid depth of the full sweep.
pub const DEPTH: u8 = 6;
/// Tri-grid depth of `--quick`.
pub const QUICK_DEPTH: u8 = 4;
/// Time budgets of the headline table, ms.
pub const BUDGETS_MS: [f64; 9] = [0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0];
/// Why the ARM column is empty.
pub const ARM_NOT_MEASURED: &str = "not measured in this run (pass `--arm FILE`, the output of \
     `cargo run --release -p pocketsplat-tests --bin arm-bench -- --json`)";

/// One frame configuration of a method.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameConfig {
    /// LOD cutoff, pixels (ignored by methods without one).
    pub cutoff_px: f32,
    /// Splat kernel.
    pub kernel: Kernel,
    /// Shadow algorithm.
    pub shadows: ShadowMode,
}

/// A way to draw a subject: a format and its renderer.
pub trait Method {
    /// Short name in tables and plots: `trigrid`, `octree`, `qsplat`, `brute`.
    fn name(&self) -> &str;
    /// What was baked, e.g. `ρ=3 depth 6, 1234567 leaves`.
    fn detail(&self) -> String;
    /// Whether the cutoff changes the frame (the brute force draws every leaf whatever it is).
    fn uses_cutoff(&self) -> bool;
    /// Whether it can draw these shadows.
    fn supports(&self, shadows: ShadowMode) -> bool;
    /// CRC-32 of the file it draws, when firmware can draw the same file (the key of its ARM
    /// counts, [`arm`]).
    fn file_crc(&self) -> Option<u32> {
        None
    }
    /// Renders `view` into `out` (cleared first), timing setup, traversal and raster.
    ///
    /// # Errors
    /// When the frame cannot be set up.
    fn render(
        &mut self,
        view: View,
        cfg: &FrameConfig,
        out: &mut FrameBuffers,
    ) -> Result<FrameReport>;
}

/// What a shadowed frame was compared with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RefShadows {
    /// The reference without shadows.
    None,
    /// Exact shadow rays against the mesh.
    RayCast,
}

impl RefShadows {
    fn name(self) -> &'static str {
        match self {
            RefShadows::None => "unshadowed",
            RefShadows::RayCast => "ray-cast",
        }
    }
}

/// A reference frame and how its shadows were made.
pub struct Reference {
    /// The f64 image.
    pub image: RefImage,
    /// Shadows in it.
    pub shadows: RefShadows,
}

/// The reference render function of a subject: `(view, with shadows)` → frame.
pub type ReferenceFn<'a> = Box<dyn Fn(View, bool) -> Result<Reference> + 'a>;

/// What the report sweeps over.
pub struct Subject<'a> {
    /// Name in titles (the file name of the mesh or scene).
    pub name: String,
    /// Named views.
    pub views: Vec<(String, View)>,
    /// The subject's own shadows (a scene's; off for a mesh): the mean plot and the budget table
    /// are also made for them when they are not off.
    pub shadows: ShadowMode,
    /// The ground truth.
    pub reference: ReferenceFn<'a>,
    /// The methods compared.
    pub methods: Vec<Box<dyn Method + 'a>>,
}

/// The sweep's axes other than views and methods.
#[derive(Clone, Debug, PartialEq)]
pub struct Sweep {
    /// Cutoffs, pixels.
    pub cutoffs: Vec<f32>,
    /// Kernels.
    pub kernels: Vec<Kernel>,
    /// Shadow algorithms (each method runs those it supports).
    pub shadows: Vec<ShadowMode>,
    /// Timed repeats per frame; the median is reported.
    pub repeats: usize,
}

impl Sweep {
    /// The full sweep: six cutoffs, both kernels, shadows off / one-pass / two-pass.
    pub fn full(repeats: usize) -> Self {
        Self {
            cutoffs: CUTOFFS_PX.to_vec(),
            kernels: vec![Kernel::Square, Kernel::Round],
            shadows: vec![ShadowMode::Off, ShadowMode::OnePass, ShadowMode::TwoPass],
            repeats,
        }
    }
    /// `--quick`: two cutoffs, everything else as [`Sweep::full`].
    pub fn quick(repeats: usize) -> Self {
        Self {
            cutoffs: QUICK_CUTOFFS_PX.to_vec(),
            ..Self::full(repeats)
        }
    }
}

/// One measured frame: a row of `results.csv`.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Row {
    /// Subject name.
    pub scene: String,
    /// View name.
    pub view: String,
    /// Method name.
    pub method: String,
    /// What was baked.
    pub detail: String,
    /// `square` or `round`.
    pub kernel: String,
    /// `off`, `one-pass` or `two-pass`.
    pub shadows: String,
    /// LOD cutoff, pixels; `None` for methods without one.
    pub cutoff_px: Option<f32>,
    /// PSNR against the reference, dB (8-bit RGB); infinite for an exact match.
    pub psnr_db: f64,
    /// Fraction of pixels covered by one image and not the other.
    pub coverage_mismatch: f64,
    /// Fraction of pixels the reference covers and the frame misses.
    pub holes: f64,
    /// Median host time per frame, ms: CPU time of the rendering thread (wall time where the
    /// thread's CPU clock is not available), so that other processes on the machine do not count.
    pub ms: f64,
    /// Median wall time per frame, ms, as the renderer measures it (setup, traversal, raster).
    pub wall_ms: f64,
    /// Nodes visited (points processed by the brute force).
    pub nodes_visited: u32,
    /// Splats drawn.
    pub splats: u32,
    /// ARM instructions per frame under QEMU, when measured.
    pub arm_instructions: Option<u64>,
    /// What shadowed frames were compared with (`unshadowed` or `ray-cast`); `-` without shadows.
    pub reference: String,
    /// The CRC-32 of the baked file the method drew (not in `results.csv`): what ARM counts of
    /// other targets are matched by (the "same frames on" section of `results.md`).
    #[serde(skip)]
    pub file_crc: Option<u32>,
}

/// Name of a shadow mode in the report.
pub fn shadows_name(s: ShadowMode) -> &'static str {
    match s {
        ShadowMode::Off => "off",
        ShadowMode::OnePass => "one-pass",
        ShadowMode::TwoPass => "two-pass",
    }
}

/// Median of durations (the upper one of an even count).
fn median(mut t: Vec<Duration>) -> Duration {
    t.sort();
    t[t.len() / 2]
}

/// Runs the sweep over every view of `subject`; `log` receives one line per view and method.
///
/// # Errors
/// When a reference or a frame cannot be made.
pub fn measure(
    subject: &mut Subject<'_>,
    sweep: &Sweep,
    arm: &arm::ArmCounts,
    mut log: impl FnMut(&str),
) -> Result<Vec<Row>> {
    let mut rows = Vec::new();
    let mut fb = FrameBuffers::new();
    for (view_name, view) in &subject.views {
        let plain = (subject.reference)(*view, false)
            .with_context(|| format!("reference of view {view_name}"))?;
        let mut shadowed: Option<Reference> = None;
        for method in &mut subject.methods {
            log(&format!("{view_name}: {}", method.name()));
            for &kernel in &sweep.kernels {
                for &shadows in &sweep.shadows {
                    if !method.supports(shadows) {
                        continue;
                    }
                    let cutoffs: Vec<Option<f32>> = if method.uses_cutoff() {
                        sweep.cutoffs.iter().copied().map(Some).collect()
                    } else {
                        vec![None]
                    };
                    for cutoff in cutoffs {
                        let cfg = FrameConfig {
                            cutoff_px: cutoff.unwrap_or(1.0),
                            kernel,
                            shadows,
                        };
                        let mut times = Vec::with_capacity(sweep.repeats.max(1));
                        let mut walls = Vec::with_capacity(sweep.repeats.max(1));
                        let mut stats = None;
                        for _ in 0..sweep.repeats.max(1) {
                            let cpu = ThreadTime::try_now().ok();
                            let r = method.render(*view, &cfg, &mut fb).with_context(|| {
                                format!("{} frame of view {view_name}", method.name())
                            })?;
                            times.push(cpu.and_then(|c| c.try_elapsed().ok()).unwrap_or(r.time));
                            walls.push(r.time);
                            stats = Some(r.stats);
                        }
                        let stats = stats.expect("at least one frame");
                        let reference = if shadows == ShadowMode::Off {
                            &plain
                        } else {
                            if shadowed.is_none() {
                                shadowed =
                                    Some((subject.reference)(*view, true).with_context(|| {
                                        format!("shadowed reference of view {view_name}")
                                    })?);
                            }
                            shadowed.as_ref().expect("just made")
                        };
                        let (psnr_db, coverage, holes) = compare(&reference.image, &fb);
                        rows.push(Row {
                            scene: subject.name.clone(),
                            view: view_name.clone(),
                            method: method.name().to_owned(),
                            detail: method.detail(),
                            kernel: kernel_name(kernel).to_owned(),
                            shadows: shadows_name(shadows).to_owned(),
                            cutoff_px: cutoff,
                            psnr_db,
                            coverage_mismatch: coverage,
                            holes,
                            ms: median(times).as_secs_f64() * 1e3,
                            wall_ms: median(walls).as_secs_f64() * 1e3,
                            nodes_visited: stats.nodes_visited,
                            splats: stats.splats,
                            arm_instructions: method.file_crc().and_then(|crc| {
                                arm.get(
                                    crc,
                                    view_name,
                                    cfg.cutoff_px,
                                    shadows_name(shadows),
                                    kernel_name(kernel),
                                )
                            }),
                            reference: if shadows == ShadowMode::Off {
                                "-".to_owned()
                            } else {
                                reference.shadows.name().to_owned()
                            },
                            file_crc: method.file_crc(),
                        });
                    }
                }
            }
        }
    }
    Ok(rows)
}

/// PSNR, coverage mismatch and holes of a frame against the reference.
fn compare(reference: &RefImage, frame: &FrameBuffers) -> (f64, f64, f64) {
    let rgb: Vec<[u8; 3]> = frame
        .pixels()
        .iter()
        .map(|&p| rgb565_to_rgb888(p))
        .collect();
    let covered = frame.covered();
    let holes = reference
        .covered
        .iter()
        .zip(&covered)
        .filter(|&(&r, &c)| r && !c)
        .count();
    (
        psnr_rgb8(&reference.to_rgb8(), &rgb),
        coverage_mismatch(&reference.covered, &covered),
        holes as f64 / covered.len() as f64,
    )
}

/// A tri-grid (any ρ the traversal draws) and its renderer, with a shading table kept across frames.
pub struct TgMethod<'a> {
    name: &'static str,
    grid: TriGrid<'a>,
    crc: u32,
    table: Box<ShadingTable<1>>,
}

impl<'a> TgMethod<'a> {
    /// Opens a baked file.
    ///
    /// # Errors
    /// When the bytes are not a valid `.tg` file.
    pub fn new(name: &'static str, bytes: &'a [u8]) -> Result<Self> {
        Ok(Self {
            name,
            grid: TriGrid::open(bytes, Verify::Structure)?,
            crc: pocketsplat_core::crc::crc32(bytes),
            table: Box::new(ShadingTable::new()),
        })
    }
}

impl Method for TgMethod<'_> {
    fn name(&self) -> &str {
        self.name
    }
    fn detail(&self) -> String {
        let h = self.grid.header();
        format!(
            "ρ={} depth {} ({} cells across), {} leaves, file CRC {:#010x}",
            h.rho,
            h.depth,
            u32::from(h.rho).pow(u32::from(h.depth)),
            self.grid.leaf_samples(),
            self.crc
        )
    }
    fn uses_cutoff(&self) -> bool {
        true
    }
    fn supports(&self, _: ShadowMode) -> bool {
        true
    }
    fn file_crc(&self) -> Option<u32> {
        Some(self.crc)
    }
    fn render(
        &mut self,
        view: View,
        cfg: &FrameConfig,
        out: &mut FrameBuffers,
    ) -> Result<FrameReport> {
        let settings = Settings {
            view,
            cutoff_px: cfg.cutoff_px,
            kernel: cfg.kernel,
            shadows: cfg.shadows,
            ..Settings::default()
        };
        render_tg_with(&self.grid, &settings, &mut self.table, out, |_, _| {})
    }
}

/// The brute-force baseline over a grid's leaves ([`brute`]).
pub struct BruteMethod {
    cloud: LeafCloud,
    detail: String,
    table: Box<ShadingTable<1>>,
}

impl BruteMethod {
    /// The leaves of `grid` as a point list.
    pub fn new(grid: &TriGrid<'_>) -> Self {
        let h = grid.header();
        let cloud = LeafCloud::from_grid(grid);
        Self {
            detail: format!(
                "every leaf of the ρ={} depth {} grid, {} points",
                h.rho,
                h.depth,
                cloud.len()
            ),
            cloud,
            table: Box::new(ShadingTable::new()),
        }
    }
}

impl Method for BruteMethod {
    fn name(&self) -> &str {
        "brute"
    }
    fn detail(&self) -> String {
        self.detail.clone()
    }
    fn uses_cutoff(&self) -> bool {
        false
    }
    fn supports(&self, shadows: ShadowMode) -> bool {
        shadows == ShadowMode::Off
    }
    fn render(
        &mut self,
        view: View,
        cfg: &FrameConfig,
        out: &mut FrameBuffers,
    ) -> Result<FrameReport> {
        let settings = Settings {
            view,
            kernel: cfg.kernel,
            ..Settings::default()
        };
        Ok(self.cloud.render(&settings, &mut self.table, out))
    }
}

/// A QSplat bounding-sphere tree and its renderer (no shadows: the `.qs` renderer has none).
pub struct QsMethod<'a> {
    file: QSplat<'a>,
    crc: u32,
    table: Box<ShadingTable<1>>,
}

impl<'a> QsMethod<'a> {
    /// Opens a baked `.qs` file.
    ///
    /// # Errors
    /// When the bytes are not a valid `.qs` file.
    pub fn new(bytes: &'a [u8]) -> Result<Self> {
        Ok(Self {
            file: QSplat::open(bytes).map_err(|e| anyhow::anyhow!("baked .qs file: {e}"))?,
            crc: pocketsplat_core::crc::crc32(bytes),
            table: Box::new(ShadingTable::new()),
        })
    }
}

impl Method for QsMethod<'_> {
    fn name(&self) -> &str {
        "qsplat"
    }
    fn detail(&self) -> String {
        let c = self.file.counts();
        format!(
            "QSplat tree of the mesh's vertices, {} leaves, depth {}, file CRC {:#010x}",
            c.leaves, c.max_depth, self.crc
        )
    }
    fn uses_cutoff(&self) -> bool {
        true
    }
    fn supports(&self, shadows: ShadowMode) -> bool {
        shadows == ShadowMode::Off
    }
    fn file_crc(&self) -> Option<u32> {
        Some(self.crc)
    }
    fn render(
        &mut self,
        view: View,
        cfg: &FrameConfig,
        out: &mut FrameBuffers,
    ) -> Result<FrameReport> {
        let settings = Settings {
            view,
            cutoff_px: cfg.cutoff_px,
            kernel: cfg.kernel,
            ..Settings::default()
        };
        render_qs_with(&self.file, &settings, &mut self.table, out, |_, _| {})
    }
}

/// Baked files of a mesh subject, owned here so the methods can borrow them.
pub struct MeshBakes {
    /// Tri-grid (ρ = 3) file.
    pub trigrid: Vec<u8>,
    /// Octree (ρ = 2) file at the nearest resolution.
    pub octree: Vec<u8>,
    /// QSplat file (one leaf per vertex, whatever the depth).
    pub qsplat: Vec<u8>,
    /// The mesh's hierarchy, for the reference's shadow rays.
    pub bvh: Bvh,
}

impl MeshBakes {
    /// Bakes `mesh` as a tri-grid of `depth`, an octree of the nearest resolution and a QSplat
    /// tree.
    ///
    /// # Errors
    /// When a bake fails.
    pub fn bake(mesh: &TriMesh, depth: u8) -> Result<Self> {
        let bake = |rho: u8, depth: u8| -> Result<Vec<u8>> {
            Ok(bake_mesh(mesh, BakeOptions { rho, depth }, 12, false)
                .with_context(|| format!("cannot bake ρ={rho} depth {depth}"))?
                .1)
        };
        Ok(Self {
            trigrid: bake(3, depth)?,
            octree: bake(2, depth_near(3, depth, 2))?,
            qsplat: bake_qs(mesh, &QsBakeOptions::default())
                .map_err(|e| anyhow::anyhow!("cannot bake QSplat: {e}"))?
                .bytes,
            bvh: Bvh::new(mesh),
        })
    }
}

/// A mesh as a subject: its four standard views, the reference renderer of the mesh, and the
/// tri-grid, octree, QSplat and brute-force methods over `bakes`.
///
/// # Errors
/// When a baked file does not open.
pub fn mesh_subject<'a>(
    name: &str,
    mesh: &'a TriMesh,
    bakes: &'a MeshBakes,
) -> Result<Subject<'a>> {
    let trigrid = TgMethod::new("trigrid", &bakes.trigrid)?;
    let brute = BruteMethod::new(&trigrid.grid);
    let octree = TgMethod::new("octree", &bakes.octree)?;
    let qsplat = QsMethod::new(&bakes.qsplat)?;
    Ok(Subject {
        name: name.to_owned(),
        views: STANDARD_VIEWS
            .iter()
            .map(|&(n, v)| (n.to_owned(), v))
            .collect(),
        shadows: ShadowMode::Off,
        reference: Box::new(move |view, with_shadows| {
            let s = Settings {
                view,
                ..Settings::default()
            };
            let light = s.light_dir();
            let rays = ShadowRays {
                bvh: &bakes.bvh,
                light: ShadowLight::Directional(light),
            };
            let image = render_reference_shadowed(
                mesh,
                &s.camera(mesh.bounds_f32()),
                &[s.material],
                light,
                with_shadows.then_some(&rays),
            );
            Ok(Reference {
                image,
                shadows: if with_shadows {
                    RefShadows::RayCast
                } else {
                    RefShadows::None
                },
            })
        }),
        methods: vec![
            Box::new(trigrid),
            Box::new(octree),
            Box::new(qsplat),
            Box::new(brute),
        ],
    })
}

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

/// The method name of a baseline run's tri-grid frames on the plots.
pub const BASELINE_METHOD: &str = "trigrid (baseline)";

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

/// The PSNR-against-ARM-instructions plot's file name.
pub const ARM_PLOT: &str = "psnr-vs-arm.png";

/// ARM instructions of a row, millions.
fn arm_millions(r: &Row) -> Option<f64> {
    r.arm_instructions.map(|n| n as f64 / 1e6)
}

/// The shadow modes the mean plot and the budget table are made for: off, and the subject's own.
fn modes_plotted(subject: &Subject<'_>) -> Vec<&'static str> {
    let mut m = vec!["off"];
    if subject.shadows != ShadowMode::Off {
        m.push(shadows_name(subject.shadows));
    }
    m
}

/// `psnr-vs-ms.png` (shadows off), `psnr-vs-ms-one-pass.png`, …
fn mean_plot_name(subject: &Subject<'_>, shadows: &str) -> String {
    if shadows == "off" || subject.shadows == ShadowMode::Off {
        "psnr-vs-ms.png".to_owned()
    } else {
        format!("psnr-vs-ms-{shadows}.png")
    }
}

/// A frame configuration on a plot: method, kernel, cutoff, time and PSNR.
#[derive(Clone, Debug, PartialEq)]
struct Point {
    method: String,
    kernel: String,
    cutoff_px: Option<f32>,
    ms: f64,
    psnr_db: f64,
}

impl Point {
    fn of(r: &Row, x: f64) -> Self {
        Self {
            method: r.method.clone(),
            kernel: r.kernel.clone(),
            cutoff_px: r.cutoff_px,
            ms: x,
            psnr_db: r.psnr_db,
        }
    }
    fn label(&self) -> String {
        match self.cutoff_px {
            Some(c) => format!("{c} px, {}", self.kernel),
            None => self.kernel.clone(),
        }
    }
}

/// The configurations with `shadows` averaged over the views that have them all, with an `x` for
/// each: mean `x` (host time, ARM instructions, …), mean PSNR. Rows without an `x` are left out.
fn mean_points(rows: &[Row], shadows: &str, x: impl Fn(&Row) -> Option<f64>) -> Vec<Point> {
    let views: std::collections::BTreeSet<&str> = rows.iter().map(|r| r.view.as_str()).collect();
    // (method, kernel, cutoff) → the rows of each view with their x.
    type Group<'r> = Vec<(&'r Row, f64)>;
    let mut groups: BTreeMap<(String, String, String), Group<'_>> = BTreeMap::new();
    for r in rows.iter().filter(|r| r.shadows == shadows) {
        let Some(v) = x(r) else { continue };
        let cutoff = r.cutoff_px.map(|c| c.to_string()).unwrap_or_default();
        groups
            .entry((r.method.clone(), r.kernel.clone(), cutoff))
            .or_default()
            .push((r, v));
    }
    let mut out: Vec<Point> = groups
        .into_values()
        .filter(|g| g.len() == views.len())
        .map(|g| {
            let n = g.len() as f64;
            Point {
                ms: g.iter().map(|(_, v)| v).sum::<f64>() / n,
                psnr_db: g.iter().map(|(r, _)| r.psnr_db).sum::<f64>() / n,
                ..Point::of(g[0].0, 0.0)
            }
        })
        .collect();
    out.sort_by(|a, b| a.method.cmp(&b.method).then(a.ms.total_cmp(&b.ms)));
    out
}

/// Method names in a fixed order (the plots' colours), then any others.
const METHOD_ORDER: [&str; 4] = ["trigrid", "octree", "qsplat", "brute"];

fn method_order(points: &[Point]) -> Vec<String> {
    let mut names: Vec<String> = METHOD_ORDER
        .iter()
        .filter(|m| points.iter().any(|p| p.method == **m))
        .map(|m| (*m).to_owned())
        .collect();
    for p in points {
        if !names.contains(&p.method) {
            names.push(p.method.clone());
        }
    }
    names
}

fn curves(points: &[Point]) -> Vec<plot::Curve> {
    method_order(points)
        .into_iter()
        .map(|m| plot::Curve {
            points: points
                .iter()
                .filter(|p| p.method == m && p.psnr_db.is_finite() && p.ms > 0.0)
                .map(|p| (p.ms, p.psnr_db))
                .collect(),
            label: m,
        })
        .collect()
}

/// The best point of each method within each budget.
fn budget_table(points: &[Point]) -> String {
    let mut out = String::from("| method |");
    for b in BUDGETS_MS {
        let _ = write!(out, " ≤ {b} ms |");
    }
    out.push_str("\n|---|");
    out.push_str(&"---|".repeat(BUDGETS_MS.len()));
    out.push('\n');
    for m in method_order(points) {
        let _ = write!(out, "| {m} |");
        let mut previous = None;
        for b in BUDGETS_MS {
            let best = points
                .iter()
                .filter(|p| p.method == m && p.ms <= b)
                // The best PSNR; of equals, the fastest.
                .max_by(|a, b| a.psnr_db.total_cmp(&b.psnr_db).then(b.ms.total_cmp(&a.ms)));
            match best {
                // The same frame as in the budget before: say so briefly.
                Some(p) if previous == Some(p) => out.push_str(" 〃 |"),
                Some(p) => {
                    let _ = write!(
                        out,
                        " **{:.2}** dB ({}, {:.2} ms) |",
                        p.psnr_db,
                        p.label(),
                        p.ms
                    );
                }
                None => out.push_str(" — |"),
            }
            previous = best;
        }
        out.push('\n');
    }
    out
}

/// `results.csv`: a header and one line per row; fields never contain commas or quotes except
/// `detail`, which is quoted.
pub fn csv(rows: &[Row]) -> String {
    let mut out = String::from(CSV_HEADER);
    out.push('\n');
    for r in rows {
        let _ = writeln!(
            out,
            "{},{},{},\"{}\",{},{},{},{:.4},{:.6},{:.6},{:.4},{:.4},{},{},{},{}",
            r.scene,
            r.view,
            r.method,
            r.detail.replace('"', "'"),
            r.kernel,
            r.shadows,
            r.cutoff_px.map(|c| c.to_string()).unwrap_or_default(),
            r.psnr_db,
            r.coverage_mismatch,
            r.holes,
            r.ms,
            r.wall_ms,
            r.nodes_visited,
            r.splats,
            r.arm_instructions
                .map(|n| n.to_string())
                .unwrap_or_default(),
            r.reference
        );
    }
    out
}

/// The columns of `results.csv`.
pub const CSV_HEADER: &str = "scene,view,method,detail,kernel,shadows,cutoff_px,psnr_db,\
     coverage_mismatch,holes,ms,wall_ms,nodes_visited,splats,arm_instructions,reference";

/// The machine's load when the report was made (Linux), for reading the times.
fn load_note() -> String {
    let cores = std::thread::available_parallelism().map_or(0, |n| n.get());
    match std::fs::read_to_string("/proc/loadavg") {
        Ok(l) => format!(
            "{cores} cores, load average {} at the end of the run",
            l.split_whitespace().take(3).collect::<Vec<_>>().join(" ")
        ),
        Err(_) => format!("{cores} cores"),
    }
}

/// `results.md`.
fn markdown(
    subject: &Subject<'_>,
    sweep: &Sweep,
    rows: &[Row],
    baseline: &[Row],
    (arm, also): (&arm::ArmCounts, &[arm::ArmCounts]),
    command: &str,
) -> String {
    let mut md = format!("# Error against run time: {}\n\n", subject.name);
    let _ = writeln!(
        md,
        "Made by `{command}`. Every frame is 240 × 320 and compared with the f64 reference \
         renderer of the original meshes: PSNR over 8-bit RGB, coverage mismatch (pixels covered \
         by one image only) and holes (covered by the reference only). Time is the host's \
         CPU time of the rendering thread for setup + traversal + raster, the median of {} \
         repeat{} ({}; wall times are in `results.csv`); nodes are the cells visited (points \
         processed, for the brute force).\n",
        sweep.repeats,
        if sweep.repeats == 1 { "" } else { "s" },
        load_note()
    );
    md.push_str("| method | what |\n|---|---|\n");
    let mut seen = Vec::new();
    for r in rows {
        if !seen.contains(&&r.method) {
            seen.push(&r.method);
            let _ = writeln!(md, "| {} | {} |", r.method, r.detail);
        }
    }
    let shadow_ref = rows
        .iter()
        .find(|r| r.shadows != "off")
        .map(|r| r.reference.as_str());
    md.push('\n');
    match shadow_ref {
        Some("unshadowed") => md.push_str(
            "Shadowed frames are compared with the **unshadowed** reference (the reference \
             renderer casts no shadow rays for this subject), so their PSNR also counts the \
             shadows themselves as error.\n",
        ),
        Some(r) => {
            let _ = writeln!(md, "Shadowed frames are compared with the {r} reference.");
        }
        None => {}
    }
    if arm.is_empty() {
        let _ = writeln!(md, "ARM instructions per frame: {ARM_NOT_MEASURED}.\n");
    } else {
        let files: Vec<String> = arm.files().iter().map(|f| arm::file_name(f)).collect();
        let _ = writeln!(
            md,
            "ARM instructions per frame ({}, counted exactly under QEMU by `arm-bench --json`, \
             read from {}) are given for the frames the firmware draws, with square splats, \
             where the firmware was built with the same baked file (its CRC-32): see \
             [On ARM](#on-arm).\n",
            arm.target(),
            files.join(", ")
        );
    }
    for shadows in modes_plotted(subject) {
        let _ = writeln!(
            md,
            "## Best PSNR within a time budget, shadows {shadows}\n\nMean over the views: for \
             each method the best mean PSNR among its configurations (cutoff, kernel) whose mean \
             time fits the budget; 〃 is the same frame as in the smaller budget.\n"
        );
        md.push_str(&budget_table(&mean_points(rows, shadows, |r| Some(r.ms))));
        let _ = writeln!(
            md,
            "\n![PSNR against time, mean over views, shadows {shadows}]({})\n",
            mean_plot_name(subject, shadows)
        );
    }
    if !arm.is_empty() {
        md.push_str(&arm_section(subject, rows));
        for other in also {
            md.push_str(&other_target_section(subject, rows, other));
        }
    }
    if !baseline.is_empty() {
        md.push_str(&baseline_section(rows, baseline));
    }
    for (view, _) in &subject.views {
        let _ = writeln!(md, "\n## View `{view}`\n");
        let points: Vec<Point> = rows
            .iter()
            .filter(|r| &r.view == view && r.shadows == "off")
            .map(|r| Point::of(r, r.ms))
            .collect();
        md.push_str(&budget_table(&points));
        let _ = writeln!(
            md,
            "\n![PSNR against time, view {view}](psnr-vs-ms-{view}.png)\n"
        );
        md.push_str(
            "| method | kernel | shadows | cutoff px | PSNR dB | coverage mismatch | holes | \
             ms/frame | nodes | splats | ARM instructions |\n\
             |---|---|---|---|---|---|---|---|---|---|---|\n",
        );
        for r in rows.iter().filter(|r| &r.view == view) {
            let _ = writeln!(
                md,
                "| {} | {} | {} | {} | {:.2} | {:.2}% | {:.3}% | {:.2} | {} | {} | {} |",
                r.method,
                r.kernel,
                r.shadows,
                r.cutoff_px.map_or("—".to_owned(), |c| c.to_string()),
                r.psnr_db,
                100.0 * r.coverage_mismatch,
                100.0 * r.holes,
                r.ms,
                r.nodes_visited,
                r.splats,
                r.arm_instructions
                    .map_or("not measured".to_owned(), |n| n.to_string()),
            );
        }
    }
    md
}

/// `## On ARM`: the frames with an instruction count, in the subject's own shadows, per view: cost,
/// frames per second at 200 MHz, PSNR and its loss against the same method's 1 px frame, and the
/// The frames of `rows` that have a count for `other` (a second target, as `arm-bench` ran it on
/// the same baked file), beside the quoted target's count.
fn other_target_section(subject: &Subject<'_>, rows: &[Row], other: &arm::ArmCounts) -> String {
    let own = shadows_name(subject.shadows);
    let mut md = format!(
        "\n### The same frames on {}\n\nShadows {own}, square splats: instructions per frame \
         on {} beside the quoted target's.\n\n| view | method | cutoff px | PSNR dB | {} | \
         quoted target | fps at 200 MHz |\n|---|---|---|---|---|---|---|\n",
        other.target(),
        other.target(),
        other.target()
    );
    for r in rows
        .iter()
        .filter(|r| r.shadows == own && r.kernel == "square")
    {
        let (Some(crc), Some(cutoff)) = (r.file_crc, r.cutoff_px) else {
            continue;
        };
        let Some(n) = other.get(crc, &r.view, cutoff, own, &r.kernel) else {
            continue;
        };
        let _ = writeln!(
            md,
            "| {} | {} | {cutoff} | {:.2} | {:.2} M | {} | {:.2} |",
            r.view,
            r.method,
            r.psnr_db,
            n as f64 / 1e6,
            r.arm_instructions
                .map_or("—".to_owned(), |q| format!("{:.2} M", q as f64 / 1e6)),
            200e6 / n as f64
        );
    }
    md
}

/// The tri-grid frames of this run beside the baseline's with the same view, shadows, kernel and
/// cutoff: PSNR, nodes and ARM instructions, before and after.
fn baseline_section(rows: &[Row], baseline: &[Row]) -> String {
    let mut md = format!(
        "\n## Against the baseline\n\nThe tri-grid frames of this run beside those of the \
         baseline run (`--baseline`; `{BASELINE_METHOD}` on the plots), square splats.\n\n\
         | view | shadows | cutoff px | PSNR dB before | after | nodes before | after | ARM \
         instructions before | after |\n|---|---|---|---|---|---|---|---|---|\n"
    );
    let m = |n: Option<u64>| n.map_or("—".to_owned(), |n| format!("{:.2} M", n as f64 / 1e6));
    for r in rows
        .iter()
        .filter(|r| r.method == "trigrid" && r.kernel == "square")
    {
        let Some(b) = baseline.iter().find(|b| {
            b.view == r.view
                && b.shadows == r.shadows
                && b.kernel == r.kernel
                && b.cutoff_px == r.cutoff_px
        }) else {
            continue;
        };
        let _ = writeln!(
            md,
            "| {} | {} | {} | {:.2} | {:.2} | {} | {} | {} | {} |",
            r.view,
            r.shadows,
            r.cutoff_px.map_or("—".to_owned(), |c| c.to_string()),
            b.psnr_db,
            r.psnr_db,
            b.nodes_visited,
            r.nodes_visited,
            m(b.arm_instructions),
            m(r.arm_instructions)
        );
    }
    md
}

/// The rows of a `results.csv` this report wrote ([`csv`]), read back.
///
/// # Errors
/// When the header is not [`CSV_HEADER`] or a line does not parse.
pub fn parse_csv(text: &str) -> Result<Vec<Row>> {
    let mut lines = text.lines();
    if lines.next() != Some(CSV_HEADER) {
        bail!("not a results.csv of this report (its first line is not `{CSV_HEADER}`)");
    }
    lines
        .enumerate()
        .filter(|(_, l)| !l.is_empty())
        .map(|(i, l)| parse_csv_line(l).with_context(|| format!("line {}", i + 2)))
        .collect()
}

/// One line of `results.csv`: 16 fields, of which only `detail` is quoted.
fn parse_csv_line(line: &str) -> Result<Row> {
    let mut fields = Vec::with_capacity(16);
    let (mut field, mut quoted) = (String::new(), false);
    for c in line.chars() {
        match c {
            '"' => quoted = !quoted,
            ',' if !quoted => fields.push(std::mem::take(&mut field)),
            c => field.push(c),
        }
    }
    fields.push(field);
    if fields.len() != 16 || quoted {
        bail!("{} fields, want 16", fields.len());
    }
    let num = |i: usize| -> Result<f64> {
        fields[i]
            .parse()
            .with_context(|| format!("field {}: `{}` is not a number", i + 1, fields[i]))
    };
    let opt = |i: usize| -> Result<Option<u64>> {
        if fields[i].is_empty() {
            Ok(None)
        } else {
            Ok(Some(fields[i].parse().with_context(|| {
                format!("field {}: `{}` is not a count", i + 1, fields[i])
            })?))
        }
    };
    Ok(Row {
        scene: fields[0].clone(),
        view: fields[1].clone(),
        method: fields[2].clone(),
        detail: fields[3].clone(),
        kernel: fields[4].clone(),
        shadows: fields[5].clone(),
        cutoff_px: if fields[6].is_empty() {
            None
        } else {
            Some(num(6)? as f32)
        },
        psnr_db: num(7)?,
        coverage_mismatch: num(8)?,
        holes: num(9)?,
        ms: num(10)?,
        wall_ms: num(11)?,
        nodes_visited: opt(12)?.unwrap_or(0) as u32,
        splats: opt(13)?.unwrap_or(0) as u32,
        arm_instructions: opt(14)?,
        reference: fields[15].clone(),
        file_crc: None,
    })
}

/// cheapest frame within 1 dB of 1 px.
fn arm_section(subject: &Subject<'_>, rows: &[Row]) -> String {
    let own = shadows_name(subject.shadows);
    let mut md = format!(
        "## On ARM\n\nShadows {own}. Frames per second assume one instruction per cycle at \
         200 MHz; Δ is the PSNR lost against the same method's frame at 1 px.\n\n\
         ![PSNR against ARM instructions per frame, mean over views]({ARM_PLOT})\n\n\
         | view | method | cutoff px | PSNR dB | Δ dB | ARM instructions | fps at 200 MHz | host \
         ms |\n|---|---|---|---|---|---|---|---|\n"
    );
    let mut cheapest = String::new();
    for (view, _) in &subject.views {
        let mut on: Vec<&Row> = rows
            .iter()
            .filter(|r| &r.view == view && r.shadows == own && r.arm_instructions.is_some())
            .collect();
        on.sort_by(|a, b| {
            a.method.cmp(&b.method).then(
                a.cutoff_px
                    .unwrap_or(0.0)
                    .total_cmp(&b.cutoff_px.unwrap_or(0.0)),
            )
        });
        for r in &on {
            let fine = on
                .iter()
                .find(|f| f.method == r.method && f.cutoff_px == Some(1.0));
            let n = r.arm_instructions.expect("filtered");
            let _ = writeln!(
                md,
                "| {view} | {} | {} | {:.2} | {} | {:.1} M | {:.2} | {:.2} |",
                r.method,
                r.cutoff_px.map_or("—".to_owned(), |c| c.to_string()),
                r.psnr_db,
                fine.map_or("—".to_owned(), |f| format!(
                    "{:.2}",
                    f.psnr_db - r.psnr_db
                )),
                n as f64 / 1e6,
                200e6 / n as f64,
                r.ms
            );
        }
        let mut methods: Vec<&str> = on.iter().map(|r| r.method.as_str()).collect();
        methods.dedup();
        for m in methods {
            let Some(fine) = on
                .iter()
                .find(|f| f.method == m && f.cutoff_px == Some(1.0))
            else {
                continue;
            };
            if let Some(best) = on
                .iter()
                .filter(|r| r.method == m && r.psnr_db >= fine.psnr_db - 1.0)
                .min_by_key(|r| r.arm_instructions)
            {
                let _ = writeln!(
                    cheapest,
                    "- `{view}`, {m}: {} px, {:.1} M instructions ({:.2} dB; 1 px: {:.1} M, \
                     {:.2} dB)",
                    best.cutoff_px.unwrap_or(1.0),
                    best.arm_instructions.expect("filtered") as f64 / 1e6,
                    best.psnr_db,
                    fine.arm_instructions.expect("filtered") as f64 / 1e6,
                    fine.psnr_db
                );
            }
        }
    }
    if !cheapest.is_empty() {
        md.push_str("\nThe cheapest frame on ARM within 1 dB of the 1 px frame:\n\n");
        md.push_str(&cheapest);
    }
    md.push('\n');
    md
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_octree_nearest_a_depth_6_trigrid_is_depth_9() {
        // 3⁶ = 729 cells: 2⁹ = 512 is 217 away, 2¹⁰ = 1024 is 295.
        assert_eq!(depth_near(3, 6, 2), 9);
        assert_eq!(depth_near(3, 4, 2), 6); // 81: 64 vs 128
        assert_eq!(depth_near(2, 7, 2), 7);
        assert_eq!(depth_near(2, 9, 3), 6); // 512: 729 vs 243
    }

    fn point(method: &str, ms: f64, psnr_db: f64) -> Point {
        Point {
            method: method.into(),
            kernel: "square".into(),
            cutoff_px: Some(1.0),
            ms,
            psnr_db,
        }
    }

    #[test]
    fn a_budget_takes_the_best_frame_that_fits() {
        let pts = [
            point("trigrid", 0.8, 20.0),
            point("trigrid", 3.0, 25.0),
            point("trigrid", 4.0, 24.0),
            point("brute", 30.0, 26.0),
            point("brute", 60.0, 26.0),
        ];
        let t = budget_table(&pts);
        let line = |m: &str| {
            t.lines()
                .find(|l| l.starts_with(&format!("| {m} |")))
                .unwrap()
                .to_owned()
        };
        let tg_line = line("trigrid");
        let tg: Vec<&str> = tg_line.split('|').map(str::trim).collect();
        // Columns: "", method, ≤0.5, ≤1, ≤2, ≤5, ...
        assert_eq!(tg[2], "—");
        assert!(tg[3].starts_with("**20.00** dB"), "{tg:?}");
        assert!(tg[5].starts_with("**25.00** dB"), "{tg:?}");
        assert_eq!(tg[6], "〃", "{tg:?}");
        let brute_line = line("brute");
        let brute: Vec<&str> = brute_line.split('|').map(str::trim).collect();
        assert_eq!(brute[6], "—");
        assert!(brute[8].starts_with("**26.00** dB"), "{brute:?}");
        // An equal PSNR later is not better.
        assert_eq!(brute[10], "〃", "{brute:?}");
    }

    #[test]
    fn csv_rows_have_as_many_fields_as_the_header() {
        let row = Row {
            scene: "s".into(),
            view: "std".into(),
            method: "brute".into(),
            detail: "every leaf, 12 points".into(),
            kernel: "round".into(),
            shadows: "off".into(),
            cutoff_px: None,
            psnr_db: 30.0,
            coverage_mismatch: 0.01,
            holes: 0.0,
            ms: 1.5,
            wall_ms: 1.6,
            nodes_visited: 12,
            splats: 10,
            arm_instructions: None,
            reference: "-".into(),
            file_crc: None,
        };
        let text = csv(&[row]);
        let mut lines = text.lines();
        let header = lines.next().unwrap().split(',').count();
        let line = lines.next().unwrap();
        // The quoted detail holds one comma.
        assert_eq!(line.split(',').count(), header + 1, "{line}");
    }

    #[test]
    fn results_csv_reads_back_as_it_was_written() {
        let row = |cutoff_px, arm_instructions| Row {
            scene: "big.toml".into(),
            view: "std".into(),
            method: "trigrid".into(),
            detail: "ρ=3 pack of 6 objects, depth ≤ 6".into(),
            kernel: "square".into(),
            shadows: "one-pass".into(),
            cutoff_px,
            psnr_db: 24.3827,
            coverage_mismatch: 0.012_5,
            holes: 0.000_391,
            ms: 3.3113,
            wall_ms: 4.25,
            nodes_visited: 104_549,
            splats: 67_168,
            arm_instructions,
            reference: "ray-cast".into(),
            file_crc: None,
        };
        let rows = vec![row(Some(4.0), Some(39_954_567)), row(None, None)];
        assert_eq!(parse_csv(&csv(&rows)).unwrap(), rows);
        assert!(parse_csv("scene,view\nx,y\n").is_err());
        let bad = csv(&rows).replace("104549", "many");
        let err = format!("{:#}", parse_csv(&bad).unwrap_err());
        assert!(err.contains("line 2") && err.contains("many"), "{err}");
    }
}
