//! Shadows with a shadow map (Duguet & Drettakis §5.3): one pass or two for a directional light, two
//! for a point light.
//!
//! Light space for a directional light is an orthographic frame: `U`, `V` across the light (Q8
//! shadow-map texels) and `D` along it (distance from the light, Q8 of the 16-bit map depth). Like the
//! camera's, it is linear in the model point, so a node's light-space position is its parent's plus a
//! per-level table entry: 3 adds, no matrix per pixel (§5.3 "the associated projected displacement
//! vectors").
//!
//! A point light ([`LightFrame::point`]) projects in perspective, like the camera: the position is
//! homogeneous `(Uh, Vh, W)`, still 3 adds per node, with `Uh / W`, `Vh / W` the texel and `W` the
//! distance along the light's axis (the map's depth is linear in `W`). The divide is the camera's
//! reciprocal look-up ([`crate::fixed::recip`]), once per tested or filling sample. One map covers the
//! grid's root cube, so the light must be outside the cube's circumscribed sphere; the sub-cell order
//! of one-pass shadows needs a single light direction, so a point light is always two-pass (§5.3:
//! "a single pass method … can also be used for directional light sources"). Shading keeps one light
//! direction per frame (the shading table's): from the model's bounding-sphere centre to the light.
//!
//! - [`OnePass`]: the ρ³ sub-cells are ordered once per light by their projection on the light
//!   direction, so cells nearer the light are always traversed first; each sample tests the map at its
//!   centre and then fills its footprint, in the same pass as the view. Subtrees the view culls are
//!   still walked (to the light's level of detail) because they may cast into the view, and
//!   backfacing samples cast without being drawn. A light exactly along an axis makes whole layers
//!   of sub-cells tie; ties keep slot order, which is safe because cells in one layer across the
//!   light cannot shadow each other. Samples of different levels (multi-level rendering stops at
//!   different depths in different places) fill footprints and get biases of their own cell's size.
//! - [`TwoPass`]: the reference algorithm: [`fill_shadow_map`] renders the whole model's depth from
//!   the light, then the view pass tests each drawn sample against it.
//!
//! Self-shadowing acne: neighbours on the same surface, nearer the light, fill a sample's texel
//! with depths nearer than its own by up to the surface's slope times the distance between them, and
//! a sample stands for a surface that may cross its cell anywhere. A sample is therefore shadowed
//! only when the map holds something nearer than its depth minus a bias of
//! (a) two depth half-extents of the larger of its cell and a one-texel cell, plus
//! (b) the tangent of its normal's angle to the light times a lateral reach: 1.5 texels, or, for a
//! cell wider than a texel, its half-extent across the light plus half a texel. The second case is
//! multi-level rendering's: a coarse sample (a big cell drawn because it is small on screen) has
//! neighbours with footprints as big as its own, and under grazing light the surface's depth changes
//! by the slope across the whole cell, so a one-texel reach leaves it full of acne. The tangent comes
//! from a 65-entry table indexed by `n·l` from the Q14 normal table: the steepest slope of the
//! table's 1/64 bin of `n·l`, so grazing light gets the largest bias, the true slope down to 0.9°
//! above the surface (tangent 64) and 128 below that, where the shadow changes less than one RGB565
//! step (a clamp at 8 left acne below 7.1°); for a point light the texel grows with `W`, so its share of the reach is
//! one more multiply. A sample facing away from the light (`n·l ≤ 0`) is in shadow without a test,
//! as in the reference renderer. One-pass shadows test against what the neighbours *drew* (their
//! centre depth over their whole footprint), and a neighbour may be one level coarser than the
//! sample, so one pass biases each sample as for its parent's level; two-pass fills at one texel and
//! needs only the sample's own. The price of the bias is that contact shadows start a little late,
//! and later for coarse samples.
//!
//! Memory: the map is borrowed ([`ShadowMap::new`]), so a frame without shadows allocates none, and
//! firmware built without the `shadows` feature compiles no code from this module (the traversal's
//! hooks are then the zero-sized `NoShadows`).
//!
//! Setup (`LightFrame::new`, `LightFrame::point`) uses floats; the per-node hooks are integer-only.

use crate::camera::{self, Placement, Sphere, Vec3};
use crate::fixed::recip;
use crate::normal::{self, NORMALS_Q14, NORMAL_COUNT};
use crate::splat::{SplatSink, Stats};
use crate::tg::frame::{round_to_i32, slot_dots, SlotTable, TgFrame, MAX_SLOTS, SLOT_TABLE};
use crate::tg::read::{Header, TriGrid};
use crate::tg::traverse::{fill_tg, render_tg_with, ShadowHooks, SlotOrder};
use crate::tg::MAX_LEVELS;

/// Q8: sub-texel bits of `U`, `V` and sub-unit bits of `D`.
const LIGHT_FRAC: u32 = 8;

/// Largest shadow-map side a point light accepts: `Uh`, `Vh` and `side · W` share 2²⁹.
pub const MAX_POINT_MAP_SIZE: usize = 4096;

/// A shadow map: `size × size` depths, 0 = nearest the light, cleared to `u16::MAX`. Borrowed, so
/// firmware can place it in a static and a scene without shadows allocates none.
pub struct ShadowMap<'a> {
    depth: &'a mut [u16],
    size: usize,
}

impl<'a> ShadowMap<'a> {
    /// Wraps a buffer of `size × size` depths (extra entries are ignored).
    ///
    /// # Panics
    /// When the buffer is shorter than `size²`.
    pub fn new(depth: &'a mut [u16], size: usize) -> Self {
        assert!(depth.len() >= size * size, "shadow map buffer too small");
        Self { depth, size }
    }
    /// Side in texels.
    pub fn size(&self) -> usize {
        self.size
    }
    /// Clears to "nothing casts".
    pub fn clear(&mut self) {
        crate::raster::fill(&mut self.depth[..self.size * self.size], u16::MAX);
    }
    /// The depths, row by row.
    pub fn depths(&self) -> &[u16] {
        &self.depth[..self.size * self.size]
    }

    /// Depth at a texel (`u16::MAX` outside).
    #[inline]
    fn at(&self, u: i32, v: i32) -> u16 {
        if u < 0 || v < 0 || u as usize >= self.size || v as usize >= self.size {
            return u16::MAX;
        }
        self.depth[v as usize * self.size + u as usize]
    }

    /// Writes `d` (keeping the nearer) over the texels whose centres lie within `[u − eu, u + eu] ×
    /// [v − ev, v + ev]` (Q8), or the texel under the centre when none does.
    #[inline]
    fn fill(&mut self, u: i32, v: i32, eu: i32, ev: i32, d: u16) {
        let half = 1 << (LIGHT_FRAC - 1);
        if eu < half && ev < half {
            // Less than half a texel each way (most cells at the finest levels): the only texel
            // centre that can lie in the footprint is the one under the centre, which is also the
            // fallback, so write just that texel.
            let (tu, tv) = (u >> LIGHT_FRAC, v >> LIGHT_FRAC);
            if tu >= 0 && tv >= 0 && (tu as usize) < self.size && (tv as usize) < self.size {
                let t = &mut self.depth[tv as usize * self.size + tu as usize];
                if d < *t {
                    *t = d;
                }
            }
            return;
        }
        let first = |c: i32, e: i32| (c - e - half + (1 << LIGHT_FRAC) - 1) >> LIGHT_FRAC;
        let last = |c: i32, e: i32| (c + e - half) >> LIGHT_FRAC;
        let (mut u0, mut u1, mut v0, mut v1) =
            (first(u, eu), last(u, eu), first(v, ev), last(v, ev));
        if u1 < u0 || v1 < v0 {
            (u0, v0) = (u >> LIGHT_FRAC, v >> LIGHT_FRAC);
            (u1, v1) = (u0, v0);
        }
        let n = self.size as i32 - 1;
        let (ua, ub, va, vb) = (u0.max(0), u1.min(n), v0.max(0), v1.min(n));
        if ub < ua || vb < va {
            return;
        }
        // One slice from the first texel to the last (one bounds check), then the rows: nearly
        // every footprint is 1 to 3 texels wide, which the match writes without a loop.
        let (size, w) = (self.size, (ub - ua) as usize + 1);
        let start = va as usize * size + ua as usize;
        let end = vb as usize * size + ub as usize + 1;
        let keep_nearer = |t: &mut u16| {
            if d < *t {
                *t = d;
            }
        };
        for row in self.depth[start..end].chunks_mut(size) {
            match &mut row[..w] {
                [a] => keep_nearer(a),
                [a, b] => {
                    keep_nearer(a);
                    keep_nearer(b);
                }
                [a, b, c] => {
                    keep_nearer(a);
                    keep_nearer(b);
                    keep_nearer(c);
                }
                texels => texels.iter_mut().for_each(keep_nearer),
            }
        }
    }
}

