//! The integer-only tri-grid traversal (Duguet §5.1–5.2): per node a few adds and compares, per drawn
//! splat one reciprocal look-up and three multiplies. No floats here.
//!
//! The walk is generic over [`ShadowHooks`]: without shadows the hooks are zero-sized and compile
//! away; with one-pass shadows (§5.3) they carry each node's light-space position (3 more adds), order
//! the children so that cells nearer the light come first, and test and fill the shadow map as
//! samples are drawn.
#![deny(clippy::float_arithmetic)]

use super::bricked::Bricked;
use super::frame::{SlotTable, TgFrame, MAX_SLOTS, TO_MODEL_BITS};
pub use super::hooks::{NoShadows, ShadowHooks, SlotOrder};
pub use super::nodes::{NodeData, Resident};
use super::read::TriGrid;
use super::MAX_LEVELS;
use crate::fixed::{
    dot3_i16, dot3_shr16, mul_shr, recip, wide_mul, wide_mul_small, wide_mul_u, wide_mul_u64,
    SUBPIXEL_BITS,
};
use crate::frame::Walk;
use crate::normal::NORMALS_Q14;
use crate::raster::exact_footprint;
use crate::splat::{ColorSink, SampleSplat, SplatSink, Stats};

/// The children's centroid tables: for a 9-bit layer `m` of a ρ = 3 mask (the 9 slots of one `k`),
/// `count | (Σ(2i − 2) + 32) << 8 | (Σ(2j − 2) + 32) << 16` over its set bits, so that the three
/// layers' entries add up without carries (counts ≤ 27, biased sums ≤ 96 + 18).
static CENTROID3: [u32; 512] = {
    let mut t = [0u32; 512];
    let mut m = 0;
    while m < 512 {
        let (mut n, mut sx, mut sy) = (0u32, 32u32, 32u32);
        let mut b = 0;
        while b < 9 {
            if m >> b & 1 != 0 {
                n += 1;
                sx = sx + 2 * (b % 3) as u32 - 2;
                sy = sy + 2 * (b / 3) as u32 - 2;
            }
            b += 1;
        }
        t[m] = n | sx << 8 | sy << 16;
        m += 1;
    }
    t
};

/// The same for a whole ρ = 2 mask: `count | (Σ(2i − 1) + 32) << 8 | … << 16 | … << 24`.
static CENTROID2: [u32; 256] = {
    let mut t = [0u32; 256];
    let mut m = 0;
    while m < 256 {
        let (mut n, mut s) = (0u32, [32u32; 3]);
        let mut b = 0;
        while b < 8 {
            if m >> b & 1 != 0 {
                n += 1;
                let mut a = 0;
                while a < 3 {
                    s[a] = s[a] + 2 * ((b >> a) & 1) as u32 - 1;
                    a += 1;
                }
            }
            b += 1;
        }
        t[m] = n | s[0] << 8 | s[1] << 16 | s[2] << 24;
        m += 1;
    }
    t
};

/// `RECIP_COUNT[n] = round(2¹⁵ / n)`: the centroid's division by the number of children (≤ 27;
/// 32 entries so that an index masked to 5 bits needs no bounds check).
static RECIP_COUNT: [i32; 32] = {
    let mut t = [0i32; 32];
    let mut n = 1;
    while n < 28 {
        t[n] = ((1 << 15) + n as i32 / 2) / n as i32;
        n += 1;
    }
    t
};

/// A tri-grid's frame ready to walk: the grid, its frame's tables and the shadow hooks (none by
/// default). What the pipeline runs ([`Walk`]); [`render_tg_with`] is the same walk as a call.
pub struct TgWalk<'a, 'g, H = NoShadows> {
    /// The grid.
    pub grid: &'a TriGrid<'g>,
    /// Its frame.
    pub frame: &'a TgFrame,
    /// What a shadow algorithm adds.
    pub hooks: H,
}

impl<H: ShadowHooks> Walk for TgWalk<'_, '_, H> {
    #[inline]
    fn walk<S: ColorSink>(&mut self, sink: &mut S) -> Stats {
        render_tg_with(self.grid, self.frame, &mut self.hooks, sink)
    }
}

/// Draws one frame of `grid` set up by `frame` into `sink`, and returns what it did.
///
/// The descent stops where a cell's projected diameter is below the cutoff (multi-level rendering,
/// drawing the stored intermediate sample), culls whole subtrees outside the frustum or behind the
/// near plane, stops testing below a cell that is entirely inside, and skips backfacing samples.
/// The work is bounded by the file: each node is visited at most once.
pub fn render_tg<S: SplatSink>(grid: &TriGrid<'_>, frame: &TgFrame, sink: &mut S) -> Stats {
    render_tg_with(grid, frame, &mut NoShadows, sink)
}

/// [`render_tg`] with shadow hooks.
pub fn render_tg_with<'g, S: SplatSink, H: ShadowHooks>(
    grid: &'g TriGrid<'g>,
    frame: &TgFrame,
    hooks: &mut H,
    sink: &mut S,
) -> Stats {
    if grid.header().bricked() {
        return render_nodes(Bricked::new(grid), frame, hooks, sink);
    }
    let data = Resident::new(grid);
    #[cfg(no_unaligned_loads)]
    if let Some(data) = data.aligned() {
        return render_nodes(data, frame, hooks, sink);
    }
    render_nodes(data, frame, hooks, sink)
}

/// [`render_tg_with`] over any [`NodeData`]: the streaming traversal. Where a cell's children are
/// not resident the descent stops and the cell is drawn, as if the LOD had stopped there, and the
/// missing blocks are requested (Streaming QSplat §3.2, Fig. 3). The caller checks that the root's
/// own data is resident.
pub fn render_nodes<D: NodeData, S: SplatSink, H: ShadowHooks>(
    data: D,
    frame: &TgFrame,
    hooks: &mut H,
    sink: &mut S,
) -> Stats {
    // One walk per ρ it draws, so that every ρ-dependent branch is decided at compile time.
    match frame.rho {
        2 => Walker::<_, _, _, 2>::new(data, frame, hooks, sink)
            .map_or_else(Stats::default, |w| w.walk()),
        _ => Walker::<_, _, _, 3>::new(data, frame, hooks, sink)
            .map_or_else(Stats::default, |w| w.walk()),
    }
}

