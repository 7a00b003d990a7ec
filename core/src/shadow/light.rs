//! The light's per-frame set-up (floats allowed: once per light and grid, never per node): light
//! space, the displacement and extent tables, the biases, the sub-cell order of one-pass shadows,
//! and the light space a scene's objects share.

use super::{LIGHT_FRAC, MAX_POINT_MAP_SIZE};
use crate::camera::{self, Placement, Sphere, Vec3};
use crate::normal::{self, NORMALS_Q14, NORMAL_COUNT};
use crate::tg::frame::{round_to_i32, slot_dots, SlotTable, MAX_SLOTS, SLOT_TABLE};
use crate::tg::read::Header;
use crate::tg::traverse::SlotOrder;
use crate::tg::MAX_LEVELS;

/// Light-space position: U, V (Q8 texels), D (Q8 depth); for a point light, homogeneous `Uh`, `Vh`
/// and `W` (texel = `Uh / W`).
pub type LightPos = [i32; 3];

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
pub(super) struct PointDepth {
    pub(super) depth_w0: i32,
    pub(super) depth_scale: u64,
}

/// The light's integer tables for one grid and one light (per-frame setup).
#[derive(Clone, Debug)]
pub struct LightFrame {
    pub(super) root: [i32; 3],
    pub(super) disp: [SlotTable; MAX_LEVELS],
    /// Half-extents of a cell along U, V (Q8 texels; a point light: `Uh`, `Vh` units, to divide by
    /// the cell's nearest `W`) and D (`W`), per level.
    pub(super) ext: [[i32; 3]; MAX_LEVELS],
    pub(super) bias: [i32; MAX_LEVELS],
    /// Direction to the light in the model frame, Q14 (a point light: from the bounding-sphere
    /// centre).
    pub(super) to_light_q14: [i32; 3],
    /// `tan θ` (Q8) by `n·l = cos θ` in 1/64 steps, `cos θ` floored at 1/128 so `tan θ ≤ 128`.
    pub(super) tan_q8: [i32; 65],
    /// Lateral reach of the slope bias per level: directional, in Q8 depth units (the depth a
    /// slope of 1 gains over it); point, the cell's half-extent across the light in `W` units (the
    /// texels' share is added per sample).
    pub(super) reach: [i32; MAX_LEVELS],
    /// Point lights: the width of a texel at distance `W`, in `W` units, is `W · texel_q16 >> 16`.
    pub(super) texel_q16: i32,
    /// A fill-only descent stops at this level and below (cells ≤ 1 texel).
    pub(super) stop_level: usize,
    /// The least map side whose texels hold every position a cell at the stop level can have
    /// (the root plus, level by level, the least and greatest displacement of any slot), in
    /// integer arithmetic; `usize::MAX` when a position can fall below texel 0. A map at least
    /// this wide needs no bounds test at the stop level ([`super::hooks`]).
    pub(super) stop_side: usize,
    pub(super) order: SlotOrder,
    /// Whether this is a point light, and its depth scale (zero for a directional light).
    pub(super) point: bool,
    pub(super) point_depth: PointDepth,
    /// Look-ups that the tables above determine ([`LightFrame::derive`]).
    pub(super) derived: Derived,
}

/// The length of a row of `Derived::behind`: a power of two above the 66 `facing` values.
pub(super) const BEHIND_ROW: usize = 128;

/// What a sample's shadow test looks up instead of computing, made once per light.
#[derive(Clone, Debug)]
pub(super) struct Derived {
    /// By normal code: 0 when the normal faces away from the light (`n·l ≤ 0`), else 1 + the
    /// `tan_q8` index of its `n·l`.
    pub(super) facing: [u8; NORMAL_COUNT],
    /// Directional lights: by row and `facing` value, how far (Q8 depth) a sample must lie
    /// behind a texel's depth to be in its shadow, less one: the whole depth bias plus one map
    /// unit, less one (what `hooks::behind` compares). Row `l + 1` is level `l`, and row 0 is level 0 again, so that one-pass's
    /// "as for the parent's level" is row `l`.
    /// Rows are [`BEHIND_ROW`] long (66 are used) so that a `facing` value masked to the row
    /// indexes it without a bounds test.
    pub(super) behind: [[i32; BEHIND_ROW]; MAX_LEVELS + 1],
}

