//! The streaming traversal fed a random medium: one of the baked `.tg` files (version 3, bricked but
//! for the shallowest; 512-byte, 4 KB or 64 KB blocks), changed as the input says, by raw byte edits
//! or by structural edits aimed at what the streamed structure checks guard (child masks and
//! sibling-group pointers wherever they lie, in the head or in a brick, single or as runs shifted
//! alike; level counts; brick-table words; header fields), CRCs recomputed or not, read through a source that fails, corrupts or cuts reads by the
//! input's script, with the input's cache size, I/O budget per frame and camera. Every frame must
//! stay within one visit per sample, nothing may panic, a stream that converges on a file that opens
//! resident must end on the resident frame, and one that converges on a file damaged only in its
//! structure must end on the undamaged file's frame (issue 17: valid data or an error, never noise).
#![no_main]

use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use pocketsplat_core::tg::brick::{entry_bytes, Array};
use pocketsplat_core::tg::write::seal;
use pocketsplat_core::tg::{TriGrid, Verify, DIRECTORY_ENTRY, DIRECTORY_OFFSET};
use pocketsplat_fuzz::{base_files_at, stream_checked, Look};

/// One change to the file. Indices wrap to the level's size, so that most edits land in an array.
#[derive(Debug, Arbitrary)]
enum Edit {
    /// A raw byte: (offset, xor).
    Byte(u32, u8),
    /// XOR into the child-mask word of a cell (ρ = 2: its low byte).
    Mask { level: u8, index: u32, xor: u32 },
    /// Set one bit of a cell's mask word: bits ≥ ρ³ (and the cone class) are reached.
    MaskBit { level: u8, index: u32, bit: u8 },
    /// Add `delta` to a cell's group pointer (aliasing, backward or skewed pointers).
    GroupAdd { level: u8, index: u32, delta: i32 },
    /// Set a cell's group pointer to another cell's (a DAG).
    GroupAlias { level: u8, index: u32, from: u32 },
    /// Add `delta` to the group pointers of `len` consecutive cells from `index` (a run shifted
    /// alike: each difference stays right, only the running sums can tell).
    GroupRun {
        level: u8,
        index: u32,
        len: u16,
        delta: i8,
    },
    /// Add `delta` to word `word` of brick-table entry `brick` (first cell, block, first indices).
    TableWord { brick: u32, word: u8, delta: i32 },
    /// Add `delta` to a level's count in the directory.
    Count { level: u8, delta: i32 },
    /// A header or directory word (offset below the CRC list, word-aligned) set to `value`.
    HeaderWord { word: u16, value: u32 },
}

impl Edit {
    /// Whether the edit leaves the samples' data (and the header's geometry) as they were.
    fn structural(&self) -> bool {
        matches!(
            self,
            Edit::Mask { .. }
                | Edit::MaskBit { .. }
                | Edit::GroupAdd { .. }
                | Edit::GroupAlias { .. }
                | Edit::GroupRun { .. }
                | Edit::TableWord { .. }
                | Edit::Count { .. }
        )
    }
}

#[derive(Debug, Arbitrary)]
enum Seal {
    /// Every CRC recomputed: only the structure checks can catch the damage.
    All,
    /// The header's only: the data blocks fail their CRC where edited.
    Header,
    /// None: the CRCs catch it.
    None,
}

#[derive(Debug, Arbitrary)]
struct Input {
    /// Which baked file.
    base: u8,
    /// Block size: 512 B, 4 KB or 64 KB.
    block: u8,
    edits: Vec<Edit>,
    seal: Seal,
    /// What each read does (see `FlakySource`).
    script: Vec<u8>,
    /// Cache, in blocks (at least the stream's minimum).
    cache_blocks: u8,
    /// Bytes read per frame, in blocks.
    budget_blocks: u8,
    look: Look,
}

fn u32_at(b: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_le_bytes(b.get(at..at + 4)?.try_into().ok()?))
}

fn put_u32(b: &mut [u8], at: usize, v: u32) {
    if let Some(w) = b.get_mut(at..at + 4) {
        w.copy_from_slice(&v.to_le_bytes());
    }
}

