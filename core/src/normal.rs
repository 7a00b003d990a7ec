//! Quantized normals (placeholder).
/// Number of normal codes.
pub const NORMAL_COUNT: usize = 8192;
