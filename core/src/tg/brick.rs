//! Version 3's bricks (FORMAT.md "Bricks"): where a brick's arrays lie, and the checks of the brick
//! table and of one brick, shared by the resident reader ([`super::TriGrid::open`]), the streaming
//! reader (`crate::stream`, at open and as the walk enters a brick) and the writer.
//!
//! A bricked file keeps levels `0..=R` level-ordered (the head, `R` = [`Header::brick_level`]) and
//! the leaves level-ordered; the levels between them are cut into bricks, each the subtrees of a run
//! of consecutive level-`R` cells, starting on a block. Indices stay global per level: a brick holds
//! the slice `first..first + count` of each of its levels, so that only where each slice lies in the
//! file changes, and a reader switches its per-level array bases when the walk enters a brick.
//!
//! Every rule here reads the file through a `read(offset, bytes)` closure (a slice in memory, or the
//! block cache), so that the same code checks a file in flash, in RAM or streamed.
#![deny(clippy::float_arithmetic)]

pub use super::header::{entry_bytes, ENTRY_HEAD};
use super::header::{mask_word_ok, slot_bits, Header, LevelDir, TgError};
use super::MAX_LEVELS;

/// One entry of the brick table.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BrickEntry {
    /// The brick's first cell at the brick level (it holds the cells up to the next entry's).
    pub first_cell: u32,
    /// The block the brick starts at.
    pub block: u32,
    /// By level: the global index of the brick's first cell at levels `R + 1..=depth` (0 at the
    /// others).
    pub first: [u32; MAX_LEVELS],
}

impl BrickEntry {
    /// Parses an entry from its [`entry_bytes`] bytes; `None` when they are short.
    pub fn parse(h: &Header, bytes: &[u8]) -> Option<Self> {
        let word = |k: usize| {
            let b = bytes.get(4 * k..4 * k + 4)?;
            Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        };
        let mut e = BrickEntry {
            first_cell: word(0)?,
            block: word(1)?,
            first: [0; MAX_LEVELS],
        };
        for (k, l) in (h.brick_level + 1..=h.depth).enumerate() {
            *e.first.get_mut(usize::from(l))? = word(2 + k)?;
        }
        Some(e)
    }

    /// Writes the entry into its [`entry_bytes`] bytes of `out`.
    pub fn write(&self, h: &Header, out: &mut [u8]) {
        let words = [self.first_cell, self.block]
            .into_iter()
            .chain((h.brick_level + 1..=h.depth).map(|l| self.first[usize::from(l)]));
        for (chunk, w) in out.chunks_exact_mut(4).zip(words) {
            chunk.copy_from_slice(&w.to_le_bytes());
        }
    }
}

/// One array of a level.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Array {
    /// Attributes, `u16`.
    Attr,
    /// RGB565 colours, `u16`.
    Color,
    /// Child masks.
    Mask,
    /// Group pointers, `u32`.
    Group,
}

/// Lays out a brick holding `count[l]` cells of each level `l` in `R..=depth` (`count[R]` cells of
/// the brick level, whose group pointers it holds, then every array of each level `R + 1..depth`),
/// calling `put(level, array, offset)` with each array's offset from the brick's start, and returns
/// the brick's length in bytes. Each array starts on a multiple of 4 bytes (masks: of their own
/// size, when larger), so that no element straddles two blocks.
#[inline(always)]
pub fn lay_out(h: &Header, count: &[u32; MAX_LEVELS], mut put: impl FnMut(u8, Array, u64)) -> u64 {
    let mb = u64::from(h.mask_bytes());
    let mut at = 0u64;
    let mut place = |level: u8, array: Array, align: u64, bytes: u64| {
        at = at.next_multiple_of(align);
        put(level, array, at);
        at += bytes;
    };
    let r = h.brick_level;
    let n = |l: u8| u64::from(count.get(usize::from(l)).copied().unwrap_or(0));
    place(r, Array::Group, 4, 4 * n(r));
    for l in r + 1..h.depth {
        let k = n(l);
        place(l, Array::Attr, 4, 2 * k);
        if h.has_color() {
            place(l, Array::Color, 4, 2 * k);
        }
        place(l, Array::Mask, mb.max(4), mb * k);
        if l + 2 <= h.depth {
            place(l, Array::Group, 4, 4 * k);
        }
    }
    at
}

/// A brick: its cells per level and where its arrays lie in the file.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Brick {
    /// Its index in the brick table.
    pub index: u32,
    /// By level `R..=depth`: the global index of its first cell there (level `R`: its first cell).
    pub first: [u32; MAX_LEVELS],
    /// By level `R..=depth`: its cells there.
    pub count: [u32; MAX_LEVELS],
    /// Byte offset of its start (a block's).
    pub start: u64,
    /// Byte offset one past its end.
    pub end: u64,
    /// By level: byte offsets in the file of its arrays (attributes, colours, masks, groups; 0 for
    /// an array it does not hold): level `R`'s groups and every array of the levels below.
    pub arrays: [[u64; 4]; MAX_LEVELS],
}

