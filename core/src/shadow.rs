//! Shadows from a directional light with a shadow map (Duguet & Drettakis §5.3).
//!
//! Light space is an orthographic frame: `U`, `V` across the light (Q8 shadow-map texels) and `D`
//! along it (distance from the light, Q8 of the 16-bit map depth). Like the camera's, it is linear in
//! the model point, so a node's light-space position is its parent's plus a per-level table entry:
//! 3 adds, no matrix per pixel (§5.3 "the associated projected displacement vectors").
//!
//! - [`OnePass`]: the ρ³ sub-cells are ordered once per light by their projection on the light
//!   direction, so cells nearer the light are always traversed first; each sample tests the map at its
//!   centre and then fills its footprint, in the same pass as the view. Subtrees the view culls are
//!   still walked (to the light's level of detail) because they may cast into the view, and
//!   backfacing samples cast without being drawn.
//! - [`TwoPass`]: the reference algorithm: [`fill_shadow_map`] renders the whole model's depth from
//!   the light, then the view pass tests each drawn sample against it.
//!
//! Self-shadowing acne: neighbours on the same surface, nearer the light, fill a sample's texel
//! with depths nearer than its own by up to the surface's slope times the distance between them. A
//! sample is therefore shadowed only when the map holds something nearer than its depth minus a bias
//! of (a) two depth half-extents of the larger of its cell and a one-texel cell, and (b) 1.5 texels
//! times the tangent of its normal's angle to the light (a 65-entry table per frame, indexed by
//! `n·l` from the Q14 normal table, the tangent clamped at 8). A sample facing away from the light
//! (`n·l ≤ 0`) is in shadow without a test, as in the reference renderer. The price of the bias is
//! that contact shadows start a little late.
//!
//! Setup (this file's `LightFrame::new`) uses floats; the per-node hooks are integer-only.

use crate::camera::{self, Placement, Vec3};
use crate::splat::{SplatSink, Stats};
use crate::tg::frame::{TgFrame, MAX_SLOTS};
use crate::tg::read::{Header, TriGrid};
use crate::tg::traverse::{fill_tg, render_tg_with, ShadowHooks};
use crate::tg::MAX_LEVELS;

/// Q8: sub-texel bits of `U`, `V` and sub-unit bits of `D`.
const LIGHT_FRAC: u32 = 8;

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
        self.depth[..self.size * self.size].fill(u16::MAX);
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
        let first = |c: i32, e: i32| (c - e - half + (1 << LIGHT_FRAC) - 1) >> LIGHT_FRAC;
        let last = |c: i32, e: i32| (c + e - half) >> LIGHT_FRAC;
        let (mut u0, mut u1, mut v0, mut v1) =
            (first(u, eu), last(u, eu), first(v, ev), last(v, ev));
        if u1 < u0 || v1 < v0 {
            (u0, v0) = (u >> LIGHT_FRAC, v >> LIGHT_FRAC);
            (u1, v1) = (u0, v0);
        }
        let n = self.size as i32 - 1;
        let (ua, ub) = (u0.max(0), u1.min(n));
        if ub < ua {
            return;
        }
        for tv in v0.max(0)..=v1.min(n) {
            let row = &mut self.depth[tv as usize * self.size..][..self.size];
            for t in &mut row[ua as usize..=ub as usize] {
                if d < *t {
                    *t = d;
                }
            }
        }
    }
}

/// The light's integer tables for one grid and one light direction (per-frame setup).
#[derive(Clone, Debug)]
pub struct LightFrame {
    root: [i32; 3],
    disp: [[[i32; 3]; MAX_SLOTS]; MAX_LEVELS],
    /// Half-extents of a cell along U, V (Q8 texels) and D, per level.
    ext: [[i32; 3]; MAX_LEVELS],
    bias: [i32; MAX_LEVELS],
    /// Direction to the light in the model frame, Q14.
    to_light_q14: [i32; 3],
    /// Slope bias (Q8 depth) by `n·l` in 1/64 steps.
    slope_bias: [i32; 65],
    /// A fill-only descent stops at this level and below (cells ≤ 1 texel).
    stop_level: usize,
    order: [u8; MAX_SLOTS],
}

