//! The integer-only tri-grid traversal (Duguet §5.1–5.2): per node a few adds and compares, per drawn
//! splat one reciprocal look-up and three multiplies. No floats here.
//!
//! The walk is generic over [`ShadowHooks`]: without shadows the hooks are zero-sized and compile
//! away; with one-pass shadows (§5.3) they carry each node's light-space position (3 more adds), order
//! the children so that cells nearer the light come first, and test and fill the shadow map as
//! samples are drawn.
#![deny(clippy::float_arithmetic)]

use super::frame::{TgFrame, MAX_SLOTS};
use super::read::{LevelArrays, TriGrid};
use super::MAX_LEVELS;
use crate::fixed::{recip, SUBPIXEL_BITS};
use crate::splat::{SampleSplat, SplatSink, Stats};

/// What a shadow algorithm adds to the walk. Implemented by [`NoShadows`] and, with the `shadows`
/// feature, by the shadow-map passes in [`crate::shadow`].
pub trait ShadowHooks {
    /// A node's light-space position (`()` without shadows).
    type Pos: Copy;
    /// Whether the children of a view-visible cell at `level` must be visited in
    /// [`ShadowHooks::order`] instead of slot order: only where visiting order changes what is in
    /// the shadow map when a sample is tested. Subtrees only the light sees are always walked in
    /// slot order: their fills keep the nearer depth, so their order cannot matter.
    #[inline(always)]
    fn ordered(&self, _level: usize) -> bool {
        false
    }
    /// Keep walking subtrees the view culls, to fill the shadow map with what they cast.
    const FILL_CULLED: bool;
    /// Light-space position of the root cell.
    fn root(&self) -> Self::Pos;
    /// Light-space position of child `slot` of a cell at `level - 1` at `parent`.
    fn child(&self, parent: Self::Pos, level: usize, slot: usize) -> Self::Pos;
    /// The child slots, nearest to the light first, where [`ShadowHooks::ordered`] says so.
    #[inline(always)]
    fn order(&self) -> &SlotOrder {
        &IDENTITY_ORDER
    }
    /// A sample drawn in the view, with attribute `attr`: returns whether it is in shadow (and may
    /// fill the map).
    fn drawn(&mut self, level: usize, p: Self::Pos, attr: u16) -> bool;
    /// A sample that casts but is not drawn (backfacing, or in a culled subtree): fill only.
    fn casts(&mut self, level: usize, p: Self::Pos);
    /// Whether a cell at `level` is small enough in the shadow map to stop a fill-only descent.
    fn light_stop(&self, level: usize) -> bool;
    /// A cell at `level`, drawn by the view walk or not, whose children have all been visited.
    #[inline(always)]
    fn descended(&mut self, _level: usize, _p: Self::Pos) {}
}

/// No shadows: every hook is a no-op and the light-space position is `()`.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoShadows;

impl ShadowHooks for NoShadows {
    type Pos = ();
    const FILL_CULLED: bool = false;
    #[inline(always)]
    fn root(&self) {}
    #[inline(always)]
    fn child(&self, _: (), _: usize, _: usize) {}
    #[inline(always)]
    fn drawn(&mut self, _: usize, _: (), _: u16) -> bool {
        false
    }
    #[inline(always)]
    fn casts(&mut self, _: usize, _: ()) {}
    #[inline(always)]
    fn light_stop(&self, _: usize) -> bool {
        true
    }
}

