//! Per-frame setup of a tri-grid render (floats allowed here, never per node): the camera becomes
//! integer tables (Duguet §5.1–5.2) that the traversal only adds and compares.
//!
//! The projection of a model point `p` is the homogeneous `(X, Y, W) = A·[p; 1]` with `X/W`, `Y/W` in
//! pixels and `W` the camera depth, all scaled by one per-frame factor so that
//! `max(|X|, |Y|) + S·|W| ≤ 2³⁰` over the root cube, `S` the image's larger side (fixed.rs). Because the map is linear:
//! - a child's centre is its parent's plus `disp[level][slot]` (3 adds, eq. 1–2);
//! - a cell's extent along each frustum plane function is a per-level constant `ext[level]`, so
//!   culling and the inside test are a few adds and compares (§5.2);
//! - the LOD test "projected size ≤ threshold" is `W − ext.w ≥ lod_w[level]` (eq. 3–4: no division);
//! - only a drawn splat divides, through the reciprocal table.
//!
//! # The level of detail and the footprint
//!
//! A cell stops the descent (is drawn as one splat) where its projected bounding-sphere diameter
//! `√3 · side · f / z` is at most the cutoff (QSplat §3.1, Duguet §5.2), **or** where its projected
//! side is at most `min(cutoff, 1)` pixels. The second rule is what makes a 1 px frame cheap: a
//! cell whose side projects to at most a pixel holds at most one pixel centre per axis, so its
//! children could only move that pixel's colour and, at a silhouette, which side of the edge a
//! pixel centre falls; descending one more level there costs ρ² ≈ 9 times the work for that. Below
//! one pixel (`--cutoff 0.5`) the cutoff alone decides, so finer frames stay available. Against the
//! bounding-sphere rule alone this never draws a coarser cell at any cutoff ≥ √3 and draws the
//! same cells as before at coarse cutoffs.
//!
//! A drawn cell's splat is its *footprint*: a square of `FOOTPRINT` × the cell's projected side
//! (a disc of the same area for round splats), centred on the centroid of the cell's children
//! (the surface passes through them; a leaf is drawn at its centre), covering exactly the pixels
//! whose centres it contains. No pixel is drawn for a footprint that contains no pixel centre: the
//! cells of a surface tile its projection, so the pixel centres they miss are covered by their
//! neighbours, and a splat grown to at least one pixel would grow every silhouette by half a pixel.
//! `FOOTPRINT` is a little over 1 so that perspective and the centroids' shifts leave no pixel
//! centre between neighbouring footprints.
//!
//! That holds where the surface's cells line up with the image's axes. A flat model (a ground)
//! is one grid of faces, and a view that turns it (the Big Scene from `top`, 20° of azimuth) puts
//! the faces' images on a turned lattice that squares of the projected side do not cover: pixel
//! centres fall between them in dotted diagonal lines. A flat model's square is instead
//! [`flat_grid_cover`] sides, enough to cover the grid's image at the rays the model spans
//! ([`footprint`]); where the grid is foreshortened that is less than 1.1 sides, so its splats
//! also overlap less.

use super::read::Header;
use super::MAX_LEVELS;
use crate::camera::{Camera, Placement, Projection, Vec3, Viewport, PROJECTED_RANGE};
use crate::frame::{FrameError, RenderOptions};
use crate::normal::{self, NORMALS_Q14, NORMAL_COUNT};
use crate::raster::Kernel;

/// Child slots of the largest ρ the traversal draws (ρ = 3).
pub const MAX_SLOTS: usize = 27;
/// Entries of a per-slot displacement table: 32, so that a slot found by `trailing_zeros` of a
/// 32-bit mask indexes it without a bounds check (entries 27..32 stay 0).
pub const SLOT_TABLE: usize = 32;
/// One level's displacement per child slot ([`SLOT_TABLE`] entries).
pub type SlotTable = [[i32; 3]; SLOT_TABLE];
/// A square footprint's side over the cell's projected side (see the module docs).
pub const FOOTPRINT: f64 = 1.1;
/// A round footprint's diameter over the cell's projected side: the disc of a square footprint's
/// area, `FOOTPRINT · 2/√π`.
pub const FOOTPRINT_ROUND: f64 = 1.25;
/// The largest error, in pixels, that linearising the perspective divide over a cell's children
/// may add to their splats' positions (`TgFrame::linear_w`).
pub const LINEAR_ERROR_PX: f64 = 1.0 / 32.0;
/// The smallest `W` the linearised loop takes: its divisions are 32-bit from there on.
const LINEAR_MIN_W: f64 = (1u32 << 18) as f64;
/// Fraction bits of [`TgFrame::to_model`].
pub(crate) const TO_MODEL_BITS: u32 = 16;
/// Normal-cone classes a file can store (FORMAT.md): class `k` in 1..=6 bounds the angle between a
/// cell's normal and every normal of its subtree by `CONE_ANGLES_DEG[k]`; 0 (no cone stored) and 7
/// (a wider cone) never cull.
pub const CONE_ANGLES_DEG: [f64; 8] = [90.0, 4.0, 8.0, 15.0, 25.0, 40.0, 60.0, 90.0];

/// Half-extents of a cell of one level along the five frustum plane functions, in the frame's
/// integer units, rounded up with a margin for the displacement rounding.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Extents {
    /// Along `X` (left plane `X ≥ 0`).
    pub x: i32,
    /// Along `Y` (top plane `Y ≥ 0`).
    pub y: i32,
    /// Along `W` (near plane `W ≥ near_w`).
    pub w: i32,
    /// Along `width·W − X` (right plane).
    pub r: i32,
    /// Along `height·W − Y` (bottom plane).
    pub b: i32,
}

