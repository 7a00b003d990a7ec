//! Reading `.tg` files: a raw layer of bounds-checked little-endian reads, then [`TriGrid`], a view
//! that is validated once by [`TriGrid::open`] and whose accessors cannot panic afterwards.

use super::brick::{self, Array, Brick, BrickEntry};
use super::{
    mask_bytes, ARRAY_ALIGN, BLOCK_LOG2_RANGE, BOUNDS_OFFSET, BRICKS_OFFSET, BRICK_LEVEL_OFFSET,
    CONE_SHIFT, DIRECTORY_ENTRY, DIRECTORY_OFFSET, FLAG_COLOR, FLAG_CONES, FLAG_PRECISE, MAGIC,
    MAX_CELLS_PER_AXIS, MAX_DEPTH, MAX_LEVELS, PRECISE_BYTES, VERSION, VERSION_BRICKS,
};
use crate::crc::crc32;

pub use super::error::TgError;

/// Largest `|corner coordinate| / side` of a root cube (2^32).
pub const MAX_CORNER_SIDES: f64 = 4_294_967_296.0;
/// Smallest side of the precise (`f64`) root cube: the smallest positive `f32`, the `f32` cube's
/// own floor. The renderer's set-up squares and multiplies distances in `f64`; within the `f32`
/// range they neither underflow nor overflow (a side near 1e−300 drew an empty frame).
pub const PRECISE_MIN_SIDE: f64 = 1.401_298_464_324_817e-45;
/// Largest magnitude of a number of the precise root cube or bounds: the largest `f32`.
pub const PRECISE_MAX: f64 = 3.402_823_466_385_288_6e38;

use crate::bytes::le::{f32_at, f64_at, u16_at, u32_at, u8_at};
use crate::bytes::take;

/// The fixed fields of a `.tg` header.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Header {
    /// Format version.
    pub version: u16,
    /// Flags ([`FLAG_COLOR`]).
    pub flags: u16,
    /// Cells per axis per subdivision: 2 (octree) to 5; 3 is the tri-grid.
    pub rho: u8,
    /// Number of subdivisions; levels are `0..=depth`.
    pub depth: u8,
    /// Bits of the normal code (13).
    pub normal_bits: u8,
    /// Bits of the material index (0..=3).
    pub material_bits: u8,
    /// Block size as a power of two.
    pub block_log2: u8,
    /// Minimum corner of the root cube, model units.
    pub origin: [f32; 3],
    /// Side of the root cube, model units.
    pub side: f32,
    /// Blocks in the file.
    pub blocks: u32,
    /// CRC-table blocks (1..=T).
    pub crc_table_blocks: u32,
    /// Bounding box of the mesh, model units: min, max.
    pub bounds: [[f32; 3]; 2],
    /// The root cube's minimum corner as rendering uses it: the header's `f64` extension
    /// ([`FLAG_PRECISE`]) when present, else [`Header::origin`] (exactly).
    pub origin64: [f64; 3],
    /// The root cube's side as rendering uses it ([`Header::origin64`]).
    pub side64: f64,
    /// The bounding box as views use it ([`Header::origin64`]).
    pub bounds64: [[f64; 3]; 2],
    /// The level `R` whose cells' subtrees are bricked (version 3 with bricks; 0 otherwise).
    pub brick_level: u8,
    /// Bricks in the file (version 3; 0: none, every level is one array as in version 2).
    pub bricks: u32,
    /// Byte offset of the brick table (0 without bricks).
    pub brick_table: u32,
}

