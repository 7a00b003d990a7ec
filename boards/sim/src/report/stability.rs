//! `pocketsplat report stability`: a named suite of extreme and stiff cases for the integer renderer,
//! each judged against an f64 projection of the same cells (docs/ARCHITECTURE.md "Numbers": overflow is a bug).
//!
//! A case passes only when it does not panic (overflow checks on: the dev profile has them), every
//! splat that reaches the screen lies within [`MAX_ERROR_PX`] of the f64 projection of its cell's
//! centre (and has the f64 diameter within as much, where the raster draws it unclamped), no splat
//! draws outside the true projected bounds of its cell's bounding sphere (and of the model) by more
//! than [`BOUNDS_SLACK_PX`], and no splat comes from in front of the near plane; cases with more to
//! check (images that must match, α, the frame-rate controller, shadows) say so in their notes. A
//! case the core cannot pass yet is a *known failure*: it checks that the failure is still the one
//! documented, so it fails as soon as the behaviour changes (fixed or worse).
//!
//! The groups are the rows of issue 8 §3; `boards/sim/tests/stability.rs` runs each as one test.
//! Meshes are generated here, so the suite needs no model files.

use std::cell::{Cell, RefCell};
use std::fmt::Write as _;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::time::Instant;

use pocketsplat_core::bake::{bake_grid, BakeOptions, BakedGrid, TriMesh};
use pocketsplat_core::camera::{self, Camera, Placement, Sphere, Vec3, View, HEIGHT, WIDTH};
use pocketsplat_core::fixed::ONE_PX_Q8;
use pocketsplat_core::lod::{FrameRateController, FINEST_CUTOFF_PX};
use pocketsplat_core::normal::{self, NORMAL_COUNT};
use pocketsplat_core::raster::{drawn_pixels, Kernel, MAX_SPLAT_PX};
use pocketsplat_core::render::RenderOptions;
use pocketsplat_core::shade::{phong, to_rgb565, ShadingTable, DEFAULT_MATERIAL};
use pocketsplat_core::shadow::{render_tg_shadowed, LightFrame, ShadowMap, ShadowMode};
use pocketsplat_core::splat::{SampleSplat, ShadedRaster, SplatSink, Stats};
use pocketsplat_core::tg::frame::{FOOTPRINT, FOOTPRINT_ROUND, PRECISION_ERROR_PX};
use pocketsplat_core::tg::write::write_tg;
use pocketsplat_core::tg::{render_tg, TgFrame, TriGrid, Verify};

use crate::render::FrameBuffers;

/// One pixel in the splats' fixed point.
const ONE_PX: f64 = ONE_PX_Q8 as f64;

/// Largest allowed distance between a splat's centre and the f64 projection of its cell's centre.
pub const MAX_ERROR_PX: f64 = 0.5;
/// How far a splat's drawn pixels may reach beyond the true projected bounds: half a pixel because
/// whole pixels are drawn whose centres fall inside the splat, and [`MAX_ERROR_PX`] of projection error.
pub const BOUNDS_SLACK_PX: f64 = 0.5 + MAX_ERROR_PX;

/// The groups, in report order.
pub const GROUPS: [&str; 9] = [
    "distance", "inside", "fov", "axes", "scale", "depth", "shapes", "lights", "lod",
];

/// What a case found.
#[derive(Clone, Debug, Default)]
pub struct Outcome {
    /// The case's worst error, in `unit`.
    pub worst: f64,
    /// Unit of `worst` (e.g. "px").
    pub unit: &'static str,
    /// Bound `worst` is held to.
    pub limit: f64,
    /// Splats checked, drawn pixels, and what else was measured.
    pub notes: String,
    /// Why the case fails; empty when it passes.
    pub failures: Vec<String>,
    /// Set when the case reproduces a documented known failure (and `failures` is then empty).
    pub known: Option<String>,
}

impl Outcome {
    fn fail(&mut self, why: impl Into<String>) {
        self.failures.push(why.into());
    }
    /// Turns a measured failure into a known one when it is exactly the documented behaviour, and
    /// into a failure ("known failure changed") otherwise. (No case has a known failure since
    /// issue 18; kept for the next one.)
    #[allow(dead_code)]
    fn expect_known(&mut self, reproduced: bool, reason: &str) {
        if reproduced {
            self.failures.clear();
            self.known = Some(reason.to_string());
        } else {
            self.failures.insert(
                0,
                format!("the known failure no longer reproduces as documented ({reason}); update the suite"),
            );
        }
    }
}

/// One row of the report.
#[derive(Clone, Debug)]
pub struct CaseResult {
    /// Group name (one of [`GROUPS`]).
    pub group: &'static str,
    /// Case name, unique within the group.
    pub name: String,
    /// What it found (a panic becomes a failure naming the message and place).
    pub outcome: Outcome,
    /// Wall time, seconds (not in the markdown, which must not change between runs).
    pub seconds: f64,
}

impl CaseResult {
    /// Passed, or reproduced its documented known failure.
    pub fn ok(&self) -> bool {
        self.outcome.failures.is_empty()
    }
    /// "pass", "known failure" or "FAIL".
    pub fn status(&self) -> &'static str {
        match (self.ok(), self.outcome.known.is_some()) {
            (true, false) => "pass",
            (true, true) => "known failure",
            (false, _) => "FAIL",
        }
    }
}

// ---- running cases: panics are caught and reported with their message and place -----------------

thread_local! {
    static IN_CASE: Cell<bool> = const { Cell::new(false) };
    static PANIC: RefCell<Option<String>> = const { RefCell::new(None) };
}

fn install_panic_hook() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if IN_CASE.with(Cell::get) {
                let msg = payload_message(info.payload());
                let at = info
                    .location()
                    .map(|l| format!(" at {}:{}", l.file(), l.line()))
                    .unwrap_or_default();
                PANIC.with(|p| *p.borrow_mut() = Some(format!("{msg}{at}")));
            } else {
                previous(info);
            }
        }));
    });
}

fn payload_message(p: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = p.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = p.downcast_ref::<String>() {
        s.clone()
    } else {
        "panic".to_string()
    }
}

/// Runs `f` with panics caught: `Err(message at file:line)` when it panicked.
fn guarded<T>(f: impl FnOnce() -> T) -> Result<T, String> {
    install_panic_hook();
    IN_CASE.with(|c| c.set(true));
    PANIC.with(|p| p.borrow_mut().take());
    let r = catch_unwind(AssertUnwindSafe(f));
    IN_CASE.with(|c| c.set(false));
    r.map_err(|payload| {
        PANIC
            .with(|p| p.borrow_mut().take())
            .unwrap_or_else(|| payload_message(payload.as_ref()))
    })
}

/// Whether this build checks integer overflow (the dev and test profiles do; release does not).
pub fn overflow_checks_on() -> bool {
    guarded(|| std::hint::black_box(i32::MAX) + std::hint::black_box(1)).is_err()
}

struct Runner {
    group: &'static str,
    results: Vec<CaseResult>,
}

impl Runner {
    fn case(&mut self, name: impl Into<String>, f: impl FnOnce() -> Outcome) {
        let t = Instant::now();
        let outcome = guarded(f).unwrap_or_else(|msg| Outcome {
            unit: "px",
            limit: MAX_ERROR_PX,
            failures: vec![format!("panicked: {msg}")],
            ..Outcome::default()
        });
        self.results.push(CaseResult {
            group: self.group,
            name: name.into(),
            outcome,
            seconds: t.elapsed().as_secs_f64(),
        });
    }

    /// Shared set-up (a bake): on a panic, a failing case named after it and `None`.
    fn setup<T>(&mut self, name: &str, f: impl FnOnce() -> T) -> Option<T> {
        let t = Instant::now();
        match guarded(f) {
            Ok(v) => Some(v),
            Err(msg) => {
                self.results.push(CaseResult {
                    group: self.group,
                    name: format!("set-up: {name}"),
                    outcome: Outcome {
                        failures: vec![format!("panicked: {msg}")],
                        ..Outcome::default()
                    },
                    seconds: t.elapsed().as_secs_f64(),
                });
                None
            }
        }
    }
}

/// Runs one group by name.
///
/// # Panics
/// When `group` is not one of [`GROUPS`].
pub fn run_group(group: &str) -> Vec<CaseResult> {
    let group = *GROUPS
        .iter()
        .find(|g| **g == group)
        .unwrap_or_else(|| panic!("no stability group {group:?}; groups: {GROUPS:?}"));
    let mut r = Runner {
        group,
        results: Vec::new(),
    };
    match group {
        "distance" => distance(&mut r),
        "inside" => inside(&mut r),
        "fov" => fov(&mut r),
        "axes" => axes(&mut r),
        "scale" => scale(&mut r),
        "depth" => depth(&mut r),
        "shapes" => shapes(&mut r),
        "lights" => lights(&mut r),
        "lod" => lod(&mut r),
        _ => unreachable!(),
    }
    r.results
}

/// Runs every group.
pub fn run_all() -> Vec<CaseResult> {
    GROUPS.iter().flat_map(|g| run_group(g)).collect()
}

/// The report as markdown: a summary line, then one table row per case.
pub fn markdown(results: &[CaseResult]) -> String {
    let failed = results.iter().filter(|c| !c.ok()).count();
    let known = results
        .iter()
        .filter(|c| c.ok() && c.outcome.known.is_some())
        .count();
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{} cases: {} pass, {} known failures, {} fail. Overflow checks: {}.\n",
        results.len(),
        results.len() - failed - known,
        known,
        failed,
        if overflow_checks_on() { "on" } else { "OFF" }
    );
    out.push_str("| group | case | result | worst | limit | notes |\n|---|---|---|---|---|---|\n");
    for c in results {
        let o = &c.outcome;
        let mut notes = o.notes.clone();
        for f in &o.failures {
            let _ = write!(
                notes,
                "{}**{}**",
                if notes.is_empty() { "" } else { "; " },
                f
            );
        }
        if let Some(k) = &o.known {
            let _ = write!(
                notes,
                "{}known failure: {}",
                if notes.is_empty() { "" } else { "; " },
                k
            );
        }
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {} | {} |",
            c.group,
            c.name,
            c.status(),
            fmt_value(o.worst, o.unit),
            fmt_value(o.limit, o.unit),
            notes.replace('|', "\\|")
        );
    }
    out
}

