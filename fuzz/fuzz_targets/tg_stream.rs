//! The streaming traversal fed a random medium: one of the baked `.tg` files, its bytes changed as
//! the input says (CRCs recomputed or not), read through a source that fails, corrupts or cuts
//! reads by the input's script, with the input's cache size, I/O budget per frame and camera. Every
//! frame must stay within the traversal's bounds, nothing may panic, and a stream that converges on
//! a file that opens resident must end on the resident frame.
#![no_main]

use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use pocketsplat_core::tg::write::seal;
use pocketsplat_fuzz::{base_files, stream_checked, Look};

#[derive(Debug, Arbitrary)]
struct Input {
    /// Which baked file.
    base: u8,
    /// Bytes to change: (offset, xor).
    edits: Vec<(u32, u8)>,
    /// Recompute every CRC after the edits (else the stream's block checks find them).
    seal_all: bool,
    /// What each read does (see `FlakySource`).
    script: Vec<u8>,
    /// Cache, in 512-byte blocks (at least the stream's minimum).
    cache_blocks: u8,
    /// Bytes read per frame, in blocks.
    budget_blocks: u8,
    look: Look,
}

fuzz_target!(|input: Input| {
    let files = base_files();
    let mut bytes = files[usize::from(input.base) % files.len()].clone();
    for &(offset, xor) in input.edits.iter().take(16) {
        let at = offset as usize % bytes.len();
        bytes[at] ^= xor;
    }
    if input.seal_all {
        seal(&mut bytes);
    }
    let bs = 1u32 << pocketsplat_fuzz::BLOCK_LOG2;
    let script: Vec<u8> = input.script.into_iter().take(64).collect();
    stream_checked(
        &bytes,
        &script,
        &input.look,
        48,
        bs * u32::from(input.budget_blocks.max(1)),
        bs as usize * usize::from(input.cache_blocks),
    );
});