/// What a frame's backface tables depend on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct BackfaceKey {
    /// Backface culling on.
    culling: bool,
    /// The view direction in the model frame (Q14) and the threshold of the per-frame test;
    /// `None` when the view is too wide for it.
    frame: Option<([i32; 3], i32)>,
}

/// The integer tables of one frame of one tri-grid.
#[derive(Clone, Debug)]
pub struct TgFrame {
    pub(crate) rho: u8,
    pub(crate) depth: u8,
    /// Projected homogeneous centre of the root cell.
    pub(crate) root: [i32; 3],
    /// `disp[L][s]`: centre of child slot `s` at level `L` minus its parent's centre.
    pub(crate) disp: [SlotTable; MAX_LEVELS],
    pub(crate) ext: [Extents; MAX_LEVELS],
    /// Stop at level `L` when `W − ext[L].w ≥ lod_w[L]`.
    pub(crate) lod_w: [i32; MAX_LEVELS],
    /// Footprint side (or diameter) in Q8 pixels = `size_k[L].0 · 2^size_k[L].1 / W`.
    pub(crate) size_k: [(u32, u32); MAX_LEVELS],
    /// Half a child step of a cell at level `L` in the units of [`TgFrame::to_model`]'s vectors
    /// (the grid's axes are the model's, so this is one number per level).
    pub(crate) half_step_model: [i32; MAX_LEVELS],
    /// A child's slot offset per axis, `(i, j, k) − (ρ − 1)/2` in half child steps: `2i − (ρ − 1)`.
    pub(crate) slot_steps: [[i8; 3]; SLOT_TABLE],
    /// A child's slot offset per axis in Q6 ticks ([`TgFrame::tick`]): `ρ · (2i − (ρ − 1)) · 64`.
    pub(crate) slot_ticks: [[i32; 3]; SLOT_TABLE],
    /// `tick[L][a]`: half a child step along model axis `a` of a cell at level `L` in `(X, Y, W)`
    /// (the centroid's unit: a child's slot is `2i − (ρ − 1)` of these from its parent's centre),
    /// and the unit in which the linearised loop places a cell's children:
    /// a child of a cell at level `L − 1` sits `ρ · (2i − (ρ − 1))` ticks of level `L` from its
    /// parent's centre, and its splat at its own children's centroid, `σ / n` ticks further.
    pub(crate) tick: [[[i32; 3]; 3]; MAX_LEVELS],
    /// The children of a cell at level `L − 1` whose `W` is at least `linear_w[L]` are placed by
    /// screen-space increments (the perspective divide linearised at their parent, [`LINEAR_ERROR_PX`]
    /// at most); nearer ones are divided one by one.
    pub(crate) linear_w: [i32; MAX_LEVELS],
    /// `tick[L][a]`'s change of depth, Q8 depth units (the depth is linear in `W`).
    pub(crate) tick_depth: [[i32; 3]; MAX_LEVELS],
    /// `(X, Y, W)` to the model-frame vector from the eye, `v = to_model · c >> TO_MODEL_BITS`,
    /// in the units of `W` (the exact backface test, `n · v > 0`, and the cone test).
    pub(crate) to_model: [[i32; 3]; 3],
    /// Whether stored normal cones may cull (off when the view is too wide to bound `|v|` by `W`).
    pub(crate) cones: bool,
    /// Cone test of class `k` at level `L`: cull when `a · v · 2¹⁴ > W · cone_k[k] + cone_r[k][L]`
    /// (`a` the cell's Q14 normal).
    pub(crate) cone_k: [i32; 8],
    pub(crate) cone_r: [[i64; MAX_LEVELS]; 8],
    /// Cells whose `W` is below this are not drawn: the camera's near plane or, when it is
    /// farther, the frame's precision plane ([`precision_near_w`]).
    pub(crate) near_w: i32,
    /// The camera's near plane alone, in `W` (setup only: the depth map's nearest depth).
    camera_near_w: i32,
    /// Depth = `(W − depth_w0) · depth_scale >> 32`.
    pub(crate) depth_w0: i32,
    pub(crate) depth_scale: u64,
    /// `W` units per world unit of camera depth (setup only: [`TgFrame::share_depth_range`]).
    w_per_unit: f64,
    /// Bit per normal code: backfacing for every ray of the view.
    pub(crate) backface: [u32; NORMAL_COUNT / 32],
    /// Bit per normal code: front-facing for every ray of the view (neither bit: the exact test).
    pub(crate) frontface: [u32; NORMAL_COUNT / 32],
    /// What `backface` and `frontface` were made from (`None` before the first frame).
    /// [`TgFrame::set`] keeps the tables when it repeats.
    backface_key: Option<BackfaceKey>,
    pub(crate) kernel: Kernel,
    /// The image (the right and bottom planes: `width·W − X ≥ 0`, `height·W − Y ≥ 0`). Two bytes
    /// per side: a frame's layout puts it with the byte fields after the tables, so that no hot
    /// table moves past the 4 KB a Thumb-2 load reaches from the frame's address.
    pub(crate) viewport: Viewport,
}

fn row(a: &[f64; 4]) -> Vec3 {
    [a[0], a[1], a[2]]
}

fn l1(v: Vec3) -> f64 {
    libm::fabs(v[0]) + libm::fabs(v[1]) + libm::fabs(v[2])
}

/// `x` rounded (halves away from zero) and saturated to ±(2³¹ − 1), NaN to 0: every integer of a
/// frame's tables comes through here.
pub(crate) fn to_i32(x: f64) -> i32 {
    round_to_i32(x)
}

