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

#[cfg(no_long_multiply)]
pub use halves::{
    dot3_i16, dot3_shr16, leading_zeros, mul_shr, step_q16, wide_mul, wide_mul_i16, wide_mul_small,
    wide_mul_u, wide_mul_u64,
};
/// Wide products (exact 32 × 32 → 64-bit, and their kin) for the per-node code: [`plain`] where the
/// core has a 32 × 32 → 64 multiply (`SMULL`/`UMULL`), [`halves`] where it has none (ARMv6-M and
/// ARMv8-M Baseline: the Cortex-M0+ and M23; `build.rs` sets `no_long_multiply`), where the compiler
/// makes every `i64` product a 64 × 64 library call (`__aeabi_lmul`, 38 % of an M0+ frame). The
/// same bits either way.
#[cfg(not(no_long_multiply))]
pub use plain::{
    dot3_i16, dot3_shr16, leading_zeros, mul_shr, step_q16, wide_mul, wide_mul_i16, wide_mul_small,
    wide_mul_u, wide_mul_u64,
};

/// The wide products as the language writes them.
pub mod plain {
    /// `a · b`, exact.
    #[inline(always)]
    pub fn wide_mul(a: i32, b: i32) -> i64 {
        i64::from(a) * i64::from(b)
    }

    /// `a · b`, exact.
    #[inline(always)]
    pub fn wide_mul_u(a: u32, b: u32) -> u64 {
        u64::from(a) * u64::from(b)
    }

    /// `a · b` for a 16-bit `a` (a Q14 normal's component), exact.
    #[inline(always)]
    pub fn wide_mul_i16(a: i16, b: i32) -> i64 {
        i64::from(a) * i64::from(b)
    }

    /// `a · b` for an `a` within `i16`'s range, exact.
    #[inline(always)]
    pub fn wide_mul_small(a: i32, b: i32) -> i64 {
        wide_mul(a, b)
    }

    /// `a · b` for a 64-bit `b` (a depth scale), where it fits 64 bits.
    #[inline(always)]
    pub fn wide_mul_u64(a: u32, b: u64) -> u64 {
        u64::from(a) * b
    }

    /// `a · b / 2^K` rounded down, modulo 2³² (exact where it fits an `i32`), `16 ≤ K ≤ 32`.
    #[inline(always)]
    pub fn mul_shr<const K: u32>(a: i32, b: i32) -> i32 {
        ((i64::from(a) * i64::from(b)) >> K) as i32
    }

    /// Leading zero bits of `x` (32 for 0).
    #[inline(always)]
    pub fn leading_zeros(x: u32) -> u32 {
        x.leading_zeros()
    }

    /// `d · f / 2¹⁶` rounded down, for `d < 2²⁴` and `f < 2¹⁶` (an interpolation step).
    #[inline(always)]
    pub fn step_q16(d: u32, f: u32) -> u32 {
        (wide_mul_u(d, f) >> 16) as u32
    }

    /// `n · v` for a Q14 unit normal `n` (`|n₀| + |n₁| + |n₂| < 2¹⁵`), exact.
    #[inline(always)]
    pub fn dot3_i16(n: [i16; 3], v: [i32; 3]) -> i64 {
        wide_mul_i16(n[0], v[0]) + wide_mul_i16(n[1], v[1]) + wide_mul_i16(n[2], v[2])
    }

    /// `m · c / 2¹⁶` rounded down, modulo 2³² (exact where it fits an `i32`).
    #[inline(always)]
    pub fn dot3_shr16(m: [i32; 3], c: [i32; 3]) -> i32 {
        ((wide_mul(m[0], c[0]) + wide_mul(m[1], c[1]) + wide_mul(m[2], c[2])) >> 16) as i32
    }
}