impl Header {
    /// Block size in bytes.
    pub fn block_size(&self) -> usize {
        1 << self.block_log2
    }
    /// Whether samples carry an RGB565 colour.
    pub fn has_color(&self) -> bool {
        self.flags & FLAG_COLOR != 0
    }
    /// Whether child masks carry normal-cone classes.
    pub fn has_cones(&self) -> bool {
        self.flags & FLAG_CONES != 0
    }
    /// Whether the header holds the precise (`f64`) root cube and bounds.
    pub fn has_precise(&self) -> bool {
        self.flags & FLAG_PRECISE != 0
    }
    /// Number of levels (depth + 1).
    pub fn levels(&self) -> usize {
        usize::from(self.depth) + 1
    }
    /// Bytes per child mask.
    pub fn mask_bytes(&self) -> u32 {
        mask_bytes(self.rho)
    }
    /// Whether the levels below [`Header::brick_level`] are in bricks (FORMAT.md "Bricks").
    pub fn bricked(&self) -> bool {
        self.bricks > 0
    }
    /// Whether level `level`'s arrays are in bricks rather than in the level directory: the levels
    /// between the brick level and the leaves (and the brick level's groups).
    pub fn in_bricks(&self, level: u8) -> bool {
        self.bricked() && level > self.brick_level && level < self.depth
    }
    /// Whether level `level`'s group array is in the level directory: a level with grandchildren,
    /// above the brick level in a bricked file.
    pub fn group_listed(&self, level: u8) -> bool {
        level + 1 < self.depth && (!self.bricked() || level < self.brick_level)
    }
    /// The last level whose arrays are in the level directory, every one of them but, in a bricked
    /// file, the group array of that level (the head: levels `0..=head_level()`).
    pub fn head_level(&self) -> u8 {
        if self.bricked() {
            self.brick_level
        } else {
            self.depth
        }
    }
}

/// One level directory entry (see FORMAT.md). Offsets are bytes from the start of the file; 0 = absent.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LevelDir {
    /// Samples at this level.
    pub count: u32,
    /// Attribute array (u16 each).
    pub attr_off: u32,
    /// Colour array (u16 RGB565 each), or 0.
    pub color_off: u32,
    /// Child-mask array, or 0 at the leaf level.
    pub mask_off: u32,
    /// Group array (u32 each), or 0 at the two finest levels.
    pub group_off: u32,
}

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