/// `libm::round(x).clamp(-2_147_483_647.0, 2_147_483_647.0) as i32`, bit for bit (tests compare
/// them), in integer arithmetic on `x`'s bits: on an FPU-less core the float version is a soft
/// add, a truncation, four soft compares and a conversion, ~200 instructions per table entry.
pub(crate) fn round_to_i32(x: f64) -> i32 {
    const FRACTION: u64 = (1 << 52) - 1;
    let bits = x.to_bits();
    let exp = ((bits >> 52) & 0x7ff) as u32; // biased: |x| = 1.f · 2^(exp − 1023)
    let magnitude: u64 = match exp {
        0x7ff if bits & FRACTION != 0 => return 0, // NaN
        0..=1021 => 0,                             // |x| < 0.5 (and zeros, subnormals)
        1022..=1053 => {
            // |x| = m · 2^−shift with shift in 22..=53: add half a unit, drop the fraction.
            let m = (bits & FRACTION) | (1 << 52);
            let shift = 1075 - exp;
            (m + (1 << (shift - 1))) >> shift
        }
        _ => u64::MAX, // |x| ≥ 2³¹ or infinite: saturates
    };
    let magnitude = magnitude.min(i32::MAX as u64) as i32;
    if bits >> 63 != 0 {
        -magnitude
    } else {
        magnitude
    }
}

/// A drawn cell's splat side (square) or diameter (round) over its projected side: [`FOOTPRINT`]
/// or [`FOOTPRINT_ROUND`], or for a flat model [`flat_grid_cover`] (the round kernel's disc of the
/// same area).
///
/// A model whose bounds are thinner than half a leaf cell along an axis is flat: its cells' patches
/// are their faces across that axis, one grid, whose image the view turns and shears. Squares of
/// the projected side leave pixel centres uncovered between them where the grid is turned (a 45°
/// turn needs √2 sides) and overlap where it is foreshortened; the grid's own cover gives the side
/// that is enough, perspective included, so it needs no `FOOTPRINT` margin. Any other model's
/// cells face every way, and keep `FOOTPRINT`.
pub fn footprint(header: &Header, placement: &Placement, camera: &Camera, kernel: Kernel) -> f64 {
    let base = match kernel {
        Kernel::Square => FOOTPRINT,
        Kernel::Round => FOOTPRINT_ROUND,
    };
    let [lo, hi] = header.bounds64;
    let leaf = (0..header.depth).fold(header.side64, |side, _| side / f64::from(header.rho));
    let Some(axis) = (0..3).find(|&a| hi[a] - lo[a] <= 0.5 * leaf) else {
        return base;
    };
    // The rays the model's bounds span, within the image's (all of them where a corner lies
    // behind the eye).
    let f = camera.focal_px;
    let (cx, cy) = camera.viewport.center();
    // Camera y is up, the image's down.
    let image = [
        [-cx / f, (f64::from(camera.viewport.width) - cx) / f],
        [(cy - f64::from(camera.viewport.height)) / f, cy / f],
    ];
    let mut rays = [[f64::INFINITY, f64::NEG_INFINITY]; 2];
    for corner in 0..8 {
        let p: Vec3 = core::array::from_fn(|k| if corner >> k & 1 != 0 { hi[k] } else { lo[k] });
        let v = camera.to_camera(placement.apply(p));
        if v[2].is_nan() || v[2] <= 0.0 {
            rays = image;
            break;
        }
        for k in 0..2 {
            let t = v[k] / v[2];
            rays[k] = [rays[k][0].min(t), rays[k][1].max(t)];
        }
    }
    for k in 0..2 {
        rays[k] = [rays[k][0].max(image[k][0]), rays[k][1].min(image[k][1])];
        if rays[k][0].is_nan() || rays[k][1].is_nan() || rays[k][0] > rays[k][1] {
            return base; // off the image: nothing to draw
        }
    }
    base / FOOTPRINT * flat_grid_cover(axis, placement, camera, rays)
}

/// The side, in projected cell sides, of axis-aligned squares centred on the cells of a flat grid
/// across model axis `axis` that cover the grid's image wherever it lies in the view.
///
/// At a view ray `(t_x, t_y)` (`x/z`, `y/z`), a model direction `d` (view coordinates) moves the
/// image by `(d_x − t_x d_z, d_y − t_y d_z)` per projected side, so the grid's cells sit on a
/// lattice spanned by the images `B`, `C` of its two axes. A row of squares of side `S` along a
/// lattice vector `v` with `|v_x| ≤ S` covers a band `S − |v_y|` tall about its line, and the
/// rows lie `|B × C| / |v_x|` apart vertically: they cover the plane when
/// `S ≥ max(|v_x|, |v_y| + |B × C| / |v_x|)` (or the same with x and y swapped, for columns).
/// The least such `S` over `v ∈ {B, C, B + C, B − C}`, at most the lattice cell's bounding box, at
/// the worst of the corners, edge midpoints and centre of `rays` (`[t_x range, t_y range]`). The
/// rule is sufficient rather than tight (it asks for more than the squares need), which covers the
/// rays between the nine: 5 × 5 rays left the Big Scene's holes exactly as nine do, and only grew
/// the `std` view's ground (0.03 dB lower), at nearly three times the set-up (soft float on a
/// Cortex-M).
pub fn flat_grid_cover(
    axis: usize,
    placement: &Placement,
    camera: &Camera,
    rays: [[f64; 2]; 2],
) -> f64 {
    // Model axis `m` in view coordinates: component `m` of each camera axis in the model's frame.
    let [right, up, forward] =
        [camera.right, camera.up, camera.forward].map(|d| placement.to_model_dir(d));
    let view = |m: usize| [right[m], up[m], forward[m]];
    let (b, c) = (view((axis + 1) % 3), view((axis + 2) % 3));
    let band = |along: f64, across: f64, det: f64| {
        if libm::fabs(along) < 1e-9 {
            f64::INFINITY
        } else {
            libm::fabs(along).max(libm::fabs(across) + det / libm::fabs(along))
        }
    };
    let mut worst = 0.0f64;
    for i in 0..3 {
        for j in 0..3 {
            let at = |r: [f64; 2], k: i32| r[0] + (r[1] - r[0]) * f64::from(k) / 2.0;
            let (tx, ty) = (at(rays[0], i), at(rays[1], j));
            let img = |d: Vec3| [d[0] - tx * d[2], d[1] - ty * d[2]];
            let (bi, ci) = (img(b), img(c));
            let det = libm::fabs(bi[0] * ci[1] - bi[1] * ci[0]);
            let need = [
                bi,
                ci,
                [bi[0] + ci[0], bi[1] + ci[1]],
                [bi[0] - ci[0], bi[1] - ci[1]],
            ]
            .iter()
            .map(|v| band(v[0], v[1], det).min(band(v[1], v[0], det)))
            .fold(f64::INFINITY, f64::min)
            .min(
                (libm::fabs(bi[0]) + libm::fabs(ci[0])).max(libm::fabs(bi[1]) + libm::fabs(ci[1])),
            );
            worst = worst.max(need);
        }
    }
    worst
}

