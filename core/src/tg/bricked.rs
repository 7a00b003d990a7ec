//! The resident walk's reads of a bricked grid (version 3, FORMAT.md "Bricks"): as
//! [`super::Resident`]'s, one base address per level and array, except that the levels in bricks
//! get the current brick's, switched when the walk enters a cell of the brick level
//! ([`NodeData::enter`]). Indices stay global: a brick's slice of a level is addressed from a base
//! its first index's elements before the slice, so that a read costs what it costs in a level-ordered
//! file, and the walk pays only for the switches (one per brick it enters).
#![deny(clippy::float_arithmetic)]

use super::brick::{self, Array};
use super::nodes::NodeData;
use super::read::TriGrid;
use super::MAX_LEVELS;

/// A validated, bricked, memory-resident grid as the walk reads it.
///
/// Its reads are not bounds-checked, as [`super::Resident`]'s are not: [`TriGrid::open`] checked
/// every brick (its counts are its cells' children, its group pointers the running counts within
/// it, and the table's first indices partition every level in the walk's order), so the
/// descendants of a brick-level cell lie in its brick's slice of every level below; the walk reads
/// a level below the brick level only under the brick-level cell it last entered (see the private
/// module `unchecked`).
///
/// Entering a brick reads its table entry and lays its arrays out inline, passing no reference into
/// the walker to a function that is not inlined: the walker's fields then stay its own, and the walk
/// need not load the bases again after every call it makes (measured: a call out of line cost the
/// bunny's std frame 0.6 M instructions beside the switches' own).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Bricked<'g> {
    /// By `level & 15`: the address of element 0 of each array (attributes, masks, groups), as if
    /// the level were one array (for a level in bricks, of the current brick's slice less its
    /// first index; never read there outside the slice).
    base: [[*const u8; 3]; 16],
    /// The brick-level cells of the current brick: the first and how many (0: none yet).
    first_cell: u32,
    cells: u32,
    /// The current brick's index.
    brick: u32,
    /// The brick level, ρ and the depth.
    level: u8,
    rho: u8,
    depth: u8,
    /// The grid (what entering a brick reads: its table entry, the level counts, the header).
    grid: &'g TriGrid<'g>,
    /// Debug builds: by level and array, the bytes the current base may be read at.
    #[cfg(debug_assertions)]
    span: [[(usize, usize); 3]; 16],
}

/// Reads at a base address, without bounds checks.
///
/// Every address read is `base[level][array] + size · i` for an index `i` the walk derived as the
/// resident walk derives it, so that it lies in the level's array (for a head or leaf level: as for
/// `Resident`, by the structure check) or, for a level in bricks, in the slice of the brick of the
/// brick-level cell entered last, which holds every descendant of that cell at that level (by the
/// brick checks of [`TriGrid::open`]); the walk enters that cell before reading below it
/// (`traverse.rs`: [`NodeData::enter`] at the brick level, in `node`, `final_parents` and
/// `cast_only`). `debug_assert!`s check each read against the span in tests.
#[allow(unsafe_code)]
mod unchecked {
    /// The `u16` at `base + at`.
    #[inline(always)]
    pub(super) fn u16_at(base: *const u8, at: usize) -> u16 {
        // SAFETY: `base + at .. + 2` lies in the file (module docs).
        u16::from_le(unsafe { base.wrapping_add(at).cast::<u16>().read_unaligned() })
    }

    /// The `u32` at `base + at`.
    #[inline(always)]
    pub(super) fn u32_at(base: *const u8, at: usize) -> u32 {
        // SAFETY: as for `u16_at`.
        u32::from_le(unsafe { base.wrapping_add(at).cast::<u32>().read_unaligned() })
    }

    /// The byte at `base + at`.
    #[inline(always)]
    pub(super) fn u8_at(base: *const u8, at: usize) -> u8 {
        // SAFETY: as for `u16_at`.
        unsafe { base.wrapping_add(at).read() }
    }
}

impl<'g> Bricked<'g> {
    /// The arrays of a bricked `grid` (validated by [`TriGrid::open`]), no brick entered yet.
    pub(crate) fn new(grid: &'g TriGrid<'g>) -> Self {
        let h = grid.header();
        let mut b = Bricked {
            base: [[grid.bytes().as_ptr(); 3]; 16],
            first_cell: 0,
            cells: 0,
            brick: 0,
            level: h.brick_level,
            rho: h.rho,
            depth: h.depth,
            grid,
            #[cfg(debug_assertions)]
            span: [[(0, 0); 3]; 16],
        };
        let mb = h.mask_bytes() as usize;
        for l in 0..h.levels() {
            let dir = grid.level(l as u8);
            let n = dir.count as usize;
            for (k, (off, size)) in [(dir.attr_off, 2), (dir.mask_off, mb), (dir.group_off, 4)]
                .into_iter()
                .enumerate()
            {
                if off != 0 {
                    b.set(l, k, off as u64, 0, size, n);
                }
            }
        }
        b
    }

    /// Points array `k` of level `l` at the slice of `n` elements of `size` bytes at byte `off`,
    /// whose first element is index `first` of the level.
    #[inline(always)]
    fn set(&mut self, l: usize, k: usize, off: u64, first: u32, size: usize, n: usize) {
        self.base[l & 15][k] = self
            .grid
            .bytes()
            .as_ptr()
            .wrapping_add(off as usize)
            .wrapping_sub(size.wrapping_mul(first as usize));
        #[cfg(debug_assertions)]
        {
            self.span[l & 15][k] = (off as usize, off as usize + size * n);
        }
        let _ = n;
    }