/// Parses and checks the header block: everything but the data. Shared by the resident reader and
/// (later) the streaming one, which has only block 0 at hand.
pub fn parse_header(block0: &[u8]) -> Result<(Header, [LevelDir; MAX_LEVELS]), TgError> {
    let short = TgError::TooShort(block0.len());
    let magic: [u8; 4] = take(block0, 0).ok_or(short)?;
    if magic != MAGIC {
        return Err(TgError::BadMagic(magic));
    }
    let version = u16_at(block0, 4).ok_or(short)?;
    if !(1..=VERSION).contains(&version) {
        return Err(TgError::UnsupportedVersion(version));
    }
    let block_log2 = u8_at(block0, 12).ok_or(short)?;
    if !BLOCK_LOG2_RANGE.contains(&block_log2) {
        return Err(TgError::UnsupportedBlockSize(block_log2));
    }
    let block_size = 1usize << block_log2;
    let block = block0.get(..block_size).ok_or(short)?;
    let stored_crc = u32_at(block, block_size - 4).ok_or(short)?;
    if crc32(&block[..block_size - 4]) != stored_crc {
        return Err(TgError::BlockCrc(0));
    }
    let flags = u16_at(block, 6).ok_or(short)?;
    let known = if version >= 2 {
        FLAG_COLOR | FLAG_CONES | FLAG_PRECISE
    } else {
        FLAG_COLOR
    };
    if flags & !known != 0 {
        return Err(TgError::UnsupportedFlags(flags));
    }
    let rho = u8_at(block, 8).ok_or(short)?;
    if !(2..=5).contains(&rho) {
        return Err(TgError::UnsupportedRho(rho));
    }
    if flags & FLAG_CONES != 0 && rho != 3 {
        // Only ρ = 3 masks have spare bits for the cone.
        return Err(TgError::UnsupportedFlags(flags));
    }
    let depth = u8_at(block, 9).ok_or(short)?;
    if depth > MAX_DEPTH
        || u32::from(rho)
            .checked_pow(u32::from(depth))
            .is_none_or(|c| c > MAX_CELLS_PER_AXIS)
    {
        return Err(TgError::DepthTooLarge(depth));
    }
    let normal_bits = u8_at(block, 10).ok_or(short)?;
    if normal_bits != 13 {
        return Err(TgError::UnsupportedNormalBits(normal_bits));
    }
    let material_bits = u8_at(block, 11).ok_or(short)?;
    if material_bits > 3 {
        return Err(TgError::UnsupportedMaterialBits(material_bits));
    }
    // Reserved bytes must be 0, so that a later version can give them a meaning (version 3 gave
    // bytes 13 and 40..48 one: the bricks).
    let v3 = version >= VERSION_BRICKS;
    let reserved = if v3 { 14..16 } else { 13..16 };
    for offset in reserved.chain(if v3 { 48..48 } else { 40..48 }) {
        if u8_at(block, offset).ok_or(short)? != 0 {
            return Err(TgError::ReservedNotZero {
                offset: offset as u16,
            });
        }
    }
    let mut origin = [0.0f32; 3];
    for (k, v) in origin.iter_mut().enumerate() {
        *v = f32_at(block, 16 + 4 * k).ok_or(short)?;
        if !v.is_finite() {
            return Err(TgError::BadRootCube {
                offset: (16 + 4 * k) as u8,
            });
        }
    }
    let side = f32_at(block, 28).ok_or(short)?;
    if !(side.is_finite() && side > 0.0) {
        return Err(TgError::BadRootCube { offset: 28 });
    }
    let mut bounds = [[0.0f32; 3]; 2];
    for (k, v) in bounds.iter_mut().flatten().enumerate() {
        *v = f32_at(block, BOUNDS_OFFSET + 4 * k).ok_or(short)?;
        if !v.is_finite() {
            return Err(TgError::BadRootCube {
                offset: (BOUNDS_OFFSET + 4 * k) as u8,
            });
        }
    }
    if let Some(a) = (0..3).find(|&a| bounds[0][a] > bounds[1][a]) {
        return Err(TgError::BadRootCube {
            offset: (BOUNDS_OFFSET + 4 * a) as u8,
        });
    }
    // The corner must be precise to well within the side: per-frame setup works with differences of
    // corner coordinates (a cube lost in its corner's rounding would have no extent). Bakes stay
    // below 2^25, as f32 rounding of the corner sets the side's floor.
    let side_f64 = f64::from(side);
    if let Some(a) = (0..3).find(|&a| f64::from(origin[a]).abs() > MAX_CORNER_SIDES * side_f64) {
        return Err(TgError::BadRootCube {
            offset: (16 + 4 * a) as u8,
        });
    }
    // The bounding box lies in the root cube, as the writer makes it.
    for a in 0..3 {
        let (lo, hi) = (f64::from(origin[a]), f64::from(origin[a]) + side_f64);
        for (k, v) in [(0, bounds[0][a]), (1, bounds[1][a])] {
            if !(lo..=hi).contains(&f64::from(v)) {
                return Err(TgError::BadRootCube {
                    offset: (BOUNDS_OFFSET + 12 * k + 4 * a) as u8,
                });
            }
        }
    }
    let blocks = u32_at(block, 32).ok_or(short)?;
    let crc_table_blocks = u32_at(block, 36).ok_or(short)?;
    let (brick_level, bricks, brick_table) = if v3 {
        (
            u8_at(block, BRICK_LEVEL_OFFSET).ok_or(short)?,
            u32_at(block, BRICKS_OFFSET).ok_or(short)?,
            u32_at(block, BRICKS_OFFSET + 4).ok_or(short)?,
        )
    } else {
        (0, 0, 0)
    };
    let mut header = Header {
        version,
        flags,
        rho,
        depth,
        normal_bits,
        material_bits,
        block_log2,
        origin,
        side,
        blocks,
        crc_table_blocks,
        bounds,
        origin64: origin.map(f64::from),
        side64: side_f64,
        bounds64: bounds.map(|c| c.map(f64::from)),
        brick_level,
        bricks,
        brick_table,
    };
    // The table-block CRC list must fit in block 0, and the table must cover every block.
    let list_at = DIRECTORY_OFFSET + DIRECTORY_ENTRY * header.levels();
    let list_end = (crc_table_blocks as usize)
        .checked_mul(4)
        .and_then(|n| n.checked_add(list_at));
    let covered = u64::from(crc_table_blocks) << (block_log2 - 2);
    if list_end.is_none_or(|e| e > block_size - 4)
        || covered < u64::from(blocks)
        || u64::from(crc_table_blocks) >= u64::from(blocks)
    {
        return Err(TgError::BadCrcTable(crc_table_blocks));
    }
    if header.has_precise() {
        let at = list_end.unwrap_or(usize::MAX);
        read_precise(block, at, &mut header)?;
    }
    let mut levels = [LevelDir::default(); MAX_LEVELS];
    for (l, dir) in levels.iter_mut().enumerate().take(header.levels()) {
        let at = DIRECTORY_OFFSET + DIRECTORY_ENTRY * l;
        *dir = LevelDir {
            count: u32_at(block, at).ok_or(short)?,
            attr_off: u32_at(block, at + 4).ok_or(short)?,
            color_off: u32_at(block, at + 8).ok_or(short)?,
            mask_off: u32_at(block, at + 12).ok_or(short)?,
            group_off: u32_at(block, at + 16).ok_or(short)?,
        };
        if u32_at(block, at + 20).ok_or(short)? != 0 {
            let first = (at + 20..at + 24)
                .find(|&o| u8_at(block, o) != Some(0))
                .unwrap_or(at + 20);
            return Err(TgError::ReservedNotZero {
                offset: first as u16,
            });
        }
    }
    check_directory(&header, &levels)?;
    Ok((header, levels))
}