/// The wide products from 16-bit halves, `a = aₕ·2¹⁶ + aₗ`: every partial product is a 32-bit
/// multiply (`MULS`) and the 64-bit sums are add-with-carry pairs.
pub mod halves {
    /// `a · b`, exact: `aₕ` signed and `aₗ` unsigned, so that `|aₕ·bₗ| < 2³¹`.
    #[inline(always)]
    pub fn wide_mul(a: i32, b: i32) -> i64 {
        let (ah, al) = (a >> 16, a & 0xFFFF);
        let (bh, bl) = (b >> 16, b & 0xFFFF);
        let ll = (al as u32).wrapping_mul(bl as u32);
        let mid = i64::from(ah * bl) + i64::from(al * bh);
        (i64::from(ah * bh) << 32) + (mid << 16) + i64::from(ll)
    }

    /// `a · b`, exact.
    #[inline(always)]
    pub fn wide_mul_u(a: u32, b: u32) -> u64 {
        let (ah, al) = (a >> 16, a & 0xFFFF);
        let (bh, bl) = (b >> 16, b & 0xFFFF);
        let mid = u64::from(ah * bl) + u64::from(al * bh);
        (u64::from(ah * bh) << 32) + (mid << 16) + u64::from(al * bl)
    }

    /// `a · b` for a 16-bit `a`, exact: two products, `|a·bₕ| ≤ 2³⁰`, `|a·bₗ| < 2³¹`.
    #[inline(always)]
    pub fn wide_mul_i16(a: i16, b: i32) -> i64 {
        wide_mul_small(i32::from(a), b)
    }

    /// `a · b` for an `a` within `i16`'s range, exact, as [`wide_mul_i16`].
    #[inline(always)]
    pub fn wide_mul_small(a: i32, b: i32) -> i64 {
        debug_assert!(i16::try_from(a).is_ok());
        (i64::from(a * (b >> 16)) << 16) + i64::from(a * (b & 0xFFFF))
    }

    /// `a · b` for a 64-bit `b`, modulo 2⁶⁴ (exact where it fits): `b`'s low half widened, its
    /// high half's product shifted up.
    #[inline(always)]
    pub fn wide_mul_u64(a: u32, b: u64) -> u64 {
        wide_mul_u(a, b as u32).wrapping_add(u64::from(a.wrapping_mul((b >> 32) as u32)) << 32)
    }

    /// `a · b / 2^K` rounded down, modulo 2³², `16 ≤ K ≤ 32`, in 32-bit words only: with
    /// `m₁ = aₕ·bₗ` and `m₂ = aₗ·bₕ` (each fits an `i32`), `a·b = aₕbₕ·2³² + (m₁ + m₂)·2¹⁶ + aₗbₗ`,
    /// and the part below `2^K` carries through one small sum. The M0+'s `a · b >> 32` through
    /// 64-bit additions (`adcs` pairs, and the registers they hold) costs half again as much.
    #[inline(always)]
    pub fn mul_shr<const K: u32>(a: i32, b: i32) -> i32 {
        let (ah, al) = (a >> 16, a & 0xFFFF);
        let (bh, bl) = (b >> 16, b & 0xFFFF);
        let ll = (al as u32).wrapping_mul(bl as u32);
        let (m1, m2) = (ah * bl, al * bh);
        let k = K - 16;
        let low = (1 << k) - 1;
        let carry = ((m1 & low) + (m2 & low) + (ll >> 16) as i32) >> k;
        (ah * bh)
            .wrapping_shl(32 - K)
            .wrapping_add(m1 >> k)
            .wrapping_add(m2 >> k)
            .wrapping_add(carry)
    }

    /// Leading zero bits of `x` (32 for 0): two halvings and a byte table, where the core has no
    /// `CLZ` (ARMv6-M; the library's bit-by-bit `__clzsi2` costs 33 instructions a call).
    #[inline(always)]
    pub fn leading_zeros(x: u32) -> u32 {
        let (mut x, mut n) = (x, 0);
        if x >> 16 == 0 {
            n += 16;
            x <<= 16;
        }
        if x >> 24 == 0 {
            n += 8;
            x <<= 8;
        }
        n + u32::from(CLZ8[(x >> 24) as usize])
    }

    /// `d · f / 2¹⁶` rounded down, for `d < 2²⁴` and `f < 2¹⁶`, in 32-bit words: `d`'s high
    /// byte's product and its low half's product shifted down are exact and sum to it.
    #[inline(always)]
    pub fn step_q16(d: u32, f: u32) -> u32 {
        (d >> 16) * f + (((d & 0xFFFF) * f) >> 16)
    }