/// Where the traversal reads a grid's arrays (attributes, child masks, group pointers): the whole
/// file in memory ([`Resident`]), or blocks streamed into a cache (`crate::stream`, Streaming QSplat
/// §3.2). The walk asks "are a cell's children here?" before descending; a resident file answers yes
/// at compile time, so its walk is the same code as before streaming existed.
pub trait NodeData {
    /// Whether some blocks may be absent. `false` compiles the residency checks away.
    const STREAMED: bool;
    /// ρ and depth of the grid.
    fn shape(&self) -> (u8, u8);
    /// Attribute of sample `i` at `level` (0 when it cannot be read).
    fn attr(&self, level: u8, i: u32) -> u16;
    /// Child mask of cell `i` at `level`, for ρ ≤ 3 (0 when it cannot be read).
    fn mask(&self, level: u8, i: u32) -> u32;
    /// Group pointer of cell `i` at `level` (0 when it cannot be read).
    fn group(&self, level: u8, i: u32) -> u32;
    /// Whether everything the descent into the `n` children of cell `index` at `level` reads is
    /// resident: their attributes and masks (the first at `first_child` on `level + 1`) and the cell's
    /// group pointer. A streamed source also notes the blocks as used by this frame.
    fn children_resident(&mut self, level: u8, index: u32, first_child: u32, n: u32) -> bool;
    /// Asks for the blocks [`NodeData::children_resident`] found missing; the cell's projected
    /// diameter (Q4 pixels) and centre row (Q4 pixels) set the priority (Streaming QSplat §4.2).
    fn request_children(
        &mut self,
        level: u8,
        index: u32,
        first_child: u32,
        n: u32,
        size_q4: i32,
        y_q4: i32,
    );
}

/// A memory-resident grid: every block is present, reads are slices cut once per level.
#[derive(Clone, Copy, Debug)]
pub struct Resident<'g> {
    arrays: [LevelArrays<'g>; MAX_LEVELS],
    rho: u8,
    depth: u8,
}

impl<'g> Resident<'g> {
    /// The arrays of `grid`, cut once.
    pub fn new(grid: &TriGrid<'g>) -> Self {
        let h = grid.header();
        let mut arrays = [LevelArrays::default(); MAX_LEVELS];
        for (l, a) in arrays.iter_mut().enumerate().take(h.levels()) {
            *a = grid.arrays(l as u8);
        }
        Resident {
            arrays,
            rho: h.rho,
            depth: h.depth,
        }
    }
}

impl NodeData for Resident<'_> {
    const STREAMED: bool = false;
    #[inline(always)]
    fn shape(&self) -> (u8, u8) {
        (self.rho, self.depth)
    }
    #[inline(always)]
    fn attr(&self, level: u8, i: u32) -> u16 {
        self.arrays[usize::from(level)].attr(i)
    }
    #[inline(always)]
    fn mask(&self, level: u8, i: u32) -> u32 {
        let a = &self.arrays[usize::from(level)];
        if self.rho == 2 {
            a.mask_u8(i)
        } else {
            a.mask_u32(i)
        }
    }
    #[inline(always)]
    fn group(&self, level: u8, i: u32) -> u32 {
        self.arrays[usize::from(level)].group(i)
    }
    #[inline(always)]
    fn children_resident(&mut self, _: u8, _: u32, _: u32, _: u32) -> bool {
        true
    }
    #[inline(always)]
    fn request_children(&mut self, _: u8, _: u32, _: u32, _: u32, _: i32, _: i32) {}
}

/// An order of the ρ³ child slots (Duguet §5.3: nearest to the light first), with the look-up that
/// visits a cell's present children in it without scanning all 27: the child mask, 7 bits at a
/// time, maps to the set of the present slots' positions in the order.
#[derive(Clone, Debug)]
pub struct SlotOrder {
    slots: [u8; MAX_SLOTS],
    /// `positions[c][m]`: bit `i` set where `slots[i]` is one of the slots `7c + b`, `b` a set bit
    /// of `m`.
    positions: [[u32; 128]; 4],
}

impl SlotOrder {
    /// `slots` must hold each of `0..MAX_SLOTS` once.
    pub const fn new(slots: [u8; MAX_SLOTS]) -> Self {
        let mut at = [0u32; 32];
        let mut i = 0;
        while i < MAX_SLOTS {
            at[slots[i] as usize] = 1 << i;
            i += 1;
        }
        let mut positions = [[0u32; 128]; 4];
        let mut c = 0;
        while c < 4 {
            let mut m = 0;
            while m < 128 {
                let mut b = 0;
                while b < 7 {
                    if m >> b & 1 != 0 {
                        positions[c][m] |= at[7 * c + b];
                    }
                    b += 1;
                }
                m += 1;
            }
            c += 1;
        }
        SlotOrder { slots, positions }
    }

