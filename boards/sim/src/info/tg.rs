//! What a tri-grid (`.tg`) file holds and what it costs: samples and α per level, bits per leaf.

use std::fmt::Write as _;
use std::path::Path;

use pocketsplat_core::stream::ChunkSource;
use pocketsplat_core::tg::read::{Header, LevelDir};
use pocketsplat_core::tg::{TriGrid, MAX_LEVELS};
use serde::Serialize;

/// One level of a `.tg` file.
#[derive(Clone, Debug, Serialize)]
pub struct LevelInfo {
    /// Level (0 = the root).
    pub depth: u8,
    /// Samples at this level.
    pub samples: u32,
    /// Mean non-empty children per cell (α, Duguet §4.3); `null` at the leaf level.
    pub alpha: Option<f64>,
}

/// Statistics of a `.tg` file.
#[derive(Clone, Debug, Serialize)]
pub struct TgInfo {
    /// Always "tg".
    pub format: &'static str,
    /// Format version of the header (not in the JSON).
    #[serde(skip)]
    pub version: u16,
    /// File size.
    pub file_bytes: u64,
    /// ρ.
    pub rho: u8,
    /// Subdivisions.
    pub depth: u8,
    /// Block size.
    pub block_bytes: u32,
    /// Material bits per sample.
    pub material_bits: u8,
    /// Whether samples carry colour.
    pub color: bool,
    /// Root cube corner and side.
    pub root_cube: [f32; 4],
    /// Leaf samples.
    pub leaf_samples: u64,
    /// Interior samples.
    pub interior_samples: u64,
    /// All samples.
    pub total_samples: u64,
    /// Per level.
    pub levels: Vec<LevelInfo>,
    /// α of the finest subdivision (leaves per cell one level up).
    pub alpha_finest: Option<f64>,
    /// File bytes per leaf sample.
    pub bytes_per_leaf: f64,
    /// Bits per leaf sample spent on everything but the leaves' own attributes (masks, group
    /// pointers, interior samples, header, CRC table, padding).
    pub structure_bits_per_leaf: f64,
    /// The same as the paper's Table 1 counts it: (σ + ρ³) bits per interior cell, per leaf sample.
    pub paper_structure_bits_per_leaf: f64,
    /// Bits per leaf sample spent on group pointers.
    pub pointer_bits_per_leaf: f64,
    /// What streaming the file takes (version 3; `null` for older files, which do not stream).
    pub stream: Option<StreamInfo>,
}

/// What `render --stream` (or a device) needs to stream a version 3 `.tg` file.
#[derive(Clone, Debug, Serialize)]
pub struct StreamInfo {
    /// The brick level (`null` without bricks).
    pub brick_level: Option<u8>,
    /// Bricks.
    pub bricks: u32,
    /// Blocks the largest brick spans.
    pub largest_brick_blocks: u32,
    /// The smallest block cache that streams it, bytes (`--cache`): smaller ones are refused.
    pub cache_bytes: u64,
}

/// What streaming `tg` needs (`None` before version 3).
fn stream_info(tg: &TriGrid<'_>) -> Option<StreamInfo> {
    let h = *tg.header();
    let dirs: [LevelDir; MAX_LEVELS] = core::array::from_fn(|l| {
        if l < h.levels() {
            tg.level(l as u8)
        } else {
            LevelDir::default()
        }
    });
    stream_need(
        &h,
        &dirs,
        &mut pocketsplat_core::stream::MemSource::new(tg.bytes()),
    )
}

/// What streaming the file `src` reads needs (header `h`, level directory `dirs`; `None` before
/// version 3 or when the file cannot be opened as a stream): a file read whole or one too large
/// for that, read in blocks (the brick table word by word, then the stream's own opening).
pub fn stream_need<C: ChunkSource>(
    h: &Header,
    dirs: &[LevelDir; MAX_LEVELS],
    src: &mut C,
) -> Option<StreamInfo> {
    use pocketsplat_core::stream::{table_entries, BlockEntry, SlotEntry, StreamError, TgStream};
    use pocketsplat_core::tg::brick::check_table;
    let h = *h;
    if h.version < pocketsplat_core::tg::VERSION_BRICKS {
        return None;
    }
    let largest_brick_blocks = if h.bricked() {
        let mut word = |off: u64, n: usize| {
            let mut w = [0u8; 16];
            src.read_at(off, w.get_mut(..n)?).ok()?;
            Some(u128::from_le_bytes(w))
        };
        check_table(&h, dirs, &mut word).map_or(0, |s| s.brick)
    } else {
        0
    };
    // A cache as large as the file (within reason) says what it needs; a smaller one says so too.
    let bs = h.block_size();
    let slots = (h.blocks as usize).clamp(pocketsplat_core::stream::MIN_SLOTS, 4096);
    use crate::memory::filled;
    let (mut data, mut slot_mem) = (
        filled(0u8, slots * bs).ok()?,
        filled(SlotEntry::EMPTY, slots).ok()?,
    );
    let mut blocks = filled(BlockEntry::EMPTY, table_entries(slots, 0)).ok()?;
    let needed = match TgStream::open(src, &mut data, &mut slot_mem, &mut blocks) {
        Ok(s) => s.cache_need(),
        Err(StreamError::CacheTooSmall { needed, .. }) => needed,
        Err(_) => return None,
    };
    Some(StreamInfo {
        brick_level: h.bricked().then_some(h.brick_level),
        bricks: h.bricks,
        largest_brick_blocks,
        cache_bytes: u64::from(needed) * bs as u64,
    })
}

