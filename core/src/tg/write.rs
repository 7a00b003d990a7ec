//! Writing `.tg` files (`bake` feature): the inverse of [`super::read`], from a [`BakedGrid`].

use std::vec;
use std::vec::Vec;

use super::brick::{self, Brick, BrickEntry};
use super::read::TriGrid;
use super::read::{Header, LevelDir};
use super::{
    mask_bytes, ARRAY_ALIGN, BLOCK_LOG2_RANGE, BOUNDS_OFFSET, BRICKS_OFFSET, BRICK_LEVEL_OFFSET,
    CONE_SHIFT, DIRECTORY_ENTRY, DIRECTORY_OFFSET, FLAG_COLOR, FLAG_CONES, FLAG_PRECISE, MAGIC,
    MAX_LEVELS, PRECISE_BYTES, VERSION,
};
use crate::bake::cone::cone_classes;
use crate::bake::{BakedGrid, BakedLevel, PreciseCube};
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
    /// A brick level with fewer than two levels below it.
    BrickLevel(u8),
    /// Bricks below this level would span more than [`MAX_BRICK_BLOCKS`] blocks: a stream
    /// enters a brick whole, so its cache would have to hold them all.
    BrickTooLarge {
        /// The brick level asked for.
        level: u8,
        /// Blocks its largest brick would span.
        blocks: u32,
        /// The shallowest level whose bricks fit.
        fits: u8,
    },
}

/// Most blocks a brick the writer makes may span (one cell's subtree larger than a block makes a
/// brick of several): a stream checks a brick whole when it first enters it, so its cache must
/// hold the largest brick with the path above it. With 4 the default bakes stream through a 64 KB
/// cache of 4 KB blocks (`pocketsplat info` gives what a file needs).
pub const MAX_BRICK_BLOCKS: u32 = 4;

impl core::fmt::Display for WriteError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            WriteError::BlockSize(b) => write!(f, "block size 2^{b} is outside 2^9..=2^16"),
            WriteError::BrickLevel(r) => write!(
                f,
                "bricks below level {r} need at least two levels below it (depth {} or more)",
                u16::from(*r) + 2
            ),
            WriteError::BrickTooLarge {
                level,
                blocks,
                fits,
            } => write!(
                f,
                "bricks below level {level} would span up to {blocks} blocks, and a stream must \
                 hold a whole brick in its cache (at most {MAX_BRICK_BLOCKS} are written): brick \
                 below level {fits} or deeper"
            ),
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

/// How a file lays out its levels (FORMAT.md "Versions").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layout {
    /// Version 3 with the deep levels in bricks below the level [`brick_level`] picks (the
    /// default: a streamed view reads a few blocks per subtree). Grids of depth below 3 have no
    /// level to brick and are written unbricked.
    Bricked,
    /// Version 3 bricked below the given level (at most depth − 2).
    BrickedBelow(u8),
    /// Version 3 without bricks: every level is one array, the layout of version 2 (what a reader
    /// that draws a file in place from flash walks fastest; scene packs).
    Unbricked,
    /// Version 2, for the tests of the older reader.
    Version2,
}

/// The level below which [`Layout::Bricked`] bricks a grid: the shallowest level `R` whose cells'
/// subtrees between `R` and the leaves (the bricks' part of them) take at most a quarter of a block
/// on average, so that a brick holds several of them and one starting on a block wastes little at
/// its end; at least 1 and at most depth − 2. `None` below depth 3.
pub fn brick_level(grid: &BakedGrid, block_log2: u8) -> Option<u8> {
    let depth = grid.levels.len() - 1;
    if depth < 3 {
        return None;
    }
    let mb = mask_bytes(grid.rho) as u64;
    let colour = if grid.levels[0].colors.is_some() {
        2
    } else {
        0
    };
    let bytes = |l: usize| -> u64 {
        let n = grid.levels[l].attrs.len() as u64;
        n * (2 + colour + mb + if l + 2 <= depth { 4 } else { 0 })
    };
    let quarter = (1u64 << block_log2) / 4;
    (1..=depth - 2)
        .find(|&r| {
            let band: u64 =
                (r + 1..depth).map(bytes).sum::<u64>() + 4 * grid.levels[r].attrs.len() as u64;
            band <= quarter * grid.levels[r].attrs.len() as u64
        })
        .or(Some(depth - 2))
        .map(|r| r as u8)
}