/// The command that regenerates `docs/stability.md` (the dev profile, so overflow checks are on).
pub const DOC_COMMAND: &str =
    "cargo run -p pocketsplat-sim -- report stability -o docs/stability.md";

/// The whole page written by `-o`: how it was made, what passing means, the table, the known failures.
pub fn document(results: &[CaseResult]) -> String {
    let mut out = String::from("# Stability suite\n\n");
    let _ = writeln!(
        out,
        "Extreme and stiff cases for the integer renderer (issue 8 §3), generated by\n\n```sh\n{DOC_COMMAND}\n```\n\n\
         and run as tests by `cargo test -p pocketsplat-sim --test stability` (one test per group). \
         Both use the dev profile, which checks integer overflow. The cases and their meshes are in \
         `boards/sim/src/report/stability.rs`.\n\n\
         A case passes when nothing panics or overflows, every splat that reaches the screen is \
         within {MAX_ERROR_PX} px of the f64 projection of its cell's centre (and its diameter within \
         {MAX_ERROR_PX} px of the f64 one, where the raster draws it unclamped), no splat's pixels reach \
         more than {BOUNDS_SLACK_PX} px (half a pixel of pixel-centre sampling plus the allowed error) \
         outside the true projected bounds of its cell's bounding sphere or of the model, and no splat \
         comes from in front of the near plane; cases with more to check say so. \"worst\" is the \
         largest error of the case (position or diameter, px, unless another unit is named). A *known \
         failure* is documented behaviour the core does not yet get right; its test checks that it \
         still fails exactly as described, so a fix (or a regression) makes it fail until the suite is \
         updated.\n"
    );
    out.push_str(&markdown(results));
    let known: Vec<&CaseResult> = results
        .iter()
        .filter(|c| c.ok() && c.outcome.known.is_some())
        .collect();
    if !known.is_empty() {
        out.push_str("\n## Known failures\n\n");
        for c in known {
            let _ = writeln!(
                out,
                "- **{} / {}**: {}",
                c.group,
                c.name,
                c.outcome.known.as_deref().unwrap_or_default()
            );
        }
    }
    out
}

/// `pocketsplat report stability`: runs `groups` (all when empty), prints the table, writes the page
/// to `out` when given, and fails when a case fails.
///
/// # Errors
/// When overflow checks are off (a release build cannot see overflow), a group name is unknown, the
/// page cannot be written, or a case fails.
pub fn command(out: Option<&std::path::Path>, groups: &[String]) -> anyhow::Result<()> {
    if !overflow_checks_on() {
        anyhow::bail!(
            "this build does not check integer overflow, which the suite tests: run it in the dev \
             profile (`cargo run -p pocketsplat-sim -- report stability`, without --release)"
        );
    }
    if let Some(g) = groups.iter().find(|g| !GROUPS.contains(&g.as_str())) {
        anyhow::bail!(
            "no stability group {g:?}; the groups are {}",
            GROUPS.join(", ")
        );
    }
    let mut results = Vec::new();
    for g in GROUPS {
        if groups.is_empty() || groups.iter().any(|x| x == g) {
            let t = Instant::now();
            let r = run_group(g);
            eprintln!(
                "{g}: {} cases in {:.1} s",
                r.len(),
                t.elapsed().as_secs_f64()
            );
            results.extend(r);
        }
    }
    print!("{}", markdown(&results));
    if let Some(path) = out {
        crate::fsutil::write_atomic(path, document(&results).as_bytes())?;
    }
    let failed: Vec<String> = results
        .iter()
        .filter(|c| !c.ok())
        .map(|c| format!("{} / {}", c.group, c.name))
        .collect();
    if !failed.is_empty() {
        anyhow::bail!(
            "{} stability cases fail: {}",
            failed.len(),
            failed.join(", ")
        );
    }
    Ok(())
}

fn fmt_value(v: f64, unit: &str) -> String {
    if unit.is_empty() && v == 0.0 {
        return "–".into();
    }
    let n = if v == 0.0 || (1e-3..1e5).contains(&v.abs()) {
        format!("{v:.3}")
    } else {
        format!("{v:.2e}")
    };
    if unit.is_empty() {
        n
    } else {
        format!("{n} {unit}")
    }
}

// ---- meshes, generated here ----------------------------------------------------------------------

fn mesh(positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> TriMesh {
    TriMesh {
        positions,
        triangles,
        materials: None,
        colors: None,
    }
}

/// A closed bumpy sphere of radius about 1, a little off the origin so that its bounds are not round
/// numbers: the "unit model" of the camera cases.
pub fn blob(n: usize) -> TriMesh {
    use std::f64::consts::PI;
    let mut positions = Vec::new();
    for i in 0..=n {
        let th = PI * i as f64 / n as f64;
        for j in 0..2 * n {
            let ph = PI * j as f64 / n as f64;
            let r = 1.0 + 0.12 * (3.0 * th).sin() * (4.0 * ph).cos() + 0.05 * (7.0 * ph).sin();
            positions.push([
                0.137 + r * th.sin() * ph.cos(),
                -0.071 + 0.9 * r * th.cos(),
                0.029 + r * th.sin() * ph.sin(),
            ]);
        }
    }
    let v = |i: usize, j: usize| (i * 2 * n + j % (2 * n)) as u32;
    let mut triangles = Vec::new();
    for i in 0..n {
        for j in 0..2 * n {
            // Counter-clockwise seen from outside.
            triangles.push([v(i, j), v(i + 1, j + 1), v(i + 1, j)]);
            triangles.push([v(i, j), v(i, j + 1), v(i + 1, j + 1)]);
        }
    }
    mesh(positions, triangles)
}

/// One triangle in general position.
pub fn single_triangle() -> TriMesh {
    mesh(
        vec![[0.1, 0.2, 0.3], [1.3, -0.4, 0.7], [-0.6, 0.9, -1.1]],
        vec![[0, 1, 2]],
    )
}

/// The square `[-1, 1]²` in the plane y = 0, facing +Y: the root cube's middle layer, so every cell
/// has exactly ρ² children (α = 9 for a tri-grid).
pub fn flat_plane() -> TriMesh {
    mesh(
        vec![
            [-1.0, 0.0, -1.0],
            [1.0, 0.0, -1.0],
            [1.0, 0.0, 1.0],
            [-1.0, 0.0, 1.0],
        ],
        vec![[0, 2, 1], [0, 3, 2]],
    )
}

/// A needle: a triangle 2 long and 2·10⁻⁴ wide (aspect 10⁴) along X.
pub fn needle() -> TriMesh {
    mesh(
        vec![[-1.0, -1e-4, 0.0], [1.0, 0.0, 0.0], [-1.0, 1e-4, 1e-5]],
        vec![[0, 1, 2]],
    )
}

/// The stiff case: a dense sphere of radius 10⁻⁶ at the origin (1 800 triangles) and eight small
/// triangles 1 away at the corners of the cube `[-1, 1]³`: scale ratio 10⁶.
pub fn cluster_with_outliers() -> TriMesh {
    let mut m = blob(30);
    let c = m.positions.len();
    for p in &mut m.positions {
        *p = p.map(|x| x * 1e-6);
    }
    for k in 0..8u32 {
        let s = [k & 1, k >> 1 & 1, k >> 2 & 1].map(|b| if b == 1 { 1.0 } else { -1.0 });
        let base = m.positions.len() as u32;
        m.positions.push(s);
        m.positions.push([s[0] * 0.999, s[1], s[2]]);
        m.positions.push([s[0], s[1] * 0.999, s[2]]);
        m.triangles.push([base, base + 1, base + 2]);
    }
    debug_assert!(m.positions.len() == c + 24);
    m
}

/// A thin tube along a trefoil knot (tube radius 10⁻⁴ of the knot's size): a curve, so even a depth-9
/// grid has few cells (the "tiny mesh" of the deep bakes).
pub fn wire() -> TriMesh {
    let mut m = crate::demo::trefoil(240, 3, 5e-4);
    // The knot is about 6 across; keep it in general position.
    for p in &mut m.positions {
        *p = [p[0] + 0.0123, p[1] - 0.0456, p[2] + 0.0789];
    }
    m
}

/// `m` with every vertex mapped by `f`.
fn transformed(m: &TriMesh, f: impl Fn(Vec3) -> Vec3) -> TriMesh {
    TriMesh {
        positions: m.positions.iter().map(|&p| f(p)).collect(),
        ..m.clone()
    }
}

// ---- bakes and the f64 geometry of their cells -----------------------------------------------------

/// A baked grid in memory, with the f64 centre of every cell.
pub struct Baked {
    /// What the baker produced (for α).
    pub grid: BakedGrid,
    /// The `.tg` file.
    pub bytes: Vec<u8>,
    /// Cell centres per level in file order, model units (from the file's root cube and masks).
    pub centres: Vec<Vec<Vec3>>,
    /// Cell side per level, model units.
    pub side: Vec<f64>,
    /// The centroid of each cell's children's centres, per level in file order (`None` for a leaf).
    pub centroids: Vec<Vec<Option<Vec3>>>,
}

impl Baked {
    /// Bakes `mesh` as a ρ-grid of `depth` subdivisions.
    ///
    /// # Panics
    /// When the mesh cannot be baked (the suite's meshes can).
    pub fn new(mesh: &TriMesh, rho: u8, depth: u8) -> Self {
        let grid = bake_grid(mesh, BakeOptions { rho, depth }, None).expect("bake");
        let bytes = write_tg(&grid, 12).expect("write");
        let tg = TriGrid::open(&bytes, Verify::Full).expect("open");
        let h = tg.header();
        let rho = usize::from(h.rho);
        let side0 = h.side64;
        let mut centres = vec![vec![h.origin64.map(|o| o + 0.5 * side0)]];
        let mut side = vec![side0];
        for l in 0..h.depth {
            let parent = side[usize::from(l)];
            side.push(parent / rho as f64);
            let mut next = Vec::with_capacity(tg.level(l + 1).count as usize);
            for (i, c) in centres[usize::from(l)].iter().enumerate() {
                let mask = tg.mask(l, i as u32);
                for s in 0..rho * rho * rho {
                    if mask >> s & 1 == 1 {
                        let ijk = [s % rho, (s / rho) % rho, s / (rho * rho)];
                        next.push(std::array::from_fn(|k| {
                            c[k] + ((ijk[k] as f64 + 0.5) / rho as f64 - 0.5) * parent
                        }));
                    }
                }
            }
            centres.push(next);
        }
        let mut centroids = Vec::with_capacity(centres.len());
        for l in 0..=h.depth {
            let (here, below) = (&centres[usize::from(l)], centres.get(usize::from(l) + 1));
            let mut first = 0usize;
            centroids.push(
                (0..here.len())
                    .map(|i| {
                        let kids = below?;
                        let k = tg.mask(l, i as u32).count_ones() as usize;
                        let kids = &kids[first..first + k];
                        first += k;
                        (k > 0).then(|| {
                            std::array::from_fn(|a| {
                                kids.iter().map(|c| c[a]).sum::<f64>() / k as f64
                            })
                        })
                    })
                    .collect(),
            );
        }
        Self {
            grid,
            bytes,
            centres,
            side,
            centroids,
        }
    }

    /// The file, opened.
    pub fn tg(&self) -> TriGrid<'_> {
        TriGrid::open(&self.bytes, Verify::Structure).expect("open")
    }

    /// The model's bounding box as the file gives it to views (`bounds64`: precise when the header
    /// has the `f64` extension).
    pub fn bounds(&self) -> [[f64; 3]; 2] {
        self.tg().header().bounds64
    }
}

