//! Scene packs two ways: the raw bytes, and a pack of two trefoil objects (one per shadow mode,
//! written in-process by `write_pack`) with bytes changed as the input says (5-byte edits: offset
//! u32 LE, xor; the first byte picks the pack), so that mutations start from a valid pack. Each is
//! opened (`Pack::open`, then every object's file with `Verify::Full` and `Structure`) and what
//! opens is rendered from its first view and its camera path, without and with shadows.
#![no_main]

use libfuzzer_sys::fuzz_target;
use pocketsplat_fuzz::{edited, pack_base_files, pack_open_and_render};

fuzz_target!(|data: &[u8]| {
    pack_open_and_render(data);
    if let Some(bytes) = edited(pack_base_files(), data) {
        pack_open_and_render(&bytes);
    }
});
