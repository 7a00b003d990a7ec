//! Normal codes: the octahedron with each face split into four, `level` times.
//!
//! This is the quantizer of Botsch et al. 2002 that the tri-grid paper uses (Duguet & Drettakis §4.1,
//! §5.5): the 8 octants give 3 bits, and each quadrisection of a face 2 more, so level 5 gives
//! 8 × 4⁵ = 8192 directions in 13 bits (Table 3's level 5, "largely sufficient" for a 16-bit display).
//!
//! A code is `octant << 2·level | path`, where `path` holds 2 bits per subdivision, coarsest first.
//! Inside an octant the point is described by barycentric coordinates `(a, b, c) = |n| / ‖n‖₁` on the
//! face spanned by the three signed axes; a subdivision picks the corner triangle whose corner weight
//! is ≥ ½ (digits 0, 1, 2) or the inverted middle one (digit 3).
//!
//! Encoding runs on the desktop (bake); decoding is per-frame setup (the shading table), so both may
//! use floats. Decoding uses only IEEE-exact operations (`+ − × ÷`, `sqrt`), so it gives the same bits
//! on every target.

/// Bits of a normal code in `.tg` files.
pub const NORMAL_BITS: u32 = 13;
/// Subdivision level of the stored codes: 8 · 4⁵ = 2¹³ directions.
pub const NORMAL_LEVEL: u32 = 5;
/// Number of distinct normal codes, and so of entries per material in a shading table.
pub const NORMAL_COUNT: usize = 1 << NORMAL_BITS;

/// Number of codes at a subdivision level: 8 · 4^level.
pub const fn code_count(level: u32) -> usize {
    8 << (2 * level)
}

/// Encodes a direction at the given subdivision level. `n` need not be normalised; a zero vector
/// encodes as +X+Y+Z's centre.
pub fn encode_level(n: [f64; 3], level: u32) -> u32 {
    let octant = (n[0] < 0.0) as u32 | ((n[1] < 0.0) as u32) << 1 | ((n[2] < 0.0) as u32) << 2;
    let l1 = n[0].abs() + n[1].abs() + n[2].abs();
    let (mut a, mut b, mut c) = if l1 > 0.0 && l1.is_finite() {
        (n[0].abs() / l1, n[1].abs() / l1, n[2].abs() / l1)
    } else {
        (1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0)
    };
    let mut code = octant;
    for _ in 0..level {
        let digit = if a >= 0.5 {
            (a, b, c) = (2.0 * a - 1.0, 2.0 * b, 2.0 * c);
            0
        } else if b >= 0.5 {
            (a, b, c) = (2.0 * a, 2.0 * b - 1.0, 2.0 * c);
            1
        } else if c >= 0.5 {
            (a, b, c) = (2.0 * a, 2.0 * b, 2.0 * c - 1.0);
            2
        } else {
            (a, b, c) = (1.0 - 2.0 * a, 1.0 - 2.0 * b, 1.0 - 2.0 * c);
            3
        };
        code = code << 2 | digit;
    }
    code
}

/// Decodes a code of the given level to the unit vector through the centroid of its triangle.
/// Codes out of range decode as if masked to the level's bit width.
pub fn decode_level(code: u32, level: u32) -> [f32; 3] {
    let (mut a, mut b, mut c) = (1.0f32 / 3.0, 1.0f32 / 3.0, 1.0f32 / 3.0);
    // Undo the subdivisions from the finest up.
    for i in 0..level {
        match (code >> (2 * i)) & 3 {
            0 => (a, b, c) = ((a + 1.0) * 0.5, b * 0.5, c * 0.5),
            1 => (a, b, c) = (a * 0.5, (b + 1.0) * 0.5, c * 0.5),
            2 => (a, b, c) = (a * 0.5, b * 0.5, (c + 1.0) * 0.5),
            _ => (a, b, c) = ((1.0 - a) * 0.5, (1.0 - b) * 0.5, (1.0 - c) * 0.5),
        }
    }
    let octant = code >> (2 * level);
    let sx = if octant & 1 != 0 { -a } else { a };
    let sy = if octant & 2 != 0 { -b } else { b };
    let sz = if octant & 4 != 0 { -c } else { c };
    let len = libm::sqrtf(sx * sx + sy * sy + sz * sz);
    [sx / len, sy / len, sz / len]
}

/// Encodes a direction as a 13-bit `.tg` normal code.
pub fn encode(n: [f64; 3]) -> u16 {
    encode_level(n, NORMAL_LEVEL) as u16
}

/// Decodes a 13-bit `.tg` normal code (bits above 13 are ignored).
pub fn decode(code: u16) -> [f32; 3] {
    decode_level(u32::from(code) & (NORMAL_COUNT as u32 - 1), NORMAL_LEVEL)
}

/// Table 3 of the tri-grid paper, measured: the dot-product error `1 − n·q(n)` of `samples`
/// pseudo-random unit normals quantized at `level`, as `(mean, max)`. Deterministic (a fixed
/// xorshift sequence), so it can be quoted and tested.
pub fn quantization_error(level: u32, samples: u32) -> (f64, f64) {
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let (mut sum, mut max) = (0.0f64, 0.0f64);
    for _ in 0..samples {
        // Uniform on the sphere: z uniform in [-1, 1], azimuth uniform.
        let z = 2.0 * next() - 1.0;
        let phi = 2.0 * core::f64::consts::PI * next();
        let r = libm::sqrt(1.0 - z * z);
        let n = [r * libm::cos(phi), r * libm::sin(phi), z];
        let q = decode_level(encode_level(n, level), level);
        let err = 1.0 - (n[0] * f64::from(q[0]) + n[1] * f64::from(q[1]) + n[2] * f64::from(q[2]));
        sum += err;
        max = max.max(err);
    }
    (sum / f64::from(samples.max(1)), max)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axes_round_trip_to_themselves_closely() {
        for n in [
            [1.0, 0.0, 0.0],
            [0.0, -1.0, 0.0],
            [0.0, 0.0, 1.0],
            [-1.0, 0.0, 0.0],
        ] {
            let q = decode(encode(n));
            let d = n[0] * f64::from(q[0]) + n[1] * f64::from(q[1]) + n[2] * f64::from(q[2]);
            assert!(d > 0.999, "{n:?} -> {q:?}");
        }
    }

    #[test]
    fn every_code_decodes_to_a_unit_vector_that_encodes_back_to_itself() {
        for code in 0..NORMAL_COUNT as u16 {
            let q = decode(code);
            let len = q.iter().map(|c| c * c).sum::<f32>();
            assert!((len - 1.0).abs() < 1e-5);
            assert_eq!(
                encode(q.map(f64::from)),
                code,
                "centroid of {code} must encode to {code}"
            );
        }
    }

    #[test]
    fn table_3_error_decreases_fourfold_per_level_and_meets_level_5() {
        let mut last = f64::INFINITY;
        for level in 3..=7 {
            let (mean, max) = quantization_error(level, 20_000);
            assert!(mean < last / 3.0, "level {level}: {mean} vs {last}");
            assert!(max >= mean);
            last = mean;
        }
        let (mean, max) = quantization_error(NORMAL_LEVEL, 100_000);
        assert!(mean <= 0.001, "Table 3 level 5: mean error {mean}");
        assert!(max <= 0.002, "Table 3 level 5: max error {max}");
    }

    #[test]
    fn code_counts() {
        assert_eq!(code_count(5), NORMAL_COUNT);
        assert_eq!(code_count(3), 512);
    }
}