/// The bounding sphere of a placed model (the orbit camera's pivot).
pub fn world_sphere(bounds: [[f64; 3]; 2], placement: &Placement) -> Sphere {
    let s = Sphere::from_bounds_f64(bounds);
    Sphere {
        center: placement.apply(s.center),
        radius: s.radius * placement.scale,
    }
}

// ---- one frame, checked splat by splat ---------------------------------------------------------------

/// Expected shadow state of a sample: `Some(true)` surely in shadow, `Some(false)` surely lit, `None`
/// too close to a shadow boundary to say.
type ShadowTruth<'a> = &'a dyn Fn(usize, Vec3) -> Option<bool>;

/// Everything that decides one checked frame.
#[derive(Clone, Copy)]
pub struct Shot<'a> {
    /// The grid.
    pub baked: &'a Baked,
    /// Where the model sits.
    pub placement: Placement,
    /// The camera.
    pub camera: Camera,
    /// Cutoff, kernel, backface culling.
    pub opts: RenderOptions,
    /// Shadow mode and the world direction to the light.
    pub light: (ShadowMode, Vec3),
}

impl<'a> Shot<'a> {
    /// An orbit view of the unit placement, cutoff 1 px, square splats, backface culling on.
    pub fn orbit(baked: &'a Baked, view: View, fov_deg: f64) -> Self {
        Self::placed(baked, Placement::IDENTITY, view, fov_deg)
    }

    /// An orbit view around the placed model's bounding sphere.
    pub fn placed(baked: &'a Baked, placement: Placement, view: View, fov_deg: f64) -> Self {
        let camera = Camera::orbit(world_sphere(baked.bounds(), &placement), view, fov_deg);
        Self {
            baked,
            placement,
            camera,
            opts: RenderOptions::default(),
            light: (ShadowMode::Off, camera::direction(-40.0, 60.0)),
        }
    }

    fn culling(mut self, on: bool) -> Self {
        self.opts.backface_culling = on;
        self
    }
}

/// What a checked frame measured.
pub struct Measured {
    /// The traversal's counts.
    pub stats: Stats,
    /// The frame.
    pub fb: FrameBuffers,
    /// What the splat-by-splat checks found.
    pub checks: Checks,
    /// The frame's near plane, world units: the camera's, or the frame's precision plane when that
    /// is farther (`TgFrame::near_depth`).
    pub near_depth: f64,
}

/// What the splat-by-splat checks of one frame found.
#[derive(Clone, Debug)]
pub struct Checks {
    /// Worst position or diameter error over splats that reach the screen, px.
    pub worst_px: f64,
    /// Worst position or diameter error over every splat, on screen or not, px.
    pub worst_any_px: f64,
    /// Worst reach of a splat's drawn pixels beyond its cell's true projected bounds, px.
    pub cell_excess_px: f64,
    /// Worst reach beyond the model's true projected bounds, px.
    pub model_excess_px: f64,
    /// Splats whose cell centre is nearer than half the near plane (or behind the eye).
    pub near_violations: u32,
    /// Splats with a negative size (wrapped around).
    pub wrapped: u32,
    /// Splats that reach the screen.
    pub on_screen: u32,
    /// Splats whose cell reaches behind the eye (no finite projected bounds to check).
    pub unbounded: u32,
    /// Nearest splat centre, in near-plane distances.
    pub min_z_over_near: f64,
    /// Samples whose shadow state disagrees with the f64 truth, where that changes their colour.
    pub shadow_wrong: u32,
    /// Samples whose shadow state disagrees but whose lit and shadowed colours are the same.
    pub shadow_invisible: u32,
    /// Of those, samples shadowed where the f64 answer is lit (self-shadowing acne).
    pub shadow_acne: u32,
    /// Largest colour change acne makes (lit against shadowed colour), RGB565 steps per channel.
    pub acne_steps: i32,
    /// Samples with a sure f64 shadow state.
    pub shadow_sure: u32,
    /// The first problem, described.
    pub first_problem: Option<String>,
}

impl Default for Checks {
    fn default() -> Self {
        Self {
            worst_px: 0.0,
            worst_any_px: 0.0,
            cell_excess_px: 0.0,
            model_excess_px: 0.0,
            near_violations: 0,
            wrapped: 0,
            on_screen: 0,
            unbounded: 0,
            min_z_over_near: f64::INFINITY,
            shadow_wrong: 0,
            shadow_invisible: 0,
            shadow_acne: 0,
            acne_steps: 0,
            shadow_sure: 0,
            first_problem: None,
        }
    }
}

impl Measured {
    /// Pixels written.
    pub fn covered(&self) -> usize {
        self.fb.covered().iter().filter(|&&c| c).count()
    }

    /// Judges the frame against the suite's bounds.
    pub fn outcome(&self) -> Outcome {
        let c = &self.checks;
        let mut o = Outcome {
            worst: c.worst_px,
            unit: "px",
            limit: MAX_ERROR_PX,
            notes: format!(
                "{} splats ({} on screen), {} px covered; bounds excess {:.3} px",
                self.stats.splats,
                c.on_screen,
                self.covered(),
                c.cell_excess_px.max(c.model_excess_px)
            ),
            ..Outcome::default()
        };
        if c.worst_px > MAX_ERROR_PX {
            o.fail(format!(
                "projected error {:.3} px > {MAX_ERROR_PX} px",
                c.worst_px
            ));
        }
        if c.cell_excess_px > BOUNDS_SLACK_PX {
            o.fail(format!(
                "a splat reaches {:.2} px outside its cell's projected bounds",
                c.cell_excess_px
            ));
        }
        if c.model_excess_px > BOUNDS_SLACK_PX {
            o.fail(format!(
                "a splat reaches {:.2} px outside the model's projected bounds",
                c.model_excess_px
            ));
        }
        if c.near_violations > 0 {
            o.fail(format!(
                "{} splats from in front of the near plane (nearest at {:.3} × near)",
                c.near_violations, c.min_z_over_near
            ));
        }
        if c.wrapped > 0 {
            o.fail(format!("{} splats with a wrapped size", c.wrapped));
        }
        if c.shadow_wrong > 0 {
            o.fail(format!(
                "{} of {} samples with a sure answer have the wrong shadow state",
                c.shadow_wrong, c.shadow_sure
            ));
        }
        if !o.failures.is_empty() {
            if let Some(p) = &c.first_problem {
                o.fail(format!("first: {p}"));
            }
        }
        if c.unbounded > 0 {
            let _ = write!(
                o.notes,
                "; {} splats of cells reaching behind the eye (bounds unchecked)",
                c.unbounded
            );
        }
        if c.worst_any_px > c.worst_px {
            let _ = write!(o.notes, "; off screen up to {:.3} px", c.worst_any_px);
        }
        if c.shadow_sure > 0 {
            let _ = write!(o.notes, "; {} sure shadow states checked", c.shadow_sure);
            if c.shadow_invisible > 0 {
                let _ = write!(
                    o.notes,
                    " ({} differ where lit and shadowed colours are equal)",
                    c.shadow_invisible
                );
            }
        }
        o
    }
}

/// Camera-space position of a model point under `placement`, computed as `R·(s·p) + (t − eye)` so that
/// a small model far from the origin keeps its precision (`placement.apply(p) − eye` would round the
/// world point to the spacing of f64 at `t` first).
fn model_to_camera(camera: &Camera, placement: &Placement, p: Vec3) -> Vec3 {
    let r = &placement.rotation;
    let q = camera::scale(p, placement.scale);
    let d = camera::add(
        [
            camera::dot(r[0], q),
            camera::dot(r[1], q),
            camera::dot(r[2], q),
        ],
        camera::sub(placement.translation, camera.eye),
    );
    [
        camera::dot(d, camera.right),
        camera::dot(d, camera.up),
        camera::dot(d, camera.forward),
    ]
}