/// `out[s][k] = round(dot(rows[k], off(s)))` for each child slot `s < ρ³` of a cell of side
/// `parent`, `off(s)` being the slot centre's offset from the cell's centre and `round` what the
/// caller makes of a dot product (scale, round to an integer): the displacement tables of a
/// camera's or a light's frame.
///
/// Bit for bit what computing each product in full gives (`dot(a, o) = (a₀o₀ + a₁o₁) + a₂o₂`), with
/// far fewer soft floats on an FPU-less core: an offset's component takes only ρ values (the
/// slot's index along that axis), so there are ρ offsets, 3ρ products per row and ρ² sums of the
/// first two terms, each computed once instead of once per slot.
pub(crate) fn slot_dots(
    rows: &[Vec3; 3],
    rho: usize,
    parent: f64,
    out: &mut SlotTable,
    round: impl Fn(usize, f64) -> i32,
) {
    // The offset of index i along an axis: the expression per slot and axis it replaces.
    let off: [f64; 3] = core::array::from_fn(|i| ((i as f64 + 0.5) / rho as f64 - 0.5) * parent);
    for (k, r) in rows.iter().enumerate() {
        // prod[c][i] = r[c] · off[i]; first[j][i] = the first two terms for indices i, j.
        let prod: [[f64; 3]; 3] = core::array::from_fn(|c| off.map(|o| r[c] * o));
        let first: [[f64; 3]; 3] = core::array::from_fn(|j| prod[0].map(|p| p + prod[1][j]));
        for (s, d) in out.iter_mut().enumerate().take(rho * rho * rho) {
            let (i, j, l) = (s % rho, (s / rho) % rho, s / (rho * rho));
            d[k] = round(k, first[j][i] + prod[2][l]);
        }
    }
}

impl TgFrame {
    /// Sets up a frame of the grid described by `header`, placed in the world by `placement`, seen by
    /// `camera`.
    ///
    /// # Errors
    /// [`FrameError`] for ρ above 3 or non-finite input.
    pub fn new(
        header: &Header,
        placement: &Placement,
        camera: &Camera,
        opts: &RenderOptions,
    ) -> Result<Self, FrameError> {
        let mut frame = Self::UNSET;
        frame.set(header, placement, camera, opts)?;
        Ok(frame)
    }

    /// No frame: a placeholder to [`TgFrame::set`] (it would draw nothing sensible).
    pub const UNSET: TgFrame = TgFrame {
        rho: 3,
        depth: 0,
        root: [0; 3],
        disp: [[[0; 3]; SLOT_TABLE]; MAX_LEVELS],
        ext: [Extents {
            x: 0,
            y: 0,
            w: 0,
            r: 0,
            b: 0,
        }; MAX_LEVELS],
        lod_w: [i32::MAX; MAX_LEVELS],
        size_k: [(0, 0); MAX_LEVELS],
        half_step_model: [0; MAX_LEVELS],
        slot_steps: [[0; 3]; SLOT_TABLE],
        slot_ticks: [[0; 3]; SLOT_TABLE],
        tick: [[[0; 3]; 3]; MAX_LEVELS],
        linear_w: [i32::MAX; MAX_LEVELS],
        tick_depth: [[0; 3]; MAX_LEVELS],
        to_model: [[0; 3]; 3],
        cones: false,
        cone_k: [0; 8],
        cone_r: [[0; MAX_LEVELS]; 8],
        near_w: 1,
        camera_near_w: 1,
        depth_w0: 0,
        depth_scale: 0,
        w_per_unit: 0.0,
        backface: [0; NORMAL_COUNT / 32],
        frontface: [0; NORMAL_COUNT / 32],
        backface_key: None,
        kernel: Kernel::Square,
        viewport: Viewport::DEFAULT,
    };

