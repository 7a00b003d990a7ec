//! Reading `.tg` files: a raw layer of bounds-checked little-endian reads, then [`TriGrid`], a view
//! that is validated once by [`TriGrid::open`] and whose accessors cannot panic afterwards.

use super::brick::{self, Array, Brick, BrickEntry};
pub use super::header::{
    check_counts, parse_header, Header, LevelDir, TgError, MAX_CORNER_SIDES, PRECISE_MAX,
    PRECISE_MIN_SIDE,
};
pub(crate) use super::header::{mask_word_ok, slot_bits};
use super::{CONE_SHIFT, DIRECTORY_ENTRY, DIRECTORY_OFFSET, MAX_LEVELS};
use crate::bytes::le::{u16_at, u32_at};
use crate::crc::crc32;

/// One level's arrays as byte slices, cut once so that per-node reads need no directory look-up.
/// Out-of-range reads return 0 (they cannot happen in a validated file).
#[derive(Clone, Copy, Debug, Default)]
pub struct LevelArrays<'a> {
    /// Attributes, `u16` each.
    pub attrs: &'a [u8],
    /// Child masks (`mask_bytes` each), empty at the leaf level.
    pub masks: &'a [u8],
    /// Group pointers, `u32` each, empty at the two finest levels.
    pub groups: &'a [u8],
}

impl LevelArrays<'_> {
    /// Attribute of sample `i`.
    #[inline(always)]
    pub fn attr(&self, i: u32) -> u16 {
        let i = 2 * i as usize;
        match self.attrs.get(i..i + 2) {
            Some(b) => u16::from_le_bytes([b[0], b[1]]),
            None => 0,
        }
    }
    /// 32-bit child mask of cell `i` (ρ = 3).
    #[inline(always)]
    pub fn mask_u32(&self, i: u32) -> u32 {
        let i = 4 * i as usize;
        match self.masks.get(i..i + 4) {
            Some(b) => u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
            None => 0,
        }
    }
    /// 8-bit child mask of cell `i` (ρ = 2).
    #[inline(always)]
    pub fn mask_u8(&self, i: u32) -> u32 {
        self.masks.get(i as usize).map_or(0, |&b| u32::from(b))
    }
    /// Group pointer of cell `i`.
    #[inline(always)]
    pub fn group(&self, i: u32) -> u32 {
        let i = 4 * i as usize;
        match self.groups.get(i..i + 4) {
            Some(b) => u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
            None => 0,
        }
    }
}

/// How much of the file [`TriGrid::open`] checks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verify {
    /// Every block's CRC, then the structure (files from SD cards, networks, anything untrusted).
    Full,
    /// The header's CRC and the structure, not the data CRCs (a model already checked into flash).
    Structure,
}

/// A validated, memory-resident `.tg` file (a flash slice, or a file read into RAM).
#[derive(Clone, Copy, Debug)]
pub struct TriGrid<'a> {
    bytes: &'a [u8],
    header: Header,
    levels: [LevelDir; MAX_LEVELS],
}