/// Projected screen rectangle `[x0, x1] × [y0, y1]` (pixels) of camera-space points, or `None` when
/// one of them is not in front of the eye.
fn screen_box(camera: &Camera, pts: impl IntoIterator<Item = Vec3>) -> Option<[f64; 4]> {
    let mut b = [
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    ];
    for [x, y, z] in pts {
        if z <= 0.0 {
            return None;
        }
        let s = camera.screen(x, y, z);
        b = [
            b[0].min(s[0]),
            b[1].max(s[0]),
            b[2].min(s[1]),
            b[3].max(s[1]),
        ];
    }
    Some(b)
}

/// How far the pixel rectangle `[x0, x1) × [y0, y1)` reaches outside `b`.
fn excess(r: [i64; 4], b: [f64; 4]) -> f64 {
    let [x0, x1, y0, y1] = r.map(|v| v as f64);
    (b[0] - x0)
        .max(x1 - b[1])
        .max(b[2] - y0)
        .max(y1 - b[3])
        .max(0.0)
}

/// The pixels the raster writes for a splat (before clipping), as `raster.rs` computes them, in i64.
fn drawn_rect(s: &SampleSplat) -> [i64; 4] {
    drawn_pixels(s.x_q8, s.y_q8, s.size_q8, s.exact).map(i64::from)
}

fn on_screen(r: [i64; 4]) -> bool {
    r[0] < WIDTH as i64 && r[1] > 0 && r[2] < HEIGHT as i64 && r[3] > 0
}

struct Probe<'a, S> {
    shot: &'a Shot<'a>,
    /// Per level: the model's box grown by 2 cell sides, placed, as 8 camera-space corners.
    model_boxes: Vec<Option<[f64; 4]>>,
    truth: Option<ShadowTruth<'a>>,
    table: &'a ShadingTable<1>,
    inner: S,
    m: Checks,
}

impl<S: SplatSink> SplatSink for Probe<'_, S> {
    fn splat(&mut self, s: &SampleSplat) {
        let shot = self.shot;
        let cam = &shot.camera;
        let l = usize::from(s.level);
        let centre_model = shot.baked.centres[l][s.index as usize];
        let centre = model_to_camera(cam, &shot.placement, centre_model);
        let [x, y, z] = centre;
        // The walk draws a cell at its centre or at its children's centroid (Duguet §4.1: where
        // in the cell the surface is): the splat's position is held to the nearer of the two.
        let centroid = shot.baked.centroids[l][s.index as usize]
            .map(|c| model_to_camera(cam, &shot.placement, c));
        // The splat stands for the cell's bounding sphere; its projected square lies inside the
        // projection of the sphere's camera-aligned bounding cube (exactly: the square's half-width
        // is radius · f / z at the projected centre).
        let radius = 0.5 * 3f64.sqrt() * shot.baked.side[l] * shot.placement.scale;
        let rect = drawn_rect(s);
        let m = &mut self.m;
        m.min_z_over_near = m.min_z_over_near.min(z / cam.near);
        if z < 0.5 * cam.near {
            m.near_violations += 1;
            m.first_problem.get_or_insert_with(|| {
                format!(
                    "level {l} cell {} at depth {z:.3e} (near {:.3e})",
                    s.index, cam.near
                )
            });
            self.inner.splat(s);
            return;
        }
        if s.size_q8 < 0 {
            m.wrapped += 1;
        }
        let p = cam.screen(x, y, z);
        let off = |p: Vec3| {
            (f64::from(s.x_q8) / ONE_PX - p[0])
                .abs()
                .max((f64::from(s.y_q8) / ONE_PX - p[1]).abs())
        };
        let pos_err = match centroid {
            Some([cx, cy, cz]) if cz > 0.0 => off(p).min(off(cam.screen(cx, cy, cz))),
            _ => off(p),
        };
        // The footprint (`pocketsplat_core::tg::frame`): FOOTPRINT × the projected side of an
        // exact splat; the bounding sphere's diameter otherwise.
        let size_true = if s.exact {
            let k = match shot.opts.kernel {
                Kernel::Square => FOOTPRINT,
                Kernel::Round => FOOTPRINT_ROUND,
            };
            k * shot.baked.side[l] * shot.placement.scale * cam.focal_px / z
        } else {
            2.0 * radius * cam.focal_px / z
        };
        // The diameter too, where the raster draws it unclamped.
        let size_err = if size_true < f64::from(MAX_SPLAT_PX) {
            (f64::from(s.size_q8) / ONE_PX - size_true).abs()
        } else {
            0.0
        };
        let err = pos_err.max(size_err);
        let half_true = 0.5 * size_true.min(f64::from(MAX_SPLAT_PX));
        let true_rect = [
            (p[0] - half_true).floor() as i64,
            (p[0] + half_true).ceil() as i64,
            (p[1] - half_true).floor() as i64,
            (p[1] + half_true).ceil() as i64,
        ];
        m.worst_any_px = m.worst_any_px.max(err);
        let visible = on_screen(rect) || on_screen(true_rect);
        if visible {
            m.on_screen += 1;
            if err > m.worst_px {
                m.worst_px = err;
                if err > MAX_ERROR_PX {
                    m.first_problem = Some(format!(
                        "level {l} cell {} drawn at ({:.2}, {:.2}) size {:.2}, f64 ({:.2}, {:.2}) \
                         size {:.2}, depth {:.3e}",
                        s.index,
                        f64::from(s.x_q8) / ONE_PX,
                        f64::from(s.y_q8) / ONE_PX,
                        f64::from(s.size_q8) / ONE_PX,
                        p[0],
                        p[1],
                        size_true,
                        z
                    ));
                }
            }
        }
        // Bounds, for what the raster actually writes (clipped to the screen).
        let clip = [
            rect[0].max(0),
            rect[1].min(WIDTH as i64),
            rect[2].max(0),
            rect[3].min(HEIGHT as i64),
        ];
        if clip[0] < clip[1] && clip[2] < clip[3] {
            let cube = (0..8).map(|k| {
                let d = |bit: u32| if k >> bit & 1 == 1 { radius } else { -radius };
                [x + d(0), y + d(1), z + d(2)]
            });
            match screen_box(cam, cube) {
                Some(b) => {
                    let e = excess(clip, b);
                    if e > m.cell_excess_px {
                        m.cell_excess_px = e;
                        if e > BOUNDS_SLACK_PX {
                            m.first_problem = Some(format!(
                                "level {l} cell {} draws {clip:?}, its bounds are {b:.2?}",
                                s.index
                            ));
                        }
                    }
                }
                None => m.unbounded += 1,
            }
            if let Some(b) = self.model_boxes[l] {
                m.model_excess_px = m.model_excess_px.max(excess(clip, b));
            }
        }
        if let Some(truth) = self.truth {
            if let Some(shadowed) = truth(l, centre_model) {
                m.shadow_sure += 1;
                // Lit and shadowed colours of this sample: a wrong answer that changes no colour
                // (a surface lit at a grazing angle) is not an error anyone can see.
                let (lit, dark) = (self.table.color(s.attr), self.table.shadowed(s.attr));
                let steps = [(11, 31), (5, 63), (0, 31)]
                    .iter()
                    .map(|&(shift, mask)| {
                        (i32::from(lit >> shift & mask) - i32::from(dark >> shift & mask)).abs()
                    })
                    .max()
                    .unwrap_or(0);
                if shadowed != s.shadowed && steps == 0 {
                    m.shadow_invisible += 1;
                } else if shadowed != s.shadowed {
                    m.shadow_wrong += 1;
                    if s.shadowed {
                        m.shadow_acne += 1;
                        m.acne_steps = m.acne_steps.max(steps);
                    }
                    m.first_problem.get_or_insert_with(|| {
                        format!(
                            "level {l} sample at {centre_model:.3?}: shadowed {} (f64: {shadowed})",
                            s.shadowed
                        )
                    });
                }
            }
        }
        self.inner.splat(s);
    }
}

/// Renders a shot through the real raster, checking every splat on the way.
pub fn shoot(shot: &Shot<'_>) -> Measured {
    shoot_with(shot, None)
}

fn shoot_with(shot: &Shot<'_>, truth: Option<ShadowTruth<'_>>) -> Measured {
    let tg = shot.baked.tg();
    let h = tg.header();
    let frame = TgFrame::new(h, &shot.placement, &shot.camera, &shot.opts).expect("frame set-up");
    let bounds = h.bounds64;
    let model_boxes = shot
        .baked
        .side
        .iter()
        .map(|&side| {
            let corners = (0..8).map(|k| {
                let p: Vec3 = std::array::from_fn(|a| {
                    if k >> a & 1 == 1 {
                        bounds[1][a] + 2.0 * side
                    } else {
                        bounds[0][a] - 2.0 * side
                    }
                });
                model_to_camera(&shot.camera, &shot.placement, p)
            });
            screen_box(&shot.camera, corners)
        })
        .collect();
    let mut fb = FrameBuffers::new();
    let mut table = Box::new(ShadingTable::<1>::new());
    let (mode, light_world) = shot.light;
    let to_model = |d: Vec3| camera::normalize(shot.placement.to_model_dir(d));
    table.update(
        &[DEFAULT_MATERIAL],
        to_model(light_world),
        to_model(camera::scale(shot.camera.forward, -1.0)),
    );
    let mut shadow = Vec::new();
    let stats;
    let measured;
    {
        let mut framebuffer = fb.framebuffer();
        framebuffer.clear(0);
        let mut probe = Probe {
            shot,
            model_boxes,
            truth,
            table: &table,
            inner: ShadedRaster {
                fb: &mut framebuffer,
                table: &table,
                kernel: shot.opts.kernel,
            },
            m: Checks::default(),
        };
        stats = if mode == ShadowMode::Off {
            render_tg(&tg, &frame, &mut probe)
        } else {
            let n = crate::render::DEFAULT_SHADOW_MAP_SIZE;
            shadow.resize(n * n, u16::MAX);
            let light = LightFrame::new(h, &shot.placement, light_world, n);
            let mut map = ShadowMap::new(&mut shadow, n);
            render_tg_shadowed(&tg, &frame, &light, &mut map, mode, &mut probe)
        };
        measured = probe.m;
    }
    Measured {
        stats,
        fb,
        checks: measured,
        near_depth: frame.near_depth(),
    }
}