    /// [`TgFrame::new`] in place: a scene sets one frame per object in turn, so that the frame
    /// (5 KB) is not copied out per object, and the backfacing table (8192 normals, ~0.1 M
    /// instructions on a Cortex-M3) is kept when the object's rotation gives the view direction the
    /// last object's did. On an error the frame is left partly set.
    ///
    /// # Errors
    /// As [`TgFrame::new`].
    pub fn set(
        &mut self,
        header: &Header,
        placement: &Placement,
        camera: &Camera,
        opts: &RenderOptions,
    ) -> Result<(), FrameError> {
        if header.rho > 3 {
            return Err(FrameError::UnsupportedRho(header.rho));
        }
        let cutoff = f64::from(opts.cutoff_px);
        let projection = Projection::new(camera, placement)
            .filter(|_| cutoff > 0.0 && cutoff.is_finite())
            .ok_or(FrameError::BadCamera)?;
        let f = camera.focal_px;
        let (cx, cy) = camera.viewport.center();
        let a = projection.rows;
        let eval = |p: Vec3| projection.eval(p);
        let side = header.side64;
        let origin = header.origin64;
        let mut bound = 0.0f64;
        for corner in 0..8 {
            let p =
                core::array::from_fn(|k| origin[k] + if corner >> k & 1 != 0 { side } else { 0.0 });
            let [x, y, w] = eval(p);
            bound = bound.max(libm::fabs(x).max(libm::fabs(y)) + projection.side() * libm::fabs(w));
        }
        if !(bound.is_finite() && bound > 0.0) {
            return Err(FrameError::BadCamera);
        }
        let scale = PROJECTED_RANGE / bound;
        let centre = origin.map(|o| o + 0.5 * side);
        let root_f = eval(centre).map(|v| v * scale);
        let root = root_f.map(to_i32);

        let rho = usize::from(header.rho);
        let disp = &mut self.disp;
        *disp = [[[0i32; 3]; SLOT_TABLE]; MAX_LEVELS];
        let mut ext = [Extents::default(); MAX_LEVELS];
        let mut lod_w = [i32::MAX; MAX_LEVELS];
        let mut size_k = [(0u32, 0u32); MAX_LEVELS];
        // The camera's near plane, and the frame's own: nearer than `precision_near_w` the
        // rounding of the tables could move a splat by more than `PRECISION_ERROR_PX`, so cells
        // there are clipped as in front of the near plane (`precision_near_w`'s docs). The depth
        // map and the LOD keep the camera's plane, so that a frame whose cells all lie beyond both
        // draws the same pixels as without the precision plane.
        let camera_near_w = to_i32((camera.near * scale).max(1.0));
        let near_w = camera_near_w.max(precision_near_w(header, camera.viewport));
        let world_side = side * placement.scale;
        let (rxm, rym, rwm) = (row(&a[0]), row(&a[1]), row(&a[2]));
        let [rr, rb] = projection.right_bottom();
        let footprint = footprint(header, placement, camera, opts.kernel);
        let mut cell = side; // model units
        for level in 0..=usize::from(header.depth) {
            if level > 0 {
                let parent = cell;
                cell = parent / rho as f64;
                let rows = [row(&a[0]), row(&a[1]), row(&a[2])];
                slot_dots(&rows, rho, parent, &mut disp[level], |_, x| {
                    to_i32(x * scale)
                });
            }
            let h = 0.5 * cell * scale;
            let margin = level as f64 + 2.0;
            let e = |r: Vec3| to_i32(libm::ceil(h * l1(r) + margin));
            ext[level] = Extents {
                x: e(rxm),
                y: e(rym),
                w: e(rwm),
                r: e(rr),
                b: e(rb),
            };
            // Projected side of the cell: side·f / z (pixels). It stops where its bounding sphere's
            // diameter (√3 × that) is at most the cutoff, or the side at most min(cutoff, 1 px)
            // (module docs).
            let k = cell * (world_side / side) * f * scale;
            let stop_side_px = (cutoff / libm::sqrt(3.0)).max(cutoff.min(1.0));
            lod_w[level] = to_i32((k / stop_side_px).max(f64::from(camera_near_w)));
            let k_q8 = k * footprint * f64::from(crate::fixed::ONE_PX_Q8);
            let mut shift = 0u32;
            let mut kk = k_q8;
            while kk >= 2_147_483_648.0 {
                kk *= 0.5;
                shift += 1;
            }
            size_k[level] = (libm::round(kk) as u32, shift);
        }

        // Ticks, and where the linearised placement of a level's cells is precise enough: a child
        // and its splat lie within ρ·(ρ − 1) + (ρ − 1) = ρ² − 1 ticks of its parent's centre per
        // axis (8·√3 ticks, 2.3 of its sides, for ρ = 3). Linearising x = X / W at the parent errs by
        // |J·d| · (dW / W) / (1 + dW / W) with |J·d| ≤ that distance in pixels and
        // dW / W ≤ distance / z = (distance in pixels) / f, so the error is at most
        // p² / f / (1 − p / f) for p = 2.3 · side · f / z: below LINEAR_ERROR_PX where
        // z ≥ 2.3·side·f / sqrt(LINEAR_ERROR_PX·f) (with 10 % to spare for 1 − p/f and rounding).
        let mut tick = [[[0i32; 3]; 3]; MAX_LEVELS];
        let mut half_step_model = [0i32; MAX_LEVELS];
        let mut linear_w = [i32::MAX; MAX_LEVELS];
        let reach = (rho * rho - 1) as f64 * libm::sqrt(3.0) / (2.0 * rho as f64);
        let mut cell_l = side;
        for l in 0..=usize::from(header.depth) {
            if l > 0 {
                cell_l /= rho as f64;
            }
            let t = 0.5 * cell_l / rho as f64;
            for (axis, tk) in tick[l].iter_mut().enumerate() {
                *tk = core::array::from_fn(|k| to_i32(t * a[k][axis] * scale));
            }
            half_step_model[l] = to_i32(t * placement.scale * scale);
            if l > 0 {
                // Also a cell of at most 8 px, so that the loop's sums fit an `i32`.
                let k_side = cell_l * placement.scale * f * scale;
                let w = (1.1 * reach * k_side / libm::sqrt(LINEAR_ERROR_PX * f))
                    .max(k_side / 8.0)
                    .max(LINEAR_MIN_W);
                linear_w[l] = to_i32(w.max(f64::from(camera_near_w)));
            }
        }
        let mut slot_steps = [[0i8; 3]; SLOT_TABLE];
        for (s, st) in slot_steps.iter_mut().enumerate().take(rho * rho * rho) {
            let ijk = [s % rho, (s / rho) % rho, s / (rho * rho)];
            *st = ijk.map(|i| (2 * i) as i8 - (rho as i8 - 1));
        }
        // The inverse of the projection's linear part, over the placement's scale: (X, Y, W) is
        // K·R·(s·(p − eye)) with K the pinhole [[f, 0, cx], [0, −f, cy], [0, 0, 1]] and R the
        // camera's rows in the model frame, so s·(p − eye) = x·right + y·up + W·forward with
        // x = (X − cx·W)/f and y = (cy·W − Y)/f. Its columns, in the model frame:
        let (right_m, up_m, fwd_m) = (
            placement.to_model_dir(camera.right),
            placement.to_model_dir(camera.up),
            placement.to_model_dir(camera.forward),
        );
        let one = f64::from(1u32 << TO_MODEL_BITS);
        let to_model: [[i32; 3]; 3] = core::array::from_fn(|k| {
            [
                to_i32(right_m[k] / f * one),
                to_i32(-up_m[k] / f * one),
                to_i32((fwd_m[k] - cx / f * right_m[k] + cy / f * up_m[k]) * one),
            ]
        });
        // Normal cones (a subtree faces away from every ray when its normals, within θ of the
        // cell's normal a, face away from the eye at every point of the cell): with v the vector
        // from the eye to the cell's centre and r the cell's bounding radius, every n·(q − eye) is
        // at least (a·v)·cos θ − |v|·sin θ − r. For a cell inside the frustum |v| ≤ W / cos θ_max
        // (θ_max: the image corner's angle from the axis), so the subtree is culled when
        // a·v > W·tan θ / cos θ_max + r / cos θ. In W units, Q14.
        let theta_max = libm::atan(libm::sqrt(cx * cx + cy * cy) / f) + 2f64.to_radians();
        let mut cone_k = [0i32; 8];
        let mut cone_r = [[0i64; MAX_LEVELS]; 8];
        let cones = theta_max < 80f64.to_radians();
        if cones {
            let k_fov = 1.0 / libm::cos(theta_max);
            for class in 1..7 {
                let t = CONE_ANGLES_DEG[class].to_radians();
                // A margin for the normals' Q14 rounding and the integer v: 0.5°.
                let t = t + 0.5f64.to_radians();
                cone_k[class] = to_i32(k_fov * libm::tan(t) * 16384.0);
                let mut cell = side;
                for (level, r_out) in cone_r[class]
                    .iter_mut()
                    .enumerate()
                    .take(usize::from(header.depth) + 1)
                {
                    if level > 0 {
                        cell /= rho as f64;
                    }
                    // Bounding radius of the cell in W units, plus the rounding of c.
                    let r = 0.5 * libm::sqrt(3.0) * cell * placement.scale * scale + 4.0;
                    *r_out = (r / libm::cos(t) * 16384.0) as i64;
                }
            }
        }

        // Depth: linear in W from the nearest to the farthest point of the root cube (a scene shares
        // one range instead: `share_depth_range`).
        let (depth_w0, depth_scale) = depth_map(
            root_f[2] - f64::from(ext[0].w),
            root_f[2] + f64::from(ext[0].w),
            camera_near_w,
        );

        // Backfacing for every ray within the frustum: n·forward > sin(θmax), with θmax the angle of
        // the image corner from the axis plus a 2° margin (splats straddle the border).
        let mut key = BackfaceKey {
            culling: opts.backface_culling,
            frame: None,
        };
        if opts.backface_culling {
            let theta = libm::atan(libm::sqrt(cx * cx + cy * cy) / f) + 2f64.to_radians();
            if theta < core::f64::consts::FRAC_PI_2 {
                let fwd = placement.to_model_dir(camera.forward);
                let fq = fwd.map(|c| libm::round(c * 16384.0) as i32);
                let threshold = to_i32(libm::sin(theta) * 16384.0 * 16384.0) + 3 * 16384;
                key.frame = Some((fq, threshold));
            }
        }
        // The table depends on the key alone: rebuilt only when it changes.
        // Front-facing for every ray: n·forward < −sin(θmax), the mirror image. Codes in neither
        // table get the exact test per splat (`n · v > 0`).
        if Some(key) != self.backface_key {
            self.backface = [0u32; NORMAL_COUNT / 32];
            // Without culling every code is "front": no splat is tested. With culling but a view
            // too wide for the per-frame test, every splat takes the exact test.
            self.frontface = if key.culling {
                [0u32; NORMAL_COUNT / 32]
            } else {
                [u32::MAX; NORMAL_COUNT / 32]
            };
            if let Some((fq, threshold)) = key.frame {
                facing_tables(fq, threshold, &mut self.backface, &mut self.frontface);
            }
            self.backface_key = Some(key);
        }
        self.rho = header.rho;
        self.depth = header.depth;
        self.root = root;
        self.ext = ext;
        self.lod_w = lod_w;
        self.size_k = size_k;
        self.half_step_model = half_step_model;
        self.slot_steps = slot_steps;
        self.slot_ticks = slot_steps.map(|st| st.map(|v| i32::from(v) * rho as i32 * 64));
        self.tick = tick;
        self.linear_w = linear_w;
        self.to_model = to_model;
        self.cones = cones && opts.backface_culling;
        self.cone_k = cone_k;
        self.cone_r = cone_r;
        self.near_w = near_w;
        self.camera_near_w = camera_near_w;
        self.depth_w0 = depth_w0;
        self.depth_scale = depth_scale;
        self.set_tick_depth();
        self.w_per_unit = scale;
        self.kernel = opts.kernel;
        self.viewport = camera.viewport;
        Ok(())
    }