impl Brick {
    /// The brick entry `e` describes, `next` being the entry after it (`None` for the last): its
    /// counts and its arrays' offsets. Checks what one entry and its successor can show: counts
    /// that the level rules allow (each cell has 1 to ρ³ children), the first entry starting every
    /// level at 0, and the brick ending before the next one starts (the last: by `band_end`).
    ///
    /// # Errors
    /// [`TgError::BadBrickEntry`] naming the brick.
    pub fn of(
        h: &Header,
        levels: &[LevelDir; MAX_LEVELS],
        index: u32,
        e: &BrickEntry,
        next: Option<&BrickEntry>,
        band_end: u64,
    ) -> Result<Brick, TgError> {
        let bad = TgError::BadBrickEntry { brick: index };
        let r = usize::from(h.brick_level);
        let depth = usize::from(h.depth);
        let cells = u64::from(u32::from(h.rho).pow(3));
        let mut b = Brick {
            index,
            start: u64::from(e.block) << h.block_log2,
            ..Brick::default()
        };
        b.first[r] = e.first_cell;
        b.first[r + 1..=depth].copy_from_slice(&e.first[r + 1..=depth]);
        #[allow(clippy::needless_range_loop)] // `first`, `count`, `levels` and `next` by level
        for l in r..=depth {
            let end = match next {
                Some(n) if l == r => n.first_cell,
                Some(n) => n.first[l],
                None => levels[l].count,
            };
            b.count[l] = end.checked_sub(b.first[l]).ok_or(bad)?;
            if index == 0 && b.first[l] != 0 {
                return Err(bad);
            }
            let c = u64::from(b.count[l]);
            if l == r {
                if c == 0 {
                    return Err(bad);
                }
            } else if c < u64::from(b.count[l - 1]) || c > cells * u64::from(b.count[l - 1]) {
                return Err(bad);
            }
        }
        let mut arrays = [[0u64; 4]; MAX_LEVELS];
        let start = b.start;
        let len = lay_out(h, &b.count, |l, a, off| {
            arrays[usize::from(l)][a as usize] = start + off;
        });
        b.arrays = arrays;
        b.end = b.start + len;
        let limit = match next {
            Some(n) => u64::from(n.block) << h.block_log2,
            None => band_end,
        };
        if b.end > limit || next.is_some_and(|n| n.block <= e.block) {
            return Err(bad);
        }
        Ok(b)
    }

    /// Byte offset of element `i` (a global index at `level`) of `array`, when the brick holds it.
    pub fn offset(&self, h: &Header, level: u8, array: Array, i: u32) -> Option<u64> {
        let l = usize::from(level);
        let base = *self.arrays.get(l)?.get(array as usize)?;
        let k = i.checked_sub(self.first[l])?;
        if base == 0 || k >= self.count[l] {
            return None;
        }
        let size = match array {
            Array::Attr | Array::Color => 2,
            Array::Mask => u64::from(h.mask_bytes()),
            Array::Group => 4,
        };
        Some(base + size * u64::from(k))
    }
}

/// Where the bricks must end: the first array of the leaf level (the bricks lie between the brick
/// table and the leaves), or the file's end.
pub fn band_end(h: &Header, levels: &[LevelDir; MAX_LEVELS]) -> u64 {
    let leaves = &levels[usize::from(h.depth)];
    [leaves.attr_off, leaves.color_off]
        .into_iter()
        .filter(|&o| o != 0)
        .map(u64::from)
        .min()
        .unwrap_or(u64::from(h.blocks) << h.block_log2)
}

/// Reads the little-endian word of `n` bytes (at most 16) at file offset `off` through `read`.
#[inline(always)]
fn word(read: &mut impl FnMut(u64, usize) -> Option<u128>, off: u64, n: usize) -> Option<u128> {
    read(off, n)
}