/// Why a light cannot be set up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LightError {
    /// The point light is inside the sphere around the grid's root cube (one map cannot see the
    /// whole cube from there).
    PointInsideGrid,
    /// The map side is 0 or above [`MAX_POINT_MAP_SIZE`].
    MapSize(usize),
    /// The position or placement is not finite.
    NotFinite,
}

impl core::fmt::Display for LightError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            LightError::PointInsideGrid => write!(
                f,
                "the point light must be outside the sphere around the model's bounding cube"
            ),
            LightError::MapSize(n) => write!(
                f,
                "shadow map side {n}: must be 1..={MAX_POINT_MAP_SIZE} for a point light"
            ),
            LightError::NotFinite => write!(f, "light position or placement is not finite"),
        }
    }
}

/// A point light's depth: `(W − depth_w0) · depth_scale >> 32`, like the camera's.
#[derive(Clone, Copy, Debug, Default)]
struct PointDepth {
    depth_w0: i32,
    depth_scale: u64,
}

/// The light's integer tables for one grid and one light (per-frame setup).
#[derive(Clone, Debug)]
pub struct LightFrame {
    root: [i32; 3],
    disp: [SlotTable; MAX_LEVELS],
    /// Half-extents of a cell along U, V (Q8 texels; a point light: `Uh`, `Vh` units, to divide by
    /// the cell's nearest `W`) and D (`W`), per level.
    ext: [[i32; 3]; MAX_LEVELS],
    bias: [i32; MAX_LEVELS],
    /// Direction to the light in the model frame, Q14 (a point light: from the bounding-sphere
    /// centre).
    to_light_q14: [i32; 3],
    /// `tan θ` (Q8) by `n·l = cos θ` in 1/64 steps, `cos θ` floored at 1/128 so `tan θ ≤ 128`.
    tan_q8: [i32; 65],
    /// Lateral reach of the slope bias per level: directional, in Q8 depth units (the depth a
    /// slope of 1 gains over it); point, the cell's half-extent across the light in `W` units (the
    /// texels' share is added per sample).
    reach: [i32; MAX_LEVELS],
    /// Point lights: the width of a texel at distance `W`, in `W` units, is `W · texel_q16 >> 16`.
    texel_q16: i32,
    /// A fill-only descent stops at this level and below (cells ≤ 1 texel).
    stop_level: usize,
    order: SlotOrder,
    /// Whether this is a point light, and its depth scale (zero for a directional light).
    point: bool,
    point_depth: PointDepth,
    /// Look-ups that the tables above determine ([`LightFrame::derive`]).
    derived: Derived,
}

/// What a sample's shadow test looks up instead of computing, made once per light.
#[derive(Clone, Debug)]
struct Derived {
    /// By normal code: 0 when the normal faces away from the light (`n·l ≤ 0`), else 1 + the
    /// `tan_q8` index of its `n·l`.
    facing: [u8; NORMAL_COUNT],
    /// Directional lights: the whole depth bias by row and `facing` value; row `l + 1` is level
    /// `l`, and row 0 is level 0 again, so that one-pass's "as for the parent's level" is row `l`.
    slope: [[i32; 66]; MAX_LEVELS + 1],
}

impl Derived {
    const EMPTY: Derived = Derived {
        facing: [0; NORMAL_COUNT],
        slope: [[0; 66]; MAX_LEVELS + 1],
    };
}

/// `x` rounded (halves away from zero) and saturated to ±(2³¹ − 1), NaN to 0, in integer
/// arithmetic ([`round_to_i32`]).
fn to_i(x: f64) -> i32 {
    round_to_i32(x)
}

fn l1(a: Vec3) -> f64 {
    libm::fabs(a[0]) + libm::fabs(a[1]) + libm::fabs(a[2])
}

/// Two unit vectors across `axis` (a unit vector), completing a right-handed frame.
fn across(axis: Vec3) -> (Vec3, Vec3) {
    let helper = if libm::fabs(axis[1]) < 0.9 {
        [0.0, 1.0, 0.0]
    } else {
        [1.0, 0.0, 0.0]
    };
    let u = camera::normalize(camera::cross(helper, axis));
    (u, camera::cross(axis, u))
}

/// The ρ³ slots in order of their centre's distance along `travel` (the light's direction of
/// travel); ties (a light along an axis) keep slot order.
fn light_order(rho: usize, travel: Vec3) -> [u8; MAX_SLOTS] {
    let mut order = [0u8; MAX_SLOTS];
    let n = rho * rho * rho;
    let key = |s: usize| -> f64 {
        let ijk = [s % rho, (s / rho) % rho, s / (rho * rho)];
        camera::dot(travel, core::array::from_fn(|k| ijk[k] as f64))
    };
    for (i, o) in order.iter_mut().enumerate() {
        *o = i as u8; // beyond ρ³: never set in a mask
    }
    order[..n].sort_unstable_by(|&a, &b| {
        key(usize::from(a))
            .total_cmp(&key(usize::from(b)))
            .then(a.cmp(&b))
    });
    order
}

impl LightFrame {
    /// Sets up light space for the grid described by `header`, placed by `placement`, lit from
    /// `light_dir` (unit vector towards the light, world space), with a `map_size²` shadow map over
    /// the root cube's extent across the light.
    pub fn new(header: &Header, placement: &Placement, light_dir: Vec3, map_size: usize) -> Self {
        let mut frame = Self::UNSET;
        frame.set(header, placement, light_dir, map_size);
        frame
    }

    /// No light: a placeholder to [`LightFrame::set`] later, all zeros (a `static` of it takes no
    /// flash). Its frames would shadow every sample.
    pub const UNSET: LightFrame = LightFrame {
        root: [0; 3],
        disp: [[[0; 3]; SLOT_TABLE]; MAX_LEVELS],
        ext: [[0; 3]; MAX_LEVELS],
        bias: [0; MAX_LEVELS],
        to_light_q14: [0; 3],
        tan_q8: [0; 65],
        reach: [0; MAX_LEVELS],
        texel_q16: 0,
        stop_level: 0,
        order: SlotOrder::NONE,
        point: false,
        point_depth: PointDepth {
            depth_w0: 0,
            depth_scale: 0,
        },
        derived: Derived::EMPTY,
    };