    /// The splat kernel this frame was set up with.
    pub fn kernel(&self) -> Kernel {
        self.kernel
    }

    /// The camera depth (world units) nearer than which nothing is drawn: the camera's near plane,
    /// or the frame's precision plane when that is farther ([`precision_near_w`]).
    pub fn near_depth(&self) -> f64 {
        f64::from(self.near_w) / self.w_per_unit
    }

    /// Maps depth over `range` instead of this grid's own root cube, so that several objects drawn
    /// into one depth buffer z-test against each other (a scene: `crate::scene`). By default a
    /// frame spreads the 16-bit depth over its own root cube, so two objects' depths would not be
    /// comparable. Depths outside the range clamp to its ends.
    pub fn share_depth_range(&mut self, range: DepthRange) {
        (self.depth_w0, self.depth_scale) = depth_map(
            range.near * self.w_per_unit,
            range.far * self.w_per_unit,
            self.camera_near_w,
        );
        self.set_tick_depth();
    }

    /// [`TgFrame::tick_depth`] from the ticks and the depth map (integer arithmetic).
    fn set_tick_depth(&mut self) {
        let scale = self.depth_scale;
        for (d, t) in self.tick_depth.iter_mut().zip(&self.tick) {
            *d = core::array::from_fn(|a| {
                let w = i128::from(t[a][2]);
                ((w * i128::from(scale)) >> 24).clamp(i128::from(i32::MIN), i128::from(i32::MAX))
                    as i32
            });
        }
    }
}

