//! `.qs` files two ways: the raw bytes, and a QSplat file baked from the trefoil with bytes changed
//! as the input says (5-byte edits: offset u32 LE, xor; the first byte picks the file), so that
//! mutations start from a valid tree. Each is opened with `QSplat::open` and, when it opens,
//! rendered from two views through a `NullSink` and the real raster.
#![no_main]

use libfuzzer_sys::fuzz_target;
use pocketsplat_core::camera::standard_view;
use pocketsplat_fuzz::{edited, qs_base_files, qs_open_and_render, Look};

fuzz_target!(|data: &[u8]| {
    let looks = [
        Look::new(standard_view("std").unwrap(), 1.0, 0),
        Look::new(standard_view("close").unwrap(), 0.5, 0),
    ];
    qs_open_and_render(data, &looks);
    if let Some(bytes) = edited(qs_base_files(), data) {
        qs_open_and_render(&bytes, &looks);
    }
});