    /// [`LightFrame::new`] in place: firmware keeps the frame in a `static` and sets it per frame,
    /// so that its 17 KB of tables are never built on the stack and copied out.
    pub fn set(
        &mut self,
        header: &Header,
        placement: &Placement,
        light_dir: Vec3,
        map_size: usize,
    ) {
        let travel = placement.to_model_dir(camera::normalize(camera::scale(light_dir, -1.0)));
        let (axis_u, axis_v) = across(travel);
        let axes = [axis_u, axis_v, travel];
        let side = header.side64;
        let origin = header.origin64;
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for corner in 0..8 {
            let p: Vec3 =
                core::array::from_fn(|k| origin[k] + if corner >> k & 1 != 0 { side } else { 0.0 });
            for k in 0..3 {
                let t = camera::dot(axes[k], p);
                lo[k] = lo[k].min(t);
                hi[k] = hi[k].max(t);
            }
        }
        let one = f64::from(1u32 << LIGHT_FRAC);
        let extent = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(1e-30);
        let s_uv = map_size as f64 * one / extent; // Q8 texels per model unit
        let s_d = 65535.0 * one / (hi[2] - lo[2]).max(1e-30); // Q8 depth units per model unit
        let scales = [s_uv, s_uv, s_d];
        let centre: Vec3 = origin.map(|o| o + 0.5 * side);
        let root =
            core::array::from_fn(|k| to_i((camera::dot(axes[k], centre) - lo[k]) * scales[k]));
        let rho = usize::from(header.rho);
        let (disp, ext) = (&mut self.disp, &mut self.ext);
        *disp = [[[0i32; 3]; SLOT_TABLE]; MAX_LEVELS];
        *ext = [[0i32; 3]; MAX_LEVELS];
        let mut stop_level = usize::from(header.depth);
        let mut cell = side;
        for level in 0..=usize::from(header.depth) {
            if level > 0 {
                let parent = cell;
                cell = parent / rho as f64;
                slot_dots(&axes, rho, parent, &mut disp[level], |k, x| {
                    to_i(x * scales[k])
                });
            }
            let h = 0.5 * cell;
            ext[level] = core::array::from_fn(|k| {
                to_i(libm::ceil(h * l1(axes[k]) * scales[k])) + level as i32 + 1
            });
            if ext[level][0].max(ext[level][1]) <= 1 << LIGHT_FRAC
                && stop_level == usize::from(header.depth)
            {
                stop_level = level;
            }
        }
        let bias = depth_bias(ext, header.depth, stop_level);
        // Depth (Q8) per texel of lateral distance, times the reach in texels.
        let reach = directional_reach(ext, header.depth, extent / map_size as f64 * s_d);
        self.set_directional(root, bias, reach, stop_level, rho, travel);
    }

    /// Sets up a point light at `light_pos` (world space) for the grid described by `header`, placed
    /// by `placement`, with a `map_size²` perspective shadow map aimed at the root cube's centre and
    /// just covering the cube. Frames with it are always two-pass (see the module's notes).
    ///
    /// # Errors
    /// [`LightError`] when the light is inside the sphere around the root cube, the map side is 0 or
    /// above [`MAX_POINT_MAP_SIZE`], or the input is not finite.
    pub fn point(
        header: &Header,
        placement: &Placement,
        light_pos: Vec3,
        map_size: usize,
    ) -> Result<Self, LightError> {
        if map_size == 0 || map_size > MAX_POINT_MAP_SIZE {
            return Err(LightError::MapSize(map_size));
        }
        let light = camera::scale(
            placement.to_model_dir(camera::sub(light_pos, placement.translation)),
            1.0 / placement.scale,
        );
        if !light.iter().all(|c| c.is_finite()) {
            return Err(LightError::NotFinite);
        }
        let side = header.side64;
        let origin = header.origin64;
        let centre: Vec3 = origin.map(|o| o + 0.5 * side);
        let to_centre = camera::sub(centre, light);
        let distance = libm::sqrt(camera::dot(to_centre, to_centre));
        if distance <= 0.5 * side * libm::sqrt(3.0) || !distance.is_finite() {
            return Err(LightError::PointInsideGrid);
        }
        // The light's axis points at the cube's centre; X, Y across it, Z along it (Z > 0 over the
        // whole cube, since the light is outside its sphere).
        let axis_d = camera::scale(to_centre, 1.0 / distance);
        let (axis_u, axis_v) = across(axis_d);
        let (mut z_lo, mut z_hi, mut tan) = (f64::INFINITY, 0.0f64, 0.0f64);
        for corner in 0..8 {
            let p: Vec3 =
                core::array::from_fn(|k| origin[k] + if corner >> k & 1 != 0 { side } else { 0.0 });
            let q = camera::sub(p, light);
            let z = camera::dot(axis_d, q);
            z_lo = z_lo.min(z);
            z_hi = z_hi.max(z);
            tan = tan
                .max(libm::fabs(camera::dot(axis_u, q)) / z)
                .max(libm::fabs(camera::dot(axis_v, q)) / z);
        }
        if !(z_lo > 0.0 && tan > 0.0 && tan.is_finite()) {
            return Err(LightError::PointInsideGrid);
        }
        // Texel (tu, tv) = N/2 + k·(X, Y)/Z, k = (N/2)/tan: the cube's projection just fits. As
        // homogeneous rows: Uh = k·X + (N/2)·Z, Vh = k·Y + (N/2)·Z, W = Z, all scaled by s so that
        // |Uh|, |Vh| ≤ N·W ≤ 2²⁹ over the cube.
        let n = map_size as f64;
        let half = 0.5 * n;
        let k = half / tan;
        let s = f64::from(1u32 << 29) / (n * z_hi);
        let rows = [
            camera::scale(
                camera::add(camera::scale(axis_u, k), camera::scale(axis_d, half)),
                s,
            ),
            camera::scale(
                camera::add(camera::scale(axis_v, k), camera::scale(axis_d, half)),
                s,
            ),
            camera::scale(axis_d, s),
        ];
        let root = rows.map(|r| to_i(camera::dot(r, to_centre)));
        let rho = usize::from(header.rho);
        let mut disp = [[[0i32; 3]; SLOT_TABLE]; MAX_LEVELS];
        let mut ext = [[0i32; 3]; MAX_LEVELS];
        let w_near = to_i(libm::floor(s * z_lo));
        let mut stop_level = usize::from(header.depth);
        let mut cell = side;
        for level in 0..=usize::from(header.depth) {
            if level > 0 {
                let parent = cell;
                cell = parent / rho as f64;
                slot_dots(&rows, rho, parent, &mut disp[level], |_, x| to_i(x));
            }
            let h = 0.5 * cell * s;
            let margin = level as i32 + 1;
            // Across: over the cell, |Uh/W − Uc/Wc| ≤ h·(k·|u|₁ + (N/2)·|d|₁) / (Wc − eW), since the
            // centre's texel lies in [0, N].
            let across_ext =
                |a: Vec3| to_i(libm::ceil(h * (k * l1(a) + half * l1(axis_d)))) + margin;
            ext[level] = [
                across_ext(axis_u),
                across_ext(axis_v),
                to_i(libm::ceil(h * l1(axis_d))) + margin,
            ];
            if ext[level][0].max(ext[level][1]) <= w_near - ext[level][2]
                && stop_level == usize::from(header.depth)
            {
                stop_level = level;
            }
        }
        let bias = depth_bias(&ext, header.depth, stop_level);
        let mut reach = [0i32; MAX_LEVELS];
        let mut cell = side;
        for (level, r) in reach
            .iter_mut()
            .enumerate()
            .take(usize::from(header.depth) + 1)
        {
            if level > 0 {
                cell /= rho as f64;
            }
            *r = to_i(0.5 * cell * s * l1(axis_u).max(l1(axis_v)));
        }
        let w_lo = libm::floor(s * z_lo) - 1.0;
        let w_hi = libm::ceil(s * z_hi) + 1.0;
        let to_light = camera::scale(
            camera::normalize(camera::sub(
                light,
                Sphere::from_bounds(header.bounds).center,
            )),
            16384.0,
        );
        let mut frame = LightFrame {
            root,
            disp,
            ext,
            bias,
            to_light_q14: [0; 3], // with the empty facing table: set below
            tan_q8: TAN_Q8,
            reach,
            // A texel at distance W spans W·2·tan/N across.
            texel_q16: to_i(2.0 * tan / n * 65536.0),
            stop_level,
            order: SlotOrder::new(light_order(rho, axis_d)),
            point: true,
            point_depth: PointDepth {
                depth_w0: to_i(w_lo),
                depth_scale: (65534.0 * 4_294_967_296.0 / (w_hi - w_lo)) as u64,
            },
            derived: Derived::EMPTY,
        };
        frame.set_to_light(to_light.map(to_i));
        frame.derive();
        Ok(frame)
    }