/// Largest error, in pixels, that the rounding of a frame's integer tables may add to the position
/// of a splat at or beyond the frame's precision plane ([`precision_near_w`]).
pub const PRECISION_ERROR_PX: f64 = 0.4;

/// The frame's precision plane, in `W` units: beyond it the rounding of the tables moves no splat
/// by more than [`PRECISION_ERROR_PX`], so a frame draws nothing nearer (issue 18).
///
/// One scale covers the whole root cube (`max(|X|, |Y|) + S·|W| ≤ 2³⁰`, `S` the image's larger side:
/// 320 for the reference frame), so `W` has about 2²¹
/// steps over the cube's depth, and a cell ten steps from the eye is drawn with an error of
/// pixels. The proof of the bound: a drawn splat's `(X, Y, W)` is the root's rounded centre plus one
/// rounded displacement per level, each within half a step of the exact value per component, plus,
/// for an interior cell, its children's centroid, `Σₐ oₐ·tickₐ >> 6` with `|oₐ| ≤ 64·(ρ − 1)` and
/// each tick within half a step: in all within `E = (depth + 1)/2 + 3·(ρ − 1)/2 + 1` steps per
/// component (the `+ 1` the shift's floor). A pixel coordinate `p = X / W` then errs by at most
/// `(E + |p|·E) / (W − E)`, so `W ≥ (1 + 1.25·S)·E / PRECISION_ERROR_PX + E` bounds it by
/// [`PRECISION_ERROR_PX`] for every splat centred within a quarter of the larger side off the
/// image (`|p| ≤ 1.25·S`: 400 for 240 × 320); a larger splat centred farther off the image errs by
/// at most that times `|p| / (1.25·S)`. A splat's
/// size errs by at most `E / (W − E)` of itself (0.1 % there). Not from the frame's scale, and
/// the same at any depth: the reciprocal's 2⁻¹⁷ (0.003 px), the Q8 rounding (0.002 px) and the
/// centroid's Q6 weights (1/128 of the cell's projected side); the linearised loops start farther
/// out (`TgFrame::linear_w` ≥ 2¹⁸) with their own bound.
///
/// For ρ = 3 and depth 9 this is 9 032 steps, a few thousandths of the `W` range (the eye at the
/// centre of a bounding sphere of radius 1: 4.8·10⁻³ radii; the orbit camera's own near plane is
/// 10⁻³ radii). The standard views of every model never come that near a surface, so they draw
/// the same pixels; an eye nearer a surface than that sees it clipped, as by a near plane, instead
/// of misplaced by up to pixels (0.8 px at ten steps, the stability suite's stiffest case before
/// issue 18). It costs nothing per node: the traversal already tests `W ≥ near_w`.
pub fn precision_near_w(header: &Header, viewport: Viewport) -> i32 {
    let steps = 0.5 * (f64::from(header.depth) + 1.0) + 1.5 * (f64::from(header.rho) - 1.0) + 1.0;
    let reach = 1.25 * f64::from(viewport.max_side());
    to_i32(libm::ceil(
        (1.0 + reach) * steps / PRECISION_ERROR_PX + steps,
    ))
}

/// Sets the bit of every normal code with `n · fq > threshold` in `back` and of every one with
/// `n · fq < −threshold` in `front` (both cleared by the caller), a word of 32 codes at a time where
/// their box of normals decides it.
fn facing_tables(
    fq: [i32; 3],
    threshold: i32,
    back: &mut [u32; NORMAL_COUNT / 32],
    front: &mut [u32; NORMAL_COUNT / 32],
) {
    for (w, (lo, hi)) in normal::word_dot_ranges(fq).enumerate() {
        // When the word's interval of n · fq lies on one side of both thresholds, the word is
        // decided without its codes (most of the sphere).
        if lo > threshold {
            back[w] = u32::MAX;
        } else if hi < -threshold {
            front[w] = u32::MAX;
        } else if lo < -threshold || hi > threshold {
            for (i, n) in NORMALS_Q14[32 * w..32 * w + 32].iter().enumerate() {
                let d = normal::dot_q14(n, fq);
                if d > threshold {
                    back[w] |= 1 << i;
                } else if d < -threshold {
                    front[w] |= 1 << i;
                }
            }
        }
    }
}

/// `(depth_w0, depth_scale)` spreading depths 0..=65534 over `W` in `[w_lo, w_hi]` (`w_lo` at least
/// the near plane's `W`).
fn depth_map(w_lo: f64, w_hi: f64, near_w: i32) -> (i32, u64) {
    let w_lo = if w_lo.is_finite() {
        w_lo.max(f64::from(near_w))
    } else {
        f64::from(near_w)
    };
    let w_hi = if w_hi.is_finite() {
        w_hi.max(w_lo + 1.0)
    } else {
        w_lo + 1.0
    };
    (
        to_i32(w_lo),
        (65534.0 * 4_294_967_296.0 / (w_hi - w_lo + 1.0)) as u64,
    )
}