/// Checks the structure that one block of a file holds by itself, as a streaming reader receives it
/// (its CRC already checked): every child mask in `bytes` (block `block` of the file) has at least
/// one child and no bit the format keeps clear (as [`TriGrid::open`]); every group entry in it lies
/// inside the level two below, the first one of a level is 0, and each is above its predecessor by
/// between 1 and ρ⁶ (a cell's children have at least one and at most ρ³·ρ³ children in all), and the
/// last one leaves 1 to ρ⁶ grandchildren for its cell. What needs other blocks (that each entry is
/// exactly the running count of the masks it stands for) is checked when the walk uses it
/// (`crate::stream`).
///
/// `levels` must have passed [`parse_header`] (arrays inside the file).
///
/// # Errors
/// [`TgError::BadMask`] or [`TgError::BadGroup`] for the first offending cell.
pub fn check_block(
    h: &Header,
    levels: &[LevelDir; MAX_LEVELS],
    block: u32,
    bytes: &[u8],
) -> Result<(), TgError> {
    let start = u64::from(block) << h.block_log2;
    let end = start + bytes.len() as u64;
    let mb = u64::from(h.mask_bytes());
    let cells = u64::from(u32::from(h.rho).pow(3));
    // The indices of an array of `count` elements of `size` bytes at `off` that lie in this block
    // (arrays are 16-byte aligned and blocks a multiple of 16 bytes: no element straddles two).
    let span = |off: u32, count: u32, size: u64| -> (u32, u32) {
        let off = u64::from(off);
        let stop = off + u64::from(count) * size;
        if off == 0 || stop <= start || off >= end {
            return (0, 0);
        }
        let first = start.saturating_sub(off) / size;
        let last = (end.min(stop) - off) / size;
        (first as u32, last as u32)
    };
    let at = |off: u32, i: u32, size: u64| (u64::from(off) + u64::from(i) * size - start) as usize;
    for l in 0..h.depth {
        let dir = levels[usize::from(l)];
        let (first, last) = span(dir.mask_off, dir.count, mb);
        for i in first..last {
            let k = at(dir.mask_off, i, mb);
            let mut word = [0u8; 16];
            let src = bytes
                .get(k..k + mb as usize)
                .ok_or(TgError::BadMask { level: l, index: i })?;
            word[..mb as usize].copy_from_slice(src);
            let word = u128::from_le_bytes(word);
            if !mask_word_ok(h, word) {
                return Err(TgError::BadMask { level: l, index: i });
            }
            // The root is level 0's one cell: its children are the whole of level 1 (the one
            // popcount a block alone can check; the resident reader checks them all).
            if l == 0 && slot_bits(h, word).count_ones() != levels[1].count {
                return Err(TgError::BadMask { level: 0, index: 0 });
            }
        }
    }
    let per_cell = cells * cells;
    for l in 0..h.depth.saturating_sub(1) {
        let dir = levels[usize::from(l)];
        let below = u64::from(levels[usize::from(l) + 2].count);
        let (first, last) = span(dir.group_off, dir.count, 4);
        let mut prev: Option<u64> = None;
        for i in first..last {
            let bad = TgError::BadGroup { level: l, index: i };
            let g = u64::from(u32_at(bytes, at(dir.group_off, i, 4)).ok_or(bad)?);
            let after_prev = prev.is_none_or(|p| g > p && g - p <= per_cell);
            let is_last = i + 1 == dir.count;
            let room = below.saturating_sub(g);
            if (i == 0 && g != 0)
                || g < u64::from(i)
                || g > u64::from(i) * per_cell
                || g >= below
                || !after_prev
                || (is_last && room > per_cell)
            {
                return Err(bad);
            }
            prev = Some(g);
        }
    }
    Ok(())
}

impl<'a> TriGrid<'a> {
    /// Opens a memory-resident `.tg` file, checking it once as [`Verify`] says.
    ///
    /// # Errors
    /// The first problem found, as a [`TgError`] carrying the offending value.
    pub fn open(bytes: &'a [u8], verify: Verify) -> Result<Self, TgError> {
        let (header, levels) = parse_header(bytes)?;
        let expected = u64::from(header.blocks) << header.block_log2;
        if expected != bytes.len() as u64 {
            return Err(TgError::LengthMismatch {
                expected,
                found: bytes.len() as u64,
            });
        }
        let grid = TriGrid {
            bytes,
            header,
            levels,
        };
        if verify == Verify::Full {
            grid.check_blocks()?;
        }
        grid.check_structure()?;
        Ok(grid)
    }