    /// Sets the direction to the light (model frame, Q14) and the facing table, which depends on
    /// it alone. The table always holds the facing of `to_light_q14` (all zeros for
    /// [`LightFrame::UNSET`]'s zero direction, as this loop makes them), so a frame set in place
    /// for an object whose rotation gives the same direction as the last one's keeps its table:
    /// 8192 normals, ~0.1 M instructions on a Cortex-M3, saved for every such object of a scene.
    /// The fields every directional light frame sets once its root, biases, reaches and stop level
    /// are known, `travel` being the light's direction of travel in model space; then the tables
    /// they determine.
    fn set_directional(
        &mut self,
        root: LightPos,
        bias: [i32; MAX_LEVELS],
        reach: [i32; MAX_LEVELS],
        stop_level: usize,
        rho: usize,
        travel: Vec3,
    ) {
        self.root = root;
        self.bias = bias;
        self.tan_q8 = TAN_Q8;
        self.reach = reach;
        self.texel_q16 = 0;
        self.stop_level = stop_level;
        self.order = SlotOrder::new(light_order(rho, travel));
        self.point = false;
        self.point_depth = PointDepth::default();
        self.set_to_light(travel.map(|t| to_i(-t * 16384.0)));
        self.derive();
    }

    fn set_to_light(&mut self, l: [i32; 3]) {
        if l == self.to_light_q14 {
            return;
        }
        self.to_light_q14 = l;
        let facing = self.derived.facing.chunks_exact_mut(32);
        for ((f, n), (_, hi)) in facing
            .zip(NORMALS_Q14.chunks_exact(32))
            .zip(normal::word_dot_ranges(l))
        {
            // Below 2¹⁴ (a cosine that floors to 0) every code of the word faces away from the
            // light (half the sphere): decided without its codes.
            if hi < 1 << 14 {
                f.fill(0);
                continue;
            }
            for (f, n) in f.iter_mut().zip(n) {
                let cos = normal::dot_q14(n, l) >> 14;
                *f = if cos <= 0 {
                    0
                } else {
                    1 + (cos >> 8).min(64) as u8
                };
            }
        }
    }

    /// The slope-bias table a sample's test looks up, from the biases and reaches: integer
    /// arithmetic only, so host and ARM make the same one.
    fn derive(&mut self) {
        if !self.point {
            for row in 0..=MAX_LEVELS {
                let level = row.max(1) - 1;
                for k in 1..66 {
                    self.derived.slope[row][k] = self.bias_at::<false>(level, 0, k - 1);
                }
            }
        }
    }

    /// The slot order, nearest to the light first.
    pub fn order(&self) -> &[u8; MAX_SLOTS] {
        self.order.slots()
    }

    /// Whether this is a point light (always two-pass).
    pub fn is_point(&self) -> bool {
        self.point
    }

    /// The level at which a descent that only fills the map stops (cells of at most one texel).
    pub fn stop_level(&self) -> usize {
        self.stop_level
    }

    /// The depth bias of a sample at `level` and light-space depth `d` (`D` or `W`) whose normal
    /// makes `n·l = cos_q14 / 16384` with the light, in light-space depth units (Q8 depth for a
    /// directional light, `W` for a point light).
    pub fn bias(&self, level: usize, d: i32, cos_q14: i32) -> i32 {
        let k = (cos_q14.max(0) >> 8).min(64) as usize;
        if self.point {
            self.bias_at::<true>(level, d, k)
        } else {
            self.bias_at::<false>(level, d, k)
        }
    }

    /// [`LightFrame::bias`] by the `tan_q8` index `k` of `n·l`.
    #[inline(always)]
    fn bias_at<const POINT: bool>(&self, level: usize, d: i32, k: usize) -> i32 {
        let tan = i64::from(self.tan_q8[k]);
        let reach = if POINT {
            // The texels' share grows with the distance from the light.
            let texel = (i64::from(d.max(0)) * i64::from(self.texel_q16)) >> 16;
            (3 * texel / 2).max(i64::from(self.reach[level]) + texel / 2)
        } else {
            i64::from(self.reach[level])
        };
        // Capped far beyond any depth range, so `d − bias` cannot overflow.
        let slope = ((reach * tan) >> 8).min(1 << 28) as i32;
        self.bias[level] + slope
    }
}

/// Constant bias per level: two depth half-extents of the larger of the cell and a stop-level cell.
fn depth_bias(ext: &[[i32; 3]; MAX_LEVELS], depth: u8, stop_level: usize) -> [i32; MAX_LEVELS] {
    let mut bias = [0i32; MAX_LEVELS];
    for level in 0..=usize::from(depth) {
        bias[level] = 2 * ext[level][2].max(ext[stop_level][2]);
    }
    bias
}

/// A directional light's slope-bias reach per level, in Q8 depth units, from the cells' half-extents
/// across the light (`ext`, Q8 texels) and the depth per texel (Q8): 1.5 texels, or half a texel
/// more than a wider cell's half-extent.
fn directional_reach(
    ext: &[[i32; 3]; MAX_LEVELS],
    depth: u8,
    depth_per_texel: f64,
) -> [i32; MAX_LEVELS] {
    let mut reach = [0i32; MAX_LEVELS];
    for level in 0..=usize::from(depth) {
        let across = f64::from(ext[level][0].max(ext[level][1])) / f64::from(1u32 << LIGHT_FRAC);
        reach[level] = to_i((across + 0.5).max(1.5) * depth_per_texel);
    }
    reach
}

/// `tan θ` in Q8 for `cos θ = i / 64`, the lower end of the bin `n·l ∈ [i/64, (i+1)/64)` the
/// sample's test indexes, so the bin's largest tangent (its true slope or steeper). Only bin 0
/// (`n·l < 1/64`, light within 0.9° of the surface) is floored, at `cos θ = 1/128` (tangent 128):
/// there the diffuse term the shadow could remove is below 1/64 of the light, under one RGB565
/// step. (Until issue 18 the cosine was floored at 1/8, tangent 8, so light below 7.1° above a
/// surface got too little bias and self-shadowed; bins 8..=64 are unchanged, so every sample lit
/// from 7.2° or more keeps its bias bit for bit.)
/// [`tan_table`]'s values, written out because every light frame (each object of a scene, each
/// frame) needs them and 65 soft-float square roots and divisions cost ~50 k instructions on a
/// Cortex-M3 each time. A test checks them against the formula.
const TAN_Q8: [i32; 65] = [
    32767, 16382, 8188, 5455, 4088, 3267, 2719, 2327, 2032, 1802, 1618, 1467, 1341, 1234, 1142,
    1062, 991, 929, 873, 823, 778, 737, 699, 665, 633, 603, 576, 550, 526, 504, 482, 462, 443, 425,
    408, 392, 376, 361, 347, 333, 320, 307, 294, 282, 270, 259, 248, 237, 226, 215, 205, 194, 184,
    173, 163, 152, 142, 131, 119, 108, 95, 81, 66, 46, 0,
];