    /// Enters the brick holding brick-level cell `index`: the next brick (a walk in slot order
    /// meets them in order), or the one a binary search of the table finds.
    #[inline(always)]
    fn switch(&mut self, index: u32) {
        let grid = self.grid;
        let h = grid.header();
        let r = self.level;
        let table = grid.brick_table();
        let entry = brick::entry_bytes(r, h.depth);
        // Word `k` of entry `b` (0 past the table: never, in a validated file).
        let word = |b: u32, k: usize| -> u32 {
            let at = (b as usize).wrapping_mul(entry) + 4 * k;
            table
                .get(at..at + 4)
                .map_or(0, |w| u32::from_le_bytes([w[0], w[1], w[2], w[3]]))
        };
        // The first cell of brick `b` at level `l`, or the level's count past the last brick.
        let first = |b: u32, l: u8| -> u32 {
            if b >= h.bricks {
                grid.level(l).count
            } else if l == r {
                word(b, 0)
            } else {
                word(b, 2 + usize::from(l - r - 1))
            }
        };
        let next = self.brick.wrapping_add(u32::from(self.cells != 0));
        let b = if next < h.bricks && first(next, r) <= index && index < first(next + 1, r) {
            next
        } else {
            find(table, entry, h.bricks, index)
        };
        self.brick = b;
        let start = u64::from(word(b, 1)) << h.block_log2;
        let mut firsts = [0u32; MAX_LEVELS];
        let mut count = [0u32; MAX_LEVELS];
        for l in r..=h.depth {
            let (lu, f) = (usize::from(l), first(b, l));
            firsts[lu] = f;
            count[lu] = first(b + 1, l).wrapping_sub(f);
        }
        self.first_cell = firsts[usize::from(r)];
        self.cells = count[usize::from(r)];
        let mb = h.mask_bytes() as usize;
        brick::lay_out(h, &count, |l, a, off| {
            let (k, size) = match a {
                Array::Attr => (0, 2),
                Array::Mask => (1, mb),
                Array::Group => (2, 4),
                Array::Color => return,
            };
            let lu = usize::from(l);
            self.set(lu, k, start + off, firsts[lu], size, count[lu] as usize);
        });
    }

    #[cfg(debug_assertions)]
    fn check(&self, level: u8, k: usize, at: usize, size: usize) {
        let (lo, hi) = self.span[usize::from(level & 15)][k];
        let base = self.base[usize::from(level & 15)][k] as usize;
        let addr = base
            .wrapping_add(at)
            .wrapping_sub(self.grid.bytes().as_ptr() as usize);
        debug_assert!(
            addr >= lo && addr + size <= hi,
            "read of level {level} array {k} at {addr} outside {lo}..{hi}"
        );
    }
}

/// The brick of a table (`bricks` entries of `entry` bytes) holding brick-level cell `index`: the
/// last whose first cell is at most `index`. Takes no reference into the walker (see [`Bricked`]).
#[inline(never)]
fn find(table: &[u8], entry: usize, bricks: u32, index: u32) -> u32 {
    let first = |b: u32| {
        let at = b as usize * entry;
        table
            .get(at..at + 4)
            .map_or(u32::MAX, |w| u32::from_le_bytes([w[0], w[1], w[2], w[3]]))
    };
    let (mut lo, mut hi) = (0u32, bricks);
    while hi - lo > 1 {
        let mid = lo + (hi - lo) / 2;
        if first(mid) <= index {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

impl NodeData for Bricked<'_> {
    const STREAMED: bool = false;
    const BRICKED: bool = true;
    #[inline(always)]
    fn shape(&self) -> (u8, u8) {
        (self.rho, self.depth)
    }
    #[inline(always)]
    fn brick_level(&self) -> u8 {
        self.level
    }
    #[cold]
    #[inline(never)]
    fn enter(&mut self, index: u32) {
        if index.wrapping_sub(self.first_cell) >= self.cells {
            self.switch(index);
        }
    }
    #[inline(always)]
    fn attr(&self, level: u8, i: u32) -> u16 {
        let at = 2 * i as usize;
        #[cfg(debug_assertions)]
        self.check(level, 0, at, 2);
        unchecked::u16_at(self.base[usize::from(level & 15)][0], at)
    }
    #[inline(always)]
    fn mask(&self, level: u8, i: u32) -> u32 {
        if self.rho == 2 {
            self.mask_of::<2>(level, i)
        } else {
            self.mask_of::<3>(level, i)
        }
    }
    #[inline(always)]
    fn mask_of<const RHO: u8>(&self, level: u8, i: u32) -> u32 {
        let base = self.base[usize::from(level & 15)][1];
        if RHO == 2 {
            #[cfg(debug_assertions)]
            self.check(level, 1, i as usize, 1);
            u32::from(unchecked::u8_at(base, i as usize))
        } else {
            #[cfg(debug_assertions)]
            self.check(level, 1, 4 * i as usize, 4);
            unchecked::u32_at(base, 4 * i as usize)
        }
    }
    #[inline(always)]
    fn group(&self, level: u8, i: u32) -> u32 {
        let at = 4 * i as usize;
        #[cfg(debug_assertions)]
        self.check(level, 2, at, 4);
        unchecked::u32_at(self.base[usize::from(level & 15)][2], at)
    }
    #[inline(always)]
    fn children_resident(&mut self, _: u8, _: u32, _: u32, _: u32) -> bool {
        true
    }
    #[inline(always)]
    fn request_children(&mut self, _: u8, _: u32, _: u32, _: u32, _: i32, _: i32) {}
}
