//! What is wrong with a `.tg` file ([`TgError`]), for every reader of the format.

use super::{MAX_DEPTH, VERSION, VERSION_BRICKS};

/// What is wrong with a `.tg` file. Each variant carries the offending value.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum TgError {
    /// Shorter than one block (or than the smallest block).
    TooShort(usize),
    /// The first four bytes are not `PSTG`.
    BadMagic([u8; 4]),
    /// A version this reader does not know.
    UnsupportedVersion(u16),
    /// Unknown bits in the flags.
    UnsupportedFlags(u16),
    /// ρ outside 2..=5.
    UnsupportedRho(u8),
    /// Depth above [`MAX_DEPTH`] or ρ^depth above 2²⁴.
    DepthTooLarge(u8),
    /// Normal bits other than 13.
    UnsupportedNormalBits(u8),
    /// Material bits above 3.
    UnsupportedMaterialBits(u8),
    /// `block_log2` outside 9..=16.
    UnsupportedBlockSize(u8),
    /// A root cube or bounding box number is not finite, the side is not positive, a corner
    /// coordinate is more than [`MAX_CORNER_SIDES`](super::read::MAX_CORNER_SIDES) sides from 0, a bounding box minimum exceeds its
    /// maximum, or the bounding box leaves the root cube.
    BadRootCube {
        /// Byte offset of the offending `f32` in the header (16..=28 root cube, 48..=68 bounds).
        offset: u8,
    },
    /// The precise root cube and bounds ([`FLAG_PRECISE`](super::FLAG_PRECISE)) do not fit the header block, or one of
    /// its numbers is not finite, the side is not positive, the corner is more than
    /// [`MAX_CORNER_SIDES`](super::read::MAX_CORNER_SIDES) sides from 0, the box is inverted or leaves the cube.
    BadPrecise {
        /// Byte offset of the offending `f64` (or of the extension, when it does not fit) in the
        /// header.
        offset: u16,
    },
    /// A number of the precise root cube or bounds is outside the magnitudes the renderer draws:
    /// those of the `f32` cube, [`PRECISE_MIN_SIDE`](super::PRECISE_MIN_SIDE) to
    /// [`PRECISE_MAX`](super::PRECISE_MAX) (a side near 1e−300 drew an empty frame, one near
    /// 1e300 overflowed the camera).
    PreciseOutOfRange {
        /// Byte offset of the offending `f64` in the header.
        offset: u16,
    },
    /// A reserved header byte is not 0.
    ReservedNotZero {
        /// Its byte offset in the header.
        offset: u16,
    },
    /// The file length is not the header's block count times the block size.
    LengthMismatch {
        /// Bytes the header announces.
        expected: u64,
        /// Bytes present.
        found: u64,
    },
    /// The CRC-table block count does not fit the header or the file.
    BadCrcTable(u32),
    /// A block's CRC-32 does not match (block 0: the header).
    BlockCrc(u32),
    /// A level's array offset is misaligned, overlaps the header or runs past the end, or is set for
    /// an array the level must not have.
    BadArray {
        /// The level.
        level: u8,
        /// The offending byte offset from the directory.
        offset: u32,
    },
    /// A count does not match what the level above announces (level 0 must hold 1 sample).
    CountMismatch {
        /// The level.
        level: u8,
        /// The count implied by the level above.
        expected: u32,
        /// The count in the directory.
        found: u32,
    },
    /// A child mask is empty or has bits at or above ρ³.
    BadMask {
        /// The level of the cell.
        level: u8,
        /// Its index in the level.
        index: u32,
    },
    /// A group entry (one pointer per sibling group) is not the running count it stands for.
    BadGroup {
        /// The level of the cell.
        level: u8,
        /// Its index in the level.
        index: u32,
    },
    /// The brick level or count of a version 3 header is out of range, or the brick table does not
    /// fit the data blocks (FORMAT.md "Bricks").
    BadBricks {
        /// The brick level.
        level: u8,
        /// The brick count.
        bricks: u32,
    },
    /// An entry of the brick table is out of order or out of range, its cells break the level
    /// rules (1 to ρ³ children per cell), or its brick overruns the next one (FORMAT.md "Bricks").
    BadBrickEntry {
        /// The brick.
        brick: u32,
    },
    /// A file of this version cannot be streamed: streaming reads version 3 (bricked) files, which
    /// can be checked brick by brick. Bake it again, or migrate it (`pocketsplat migrate`).
    NotStreamable {
        /// The file's version.
        version: u16,
    },
}