/// [`TAN_Q8`] from its formula.
#[cfg(test)]
fn tan_table() -> [i32; 65] {
    let mut t = [0i32; 65];
    for (i, b) in t.iter_mut().enumerate() {
        let c = (i as f64 / 64.0).max(1.0 / 128.0);
        *b = to_i(libm::sqrt(1.0 - c * c) / c * 256.0);
    }
    t
}

/// Light-space position: U, V (Q8 texels), D (Q8 depth); for a point light, homogeneous `Uh`, `Vh`
/// and `W` (texel = `Uh / W`).
pub type LightPos = [i32; 3];

impl LightFrame {
    /// Map position of a light-space position: texel coordinates (Q8) and, for a point light, the
    /// reciprocal of `W` to scale extents with.
    #[inline(always)]
    fn texel<const POINT: bool>(p: LightPos) -> (i32, i32, (u32, u32)) {
        if POINT {
            let (r, shift) = recip(p[2] as u32);
            let sh = shift - LIGHT_FRAC;
            let r64 = i64::from(r);
            let u = ((i64::from(p[0]) * r64) >> sh) as i32;
            let v = ((i64::from(p[1]) * r64) >> sh) as i32;
            (u, v, (r, shift))
        } else {
            (p[0], p[1], (0, 0))
        }
    }

    /// The 16-bit map depth of light-space depth `d` (`D` or `W`).
    #[inline(always)]
    fn depth16<const POINT: bool>(&self, d: i32) -> u16 {
        if POINT {
            let pd = self.point_depth;
            let dz = (d - pd.depth_w0).max(0) as u64;
            ((dz * pd.depth_scale) >> 32).min(65534) as u16
        } else {
            (d >> LIGHT_FRAC).clamp(0, 65534) as u16
        }
    }

    /// Whether a sample at light-space `p` with attribute `attr` is in shadow in `map`, biased as
    /// for a cell at level `row - 1` (row 0: level 0; a point light: `row ≥ 1`).
    #[inline]
    fn in_shadow<const POINT: bool>(
        &self,
        map: &ShadowMap<'_>,
        row: usize,
        p: LightPos,
        attr: u16,
    ) -> bool {
        let k = self.derived.facing[usize::from(attr) & (NORMAL_COUNT - 1)];
        if k == 0 {
            return true;
        }
        let bias = if POINT {
            self.bias_at::<true>(row - 1, p[2], usize::from(k - 1))
        } else {
            self.derived.slope[row][usize::from(k)]
        };
        let (u, v, _) = Self::texel::<POINT>(p);
        map.at(u >> LIGHT_FRAC, v >> LIGHT_FRAC) < self.depth16::<POINT>(p[2] - bias)
    }

    /// Fills the footprint of a cell at `level`, light-space `p`.
    #[inline]
    fn cast<const POINT: bool>(&self, map: &mut ShadowMap<'_>, level: usize, p: LightPos) {
        let e = self.ext[level];
        let (u, v, _) = Self::texel::<POINT>(p);
        let (eu, ev) = if POINT {
            // Extents over the cell's nearest W (Q8 texels).
            let (r, shift) = recip((p[2] - e[2]).max(1) as u32);
            let sh = shift - LIGHT_FRAC;
            let r64 = i64::from(r);
            (
                ((i64::from(e[0]) * r64) >> sh) as i32 + 1,
                ((i64::from(e[1]) * r64) >> sh) as i32 + 1,
            )
        } else {
            (e[0], e[1])
        };
        map.fill(u, v, eu, ev, self.depth16::<POINT>(p[2]));
    }

    #[inline(always)]
    fn step(&self, p: LightPos, level: usize, slot: usize) -> LightPos {
        let d = self.disp[level][slot & 31];
        [p[0] + d[0], p[1] + d[1], p[2] + d[2]]
    }
}

/// One-pass shadows (directional lights): test and fill as samples are drawn, nearest to the light
/// first.
pub struct OnePass<'l, 'm, 'b> {
    light: &'l LightFrame,
    map: &'m mut ShadowMap<'b>,
}

impl ShadowHooks for OnePass<'_, '_, '_> {
    type Pos = LightPos;
    const FILL_CULLED: bool = true;
    /// Light order only above the stop level: below it nothing fills until the stop-level
    /// ancestor has been descended ([`OnePass::casts`]), so the order of its descendants cannot
    /// change what any of them is tested against, and the walk there takes the cheaper slot order.
    #[inline(always)]
    fn ordered(&self, level: usize) -> bool {
        level < self.light.stop_level
    }
    #[inline(always)]
    fn root(&self) -> LightPos {
        self.light.root
    }
    #[inline(always)]
    fn child(&self, p: LightPos, level: usize, slot: usize) -> LightPos {
        self.light.step(p, level, slot)
    }
    fn order(&self) -> &SlotOrder {
        &self.light.order
    }
    #[inline]
    fn drawn(&mut self, level: usize, p: LightPos, attr: u16) -> bool {
        // The map holds what neighbours drew, with their footprints and centre depths, and with
        // multi-level rendering a neighbour may be one level coarser: bias as for that level,
        // which is row `level` of the bias table.
        let shadowed = self.light.in_shadow::<false>(self.map, level, p, attr);
        self.casts(level, p);
        shadowed
    }
    /// Fills only at the light's level of detail or coarser. A cell finer than the stop level is
    /// at most a texel in the map: its stop-level ancestor fills that footprint once, after its
    /// whole subtree has been tested ([`ShadowHooks::descended`]), as the light pass of two-pass
    /// shadows fills at that level. Testing before the ancestor fills keeps a cell from shadowing
    /// itself; cells nearer the light were visited, and filled, before it (Duguet §5.3). On the
    /// bunny at 1 px this is 0.23 M fills instead of 1.3 M.
    #[inline]
    fn casts(&mut self, level: usize, p: LightPos) {
        if level <= self.light.stop_level {
            self.light.cast::<false>(self.map, level, p);
        }
    }
    #[inline]
    fn descended(&mut self, level: usize, p: LightPos) {
        if level == self.light.stop_level {
            self.light.cast::<false>(self.map, level, p);
        }
    }
    fn light_stop(&self, level: usize) -> bool {
        level >= self.light.stop_level
    }
}

/// The second pass of two-pass shadows: test only, against a map filled by [`fill_shadow_map`].
/// `POINT`: the light is a point light (perspective map).
pub struct TwoPass<'l, 'm, 'b, const POINT: bool> {
    light: &'l LightFrame,
    map: &'m ShadowMap<'b>,
}

impl<const POINT: bool> ShadowHooks for TwoPass<'_, '_, '_, POINT> {
    type Pos = LightPos;
    const FILL_CULLED: bool = false;
    #[inline(always)]
    fn root(&self) -> LightPos {
        self.light.root
    }
    #[inline(always)]
    fn child(&self, p: LightPos, level: usize, slot: usize) -> LightPos {
        self.light.step(p, level, slot)
    }
    #[inline]
    fn drawn(&mut self, level: usize, p: LightPos, attr: u16) -> bool {
        self.light.in_shadow::<POINT>(self.map, level + 1, p, attr)
    }
    #[inline(always)]
    fn casts(&mut self, _: usize, _: LightPos) {}
    fn light_stop(&self, level: usize) -> bool {
        level >= self.light.stop_level
    }
}

/// The first pass of two-pass shadows: the whole grid's depth from the light, down to cells of one
/// texel.
struct Fill<'l, 'm, 'b, const POINT: bool> {
    light: &'l LightFrame,
    map: &'m mut ShadowMap<'b>,
}

