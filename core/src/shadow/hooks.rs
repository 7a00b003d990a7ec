//! The shadow test and fill per node and per sample (Duguet §5.3): integer only, the hooks the
//! tri-grid traversal calls ([`ShadowHooks`]): light-space positions by 3 adds, the map tested at
//! a sample's centre and filled over its footprint.
#![deny(clippy::float_arithmetic)]

use super::light::{LightFrame, LightPos, BEHIND_ROW};
use super::{ShadowMap, LIGHT_FRAC};
use crate::fixed::recip;
use crate::normal::{self, NORMALS_Q14, NORMAL_COUNT};
use crate::tg::hooks::{drawn_each, each_slot};
use crate::tg::traverse::{ShadowHooks, SlotOrder};

/// By normal-cone class ([`crate::tg::frame::CONE_ANGLES_DEG`]): a cell whose normal `n` has
/// `n · l` (Q14 × Q14, `l` the direction to the light) below this faces away from the light at
/// every sample of its subtree, `n · l < −sin(θ + 0.5°)` (the margin for the Q14 normals and
/// direction); classes 0 and 7 bound nothing. Checked against the angles by a test.
pub(super) const UNLIT_Q28: [i32; 8] = [
    i32::MIN,
    -21_061_203,
    -39_677_287,
    -71_736_255,
    -115_564_443,
    -174_334_883,
    -233_634_328,
    i32::MIN,
];

/// Whether a texel holding `nearest` shadows a directional light's sample at Q8 depth `d` (1) or
/// not (0), with `behind` from `Derived::behind` (its bias plus one map unit, less one):
/// `nearest < depth16(d − bias)`, compared in Q8 without clamping `d − bias` (the same answer for
/// every depth in the root cube, whose extent along the light the map's 16 bits span), as the
/// sign of `nearest · 2⁸ + behind − d` (both terms within ±2²⁶ there): two instructions fewer a
/// sample than a compare and its flag.
#[inline(always)]
fn behind(nearest: u16, d: i32, behind: i32) -> u32 {
    ((i32::from(nearest) << LIGHT_FRAC) + behind).wrapping_sub(d) as u32 >> 31
}

impl LightFrame {
    /// Map position of a light-space position: texel coordinates (Q8) and, for a point light, the
    /// reciprocal of `W` to scale extents with.
    #[inline(always)]
    pub(super) fn texel<const POINT: bool>(p: LightPos) -> (i32, i32, (u32, u32)) {
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
    pub(super) fn depth16<const POINT: bool>(&self, d: i32) -> u16 {
        if POINT {
            let pd = self.point_depth;
            let dz = (d - pd.depth_w0).max(0) as u64;
            ((dz * pd.depth_scale) >> 32).min(65534) as u16
        } else {
            // Saturating to the full 16 bits is one `usat` on Armv7-M (to 65534 it was five
            // instructions a sample); a depth at 65535 casts nothing, as the cleared map.
            (d >> LIGHT_FRAC).clamp(0, 65535) as u16
        }
    }

    /// Whether a sample at light-space `p` with attribute `attr` is in shadow in `map`, biased as
    /// for a cell at level `row - 1` (row 0: level 0; a point light: `row ≥ 1`).
    #[inline]
    pub(super) fn in_shadow<const POINT: bool>(
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
        let (u, v, _) = Self::texel::<POINT>(p);
        let nearest = map.at(u >> LIGHT_FRAC, v >> LIGHT_FRAC);
        if POINT {
            let bias = self.bias_at::<true>(row - 1, p[2], usize::from(k - 1));
            nearest < self.depth16::<POINT>(p[2] - bias)
        } else {
            behind(
                nearest,
                p[2],
                self.derived.behind[row][usize::from(k) & (BEHIND_ROW - 1)],
            ) != 0
        }
    }

    /// Fills the footprint of a cell at `level`, light-space `p`.
    #[inline]
    pub(super) fn cast<const POINT: bool>(
        &self,
        map: &mut ShadowMap<'_>,
        level: usize,
        p: LightPos,
    ) {
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

    /// Fills the one texel under the centre of a cell at the stop level (directional light): such
    /// a cell is smaller than a texel, so its centre's texel is the one it covers most, and the
    /// general footprint (up to 2×2, 60 instructions) both cost a quarter of a one-pass frame and
    /// spread its depth onto texels a neighbour's sample is tested in (bunny std 1 px: 26.81 dB
    /// either way).
    #[inline(always)]
    pub(super) fn cast_centre(&self, map: &mut ShadowMap<'_>, p: LightPos) {
        if let Some(t) = map.texel_mut(p[0] >> LIGHT_FRAC, p[1] >> LIGHT_FRAC) {
            *t = (*t).min(self.depth16::<false>(p[2]));
        }
    }

    /// [`LightFrame::in_shadow`] then [`LightFrame::cast_centre`] of a sample at the stop level
    /// (directional light), with one look-up of its texel: the test reads the texel before the
    /// sample fills it, so a sample never shadows itself.
    #[inline(always)]
    pub(super) fn test_and_fill(
        &self,
        map: &mut ShadowMap<'_>,
        row: usize,
        p: LightPos,
        attr: u16,
    ) -> bool {
        let k = self.derived.facing[usize::from(attr) & (NORMAL_COUNT - 1)];
        if k == 0 {
            // Turned from the light: in shadow, and it casts nothing the lit side does not
            // ([`LightFrame::unlit`]).
            return true;
        }
        let Some(t) = map.texel_mut(p[0] >> LIGHT_FRAC, p[1] >> LIGHT_FRAC) else {
            return false;
        };
        let nearest = *t;
        *t = nearest.min(self.depth16::<false>(p[2]));
        behind(
            nearest,
            p[2],
            self.derived.behind[row][usize::from(k) & (BEHIND_ROW - 1)],
        ) != 0
    }

    /// Whether every sample below a cell with normal `code` and cone `class` faces away from
    /// the light: on a closed surface such samples lie behind the lit side along every light
    /// ray (a ray enters a solid through a face turned from the light and leaves it through one
    /// turned towards it, nearer the light), so they never hold a texel's nearest depth.
    #[inline(always)]
    pub(super) fn unlit(&self, class: usize, code: usize) -> bool {
        normal::dot_q14(&NORMALS_Q14[code & (NORMAL_COUNT - 1)], self.to_light_q14)
            < UNLIT_Q28[class & 7]
    }

    #[inline(always)]
    pub(super) fn step(&self, p: LightPos, level: usize, slot: usize) -> LightPos {
        let d = self.disp[level][slot & 31];
        [p[0] + d[0], p[1] + d[1], p[2] + d[2]]
    }
}

/// One-pass shadows (directional lights): test and fill as samples are drawn, nearest to the light
/// first.
pub struct OnePass<'l, 'm, 'b> {
    pub(crate) light: &'l LightFrame,
    pub(crate) map: &'m mut ShadowMap<'b>,
}

impl OnePass<'_, '_, '_> {
    /// Fills the footprints of the children `mask` of a cell at `level` (= `S − 1`) at `p`.
    #[inline]
    fn fill_children(&mut self, level: usize, p: LightPos, mask: u32) {
        if self.map.texels().holds_stop_level(self.light) {
            self.fill_children_in::<true>(level, p, mask);
        } else {
            self.fill_children_in::<false>(level, p, mask);
        }
    }