/// Walks the whole grid for the shadow map only (a two-pass renderer's first pass), stopping where
/// [`ShadowHooks::light_stop`] says; returns the nodes visited.
pub fn fill_tg<'g, H: ShadowHooks>(grid: &'g TriGrid<'g>, frame: &TgFrame, hooks: &mut H) -> u32 {
    if grid.header().bricked() {
        return fill_nodes(Bricked::new(grid), frame, hooks);
    }
    let data = Resident::new(grid);
    #[cfg(no_unaligned_loads)]
    if let Some(data) = data.aligned() {
        return fill_nodes(data, frame, hooks);
    }
    fill_nodes(data, frame, hooks)
}

/// [`fill_tg`] over any [`NodeData`]: a streamed grid casts what is resident (where children are
/// absent, the cell casts as a leaf). Returns nodes visited.
pub(crate) fn fill_nodes<D: NodeData, H: ShadowHooks>(
    data: D,
    frame: &TgFrame,
    hooks: &mut H,
) -> u32 {
    let mut sink = crate::splat::NullSink::default();
    match frame.rho {
        2 => Walker::<_, _, _, 2>::new(data, frame, hooks, &mut sink).map_or(0, |w| w.fill()),
        _ => Walker::<_, _, _, 3>::new(data, frame, hooks, &mut sink).map_or(0, |w| w.fill()),
    }
}

struct Walker<'f, 'h, 's, D, S, H, const RHO: u8> {
    data: D,
    frame: &'f TgFrame,
    hooks: &'h mut H,
    sink: &'s mut S,
    stats: Stats,
    /// Per level, the children of the cell being descended there, by slot, for the light-ordered
    /// walk (Duguet §5.3). Kept for the frame rather than made per node: a fresh array per node
    /// is a 324-byte memset, 9 % of a one-pass frame on a Cortex-M3. Only present slots are read.
    kids: [[Child; MAX_SLOTS]; MAX_LEVELS],
}

/// Which way every sample of a subtree faces the eye, by its normal cone.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Facing {
    Away,
    Towards,
    Either,
}

/// A child about to be visited: its index, first child, mask word.
#[derive(Clone, Copy, Default)]
struct Child {
    index: u32,
    grand: u32,
    mask: u32,
}

/// The per-frame tables of one level that drawing a cell there reads.
struct DrawLevel<'f> {
    /// [`TgFrame::size_k`].
    size_k: (u32, u32),
    /// [`TgFrame::tick`].
    tick: &'f [[i32; 3]; 3],
    /// [`TgFrame::half_step_model`].
    half_step_model: i32,
}

impl<'f> DrawLevel<'f> {
    #[inline(always)]
    fn of(f: &'f TgFrame, level: u8) -> Self {
        let l = usize::from(level);
        DrawLevel {
            size_k: f.size_k[l],
            tick: &f.tick[l],
            half_step_model: f.half_step_model[l],
        }
    }
}

/// What [`Walker::final_parents`] computes once for a cell's children.
#[derive(Clone, Copy)]
struct FinalChildren<'f, P> {
    /// The children's displacement table, extent, level-of-detail and linear-rule depths.
    disp: &'f SlotTable,
    e: i32,
    lod: i32,
    linear: i32,
    /// The cell's model-frame eye vector and half a child's step, for the children's cone tests.
    vp: [i32; 3],
    step: i32,
    /// The cell's projected centre and light-space position.
    c: [i32; 3],
    p: P,
}

/// The screen-space set-up of a cell whose children [`Walker::draw_children_linear`] draws: its
/// centre, the screen offset of one tick of its children along each axis, its depth and its
/// children's footprint (Q16 pixels, Q16 pixels per Q6 tick, Q8 depth units, Q8 pixels).
///
/// Out of line where the core has no 32 × 32 → 64 multiply: there its twenty products from 16-bit
/// halves, inlined into a walk that keeps a light-space position too (one-pass shadows), left the
/// M0+ spilling 1,041 instructions a cell (std 1 px one-pass: 58.08 → 61.03 M); on its own it is
/// one set-up whatever the walk.
struct LinearCell {
    xp: i32,
    yp: i32,
    jx: [i32; 3],
    jy: [i32; 3],
    dp: i32,
    size_q8: i32,
}

impl LinearCell {
    #[cfg_attr(no_long_multiply, inline(never))]
    #[cfg_attr(not(no_long_multiply), inline(always))]
    fn of(f: &TgFrame, n: usize, c: [i32; 3]) -> Self {
        let t = &f.tick[n];
        let [x, y, w] = c;
        let (r, shift) = recip(w as u32);
        // 1/W = r31 / 2^(shift − 1), r31 < 2³¹; `W ≥ 2¹⁸` (the linear rule) makes
        // `s = shift − 49 ≥ 0`, so `a / W` in Q16 is the high word of `a · r31`, shifted by `s`.
        let r31 = (r >> 1) as i32;
        let s = shift - 49;
        let hi = |a: i32| mul_shr::<32>(a, r31) >> s;
        // The cell's centre, Q16 pixels, and the screen offset of one tick along each axis,
        // Q16 pixels: d(X/W) = (dX − (X/W)·dW) / W. Bounded by the linear rule (a cell of at
        // most 8 px), so that sums of three offsets of up to 2⁹ Q6 ticks fit an `i32`.
        let (xp, yp) = (hi(x), hi(y));
        // dW / W per tick, Q24: a tick is a small part of the depth (|dW| < 2²³ and
        // |dW / W| < 2⁻⁸ under the linear rule); `xp · u` takes 64 bits (up to 2⁴¹).
        // (Written out per axis: `array::from_fn` here stays a call per array on thumbv7m.)
        let u = [hi(t[0][2] << 8), hi(t[1][2] << 8), hi(t[2][2] << 8)];
        let du = |p: i32, u: i32| mul_shr::<24>(p, u);
        let j = |a: usize, c: usize, p: i32| hi(t[a][c]) - du(p, u[a]);
        let jx = [j(0, 0, xp), j(1, 0, xp), j(2, 0, xp)];
        let jy = [j(0, 1, yp), j(1, 1, yp), j(2, 1, yp)];
        // The cell's depth, Q8 depth units.
        let dz = (w - f.depth_w0).max(0) as u32;
        let dp = (wide_mul_u64(dz, f.depth_scale) >> 24).min(65534 << 8) as i32;
        // The footprint, Q8: k · 2^kshift / W, the high word of (k/2)·r31 shifted by
        // shift − kshift − 34 (the children's own depths differ from the cell's by under 1 %).
        let (k, kshift) = f.size_k[n];
        let s3 = shift.wrapping_sub(kshift).wrapping_sub(34);
        let size_q8 = if s3 < 32 {
            mul_shr::<32>((k >> 1) as i32, r31) >> s3
        } else if shift > kshift {
            (wide_mul_u(k, r) >> (shift - kshift)).min(i32::MAX as u64) as i32
        } else {
            i32::MAX
        };
        LinearCell {
            xp,
            yp,
            jx,
            jy,
            dp,
            size_q8,
        }
    }
}

