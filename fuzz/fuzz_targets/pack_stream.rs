//! Scene packs streamed from a random medium: one of the two-trefoil packs (one per shadow mode)
//! with bytes changed as the input says, read through a source that fails or cuts reads by the
//! input's script, with the input's cache, I/O budget and shadows. Nothing panics, and a frame that
//! converges on a pack that opens whole is exactly the pack's resident frame.
#![no_main]

use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use pocketsplat_fuzz::{pack_base_files, pack_stream_checked};

#[derive(Debug, Arbitrary)]
struct Input {
    /// Which pack.
    base: u8,
    /// Byte edits: (offset, xor).
    edits: Vec<(u32, u8)>,
    /// What each read does (`FlakySource`).
    script: Vec<u8>,
    /// Cache, in KB.
    cache_kb: u8,
    /// Bytes read per frame, in 512-byte blocks.
    budget_blocks: u8,
    /// Shadows: 0 off, 1 one-pass, 2 two-pass.
    shadows: u8,
}

fuzz_target!(|input: Input| {
    let files = pack_base_files();
    let mut bytes = files[usize::from(input.base) % files.len()].clone();
    for &(at, xor) in input.edits.iter().take(32) {
        let at = at as usize % bytes.len();
        bytes[at] ^= xor;
    }
    let script: Vec<u8> = input.script.into_iter().take(64).collect();
    pack_stream_checked(
        &bytes,
        &script,
        input.shadows,
        48,
        512 * u32::from(input.budget_blocks.max(1)),
        1024 * usize::from(input.cache_kb),
    );
});