    /// `n · v` for a Q14 unit normal `n`, exact: `v = h·2¹⁵ + l` with `l ∈ [0, 2¹⁵)`, and a unit
    /// normal's `|n₀| + |n₁| + |n₂| ≤ √3 · 2¹⁴ < 2¹⁵`, so both sums of three fit an `i32`
    /// (`< 2¹⁵ · 2¹⁶`) and one 64-bit shift and add joins them.
    #[inline(always)]
    pub fn dot3_i16(n: [i16; 3], v: [i32; 3]) -> i64 {
        let n = n.map(i32::from);
        debug_assert!(n[0].abs() + n[1].abs() + n[2].abs() < 1 << 15, "{n:?}");
        let (h, l) = (v.map(|v| v >> 15), v.map(|v| v & 0x7FFF));
        let hs = n[0] * h[0] + n[1] * h[1] + n[2] * h[2];
        let ls = n[0] * l[0] + n[1] * l[1] + n[2] * l[2];
        (i64::from(hs) << 15) + i64::from(ls)
    }

    /// `m · c / 2¹⁶` rounded down, modulo 2³², in 32-bit words: each product's part above 2¹⁶ as
    /// [`mul_shr`] takes it, and the parts below summed apart, whose carry is the one that
    /// crosses 2¹⁶.
    #[inline(always)]
    pub fn dot3_shr16(m: [i32; 3], c: [i32; 3]) -> i32 {
        let mut high = 0i32;
        let mut low = 0u32;
        for k in 0..3 {
            let (ah, al) = (m[k] >> 16, m[k] & 0xFFFF);
            let (bh, bl) = (c[k] >> 16, c[k] & 0xFFFF);
            let ll = (al as u32).wrapping_mul(bl as u32);
            high = high
                .wrapping_add((ah * bh).wrapping_shl(16))
                .wrapping_add(ah * bl)
                .wrapping_add(al * bh)
                .wrapping_add((ll >> 16) as i32);
            low += ll & 0xFFFF;
        }
        high.wrapping_add((low >> 16) as i32)
    }

