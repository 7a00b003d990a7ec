//! Writing `.tg` files (`bake` feature): the inverse of [`super::read`], from a [`BakedGrid`].

use std::vec;
use std::vec::Vec;

use super::{
    mask_bytes, ARRAY_ALIGN, BLOCK_LOG2_RANGE, BOUNDS_OFFSET, CONE_SHIFT, DIRECTORY_ENTRY,
    DIRECTORY_OFFSET, FLAG_COLOR, FLAG_CONES, FLAG_PRECISE, MAGIC, PRECISE_BYTES, VERSION,
};
use crate::bake::cone::cone_classes;
use crate::bake::BakedGrid;
use crate::crc::crc32;

/// Why a grid cannot be written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WriteError {
    /// `block_log2` outside 9..=16.
    BlockSize(u8),
    /// The file would need more CRC-table blocks than the header block can list (use bigger blocks).
    TooLarge {
        /// Blocks the file would have.
        blocks: u64,
    },
}

impl core::fmt::Display for WriteError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            WriteError::BlockSize(b) => write!(f, "block size 2^{b} is outside 2^9..=2^16"),
            WriteError::TooLarge { blocks } => {
                write!(
                    f,
                    "{blocks} blocks are too many for this block size; use a larger --block-size"
                )
            }
        }
    }
}

impl std::error::Error for WriteError {}

fn align(n: usize) -> usize {
    n.next_multiple_of(ARRAY_ALIGN as usize)
}

/// The group array of level `l` (FORMAT.md): for each cell, the index of its first grandchild.
pub fn group_array(grid: &BakedGrid, l: usize) -> Vec<u32> {
    let (here, next) = (&grid.levels[l].masks, &grid.levels[l + 1].masks);
    let mut out = Vec::with_capacity(here.len());
    let (mut child, mut grandchild) = (0usize, 0u32);
    for &m in here {
        out.push(grandchild);
        let n = m.count_ones() as usize;
        grandchild += next[child..child + n]
            .iter()
            .map(|c| c.count_ones())
            .sum::<u32>();
        child += n;
    }
    out
}

/// Serialises a baked grid into a `.tg` file with blocks of `2^block_log2` bytes.
///
/// # Errors
/// [`WriteError`] when the block size is out of range or the file too large for it.
pub fn write_tg(grid: &BakedGrid, block_log2: u8) -> Result<Vec<u8>, WriteError> {
    if !BLOCK_LOG2_RANGE.contains(&block_log2) {
        return Err(WriteError::BlockSize(block_log2));
    }
    let bs = 1usize << block_log2;
    let levels = grid.levels.len();
    let depth = levels - 1;
    let mb = mask_bytes(grid.rho) as usize;
    let color = grid.levels[0].colors.is_some();
    // Normal cones go in the spare bits of ρ = 3 masks.
    let cones = if grid.cones && grid.rho == 3 {
        cone_classes(grid)
    } else {
        Vec::new()
    };

    // Array sizes, level by level: attributes, colours, masks, groups.
    let mut sizes = Vec::with_capacity(levels);
    let mut data_bytes = 0usize;
    for (l, level) in grid.levels.iter().enumerate() {
        let n = level.attrs.len();
        let s = [
            2 * n,
            if color { 2 * n } else { 0 },
            if l < depth { mb * n } else { 0 },
            if l + 1 < depth { 4 * n } else { 0 },
        ];
        data_bytes += s.iter().map(|&x| align(x)).sum::<usize>();
        sizes.push(s);
    }
    // T table blocks cover 4T·bs/4 = T·bs/4 blocks; grow T until the file fits.
    let list_at = DIRECTORY_OFFSET + DIRECTORY_ENTRY * levels;
    let mut t = 1usize;
    let blocks = loop {
        let blocks = 1 + t + data_bytes.div_ceil(bs);
        if t * (bs / 4) >= blocks {
            break blocks;
        }
        t += 1;
    };
    let precise_bytes = if grid.precise.is_some() {
        PRECISE_BYTES
    } else {
        0
    };
    if list_at + 4 * t + precise_bytes > bs - 4 {
        return Err(WriteError::TooLarge {
            blocks: blocks as u64,
        });
    }

    let mut file = vec![0u8; blocks * bs];
    let data_start = (1 + t) * bs;
    let mut at = data_start;
    let mut dir = Vec::with_capacity(levels);
    for (l, level) in grid.levels.iter().enumerate() {
        let mut offs = [0u32; 4];
        let group = if l + 1 < depth {
            group_array(grid, l)
        } else {
            Vec::new()
        };
        for (k, &size) in sizes[l].iter().enumerate() {
            if size == 0 {
                continue;
            }
            offs[k] = at as u32;
            let dst = &mut file[at..at + size];
            match k {
                0 => put_u16s(dst, &level.attrs),
                1 => put_u16s(dst, level.colors.as_deref().unwrap_or(&[])),
                2 => {
                    for (i, (chunk, m)) in dst.chunks_exact_mut(mb).zip(&level.masks).enumerate() {
                        let cone = cones.get(l).map_or(0, |c| u128::from(c[i]));
                        chunk.copy_from_slice(&(m | cone << CONE_SHIFT).to_le_bytes()[..mb]);
                    }
                }
                _ => {
                    for (chunk, g) in dst.chunks_exact_mut(4).zip(&group) {
                        chunk.copy_from_slice(&g.to_le_bytes());
                    }
                }
            }
            at += align(size);
        }
        dir.push((level.attrs.len() as u32, offs));
    }

    // Header.
    let h = &mut file[..bs];
    h[0..4].copy_from_slice(&MAGIC);
    h[4..6].copy_from_slice(&VERSION.to_le_bytes());
    let precise = grid.precise.map_or(0, |_| FLAG_PRECISE);
    let flags = if color { FLAG_COLOR } else { 0 }
        | if cones.is_empty() { 0 } else { FLAG_CONES }
        | precise;
    h[6..8].copy_from_slice(&flags.to_le_bytes());
    h[8] = grid.rho;
    h[9] = depth as u8;
    h[10] = 13;
    h[11] = grid.material_bits;
    h[12] = block_log2;
    for (k, v) in grid
        .origin
        .iter()
        .chain(core::iter::once(&grid.side))
        .enumerate()
    {
        h[16 + 4 * k..20 + 4 * k].copy_from_slice(&(*v as f32).to_le_bytes());
    }
    for (k, v) in grid.bounds.iter().flatten().enumerate() {
        let at = BOUNDS_OFFSET + 4 * k;
        h[at..at + 4].copy_from_slice(&v.to_le_bytes());
    }
    h[32..36].copy_from_slice(&(blocks as u32).to_le_bytes());
    h[36..40].copy_from_slice(&(t as u32).to_le_bytes());
    for (l, (count, offs)) in dir.iter().enumerate() {
        let e = DIRECTORY_OFFSET + DIRECTORY_ENTRY * l;
        h[e..e + 4].copy_from_slice(&count.to_le_bytes());
        for (k, o) in offs.iter().enumerate() {
            h[e + 4 + 4 * k..e + 8 + 4 * k].copy_from_slice(&o.to_le_bytes());
        }
    }

    // The precise root cube and bounds, after the CRC list (FORMAT.md, flag bit 2).
    if let Some(p) = &grid.precise {
        let values = p
            .origin
            .iter()
            .chain([&p.side])
            .chain(p.bounds.iter().flatten());
        for (k, v) in values.enumerate() {
            let at = list_at + 4 * t + 8 * k;
            h[at..at + 8].copy_from_slice(&v.to_le_bytes());
        }
    }

    seal(&mut file);
    Ok(file)
}