impl core::error::Error for TgError {}

impl core::fmt::Display for TgError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            TgError::TooShort(n) => write!(f, "file is {n} bytes, shorter than one block"),
            TgError::BadMagic(m) => write!(f, "not a .tg file (magic {m:02x?}, expected \"PSTG\")"),
            TgError::UnsupportedVersion(v) => write!(
                f,
                "unsupported .tg version {v} (this reader knows {VERSION})"
            ),
            TgError::UnsupportedFlags(x) => write!(f, "unknown header flags {x:#06x}"),
            TgError::UnsupportedRho(r) => write!(f, "unsupported rho {r} (2..=5)"),
            TgError::DepthTooLarge(d) => write!(
                f,
                "depth {d} is too large (at most {MAX_DEPTH} and rho^depth <= 2^24)"
            ),
            TgError::UnsupportedNormalBits(b) => write!(f, "unsupported normal bits {b} (13)"),
            TgError::UnsupportedMaterialBits(b) => {
                write!(f, "unsupported material bits {b} (0..=3)")
            }
            TgError::UnsupportedBlockSize(b) => {
                write!(f, "unsupported block size 2^{b} (2^9..=2^16)")
            }
            TgError::BadRootCube { offset } => write!(
                f,
                "header field at byte {offset} ({}): the root cube or bounding box is not finite, \
                 has no size, is inverted, or lies outside the cube, or the cube is lost in its \
                 corner's rounding",
                match offset {
                    16..=27 => "root cube corner",
                    28..=31 => "root cube side",
                    _ => "bounding box",
                }
            ),
            TgError::BadPrecise { offset } => write!(
                f,
                "header field at byte {offset} (precise root cube or bounds, f64): missing, not \
                 finite, no size, inverted, outside the cube or lost in its corner's rounding"
            ),
            TgError::PreciseOutOfRange { offset } => write!(
                f,
                "header field at byte {offset} (precise root cube or bounds, f64): outside what \
                 rendering draws (the f32 cube's range: a side of at least {:e}, every number at \
                 most {:e} in size)",
                super::PRECISE_MIN_SIDE,
                super::PRECISE_MAX
            ),
            TgError::ReservedNotZero { offset } => {
                write!(f, "reserved header byte {offset} is not 0")
            }
            TgError::LengthMismatch { expected, found } => {
                write!(
                    f,
                    "file is {found} bytes but the header announces {expected}"
                )
            }
            TgError::BadCrcTable(t) => write!(f, "CRC table of {t} blocks does not fit"),
            TgError::BlockCrc(0) => write!(f, "header block fails its CRC check"),
            TgError::BlockCrc(b) => write!(f, "block {b} fails its CRC check"),
            TgError::BadArray { level, offset } => write!(
                f,
                "level {level}: the array at byte {offset} is misaligned, lies outside the data \
                 blocks or should be absent"
            ),
            TgError::CountMismatch {
                level,
                expected,
                found,
            } => {
                write!(
                    f,
                    "level {level}: {found} samples, but the level above announces {expected}"
                )
            }
            TgError::BadMask { level, index } => {
                write!(f, "level {level}: cell {index} has an invalid child mask")
            }
            TgError::BadGroup { level, index } => {
                write!(
                    f,
                    "level {level}: cell {index} has a wrong sibling-group pointer"
                )
            }
            TgError::BadBricks { level, bricks } => write!(
                f,
                "{bricks} bricks below level {level}: the brick level, the count or the brick \
                 table is out of range"
            ),
            TgError::BadBrickEntry { brick } => write!(
                f,
                "brick {brick}: its entry in the brick table is out of order or out of range, or \
                 its brick overruns the next"
            ),
            TgError::NotStreamable { version } => write!(
                f,
                "a version {version} .tg file cannot be streamed (streaming reads version \
                 {VERSION_BRICKS}, whose bricks are checked one by one): bake it again, or \
                 convert it with `pocketsplat migrate IN.tg OUT.tg`"
            ),
        }
    }
}