    /// [`OnePass::fill_children`]; `IN_MAP`: every stop-level texel is in the map.
    #[inline(always)]
    fn fill_children_in<const IN_MAP: bool>(&mut self, level: usize, p: LightPos, mask: u32) {
        let light = self.light;
        let disp = &light.disp[level + 1];
        let mut texels = self.map.texels();
        let mut m = mask;
        while m != 0 {
            let s = m.trailing_zeros() as usize & 31;
            m &= m - 1;
            let d = disp[s];
            let (u, v) = ((p[0] + d[0]) >> LIGHT_FRAC, (p[1] + d[1]) >> LIGHT_FRAC);
            if let Some(t) = texels.at_mut_in::<IN_MAP>(u, v) {
                *t = (*t).min(light.depth16::<false>(p[2] + d[2]));
            }
        }
    }

    /// [`ShadowHooks::drawn_children`] at the stop level; `IN_MAP`: every stop-level texel is in
    /// the map, so none is tested against its bounds.
    #[inline(always)]
    fn test_and_fill_children<const IN_MAP: bool>(
        &mut self,
        parent: LightPos,
        level: usize,
        mask: u32,
        attr: impl Fn(u32) -> u16,
    ) -> u32 {
        let light = self.light;
        let disp = &light.disp[level];
        let behind_at = &light.derived.behind[level];
        let facing = &light.derived.facing;
        let mut texels = self.map.texels();
        let mut shadowed = 0;
        each_slot(mask, |i, s| {
            let k = facing[usize::from(attr(i)) & (NORMAL_COUNT - 1)];
            if k == 0 {
                shadowed |= 1 << s;
                return;
            }
            let d = disp[s];
            let p = [parent[0] + d[0], parent[1] + d[1], parent[2] + d[2]];
            if let Some(t) = texels.at_mut_in::<IN_MAP>(p[0] >> LIGHT_FRAC, p[1] >> LIGHT_FRAC) {
                let nearest = *t;
                *t = nearest.min(light.depth16::<false>(p[2]));
                shadowed |=
                    behind(nearest, p[2], behind_at[usize::from(k) & (BEHIND_ROW - 1)]) << s;
            }
        });
        shadowed
    }
}