/// A checked frame as a case outcome.
fn check(shot: &Shot<'_>) -> Outcome {
    shoot(shot).outcome()
}

/// Requires that something was drawn (a vacuous pass proves nothing) where, in f64, some leaf's
/// footprint covers a pixel centre beyond the frame's near plane (the camera's, or the frame's
/// precision plane, `TgFrame::near_depth`). A model smaller than that draws nothing: its splats,
/// exact footprints, cover no pixel centre, as the surface itself covers none.
fn check_drawn(shot: &Shot<'_>) -> Outcome {
    let m = shoot(shot);
    let mut o = m.outcome();
    let b = shot.baked;
    let leaf = b.side.len() - 1;
    let half = 0.5 * FOOTPRINT * b.side[leaf] * shot.placement.scale;
    let cam = &shot.camera;
    // A leaf straddling the plane may be drawn or not (its centre decides): only leaves wholly
    // beyond it must be.
    let near = cam.near.max(m.near_depth) + half * 3f64.sqrt();
    let over_a_centre = b.centres[leaf].iter().any(|&c| {
        let [x, y, z] = model_to_camera(cam, &shot.placement, c);
        if z <= near {
            return false;
        }
        let p = cam.screen(x, y, z);
        let h = half * cam.focal_px / z;
        // A pixel centre i + ½ in [p − h, p + h) on both axes, on the screen.
        let centre_in = |a: f64, b: f64, n: f64| {
            let (first, end) = ((a - 0.5).ceil().max(0.0), (b - 0.5).ceil().min(n));
            first < end
        };
        centre_in(p[0] - h, p[0] + h, WIDTH as f64) && centre_in(p[1] - h, p[1] + h, HEIGHT as f64)
    });
    if over_a_centre && (m.stats.splats == 0 || m.covered() == 0) {
        o.fail("nothing drawn where the model is in view");
    }
    if !over_a_centre {
        o.notes
            .push_str("; no leaf covers a pixel centre: nothing to draw");
    }
    if m.near_depth > cam.near {
        let _ = write!(
            o.notes,
            "; the frame's precision plane clips at {:.1} × the camera's near plane",
            m.near_depth / cam.near
        );
    }
    o
}

// ---- the groups ----------------------------------------------------------------------------------

const STD: View = View::new(30.0, 20.0, 2.5);

fn blob_grid() -> Baked {
    Baked::new(&blob(40), 3, 4)
}

/// Camera distances from 0.001 to 10 000 bounding radii (backface culling off, so that views from
/// inside draw the far walls).
fn distance(r: &mut Runner) {
    let Some(b) = r.setup("blob, tri-grid depth 4", blob_grid) else {
        return;
    };
    for dist in [1e-3, 1e-2, 0.1, 0.5, 1.0, 2.5, 10.0, 100.0, 1e3, 1e4] {
        r.case(format!("blob at {dist} radii"), || {
            check_drawn(&Shot::orbit(&b, View::new(30.0, 20.0, dist), 45.0).culling(false))
        });
    }
}

/// Inside the model, and the near plane through it.
fn inside(r: &mut Runner) {
    let Some(b) = r.setup("blob, tri-grid depth 5", || Baked::new(&blob(40), 3, 5)) else {
        return;
    };
    for (az, el) in [(0.0, 0.0), (123.0, -35.0), (-70.0, 60.0)] {
        r.case(format!("eye inside at 0.3 radii, view {az},{el}"), || {
            check_drawn(&Shot::orbit(&b, View::new(az, el, 0.3), 45.0).culling(false))
        });
    }
    // The blob's surface is about 0.55 bounding radii from its centre: the near plane (10⁻³ radii in
    // front of the eye) cuts it from just outside.
    r.case("eye on the surface, near plane through it", || {
        check_drawn(&Shot::orbit(&b, View::new(0.0, 0.0, 0.575), 45.0))
    });
    // A far near plane, through the middle of the model.
    for near in [0.3, 0.9] {
        r.case(
            format!("near plane at {near} radii through the middle"),
            || {
                let mut shot = Shot::orbit(&b, View::new(20.0, 10.0, 1.0), 60.0).culling(false);
                shot.camera.near = near * world_sphere(b.bounds(), &shot.placement).radius;
                check_drawn(&shot)
            },
        );
    }
    r.case(
        "eye inside at 0.3 radii, cutoff 0.25 px (descends to the leaves)",
        || {
            let mut shot = Shot::orbit(&b, View::new(45.0, 30.0, 0.3), 45.0).culling(false);
            shot.opts.cutoff_px = 0.25;
            check_drawn(&shot)
        },
    );
}

/// Field of view 1° and 170°, near and far.
fn fov(r: &mut Runner) {
    let Some(b) = r.setup("blob, tri-grid depth 4", blob_grid) else {
        return;
    };
    for (fov, dist) in [
        (1.0, 2.5),
        (1.0, 1e4),
        (1.0, 0.3),
        (170.0, 2.5),
        (170.0, 0.3),
        (170.0, 1e3),
    ] {
        r.case(format!("FOV {fov}° at {dist} radii"), || {
            check_drawn(&Shot::orbit(&b, View::new(30.0, 20.0, dist), fov).culling(dist >= 1.0))
        });
    }
}

/// Angle between two unit vectors, degrees.
fn angle_deg(a: Vec3, b: Vec3) -> f64 {
    let c = camera::cross(a, b);
    camera::dot(c, c)
        .sqrt()
        .atan2(camera::dot(a, b))
        .to_degrees()
}

/// Looking straight along each axis, including straight up and down (elevation ±90°, where +Y is no
/// use as the camera's up reference).
fn axes(r: &mut Runner) {
    let Some(b) = r.setup("blob, tri-grid depth 4", blob_grid) else {
        return;
    };
    for (name, az, el) in [
        ("along -Z (from +Z)", 0.0, 0.0),
        ("along +Z (from -Z)", 180.0, 0.0),
        ("along -X (from +X)", 90.0, 0.0),
        ("along +X (from -X)", -90.0, 0.0),
        ("straight down (EL 90, AZ 0)", 0.0, 90.0),
        ("straight down (EL 90, AZ 90)", 90.0, 90.0),
        ("straight up (EL -90, AZ 0)", 0.0, -90.0),
        ("straight up (EL -90, AZ 210)", 210.0, -90.0),
    ] {
        r.case(name, || {
            check_drawn(&Shot::orbit(&b, View::new(az, el, 2.5), 45.0))
        });
    }
    // The up-vector degeneracy: at EL ±90 the camera must be the limit of the cameras just off the
    // pole at the same azimuth, so that orbiting over the top turns the image continuously.
    for el in [90.0, -90.0] {
        r.case(format!("pole continuity at EL {el} (AZ 0..360)"), || {
            let s = world_sphere(b.bounds(), &Placement::IDENTITY);
            let mut worst = 0.0f64;
            let mut worst_pixels = 0.0f64;
            for az in [0.0, 30.0, 90.0, 135.0, 180.0, 270.0] {
                let at = Camera::orbit(s, View::new(az, el, 2.5), 45.0);
                let near = Camera::orbit(s, View::new(az, el - el.signum() * 1e-3, 2.5), 45.0);
                let d = angle_deg(at.right, near.right).max(angle_deg(at.up, near.up));
                worst = worst.max(d);
                // The same in pixels: how far the model's bounding-box corners move on screen.
                let (lo, hi) = (b.bounds()[0], b.bounds()[1]);
                for k in 0..8 {
                    let p: Vec3 =
                        std::array::from_fn(|a| if k >> a & 1 == 1 { hi[a] } else { lo[a] });
                    if let (Some(p1), Some(p2)) = (at.project(p), near.project(p)) {
                        worst_pixels = worst_pixels
                            .max((p1[0] - p2[0]).abs().max((p1[1] - p2[1]).abs()));
                    }
                }
            }
            let mut o = Outcome {
                worst: worst_pixels,
                unit: "px",
                limit: MAX_ERROR_PX,
                notes: format!(
                    "camera basis at the pole vs 0.001° off it: up to {worst:.4}° apart"
                ),
                ..Outcome::default()
            };
            if worst_pixels > MAX_ERROR_PX {
                o.fail(format!(
                    "the image jumps by {worst_pixels:.1} px (basis turns {worst:.1}°) onto the pole"
                ));
            }
            o
        });
    }
}

/// Pixels that differ between two frames.
fn differing(a: &FrameBuffers, b: &FrameBuffers) -> usize {
    a.pixels()
        .iter()
        .zip(b.pixels())
        .filter(|(x, y)| x != y)
        .count()
}