    /// No slot at all: a placeholder (all zeros) for a light not set up yet.
    pub const NONE: SlotOrder = SlotOrder {
        slots: [0; MAX_SLOTS],
        positions: [[0; 128]; 4],
    };

    /// The slots, in order.
    pub fn slots(&self) -> &[u8; MAX_SLOTS] {
        &self.slots
    }

    /// Where the slots of `mask` are in the order, as a bit set: four look-ups.
    #[inline(always)]
    fn positions(&self, mask: u32) -> u32 {
        let p = &self.positions;
        p[0][(mask & 127) as usize]
            | p[1][(mask >> 7 & 127) as usize]
            | p[2][(mask >> 14 & 127) as usize]
            | p[3][(mask >> 21 & 127) as usize]
    }
}

/// Slot order.
const IDENTITY_ORDER: SlotOrder = {
    let mut o = [0u8; MAX_SLOTS];
    let mut i = 0;
    while i < MAX_SLOTS {
        o[i] = i as u8;
        i += 1;
    }
    SlotOrder::new(o)
};

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
pub fn render_tg_with<S: SplatSink, H: ShadowHooks>(
    grid: &TriGrid<'_>,
    frame: &TgFrame,
    hooks: &mut H,
    sink: &mut S,
) -> Stats {
    render_nodes(Resident::new(grid), frame, hooks, sink)
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
    match Walker::new(data, frame, hooks, sink) {
        Some(mut w) => {
            let mask = w.mask(0, 0);
            let root = w.hooks.root();
            w.node(0, 0, mask, 0, frame.root, root, false);
            w.stats
        }
        None => Stats::default(),
    }
}

/// Walks the whole grid for the shadow map only (a two-pass renderer's first pass), stopping where
/// [`ShadowHooks::light_stop`] says; returns the nodes visited.
pub fn fill_tg<H: ShadowHooks>(grid: &TriGrid<'_>, frame: &TgFrame, hooks: &mut H) -> u32 {
    let mut sink = crate::splat::NullSink::default();
    match Walker::new(Resident::new(grid), frame, hooks, &mut sink) {
        Some(mut w) => {
            let mask = w.mask(0, 0);
            let root = w.hooks.root();
            w.cast_only(0, 0, mask, 0, root);
            w.stats.nodes_visited
        }
        None => 0,
    }
}

struct Walker<'f, 'h, 's, D, S, H> {
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

/// A child about to be visited: its slot, index, first child, mask.
#[derive(Clone, Copy, Default)]
struct Child {
    index: u32,
    grand: u32,
    mask: u32,
}

impl<'f, 'h, 's, D: NodeData, S: SplatSink, H: ShadowHooks> Walker<'f, 'h, 's, D, S, H> {
    fn new(data: D, frame: &'f TgFrame, hooks: &'h mut H, sink: &'s mut S) -> Option<Self> {
        if data.shape() != (frame.rho, frame.depth) {
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

    #[inline(always)]
    fn mask(&self, level: u8, i: u32) -> u32 {
        self.data.mask(level, i)
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

    /// Visits cell `index` at `level` with child mask `mask`, whose children start at `first_child`
    /// on the next level, with projected centre `c` and light-space position `p`; `inside` when an
    /// ancestor was entirely inside the frustum (QSplat's flag: no more tests below it).
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
        self.stats.nodes_visited += 1;
        let f = self.frame;
        let l = usize::from(level);
        let e = &f.ext[l];
        let [x, y, w] = c;
        let mut inside = inside;
        if !inside {
            let r = 240 * w - x;
            let b = 320 * w - y;
            if w + e.w < f.near_w || x + e.x < 0 || r + e.r < 0 || y + e.y < 0 || b + e.b < 0 {
                self.stats.culled += 1;
                if H::FILL_CULLED {
                    // Outside the view, but it may cast shadows into it.
                    self.stats.nodes_visited -= 1;
                    self.cast_only(level, index, mask, first_child, p);
                }
                return;
            }
            inside =
                x - e.x >= 0 && r - e.r >= 0 && y - e.y >= 0 && b - e.b >= 0 && w - e.w >= f.near_w;
        }
        if level == f.depth || w - e.w >= f.lod_w[l] {
            self.draw(level, index, c, p);
            return;
        }
        if D::STREAMED {
            // Streaming QSplat §3.2: children not here yet, so draw this cell and ask for them.
            let n = mask.count_ones();
            if !self.data.children_resident(level, index, first_child, n) {
                let (_, y_q4, size_q4) = self.project(l, c);
                self.data
                    .request_children(level, index, first_child, n, size_q4, y_q4);
                self.draw(level, index, c, p);
                return;
            }
        }
        let next = level + 1;
        let disp = &f.disp[usize::from(next)];
        let ordered = self.hooks.ordered(l);
        self.each_child(
            level,
            index,
            mask,
            first_child,
            ordered,
            move |walker, s, k| {
                let d = disp[s];
                let cp = walker.hooks.child(p, usize::from(next), s);
                walker.node(
                    next,
                    k.index,
                    k.mask,
                    k.grand,
                    [x + d[0], y + d[1], w + d[2]],
                    cp,
                    inside,
                );
            },
        );
        self.hooks.descended(l, p);
    }

    /// Visits the children of cell `index` at `level` (child mask `mask`, children from
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
            let s = m.trailing_zeros() as usize;
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
            grand += cm.count_ones();
            child += 1;
        }
    }

