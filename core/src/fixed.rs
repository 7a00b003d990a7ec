//! Fixed-point formats and the reciprocal look-up, written down once (`docs/ARCHITECTURE.md`,
//! convention 8).
//!
//! | quantity | format |
//! |---|---|
//! | projected homogeneous centre `(X, Y, W)` of a cell | `i32`, per-frame scale: `X/W`, `Y/W` are pixels; `\|X\|, \|Y\|, 320·\|W\|` ≤ 2³⁰ over the root cube |
//! | screen positions and splat sizes | pixels, Q8 (`i32`, 256 = 1 px) |
//! | normals | Q14 (`i16`, 16384 = 1.0) |
//! | shading weights and colour channels | Q16 |
//! | depth | `u16`, linear in `W` over the frame's depth range, 0 = nearest |
//!
//! Duguet §6.1: a division costs more than a table look-up on an FPU-less core, so the perspective
//! divide multiplies by a reciprocal from a 257-entry table, interpolated linearly.
#![deny(clippy::float_arithmetic)]

/// Fractional bits of screen positions and sizes.
pub const SUBPIXEL_BITS: u32 = 8;
/// One pixel in Q8.
pub const ONE_PX_Q8: i32 = 1 << SUBPIXEL_BITS;

/// `RECIP[i] = round(2³⁹ / (256 + i))`: 1/m for mantissas m ∈ [1, 2] in steps of 1/256.
static RECIP: [u32; 257] = {
    let mut t = [0u32; 257];
    let mut i = 0;
    while i < 257 {
        let d = 256 + i as u64;
        t[i] = (((1u64 << 39) + d / 2) / d) as u32;
        i += 1;
    }
    t
};

/// Reciprocal of `w > 0`: returns `(r, shift)` with `1/w ≈ r / 2^shift`, `r ∈ [2³⁰, 2³¹]`, relative
/// error below 2⁻¹⁷ (linear interpolation between table entries, 16 fraction bits). `w = 0` is treated as 1.
#[inline]
pub fn recip(w: u32) -> (u32, u32) {
    let w = w.max(1);
    let lz = w.leading_zeros();
    let m = w << lz; // top bit set: m ∈ [2³¹, 2³²)
    let idx = ((m >> 23) & 0xFF) as usize;
    let frac = u64::from((m >> 7) & 0xFFFF);
    let (a, b) = (RECIP[idx], RECIP[idx + 1]);
    let r = a - ((u64::from(a - b) * frac) >> 16) as u32;
    // m ≈ (256 + idx + frac/256) · 2²³, so 1/m ≈ r / 2⁶², and w = m / 2^lz.
    (r, 62 - lz)
}

/// `x / w` in Q8 via [`recip`], rounded to nearest, for `|x| < 2³¹`, `w > 0`.
#[inline]
pub fn div_q8(x: i32, w: u32) -> i32 {
    let (r, shift) = recip(w);
    let sh = shift - SUBPIXEL_BITS;
    let p = i64::from(x) * i64::from(r) + (1i64 << (sh - 1));
    (p >> sh) as i32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    #[allow(clippy::float_arithmetic)]
    fn reciprocal_is_accurate_over_the_whole_range() {
        let mut w = 1u32;
        while w < u32::MAX / 3 {
            for d in [0, 1, 7, 255] {
                let x = w + d;
                let (r, shift) = recip(x);
                let approx = f64::from(r) / 2f64.powi(shift as i32);
                let rel = (approx * f64::from(x) - 1.0).abs();
                assert!(rel < 1.0 / 131072.0, "w = {x}: relative error {rel}");
            }
            w = w * 3 / 2 + 1;
        }
    }

    #[test]
    fn division_in_q8() {
        assert_eq!(div_q8(120 * 1000, 1000), 120 * 256);
        assert_eq!(div_q8(-5 * 4096, 4096), -5 * 256);
        assert!((div_q8(1 << 30, 1 << 21) - (512 * 256)).abs() <= 1);
    }
}
