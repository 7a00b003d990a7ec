//! Tri-grid (`.tg`) files: ρ-grids with a sample at every non-empty cell (Duguet & Drettakis §4).
//!
//! The byte layout is specified in `FORMAT.md` beside this file, included below; [`read`] parses it
//! (no_std, validate once, then no accessor can panic) and `write` produces it (`bake` feature).
#![doc = include_str!("FORMAT.md")]

#[doc(hidden)]
pub mod brick;
pub(crate) mod bricked;
mod error;
#[doc(hidden)]
pub mod frame;
mod header;
pub(crate) mod hooks;
mod nodes;
pub mod read;
#[doc(hidden)]
pub mod traverse;
#[cfg(feature = "bake")]
pub mod write;

pub use frame::TgFrame;
pub use read::{Header, LevelArrays, LevelDir, TgError, TriGrid, Verify};
pub use traverse::{
    render_nodes, render_tg, render_tg_with, NoShadows, NodeData, Resident, ShadowHooks, TgWalk,
};

/// File magic.
pub const MAGIC: [u8; 4] = crate::format::TG_MAGIC;
/// Current format version (3: the deep levels in bricks, FORMAT.md "Bricks"). Versions 1 (no
/// cones) and 2 (level-ordered) are read too, resident; streaming needs version 3.
pub const VERSION: u16 = 3;
/// The first version with bricks (and the brick fields of the header).
pub const VERSION_BRICKS: u16 = 3;
/// Smallest side of the precise (`f64`) root cube: the smallest positive `f32`, the `f32` cube's
/// own floor. The renderer's set-up squares and multiplies distances in `f64`; within the `f32`
/// range they neither underflow nor overflow (a side near 1e−300 drew an empty frame).
pub const PRECISE_MIN_SIDE: f64 = 1.401_298_464_324_817e-45;
/// Largest magnitude of a number of the precise root cube or bounds: the largest `f32`.
pub const PRECISE_MAX: f64 = 3.402_823_466_385_288_6e38;
/// Deepest supported grid (levels 0..=MAX_DEPTH).
pub const MAX_DEPTH: u8 = 10;
/// Number of level directory entries a reader keeps.
pub const MAX_LEVELS: usize = MAX_DEPTH as usize + 1;
/// Largest number of cells per axis (ρ^depth).
pub const MAX_CELLS_PER_AXIS: u32 = 1 << 24;
/// Smallest and largest `block_log2`.
pub const BLOCK_LOG2_RANGE: core::ops::RangeInclusive<u8> = 9..=16;
/// Header flag: an RGB565 colour array is present.
pub const FLAG_COLOR: u16 = 1;
/// Header flag (version 2, ρ = 3 only): bits 27..30 of each child mask hold the cell's normal-cone
/// class ([`frame::CONE_ANGLES_DEG`]).
pub const FLAG_CONES: u16 = 2;
/// Header flag: the precise root cube and bounding box follow the CRC list of the table blocks in
/// the header block, as ten little-endian `f64` (corner x, y, z, side, bounds min x, y, z, max x,
/// y, z; FORMAT.md). Readers render with them; the `f32` fields stay valid (a cube containing the
/// mesh) for readers that do not know the flag.
pub const FLAG_PRECISE: u16 = 4;
/// Bytes of the [`FLAG_PRECISE`] extension.
pub const PRECISE_BYTES: usize = 80;
/// First bit of the normal-cone class in a ρ = 3 child mask.
pub const CONE_SHIFT: u32 = 27;
/// Byte offset of the brick level in block 0 (version 3).
pub const BRICK_LEVEL_OFFSET: usize = 13;
/// Byte offset of the brick count and, 4 bytes further, of the brick table's byte offset (version 3).
pub const BRICKS_OFFSET: usize = 40;
/// Byte offset of the level directory in block 0.
pub const DIRECTORY_OFFSET: usize = 72;
/// Byte offset of the bounding box in block 0.
pub const BOUNDS_OFFSET: usize = 48;
/// Bytes per level directory entry.
pub const DIRECTORY_ENTRY: usize = 24;
/// Alignment of every data array.
pub const ARRAY_ALIGN: u32 = 16;

/// Bytes of one child mask for a given ρ (ρ³ bits, rounded up to 1, 4, 8 or 16 bytes).
pub const fn mask_bytes(rho: u8) -> u32 {
    match rho {
        2 => 1,
        3 => 4,
        4 => 8,
        _ => 16,
    }
}
