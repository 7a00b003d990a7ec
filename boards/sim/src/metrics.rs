//! Image error measures: PSNR against the reference renderer, coverage mismatch, and the exact
//! frame comparison golden-image tests report with.
//!
//! # Example
//!
//! ```
//! use pocketsplat_sim::metrics::{compare_frames, psnr_rgb8};
//!
//! let a = vec![[10u8, 20, 30]; 4];
//! let mut b = a.clone();
//! assert_eq!(psnr_rgb8(&a, &b), f64::INFINITY);
//! b[3] = [10, 20, 31];
//! let diff = compare_frames(&a, &b).unwrap();
//! assert_eq!((diff.x, diff.y, diff.count), (3, 0, 1));
//! ```

use std::fmt;

use pocketsplat_core::camera::WIDTH;

/// Peak signal-to-noise ratio, in dB, of two 8-bit RGB images of the same size.
///
/// The mean squared error is taken over all three channels of every pixel (`3 · len` values) and
/// compared with the 8-bit peak: `10 · log10(255² / mse)`. Identical images (including two empty
/// ones) give `f64::INFINITY`.
///
/// # Panics
/// When the images have different lengths.
pub fn psnr_rgb8(a: &[[u8; 3]], b: &[[u8; 3]]) -> f64 {
    assert_eq!(
        a.len(),
        b.len(),
        "psnr_rgb8: images of different sizes ({} and {} pixels)",
        a.len(),
        b.len()
    );
    // Exact integer sum: 3 · 255² per pixel fits u64 for any image that fits in memory.
    let sse: u64 = a
        .iter()
        .zip(b)
        .flat_map(|(p, q)| (0..3).map(move |c| (i64::from(p[c]) - i64::from(q[c])).pow(2) as u64))
        .sum();
    if sse == 0 {
        return f64::INFINITY;
    }
    let mse = sse as f64 / (3 * a.len()) as f64;
    10.0 * (255.0f64 * 255.0 / mse).log10()
}

/// The fraction (0..=1) of pixels covered in one image and not in the other. Two empty masks give 0.
///
/// # Panics
/// When the masks have different lengths.
pub fn coverage_mismatch(a: &[bool], b: &[bool]) -> f64 {
    assert_eq!(
        a.len(),
        b.len(),
        "coverage_mismatch: masks of different sizes ({} and {} pixels)",
        a.len(),
        b.len()
    );
    if a.is_empty() {
        return 0.0;
    }
    let differ = a.iter().zip(b).filter(|(p, q)| p != q).count();
    differ as f64 / a.len() as f64
}

/// The fraction (0..=1) of the pixels covered in both images whose lit/shadowed classification
/// differs: `a_shadowed[i] != b_shadowed[i]` over the `i` with `a_covered[i] && b_covered[i]`.
/// No pixel covered in both gives 0.
///
/// The classifications are "unlit" masks: [`crate::reference::RefImage::shadowed`] for the
/// reference, [`crate::render::Classified::shadowed`] for the device renderer.
///
/// # Panics
/// When the four masks do not have the same length.
pub fn shadow_disagreement(
    a_covered: &[bool],
    a_shadowed: &[bool],
    b_covered: &[bool],
    b_shadowed: &[bool],
) -> f64 {
    let n = a_covered.len();
    assert!(
        a_shadowed.len() == n && b_covered.len() == n && b_shadowed.len() == n,
        "shadow_disagreement: masks of different sizes ({n}, {}, {}, {} pixels)",
        a_shadowed.len(),
        b_covered.len(),
        b_shadowed.len()
    );
    let (mut both, mut differ) = (0usize, 0usize);
    for i in 0..n {
        if a_covered[i] && b_covered[i] {
            both += 1;
            differ += usize::from(a_shadowed[i] != b_shadowed[i]);
        }
    }
    if both == 0 {
        0.0
    } else {
        differ as f64 / both as f64
    }
}

/// Where two frames differ: the first differing pixel in row order and how many pixels differ.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameDiff<T> {
    /// Column of the first differing pixel.
    pub x: usize,
    /// Row of the first differing pixel (0 at the top).
    pub y: usize,
    /// The expected value there.
    pub expected: T,
    /// The actual value there.
    pub actual: T,
    /// Number of differing pixels in the whole frame.
    pub count: usize,
}

impl<T: fmt::Debug> fmt::Display for FrameDiff<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} pixel{} differ; first at (x {}, y {}): expected {:?}, got {:?}",
            self.count,
            if self.count == 1 { "" } else { "s" },
            self.x,
            self.y,
            self.expected,
            self.actual
        )
    }
}

/// Compares two row-major frames `WIDTH` (240) pixels wide, pixel by pixel (RGB565 `u16`,
/// 8-bit `[u8; 3]`, coverage `bool`, …). Returns `None` when they are equal, else the first
/// differing pixel and the number of differing pixels, whose `Display` is the message a
/// golden-image test fails with.
///
/// # Panics
/// When the frames have different lengths (compare their sizes first).
pub fn compare_frames<T: PartialEq + Copy>(expected: &[T], actual: &[T]) -> Option<FrameDiff<T>> {
    assert_eq!(
        expected.len(),
        actual.len(),
        "compare_frames: frames of different sizes ({} and {} pixels)",
        expected.len(),
        actual.len()
    );
    let first = expected.iter().zip(actual).position(|(e, a)| e != a)?;
    let count = 1 + expected[first + 1..]
        .iter()
        .zip(&actual[first + 1..])
        .filter(|(e, a)| e != a)
        .count();
    Some(FrameDiff {
        x: first % WIDTH,
        y: first / WIDTH,
        expected: expected[first],
        actual: actual[first],
        count,
    })
}