    /// A subtree seen only by the light: descend to the light's level of detail and let every
    /// sample there cast into the shadow map.
    fn cast_only(&mut self, level: u8, index: u32, mask: u32, first_child: u32, p: H::Pos) {
        self.stats.nodes_visited += 1;
        let l = usize::from(level);
        if level == self.frame.depth
            || self.hooks.light_stop(l)
            || (D::STREAMED
                && !self
                    .data
                    .children_resident(level, index, first_child, mask.count_ones()))
        {
            self.hooks.casts(l, p);
            return;
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

    /// Screen centre and diameter (Q4 pixels) of a cell at level `l` with projected centre `c`: one
    /// reciprocal look-up and three multiplies.
    #[inline(always)]
    fn project(&self, l: usize, c: [i32; 3]) -> (i32, i32, i32) {
        let [x, y, w] = c;
        let (r, shift) = recip(w as u32);
        let r = i64::from(r);
        let sh = shift - SUBPIXEL_BITS;
        let half = 1i64 << (sh - 1);
        let x_q4 = ((i64::from(x) * r + half) >> sh) as i32;
        let y_q4 = ((i64::from(y) * r + half) >> sh) as i32;
        let (k, kshift) = self.frame.size_k[l];
        let size_q4 = if shift > kshift {
            ((u64::from(k) * r as u64) >> (shift - kshift)).min(i32::MAX as u64) as i32
        } else {
            i32::MAX
        };
        (x_q4, y_q4, size_q4)
    }

    #[inline]
    fn draw(&mut self, level: u8, index: u32, c: [i32; 3], p: H::Pos) {
        let f = self.frame;
        let [_, _, w] = c;
        let l = usize::from(level);
        if w < f.near_w {
            self.hooks.casts(l, p);
            return;
        }
        let attr = self.data.attr(level, index);
        let code = usize::from(attr & 0x1FFF);
        if f.backface[code / 32] >> (code % 32) & 1 != 0 {
            self.stats.backfacing += 1;
            self.hooks.casts(l, p);
            return;
        }
        let shadowed = self.hooks.drawn(l, p, attr);
        let (x_q4, y_q4, size_q4) = self.project(l, c);
        let dz = (w - f.depth_w0).max(0) as u64;
        let depth = ((dz * f.depth_scale) >> 32).min(65534) as u16;
        self.stats.splats += 1;
        self.stats.shadowed += u32::from(shadowed);
        self.stats.max_level = self.stats.max_level.max(level);
        self.sink.splat(&SampleSplat {
            x_q4,
            y_q4,
            size_q4,
            depth,
            attr,
            level,
            index,
            shadowed,
        });
    }
}
