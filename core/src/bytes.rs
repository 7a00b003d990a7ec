//! The one raw layer under every reader: bounds-checked reads of fixed-width fields at a byte offset,
//! in either byte order. A read past the end is `None`, never a made-up 0 or NaN: each reader turns
//! it into its own error (or, after its validation proved the range, into nothing at all).
//!
//! Tri-grid and pack files are little-endian ([`le`]); QSplat 1.0 files are big-endian, or
//! little-endian where the original wrote them without swapping ([`ByteOrder`]).

/// `N` bytes at `at`, or `None` when they run past the end (or `at + N` overflows).
#[inline(always)]
pub fn take<const N: usize>(bytes: &[u8], at: usize) -> Option<[u8; N]> {
    bytes.get(at..at.checked_add(N)?)?.try_into().ok()
}

/// The byte at `at`.
#[inline(always)]
pub fn u8_at(bytes: &[u8], at: usize) -> Option<u8> {
    bytes.get(at).copied()
}

/// The byte order of a file's multi-byte fields.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ByteOrder {
    /// Most significant byte first (as QSplat 1.0 specifies and pocketsplat writes QSplat files).
    Big,
    /// Least significant byte first (tri-grid and pack files; QSplat files from non-swapping builds).
    Little,
}

impl ByteOrder {
    /// The `u16` at `at`.
    #[inline(always)]
    pub fn u16(self, bytes: &[u8], at: usize) -> Option<u16> {
        let b = take(bytes, at)?;
        Some(match self {
            ByteOrder::Big => u16::from_be_bytes(b),
            ByteOrder::Little => u16::from_le_bytes(b),
        })
    }
    /// The `u32` at `at`.
    #[inline(always)]
    pub fn u32(self, bytes: &[u8], at: usize) -> Option<u32> {
        let b = take(bytes, at)?;
        Some(match self {
            ByteOrder::Big => u32::from_be_bytes(b),
            ByteOrder::Little => u32::from_le_bytes(b),
        })
    }
    /// The `u64` at `at`.
    #[inline(always)]
    pub fn u64(self, bytes: &[u8], at: usize) -> Option<u64> {
        let b = take(bytes, at)?;
        Some(match self {
            ByteOrder::Big => u64::from_be_bytes(b),
            ByteOrder::Little => u64::from_le_bytes(b),
        })
    }
    /// The `f32` at `at` (its bits, as stored: may be NaN or infinite).
    #[inline(always)]
    pub fn f32(self, bytes: &[u8], at: usize) -> Option<f32> {
        self.u32(bytes, at).map(f32::from_bits)
    }
    /// The `f64` at `at` (its bits, as stored: may be NaN or infinite).
    #[inline(always)]
    pub fn f64(self, bytes: &[u8], at: usize) -> Option<f64> {
        self.u64(bytes, at).map(f64::from_bits)
    }
}

/// Little-endian reads by name, for the little-endian formats.
pub mod le {
    pub use super::u8_at;
    use super::ByteOrder::Little;

    /// The little-endian `u16` at `at`.
    #[inline(always)]
    pub fn u16_at(bytes: &[u8], at: usize) -> Option<u16> {
        Little.u16(bytes, at)
    }
    /// The little-endian `u32` at `at`.
    #[inline(always)]
    pub fn u32_at(bytes: &[u8], at: usize) -> Option<u32> {
        Little.u32(bytes, at)
    }
    /// The little-endian `f32` at `at`.
    #[inline(always)]
    pub fn f32_at(bytes: &[u8], at: usize) -> Option<f32> {
        Little.f32(bytes, at)
    }
    /// The little-endian `f64` at `at`.
    #[inline(always)]
    pub fn f64_at(bytes: &[u8], at: usize) -> Option<f64> {
        Little.f64(bytes, at)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_in_both_orders_and_misses_past_the_end() {
        let b = [1u8, 2, 3, 4, 5, 6, 7, 8];
        assert_eq!(ByteOrder::Big.u16(&b, 0), Some(0x0102));
        assert_eq!(ByteOrder::Little.u32(&b, 0), Some(0x0403_0201));
        assert_eq!(ByteOrder::Big.u64(&b, 0), Some(0x0102_0304_0506_0708));
        assert_eq!(le::u16_at(&b, 7), None);
        assert_eq!(le::u32_at(&b, usize::MAX), None);
        assert_eq!(u8_at(&b, 8), None);
        assert_eq!(le::f64_at(&1.5f64.to_le_bytes(), 0), Some(1.5));
    }
}