impl<const POINT: bool> ShadowHooks for Fill<'_, '_, '_, POINT> {
    type Pos = LightPos;
    const FILL_CULLED: bool = true;
    fn root(&self) -> LightPos {
        self.light.root
    }
    #[inline(always)]
    fn child(&self, p: LightPos, level: usize, slot: usize) -> LightPos {
        self.light.step(p, level, slot)
    }
    fn drawn(&mut self, _: usize, _: LightPos, _: u16) -> bool {
        false
    }
    #[inline]
    fn casts(&mut self, level: usize, p: LightPos) {
        self.light.cast::<POINT>(self.map, level, p);
    }
    fn light_stop(&self, level: usize) -> bool {
        level >= self.light.stop_level
    }
}

pub use crate::shade::ShadowMode;

/// Fills `map` (cleared first) with the grid's depth seen from the light. Returns nodes visited.
pub fn fill_shadow_map(
    grid: &TriGrid<'_>,
    frame: &TgFrame,
    light: &LightFrame,
    map: &mut ShadowMap<'_>,
) -> u32 {
    map.clear();
    if light.is_point() {
        fill_tg(grid, frame, &mut Fill::<true> { light, map })
    } else {
        fill_tg(grid, frame, &mut Fill::<false> { light, map })
    }
}

/// Renders a frame with shadows (`mode` other than `Off`), clearing the map first. For `TwoPass` the
/// returned stats count both passes' nodes. A point light is always two-pass.
pub fn render_tg_shadowed<S: SplatSink>(
    grid: &TriGrid<'_>,
    frame: &TgFrame,
    light: &LightFrame,
    map: &mut ShadowMap<'_>,
    mode: ShadowMode,
    sink: &mut S,
) -> Stats {
    match mode {
        ShadowMode::Off => crate::tg::render_tg(grid, frame, sink),
        ShadowMode::OnePass if !light.is_point() => {
            map.clear();
            render_tg_with(grid, frame, &mut OnePass { light, map }, sink)
        }
        ShadowMode::OnePass | ShadowMode::TwoPass => {
            let filled = fill_shadow_map(grid, frame, light, map);
            let mut stats = if light.is_point() {
                render_tg_with(grid, frame, &mut TwoPass::<true> { light, map }, sink)
            } else {
                render_tg_with(grid, frame, &mut TwoPass::<false> { light, map }, sink)
            };
            stats.nodes_visited += filled;
            stats
        }
    }
}

/// Light space shared by the objects of a scene (`crate::scene`): the orthographic frame of a
/// directional light over a world-space box holding every object, so that all of them fill and test
/// one shadow map at comparable depths and shadows fall from one object onto another.
///
/// Each object then gets its own [`LightFrame`] from [`LightFrame::in_space`]: the same world frame
/// seen from its model frame (its rows are the world axes turned by the object's rotation and
/// scaled by its scale, plus a constant), so per node it is still 3 adds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightSpace {
    /// World axes: `U`, `V` across the light, `D` its direction of travel.
    axes: [Vec3; 3],
    /// World coordinate of the box's minimum along each axis.
    lo: [f64; 3],
    /// Q8 texels (`U`, `V`) and Q8 depth units (`D`) per world unit.
    scales: [f64; 3],
    /// World units per texel.
    texel: f64,
}

impl LightSpace {
    /// The light space of a directional light towards `light_dir` (unit vector, world) over the
    /// world-space box `bounds` (min, max), with a `map_size²` shadow map just covering the box's
    /// extent across the light and the 16-bit depth its extent along it.
    pub fn directional(light_dir: Vec3, bounds: [Vec3; 2], map_size: usize) -> Self {
        let travel = camera::normalize(camera::scale(light_dir, -1.0));
        let (axis_u, axis_v) = across(travel);
        let axes = [axis_u, axis_v, travel];
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for corner in 0..8 {
            let p: Vec3 = core::array::from_fn(|k| bounds[corner >> k & 1][k]);
            for k in 0..3 {
                let t = camera::dot(axes[k], p);
                lo[k] = lo[k].min(t);
                hi[k] = hi[k].max(t);
            }
        }
        let one = f64::from(1u32 << LIGHT_FRAC);
        let extent = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(1e-30);
        let s_uv = map_size.max(1) as f64 * one / extent;
        let s_d = 65535.0 * one / (hi[2] - lo[2]).max(1e-30);
        LightSpace {
            axes,
            lo,
            scales: [s_uv, s_uv, s_d],
            texel: extent / map_size.max(1) as f64,
        }
    }

    /// Distance of a world point along the light's direction of travel, world units, from the
    /// box's side nearest the light: smaller is nearer the light.
    pub fn distance(&self, p: Vec3) -> f64 {
        camera::dot(self.axes[2], p) - self.lo[2]
    }
}

impl LightFrame {
    /// The light's tables for one object of a scene: the grid described by `header`, placed by
    /// `placement`, in the scene's shared light space (one shadow map for every object).
    pub fn in_space(header: &Header, placement: &Placement, space: &LightSpace) -> Self {
        let mut frame = Self::UNSET;
        frame.set_in_space(header, placement, space);
        frame
    }

    /// [`LightFrame::in_space`] in place: the scene renderer sets one frame per object in turn
    /// (firmware keeps it in a `static`, as for [`LightFrame::set`]), so that 17 KB of tables are
    /// neither built on the stack and copied out nor rebuilt where they cannot have changed (the
    /// facing table, `LightFrame::set_to_light`).
    pub fn set_in_space(&mut self, header: &Header, placement: &Placement, space: &LightSpace) {
        // Light coordinate k of a model point p: (s·Rᵀ·axis_k · p + axis_k · t − lo_k) · scale_k.
        let rows: [[f64; 4]; 3] = core::array::from_fn(|k| {
            let m = camera::scale(placement.to_model_dir(space.axes[k]), placement.scale);
            [
                m[0] * space.scales[k],
                m[1] * space.scales[k],
                m[2] * space.scales[k],
                (camera::dot(space.axes[k], placement.translation) - space.lo[k]) * space.scales[k],
            ]
        });
        let dir = |k: usize| -> Vec3 { [rows[k][0], rows[k][1], rows[k][2]] };
        let side = header.side64;
        let origin = header.origin64;
        let centre: Vec3 = origin.map(|o| o + 0.5 * side);
        let root = core::array::from_fn(|k| to_i(camera::dot(dir(k), centre) + rows[k][3]));
        let rho = usize::from(header.rho);
        let (disp, ext) = (&mut self.disp, &mut self.ext);
        *disp = [[[0i32; 3]; SLOT_TABLE]; MAX_LEVELS];
        *ext = [[0i32; 3]; MAX_LEVELS];
        let mut stop_level = usize::from(header.depth);
        let mut cell = side;
        for level in 0..=usize::from(header.depth) {
            if level > 0 {
                let parent = cell;
                cell = parent / rho as f64;
                slot_dots(
                    &[dir(0), dir(1), dir(2)],
                    rho,
                    parent,
                    &mut disp[level],
                    |_, x| to_i(x),
                );
            }
            let h = 0.5 * cell;
            ext[level] =
                core::array::from_fn(|k| to_i(libm::ceil(h * l1(dir(k)))) + level as i32 + 1);
            if ext[level][0].max(ext[level][1]) <= 1 << LIGHT_FRAC
                && stop_level == usize::from(header.depth)
            {
                stop_level = level;
            }
        }
        let bias = depth_bias(ext, header.depth, stop_level);
        let reach = directional_reach(ext, header.depth, space.texel * space.scales[2]);
        let travel = placement.to_model_dir(space.axes[2]);
        self.set_directional(root, bias, reach, stop_level, rho, travel);
    }
}

