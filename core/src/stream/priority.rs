//! What a stream reads first (Streaming QSplat §4.2): the request queue's size and the priority of
//! a missing block, by the size of the splat drawn in its place and its row on screen.

/// Requests one frame may queue; further ones replace the lowest or are dropped (and counted).
pub const QUEUE_CAPACITY: usize = 256;

/// Priority of the root's own blocks: before anything else.
pub(crate) const ROOT_PRIORITY: u32 = u32::MAX;

/// Splat size class: ⌊log_√2 size⌋ of the diameter in Q8 pixels (Streaming QSplat §4.2 uses
/// k = √2: each class holds about twice the nodes of the one above).
pub fn size_class(size_q8: i32) -> u32 {
    let s = size_q8.max(1) as u32;
    let l = 31 - s.leading_zeros();
    let half = u64::from(s) * u64::from(s) >= 1u64 << (2 * l + 1);
    2 * l + u32::from(half)
}

/// Streaming QSplat's priority (§4.2), larger first: the size class, then the screen row from the
/// top, so that the model refines in top-to-bottom sweeps of decreasing splat size.
pub fn stream_priority(size_q8: i32, y_q8: i32) -> u32 {
    let row = (y_q8 >> crate::fixed::SUBPIXEL_BITS).clamp(0, 0xFFFF) as u32;
    size_class(size_q8) << 16 | (0xFFFF - row)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn size_classes_are_half_octaves() {
        assert_eq!(size_class(0), 0);
        assert_eq!(size_class(1), 0);
        assert_eq!(size_class(2), 2);
        assert_eq!(size_class(3), 3);
        assert_eq!(size_class(16), 8);
        assert_eq!(size_class(23), 9);
        assert_eq!(size_class(22), 8);
        assert_eq!(size_class(32), 10);
        assert!(size_class(i32::MAX) < 64);
    }

    #[test]
    fn larger_splats_first_then_top_rows() {
        let big_low = stream_priority(64 * 256, 300 * 256);
        let big_high = stream_priority(64 * 256, 10 * 256);
        let small_high = stream_priority(8 * 256, 0);
        assert!(big_high > big_low && big_low > small_high);
        // Off-screen rows clamp instead of wrapping.
        assert_eq!(stream_priority(16, -5000), stream_priority(16, 0));
    }
}