impl LightFrame {
    /// Sets up light space for the grid described by `header`, placed by `placement`, lit from
    /// `light_dir` (unit vector towards the light, world space), with a `map_size²` shadow map over
    /// the root cube's extent across the light.
    pub fn new(header: &Header, placement: &Placement, light_dir: Vec3, map_size: usize) -> Self {
        let travel = placement.to_model_dir(camera::normalize(camera::scale(light_dir, -1.0)));
        // Any unit vector across the light, then the third by a cross product.
        let helper = if libm::fabs(travel[1]) < 0.9 {
            [0.0, 1.0, 0.0]
        } else {
            [1.0, 0.0, 0.0]
        };
        let axis_u = camera::normalize(camera::cross(helper, travel));
        let axis_v = camera::cross(travel, axis_u);
        let axes = [axis_u, axis_v, travel];
        let side = f64::from(header.side);
        let origin = header.origin.map(f64::from);
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
        let across = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(1e-30);
        let s_uv = map_size as f64 * one / across; // Q8 texels per model unit
        let s_d = 65535.0 * one / (hi[2] - lo[2]).max(1e-30); // Q8 depth units per model unit
        let scales = [s_uv, s_uv, s_d];
        let to_i = |x: f64| libm::round(x) as i32;
        let centre: Vec3 = origin.map(|o| o + 0.5 * side);
        let root =
            core::array::from_fn(|k| to_i((camera::dot(axes[k], centre) - lo[k]) * scales[k]));
        let rho = usize::from(header.rho);
        let mut disp = [[[0i32; 3]; MAX_SLOTS]; MAX_LEVELS];
        let mut ext = [[0i32; 3]; MAX_LEVELS];
        let mut bias = [0i32; MAX_LEVELS];
        let mut stop_level = usize::from(header.depth);
        let mut cell = side;
        for level in 0..=usize::from(header.depth) {
            if level > 0 {
                let parent = cell;
                cell = parent / rho as f64;
                for (s, d) in disp[level].iter_mut().enumerate().take(rho * rho * rho) {
                    let ijk = [s % rho, (s / rho) % rho, s / (rho * rho)];
                    let off: Vec3 = core::array::from_fn(|k| {
                        ((ijk[k] as f64 + 0.5) / rho as f64 - 0.5) * parent
                    });
                    *d = core::array::from_fn(|k| to_i(camera::dot(axes[k], off) * scales[k]));
                }
            }
            let h = 0.5 * cell;
            let l1 = |a: Vec3| libm::fabs(a[0]) + libm::fabs(a[1]) + libm::fabs(a[2]);
            ext[level] = core::array::from_fn(|k| {
                to_i(libm::ceil(h * l1(axes[k]) * scales[k])) + level as i32 + 1
            });
            if ext[level][0].max(ext[level][1]) <= 1 << LIGHT_FRAC
                && stop_level == usize::from(header.depth)
            {
                stop_level = level;
            }
        }
        for level in 0..=usize::from(header.depth) {
            bias[level] = 2 * ext[level][2].max(ext[stop_level][2]);
        }
        // Depth (Q8) per texel of lateral distance, times 1.5 texels, times tan θ.
        let depth_per_texel = across / map_size as f64 * s_d;
        let mut slope_bias = [0i32; 65];
        for (i, b) in slope_bias.iter_mut().enumerate() {
            let c = (i as f64 / 64.0).max(1.0 / 8.0);
            let tan = (libm::sqrt(1.0 - c * c) / c).min(8.0);
            *b = to_i(1.5 * depth_per_texel * tan);
        }
        let to_light_q14 = travel.map(|t| to_i(-t * 16384.0));
        // Slots in order of their centre's distance from the light; ties (light along an axis) keep
        // slot order, which is safe: cells that tie cannot shadow each other.
        let mut order = [0u8; MAX_SLOTS];
        let n = rho * rho * rho;
        let key = |s: usize| -> f64 {
            let ijk = [s % rho, (s / rho) % rho, s / (rho * rho)];
            camera::dot(travel, core::array::from_fn(|k| ijk[k] as f64))
        };
        for (i, o) in order.iter_mut().enumerate() {
            *o = i as u8;
        }
        order[..n].sort_unstable_by(|&a, &b| {
            key(usize::from(a))
                .total_cmp(&key(usize::from(b)))
                .then(a.cmp(&b))
        });
        for (i, o) in order.iter_mut().enumerate().skip(n) {
            *o = i as u8; // beyond ρ³: never set in a mask
        }
        LightFrame {
            root,
            disp,
            ext,
            bias,
            to_light_q14,
            slope_bias,
            stop_level,
            order,
        }
    }

    /// The slot order, nearest to the light first.
    pub fn order(&self) -> &[u8; MAX_SLOTS] {
        &self.order
    }
}

/// Light-space position: U, V (Q8 texels), D (Q8 depth).
pub type LightPos = [i32; 3];

impl LightFrame {
    /// Whether a sample at `level`, light-space `p`, attribute `attr` is in shadow in `map`.
    #[inline]
    fn in_shadow(&self, map: &ShadowMap<'_>, level: usize, p: LightPos, attr: u16) -> bool {
        let n = crate::normal::NORMALS_Q14[usize::from(attr) & (crate::normal::NORMAL_COUNT - 1)];
        let l = self.to_light_q14;
        let cos = (i32::from(n[0]) * l[0] + i32::from(n[1]) * l[1] + i32::from(n[2]) * l[2]) >> 14;
        if cos <= 0 {
            return true;
        }
        let bias = self.bias[level] + self.slope_bias[(cos >> 8).min(64) as usize];
        map.at(p[0] >> LIGHT_FRAC, p[1] >> LIGHT_FRAC) < depth16(p[2] - bias)
    }
}

#[inline(always)]
fn depth16(d: i32) -> u16 {
    (d >> LIGHT_FRAC).clamp(0, 65534) as u16
}