/// The precise root cube and bounds (FORMAT.md, flag bit 2): ten `f64` at `at`, right after the CRC
/// list, checked as the `f32` ones are, into `header`'s `origin64`, `side64` and `bounds64`.
fn read_precise(block: &[u8], at: usize, header: &mut Header) -> Result<(), TgError> {
    let bad = |k: usize| TgError::BadPrecise {
        offset: at.saturating_add(8 * k).min(usize::from(u16::MAX)) as u16,
    };
    if at
        .checked_add(PRECISE_BYTES)
        .is_none_or(|e| e > block.len() - 4)
    {
        return Err(bad(0));
    }
    let mut v = [0.0f64; 10];
    for (k, x) in v.iter_mut().enumerate() {
        *x = f64_at(block, at + 8 * k).ok_or(bad(k))?;
        if !x.is_finite() {
            return Err(bad(k));
        }
    }
    let origin = [v[0], v[1], v[2]];
    let side = v[3];
    if side <= 0.0 {
        return Err(bad(3));
    }
    // What rendering draws: the magnitudes of the f32 cube (issue 33).
    let out = |k: usize| TgError::PreciseOutOfRange {
        offset: at.saturating_add(8 * k).min(usize::from(u16::MAX)) as u16,
    };
    if side < PRECISE_MIN_SIDE {
        return Err(out(3));
    }
    if let Some(k) = (0..10).find(|&k| libm::fabs(v[k]) > PRECISE_MAX) {
        return Err(out(k));
    }
    if let Some(a) = (0..3).find(|&a| libm::fabs(origin[a]) > MAX_CORNER_SIDES * side) {
        return Err(bad(a));
    }
    let bounds = [[v[4], v[5], v[6]], [v[7], v[8], v[9]]];
    for a in 0..3 {
        let (lo, hi) = (origin[a], origin[a] + side);
        if bounds[0][a] > bounds[1][a] {
            return Err(bad(4 + a));
        }
        for (k, b) in bounds.iter().enumerate() {
            if !(lo..=hi).contains(&b[a]) {
                return Err(bad(4 + 3 * k + a));
            }
        }
    }
    header.origin64 = origin;
    header.side64 = side;
    header.bounds64 = bounds;
    Ok(())
}

