//! Raw bytes as a command-line number (lossy UTF-8): every parser of `pocketsplat_sim::args` and
//! `--limits` answers with a value or an error, never a panic; a size that parses prints back
//! (`format_size`) to text that parses to the same size; a value a range parser accepts is in its
//! range.
#![no_main]

use libfuzzer_sys::fuzz_target;
use pocketsplat_sim::args::{
    block_size, float, format_size, int, light_az_el, light_pos, parse_float, parse_numbers,
    parse_size, size, Ends,
};
use pocketsplat_sim::limits::Limits;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let text = text.as_ref();
    if let Ok(n) = parse_size(text) {
        assert_eq!(parse_size(&format_size(n)), Ok(n), "{text:?}");
    }
    if let Ok(v) = parse_float(text) {
        assert!(v.is_finite());
    }
    let _ = parse_numbers::<2>("--light", text);
    let _ = parse_numbers::<3>("--view", text);
    if let Ok((az, el)) = light_az_el(text) {
        assert!(az.is_finite() && el.is_finite());
    }
    if let Ok(p) = light_pos(text) {
        assert!(p != [0.0; 3] && p.iter().all(|c| c.is_finite()));
    }
    if let Ok(n) = size::<usize>(4 << 10, 1 << 30)(text) {
        assert!((4 << 10..=1 << 30).contains(&n));
    }
    if let Ok(n) = size::<u32>(512, 1 << 30)(text) {
        assert!((512..=1 << 30).contains(&n));
    }
    if let Ok(n) = int::<u8>(0, 10)(text) {
        assert!(n <= 10);
    }
    if let Ok(n) = block_size(text) {
        assert!(n.is_power_of_two() && (512..=65536).contains(&n));
    }
    if let Ok(v) = float::<f64>(0.0, 180.0, Ends::Open)(text) {
        assert!(v > 0.0 && v < 180.0);
    }
    if let Ok(v) = float::<f32>(0.0, f64::from(f32::MAX), Ends::OpenLow)(text) {
        assert!(v > 0.0 && v.is_finite());
    }
    let mut limits = Limits::DEFAULT;
    let _ = limits.apply(text);
});