/// One-pass shadows: test and fill as samples are drawn, nearest to the light first.
pub struct OnePass<'l, 'm, 'b> {
    light: &'l LightFrame,
    map: &'m mut ShadowMap<'b>,
}

impl ShadowHooks for OnePass<'_, '_, '_> {
    type Pos = LightPos;
    const ORDERED: bool = true;
    const FILL_CULLED: bool = true;
    #[inline(always)]
    fn root(&self) -> LightPos {
        self.light.root
    }
    #[inline(always)]
    fn child(&self, p: LightPos, level: usize, slot: usize) -> LightPos {
        let d = self.light.disp[level][slot];
        [p[0] + d[0], p[1] + d[1], p[2] + d[2]]
    }
    fn order(&self) -> &[u8; MAX_SLOTS] {
        &self.light.order
    }
    #[inline]
    fn drawn(&mut self, level: usize, p: LightPos, attr: u16) -> bool {
        let shadowed = self.light.in_shadow(self.map, level, p, attr);
        self.casts(level, p);
        shadowed
    }
    #[inline]
    fn casts(&mut self, level: usize, p: LightPos) {
        let e = self.light.ext[level];
        self.map.fill(p[0], p[1], e[0], e[1], depth16(p[2]));
    }
    fn light_stop(&self, level: usize) -> bool {
        level >= self.light.stop_level
    }
}

/// The second pass of two-pass shadows: test only, against a map filled by [`fill_shadow_map`].
pub struct TwoPass<'l, 'm, 'b> {
    light: &'l LightFrame,
    map: &'m ShadowMap<'b>,
}

impl ShadowHooks for TwoPass<'_, '_, '_> {
    type Pos = LightPos;
    const ORDERED: bool = false;
    const FILL_CULLED: bool = false;
    #[inline(always)]
    fn root(&self) -> LightPos {
        self.light.root
    }
    #[inline(always)]
    fn child(&self, p: LightPos, level: usize, slot: usize) -> LightPos {
        let d = self.light.disp[level][slot];
        [p[0] + d[0], p[1] + d[1], p[2] + d[2]]
    }
    fn order(&self) -> &[u8; MAX_SLOTS] {
        &self.light.order
    }
    #[inline]
    fn drawn(&mut self, level: usize, p: LightPos, attr: u16) -> bool {
        self.light.in_shadow(self.map, level, p, attr)
    }
    #[inline(always)]
    fn casts(&mut self, _: usize, _: LightPos) {}
    fn light_stop(&self, level: usize) -> bool {
        level >= self.light.stop_level
    }
}

/// The first pass of two-pass shadows: the whole grid's depth from the light, down to cells of one
/// texel. Returns the nodes visited.
struct Fill<'l, 'm, 'b> {
    light: &'l LightFrame,
    map: &'m mut ShadowMap<'b>,
}

impl ShadowHooks for Fill<'_, '_, '_> {
    type Pos = LightPos;
    const ORDERED: bool = false;
    const FILL_CULLED: bool = true;
    fn root(&self) -> LightPos {
        self.light.root
    }
    #[inline(always)]
    fn child(&self, p: LightPos, level: usize, slot: usize) -> LightPos {
        let d = self.light.disp[level][slot];
        [p[0] + d[0], p[1] + d[1], p[2] + d[2]]
    }
    fn order(&self) -> &[u8; MAX_SLOTS] {
        &self.light.order
    }
    fn drawn(&mut self, _: usize, _: LightPos, _: u16) -> bool {
        false
    }
    #[inline]
    fn casts(&mut self, level: usize, p: LightPos) {
        let e = self.light.ext[level];
        self.map.fill(p[0], p[1], e[0], e[1], depth16(p[2]));
    }
    fn light_stop(&self, level: usize) -> bool {
        level >= self.light.stop_level
    }
}

/// Which shadow algorithm a frame uses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ShadowMode {
    /// No shadows: no map, no light tables.
    #[default]
    Off,
    /// One pass, children in light order (§5.3).
    OnePass,
    /// Shadow map first, then the view.
    TwoPass,
}

/// Fills `map` (cleared first) with the grid's depth seen from the light. Returns nodes visited.
pub fn fill_shadow_map(
    grid: &TriGrid<'_>,
    frame: &TgFrame,
    light: &LightFrame,
    map: &mut ShadowMap<'_>,
) -> u32 {
    map.clear();
    fill_tg(grid, frame, &mut Fill { light, map })
}

/// Renders a frame with shadows (`mode` other than `Off`), clearing the map first. For `TwoPass` the
/// returned stats count both passes' nodes.
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
        ShadowMode::OnePass => {
            map.clear();
            render_tg_with(grid, frame, &mut OnePass { light, map }, sink)
        }
        ShadowMode::TwoPass => {
            let filled = fill_shadow_map(grid, frame, light, map);
            let mut stats = render_tg_with(grid, frame, &mut TwoPass { light, map }, sink);
            stats.nodes_visited += filled;
            stats
        }
    }
}