/// Models scaled by 10⁻⁶ and 10⁶ and translated by 10⁷: by the renderer's placement, and in the mesh's
/// own coordinates before baking. The image must match the unit model's.
fn scale(r: &mut Runner) {
    let unit_mesh = blob(40);
    let Some(unit) = r.setup("blob, tri-grid depth 4", || Baked::new(&unit_mesh, 3, 4)) else {
        return;
    };
    let views = [("std", STD), ("close", View::new(60.0, 10.0, 0.8))];
    let reference: Vec<FrameBuffers> = views
        .iter()
        .map(|(_, v)| shoot(&Shot::orbit(&unit, *v, 45.0)).fb)
        .collect();
    // 1. The renderer's placement: world = s·p + t.
    // The last one is beyond f64 world coordinates: at 10⁷ their spacing is 1.9·10⁻⁹, 10⁻³ of the
    // model's radius, so the orbit camera itself (eye and pivot) is off by that much against the
    // model and no renderer could match the unit image. That frame must still project exactly, and
    // match the unit model seen by the *same* camera (expressed in model units).
    for (name, s, t, same_camera) in [
        ("placement scale 1e-6", 1e-6, [0.0; 3], false),
        ("placement scale 1e6", 1e6, [0.0; 3], false),
        ("placement translation 1e7", 1.0, [1e7, -1e7, 1e7], false),
        (
            "placement scale 1e6, translation 1e7",
            1e6,
            [1e7, 1e7, -1e7],
            false,
        ),
        (
            "placement scale 1e-6, translation 1e7",
            1e-6,
            [1e7, 1e7, 1e7],
            true,
        ),
    ] {
        let reference = &reference;
        let unit = &unit;
        r.case(name, move || {
            let placement = Placement {
                scale: s,
                translation: t,
                ..Placement::IDENTITY
            };
            let mut o = Outcome::default();
            let mut diffs = Vec::new();
            for ((vname, v), want) in views.iter().zip(reference) {
                let shot = Shot::placed(unit, placement, *v, 45.0);
                let m = shoot(&shot);
                let mo = m.outcome();
                o.worst = o.worst.max(mo.worst);
                o.failures.extend(mo.failures);
                let d = differing(&m.fb, want);
                if same_camera {
                    let c = shot.camera;
                    let unit_camera = Camera {
                        eye: camera::scale(camera::sub(c.eye, t), 1.0 / s),
                        near: c.near / s,
                        ..c
                    };
                    let same = shoot(&Shot {
                        camera: unit_camera,
                        ..Shot::orbit(unit, *v, 45.0)
                    });
                    let d_same = differing(&m.fb, &same.fb);
                    diffs.push(format!(
                        "{vname}: {d} px differ (orbit camera), {d_same} with the same camera"
                    ));
                    if d_same > 20 {
                        o.fail(format!(
                            "{vname}: {d_same} pixels differ from the unit model's, same camera"
                        ));
                    }
                } else {
                    diffs.push(format!("{vname}: {d} px differ"));
                    if d != 0 {
                        o.fail(format!("{vname}: {d} pixels differ from the unit model's"));
                    }
                }
            }
            o.unit = "px";
            o.limit = MAX_ERROR_PX;
            o.notes = format!("image vs unit model: {}", diffs.join(", "));
            o
        });
    }
    // 2. The mesh itself scaled or moved, then baked: the `.tg` root cube is f32, and f64 where f32
    // would re-grid the mesh.
    for (name, f, exact) in [
        ("mesh scaled by 2^-20", 2f64.powi(-20), true),
        ("mesh scaled by 2^20", 2f64.powi(20), true),
        ("mesh scaled by 1e-6", 1e-6, false),
        ("mesh scaled by 1e6", 1e6, false),
    ] {
        let (reference, unit_mesh) = (&reference, &unit_mesh);
        r.case(name, move || {
            let b = Baked::new(&transformed(unit_mesh, |p| p.map(|c| c * f)), 3, 4);
            let mut o = Outcome::default();
            let mut diffs = Vec::new();
            for ((vname, v), want) in views.iter().zip(reference) {
                let m = shoot(&Shot::orbit(&b, *v, 45.0));
                let mo = m.outcome();
                o.worst = o.worst.max(mo.worst);
                o.failures.extend(mo.failures);
                let d = differing(&m.fb, want);
                diffs.push(format!("{vname}: {d} px differ"));
                // A power of two scales every f32 and f64 exactly: the frame must be bit-identical.
                // Otherwise the f32 root cube rounds differently at each scale (6·10⁻⁸ relative),
                // which moves splats by ~10⁻⁵ px: a handful of pixel-centre decisions may flip.
                let allowed = if exact { 0 } else { 20 };
                if d > allowed {
                    o.fail(format!("{vname}: {d} pixels differ (allowed {allowed})"));
                }
            }
            o.unit = "px";
            o.limit = MAX_ERROR_PX;
            o.notes = format!("image vs unit model: {}", diffs.join(", "));
            o
        });
    }
    let (reference, unit_mesh) = (&reference, &unit_mesh);
    r.case("mesh translated by 1e7, then baked", move || {
        let t = [1e7, -1e7, 1e7];
        let b = Baked::new(
            &transformed(unit_mesh, |p| [p[0] + t[0], p[1] + t[1], p[2] + t[2]]),
            3,
            4,
        );
        let mut o = Outcome::default();
        // The `f32` root cube and bounds have a spacing of 1 model unit (half the blob) at 10⁷: the
        // baker builds the grid on an `f64` cube and the file stores it in the header's extension
        // (FORMAT.md, flag bit 2), which the frame and the orbit camera use.
        if !b.tg().header().has_precise() {
            o.fail("the file has no precise (f64) root cube");
        }
        let mut diffs = Vec::new();
        for ((vname, v), want) in views.iter().zip(reference) {
            let m = shoot(&Shot::orbit(&b, *v, 45.0));
            let mo = m.outcome();
            o.worst = o.worst.max(mo.worst);
            o.failures.extend(mo.failures);
            let d = differing(&m.fb, want);
            diffs.push(format!("{vname}: {d} px differ"));
            // As for a mesh scaled by 10⁶: the f64 cube is not the unit model's f32 one bit for bit
            // (6·10⁻⁸ of the side apart), so a handful of pixel-centre decisions may flip.
            if d > 20 {
                o.fail(format!("{vname}: {d} pixels differ (allowed 20)"));
            }
        }
        o.unit = "px";
        o.limit = MAX_ERROR_PX;
        o.notes = format!("image vs unit model: {}", diffs.join(", "));
        o
    });
}

/// Depths 1 to 9, tri-grid and octree, on a wire (few cells even at depth 9) and a sphere.
fn depth(r: &mut Runner) {
    let w = wire();
    for (rho, depths) in [(3u8, 1..=9u8), (2, 1..=9)] {
        for d in depths {
            let w = &w;
            r.case(format!("wire, rho {rho}, depth {d}"), move || {
                let b = Baked::new(w, rho, d);
                let mut o = Outcome {
                    unit: "px",
                    limit: MAX_ERROR_PX,
                    ..Outcome::default()
                };
                let mut splats = 0;
                let mut deepest = 0;
                let sphere = world_sphere(b.bounds(), &Placement::IDENTITY);
                // The last view orbits a point of the wire 0.05 units away, so the descent reaches
                // the leaves at every depth.
                let on_wire = Sphere {
                    center: w.positions[0],
                    ..sphere
                };
                for (pivot, v, cutoff) in [
                    (sphere, STD, 1.0),
                    (sphere, View::new(10.0, 5.0, 0.2), 0.5),
                    (sphere, View::new(-100.0, -40.0, 0.01), 0.5),
                    (on_wire, View::new(40.0, 25.0, 0.05 / sphere.radius), 0.5),
                ] {
                    let mut shot = Shot::orbit(&b, v, 45.0).culling(false);
                    shot.camera = Camera::orbit(pivot, v, 45.0);
                    shot.opts.cutoff_px = cutoff;
                    let m = shoot(&shot);
                    let mo = m.outcome();
                    o.worst = o.worst.max(mo.worst);
                    o.failures.extend(mo.failures);
                    splats += m.stats.splats;
                    deepest = deepest.max(m.stats.max_level);
                }
                if deepest != d {
                    o.fail(format!(
                        "the nearest view draws down to level {deepest}, not {d}"
                    ));
                }
                let cells: usize = b.centres.iter().map(Vec::len).sum();
                o.notes =
                    format!("{cells} cells, {splats} splats over 4 views, down to level {deepest}");
                o
            });
        }
    }
    let s = blob(24);
    for d in 1..=5u8 {
        let s = &s;
        r.case(format!("blob, rho 3, depth {d}"), move || {
            let b = Baked::new(s, 3, d);
            check_drawn(&Shot::orbit(&b, View::new(-20.0, 35.0, 0.9), 45.0))
        });
    }
}

/// Builds a View whose eye direction (from the pivot) is `d`.
fn view_from(d: Vec3, dist: f64) -> View {
    let d = camera::normalize(d);
    View::new(
        d[0].atan2(d[2]).to_degrees(),
        d[1].clamp(-1.0, 1.0).asin().to_degrees(),
        dist,
    )
}