    /// Checks the CRC table against the header and every data block against the table.
    fn check_blocks(&self) -> Result<(), TgError> {
        let h = &self.header;
        let bs = h.block_size();
        let list_at = DIRECTORY_OFFSET + DIRECTORY_ENTRY * h.levels();
        for t in 1..=h.crc_table_blocks {
            let want = u32_at(self.bytes, list_at + 4 * (t as usize - 1))
                .ok_or(TgError::BadCrcTable(t))?;
            if self.block(t).map(crc32) != Some(want) {
                return Err(TgError::BlockCrc(t));
            }
        }
        for b in h.crc_table_blocks + 1..h.blocks {
            let want = u32_at(self.bytes, bs + 4 * b as usize)
                .ok_or(TgError::BadCrcTable(h.crc_table_blocks))?;
            if self.block(b).map(crc32) != Some(want) {
                return Err(TgError::BlockCrc(b));
            }
        }
        Ok(())
    }

    fn block(&self, b: u32) -> Option<&'a [u8]> {
        let bs = self.header.block_size();
        self.bytes.get(b as usize * bs..(b as usize + 1) * bs)
    }

    /// Recomputes every count and group pointer from the masks (FORMAT.md "Validation"): the head,
    /// then, in a bricked file, the brick table and every brick.
    fn check_structure(&self) -> Result<(), TgError> {
        let (h, levels) = (&self.header, &self.levels);
        let mut read = |off: u64, n: usize| brick::slice_word(self.bytes, off, n);
        brick::check_head(h, levels, &mut read)?;
        if h.bricked() {
            brick::check_table(h, levels, &mut read)?;
            for b in 0..h.bricks {
                let brick = self.brick(b).ok_or(TgError::BadBrickEntry { brick: b })?;
                brick::check_brick(h, levels, &brick, &mut read)?;
            }
        }
        Ok(())
    }

    /// The brick table's bytes (empty without bricks).
    pub fn brick_table(&self) -> &'a [u8] {
        let h = &self.header;
        let at = h.brick_table as usize;
        let len = brick::entry_bytes(h.brick_level, h.depth) * h.bricks as usize;
        self.bytes.get(at..at + len).unwrap_or(&[])
    }

    /// Entry `b` of the brick table (FORMAT.md "Bricks"), when the file has it.
    pub fn brick_entry(&self, b: u32) -> Option<BrickEntry> {
        let h = &self.header;
        if b >= h.bricks {
            return None;
        }
        let size = brick::entry_bytes(h.brick_level, h.depth);
        let at = h.brick_table as usize + size * b as usize;
        BrickEntry::parse(h, self.bytes.get(at..at + size)?)
    }

    /// Brick `b`: its cells per level and where its arrays lie.
    pub fn brick(&self, b: u32) -> Option<Brick> {
        let e = self.brick_entry(b)?;
        let next = self.brick_entry(b + 1);
        let end = brick::band_end(&self.header, &self.levels);
        Brick::of(&self.header, &self.levels, b, &e, next.as_ref(), end).ok()
    }

    /// The brick holding cell `i` of `level` (the brick level or below, above the leaves), by a
    /// binary search of the table.
    pub fn brick_at(&self, level: u8, i: u32) -> Option<Brick> {
        let h = &self.header;
        if !h.bricked() || level < h.brick_level || level >= h.depth {
            return None;
        }
        let key = |b: u32| {
            self.brick_entry(b).map(|e| {
                if level == h.brick_level {
                    e.first_cell
                } else {
                    e.first[usize::from(level)]
                }
            })
        };
        let (mut lo, mut hi) = (0u32, h.bricks);
        while hi - lo > 1 {
            let mid = lo + (hi - lo) / 2;
            if key(mid)? <= i {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        self.brick(lo)
    }

    /// Byte offset of element `i` of `array` at `level`: in the level directory, or in its brick
    /// (`None` when the file has no such element).
    pub fn element_offset(&self, level: u8, array: Array, i: u32) -> Option<usize> {
        let h = &self.header;
        let dir = self.level(level);
        let in_brick =
            h.in_bricks(level) || (array == Array::Group && h.bricked() && level == h.brick_level);
        let off = if in_brick {
            self.brick_at(level, i)?.offset(h, level, array, i)?
        } else {
            let (base, size) = match array {
                Array::Attr => (dir.attr_off, 2),
                Array::Color => (dir.color_off, 2),
                Array::Mask => (dir.mask_off, h.mask_bytes()),
                Array::Group => (dir.group_off, 4),
            };
            if base == 0 || i >= dir.count {
                return None;
            }
            u64::from(base) + u64::from(size) * u64::from(i)
        };
        usize::try_from(off).ok()
    }

    /// The header.
    pub fn header(&self) -> &Header {
        &self.header
    }

    /// The directory entry of a level (all zero beyond the depth).
    pub fn level(&self, level: u8) -> LevelDir {
        self.levels
            .get(usize::from(level))
            .copied()
            .unwrap_or_default()
    }

    /// The whole file.
    pub fn bytes(&self) -> &'a [u8] {
        self.bytes
    }

    /// The arrays of one level, cut from the file (empty beyond the depth).
    pub fn arrays(&self, level: u8) -> LevelArrays<'a> {
        let dir = self.level(level);
        let cut = |off: u32, size: usize| -> &'a [u8] {
            if off == 0 {
                return &[];
            }
            let start = off as usize;
            let end = start.saturating_add(size.saturating_mul(dir.count as usize));
            self.bytes.get(start..end).unwrap_or(&[])
        };
        LevelArrays {
            attrs: cut(dir.attr_off, 2),
            masks: cut(dir.mask_off, self.header.mask_bytes() as usize),
            groups: cut(dir.group_off, 4),
        }
    }

    /// Attribute (normal code and material) of sample `i` at `level`; 0 when out of range.
    #[inline]
    pub fn attr(&self, level: u8, i: u32) -> u16 {
        self.element_offset(level, Array::Attr, i)
            .and_then(|at| u16_at(self.bytes, at))
            .unwrap_or(0)
    }

    /// RGB565 colour of sample `i` at `level`, when the file has colours.
    #[inline]
    pub fn color(&self, level: u8, i: u32) -> Option<u16> {
        u16_at(self.bytes, self.element_offset(level, Array::Color, i)?)
    }

    /// Child mask of cell `i` at `level` (bit `s` = slot `s` non-empty); 0 at the leaf level.
    #[inline]
    pub fn mask(&self, level: u8, i: u32) -> u128 {
        slot_bits(&self.header, self.mask_word(level, i))
    }

    /// Normal-cone class of cell `i` at `level` (FORMAT.md; 0 when the file has no cones or at the
    /// leaf level).
    #[inline]
    pub fn cone(&self, level: u8, i: u32) -> u8 {
        if !self.header.has_cones() {
            return 0;
        }
        (self.mask_word(level, i) >> CONE_SHIFT & 7) as u8
    }

    /// The stored mask bytes of cell `i` at `level`, the child bits and what the bits above them
    /// hold.
    #[inline]
    fn mask_word(&self, level: u8, i: u32) -> u128 {
        let n = self.header.mask_bytes() as usize;
        self.element_offset(level, Array::Mask, i)
            .and_then(|at| brick::slice_word(self.bytes, at as u64, n))
            .unwrap_or(0)
    }

    /// The stored child-mask word for ρ ≤ 3, as a `u32`: the child bits and, for ρ = 3, the cone
    /// class above them.
    #[inline]
    pub fn mask32(&self, level: u8, i: u32) -> u32 {
        self.mask_word(level, i) as u32
    }

    /// Group entry of cell `i` at `level`: the index of its first grandchild at `level + 2`.
    #[inline]
    pub fn group(&self, level: u8, i: u32) -> u32 {
        self.element_offset(level, Array::Group, i)
            .and_then(|at| u32_at(self.bytes, at))
            .unwrap_or(0)
    }

    /// Total number of samples, interior and leaf.
    pub fn total_samples(&self) -> u64 {
        self.levels.iter().map(|l| u64::from(l.count)).sum()
    }

    /// Number of leaf samples (the finest level).
    pub fn leaf_samples(&self) -> u32 {
        self.level(self.header.depth).count
    }
}