/// Checks the head of a file, the levels whose arrays are in the level directory (all of them
/// without bricks): every mask there has a child and no bit the format keeps clear, each level's
/// count is the number of child bits at the level above, and every group pointer there is the
/// running count it stands for (FORMAT.md "Validation"). `read(offset, n)` gives the `n`-byte
/// little-endian word at a file offset (`None` when it cannot: a failed read).
///
/// # Errors
/// The first fault found: [`TgError::BadMask`], [`TgError::CountMismatch`], [`TgError::BadGroup`]
/// (or [`TgError::TooShort`] when a read fails).
pub fn check_head(
    h: &Header,
    levels: &[LevelDir; MAX_LEVELS],
    read: &mut impl FnMut(u64, usize) -> Option<u128>,
) -> Result<(), TgError> {
    let mb = h.mask_bytes() as usize;
    let short = TgError::TooShort(0);
    let mask = |read: &mut _, l: u8, i: u32| -> Result<u128, TgError> {
        let off = u64::from(levels[usize::from(l)].mask_off) + mb as u64 * u64::from(i);
        word(read, off, mb).ok_or(short)
    };
    let head = h.head_level().min(h.depth.saturating_sub(1));
    for l in 0..h.depth.min(head + 1) {
        let mut children = 0u32;
        for i in 0..levels[usize::from(l)].count {
            let w = mask(read, l, i)?;
            if !mask_word_ok(h, w) {
                return Err(TgError::BadMask { level: l, index: i });
            }
            children = children.saturating_add(slot_bits(h, w).count_ones());
        }
        let found = levels[usize::from(l) + 1].count;
        if children != found {
            return Err(TgError::CountMismatch {
                level: l + 1,
                expected: children,
                found,
            });
        }
    }
    // group[p] at level L = first grandchild of p = running count of masks at level L+1.
    for l in (0..h.depth.saturating_sub(1)).filter(|&l| h.group_listed(l)) {
        let (mut child, mut grandchild) = (0u32, 0u32);
        let groups = u64::from(levels[usize::from(l)].group_off);
        for p in 0..levels[usize::from(l)].count {
            let g = word(read, groups + 4 * u64::from(p), 4).ok_or(short)?;
            if g != u128::from(grandchild) {
                return Err(TgError::BadGroup { level: l, index: p });
            }
            let n = slot_bits(h, mask(read, l, p)?).count_ones();
            for c in child..child.saturating_add(n) {
                let w = mask(read, l + 1, c)?;
                grandchild = grandchild.saturating_add(slot_bits(h, w).count_ones());
            }
            child = child.saturating_add(n);
        }
    }
    Ok(())
}

/// What the largest bricks of a file span, from its brick table ([`check_table`]): what a streaming
/// reader must hold at once to enter one (`crate::stream`, "the cache a file needs").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BrickSpans {
    /// Blocks the largest brick spans.
    pub brick: u32,
    /// The most blocks checking one brick reads: its own and those of the head's masks of its cells
    /// ([`check_brick`]).
    pub checked: u32,
}

/// Blocks of `2^log2` bytes that bytes `off..off + len` touch (0 for none).
pub fn blocks_spanned(off: u64, len: u64, log2: u8) -> u32 {
    if len == 0 {
        return 0;
    }
    let last = off.saturating_add(len - 1) >> log2;
    u32::try_from(last - (off >> log2) + 1).unwrap_or(u32::MAX)
}

/// Checks the brick table of a bricked file, whose head [`check_head`] passed: every entry in order
/// and in range ([`Brick::of`]), the first brick after the table, and each brick's first index at
/// the level below the brick level equal to the children of the brick-level cells before it (the
/// running count of the head's masks there), so that the bricks partition every level in the walk's
/// order. `read` as for [`check_head`]. Returns what the largest bricks span.
///
/// # Errors
/// [`TgError::BadBrickEntry`] naming the first brick out of order (or [`TgError::TooShort`] when a
/// read fails).
pub fn check_table(
    h: &Header,
    levels: &[LevelDir; MAX_LEVELS],
    read: &mut impl FnMut(u64, usize) -> Option<u128>,
) -> Result<BrickSpans, TgError> {
    let entry = entry_bytes(h.brick_level, h.depth);
    let table_end = u64::from(h.brick_table) + u64::from(h.bricks) * entry as u64;
    let band_end = band_end(h, levels);
    let r = usize::from(h.brick_level);
    let mb = u64::from(h.mask_bytes());
    let entry_at = |read: &mut _, b: u32| -> Result<BrickEntry, TgError> {
        let mut bytes = [0u8; 4 * (MAX_LEVELS + 2)];
        let at = u64::from(h.brick_table) + u64::from(b) * entry as u64;
        for (k, chunk) in bytes.chunks_exact_mut(4).take(entry / 4).enumerate() {
            let w = word(read, at + 4 * k as u64, 4).ok_or(TgError::TooShort(0))?;
            chunk.copy_from_slice(&(w as u32).to_le_bytes());
        }
        BrickEntry::parse(h, &bytes).ok_or(TgError::BadBrickEntry { brick: b })
    };
    let (mut cell, mut children) = (0u32, 0u32);
    let mut spans = BrickSpans::default();
    let mut e = entry_at(read, 0)?;
    for b in 0..h.bricks {
        let next = if b + 1 < h.bricks {
            Some(entry_at(read, b + 1)?)
        } else {
            None
        };
        let brick = Brick::of(h, levels, b, &e, next.as_ref(), band_end)?;
        let own = blocks_spanned(brick.start, brick.end - brick.start, h.block_log2).max(1);
        let masks = blocks_spanned(
            u64::from(levels[r].mask_off) + mb * u64::from(brick.first[r]),
            mb * u64::from(brick.count[r]),
            h.block_log2,
        );
        spans.brick = spans.brick.max(own);
        spans.checked = spans.checked.max(own.saturating_add(masks));
        if b == 0 && brick.start < table_end {
            return Err(TgError::BadBrickEntry { brick: 0 });
        }
        // The head's children of the brick-level cells before this brick.
        while cell < e.first_cell {
            let off = u64::from(levels[r].mask_off) + mb * u64::from(cell);
            let w = word(read, off, mb as usize).ok_or(TgError::TooShort(0))?;
            children = children.saturating_add(slot_bits(h, w).count_ones());
            cell += 1;
        }
        if brick.first[r + 1] != children {
            return Err(TgError::BadBrickEntry { brick: b });
        }
        if let Some(n) = next {
            e = n;
        }
    }
    Ok(spans)
}

