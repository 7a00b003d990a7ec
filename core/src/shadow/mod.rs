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
//!   still walked (to the light's level of detail) because they may cast into the view, unless
//!   their normal cone faces away from the light (on a closed surface such samples lie behind the
//!   lit side along every light ray), and backfacing samples cast without being drawn. A cell at
//!   the light's level of detail (about a texel) fills the texel under its centre once its
//!   subtree has been tested. A light exactly along an axis makes whole layers
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
//! and later for coarse samples. A directional light's test is done in the light's Q8 depth units,
//! `(texel << 8) + bias + 256 ≤ depth`: the same answer as comparing the texel with the biased
//! depth rounded down to 16 bits, for every depth inside the root cube, without that clamp.
//!
//! Memory: the map is borrowed ([`ShadowMap::new`]), so a frame without shadows allocates none, and
//! firmware built without the `shadows` feature compiles no code from this module (the traversal's
//! hooks are then the zero-sized `NoShadows`).
//!
//! Setup (`LightFrame::new`, `LightFrame::point`) uses floats; the per-node hooks are integer-only.

mod hooks;
mod light;

pub(crate) use hooks::Fill;
pub use hooks::{OnePass, TwoPass};
pub use light::{LightError, LightFrame, LightPos, LightSpace};

use crate::camera::Placement;
use crate::frame::{RenderOptions, Walk};
use crate::splat::{ColorSink, SplatSink, Stats};
use crate::tg::frame::TgFrame;
use crate::tg::read::TriGrid;
use crate::tg::traverse::{fill_tg, render_tg_with};

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
    /// When the buffer is shorter than `size²` (or `size²` overflows).
    pub fn new(depth: &'a mut [u16], size: usize) -> Self {
        assert!(
            size.checked_mul(size).is_some_and(|n| depth.len() >= n),
            "shadow map buffer too small"
        );
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

    /// The texel `(u, v)`, if it is in the map.
    #[inline(always)]
    fn texel_mut(&mut self, u: i32, v: i32) -> Option<&mut u16> {
        texel_at(self.depth, self.size, u, v)
    }

    /// The depths as [`Texels`], for a loop that keeps their address and side in registers.
    #[inline(always)]
    fn texels(&mut self) -> Texels<'_> {
        Texels {
            depth: &mut self.depth[..self.size * self.size],
            size: self.size,
        }
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

/// A shadow map's `size²` depths, borrowed.
struct Texels<'a> {
    depth: &'a mut [u16],
    size: usize,
}

impl Texels<'_> {
    /// The texel `(u, v)`, if it is in the map.
    #[inline(always)]
    fn at_mut(&mut self, u: i32, v: i32) -> Option<&mut u16> {
        texel_at(self.depth, self.size, u, v)
    }

    /// [`Texels::at_mut`]; with `IN_MAP`, for a texel the caller knows is in the map (a cell at
    /// the stop level of a light whose `stop_side` is at most this map's side),
    /// without the test.
    #[inline(always)]
    #[allow(unsafe_code)]
    fn at_mut_in<const IN_MAP: bool>(&mut self, u: i32, v: i32) -> Option<&mut u16> {
        if IN_MAP {
            let at = v as usize * self.size + u as usize;
            debug_assert!((u as u32 as usize) < self.size && (v as u32 as usize) < self.size);
            // SAFETY: the light's integer bounds on every stop-level position (`stop_side`)
            // put `u, v` in `0..size`, so `at < size² ≤ depth.len()`.
            Some(unsafe { self.depth.get_unchecked_mut(at) })
        } else {
            self.at_mut(u, v)
        }
    }

    /// Whether every stop-level texel of `light` is in this map.
    #[inline(always)]
    fn holds_stop_level(&self, light: &LightFrame) -> bool {
        self.size >= light.stop_side
    }
}

/// Texel `(u, v)` of the `size × size` depths at the start of `depth`, if it is in the map.
/// `depth` holds at least `size²` (as [`ShadowMap::new`] checks).
#[inline(always)]
#[allow(unsafe_code)]
fn texel_at(depth: &mut [u16], size: usize, u: i32, v: i32) -> Option<&mut u16> {
    if (u as u32 as usize) < size && (v as u32 as usize) < size {
        let at = v as usize * size + u as usize;
        debug_assert!(at < depth.len());
        // SAFETY: `u, v < size` make `at < size² ≤ depth.len()` (a second bounds check here cost
        // the one-pass frame 3 instructions a sample).
        Some(unsafe { depth.get_unchecked_mut(at) })
    } else {
        None
    }
}

pub use crate::shade::ShadowMode;

/// Why a tri-grid frame cannot have the shadows its options ask for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ShadowSetupError {
    /// The map buffer holds fewer depths than the options' side² (`need`), or the side is 0.
    Map {
        /// Depths the map needs.
        need: u32,
        /// Depths the buffer has.
        given: u32,
    },
    /// One-pass shadows of a point light (Duguet §5.3's sub-cell order needs one light
    /// direction): a point light is two-pass.
    OnePassPointLight,
    /// The light cannot be set up.
    Light(LightError),
}

/// A tri-grid frame with the shadows its options ask for, ready to walk ([`Walk`]): the light's
/// tables set, the map borrowed.
pub struct ShadowedWalk<'a, 'g> {
    grid: &'a TriGrid<'g>,
    frame: &'a TgFrame,
    light: &'a LightFrame,
    map: ShadowMap<'a>,
    mode: ShadowMode,
}

impl<'a, 'g> ShadowedWalk<'a, 'g> {
    /// Sets the light's tables in `light` for `grid` (the options' directional light, or their
    /// point light), checking `map` against the options' side.
    ///
    /// # Errors
    /// [`ShadowSetupError`]: a map smaller than the options' side², one-pass shadows of a point
    /// light, a light that cannot be set up.
    pub fn new(
        grid: &'a TriGrid<'g>,
        frame: &'a TgFrame,
        options: &RenderOptions,
        map: &'a mut [u16],
        light: &'a mut LightFrame,
    ) -> Result<Self, ShadowSetupError> {
        let side = options.shadow_map_size;
        let need = side.checked_mul(side).filter(|&n| n > 0);
        if need.is_none_or(|n| n > map.len()) {
            return Err(ShadowSetupError::Map {
                need: need.map_or(u32::MAX, |n| n.min(u32::MAX as usize) as u32),
                given: map.len().min(u32::MAX as usize) as u32,
            });
        }
        let header = grid.header();
        let placement = Placement::IDENTITY;
        match options.light_position {
            None => light.set(header, &placement, options.light_dir, side),
            Some(_) if options.shadows == ShadowMode::OnePass => {
                return Err(ShadowSetupError::OnePassPointLight)
            }
            Some(at) => {
                *light = LightFrame::point(header, &placement, at, side)
                    .map_err(ShadowSetupError::Light)?
            }
        }
        Ok(Self {
            grid,
            frame,
            light,
            map: ShadowMap::new(map, side),
            mode: options.shadows,
        })
    }
}

impl Walk for ShadowedWalk<'_, '_> {
    fn walk<S: ColorSink>(&mut self, sink: &mut S) -> Stats {
        render_tg_shadowed(
            self.grid,
            self.frame,
            self.light,
            &mut self.map,
            self.mode,
            sink,
        )
    }
}

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

#[cfg(all(test, feature = "bake"))]
mod order_tests;
#[cfg(test)]
mod tests;