/// Lets a grid cast into a shadow map shared by a scene's objects, without clearing it: the first
/// pass of two-pass scene shadows, once per object (then [`render_tg_in_scene`] per object). A
/// directional light only. Returns nodes visited.
pub fn cast_shadow_map(
    grid: &TriGrid<'_>,
    frame: &TgFrame,
    light: &LightFrame,
    map: &mut ShadowMap<'_>,
) -> u32 {
    fill_tg(grid, frame, &mut Fill::<false> { light, map })
}

/// Renders one object of a scene against the scene's shared shadow map, which is not cleared:
/// - [`ShadowMode::OnePass`]: tests and fills as it draws. Call it for the objects in order of
///   their distance from the light, nearest first (Duguet §5.3 applied across objects). Where two
///   objects overlap along the light, a part of the later one nearer the light than a part of the
///   earlier one cannot shadow it: that part of the map was not filled yet when the earlier object
///   was drawn (the one-pass limitation, now between objects as well as within none).
/// - [`ShadowMode::TwoPass`]: tests only, against a map every object has cast into first
///   ([`cast_shadow_map`]).
/// - [`ShadowMode::Off`]: no shadows.
///
/// `light` comes from [`LightFrame::in_space`] (directional).
pub fn render_tg_in_scene<S: SplatSink>(
    grid: &TriGrid<'_>,
    frame: &TgFrame,
    light: &LightFrame,
    map: &mut ShadowMap<'_>,
    mode: ShadowMode,
    sink: &mut S,
) -> Stats {
    match mode {
        ShadowMode::Off => crate::tg::render_tg(grid, frame, sink),
        ShadowMode::OnePass => render_tg_with(grid, frame, &mut OnePass { light, map }, sink),
        ShadowMode::TwoPass => {
            render_tg_with(grid, frame, &mut TwoPass::<false> { light, map }, sink)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn light_facing_table_matches_the_formula_per_code() {
        let mut next = crate::testing::signed_uniform(0x2545_f491_u64);
        let mut light = LightFrame::UNSET;
        for _ in 0..100 {
            let v: [f64; 3] = core::array::from_fn(|_| next());
            let len = libm::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
            let l = v.map(|c| libm::round(c / len * 16384.0) as i32);
            light.set_to_light(l);
            for (code, n) in NORMALS_Q14.iter().enumerate() {
                let cos =
                    (i32::from(n[0]) * l[0] + i32::from(n[1]) * l[1] + i32::from(n[2]) * l[2])
                        >> 14;
                let want = if cos <= 0 {
                    0
                } else {
                    1 + (cos >> 8).min(64) as u8
                };
                assert_eq!(light.derived.facing[code], want, "code {code}, l {l:?}");
            }
        }
    }

    /// A depth-6 tri-grid header over the cube [-1, 1]³.
    fn header() -> Header {
        Header {
            version: 1,
            flags: 0,
            rho: 3,
            depth: 6,
            normal_bits: 13,
            material_bits: 0,
            block_log2: 12,
            origin: [-1.0; 3],
            side: 2.0,
            blocks: 1,
            crc_table_blocks: 1,
            bounds: [[-1.0; 3], [1.0; 3]],
            origin64: [-1.0; 3],
            side64: 2.0,
            bounds64: [[-1.0; 3], [1.0; 3]],
            brick_level: 0,
            bricks: 0,
            brick_table: 0,
        }
    }

    fn ijk(s: u8) -> [i32; 3] {
        let s = i32::from(s);
        [s % 3, s / 3 % 3, s / 9]
    }

    #[test]
    fn the_written_out_tangents_are_the_formula_s() {
        assert_eq!(TAN_Q8, tan_table());
    }

    #[test]
    fn sub_cells_nearer_the_light_come_first_and_ties_keep_slot_order() {
        let mut lights: Vec<Vec3> = Vec::new();
        for axis in 0..3 {
            for sign in [-1.0, 1.0] {
                let mut d = [0.0; 3];
                d[axis] = sign;
                lights.push(d); // exactly along an axis: layers of 9 tie
            }
        }
        lights.extend([
            [1.0, 1.0, 0.0],  // along a face diagonal: lines of 3 tie
            [1.0, -1.0, 1.0], // along a main diagonal
            [0.3, 0.8, -0.2], // general
            [1.0, 1e-9, 0.0], // grazing, all but tied
            camera::direction(-40.0, 60.0),
        ]);
        for l in lights {
            let frame = LightFrame::new(&header(), &Placement::IDENTITY, camera::normalize(l), 64);
            let order = frame.order();
            let mut seen = [false; 27];
            for &s in &order[..27] {
                assert!(!seen[usize::from(s)], "{l:?}: slot {s} twice");
                seen[usize::from(s)] = true;
            }
            assert!(order[27..]
                .iter()
                .enumerate()
                .all(|(i, &s)| usize::from(s) == 27 + i));
            // Distance from the light grows along the order: −l·ijk never decreases (up to rounding
            // for the general directions), and equal distances (exact when l's components are 0
            // or ±1) keep slot order.
            let key = |s: u8| -> f64 {
                let c = ijk(s);
                -(l[0] * f64::from(c[0]) + l[1] * f64::from(c[1]) + l[2] * f64::from(c[2]))
            };
            let exact = l.iter().all(|c| [-1.0, 0.0, 1.0].contains(c));
            for w in order[..27].windows(2) {
                let (a, b) = (key(w[0]), key(w[1]));
                assert!(a <= b + 1e-9, "{l:?}: slot {} after {}", w[1], w[0]);
                if exact && a == b {
                    assert!(w[0] < w[1], "{l:?}: tie out of slot order");
                }
            }
        }
        // Straight down: the top layer (j = 2) first, then j = 1, then j = 0, each in slot order.
        let down = LightFrame::new(&header(), &Placement::IDENTITY, [0.0, 1.0, 0.0], 64);
        let expected: [u8; 27] = core::array::from_fn(|i| {
            let layer = 2 - i / 9;
            let k = i % 9;
            (k % 3 + 3 * layer + 9 * (k / 3)) as u8
        });
        assert_eq!(down.order()[..27], expected);
    }

    #[test]
    fn the_acne_bias_grows_with_grazing_light_and_coarse_cells_and_stops_at_one_texel() {
        for map in [64, 256, 1024] {
            let f = LightFrame::new(&header(), &Placement::IDENTITY, [0.6, 0.8, 0.0], map);
            let stop = f.stop_level();
            assert!(stop > 0 && stop <= 6, "map {map}: stop level {stop}");
            let slope = |level: usize, cos: i32| f.bias(level, 0, cos) - f.bias[level];
            for level in 0..=6 {
                // The slope term grows as the light grazes (cos → 0) and is 0 head-on.
                assert_eq!(slope(level, 16384), 0);
                assert!(slope(level, 16384 / 16) > slope(level, 16384 / 2));
                assert!(slope(level, 16384 / 2) > 0, "map {map} level {level}");
                if level >= stop {
                    // At and below one texel: a one-texel cell's bias (1.5 texels of reach).
                    assert_eq!(f.bias[level], f.bias[stop]);
                    assert_eq!(slope(level, 4000), slope(stop, 4000));
                } else {
                    // Coarser samples (multi-level rendering) get more of both terms.
                    assert!(f.bias[level] > f.bias[level + 1]);
                    assert!(slope(level, 4000) > slope(level + 1, 4000));
                }
            }
            // Finer maps stop deeper.
            if map == 1024 {
                let coarse = LightFrame::new(&header(), &Placement::IDENTITY, [0.6, 0.8, 0.0], 64);
                assert!(f.stop_level() > coarse.stop_level());
            }
        }
        // A point light's texels widen with distance, and so does the fine levels' slope bias.
        let p = LightFrame::point(&header(), &Placement::IDENTITY, [0.0, 6.0, 0.0], 256).unwrap();
        let w = p.root[2];
        assert!(p.bias(6, 2 * w, 4000) > p.bias(6, w, 4000));
        assert!(p.bias(1, w, 4000) > p.bias(6, w, 4000));
    }

    #[test]
    fn a_point_light_maps_the_cube_into_the_shadow_map() {
        let h = header();
        for at in [[0.0, 6.0, 0.0], [4.0, 3.0, -2.5], [0.0, 0.0, -1.8]] {
            let f = LightFrame::point(&h, &Placement::IDENTITY, at, 256).unwrap();
            assert!(f.is_point());
            // The root's centre is on the light's axis: the middle of the map.
            let (u, v, _) = LightFrame::texel::<true>(f.root);
            assert!(
                (u - 128 * 256).abs() <= 2 && (v - 128 * 256).abs() <= 2,
                "{at:?}: {u} {v}"
            );
            // Every corner cell of the finest level lands inside the map, with W > 0.
            let mut p = f.root;
            for level in 1..=6 {
                p = f.step(p, level, 26);
            }
            let (u, v, _) = LightFrame::texel::<true>(p);
            assert!(p[2] > 0 && (0..256 * 256).contains(&u) && (0..256 * 256).contains(&v));
            // Depth grows away from the light.
            let near = f.depth16::<true>(f.root[2] - f.ext[0][2]);
            let far = f.depth16::<true>(f.root[2] + f.ext[0][2]);
            assert!(near < 1000 && far > 64000, "{near} {far}");
        }
        assert_eq!(
            LightFrame::point(&h, &Placement::IDENTITY, [0.0, 1.5, 0.0], 256).unwrap_err(),
            LightError::PointInsideGrid
        );
        assert_eq!(
            LightFrame::point(&h, &Placement::IDENTITY, [0.0, 5.0, 0.0], 0).unwrap_err(),
            LightError::MapSize(0)
        );
        assert_eq!(
            LightFrame::point(&h, &Placement::IDENTITY, [f64::NAN, 5.0, 0.0], 64).unwrap_err(),
            LightError::NotFinite
        );
    }
}

#[cfg(all(test, feature = "bake"))]
mod order_tests {
    #![allow(clippy::float_arithmetic)]
    use super::*;
    use crate::bake::{bake_grid, BakeOptions, TriMesh};
    use crate::camera::{Camera, View, STANDARD_VIEWS};
    use crate::splat::SampleSplat;
    use crate::tg::write::write_tg;
    use crate::tg::{RenderOptions, Verify};
    use std::vec::Vec;

    /// A bumpy height field, which shadows itself under an oblique light.
    fn terrain(n: u32) -> TriMesh {
        let mut m = TriMesh::default();
        for j in 0..=n {
            for i in 0..=n {
                let (x, z) = (
                    f64::from(i) / f64::from(n) * 2.0 - 1.0,
                    f64::from(j) / f64::from(n) * 2.0 - 1.0,
                );
                let y = 0.6 * libm::sin(7.0 * x) * libm::cos(6.0 * z);
                m.positions.push([x, y, z]);
            }
        }
        for j in 0..n {
            for i in 0..n {
                let a = j * (n + 1) + i;
                let (b, c, d) = (a + 1, a + n + 1, a + n + 2);
                m.triangles.push([a, c, b]);
                m.triangles.push([b, c, d]);
            }
        }
        m
    }

    /// One-pass shadows with the children in light order at every level, as the walk was before
    /// it took slot order below the stop level.
    struct OrderedEverywhere<'a, 'l, 'm, 'b>(&'a mut OnePass<'l, 'm, 'b>);

    impl ShadowHooks for OrderedEverywhere<'_, '_, '_, '_> {
        type Pos = LightPos;
        const FILL_CULLED: bool = true;
        fn ordered(&self, _: usize) -> bool {
            true
        }
        fn root(&self) -> LightPos {
            self.0.root()
        }
        fn child(&self, p: LightPos, level: usize, slot: usize) -> LightPos {
            self.0.child(p, level, slot)
        }
        fn order(&self) -> &SlotOrder {
            self.0.order()
        }
        fn drawn(&mut self, level: usize, p: LightPos, attr: u16) -> bool {
            self.0.drawn(level, p, attr)
        }
        fn casts(&mut self, level: usize, p: LightPos) {
            self.0.casts(level, p);
        }
        fn light_stop(&self, level: usize) -> bool {
            self.0.light_stop(level)
        }
        fn descended(&mut self, level: usize, p: LightPos) {
            self.0.descended(level, p);
        }
    }

    /// Every drawn sample's (level, index, shadowed), sorted.
    #[derive(Default)]
    struct Classes(Vec<(u8, u32, bool)>);
    impl SplatSink for Classes {
        fn splat(&mut self, s: &SampleSplat) {
            self.0.push((s.level, s.index, s.shadowed));
        }
    }

    #[test]
    fn slot_order_below_the_stop_level_shadows_every_sample_as_light_order_does() {
        let baked = bake_grid(&terrain(60), BakeOptions { rho: 3, depth: 5 }, None).unwrap();
        let bytes = write_tg(&baked, 12).unwrap();
        let grid = TriGrid::open(&bytes, Verify::Full).unwrap();
        let h = grid.header();
        let sphere = Sphere::from_bounds(h.bounds);
        let light = LightFrame::new(h, &Placement::IDENTITY, camera::direction(-40.0, 35.0), 64);
        assert!(
            light.stop_level() < usize::from(h.depth),
            "the test needs levels below the stop"
        );
        let mut depth = std::vec![0u16; 64 * 64];
        let views = STANDARD_VIEWS
            .iter()
            .map(|&(_, v)| v)
            .chain([View::new(30.0, 20.0, 0.6)]);
        for view in views {
            for cutoff_px in [1.0, 3.0] {
                let cam = Camera::orbit(sphere, view, 45.0);
                let opts = RenderOptions {
                    cutoff_px,
                    ..RenderOptions::default()
                };
                let frame = TgFrame::new(h, &Placement::IDENTITY, &cam, &opts).unwrap();
                let mut classes = [Classes::default(), Classes::default()];
                for (everywhere, out) in [false, true].into_iter().zip(&mut classes) {
                    let mut map = ShadowMap::new(&mut depth, 64);
                    map.clear();
                    let mut one = OnePass {
                        light: &light,
                        map: &mut map,
                    };
                    if everywhere {
                        render_tg_with(&grid, &frame, &mut OrderedEverywhere(&mut one), out);
                    } else {
                        render_tg_with(&grid, &frame, &mut one, out);
                    }
                    out.0.sort_unstable();
                }
                let shadowed = classes[0].0.iter().filter(|c| c.2).count();
                assert!(
                    shadowed > 0 && shadowed < classes[0].0.len(),
                    "{view:?}: {shadowed} shadowed"
                );
                // The walk in light order everywhere places the last level's splats by the exact
                // divide where the other uses the linearised one (within 1/32 px), so a few
                // splats at the edge of a pixel centre or of facing differ; every sample both
                // draw must be shadowed alike.
                let both: std::collections::BTreeMap<_, _> =
                    classes[1].0.iter().map(|c| ((c.0, c.1), c.2)).collect();
                let mut common = 0;
                for c in &classes[0].0 {
                    if let Some(&s) = both.get(&(c.0, c.1)) {
                        assert_eq!(s, c.2, "{view:?} at {cutoff_px} px: sample {c:?}");
                        common += 1;
                    }
                }
                assert!(
                    common * 100 >= 97 * classes[0].0.len().max(classes[1].0.len()),
                    "{view:?} at {cutoff_px} px: {common} of {} / {} in common",
                    classes[0].0.len(),
                    classes[1].0.len()
                );
            }
        }
    }
}