impl ShadowHooks for OnePass<'_, '_, '_> {
    type Pos = LightPos;
    const FILL_CULLED: bool = true;
    const TESTS_FIRST: bool = true;
    /// Light order only above the level `S − 1` whose children are the stop level `S`'s cells:
    /// below, a cell is at most a texel and fills its one texel when it is done
    /// ([`ShadowHooks::descended`]), so its descendants are tested before it fills and the order
    /// of the ρ³ cells of one `S − 1` cell changes what they test against by no more than the
    /// bias covers (neighbours on one surface, within a texel or two). The walk there takes the
    /// cheaper slot order and its flat loops.
    #[inline(always)]
    fn ordered(&self, level: usize) -> bool {
        level + 1 < self.light.stop_level
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
    /// Tests, then fills: a cell coarser than the light's level of detail `S` over its footprint,
    /// a cell at `S` its one texel (tested and filled with one look-up), a finer one not at all
    /// (its `S` ancestor fills when its subtree is done). Testing before filling keeps a cell
    /// from shadowing itself; cells nearer the light were visited, and filled, before it (Duguet
    /// §5.3).
    #[inline]
    fn drawn(&mut self, level: usize, p: LightPos, attr: u16) -> bool {
        // The map holds what neighbours drew, with their footprints and centre depths, and with
        // multi-level rendering a neighbour may be one level coarser: bias as for that level,
        // which is row `level` of the bias table.
        if level == self.light.stop_level {
            return self.light.test_and_fill(self.map, level, p, attr);
        }
        if self.light.derived.facing[usize::from(attr) & (NORMAL_COUNT - 1)] == 0 {
            // Turned from the light: in shadow, and it casts nothing the lit side does not
            // ([`LightFrame::unlit`]).
            return true;
        }
        let shadowed = self.light.in_shadow::<false>(self.map, level, p, attr);
        if level < self.light.stop_level {
            self.light.cast::<false>(self.map, level, p);
        }
        shadowed
    }
    /// At the stop level (nearly every drawn child of a frame), one loop with the light's
    /// tables looked up once, each child tested and filled as `LightFrame::test_and_fill`
    /// does; elsewhere [`OnePass::drawn`] for each.
    #[inline(always)]
    fn drawn_children(
        &mut self,
        parent: LightPos,
        level: usize,
        mask: u32,
        attr: impl Fn(u32) -> u16,
    ) -> u32 {
        if level != self.light.stop_level {
            return drawn_each(self, parent, level, mask, attr);
        }
        if self.map.texels().holds_stop_level(self.light) {
            self.test_and_fill_children::<true>(parent, level, mask, attr)
        } else {
            self.test_and_fill_children::<false>(parent, level, mask, attr)
        }
    }
    /// As [`OnePass::drawn`] without the test.
    #[inline]
    fn casts(&mut self, level: usize, p: LightPos) {
        let s = self.light.stop_level;
        if level < s {
            self.light.cast::<false>(self.map, level, p);
        } else if level == s {
            self.light.cast_centre(self.map, p);
        }
    }
    #[inline]
    fn casts_subtree(&mut self, level: usize, p: LightPos, mask: u32) {
        if level + 1 == self.light.stop_level {
            self.fill_children(level, p, mask);
        } else {
            self.casts(level, p);
        }
    }
    #[inline(always)]
    fn unlit(&self, class: usize, code: usize) -> bool {
        self.light.unlit(class, code)
    }
    /// A cell at `S` fills its texel once its descendants are tested.
    #[inline]
    fn descended(&mut self, level: usize, p: LightPos, _mask: u32) {
        if level == self.light.stop_level {
            self.light.cast_centre(self.map, p);
        }
    }
    /// A fill-only descent stops at `S − 1`, whose cells fill their children from their masks.
    fn light_stop(&self, level: usize) -> bool {
        level + 1 >= self.light.stop_level
    }
}

/// The second pass of two-pass shadows: test only, against a map filled by [`super::fill_shadow_map`].
/// `POINT`: the light is a point light (perspective map).
pub struct TwoPass<'l, 'm, 'b, const POINT: bool> {
    pub(crate) light: &'l LightFrame,
    pub(crate) map: &'m ShadowMap<'b>,
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
    /// The reference algorithm casts everything.
    fn unlit(&self, _: usize, _: usize) -> bool {
        false
    }
}

/// The first pass of two-pass shadows: the whole grid's depth from the light, down to cells of one
/// texel.
pub(crate) struct Fill<'l, 'm, 'b, const POINT: bool> {
    pub(crate) light: &'l LightFrame,
    pub(crate) map: &'m mut ShadowMap<'b>,
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
    /// At `S − 1` the children, the stop level's cells, fill from the mask (no visit each).
    #[inline]
    fn casts_subtree(&mut self, level: usize, p: LightPos, mask: u32) {
        if level + 1 != self.light.stop_level {
            return self.casts(level, p);
        }
        let mut m = mask;
        while m != 0 {
            let s = m.trailing_zeros() as usize;
            m &= m - 1;
            let cp = self.light.step(p, level + 1, s);
            self.light.cast::<POINT>(self.map, level + 1, cp);
        }
    }
    fn light_stop(&self, level: usize) -> bool {
        level + 1 >= self.light.stop_level
    }
    /// The reference algorithm casts everything.
    fn unlit(&self, _: usize, _: usize) -> bool {
        false
    }
}