/// Recomputes every CRC of a `.tg` file from the layout its header announces: the CRC table over the
/// data blocks, the table blocks' CRCs in the header, then the header's own CRC. Whatever does not fit
/// (a block size out of range, a table that runs past the file) is skipped, never indexed blindly, so
/// this takes any bytes.
///
/// The writer uses it last; tests and fuzzers use it to craft files whose checksums are right but
/// whose structure is not, so that the structure checks of [`super::TriGrid::open`] are what fires.
pub fn seal(file: &mut [u8]) {
    let Some(&block_log2) = file.get(12) else {
        return;
    };
    if !BLOCK_LOG2_RANGE.contains(&block_log2) {
        return;
    }
    let bs = 1usize << block_log2;
    if file.len() < bs {
        return;
    }
    let blocks = file.len() / bs;
    let levels = usize::from(file[9]) + 1;
    let t = u32::from_le_bytes([file[36], file[37], file[38], file[39]]) as usize;
    let list_at = DIRECTORY_OFFSET + DIRECTORY_ENTRY * levels;
    let table_end = t.saturating_add(1).saturating_mul(bs).min(file.len());
    for b in t.saturating_add(1)..blocks {
        let at = bs + 4 * b;
        if at + 4 > table_end {
            break;
        }
        let c = crc32(&file[b * bs..(b + 1) * bs]);
        file[at..at + 4].copy_from_slice(&c.to_le_bytes());
    }
    for k in 1..=t.min(blocks.saturating_sub(1)) {
        let e = list_at + 4 * (k - 1);
        if e + 4 > bs - 4 {
            break;
        }
        let c = crc32(&file[k * bs..(k + 1) * bs]);
        file[e..e + 4].copy_from_slice(&c.to_le_bytes());
    }
    let c = crc32(&file[..bs - 4]);
    file[bs - 4..bs].copy_from_slice(&c.to_le_bytes());
}

fn put_u16s(dst: &mut [u8], src: &[u16]) {
    for (chunk, v) in dst.chunks_exact_mut(2).zip(src) {
        chunk.copy_from_slice(&v.to_le_bytes());
    }
}
