//! The `.tg` header: its fields ([`Header`]), the level directory ([`LevelDir`]), and the checks
//! of both that every reader makes before it sizes anything by them (FORMAT.md "Header",
//! "Validation").

use super::{
    mask_bytes, ARRAY_ALIGN, BLOCK_LOG2_RANGE, BOUNDS_OFFSET, BRICKS_OFFSET, BRICK_LEVEL_OFFSET,
    CONE_SHIFT, DIRECTORY_ENTRY, DIRECTORY_OFFSET, FLAG_COLOR, FLAG_CONES, FLAG_PRECISE, MAGIC,
    MAX_CELLS_PER_AXIS, MAX_DEPTH, MAX_LEVELS, PRECISE_BYTES, VERSION, VERSION_BRICKS,
};
use crate::bytes::le::{f32_at, f64_at, u16_at, u32_at, u8_at};
use crate::bytes::take;
use crate::crc::crc32;

pub use super::error::TgError;

/// Bytes of one brick-table entry of a grid of `depth` bricked below level `level`: the first cell
/// at `level`, the first block, and the first index at each level `level + 1..=depth`
/// (FORMAT.md "Bricks").
pub const fn entry_bytes(level: u8, depth: u8) -> usize {
    ENTRY_HEAD + 4 * depth.saturating_sub(level) as usize
}

/// Bytes of a brick-table entry before its per-level first indices: first cell, first block.
pub const ENTRY_HEAD: usize = 8;

/// Largest `|corner coordinate| / side` of a root cube (2^32).
pub const MAX_CORNER_SIDES: f64 = 4_294_967_296.0;
pub use super::{PRECISE_MAX, PRECISE_MIN_SIDE};

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
            + u64::from(h.bricks) * entry_bytes(h.brick_level, h.depth) as u64;
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