fuzz_target!(|input: Input| {
    let log2 = [9u8, 12, 16][usize::from(input.block % 3)];
    let files = base_files_at(log2);
    let clean = &files[usize::from(input.base) % files.len()];
    let Ok(grid) = TriGrid::open(clean, Verify::Full) else {
        return;
    };
    let h = *grid.header();
    let mut bytes = clean.clone();
    let levels = h.levels();
    let mb = h.mask_bytes() as usize;
    let list_at = DIRECTORY_OFFSET + DIRECTORY_ENTRY * levels;
    // Where element `index` (wrapped to the level) of `array` at `level` lies: in the level
    // directory's array or in a brick.
    let at = |array: Array, level: u8, index: u32| -> Option<usize> {
        let level = (usize::from(level) % levels) as u8;
        let n = grid.level(level).count;
        grid.element_offset(level, array, index % n.max(1))
    };
    for e in input.edits.iter().take(16) {
        match *e {
            Edit::Byte(offset, xor) => {
                let at = offset as usize % bytes.len();
                bytes[at] ^= xor;
            }
            Edit::Mask { level, index, xor } => {
                if let Some(at) = at(Array::Mask, level, index) {
                    for (k, x) in xor.to_le_bytes().iter().take(mb).enumerate() {
                        bytes[at + k] ^= x;
                    }
                }
            }
            Edit::MaskBit { level, index, bit } => {
                if let Some(at) = at(Array::Mask, level, index) {
                    let bit = usize::from(bit) % (8 * mb);
                    bytes[at + bit / 8] |= 1 << (bit % 8);
                }
            }
            Edit::GroupAdd {
                level,
                index,
                delta,
            } => {
                if let Some(at) = at(Array::Group, level, index) {
                    let g = u32_at(&bytes, at).unwrap_or(0);
                    put_u32(&mut bytes, at, g.wrapping_add_signed(delta));
                }
            }
            Edit::GroupAlias { level, index, from } => {
                if let (Some(at), Some(src)) = (
                    at(Array::Group, level, index),
                    at(Array::Group, level, from),
                ) {
                    let g = u32_at(&bytes, src).unwrap_or(0);
                    put_u32(&mut bytes, at, g);
                }
            }
            Edit::GroupRun {
                level,
                index,
                len,
                delta,
            } => {
                let n = grid.level((usize::from(level) % levels) as u8).count;
                let first = index % n.max(1);
                for i in first..first.saturating_add(u32::from(len)).min(n) {
                    if let Some(at) = at(Array::Group, level, i) {
                        let g = u32_at(&bytes, at).unwrap_or(0);
                        put_u32(&mut bytes, at, g.wrapping_add_signed(i32::from(delta)));
                    }
                }
            }
            Edit::TableWord { brick, word, delta } => {
                if h.bricked() {
                    let entry = entry_bytes(h.brick_level, h.depth);
                    let at = h.brick_table as usize
                        + entry * (brick % h.bricks) as usize
                        + 4 * (usize::from(word) % (entry / 4));
                    let v = u32_at(&bytes, at).unwrap_or(0);
                    put_u32(&mut bytes, at, v.wrapping_add_signed(delta));
                }
            }
            Edit::Count { level, delta } => {
                let at = DIRECTORY_OFFSET + DIRECTORY_ENTRY * (usize::from(level) % levels);
                let c = u32_at(&bytes, at).unwrap_or(0);
                put_u32(&mut bytes, at, c.wrapping_add_signed(delta));
            }
            Edit::HeaderWord { word, value } => {
                let at = 4 * (usize::from(word) % (list_at / 4));
                put_u32(&mut bytes, at, value);
            }
        }
    }
    match input.seal {
        Seal::All => seal(&mut bytes),
        Seal::Header => {
            let bs = h.block_size();
            let c = pocketsplat_core::crc::crc32(&bytes[..bs - 4]);
            bytes[bs - 4..bs].copy_from_slice(&c.to_le_bytes());
        }
        Seal::None => {}
    }
    let structural = input.edits.iter().take(16).all(Edit::structural);
    let bs = 1u32 << log2;
    let script: Vec<u8> = input.script.into_iter().take(64).collect();
    stream_checked(
        &bytes,
        &script,
        &input.look,
        48,
        bs * u32::from(input.budget_blocks.max(1)),
        bs as usize * usize::from(input.cache_blocks),
        structural.then_some(clean.as_slice()),
    );
});