/// A single triangle, a flat plane (α = 9 exactly), a needle, and a dense cluster with far outliers.
fn shapes(r: &mut Runner) {
    // Single triangle.
    if let Some(b) = r.setup("single triangle, depth 5", || {
        Baked::new(&single_triangle(), 3, 5)
    }) {
        let n = {
            let m = single_triangle();
            let p = m.positions;
            camera::normalize(camera::cross(
                camera::sub(p[1], p[0]),
                camera::sub(p[2], p[0]),
            ))
        };
        r.case("single triangle, std view", || {
            check_drawn(&Shot::orbit(&b, STD, 45.0))
        });
        r.case("single triangle, face on", || {
            check_drawn(&Shot::orbit(&b, view_from(n, 2.0), 45.0))
        });
        r.case("single triangle, edge on", || {
            let edge = camera::normalize(camera::cross(n, [0.0, 1.0, 0.0]));
            check(&Shot::orbit(&b, view_from(edge, 2.0), 45.0))
        });
        r.case("single triangle, from behind (all backfacing)", || {
            let m = shoot(&Shot::orbit(
                &b,
                view_from(camera::scale(n, -1.0), 2.0),
                45.0,
            ));
            let mut o = m.outcome();
            let _ = write!(o.notes, "; {} backfacing skipped", m.stats.backfacing);
            o
        });
    }
    // Flat plane, α = 9.
    if let Some(b) = r.setup("flat plane, depth 5", || Baked::new(&flat_plane(), 3, 5)) {
        r.case("flat plane: alpha = 9 exactly at every level", || {
            let alphas: Vec<f64> = (0..usize::from(b.grid.depth()))
                .map_while(|l| b.grid.alpha(l))
                .collect();
            let worst = alphas.iter().map(|a| (a - 9.0).abs()).fold(0.0, f64::max);
            let mut o = Outcome {
                worst,
                unit: "",
                limit: 0.0,
                notes: format!("alpha per level {alphas:?}"),
                ..Outcome::default()
            };
            if worst != 0.0 {
                o.fail("alpha is not exactly 9");
            }
            o
        });
        for (name, view, drawn) in [
            (
                "flat plane from straight above (EL 90)",
                View::new(0.0, 90.0, 2.0),
                true,
            ),
            (
                "flat plane from straight above (EL 90, AZ 45)",
                View::new(45.0, 90.0, 2.0),
                true,
            ),
            (
                "flat plane edge on (EL 0)",
                View::new(30.0, 0.0, 2.0),
                false,
            ),
            (
                "flat plane at grazing EL 0.5",
                View::new(30.0, 0.5, 2.0),
                true,
            ),
            (
                "flat plane from below (EL -90, backfacing)",
                View::new(0.0, -90.0, 2.0),
                false,
            ),
            (
                "flat plane, eye 0.01 radii above it",
                View::new(10.0, 0.4, 0.9),
                true,
            ),
        ] {
            r.case(name, || {
                let shot = Shot::orbit(&b, view, 45.0);
                if drawn {
                    check_drawn(&shot)
                } else {
                    check(&shot)
                }
            });
        }
    }
    // Needle.
    if let Some(b) = r.setup("needle, depth 7", || Baked::new(&needle(), 3, 7)) {
        for (name, view) in [
            ("needle, std view", STD),
            ("needle, along its axis", View::new(90.0, 0.0, 2.0)),
            ("needle, across it", View::new(0.0, 0.0, 2.0)),
            ("needle, eye at 0.01 radii", View::new(80.0, 3.0, 0.01)),
        ] {
            r.case(name, || check(&Shot::orbit(&b, view, 45.0).culling(false)));
        }
    }
    // Dense cluster with far outliers.
    if let Some(b) = r.setup("cluster with outliers, depth 9", || {
        Baked::new(&cluster_with_outliers(), 3, 9)
    }) {
        for (name, view) in [
            ("cluster + outliers (1e6), std view", STD),
            (
                "cluster + outliers (1e6), eye at 0.001 radii",
                View::new(30.0, 20.0, 1e-3),
            ),
            (
                "cluster + outliers (1e6), eye at 0.01 radii",
                View::new(-60.0, -10.0, 1e-2),
            ),
        ] {
            r.case(name, || {
                let mut shot = Shot::orbit(&b, view, 45.0).culling(false);
                shot.opts.cutoff_px = 0.5;
                check_drawn(&shot)
            });
        }
        // Beyond the orbit camera (whose near plane is 10⁻³ radii): an eye 100 and 10 cluster radii
        // from the cluster, near plane 10⁻⁸ radii. One frame scale covers the root cube, so `W` has
        // about 2²¹ steps over it and the cluster is some 100 or 10 steps from the eye, where the
        // rounding of the tables could move it by pixels (0.2 and 0.8 px were measured before
        // issue 18): the frame's precision plane (`TgFrame::near_depth`) must clip it, as a near
        // plane would, rather than draw it misplaced.
        for (name, dist) in [
            (
                "cluster + outliers (1e6), eye 1e-4 radii from the cluster",
                1e-4,
            ),
            (
                "cluster + outliers (1e6), eye 1e-5 radii from the cluster",
                1e-5,
            ),
        ] {
            r.case(name, || {
                let mut shot = Shot::orbit(&b, View::new(20.0, 10.0, dist), 45.0).culling(false);
                let radius = world_sphere(b.bounds(), &shot.placement).radius;
                shot.camera.near = 1e-8 * radius;
                shot.opts.cutoff_px = 0.5;
                let m = shoot(&shot);
                let mut o = m.outcome();
                if m.near_depth < 2.0 * dist * radius {
                    o.fail(format!(
                        "the frame's near plane is at {:.2e} radii, in front of the cluster",
                        m.near_depth / radius
                    ));
                }
                if m.stats.splats != 0 {
                    o.fail(format!(
                        "{} splats drawn nearer than the precision plane",
                        m.stats.splats
                    ));
                }
                let _ = write!(
                    o.notes,
                    "; the frame's precision plane at {:.2e} radii clips the cluster",
                    m.near_depth / radius
                );
                o
            });
        }
        // The precision plane's bound, checked where it is tightest: the eye just beyond it from
        // the cluster, whose cell must be drawn within `PRECISION_ERROR_PX` (0.4 px).
        r.case(
            "cluster + outliers (1e6), eye 1.1 precision planes from the cluster",
            || {
                let view = |dist| View::new(20.0, 10.0, dist);
                let mut shot = Shot::orbit(&b, view(1e-5), 45.0).culling(false);
                let radius = world_sphere(b.bounds(), &shot.placement).radius;
                // The plane's depth hardly depends on where the eye is (the frame's scale is set by
                // the whole root cube), so one look at it places the eye.
                let probe =
                    TgFrame::new(b.tg().header(), &shot.placement, &shot.camera, &shot.opts)
                        .expect("frame set-up");
                let dist = 1.1 * probe.near_depth() / radius;
                shot = Shot::orbit(&b, view(dist), 45.0).culling(false);
                shot.camera.near = 1e-8 * radius;
                shot.opts.cutoff_px = 0.5;
                let mut o = check_drawn(&shot);
                let m = shoot(&shot);
                if m.stats.splats == 0 || m.near_depth > dist * radius {
                    o.fail(format!(
                        "the cluster at {dist:.2e} radii is not drawn (precision plane at {:.2e})",
                        m.near_depth / radius
                    ));
                }
                if o.worst > PRECISION_ERROR_PX {
                    o.fail(format!(
                        "error {:.3} px beyond the precision plane (bound {PRECISION_ERROR_PX} px)",
                        o.worst
                    ));
                }
                let _ = write!(o.notes, "; eye {dist:.2e} radii from the cluster");
                o
            },
        );
        r.case(
            "cluster + outliers (1e6): the cluster's cell is drawn",
            || {
                // The cluster is far below a depth-9 cell (10⁻⁶ vs 10⁻⁴): one leaf holds it, and an eye 0.01
                // radii away must see that leaf at the f64 position of its centre.
                let mut shot = Shot::orbit(&b, View::new(0.0, 0.0, 0.01), 45.0).culling(false);
                shot.opts.cutoff_px = 0.5;
                let m = shoot(&shot);
                let mut o = m.outcome();
                if m.stats.max_level != 9 {
                    o.fail(format!(
                        "deepest level drawn {} (want 9)",
                        m.stats.max_level
                    ));
                }
                o
            },
        );
    }
}

/// The light test scene: a 2×2 ground square across axis `a` facing `σ·e_a`, and a 0.6×0.6 occluder
/// 0.5 above it (towards `σ·e_a`), both facing the same way.
fn shadow_scene(a: usize, sigma: f64, height: f64) -> TriMesh {
    let (u, v) = ((a + 1) % 3, (a + 2) % 3);
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for (half, off) in [(1.0, 0.0), (0.3, height)] {
        let base = positions.len() as u32;
        for (s, t) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            let mut p = [0.0; 3];
            p[u] = s * half;
            p[v] = t * half;
            p[a] = sigma * off;
            positions.push(p);
        }
        // e_u × e_v = e_a: counter-clockwise in (u, v) faces +e_a.
        if sigma > 0.0 {
            triangles.extend([[base, base + 1, base + 2], [base, base + 2, base + 3]]);
        } else {
            triangles.extend([[base, base + 2, base + 1], [base, base + 3, base + 2]]);
        }
    }
    mesh(positions, triangles)
}