/// `n · v` for a Q14 normal `n` and an eye vector `v`, exact: the sign a backface test reads.
#[inline(always)]
fn normal_dot(n: [i16; 3], v: [i32; 3]) -> i64 {
    dot3_i16(n, v)
}

/// Bit `code` of a per-normal-code bit table.
#[inline(always)]
fn bit(table: &[u32; 256], code: usize) -> bool {
    table[code / 32] >> (code % 32) & 1 != 0
}

impl<'f, 'h, 's, D: NodeData, S: SplatSink, H: ShadowHooks, const RHO: u8>
    Walker<'f, 'h, 's, D, S, H, RHO>
{
    /// The child bits of a mask word: the ρ³ slots (the bits above hold the cone class).
    const SLOT_BITS: u32 = (1u32 << (RHO as u32 * RHO as u32 * RHO as u32)) - 1;

    fn new(data: D, frame: &'f TgFrame, hooks: &'h mut H, sink: &'s mut S) -> Option<Self> {
        if data.shape() != (RHO, frame.depth) || frame.rho != RHO {
            return None;
        }
        Some(Walker {
            data,
            frame,
            hooks,
            sink,
            stats: Stats::default(),
            kids: [[Child::default(); MAX_SLOTS]; MAX_LEVELS],
        })
    }

    /// The frame's view walk from the root.
    fn walk(mut self) -> Stats {
        let mask = self.root_mask();
        let root = self.hooks.root();
        self.node(0, 0, mask, 0, self.frame.root, root, false);
        self.stats
    }

    /// The light-only walk from the root (two-pass shadows' first pass); the nodes it visited.
    fn fill(mut self) -> u32 {
        let mask = self.root_mask();
        let root = self.hooks.root();
        self.cast_only(0, 0, mask, 0, root);
        self.stats.nodes_visited
    }

    /// The root's mask word (none when the root is a leaf).
    fn root_mask(&self) -> u32 {
        if self.frame.depth > 0 {
            self.mask(0, 0)
        } else {
            0
        }
    }

    #[inline(always)]
    fn mask(&self, level: u8, i: u32) -> u32 {
        self.data.mask_of::<RHO>(level, i)
    }

    /// Before reading below cell `index` at `level`: when that is the brick level of a bricked
    /// grid, the data enters the cell's brick (compiled away for a grid without bricks).
    #[inline(always)]
    fn enter(&mut self, level: u8, index: u32) {
        if D::BRICKED && level == self.data.brick_level() {
            self.data.enter(index);
        }
    }

    /// The children of a cell at `level` into `kids[level]` by slot, for a walk in light order.
    #[inline(always)]
    fn children(&mut self, level: u8, index: u32, mask: u32, first_child: u32) {
        let l = usize::from(level);
        self.each_child(
            level,
            index,
            mask,
            first_child,
            false,
            move |walker, s, k| {
                walker.kids[l][s] = k;
            },
        );
    }

    /// Whether `c` (a cell at level `l`, extents `e`) lies outside the frustum or behind the near
    /// plane, and whether it lies entirely inside.
    #[inline(always)]
    fn frustum(&self, l: usize, c: [i32; 3]) -> (bool, bool) {
        let f = self.frame;
        let e = &f.ext[l];
        let [x, y, w] = c;
        let r = i32::from(f.viewport.width) * w - x;
        let b = i32::from(f.viewport.height) * w - y;
        let outside =
            w + e.w < f.near_w || x + e.x < 0 || r + e.r < 0 || y + e.y < 0 || b + e.b < 0;
        let inside =
            x - e.x >= 0 && r - e.r >= 0 && y - e.y >= 0 && b - e.b >= 0 && w - e.w >= f.near_w;
        (outside, inside)
    }

    /// Visits cell `index` at `level` with child mask word `mask`, whose children start at
    /// `first_child` on the next level, with projected centre `c` and light-space position `p`;
    /// `inside` when an ancestor was entirely inside the frustum (QSplat's flag: no more tests
    /// below it).
    #[allow(clippy::too_many_arguments)]
    fn node(
        &mut self,
        level: u8,
        index: u32,
        mask: u32,
        first_child: u32,
        c: [i32; 3],
        p: H::Pos,
        inside: bool,
    ) {
        if D::STREAMED && self.data.skip(level, index) {
            return;
        }
        count!(self.stats.nodes_visited += 1);
        let f = self.frame;
        let l = usize::from(level);
        let mut inside = inside;
        if !inside {
            let (outside, all_in) = self.frustum(l, c);
            if outside {
                count!(self.stats.culled += 1);
                if H::FILL_CULLED {
                    // Outside the view, but it may cast shadows into it.
                    count!(self.stats.nodes_visited -= 1);
                    self.cast_only(level, index, mask, first_child, p);
                }
                return;
            }
            inside = all_in;
        }
        let w_near = c[2] - f.ext[l].w;
        if level == f.depth || w_near >= f.lod_w[l] {
            self.draw(level, index, mask, c, p, inside);
            return;
        }
        // Normal cones (QSplat §3.2): a subtree whose every normal faces away from the eye.
        if inside && f.cones && self.cone_backfacing(level, index, mask, c) {
            count!(self.stats.backfacing += 1);
            if H::FILL_CULLED {
                count!(self.stats.nodes_visited -= 1);
                self.cast_only(level, index, mask, first_child, p);
            }
            return;
        }
        self.enter(level, index);
        if D::STREAMED {
            // Streaming QSplat §3.2: children not here yet, so draw this cell and ask for them.
            let n = (mask & Self::SLOT_BITS).count_ones();
            if !self.data.children_resident(level, index, first_child, n) {
                let (_, y_q8, size_q8) = self.project(&DrawLevel::of(f, level), c);
                self.data
                    .request_children(level, index, first_child, n, size_q8, y_q8);
                self.draw(level, index, mask, c, p, inside);
                return;
            }
        }
        let next = level + 1;
        let ordered = self.hooks.ordered(l);
        // Every child stops when even this cell's nearest point is far enough for the children's
        // level, or they are leaves: draw them in one flat loop, without recursion or the running
        // group pointer (which only a descent needs). The one-pass shadows' ordered levels take
        // the general path. A streamed grid takes the same paths as a resident one (its frame,
        // once every block is in, is the resident frame bit for bit): the children's residency
        // was checked above, and `final_parents` checks the grandchildren's.
        if !ordered && (next == f.depth || w_near >= f.lod_w[usize::from(next)]) {
            if inside && c[2] >= f.linear_w[usize::from(next)] {
                self.draw_children_linear::<false>(level, mask, first_child, c, p);
            } else {
                self.draw_children(level, index, mask, first_child, c, p, inside);
            }
        } else if inside
            && next < f.depth
            && !self.hooks.ordered(usize::from(next))
            && (next + 1 == f.depth || w_near >= f.lod_w[usize::from(next) + 1])
        {
            // Every grandchild stops: the children are the last cells that descend (in light
            // order where the one-pass shadows ask for it, their own children in slot order).
            // Children of the brick level enter their bricks in a copy of the loop out of line (a
            // test in the one loop cost a bricked walk's registers 0.26 M instructions at std 1 px).
            if D::BRICKED && next == self.data.brick_level() {
                self.final_bricks(level, index, mask, first_child, c, p, ordered);
            } else if ordered {
                self.final_parents_ordered(level, index, mask, first_child, c, p);
            } else {
                self.final_parents::<false, false>(level, index, mask, first_child, c, p);
            }
        } else {
            let disp = &f.disp[usize::from(next)];
            self.each_child(
                level,
                index,
                mask,
                first_child,
                ordered,
                move |walker, s, k| {
                    let d = disp[s & 31];
                    let cp = walker.hooks.child(p, usize::from(next), s);
                    walker.node(
                        next,
                        k.index,
                        k.mask,
                        k.grand,
                        [c[0] + d[0], c[1] + d[1], c[2] + d[2]],
                        cp,
                        inside,
                    );
                },
            );
        }
        self.hooks.descended(l, p, mask & Self::SLOT_BITS);
    }

    /// The children of cell `index` at `level` (inside the frustum) when all of their children
    /// stop: what [`Walker::node`] would do for each, in one loop instead of a call per child, with
    /// the cone test's eye vector from the cell's by the slot offsets (the deepest cells that
    /// descend are a tenth of a frame's nodes; their calls were a third of its cost).
    #[allow(clippy::too_many_arguments)]
    #[inline(never)]
    fn final_bricks(
        &mut self,
        level: u8,
        index: u32,
        mask: u32,
        first_child: u32,
        c: [i32; 3],
        p: H::Pos,
        ordered: bool,
    ) {
        if ordered {
            self.final_parents::<true, true>(level, index, mask, first_child, c, p);
        } else {
            self.final_parents::<true, false>(level, index, mask, first_child, c, p);
        }
    }

    /// [`Walker::final_parents`] in the light's order (one-pass shadows above the stop level),
    /// out of line: the slot-order loop keeps its registers.
    #[inline(never)]
    fn final_parents_ordered(
        &mut self,
        level: u8,
        index: u32,
        mask: u32,
        first_child: u32,
        c: [i32; 3],
        p: H::Pos,
    ) {
        self.final_parents::<false, true>(level, index, mask, first_child, c, p);
    }

    /// [`Walker::final_parents`] with each child entering its brick first (`ENTER`: the children
    /// are brick-level cells of a grid in bricks), the children in the light's order when
    /// `ORDERED` ([`ShadowHooks::order`]), else in slot order.
    #[inline(always)]
    fn final_parents<const ENTER: bool, const ORDERED: bool>(
        &mut self,
        level: u8,
        index: u32,
        mask: u32,
        first_child: u32,
        c: [i32; 3],
        p: H::Pos,
    ) {
        let f = self.frame;
        let next = level + 1;
        let n = usize::from(next);
        let fc = FinalChildren {
            disp: &f.disp[n],
            e: f.ext[n].w,
            lod: f.lod_w[n],
            linear: f.linear_w[n + 1],
            vp: if f.cones { self.to_model(c) } else { [0; 3] },
            step: f.half_step_model[usize::from(level)],
            c,
            p,
        };
        let mask = mask & Self::SLOT_BITS;
        if ORDERED {
            self.children(level, index, mask, first_child);
            let mut at = self.hooks.order().positions(mask);
            while at != 0 {
                let i = at.trailing_zeros() as usize;
                at &= at - 1;
                let s = usize::from(self.hooks.order().slots[i]) & 31;
                let k = self.kids[usize::from(level)][s];
                self.final_child::<ENTER, ORDERED>(fc, next, s, k);
            }
            return;
        }
        let mut grand = self.data.group(level, index);
        let mut child = first_child;
        let mut m = mask;
        while m != 0 {
            let s = m.trailing_zeros() as usize & 31;
            m &= m - 1;
            let k = child;
            child += 1;
            let cm = self.mask(next, k);
            let first = grand;
            grand += (cm & Self::SLOT_BITS).count_ones();
            let k = Child {
                index: k,
                grand: first,
                mask: cm,
            };
            self.final_child::<ENTER, ORDERED>(fc, next, s, k);
        }
    }

    /// One child `k` (slot `s`, at level `next`) of [`Walker::final_parents`]: drawn, culled by
    /// its cone, or its children drawn. `ORDERED` (one-pass shadows) draws the children as
    /// [`Walker::node`] would, with the centroids of [`Walker::draw_children_linear`] even where
    /// the cone faces the eye: against the ray-cast shadows the centres alone cost the bunny's
    /// std one-pass frame 0.11 dB (26.91 → 26.80).
    #[inline(always)]
    fn final_child<const ENTER: bool, const ORDERED: bool>(
        &mut self,
        fc: FinalChildren<'_, H::Pos>,
        next: u8,
        s: usize,
        k: Child,
    ) {
        let f = self.frame;
        let n = usize::from(next);
        let Child {
            index: k,
            grand: first,
            mask: cm,
        } = k;
        if D::STREAMED && self.data.skip(next, k) {
            return;
        }
        count!(self.stats.nodes_visited += 1);
        let (c, d) = (fc.c, fc.disp[s]);
        let cc = [c[0] + d[0], c[1] + d[1], c[2] + d[2]];
        let cp = self.hooks.child(fc.p, n, s);
        if cc[2] - fc.e >= fc.lod {
            self.draw(next, k, cm, cc, cp, true);
            return;
        }
        let mut facing = Facing::Either;
        if f.cones {
            let o = f.slot_steps[s];
            let v = core::array::from_fn(|a| fc.vp[a] + i32::from(o[a]) * fc.step);
            facing = self.cone_facing(next, k, cm, cc, v);
            if facing == Facing::Away {
                count!(self.stats.backfacing += 1);
                if H::FILL_CULLED {
                    count!(self.stats.nodes_visited -= 1);
                    self.cast_only(next, k, cm, first, cp);
                }
                return;
            }
        }
        if ENTER {
            // The children are brick-level cells: each enters its brick before its own
            // children are read.
            self.data.enter(k);
        }
        if D::STREAMED {
            // As in `node`: the grandchildren not here yet, so draw the child and ask.
            let n = (cm & Self::SLOT_BITS).count_ones();
            if !self.data.children_resident(next, k, first, n) {
                let (_, y_q8, size_q8) = self.project(&DrawLevel::of(f, next), cc);
                self.data.request_children(next, k, first, n, size_q8, y_q8);
                self.draw(next, k, cm, cc, cp, true);
                return;
            }
        }
        if cc[2] >= fc.linear {
            if facing == Facing::Towards {
                self.draw_children_linear::<true>(next, cm, first, cc, cp);
            } else {
                self.draw_children_linear::<false>(next, cm, first, cc, cp);
            }
        } else {
            self.draw_children(next, k, cm, first, cc, cp, true);
        }
        self.hooks.descended(n, cp, cm & Self::SLOT_BITS);
    }

    /// [`Walker::draw_children`] of a cell inside the frustum and far enough from the eye
    /// ([`TgFrame::linear_w`]) that the perspective divide is linear over its children to within
    /// [`crate::tg::frame::LINEAR_ERROR_PX`]: one division for the cell, then each child's splat
    /// is the cell's projection plus its offset, in ticks along the three axes, times the screen
    /// offset of one tick (Duguet §5.1's displacement tables, in screen space, for the last level),
    /// and its depth and eye vector likewise. The offset is the child's slot plus its own children's
    /// centroid, so the centroid costs three multiply-adds per coordinate, not a projection.
    ///
    /// `TOWARDS`: the cell's normal cone says every child faces the eye (no per-child test, and
    /// the children are drawn at their centres: the centroid is for silhouettes).
    #[inline(always)]
    fn draw_children_linear<const TOWARDS: bool>(
        &mut self,
        level: u8,
        mask: u32,
        first_child: u32,
        c: [i32; 3],
        p: H::Pos,
    ) {
        let f = self.frame;
        let next = level + 1;
        let n = usize::from(next);
        let leaves = next == f.depth;
        let LinearCell {
            xp,
            yp,
            jx,
            jy,
            dp,
            size_q8,
        } = LinearCell::of(f, n, c);
        let jd = &f.tick_depth[n];
        let shadowed_slots = self.light_children(n, p, mask, first_child);
        let mut vp = None;
        let tm = f.half_step_model[n];
        let mut child = first_child;
        let mut m = mask & Self::SLOT_BITS;
        while m != 0 {
            let s = m.trailing_zeros() as usize & 31;
            m &= m - 1;
            let k = child;
            child += 1;
            count!(self.stats.nodes_visited += 1);
            let cp = self.hooks.child(p, n, s);
            let attr = self.data.attr(next, k);
            let code = usize::from(attr & 0x1FFF);
            if !TOWARDS && bit(&f.backface, code) {
                count!(self.stats.backfacing += 1);
                self.casts_unless_tested(n, cp);
                continue;
            }
            // The splat's offset from the cell's centre, Q6 ticks: the slot, ρ·(2i − (ρ − 1)),
            // plus the child's children's centroid, σ / n, where the normal needs the exact
            // backface test (near a silhouette: where the splat's place changes which pixel
            // centres it covers).
            let front = TOWARDS || bit(&f.frontface, code);
            let o: [i32; 3] = if leaves || front {
                f.slot_ticks[s]
            } else {
                let st = f.slot_steps[s];
                let (nc, sigma) = Self::centroid_sums(self.mask(next, k));
                let q = RECIP_COUNT[nc as usize & 31];
                let nc = nc as i32;
                core::array::from_fn(|a| {
                    ((i32::from(st[a]) * i32::from(RHO) * nc + sigma[a]) * q) >> 9
                })
            };
            let dot = |j: &[i32; 3]| (o[0] * j[0] + o[1] * j[1] + o[2] * j[2]) >> 6;
            let x_q8 = (xp + dot(&jx) + 128) >> 8;
            let y_q8 = (yp + dot(&jy) + 128) >> 8;
            let [x0, x1, y0, y1] = exact_footprint(x_q8, y_q8, size_q8);
            if x1 <= x0 || y1 <= y0 {
                // It would draw nothing: no test, no depth (it still casts).
                count!(self.stats.splats += 1);
                self.casts_unless_tested(n, cp);
                continue;
            }
            if !front {
                let vp = *vp.get_or_insert_with(|| self.to_model(c));
                let nq = NORMALS_Q14[code];
                let v: [i32; 3] = core::array::from_fn(|a| vp[a] + ((o[a] * tm) >> 6));
                let facing = normal_dot(nq, v);
                if facing > 0 {
                    count!(self.stats.backfacing += 1);
                    self.casts_unless_tested(n, cp);
                    continue;
                }
            }
            let shadowed = if H::TESTS_FIRST {
                shadowed_slots >> s & 1 != 0
            } else {
                self.hooks.drawn(n, cp, attr)
            };
            let depth = ((dp + dot(jd)).clamp(0, 65534 << 8) >> 8) as u16;
            count!(self.stats.splats += 1);
            count!(self.stats.shadowed += u32::from(shadowed));
            count!(self.stats.max_level = self.stats.max_level.max(next));
            let splat = SampleSplat {
                x_q8,
                y_q8,
                size_q8,
                depth,
                attr,
                level: next,
                index: k,
                shadowed,
                exact: true,
            };
            Self::emit(self.sink, &splat, [x0, x1, y0, y1]);
        }
    }

    /// The light's side of [`Walker::draw_children_linear`]: every child of the cell (light-space
    /// `p`, children from `first_child` at level `n`) tested and cast as a drawn sample
    /// ([`ShadowHooks::drawn`]), in slot order, before the view draws any; the slots of those
    /// in shadow. A child the view does not draw (backfacing, or covering no pixel) takes the
    /// same fill as a drawn one and its test is not read, so the map ends as when each child
    /// cast or was tested as the view met it: the same frame, with the light's registers kept out
    /// of the view's loop (one-pass std 1 px: they spilled the light position twice a child).
    #[inline(always)]
    fn light_children(&mut self, n: usize, p: H::Pos, mask: u32, first_child: u32) -> u32 {
        if !H::TESTS_FIRST {
            return 0;
        }
        let next = n as u8;
        let data = &self.data;
        self.hooks
            .drawn_children(p, n, mask & Self::SLOT_BITS, |i| {
                data.attr(next, first_child + i)
            })
    }

    /// A child of [`Walker::draw_children_linear`] that the view does not draw casts, unless
    /// [`Walker::light_children`] cast it with the others.
    #[inline(always)]
    fn casts_unless_tested(&mut self, n: usize, cp: H::Pos) {
        if !H::TESTS_FIRST {
            self.hooks.casts(n, cp);
        }
    }

    /// Hands an exact splat with footprint `[x0, x1, y0, y1]` (not empty) to the sink: as its one
    /// pixel when it covers one (nearly every splat of a frame), else whole.
    #[inline(always)]
    fn emit(sink: &mut S, splat: &SampleSplat, [x0, x1, y0, y1]: [i32; 4]) {
        if x1 == x0 + 1 && y1 == y0 + 1 {
            sink.pixel(splat, x0, y0);
        } else {
            sink.splat(splat);
        }
    }

    /// Draws every child of cell `index` at `level` (child mask word `mask`, children from
    /// `first_child`): the children's level is where the descent stops. One pass over the mask's
    /// bits, no recursion.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn draw_children(
        &mut self,
        level: u8,
        index: u32,
        mask: u32,
        first_child: u32,
        c: [i32; 3],
        p: H::Pos,
        inside: bool,
    ) {
        let f = self.frame;
        let next = level + 1;
        let n = usize::from(next);
        let disp = &f.disp[n];
        let lv = DrawLevel::of(f, next);
        let has_grandchildren = next < f.depth;
        // The model-frame vectors of the children for the exact backface test: the parent's, plus
        // their slots' offsets along the grid's (the model's) axes.
        let vp = self.to_model(c);
        let step = f.half_step_model[usize::from(level)];
        // Only a culled child that still casts (one-pass shadows) descends: it needs its first
        // grandchild, the group pointer plus its elder siblings' children.
        let mut grand = if H::FILL_CULLED && has_grandchildren {
            self.data.group(level, index)
        } else {
            0
        };
        let mut child = first_child;
        let mut m = mask & Self::SLOT_BITS;
        while m != 0 {
            let s = m.trailing_zeros() as usize & 31;
            m &= m - 1;
            count!(self.stats.nodes_visited += 1);
            let d = disp[s];
            let cc = [c[0] + d[0], c[1] + d[1], c[2] + d[2]];
            let cp = self.hooks.child(p, n, s);
            let cm = if has_grandchildren {
                self.mask(next, child)
            } else {
                0
            };
            if !inside && self.frustum(n, cc).0 {
                count!(self.stats.culled += 1);
                if H::FILL_CULLED {
                    count!(self.stats.nodes_visited -= 1);
                    self.cast_only(next, child, cm, grand, cp);
                }
            } else {
                let o = f.slot_steps[s];
                let v = core::array::from_fn(|k| vp[k] + i32::from(o[k]) * step);
                self.draw_at(&lv, next, child, cm, cc, Some(v), cp, inside);
            }
            if H::FILL_CULLED {
                grand += (cm & Self::SLOT_BITS).count_ones();
            }
            child += 1;
        }
        let _ = index;
    }

    /// Visits the children of cell `index` at `level` (child mask word `mask`, children from
    /// `first_child`): in light order when `ordered`, else in slot order, where the group pointer
    /// and a running popcount find each child's own children.
    #[inline(always)]
    fn each_child(
        &mut self,
        level: u8,
        index: u32,
        mask: u32,
        first_child: u32,
        ordered: bool,
        mut visit: impl FnMut(&mut Self, usize, Child),
    ) {
        let mask = mask & Self::SLOT_BITS;
        if ordered {
            self.children(level, index, mask, first_child);
            let mut at = self.hooks.order().positions(mask);
            while at != 0 {
                let i = at.trailing_zeros() as usize;
                at &= at - 1;
                let s = usize::from(self.hooks.order().slots[i]);
                let k = self.kids[usize::from(level)][s];
                visit(self, s, k);
            }
            return;
        }
        let next = level + 1;
        let has_grandchildren = next < self.frame.depth;
        let mut grand = if has_grandchildren {
            self.data.group(level, index)
        } else {
            0
        };
        let mut child = first_child;
        let mut m = mask;
        while m != 0 {
            let s = m.trailing_zeros() as usize & 31;
            m &= m - 1;
            let cm = if has_grandchildren {
                self.mask(next, child)
            } else {
                0
            };
            visit(
                self,
                s,
                Child {
                    index: child,
                    grand,
                    mask: cm,
                },
            );
            grand += (cm & Self::SLOT_BITS).count_ones();
            child += 1;
        }
    }

    /// A subtree seen only by the light: descend to the light's level of detail and let every
    /// sample there cast into the shadow map.
    fn cast_only(&mut self, level: u8, index: u32, mask: u32, first_child: u32, p: H::Pos) {
        // A refined cast in passes skips what earlier passes cast (slot order is walk order here).
        if D::STREAMED && self.data.skip(level, index) {
            return;
        }
        count!(self.stats.nodes_visited += 1);
        let class = (mask >> 27 & 7) as usize;
        if class != 0
            && class != 7
            && self
                .hooks
                .unlit(class, usize::from(self.data.attr(level, index) & 0x1FFF))
        {
            // Turned from the light at every sample: it casts nothing a lit side does not.
            return;
        }
        let l = usize::from(level);
        if level != self.frame.depth && !self.hooks.light_stop(l) {
            self.enter(level, index);
        }
        if level == self.frame.depth {
            self.hooks.casts(l, p);
            return;
        }
        if self.hooks.light_stop(l) {
            // The cell's mask says where its children are: enough to cast them.
            self.hooks.casts_subtree(l, p, mask & Self::SLOT_BITS);
            return;
        }
        if D::STREAMED {
            let n = (mask & Self::SLOT_BITS).count_ones();
            if !self.data.children_resident(level, index, first_child, n) {
                // Cast coarser for now, and ask for the children as a drawn cell does: the frame
                // is not the resident one (it does not count as converged) until they are in.
                // Unseen, they wait behind everything on screen (the lowest priority: no size, the
                // last row).
                self.data
                    .request_children(level, index, first_child, n, 0, i32::MAX);
                self.hooks.casts(l, p);
                return;
            }
        }
        // Only the light sees this subtree and fills keep the nearer depth, so the order of its
        // fills cannot change a test: slot order.
        let next = level + 1;
        self.each_child(
            level,
            index,
            mask,
            first_child,
            false,
            move |walker, s, k| {
                let cp = walker.hooks.child(p, usize::from(next), s);
                walker.cast_only(next, k.index, k.mask, k.grand, cp);
            },
        );
    }

    /// The model-frame vector from the eye to the point at `c`, in `W` units
    /// ([`TgFrame::to_model`]; it fits an `i32`, as `c` does).
    #[inline(always)]
    fn to_model(&self, c: [i32; 3]) -> [i32; 3] {
        const { assert!(TO_MODEL_BITS == 16) };
        let m = &self.frame.to_model;
        [
            dot3_shr16(m[0], c),
            dot3_shr16(m[1], c),
            dot3_shr16(m[2], c),
        ]
    }

    /// Whether every sample of the subtree of cell `index` at `level` (centre `c`, inside the
    /// frustum) faces away from the eye, by the cell's normal cone (its class in `mask`'s top
    /// bits; see [`TgFrame`]'s cone tables).
    #[inline]
    fn cone_backfacing(&self, level: u8, index: u32, mask: u32, c: [i32; 3]) -> bool {
        let class = (mask >> 27 & 7) as usize;
        if class == 0 || class == 7 {
            return false;
        }
        self.cone_culls(level, index, mask, c, self.to_model(c))
    }

    /// [`Walker::cone_backfacing`] with the cell's eye vector `v` ([`Walker::to_model`] of `c`).
    #[inline(always)]
    fn cone_culls(&self, level: u8, index: u32, mask: u32, c: [i32; 3], v: [i32; 3]) -> bool {
        self.cone_facing(level, index, mask, c, v) == Facing::Away
    }

    /// Which way the whole subtree of cell `index` at `level` (centre `c`, eye vector `v`, inside
    /// the frustum) faces, by its normal cone: away from the eye at every sample
    /// ([`Walker::cone_backfacing`]), towards it at every sample (the mirror test:
    /// `−a·v > W·tan θ / cos θ_max + r / cos θ`), or either.
    #[inline(always)]
    fn cone_facing(&self, level: u8, index: u32, mask: u32, c: [i32; 3], v: [i32; 3]) -> Facing {
        let class = (mask >> 27 & 7) as usize;
        if class == 0 || class == 7 {
            return Facing::Either;
        }
        let f = self.frame;
        let code = usize::from(self.data.attr(level, index) & 0x1FFF);
        let n = NORMALS_Q14[code];
        let av = normal_dot(n, v);
        let bound = wide_mul(c[2], f.cone_k[class & 7]) + f.cone_r[class & 7][usize::from(level)];
        if av > bound {
            Facing::Away
        } else if -av > bound {
            Facing::Towards
        } else {
            Facing::Either
        }
    }

    /// Screen centre and footprint (Q8 pixels) of a cell at level `l` with projected centre `c`:
    /// one reciprocal look-up and three multiplies.
    ///
    /// `x / w` is `x · r / 2^shift`. For the usual depths (`w ≥ 2¹⁰`, so `shift − 8 ≥ 32`) the
    /// product's high word, rounded and shifted by `shift − 40` (a 32-bit shift), gives it in Q8:
    /// one `smull` and two instructions, where a 64-bit shift by a variable amount takes eight on a
    /// Cortex-M. Cells nearer the eye take the 64-bit path.
    #[inline(always)]
    fn project(&self, lv: &DrawLevel<'_>, c: [i32; 3]) -> (i32, i32, i32) {
        let [x, y, w] = c;
        let (r, shift) = recip(w as u32);
        let (k, kshift) = lv.size_k;
        let ks = shift.wrapping_sub(kshift);
        let size_q8 = if (32..64).contains(&ks) {
            ((wide_mul_u(k, r) >> 32) as u32 >> (ks - 32)).min(i32::MAX as u32) as i32
        } else if shift > kshift {
            (wide_mul_u(k, r) >> ks).min(i32::MAX as u64) as i32
        } else {
            i32::MAX
        };
        let r = i64::from(r);
        let sh = shift - SUBPIXEL_BITS;
        if sh >= 33 {
            let s = sh - 32;
            let half = 1i32 << (s - 1);
            let x_q8 = (((i64::from(x) * r) >> 32) as i32).wrapping_add(half) >> s;
            let y_q8 = (((i64::from(y) * r) >> 32) as i32).wrapping_add(half) >> s;
            return (x_q8, y_q8, size_q8);
        }
        let half = 1i64 << (sh - 1);
        let x_q8 = ((i64::from(x) * r + half) >> sh) as i32;
        let y_q8 = ((i64::from(y) * r + half) >> sh) as i32;
        (x_q8, y_q8, size_q8)
    }

    /// The number `n` of children in `mask` and the sums `σ` of their slots' offsets from the
    /// centre, in half child steps per axis (`Σ 2i − (ρ − 1)`): the centroid is `σ / n`.
    #[inline(always)]
    fn centroid_sums(mask: u32) -> (u32, [i32; 3]) {
        if RHO == 3 {
            let (t0, t1, t2) = (
                CENTROID3[(mask & 511) as usize],
                CENTROID3[(mask >> 9 & 511) as usize],
                CENTROID3[(mask >> 18 & 511) as usize],
            );
            let t = t0 + t1 + t2;
            (
                t & 0xFF,
                [
                    (t >> 8 & 0xFF) as i32 - 96,
                    (t >> 16 & 0xFF) as i32 - 96,
                    2 * ((t2 & 0xFF) as i32 - (t0 & 0xFF) as i32),
                ],
            )
        } else {
            let t = CENTROID2[(mask & 255) as usize];
            (
                t & 0xFF,
                [
                    (t >> 8 & 0xFF) as i32 - 32,
                    (t >> 16 & 0xFF) as i32 - 32,
                    (t >> 24) as i32 - 32,
                ],
            )
        }
    }

    /// Draws cell `index` at `level` (mask word `mask`, centre `c`) as its footprint, unless it
    /// is behind the near plane or faces away from the eye.
    #[inline(always)]
    fn draw(&mut self, level: u8, index: u32, mask: u32, c: [i32; 3], p: H::Pos, inside: bool) {
        let lv = DrawLevel::of(self.frame, level);
        self.draw_at(&lv, level, index, mask, c, None, p, inside);
    }

    /// [`Walker::draw`] with the level's tables looked up: a loop over one level's cells looks
    /// them up once. `inside`: the cell's parent lies inside the frustum, so the cell is in front
    /// of the near plane.
    /// `v`: the model-frame vector from the eye to the cell's centre, when the caller has it
    /// ([`Walker::to_model`] otherwise, when the exact backface test needs it).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn draw_at(
        &mut self,
        lv: &DrawLevel<'_>,
        level: u8,
        index: u32,
        mask: u32,
        c: [i32; 3],
        v: Option<[i32; 3]>,
        p: H::Pos,
        inside: bool,
    ) {
        let f = self.frame;
        let l = usize::from(level);
        if !inside && c[2] < f.near_w {
            self.hooks.casts(l, p);
            return;
        }
        let attr = self.data.attr(level, index);
        let code = usize::from(attr & 0x1FFF);
        if bit(&f.backface, code) {
            // Backfacing for every ray of the view.
            count!(self.stats.backfacing += 1);
            self.hooks.casts(l, p);
            return;
        }
        // At the children's centroid (Duguet §4.1 samples the surface nearest the cell's centre;
        // the children say where in the cell the surface is).
        let (c, o) = if mask & Self::SLOT_BITS != 0 {
            // σ / n ticks of this level, Q6, then through the ticks' (X, Y, W) (64-bit: a cell
            // drawn here may be any size).
            let (nc, sigma) = Self::centroid_sums(mask);
            let q = RECIP_COUNT[nc as usize & 31];
            let o: [i32; 3] = sigma.map(|s| (s * q) >> 9);
            let t = lv.tick;
            (
                core::array::from_fn(|k| {
                    // |o| ≤ 2⁷: a centroid within the cell.
                    let d: i64 = (0..3).map(|a| wide_mul_small(o[a], t[a][k])).sum();
                    c[k] + (d >> 6) as i32
                }),
                o,
            )
        } else {
            (c, [0; 3])
        };
        // Neither always front- nor always backfacing: the exact test, at the centroid (at a
        // silhouette the cell's centre may lie on the other side of the surface).
        if !bit(&f.frontface, code) {
            let v = match v {
                Some(v) => core::array::from_fn(|k| v[k] + ((o[k] * lv.half_step_model) >> 6)),
                None => self.to_model(c),
            };
            let n = NORMALS_Q14[code];
            let facing = normal_dot(n, v);
            if facing > 0 {
                count!(self.stats.backfacing += 1);
                self.hooks.casts(l, p);
                return;
            }
        }
        let (x_q8, y_q8, size_q8) = self.project(lv, c);
        let fp = exact_footprint(x_q8, y_q8, size_q8);
        if fp[1] <= fp[0] || fp[3] <= fp[2] {
            // It would draw nothing (it still casts).
            count!(self.stats.splats += 1);
            self.hooks.casts(l, p);
            return;
        }
        let shadowed = self.hooks.drawn(l, p, attr);
        let dz = (c[2] - f.depth_w0).max(0) as u64;
        let depth = ((dz * f.depth_scale) >> 32).min(65534) as u16;
        count!(self.stats.splats += 1);
        count!(self.stats.shadowed += u32::from(shadowed));
        count!(self.stats.max_level = self.stats.max_level.max(level));
        let splat = SampleSplat {
            x_q8,
            y_q8,
            size_q8,
            depth,
            attr,
            level,
            index,
            shadowed,
            exact: true,
        };
        Self::emit(self.sink, &splat, fp);
    }
}
