//! Where the tri-grid walk reads a grid's arrays ([`NodeData`]): a memory-resident file
//! ([`Resident`], read in place, validated once so that its reads need no bounds checks), a
//! bricked one (`super::bricked`) or blocks streamed into a cache (`crate::stream`).
#![deny(clippy::float_arithmetic)]

use super::read::{LevelArrays, TriGrid};

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
    /// Child mask word of cell `i` at `level`, for ρ ≤ 3 (0 when it cannot be read): the child
    /// bits below ρ³ and, for ρ = 3, the normal-cone class in bits 27..30 (FORMAT.md).
    fn mask(&self, level: u8, i: u32) -> u32;
    /// [`NodeData::mask`] for a walk that knows ρ at compile time.
    #[inline(always)]
    fn mask_of<const RHO: u8>(&self, level: u8, i: u32) -> u32 {
        self.mask(level, i)
    }
    /// Group pointer of cell `i` at `level` (0 when it cannot be read).
    fn group(&self, level: u8, i: u32) -> u32;
    /// Whether everything the descent into the `n` children of cell `index` at `level` reads is
    /// resident: their attributes and masks (the first at `first_child` on `level + 1`) and the cell's
    /// group pointer. A streamed source also notes the blocks as used by this frame.
    fn children_resident(&mut self, level: u8, index: u32, first_child: u32, n: u32) -> bool;
    /// Asks for the blocks [`NodeData::children_resident`] found missing; the cell's projected
    /// diameter (Q8 pixels) and centre row (Q8 pixels) set the priority (Streaming QSplat §4.2).
    fn request_children(
        &mut self,
        level: u8,
        index: u32,
        first_child: u32,
        n: u32,
        size_q8: i32,
        y_q8: i32,
    );
    /// Whether the levels below [`NodeData::brick_level`] are in bricks (version 3, FORMAT.md
    /// "Bricks"): the walk then calls [`NodeData::enter`] before it reads below a cell of that
    /// level. `false` compiles the calls away.
    const BRICKED: bool = false;
    /// The brick level (asked only when [`NodeData::BRICKED`]).
    #[inline(always)]
    fn brick_level(&self) -> u8 {
        u8::MAX
    }
    /// The walk is about to read below cell `index` of the brick level: the data switches to the
    /// brick holding it. (Asked only when [`NodeData::BRICKED`].)
    #[inline(always)]
    fn enter(&mut self, _index: u32) {}
    /// Whether the walk leaves cell `index` at `level` alone (neither draws nor descends into it):
    /// a refined frame drawn in passes over subtrees skips what an earlier pass drew and what a
    /// later one will (`crate::stream`). Asked only when [`NodeData::STREAMED`].
    #[inline(always)]
    fn skip(&mut self, _level: u8, _index: u32) -> bool {
        false
    }
}

/// A memory-resident grid: every block is present, reads are slices cut once per level.
///
/// Its reads are not bounds-checked: [`TriGrid::open`] proved every index the walk can compute
/// (see the private module `unchecked`).
///
/// `ALIGNED`: every array starts at a multiple of 4 bytes in memory (the format aligns them within
/// the file, so the file's own place in memory decides; [`Resident::aligned`]), and words are read
/// with one load on cores that have no unaligned loads (the M0+, where an unaligned `u32` is four
/// byte loads and their shifts). A separate type, so that the walk is compiled for each and no
/// read tests a flag.
#[derive(Clone, Copy, Debug)]
pub struct Resident<'g, const ALIGNED: bool = false> {
    /// Indexed by `level & 15`: in range without a check.
    arrays: [LevelArrays<'g>; 16],
    rho: u8,
    depth: u8,
}

impl<'g> Resident<'g> {
    /// The arrays of `grid`, cut once.
    pub fn new(grid: &TriGrid<'g>) -> Self {
        let h = grid.header();
        let mut arrays = [LevelArrays::default(); 16];
        for (l, a) in arrays.iter_mut().enumerate().take(h.levels()) {
            *a = grid.arrays(l as u8);
        }
        Resident {
            arrays,
            rho: h.rho,
            depth: h.depth,
        }
    }

    /// The same reader reading whole words, when every array starts at a multiple of 4 bytes.
    pub fn aligned(self) -> Option<Resident<'g, true>> {
        // (An empty array is never read: where it points does not matter.)
        let word = |b: &[u8]| b.is_empty() || (b.as_ptr() as usize).is_multiple_of(4);
        self.arrays
            .iter()
            .all(|a| word(a.attrs) && word(a.masks) && word(a.groups))
            .then_some(Resident {
                arrays: self.arrays,
                rho: self.rho,
                depth: self.depth,
            })
    }
}

impl<'g, const ALIGNED: bool> Resident<'g, ALIGNED> {
    #[inline(always)]
    fn level(&self, level: u8) -> &LevelArrays<'g> {
        &self.arrays[usize::from(level & 15)]
    }
}

