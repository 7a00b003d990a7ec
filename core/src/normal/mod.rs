//! Quantized unit normals: 13-bit codes (encode and decode below) and their decoded Q14 table.
//!
//! The codes are the octahedron with each face split into four, `level` times (Botsch et al. 2002,
//! Duguet & Drettakis §4.1, §5.5): level 5 gives 8 × 4⁵ = 8192 directions.

mod code;
pub use code::*;

mod table {
    include!(concat!(env!("OUT_DIR"), "/normals_q14.rs"));
}
pub use table::NORMALS_Q14;
pub(crate) use table::NORMAL_BOXES_Q14;
