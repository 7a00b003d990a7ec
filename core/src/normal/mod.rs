//! Quantized unit normals: 13-bit codes (encode and decode below) and their decoded Q14 table.
//!
//! The codes are the octahedron with each face split into four, `level` times (Botsch et al. 2002,
//! Duguet & Drettakis §4.1, §5.5): level 5 gives 8 × 4⁵ = 8192 directions.

mod code;
pub use code::*;

// The boxes serve the tri-grid's per-frame tables only.
#[cfg_attr(not(feature = "trigrid"), allow(dead_code))]
mod table {
    include!(concat!(env!("OUT_DIR"), "/normals_q14.rs"));
}
pub use table::NORMALS_Q14;
#[cfg(feature = "trigrid")]
use table::NORMAL_BOXES_Q14;

/// `n · v` for a Q14 normal `n` and an integer vector `v` whose components are at most 2¹⁴ in
/// magnitude (so the sum fits an `i32`).
#[cfg(feature = "trigrid")]
#[inline(always)]
pub(crate) fn dot_q14(n: &[i16; 3], v: [i32; 3]) -> i32 {
    i32::from(n[0]) * v[0] + i32::from(n[1]) * v[1] + i32::from(n[2]) * v[2]
}

/// For each word of a per-code bit table (codes `32w..32w + 32`: two neighbouring triangles of the
/// octahedron's third subdivision, a small patch of the sphere), the least and greatest `n · v`
/// over the box around its 32 normals (`v` as for [`dot_q14`]): an interval that holds every one of
/// them, so that a per-frame table can decide most words without their codes.
#[cfg(feature = "trigrid")]
pub(crate) fn word_dot_ranges(v: [i32; 3]) -> impl Iterator<Item = (i32, i32)> {
    NORMAL_BOXES_Q14.iter().map(move |b| {
        let (mut lo, mut hi) = (0i32, 0i32);
        for (a, &f) in v.iter().enumerate() {
            let (p, q) = (i32::from(b[a]) * f, i32::from(b[3 + a]) * f);
            lo += p.min(q);
            hi += p.max(q);
        }
        (lo, hi)
    })
}