/// Attribute bits per sample as stored (13-bit normal + material bits, in a u16; + colour).
fn sigma(h: &Header) -> u32 {
    16 + if h.has_color() { 16 } else { 0 }
}

/// Statistics of an opened `.tg` file.
pub fn tg_info(tg: &TriGrid<'_>) -> TgInfo {
    let levels: [LevelDir; MAX_LEVELS] = core::array::from_fn(|l| {
        if l < tg.header().levels() {
            tg.level(l as u8)
        } else {
            LevelDir::default()
        }
    });
    TgInfo {
        stream: stream_info(tg),
        ..tg_info_of(tg.header(), &levels, tg.bytes().len() as u64)
    }
}

/// Statistics of a `.tg` file of `file_bytes` bytes from its header and level directory (`stream`
/// left `None`: the caller works it out from the file, `stream_need`).
pub fn tg_info_of(h: &Header, dirs: &[LevelDir; MAX_LEVELS], file_bytes: u64) -> TgInfo {
    let h = *h;
    let count = |d: u8| dirs[usize::from(d)].count;
    let leaves = u64::from(count(h.depth));
    let total: u64 = (0..=h.depth).map(|d| u64::from(count(d))).sum();
    let interior = total - leaves;
    let levels: Vec<LevelInfo> = (0..=h.depth)
        .map(|d| {
            let samples = count(d);
            let alpha = (d < h.depth).then(|| f64::from(count(d + 1)) / f64::from(samples));
            LevelInfo {
                depth: d,
                samples,
                alpha,
            }
        })
        .collect();
    let l = leaves.max(1) as f64;
    let pointers: u64 = (0..h.depth.saturating_sub(1))
        .map(|d| u64::from(count(d)))
        .sum();
    TgInfo {
        format: "tg",
        version: h.version,
        file_bytes,
        rho: h.rho,
        depth: h.depth,
        block_bytes: h.block_size() as u32,
        material_bits: h.material_bits,
        color: h.has_color(),
        root_cube: [h.origin[0], h.origin[1], h.origin[2], h.side],
        leaf_samples: leaves,
        interior_samples: interior,
        total_samples: total,
        alpha_finest: h
            .depth
            .checked_sub(1)
            .and_then(|d| levels[usize::from(d)].alpha),
        levels,
        bytes_per_leaf: file_bytes as f64 / l,
        structure_bits_per_leaf: (file_bytes as f64 * 8.0 - leaves as f64 * f64::from(sigma(&h)))
            / l,
        paper_structure_bits_per_leaf: interior as f64
            * f64::from(sigma(&h) + u32::from(h.rho).pow(3))
            / l,
        pointer_bits_per_leaf: pointers as f64 * 32.0 / l,
        stream: None,
    }
}

impl TgInfo {
    /// The statistics as `info` prints them, a table of the levels included; `path` heads them.
    pub fn to_text(&self, path: &Path) -> String {
        let mut out = String::new();
        let _ = writeln!(
            out,
            "{}: .tg version {}, rho {} ({}), depth {}",
            path.display(),
            self.version,
            self.rho,
            match self.rho {
                2 => "octree",
                3 => "tri-grid",
                _ => "rho-grid",
            },
            self.depth
        );
        let _ = writeln!(
            out,
            "  root cube: corner ({}, {}, {}), side {}",
            self.root_cube[0], self.root_cube[1], self.root_cube[2], self.root_cube[3]
        );
        let _ = writeln!(
            out,
            "  attributes: 13-bit normal, {} material bits, colour {}; blocks of {} bytes",
            self.material_bits,
            if self.color { "RGB565" } else { "none" },
            self.block_bytes
        );
        let _ = writeln!(out, "  level      samples   alpha");
        for l in &self.levels {
            let kind = if l.depth == self.depth { "leaf" } else { "" };
            let _ = match l.alpha {
                Some(a) => writeln!(out, "  {:>5} {:>12} {:>7.3}", l.depth, l.samples, a),
                None => writeln!(out, "  {:>5} {:>12}    -    {kind}", l.depth, l.samples),
            };
        }
        let _ = writeln!(
            out,
            "  samples: {} ({} leaf, {} interior)",
            self.total_samples, self.leaf_samples, self.interior_samples
        );
        let _ = writeln!(
            out,
            "  file: {} bytes, {:.3} bytes per leaf sample; structure {:.2} bits per leaf sample \
             (paper's count {:.2}, group pointers {:.3})",
            self.file_bytes,
            self.bytes_per_leaf,
            self.structure_bits_per_leaf,
            self.paper_structure_bits_per_leaf,
            self.pointer_bits_per_leaf
        );
        let cache = |s: &StreamInfo| crate::stream::run::cache_arg(s.cache_bytes);
        let _ = match &self.stream {
            Some(
                s @ StreamInfo {
                    brick_level: Some(r),
                    ..
                },
            ) => writeln!(
                out,
                "  bricks: {} below level {r}, the largest {} blocks; streaming needs --cache {} \
                 or more",
                s.bricks,
                s.largest_brick_blocks,
                cache(s)
            ),
            Some(s) => writeln!(
                out,
                "  no bricks; streaming needs --cache {} or more",
                cache(s)
            ),
            None => writeln!(
                out,
                "  version {}: not streamable (`pocketsplat migrate` writes version 3)",
                self.version
            ),
        };
        out
    }
}