/// Serialises a baked grid into a `.tg` file with blocks of `2^block_log2` bytes: version 3,
/// bricked ([`Layout::Bricked`]).
///
/// # Errors
/// [`WriteError`] when the block size is out of range or the file too large for it.
pub fn write_tg(grid: &BakedGrid, block_log2: u8) -> Result<Vec<u8>, WriteError> {
    write_tg_as(grid, block_log2, Layout::Bricked)
}

/// Where a file's arrays go: per level the offsets of attributes, colours, masks and groups in the
/// level directory (0: absent), the brick table and the bricks.
struct Plan {
    dir: Vec<[u32; 4]>,
    table: u32,
    bricks: Vec<BrickEntry>,
    end: usize,
}

/// [`write_tg`] with the layout chosen.
///
/// # Errors
/// [`WriteError`] when the block size is out of range, the file too large for it, or the brick
/// level out of range.
pub fn write_tg_as(
    grid: &BakedGrid,
    block_log2: u8,
    layout: Layout,
) -> Result<Vec<u8>, WriteError> {
    // Normal cones go in the spare bits of ρ = 3 masks.
    let cones = if grid.cones && grid.rho == 3 {
        cone_classes(grid)
    } else {
        Vec::new()
    };
    write_with_cones(grid, block_log2, layout, cones)
}

/// A file read back into a [`BakedGrid`] and its normal-cone classes as stored (per level, per
/// cell; empty without cones): what the writer needs to write the same grid in another layout.
pub fn unbake(file: &TriGrid<'_>) -> (BakedGrid, Vec<Vec<u8>>) {
    let h = file.header();
    let levels = (0..=h.depth)
        .map(|l| {
            let n = file.level(l).count;
            BakedLevel {
                attrs: (0..n).map(|i| file.attr(l, i)).collect(),
                colors: h
                    .has_color()
                    .then(|| (0..n).map(|i| file.color(l, i).unwrap_or(0)).collect()),
                masks: if l < h.depth {
                    (0..n).map(|i| file.mask(l, i)).collect()
                } else {
                    Vec::new()
                },
            }
        })
        .collect();
    let cones = if h.has_cones() {
        (0..=h.depth)
            .map(|l| (0..file.level(l).count).map(|i| file.cone(l, i)).collect())
            .collect()
    } else {
        Vec::new()
    };
    let grid = BakedGrid {
        rho: h.rho,
        material_bits: h.material_bits,
        origin: h.origin.map(f64::from),
        side: f64::from(h.side),
        bounds: h.bounds,
        precise: h.has_precise().then_some(PreciseCube {
            origin: h.origin64,
            side: h.side64,
            bounds: h.bounds64,
        }),
        levels,
        cones: h.has_cones(),
    };
    (grid, cones)
}

/// Writes a validated file again in `layout`, with its block size and every stored value (cone
/// classes included, as stored): `pocketsplat migrate`, for a version 2 file that is to be
/// streamed. Its frames are the same pixels.
///
/// # Errors
/// As [`write_tg_as`].
pub fn rewrite_tg(file: &TriGrid<'_>, layout: Layout) -> Result<Vec<u8>, WriteError> {
    let (grid, cones) = unbake(file);
    write_with_cones(&grid, file.header().block_log2, layout, cones)
}

