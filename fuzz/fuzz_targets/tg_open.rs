//! Raw bytes as a `.tg` file: `TriGrid::open` with `Verify::Full` and `Verify::Structure`, and a
//! traversal of two frames when it opens. Then the same bytes with every CRC recomputed
//! (`write::seal`), so that mutations reach the structure checks behind the checksums.
#![no_main]

use libfuzzer_sys::fuzz_target;
use pocketsplat_core::camera::standard_view;
use pocketsplat_core::tg::write::seal;
use pocketsplat_fuzz::{open_and_render, Look};

fuzz_target!(|data: &[u8]| {
    let looks = [
        Look::new(standard_view("std").unwrap(), 1.0, 0),
        Look::new(standard_view("close").unwrap(), 0.5, 0),
    ];
    open_and_render(data, &looks, false);
    let mut sealed = data.to_vec();
    seal(&mut sealed);
    if sealed != data {
        open_and_render(&sealed, &looks, false);
    }
});
