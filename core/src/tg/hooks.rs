//! What a shadow algorithm adds to the tri-grid walk ([`ShadowHooks`], none: [`NoShadows`]) and the
//! order of the child slots it may ask for ([`SlotOrder`], Duguet §5.3: nearest to the light first).
#![deny(clippy::float_arithmetic)]

use super::frame::MAX_SLOTS;

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
    /// Whether the walk's flat loops over a cell's children test them all first, in a loop of
    /// their own ([`ShadowHooks::drawn_children`]), before the view draws any: for hooks where
    /// every child casts, drawn or not (one-pass shadows), so that the light's registers stay out
    /// of the view's loop. Otherwise the view tests each child it draws as it draws it
    /// ([`ShadowHooks::drawn`]) and the others only cast ([`ShadowHooks::casts`]).
    const TESTS_FIRST: bool = false;
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
    /// The children (the slots of `mask`, child bits only) of a cell at `level - 1` with
    /// light-space position `parent`, each as a sample drawn with attribute `attr(i)` (`i`: its
    /// rank among them), in slot order: the slots of those in shadow. By default
    /// [`ShadowHooks::drawn`] for each.
    #[inline(always)]
    fn drawn_children(
        &mut self,
        parent: Self::Pos,
        level: usize,
        mask: u32,
        attr: impl Fn(u32) -> u16,
    ) -> u32
    where
        Self: Sized,
    {
        drawn_each(self, parent, level, mask, attr)
    }
    /// A sample that casts but is not drawn (backfacing, or in a culled subtree): fill only.
    fn casts(&mut self, level: usize, p: Self::Pos);
    /// Whether a subtree the view does not draw, whose cell has normal `code` and cone `class`
    /// (classes 0 and 7 bound nothing), faces away from the light at every sample, so that its
    /// casts can be left out. (No default: a wrapper that forgot to forward it would walk what
    /// the hooks it wraps leave out.)
    fn unlit(&self, class: usize, code: usize) -> bool;
    /// Whether a cell at `level` is small enough in the shadow map to stop a fill-only descent.
    fn light_stop(&self, level: usize) -> bool;
    /// Where a fill-only descent stops ([`ShadowHooks::light_stop`]): the cell at `level`, whose
    /// children are the slots of `mask` (its child bits only), casts. By default as one sample.
    #[inline(always)]
    fn casts_subtree(&mut self, level: usize, p: Self::Pos, mask: u32) {
        let _ = mask;
        self.casts(level, p);
    }
    /// A cell at `level` whose children (the slots of `mask`, its child bits only) have all been
    /// visited by the view walk.
    #[inline(always)]
    fn descended(&mut self, _level: usize, _p: Self::Pos, _mask: u32) {}
}

/// [`ShadowHooks::drawn_children`] as [`ShadowHooks::drawn`] for each child.
#[inline(always)]
pub(crate) fn drawn_each<H: ShadowHooks>(
    hooks: &mut H,
    parent: H::Pos,
    level: usize,
    mask: u32,
    attr: impl Fn(u32) -> u16,
) -> u32 {
    let mut shadowed = 0;
    each_slot(mask, |i, s| {
        let p = hooks.child(parent, level, s);
        shadowed |= u32::from(hooks.drawn(level, p, attr(i))) << s;
    });
    shadowed
}

/// `visit(i, s)` for each set bit `s` of `mask`, lowest first, `i` its rank (0, 1, …).
#[inline(always)]
pub(crate) fn each_slot(mask: u32, mut visit: impl FnMut(u32, usize)) {
    let mut i = 0;
    let mut m = mask;
    while m != 0 {
        let s = m.trailing_zeros() as usize & 31;
        m &= m - 1;
        visit(i, s);
        i += 1;
    }
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
    #[inline(always)]
    fn unlit(&self, _: usize, _: usize) -> bool {
        false
    }
}

/// An order of the ρ³ child slots (Duguet §5.3: nearest to the light first), with the look-up that
/// visits a cell's present children in it without scanning all 27: the child mask, 7 bits at a
/// time, maps to the set of the present slots' positions in the order.
#[derive(Clone, Debug)]
pub struct SlotOrder {
    pub(crate) slots: [u8; MAX_SLOTS],
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
    pub(crate) fn positions(&self, mask: u32) -> u32 {
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
