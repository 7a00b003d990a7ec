//! The streaming traversal fed a random medium: one of the baked `.tg` files (512-byte, 4 KB or
//! 64 KB blocks), changed as the input says, by raw byte edits or by structural edits aimed at what
//! the streamed structure checks guard (child masks, sibling-group pointers, level counts, header
//! fields), CRCs recomputed or not, read through a source that fails, corrupts or cuts reads by the
//! input's script, with the input's cache size, I/O budget per frame and camera. Every frame must
//! stay within one visit per sample, nothing may panic, a stream that converges on a file that opens
//! resident must end on the resident frame, and one that converges on a file damaged only in its
//! structure must end on the undamaged file's frame (issue 17: valid data or an error, never noise).
#![no_main]

use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use pocketsplat_core::tg::read::parse_header;
use pocketsplat_core::tg::write::seal;
use pocketsplat_core::tg::{DIRECTORY_ENTRY, DIRECTORY_OFFSET};
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
    let Ok((h, dirs)) = parse_header(clean) else {
        return;
    };
    let mut bytes = clean.clone();
    let levels = h.levels();
    let mb = h.mask_bytes() as usize;
    let list_at = DIRECTORY_OFFSET + DIRECTORY_ENTRY * levels;
    for e in input.edits.iter().take(16) {
        let lv = |l: u8| usize::from(l) % levels;
        match *e {
            Edit::Byte(offset, xor) => {
                let at = offset as usize % bytes.len();
                bytes[at] ^= xor;
            }
            Edit::Mask { level, .. } | Edit::MaskBit { level, .. }
                if dirs[lv(level)].mask_off == 0 || dirs[lv(level)].count == 0 => {}
            Edit::Mask { level, index, xor } => {
                let d = dirs[lv(level)];
                let at = d.mask_off as usize + mb * (index % d.count) as usize;
                for (k, x) in xor.to_le_bytes().iter().take(mb).enumerate() {
                    bytes[at + k] ^= x;
                }
            }
            Edit::MaskBit { level, index, bit } => {
                let d = dirs[lv(level)];
                let at = d.mask_off as usize + mb * (index % d.count) as usize;
                let bit = usize::from(bit) % (8 * mb);
                bytes[at + bit / 8] |= 1 << (bit % 8);
            }
            Edit::GroupAdd { level, index, delta } => {
                let d = dirs[lv(level)];
                if d.group_off != 0 && d.count > 0 {
                    let at = d.group_off as usize + 4 * (index % d.count) as usize;
                    let g = u32_at(&bytes, at).unwrap_or(0);
                    put_u32(&mut bytes, at, g.wrapping_add_signed(delta));
                }
            }
            Edit::GroupAlias { level, index, from } => {
                let d = dirs[lv(level)];
                if d.group_off != 0 && d.count > 0 {
                    let at = d.group_off as usize + 4 * (index % d.count) as usize;
                    let src = d.group_off as usize + 4 * (from % d.count) as usize;
                    let g = u32_at(&bytes, src).unwrap_or(0);
                    put_u32(&mut bytes, at, g);
                }
            }
            Edit::Count { level, delta } => {
                let at = DIRECTORY_OFFSET + DIRECTORY_ENTRY * lv(level);
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