/// Every array of every level must be present exactly when the format says, aligned, after the CRC
/// table and inside the file; in a bricked file (version 3), the brick level and count in range and
/// the brick table inside the data blocks.
fn check_directory(h: &Header, levels: &[LevelDir; MAX_LEVELS]) -> Result<(), TgError> {
    let data_start = (u64::from(h.crc_table_blocks) + 1) << h.block_log2;
    let file_end = u64::from(h.blocks) << h.block_log2;
    if h.bricked() {
        // At least one level between the brick level and the leaves; at most one brick per block.
        let table_end = u64::from(h.brick_table)
            + u64::from(h.bricks) * brick::entry_bytes(h.brick_level, h.depth) as u64;
        if u16::from(h.brick_level) + 2 > u16::from(h.depth)
            || h.bricks >= h.blocks
            || !h.brick_table.is_multiple_of(ARRAY_ALIGN)
            || u64::from(h.brick_table) < data_start
            || table_end > file_end
        {
            return Err(TgError::BadBricks {
                level: h.brick_level,
                bricks: h.bricks,
            });
        }
    } else if h.brick_level != 0 || h.brick_table != 0 {
        return Err(TgError::BadBricks {
            level: h.brick_level,
            bricks: h.bricks,
        });
    }
    let head = h.head_level();
    for (l, dir) in levels.iter().enumerate().take(h.levels()) {
        let level = l as u8;
        // Version 3 keeps the arrays of the levels between the brick level and the leaves, and the
        // brick level's groups, in the bricks.
        let listed = level <= head || level == h.depth;
        let arrays = [
            (dir.attr_off, 2, listed),
            (dir.color_off, 2, listed && h.has_color()),
            (dir.mask_off, h.mask_bytes(), listed && level < h.depth),
            (dir.group_off, 4, listed && h.group_listed(level)),
        ];
        for (offset, size, present) in arrays {
            let bad = TgError::BadArray { level, offset };
            if !present {
                if offset != 0 {
                    return Err(bad);
                }
                continue;
            }
            let end = u64::from(offset) + u64::from(dir.count) * u64::from(size);
            if offset % ARRAY_ALIGN != 0 || u64::from(offset) < data_start || end > file_end {
                return Err(bad);
            }
        }
    }
    if levels[0].count != 1 {
        return Err(TgError::CountMismatch {
            level: 0,
            expected: 1,
            found: levels[0].count,
        });
    }
    Ok(())
}

// ---- structure rules shared by the resident and the streaming reader ------------------------------

/// The lowest mask-word bit that must be clear: ρ³, or above the cone class (bits 27..30) in a file
/// with cones (FORMAT.md "Child mask", "Normal cone").
fn spare_free(h: &Header) -> u32 {
    if h.has_cones() {
        CONE_SHIFT + 3
    } else {
        u32::from(h.rho).pow(3)
    }
}

/// Whether a stored mask word is one the format allows at a level below the depth: at least one
/// child, no bit at or above [`spare_free`].
/// The child-slot bits of a mask word (the ρ³ low bits; cone classes above them are not children).
pub(crate) fn slot_bits(h: &Header, word: u128) -> u128 {
    let cells = u32::from(h.rho).pow(3);
    if cells < 128 {
        word & ((1u128 << cells) - 1)
    } else {
        word
    }
}

pub(crate) fn mask_word_ok(h: &Header, word: u128) -> bool {
    let free = spare_free(h);
    slot_bits(h, word) != 0 && (free >= 128 || word >> free == 0)
}

/// Checks the level counts of a header against each other, before anything is sized by them: every
/// cell below the depth has between 1 and ρ³ children, so `count[L] ≤ count[L+1] ≤ ρ³·count[L]`.
/// (The resident reader finds the same faults later, as exact popcount mismatches; a streaming
/// reader, which never holds every mask at once, checks these bounds when it opens.)
///
/// # Errors
/// [`TgError::CountMismatch`] naming the first level out of bounds and the bound it breaks.
pub fn check_counts(h: &Header, levels: &[LevelDir; MAX_LEVELS]) -> Result<(), TgError> {
    let cells = u64::from(u32::from(h.rho).pow(3));
    for l in 0..usize::from(h.depth) {
        let (up, found) = (u64::from(levels[l].count), levels[l + 1].count);
        let expected = if u64::from(found) < up {
            up
        } else if u64::from(found) > up * cells {
            up * cells
        } else {
            continue;
        };
        return Err(TgError::CountMismatch {
            level: l as u8 + 1,
            expected: expected.min(u64::from(u32::MAX)) as u32,
            found,
        });
    }
    Ok(())
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