impl Derived {
    const EMPTY: Derived = Derived {
        facing: [0; NORMAL_COUNT],
        behind: [[0; BEHIND_ROW]; MAX_LEVELS + 1],
    };
}

/// [`LightFrame::stop_side`] of a light with `root` and displacements `disp`: every cell at
/// `stop_level` lies at the root plus one slot's displacement per level, so the sums of each
/// level's least and greatest displacement bound them (in `i64`: saturated tables cannot wrap).
fn stop_side(
    root: LightPos,
    disp: &[[[i32; 3]; SLOT_TABLE]; MAX_LEVELS],
    stop_level: usize,
) -> usize {
    let mut lo = [i64::from(root[0]), i64::from(root[1])];
    let mut hi = lo;
    for level in disp.iter().take(stop_level + 1).skip(1) {
        for k in 0..2 {
            lo[k] += level.iter().map(|d| i64::from(d[k])).min().unwrap_or(0);
            hi[k] += level.iter().map(|d| i64::from(d[k])).max().unwrap_or(0);
        }
    }
    if lo[0].min(lo[1]) < 0 {
        return usize::MAX;
    }
    usize::try_from((hi[0].max(hi[1]) >> LIGHT_FRAC) + 1).unwrap_or(usize::MAX)
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
        stop_side: usize::MAX,
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
            // A point light's map is never looked up without its bounds test.
            stop_side: usize::MAX,
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
        self.stop_side = stop_side(root, &self.disp, stop_level);
        self.order = SlotOrder::new(light_order(rho, travel));
        self.point = false;
        self.point_depth = PointDepth::default();
        self.set_to_light(travel.map(|t| to_i(-t * 16384.0)));
        self.derive();
    }

    pub(super) fn set_to_light(&mut self, l: [i32; 3]) {
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
                    self.derived.behind[row][k] =
                        self.bias_at::<false>(level, 0, k - 1) + (1 << LIGHT_FRAC) - 1;
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
    pub(super) fn bias_at<const POINT: bool>(&self, level: usize, d: i32, k: usize) -> i32 {
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

/// Constant bias per level: three depth half-extents of the larger of the cell and a stop-level
/// cell. (Two until one-pass shadows filled each stop-level cell's centre texel only: against the
/// f64 ray-cast shadows, 3 gives bunny std 1 px 26.81 -> 26.91 dB one-pass, 26.52 -> 26.59 two-pass,
/// dragon std 25.20 -> 25.17 / 24.97 -> 25.06; 4 gave the bunny 26.93 and the dragon 25.15.)
fn depth_bias(ext: &[[i32; 3]; MAX_LEVELS], depth: u8, stop_level: usize) -> [i32; MAX_LEVELS] {
    let mut bias = [0i32; MAX_LEVELS];
    for level in 0..=usize::from(depth) {
        bias[level] = 3 * ext[level][2].max(ext[stop_level][2]);
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
pub(super) const TAN_Q8: [i32; 65] = [
    32767, 16382, 8188, 5455, 4088, 3267, 2719, 2327, 2032, 1802, 1618, 1467, 1341, 1234, 1142,
    1062, 991, 929, 873, 823, 778, 737, 699, 665, 633, 603, 576, 550, 526, 504, 482, 462, 443, 425,
    408, 392, 376, 361, 347, 333, 320, 307, 294, 282, 270, 259, 248, 237, 226, 215, 205, 194, 184,
    173, 163, 152, 142, 131, 119, 108, 95, 81, 66, 46, 0,
];

/// [`TAN_Q8`] from its formula.
#[cfg(test)]
pub(super) fn tan_table() -> [i32; 65] {
    let mut t = [0i32; 65];
    for (i, b) in t.iter_mut().enumerate() {
        let c = (i as f64 / 64.0).max(1.0 / 128.0);
        *b = to_i(libm::sqrt(1.0 - c * c) / c * 256.0);
    }
    t
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