fn write_with_cones(
    grid: &BakedGrid,
    block_log2: u8,
    layout: Layout,
    cones: Vec<Vec<u8>>,
) -> Result<Vec<u8>, WriteError> {
    if !BLOCK_LOG2_RANGE.contains(&block_log2) {
        return Err(WriteError::BlockSize(block_log2));
    }
    let bs = 1usize << block_log2;
    let levels = grid.levels.len();
    let depth = levels - 1;
    let color = grid.levels[0].colors.is_some();
    let r = match layout {
        Layout::Bricked => brick_level(grid, block_log2),
        Layout::BrickedBelow(r) if usize::from(r) + 2 <= depth => Some(r),
        Layout::BrickedBelow(r) => return Err(WriteError::BrickLevel(r)),
        Layout::Unbricked | Layout::Version2 => None,
    };
    let mut header = Header {
        version: if layout == Layout::Version2 {
            2
        } else {
            VERSION
        },
        flags: if color { FLAG_COLOR } else { 0 }
            | if cones.is_empty() { 0 } else { FLAG_CONES }
            | grid.precise.map_or(0, |_| FLAG_PRECISE),
        rho: grid.rho,
        depth: depth as u8,
        normal_bits: 13,
        material_bits: grid.material_bits,
        block_log2,
        origin: grid.origin.map(|v| v as f32),
        side: grid.side as f32,
        blocks: 0,
        crc_table_blocks: 0,
        bounds: grid.bounds,
        origin64: grid.origin,
        side64: grid.side,
        bounds64: grid.bounds.map(|c| c.map(f64::from)),
        brick_level: r.unwrap_or(0),
        bricks: u32::from(r.is_some()),
        brick_table: 0,
    };
    let bricks = match r {
        Some(r) => {
            // The shallowest level from the one chosen whose bricks fit: the writer's own choice
            // goes deeper, a level asked for is refused, naming the one that fits.
            let (mut fits, mut asked) = (None, 0);
            for level in r..=depth as u8 - 2 {
                header.brick_level = level;
                let (bricks, blocks) = pack_bricks(grid, &header, level);
                if level == r {
                    asked = blocks;
                }
                if blocks <= MAX_BRICK_BLOCKS {
                    fits = Some((level, bricks));
                    break;
                }
            }
            let (level, bricks) =
                fits.expect("bricks below depth - 2 hold one cell's children: a block at most");
            if level != r && layout != Layout::Bricked {
                return Err(WriteError::BrickTooLarge {
                    level: r,
                    blocks: asked,
                    fits: level,
                });
            }
            bricks
        }
        None => Vec::new(),
    };
    let r = r.map(|_| header.brick_level);
    header.bricks = bricks.len() as u32;
    // T table blocks cover 4T·bs/4 = T·bs/4 blocks; grow T until the file fits.
    let list_at = DIRECTORY_OFFSET + DIRECTORY_ENTRY * levels;
    let mut t = 1usize;
    let (plan, blocks) = loop {
        let plan = plan(grid, &header, &bricks, (1 + t) * bs);
        let blocks = plan.end.div_ceil(bs);
        if t * (bs / 4) >= blocks {
            break (plan, blocks);
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
    header.blocks = blocks as u32;
    header.crc_table_blocks = t as u32;
    header.brick_table = plan.table;

    let mb = mask_bytes(grid.rho) as usize;
    let masks = |l: usize| -> Vec<u8> {
        let mut out = vec![0u8; mb * grid.levels[l].masks.len()];
        for (i, (chunk, m)) in out
            .chunks_exact_mut(mb)
            .zip(&grid.levels[l].masks)
            .enumerate()
        {
            let cone = cones.get(l).map_or(0, |c| u128::from(c[i]));
            chunk.copy_from_slice(&(m | cone << CONE_SHIFT).to_le_bytes()[..mb]);
        }
        out
    };
    let groups = |l: usize| -> Vec<u8> {
        if l + 2 > depth {
            return Vec::new();
        }
        group_array(grid, l)
            .iter()
            .flat_map(|g| g.to_le_bytes())
            .collect()
    };
    let u16s = |v: &[u16]| -> Vec<u8> { v.iter().flat_map(|x| x.to_le_bytes()).collect() };
    let level_arrays = |l: usize| -> [Vec<u8>; 4] {
        let level = &grid.levels[l];
        [
            u16s(&level.attrs),
            u16s(level.colors.as_deref().unwrap_or(&[])),
            masks(l),
            groups(l),
        ]
    };
    let sizes = [2usize, 2, mb, 4];
    let mut file = vec![0u8; blocks * bs];
    for (l, offs) in plan.dir.iter().enumerate() {
        if offs.iter().all(|&o| o == 0) {
            continue;
        }
        for (k, bytes) in level_arrays(l).iter().enumerate() {
            if offs[k] != 0 {
                let at = offs[k] as usize;
                file[at..at + bytes.len()].copy_from_slice(bytes);
            }
        }
    }
    if let Some(r) = r {
        let entry = brick::entry_bytes(r, depth as u8);
        let arrays: Vec<[Vec<u8>; 4]> = (0..levels)
            .map(|l| {
                if l >= usize::from(r) && l < depth {
                    level_arrays(l)
                } else {
                    Default::default()
                }
            })
            .collect();
        let dirs = header_dirs(&header, grid, &plan);
        let end = brick::band_end(&header, &dirs);
        for (b, e) in plan.bricks.iter().enumerate() {
            let at = plan.table as usize + entry * b;
            e.write(&header, &mut file[at..at + entry]);
            let brick = Brick::of(&header, &dirs, b as u32, e, plan.bricks.get(b + 1), end)
                .expect("the writer's bricks follow the rules");
            for (l, level) in arrays.iter().enumerate().take(depth).skip(usize::from(r)) {
                for (k, &size) in sizes.iter().enumerate() {
                    let off = brick.arrays[l][k] as usize;
                    if off == 0 {
                        continue;
                    }
                    let (from, n) = (brick.first[l] as usize, brick.count[l] as usize);
                    let src = &level[k][size * from..size * (from + n)];
                    file[off..off + src.len()].copy_from_slice(src);
                }
            }
        }
    }

    // Header.
    let h = &mut file[..bs];
    h[0..4].copy_from_slice(&MAGIC);
    h[4..6].copy_from_slice(&header.version.to_le_bytes());
    h[6..8].copy_from_slice(&header.flags.to_le_bytes());
    h[8] = grid.rho;
    h[9] = depth as u8;
    h[10] = 13;
    h[11] = grid.material_bits;
    h[12] = block_log2;
    if r.is_some() {
        h[BRICK_LEVEL_OFFSET] = header.brick_level;
        h[BRICKS_OFFSET..BRICKS_OFFSET + 4].copy_from_slice(&header.bricks.to_le_bytes());
        h[BRICKS_OFFSET + 4..BRICKS_OFFSET + 8].copy_from_slice(&plan.table.to_le_bytes());
    }
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
    for (l, offs) in plan.dir.iter().enumerate() {
        let e = DIRECTORY_OFFSET + DIRECTORY_ENTRY * l;
        let count = grid.levels[l].attrs.len() as u32;
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

/// The level directory a plan gives (counts and offsets), as a reader parses it.
fn header_dirs(h: &Header, grid: &BakedGrid, plan: &Plan) -> [LevelDir; MAX_LEVELS] {
    let mut dirs = [LevelDir::default(); MAX_LEVELS];
    for (l, d) in dirs.iter_mut().enumerate().take(h.levels()) {
        let o = plan.dir[l];
        *d = LevelDir {
            count: grid.levels[l].attrs.len() as u32,
            attr_off: o[0],
            color_off: o[1],
            mask_off: o[2],
            group_off: o[3],
        };
    }
    dirs
}

/// Cuts the levels below `r` into bricks: runs of consecutive level-`r` cells, each as many as fit
/// in one block (a cell whose subtree is larger than a block alone), each brick starting on a block
/// (FORMAT.md "Bricks"). Returns their entries, block numbers counted from the first brick's, and
/// the most blocks one spans.
fn pack_bricks(grid: &BakedGrid, header: &Header, r: u8) -> (Vec<BrickEntry>, u32) {
    let depth = grid.levels.len() - 1;
    let ru = usize::from(r);
    // first[l][i]: the first child (at l + 1) of cell i at l, for i in 0..=count (the last: count
    // of l + 1).
    let mut first: Vec<Vec<u32>> = Vec::new();
    for l in 0..depth {
        let mut f = Vec::with_capacity(grid.levels[l].masks.len() + 1);
        let mut acc = 0u32;
        for m in &grid.levels[l].masks {
            f.push(acc);
            acc += m.count_ones();
        }
        f.push(acc);
        first.push(f);
    }
    // The index of cell c of level r's first descendant at each level.
    let below = |c: u32| -> [u32; MAX_LEVELS] {
        let mut at = [0u32; MAX_LEVELS];
        at[ru] = c;
        for l in ru..depth {
            at[l + 1] = first[l][at[l] as usize];
        }
        at
    };
    let bs = header.block_size() as u64;
    let cells = grid.levels[ru].attrs.len() as u32;
    let size = |a: &[u32; MAX_LEVELS], b: &[u32; MAX_LEVELS]| -> u64 {
        let mut count = [0u32; MAX_LEVELS];
        for l in ru..=depth {
            count[l] = b[l] - a[l];
        }
        brick::lay_out(header, &count, |_, _, _| {})
    };
    let mut bricks = Vec::new();
    let (mut block, mut largest) = (0u32, 0u32);
    let mut a = below(0);
    while a[ru] < cells {
        let mut b = below(a[ru] + 1);
        while b[ru] < cells {
            let next = below(b[ru] + 1);
            if size(&a, &next) > bs {
                break;
            }
            b = next;
        }
        let mut e = BrickEntry {
            first_cell: a[ru],
            block,
            first: [0; MAX_LEVELS],
        };
        e.first[ru + 1..=depth].copy_from_slice(&a[ru + 1..=depth]);
        bricks.push(e);
        let blocks = size(&a, &b).div_ceil(bs).max(1) as u32;
        largest = largest.max(blocks);
        block += blocks;
        a = b;
    }
    (bricks, largest)
}

/// Places the arrays from `data_start`: the level-ordered head (every level when there are no
/// bricks), the brick table and the bricks (from the next block), then the leaves.
fn plan(grid: &BakedGrid, h: &Header, bricks: &[BrickEntry], data_start: usize) -> Plan {
    let depth = grid.levels.len() - 1;
    let mb = mask_bytes(grid.rho) as usize;
    let color = grid.levels[0].colors.is_some();
    let bs = h.block_size();
    let bricked = !bricks.is_empty();
    let mut at = data_start;
    let mut dir = vec![[0u32; 4]; depth + 1];
    let place = |dir: &mut [u32; 4], at: &mut usize, n: usize, l: usize, upto: usize| {
        let sizes = [
            2 * n,
            if color { 2 * n } else { 0 },
            if l < depth { mb * n } else { 0 },
            if l + 1 < depth && l < upto { 4 * n } else { 0 },
        ];
        for (k, size) in sizes.into_iter().enumerate() {
            if size > 0 {
                dir[k] = *at as u32;
                *at += align(size);
            }
        }
    };
    let head = if bricked {
        usize::from(h.brick_level)
    } else {
        depth
    };
    for (l, d) in dir.iter_mut().enumerate().take(head + 1) {
        place(
            d,
            &mut at,
            grid.levels[l].attrs.len(),
            l,
            if bricked { head } else { depth },
        );
    }
    let mut table = 0u32;
    let mut entries = bricks.to_vec();
    if bricked {
        table = at as u32;
        at += align(bricks.len() * brick::entry_bytes(h.brick_level, depth as u8));
        let first_block = at.div_ceil(bs) as u32;
        let mut h3 = *h;
        h3.brick_table = table;
        for e in &mut entries {
            e.block += first_block;
        }
        // The last brick's end: its first block plus its length.
        let last = entries.last().copied().unwrap_or_default();
        let mut count = [0u32; MAX_LEVELS];
        for (l, c) in count
            .iter_mut()
            .enumerate()
            .take(depth + 1)
            .skip(usize::from(h.brick_level))
        {
            let total = grid.levels[l].attrs.len() as u32;
            *c = total
                - if l == usize::from(h.brick_level) {
                    last.first_cell
                } else {
                    last.first[l]
                };
        }
        at = (last.block as usize) * bs + brick::lay_out(&h3, &count, |_, _, _| {}) as usize;
        at = align(at);
        place(
            &mut dir[depth],
            &mut at,
            grid.levels[depth].attrs.len(),
            depth,
            0,
        );
    }
    Plan {
        dir,
        table,
        bricks: entries,
        end: at,
    }
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