/// Lights along each axis and grazing; the shading table and the shadow map.
fn lights(r: &mut Runner) {
    // The shading table against f64 Phong for every normal code, lights along the axes and grazing.
    let lights: [(&str, Vec3); 9] = [
        ("+X", [1.0, 0.0, 0.0]),
        ("-X", [-1.0, 0.0, 0.0]),
        ("+Y", [0.0, 1.0, 0.0]),
        ("-Y", [0.0, -1.0, 0.0]),
        ("+Z", [0.0, 0.0, 1.0]),
        ("-Z", [0.0, 0.0, -1.0]),
        ("grazing the view (light ⟂ view)", [1.0, 0.0, 0.0]),
        ("behind the model (light = -view)", [0.0, 0.0, -1.0]),
        ("along the view", [0.0, 0.0, 1.0]),
    ];
    r.case(
        "shading table vs f64 Phong, lights along the axes and grazing",
        || {
            let mut table = Box::new(ShadingTable::<1>::new());
            let mut worst = 0i32;
            let views = [
                [0.0, 0.0, 1.0],
                camera::direction(30.0, 20.0),
                [0.0, 1.0, 0.0],
            ];
            for (_, l) in &lights {
                for v in views {
                    table.update(&[DEFAULT_MATERIAL], *l, v);
                    for code in 0..NORMAL_COUNT as u16 {
                        let n = normal::decode(code).map(f64::from);
                        let want = to_rgb565(phong(&DEFAULT_MATERIAL, n, *l, v));
                        let got = table.color(code);
                        for (shift, mask) in [(11, 31), (5, 63), (0, 31)] {
                            let d =
                                i32::from(want >> shift & mask) - i32::from(got >> shift & mask);
                            worst = worst.max(d.abs());
                        }
                    }
                }
            }
            let mut o = Outcome {
                worst: f64::from(worst),
                unit: "LSB",
                limit: 1.0,
                notes: format!("{} lights × 3 views × {NORMAL_COUNT} normals", lights.len()),
                ..Outcome::default()
            };
            if worst > 1 {
                o.fail(format!("a table entry is {worst} steps from Phong"));
            }
            o
        },
    );

    // Shadows from a light along each axis, and grazing: every sample whose f64 answer is sure (not
    // within a texel and a cell of the shadow's edge) must be shadowed exactly when the occluder hides
    // it from the light.
    // The map spans the root cube (side 2) across the light: at most 2√3 wide.
    let map_texel = 2.0 * 3f64.sqrt() / crate::render::DEFAULT_SHADOW_MAP_SIZE as f64;
    let mut scenes: Vec<(String, usize, f64, Vec3, f64)> = Vec::new();
    for a in 0..3 {
        for sigma in [1.0, -1.0] {
            let mut l = [0.0; 3];
            l[a] = sigma;
            let axis = ["X", "Y", "Z"][a];
            scenes.push((
                format!("light along {}{axis}", if sigma > 0.0 { "+" } else { "-" }),
                a,
                sigma,
                l,
                0.5,
            ));
        }
    }
    // Grazing: the occluder's shadow falls off the ground below ~8°, so every ground sample is lit
    // (or, at 0°, facing away: in shadow by definition). Below 7.1° the slope bias needs tangents
    // above 8 (the ground's baked normal at EL 2° is 2.8° from the light: tangent 20), which a clamp
    // at 8 left to acne on 24 416 samples until issue 18.
    for el in [10.0, 5.0, 2.0, 0.0] {
        let l = camera::direction(25.0, el);
        scenes.push((format!("grazing light, EL {el}°"), 1, 1.0, l, 0.1));
    }
    for (name, a, sigma, l, height) in scenes {
        let Some(b) = r.setup(&name, || Baked::new(&shadow_scene(a, sigma, height), 3, 5)) else {
            continue;
        };
        for mode in [ShadowMode::OnePass, ShadowMode::TwoPass] {
            let (b, name) = (&b, &name);
            r.case(format!("{name}, {mode:?}"), move || {
                let (u, v) = ((a + 1) % 3, (a + 2) % 3);
                let mut eye = [0.0; 3];
                eye[a] = sigma;
                eye[u] = 0.45;
                eye[v] = 0.3;
                let mut shot = Shot::orbit(b, view_from(eye, 2.2), 45.0);
                shot.light = (mode, l);
                let l_a = l[a] * sigma; // cosine of the light to the surfaces' normal
                                        // Facing the light or not is decided on the baked (13-bit) normal, as the reference
                                        // renderer would with that normal: near grazing, quantisation decides, not geometry.
                let mut n = [0.0; 3];
                n[a] = sigma;
                let n_q = normal::decode(normal::encode(n)).map(f64::from);
                let facing = camera::dot(n_q, l);
                let truth = move |level: usize, c: Vec3| -> Option<bool> {
                    let side = b.side[level];
                    if facing <= 0.0 {
                        return Some(true); // facing away from the light
                    }
                    if l_a <= 0.0 {
                        return Some(false); // the occluder's shadow is at infinity
                    }
                    // A cell's footprint and three texels across the light, stretched on the ground by
                    // 1 / cos of the light's angle to the normal.
                    let tol = (2.0 * side + 3.0 * map_texel) / l_a;
                    let h = c[a] * sigma;
                    if h > 0.5 * height {
                        return Some(false); // on the occluder: nothing above it
                    }
                    // Along the light to the occluder's plane.
                    let t = (height - h) / l_a;
                    let hit = [c[u] + t * l[u], c[v] + t * l[v]];
                    let m = hit[0].abs().max(hit[1].abs());
                    if m < 0.3 - tol {
                        Some(true)
                    } else if m > 0.3 + tol {
                        Some(false)
                    } else {
                        None
                    }
                };
                let m = shoot_with(&shot, Some(&truth));
                let mut o = m.outcome();
                if m.stats.splats == 0 {
                    o.fail("nothing drawn");
                }
                let _ = write!(
                    o.notes,
                    "; {} shadowed; baked normal·light {facing:.4}",
                    m.stats.shadowed
                );
                if m.checks.shadow_acne > 0 {
                    let _ = write!(
                        o.notes,
                        "; acne on {} samples changes their colour by up to {} RGB565 steps",
                        m.checks.shadow_acne, m.checks.acne_steps
                    );
                }
                o
            });
        }
    }
}

/// The frame-rate controller under a 100× cost jump and back, with a model of the cost and with the
/// real traversal's node count as the cost.
fn lod(r: &mut Runner) {
    /// Runs `frames` frames of cost `cost(frame, cutoff)` µs; returns the log errors and cutoffs.
    fn run(
        c: &mut FrameRateController,
        frames: usize,
        mut cost: impl FnMut(usize, f32) -> u32,
    ) -> (Vec<f64>, Vec<f32>) {
        let (mut errs, mut cuts) = (Vec::new(), Vec::new());
        for f in 0..frames {
            let t = cost(f, c.cutoff());
            errs.push((f64::from(t) / f64::from(c.target_us())).ln());
            cuts.push(c.cutoff());
            c.update(t);
        }
        (errs, cuts)
    }
    /// Judges the frames after a jump: cutoff in range, settled within `settle` frames to within `tol`
    /// in log (or pinned at the cutoff limit on the side the error pushes to), no overshoot past the
    /// band, and never leaving it again.
    fn judge(o: &mut Outcome, what: &str, errs: &[f64], cuts: &[f32], settle: usize, tol: f64) {
        if cuts.iter().any(|c| !(FINEST_CUTOFF_PX..=64.0).contains(c)) {
            o.fail(format!("{what}: cutoff left [1, 64]: {cuts:?}"));
        }
        let ok = |e: f64, c: f32| {
            e.abs() <= tol || (c <= FINEST_CUTOFF_PX && e < 0.0) || (c >= 64.0 && e > 0.0)
        };
        match errs.iter().zip(cuts).position(|(&e, &c)| ok(e, c)) {
            Some(k) if k <= settle => {
                let _ = write!(
                    o.notes,
                    "{what}: from {:.2} settled in {k} frames (cutoff {:.2} → {:.2} px); ",
                    errs[0],
                    cuts[0],
                    cuts[cuts.len() - 1]
                );
                // Worst error once settled, leaving out frames pinned at a cutoff limit.
                let pinned = |e: f64, c: f32| ok(e, c) && e.abs() > tol;
                let worst = errs[k..]
                    .iter()
                    .zip(&cuts[k..])
                    .filter(|&(&e, &c)| !pinned(e, c))
                    .fold(0.0f64, |w, (e, _)| w.max(e.abs()));
                o.worst = o.worst.max(worst);
                if worst > tol {
                    o.fail(format!("{what}: leaves the band again ({worst:.3})"));
                }
            }
            _ => o.fail(format!(
                "{what}: not settled in {settle} frames: {errs:.3?}"
            )),
        }
        // Overshoot: the error changes sign by more than the band.
        let first = errs[0].signum();
        if errs.iter().any(|e| e.signum() != first && e.abs() > tol) {
            o.fail(format!("{what}: overshoots: {errs:.3?}"));
        }
    }

    r.case("cost model k/cutoff², 100× jump up and down", || {
        let target = 40_000u32;
        let mut c = FrameRateController::new(target, 2.0);
        let mut k = 4.0 * 40_000.0f64;
        let cost = |k: f64, cut: f32| (500.0 + k / f64::from(cut * cut)) as u32;
        let _ = run(&mut c, 30, |_, cut| cost(k, cut));
        let mut o = Outcome {
            unit: "log",
            limit: 0.1,
            ..Outcome::default()
        };
        k *= 100.0;
        let (errs, cuts) = run(&mut c, 40, |_, cut| cost(k, cut));
        judge(&mut o, "up", &errs, &cuts, 12, 0.1);
        k /= 100.0;
        let (errs, cuts) = run(&mut c, 40, |_, cut| cost(k, cut));
        judge(&mut o, "down", &errs, &cuts, 12, 0.1);
        o
    });
    r.case("clamps: frame times 0 and u32::MAX, target 0", || {
        let mut o = Outcome {
            unit: "",
            ..Outcome::default()
        };
        let mut c = FrameRateController::new(0, 4.0);
        for t in [0, u32::MAX, 0, 1, u32::MAX, u32::MAX] {
            let cut = c.update(t);
            if !(FINEST_CUTOFF_PX..=64.0).contains(&cut) || !cut.is_finite() {
                o.fail(format!("cutoff {cut} after a frame of {t} µs"));
            }
        }
        let mut steps = 0;
        while c.refine_idle().is_some() {
            steps += 1;
            if steps > 64 {
                o.fail("idle refinement does not stop");
                break;
            }
        }
        o.notes = format!("idle refinement stops after {steps} steps");
        o
    });
    let Some(b) = r.setup("blob, tri-grid depth 5", || Baked::new(&blob(40), 3, 5)) else {
        return;
    };
    r.case(
        "real traversal cost (nodes visited), 100× jump up and down",
        || {
            let tg = b.tg();
            let camera = Camera::orbit(world_sphere(b.bounds(), &Placement::IDENTITY), STD, 45.0);
            let nodes = |cut: f32| {
                let opts = RenderOptions {
                    cutoff_px: cut,
                    ..RenderOptions::default()
                };
                let frame = TgFrame::new(tg.header(), &Placement::IDENTITY, &camera, &opts)
                    .expect("frame set-up");
                let mut sink = pocketsplat_core::splat::NullSink::default();
                render_tg(&tg, &frame, &mut sink).nodes_visited
            };
            // 1 µs per node, then 100 µs per node (a slower device, or 100× the detail), then back.
            let target = nodes(2.0);
            let mut c = FrameRateController::new(target, 1.0);
            let mut ns = 1.0f64;
            let mut cost = |_: usize, cut: f32| (ns * f64::from(nodes(cut))) as u32;
            let _ = run(&mut c, 25, &mut cost);
            let mut o = Outcome {
                unit: "log",
                limit: 0.25,
                ..Outcome::default()
            };
            ns = 100.0;
            let mut cost = |_: usize, cut: f32| (ns * f64::from(nodes(cut))) as u32;
            let (errs, cuts) = run(&mut c, 25, &mut cost);
            // The node count is a step function of the cutoff and not 1/cutoff², so the band is wider.
            judge(&mut o, "up", &errs, &cuts, 12, 0.25);
            ns = 1.0;
            let mut cost = |_: usize, cut: f32| (ns * f64::from(nodes(cut))) as u32;
            let (errs, cuts) = run(&mut c, 25, &mut cost);
            judge(&mut o, "down", &errs, &cuts, 12, 0.25);
            o
        },
    );
}