/// The walk's reads of a validated grid, without bounds checks (the "validation once").
///
/// Every index the walk passes here was proven in range by [`TriGrid::open`]'s structure check
/// (FORMAT.md "Validation"): a level's count is the number of child bits at the level above, every
/// group entry is the running count it stands for, and mask bits at or above ρ³ are clear (the
/// walk masks the cone bits off before counting). The walk derives a child's index from its
/// parent's group entry plus the child bits of its elder siblings, exactly as the check recomputes
/// them, so `i < count` at `level` for every read, and each array holds `count` elements.
/// `debug_assert!`s check it in tests.
#[allow(unsafe_code)]
mod unchecked {
    use super::LevelArrays;

    /// Attribute `i`: `2i + 2 ≤ attrs.len()`.
    #[inline(always)]
    pub(super) fn attr(a: &LevelArrays<'_>, i: u32, aligned: bool) -> u16 {
        let at = 2 * i as usize;
        debug_assert!(at + 2 <= a.attrs.len());
        // SAFETY: the walk reads only validated indices (module docs), so `at + 2 ≤ len`.
        let p = unsafe { a.attrs.as_ptr().add(at) }.cast::<u16>();
        #[cfg(no_unaligned_loads)]
        if aligned {
            debug_assert!(p.is_aligned());
            // SAFETY: as above, and `at` is even, so `p` is aligned if the array is.
            return u16::from_le(unsafe { p.read() });
        }
        let _ = aligned;
        // SAFETY: as above.
        u16::from_le(unsafe { p.read_unaligned() })
    }

    /// ρ = 3 mask word `i`: `4i + 4 ≤ masks.len()`. `aligned`: the array starts at a multiple
    /// of 4 bytes (so does each of these readers').
    #[inline(always)]
    pub(super) fn mask_u32(a: &LevelArrays<'_>, i: u32, aligned: bool) -> u32 {
        let at = 4 * i as usize;
        debug_assert!(at + 4 <= a.masks.len());
        // SAFETY: as for `attr`; `at` is a multiple of 4, so the word is aligned if the array is.
        unsafe { word(a.masks.as_ptr().add(at), aligned) }
    }

    /// The little-endian word at `p`: one load where `aligned` says `p` is a multiple of 4 and the
    /// core cannot load unaligned words (four byte loads and their shifts otherwise).
    ///
    /// # Safety
    /// `p..p + 4` is readable, and a multiple of 4 when `aligned`.
    #[inline(always)]
    unsafe fn word(p: *const u8, aligned: bool) -> u32 {
        #[cfg(no_unaligned_loads)]
        if aligned {
            debug_assert!(p.cast::<u32>().is_aligned());
            // SAFETY: the caller's.
            return u32::from_le(unsafe { p.cast::<u32>().read() });
        }
        let _ = aligned;
        // SAFETY: the caller's.
        u32::from_le(unsafe { p.cast::<u32>().read_unaligned() })
    }

    /// ρ = 2 mask `i`: `i < masks.len()`.
    #[inline(always)]
    pub(super) fn mask_u8(a: &LevelArrays<'_>, i: u32) -> u32 {
        debug_assert!((i as usize) < a.masks.len());
        // SAFETY: as for `attr`.
        u32::from(unsafe { *a.masks.get_unchecked(i as usize) })
    }

    /// Group entry `i`: `4i + 4 ≤ groups.len()`.
    #[inline(always)]
    pub(super) fn group(a: &LevelArrays<'_>, i: u32, aligned: bool) -> u32 {
        let at = 4 * i as usize;
        debug_assert!(at + 4 <= a.groups.len());
        // SAFETY: as for `mask_u32`.
        unsafe { word(a.groups.as_ptr().add(at), aligned) }
    }
}

impl<const ALIGNED: bool> NodeData for Resident<'_, ALIGNED> {
    const STREAMED: bool = false;
    #[inline(always)]
    fn shape(&self) -> (u8, u8) {
        (self.rho, self.depth)
    }
    #[inline(always)]
    fn attr(&self, level: u8, i: u32) -> u16 {
        unchecked::attr(self.level(level), i, ALIGNED)
    }
    #[inline(always)]
    fn mask(&self, level: u8, i: u32) -> u32 {
        let a = self.level(level);
        if self.rho == 2 {
            unchecked::mask_u8(a, i)
        } else {
            unchecked::mask_u32(a, i, ALIGNED)
        }
    }
    #[inline(always)]
    fn mask_of<const RHO: u8>(&self, level: u8, i: u32) -> u32 {
        let a = self.level(level);
        if RHO == 2 {
            unchecked::mask_u8(a, i)
        } else {
            unchecked::mask_u32(a, i, ALIGNED)
        }
    }
    #[inline(always)]
    fn group(&self, level: u8, i: u32) -> u32 {
        unchecked::group(self.level(level), i, ALIGNED)
    }
    #[inline(always)]
    fn children_resident(&mut self, _: u8, _: u32, _: u32, _: u32) -> bool {
        true
    }
    #[inline(always)]
    fn request_children(&mut self, _: u8, _: u32, _: u32, _: u32, _: i32, _: i32) {}
}
