//! Structured: a valid `.tg` file baked from the trefoil, its header fields overwritten and its body
//! bytes changed as the input says, CRCs recomputed (all of them, or the header's only), then opened
//! and rendered from the input's camera through a `NullSink` and the real raster, with or without
//! shadows.
#![no_main]

use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use pocketsplat_core::tg::{write::seal, DIRECTORY_ENTRY, DIRECTORY_OFFSET, MAX_LEVELS};
use pocketsplat_fuzz::{base_files, open_and_render, seal_header, Look};

#[derive(Debug, Arbitrary)]
struct Input {
    /// Which baked file.
    base: u8,
    /// Header fields to overwrite: (field, value), low bytes of the value for narrower fields.
    header: Vec<(u8, u32)>,
    /// Body bytes to change: (offset past block 0, xor).
    body: Vec<(u32, u8)>,
    /// Recompute the data CRCs too (else only the header's: `Verify::Full` then finds the damage).
    seal_all: bool,
    look: Look,
}

/// (offset, width) of every header field a reader interprets.
fn fields() -> Vec<(usize, usize)> {
    let mut f = vec![
        (6, 2),  // flags
        (8, 1),  // rho
        (9, 1),  // depth
        (11, 1), // material bits
        (32, 4), // blocks
        (36, 4), // CRC-table blocks
    ];
    f.extend((16..32).step_by(4).map(|o| (o, 4))); // root cube
    f.extend((48..72).step_by(4).map(|o| (o, 4))); // bounds
    for l in 0..MAX_LEVELS {
        let at = DIRECTORY_OFFSET + DIRECTORY_ENTRY * l;
        f.extend((0..5).map(|k| (at + 4 * k, 4))); // count and the four array offsets
    }
    f
}

fuzz_target!(|input: Input| {
    let files = base_files();
    let mut bytes = files[usize::from(input.base) % files.len()].clone();
    let fields = fields();
    for &(field, value) in input.header.iter().take(8) {
        let (at, width) = fields[usize::from(field) % fields.len()];
        bytes[at..at + width].copy_from_slice(&value.to_le_bytes()[..width]);
    }
    let bs = 1usize << pocketsplat_fuzz::BLOCK_LOG2;
    let body = bytes.len() - bs;
    for &(offset, xor) in input.body.iter().take(64) {
        bytes[bs + offset as usize % body] ^= xor;
    }
    if input.seal_all {
        seal(&mut bytes);
    } else {
        seal_header(&mut bytes);
    }
    open_and_render(&bytes, &[input.look], true);
});