pub use crate::camera::DepthRange;

impl DepthRange {
    /// The camera depths of the grid's root cube placed by `placement`: the extremes over its eight
    /// corners (camera depth is linear, so they bound the whole cube).
    pub fn of_root_cube(header: &Header, placement: &Placement, camera: &Camera) -> DepthRange {
        let side = header.side64;
        let origin = header.origin64;
        let mut r = DepthRange::EMPTY;
        for corner in 0..8 {
            let p: Vec3 =
                core::array::from_fn(|k| origin[k] + if corner >> k & 1 != 0 { side } else { 0.0 });
            let z = camera.to_camera(placement.apply(p))[2];
            r.near = r.near.min(z);
            r.far = r.far.max(z);
        }
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera;

    #[test]
    fn to_i32_is_the_clamped_cast() {
        let old = |x: f64| libm::round(x).clamp(-2_147_483_647.0, 2_147_483_647.0) as i32;
        let mut xs = vec![
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.5,
            -2.5,
            2_147_483_646.5,
            2_147_483_647.0,
            2_147_483_647.4,
            2_147_483_647.5,
            2_147_483_648.0,
            -2_147_483_646.5,
            -2_147_483_647.0,
            -2_147_483_647.5,
            -2_147_483_648.0,
            -2_147_483_649.0,
            1e300,
            -1e300,
        ];
        xs.extend((0..2000).map(|i| (f64::from(i) - 1000.0) * 1_234.567_89));
        // Halves and their neighbours, over the whole range.
        for k in (0..40).flat_map(|e| [1i64 << e, (1i64 << e) + 1, (1i64 << e) - 1, 3 << e]) {
            let h = k as f64 + 0.5;
            for x in [h, -h, k as f64, -(k as f64)] {
                let b = x.to_bits();
                xs.extend([
                    x,
                    f64::from_bits(b + 1),
                    f64::from_bits(b.saturating_sub(1)),
                ]);
            }
        }
        xs.extend([
            0.499_999_999_999_999_94,
            -0.499_999_999_999_999_94,
            f64::MIN_POSITIVE,
            5e-324,
        ]);
        // Random bit patterns with exponents about the interesting range (a little LCG).
        let mut seed = 0x9e37_79b9_7f4a_7c15_u64;
        for _ in 0..200_000 {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            let exp = 1000 + (seed >> 58) % 64; // 2^-23 .. 2^40
            let bits = (seed & (1 << 63)) | (exp << 52) | (seed.rotate_left(17) & ((1 << 52) - 1));
            xs.push(f64::from_bits(bits));
        }
        for x in xs {
            assert_eq!(to_i32(x), old(x), "{x:e} ({:#x})", x.to_bits());
        }
    }

    #[test]
    fn facing_tables_match_the_test_per_code() {
        let mut next = crate::testing::signed_uniform(0x9e37_79b9_u64);
        for round in 0..300 {
            let v: Vec3 = core::array::from_fn(|_| next());
            let len = camera::dot(v, v).sqrt();
            let fq = v.map(|c| (c / len * 16384.0).round() as i32);
            // Thresholds from 0 to past the largest dot product.
            let threshold = (f64::from(round % 30) / 29.0 * 1.05 * 16384.0 * 16384.0) as i32;
            let (mut back, mut front) = ([0u32; NORMAL_COUNT / 32], [0u32; NORMAL_COUNT / 32]);
            facing_tables(fq, threshold, &mut back, &mut front);
            for (code, n) in NORMALS_Q14.iter().enumerate() {
                let d = i32::from(n[0]) * fq[0] + i32::from(n[1]) * fq[1] + i32::from(n[2]) * fq[2];
                let bit = |t: &[u32]| t[code / 32] >> (code % 32) & 1 != 0;
                assert_eq!(
                    bit(&back),
                    d > threshold,
                    "code {code}, fq {fq:?}, t {threshold}"
                );
                assert_eq!(
                    bit(&front),
                    d < -threshold,
                    "code {code}, fq {fq:?}, t {threshold}"
                );
            }
        }
    }

    #[test]
    fn slot_dots_are_the_full_dot_products_bit_for_bit() {
        // Awkward rows and sides (a little LCG: no dependency), ρ 2 and 3.
        let mut next = crate::testing::signed_uniform(0x1234_5678_u64);
        for _ in 0..200 {
            let rows: [Vec3; 3] = core::array::from_fn(|_| core::array::from_fn(|_| next() * 1e6));
            let parent = next().abs() * 7.0 + 1e-3;
            let scale = next().abs() * 100.0;
            for rho in [2, 3] {
                let mut fast = [[0i32; 3]; SLOT_TABLE];
                // The low bits of the dot product itself: any difference in rounding shows.
                slot_dots(&rows, rho, parent, &mut fast, |k, x| {
                    (x * scale + k as f64).to_bits() as i32
                });
                for (s, d) in fast.iter().enumerate() {
                    let ijk = [s % rho, (s / rho) % rho, s / (rho * rho)];
                    let off: Vec3 = core::array::from_fn(|k| {
                        ((ijk[k] as f64 + 0.5) / rho as f64 - 0.5) * parent
                    });
                    let full: [i32; 3] = if s < rho * rho * rho {
                        core::array::from_fn(|k| {
                            (camera::dot(rows[k], off) * scale + k as f64).to_bits() as i32
                        })
                    } else {
                        [0; 3]
                    };
                    assert_eq!(*d, full, "slot {s}, rho {rho}");
                }
            }
        }
    }
}
