//! Streaming QSplat fed a random medium: one of the trefoil `.qs` files (with and without colours
//! and pocketsplat's comment) with bytes changed as the input says, read through a source that
//! fails or cuts reads by the input's script, with the input's cache size, I/O budget and camera.
//! Frames and passes stay within one visit per 4 bytes of the file, nothing panics, and a refined
//! frame that completes on a file that opens resident is exactly the resident frame.
#![no_main]

use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use pocketsplat_fuzz::{qs_base_files, qs_stream_checked, Look};

#[derive(Debug, Arbitrary)]
struct Input {
    /// Which baked file.
    base: u8,
    /// Byte edits: (offset, xor).
    edits: Vec<(u32, u8)>,
    /// What each read does (`FlakySource`).
    script: Vec<u8>,
    /// Cache, in 512-byte blocks.
    cache_blocks: u8,
    /// Bytes read per frame, in blocks.
    budget_blocks: u8,
    look: Look,
}

fuzz_target!(|input: Input| {
    let files = qs_base_files();
    let mut bytes = files[usize::from(input.base) % files.len()].clone();
    for &(at, xor) in input.edits.iter().take(32) {
        let at = at as usize % bytes.len();
        bytes[at] ^= xor;
    }
    let script: Vec<u8> = input.script.into_iter().take(64).collect();
    qs_stream_checked(
        &bytes,
        &script,
        &input.look,
        48,
        512 * u32::from(input.budget_blocks.max(1)),
        512 * usize::from(input.cache_blocks),
    );
});