/// Checks one brick, whose entry passed [`check_table`], as [`check_head`] checks the head, within
/// the brick: every mask has a child and no bit the format keeps clear; the brick's cells at each
/// level are the child bits of its cells at the level above (at the brick level, of the head's
/// masks of its cells); every group pointer in it (the brick level's too) is its brick's first
/// index two levels below plus the running count of the brick's masks one level below. So within a
/// brick each cell has one parent, and with the table the brick's indices are the file's.
/// `read` as for [`check_head`]: the brick's bytes and the head's masks of its cells.
///
/// # Errors
/// The first fault: [`TgError::BadMask`], [`TgError::CountMismatch`] or [`TgError::BadGroup`]
/// (global indices), or [`TgError::TooShort`] when a read fails.
pub fn check_brick(
    h: &Header,
    levels: &[LevelDir; MAX_LEVELS],
    brick: &Brick,
    read: &mut impl FnMut(u64, usize) -> Option<u128>,
) -> Result<(), TgError> {
    let r = h.brick_level;
    let mb = u64::from(h.mask_bytes());
    let short = TgError::TooShort(0);
    // The mask of cell `i` at level `l`: the head's at the brick level, the brick's below.
    let mask = |read: &mut _, l: u8, i: u32| -> Result<u128, TgError> {
        let off = if l == r {
            u64::from(levels[usize::from(r)].mask_off) + mb * u64::from(i)
        } else {
            brick.offset(h, l, Array::Mask, i).ok_or(short)?
        };
        word(read, off, mb as usize).ok_or(short)
    };
    for l in r..h.depth {
        let (first, count) = (brick.first[usize::from(l)], brick.count[usize::from(l)]);
        let mut children = 0u32;
        for i in first..first + count {
            let w = mask(read, l, i)?;
            if l > r && !mask_word_ok(h, w) {
                return Err(TgError::BadMask { level: l, index: i });
            }
            children = children.saturating_add(slot_bits(h, w).count_ones());
        }
        let found = brick.count[usize::from(l) + 1];
        if children != found {
            return Err(TgError::CountMismatch {
                level: l + 1,
                expected: children,
                found,
            });
        }
    }
    for l in r..h.depth - 1 {
        let lu = usize::from(l);
        let mut child = brick.first[lu + 1];
        let mut grandchild = brick.first[lu + 2];
        for p in brick.first[lu]..brick.first[lu] + brick.count[lu] {
            let off = brick.offset(h, l, Array::Group, p).ok_or(short)?;
            let g = word(read, off, 4).ok_or(short)?;
            if g != u128::from(grandchild) {
                return Err(TgError::BadGroup { level: l, index: p });
            }
            let n = slot_bits(h, mask(read, l, p)?).count_ones();
            for c in child..child.saturating_add(n) {
                let w = mask(read, l + 1, c)?;
                grandchild = grandchild.saturating_add(slot_bits(h, w).count_ones());
            }
            child = child.saturating_add(n);
        }
    }
    Ok(())
}

/// The `n`-byte little-endian word at `off` of a file held in `bytes` (a reader for the checks).
#[inline]
pub fn slice_word(bytes: &[u8], off: u64, n: usize) -> Option<u128> {
    let at = usize::try_from(off).ok()?;
    let src = bytes.get(at..at.checked_add(n)?)?;
    let mut w = [0u8; 16];
    w.get_mut(..n)?.copy_from_slice(src);
    Some(u128::from_le_bytes(w))
}