    /// `CLZ8[b]`: leading zero bits of the byte `b` (8 for 0).
    static CLZ8: [u8; 256] = {
        let mut t = [0u8; 256];
        let mut b = 0;
        while b < 256 {
            t[b] = (b as u8).leading_zeros() as u8;
            b += 1;
        }
        t
    };
}

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
    let lz = leading_zeros(w);
    let m = w << lz; // top bit set: m ∈ [2³¹, 2³²)
    let idx = ((m >> 23) & 0xFF) as usize;
    let frac = (m >> 7) & 0xFFFF;
    let (a, b) = (RECIP[idx], RECIP[idx + 1]);
    // a − b < 2²⁴: the steepest step, 2³⁹/(256·257).
    let r = a - step_q16(a - b, frac);
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
    fn wide_products_from_halves_are_exact() {
        let edges = [
            0,
            1,
            -1,
            0xFFFF,
            0x1_0000,
            -0x1_0000,
            0x7FFF_FFFF,
            i32::MIN,
            i32::MIN + 1,
            0x1234_5678,
            -0x0765_4321,
            0x8000,
            -0x8000,
        ];
        let mut x = 0x9E37_79B9u32;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            x
        };
        let mut pairs: std::vec::Vec<(u32, u32)> = std::vec::Vec::new();
        for &a in &edges {
            for &b in &edges {
                pairs.push((a as u32, b as u32));
            }
        }
        for _ in 0..200_000 {
            pairs.push((next(), next() >> (next() % 32)));
        }
        for (a, b) in pairs {
            let (sa, sb) = (a as i32, b as i32);
            let want = plain::wide_mul(sa, sb);
            assert_eq!(halves::wide_mul(sa, sb), want, "{sa} · {sb}");
            assert_eq!(
                halves::wide_mul_u(a, b),
                plain::wide_mul_u(a, b),
                "{a} · {b}"
            );
            let a16 = a as i16;
            let want = plain::wide_mul_i16(a16, sb);
            assert_eq!(halves::wide_mul_i16(a16, sb), want, "{a16} · {sb}");
            let small = i32::from(a16 >> 1);
            let want = plain::wide_mul_small(small, sb);
            assert_eq!(halves::wide_mul_small(small, sb), want, "{small} · {sb}");
            let b64 = (u64::from(b) << 32) | u64::from(next());
            if let Some(p) = u64::from(a).checked_mul(b64) {
                assert_eq!(halves::wide_mul_u64(a, b64), p, "{a} · {b64}");
            }
            let small = b64 >> 40; // a depth scale's size: the product always fits
            assert_eq!(
                halves::wide_mul_u64(a, small),
                plain::wide_mul_u64(a, small)
            );
        }
    }

    #[test]
    fn shifted_products_and_leading_zeros_from_halves_are_exact() {
        let mut x = 0x2545_F491u32;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            x
        };
        let edges = [
            0,
            1,
            -1,
            0xFFFF,
            0x1_0000,
            -0x1_0000,
            0x7FFF,
            -0x8000,
            i32::MAX,
            i32::MIN,
        ];
        let mut pairs: std::vec::Vec<(i32, i32)> = std::vec::Vec::new();
        for &a in &edges {
            for &b in &edges {
                pairs.push((a, b));
            }
        }
        for _ in 0..200_000 {
            let a = next() as i32 >> (next() % 32);
            pairs.push((a, next() as i32 >> (next() % 32)));
        }
        for (a, b) in pairs {
            fn check<const K: u32>(a: i32, b: i32) {
                assert_eq!(
                    halves::mul_shr::<K>(a, b),
                    plain::mul_shr::<K>(a, b),
                    "{a}·{b} >> {K}"
                );
            }
            check::<32>(a, b);
            check::<24>(a, b);
            check::<20>(a, b);
            check::<16>(a, b);
            let u = a as u32 >> (b as u32 % 32);
            assert_eq!(halves::leading_zeros(u), u.leading_zeros(), "clz {u:#x}");
            let (c, d) = (next() as i32 >> (next() % 32), next() as i32);
            // A Q14 unit normal's components: |n₀| + |n₁| + |n₂| ≤ √3 · 2¹⁴.
            let n = [
                (a as i16) >> 2,
                (b as i16) >> 2,
                (c as i16).clamp(-12000, 12000),
            ];
            let v = [b, d, a ^ c];
            assert_eq!(halves::dot3_i16(n, v), plain::dot3_i16(n, v), "{n:?}·{v:?}");
            let (m, w) = ([a, b, c], [d, c, a.wrapping_add(b)]);
            assert_eq!(
                halves::dot3_shr16(m, w),
                plain::dot3_shr16(m, w),
                "{m:?}·{w:?}"
            );
        }
        assert_eq!(halves::leading_zeros(0), 32);
    }

    #[test]
    fn reciprocal_interpolates_as_the_wide_product_does() {
        let mut w = 1u32;
        while w < u32::MAX / 2 {
            for x in [w, w + 1, w + 255, w | 0x7F] {
                let lz = x.leading_zeros();
                let m = x << lz;
                let idx = ((m >> 23) & 0xFF) as usize;
                let frac = (m >> 7) & 0xFFFF;
                let (a, b) = (RECIP[idx], RECIP[idx + 1]);
                let want = a - (plain::wide_mul_u(a - b, frac) >> 16) as u32;
                assert_eq!(recip(x), (want, 62 - lz), "w = {x}");
                assert_eq!(halves::step_q16(a - b, frac), plain::step_q16(a - b, frac));
            }
            w = w + (w >> 7) + 1;
        }
    }

    #[test]
    fn division_in_q8() {
        assert_eq!(div_q8(120 * 1000, 1000), 120 * 256);
        assert_eq!(div_q8(-5 * 4096, 4096), -5 * 256);
        assert!((div_q8(1 << 30, 1 << 21) - (512 * 256)).abs() <= 1);
    }
}
