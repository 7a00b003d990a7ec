//! Scene packs two ways: the raw bytes, and a pack of two trefoil objects (one per shadow mode,
//! written in-process by `write_pack`) with bytes changed as the input says (5-byte edits: offset
//! u32 LE, xor; the first byte picks the pack), so that mutations start from a valid pack. Each is
//! opened (`Pack::open`, then every object's file with `Verify::Full` and `Structure`) and what
//! opens is rendered from its first view and its camera path, without and with shadows.
#![no_main]

use libfuzzer_sys::fuzz_target;
use pocketsplat_fuzz::{pack_base_files, pack_open_and_render};

fuzz_target!(|data: &[u8]| {
    pack_open_and_render(data);
    let Some((&pick, edits)) = data.split_first() else {
        return;
    };
    let files = pack_base_files();
    let mut bytes = files[usize::from(pick) % files.len()].clone();
    for e in edits.chunks_exact(5).take(32) {
        let at = u32::from_le_bytes([e[0], e[1], e[2], e[3]]) as usize % bytes.len();
        bytes[at] ^= e[4];
    }
    pack_open_and_render(&bytes);
});
