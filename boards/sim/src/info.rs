//! `pocketsplat info FILE [--json]`: what a point file (`.tg` or `.qs`) holds and what it costs.

use std::path::Path;

use anyhow::Result;
use pocketsplat_core::qs::{ByteOrder, QSplat};
use pocketsplat_core::tg::{TriGrid, Verify};
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
}

/// Attribute bits per sample as stored (13-bit normal + material bits, in a u16; + colour).
fn sigma(tg: &TriGrid<'_>) -> u32 {
    16 + if tg.header().has_color() { 16 } else { 0 }
}

/// Statistics of an opened `.tg` file.
pub fn tg_info(tg: &TriGrid<'_>) -> TgInfo {
    let h = *tg.header();
    let leaves = u64::from(tg.leaf_samples());
    let total = tg.total_samples();
    let interior = total - leaves;
    let levels: Vec<LevelInfo> = (0..=h.depth)
        .map(|d| {
            let samples = tg.level(d).count;
            let alpha =
                (d < h.depth).then(|| f64::from(tg.level(d + 1).count) / f64::from(samples));
            LevelInfo {
                depth: d,
                samples,
                alpha,
            }
        })
        .collect();
    let file_bytes = tg.bytes().len() as u64;
    let l = leaves.max(1) as f64;
    let pointers: u64 = (0..h.depth.saturating_sub(1))
        .map(|d| u64::from(tg.level(d).count))
        .sum();
    TgInfo {
        format: "tg",
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
        structure_bits_per_leaf: (file_bytes as f64 * 8.0 - leaves as f64 * f64::from(sigma(tg)))
            / l,
        paper_structure_bits_per_leaf: interior as f64
            * f64::from(sigma(tg) + u32::from(h.rho).pow(3))
            / l,
        pointer_bits_per_leaf: pointers as f64 * 32.0 / l,
    }
}

/// Statistics of a `.qs` file.
#[derive(Clone, Debug, Serialize)]
pub struct QsInfo {
    /// Always "qsplat".
    pub format: &'static str,
    /// File size.
    pub file_bytes: u64,
    /// "big" or "little" endian.
    pub byte_order: &'static str,
    /// Fragments, comments included.
    pub fragments: u32,
    /// Comment fragments.
    pub comment_fragments: u32,
    /// Tree fragments.
    pub tree_fragments: u32,
    /// The comments' texts.
    pub comments: Vec<String>,
    /// Whether any tree carries RGB565 colours.
    pub color: bool,
    /// Leaf nodes (points).
    pub leaves: u64,
    /// Interior nodes, one root per tree included (roots live in fragment headers).
    pub interior_nodes: u64,
    /// Deepest level below a root.
    pub depth: u8,
    /// Bytes per node record (4, or 6 with colour; the mean over trees).
    pub bytes_per_node: f64,
    /// File bytes per leaf.
    pub bytes_per_leaf: f64,
    /// Group pointers.
    pub pointers: u64,
    /// Bytes of pointers.
    pub pointer_bytes: u64,
    /// Share of the file taken by pointers.
    pub pointer_share: f64,
    /// Bytes of fragment headers, comments and padding.
    pub header_bytes: u64,
}

/// Statistics of an opened `.qs` file.
pub fn qs_info(q: &QSplat<'_>) -> QsInfo {
    let c = *q.counts();
    let file_bytes = q.bytes().len() as u64;
    let records = c.leaves + c.interior;
    let pointer_bytes = 4 * c.pointers;
    QsInfo {
        format: "qsplat",
        file_bytes,
        byte_order: match q.byte_order() {
            ByteOrder::Big => "big",
            ByteOrder::Little => "little",
        },
        fragments: c.fragments,
        comment_fragments: c.comments,
        tree_fragments: c.trees,
        comments: q
            .comments()
            .map(|t| String::from_utf8_lossy(t).into_owned())
            .collect(),
        color: c.color_trees > 0,
        leaves: c.leaves,
        interior_nodes: c.interior + u64::from(c.trees),
        depth: c.max_depth,
        bytes_per_node: c.node_bytes as f64 / records.max(1) as f64,
        bytes_per_leaf: file_bytes as f64 / c.leaves.max(1) as f64,
        pointers: c.pointers,
        pointer_bytes,
        pointer_share: pointer_bytes as f64 / file_bytes.max(1) as f64,
        header_bytes: c.header_bytes,
    }
}

fn run_qs(path: &Path, json: bool) -> Result<()> {
    let bytes = crate::qsplat::read_qs(path)?;
    let q = QSplat::open(&bytes).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    let info = qs_info(&q);
    if json {
        println!("{}", serde_json::to_string(&info)?);
        return Ok(());
    }
    println!(
        "{}: QSplat version 11, {}-endian, {} fragments ({} tree, {} comment)",
        path.display(),
        info.byte_order,
        info.fragments,
        info.tree_fragments,
        info.comment_fragments
    );
    for c in &info.comments {
        println!("  comment: {c}");
    }
    println!(
        "  nodes: {} leaves, {} interior (roots included), depth {}; colour {}",
        info.leaves,
        info.interior_nodes,
        info.depth,
        if info.color { "RGB565" } else { "none" }
    );
    println!(
        "  file: {} bytes, {:.2} bytes per node, {:.3} bytes per leaf; pointers {} ({} bytes, {:.1} % of the file); headers {} bytes",
        info.file_bytes,
        info.bytes_per_node,
        info.bytes_per_leaf,
        info.pointers,
        info.pointer_bytes,
        100.0 * info.pointer_share,
        info.header_bytes
    );
    Ok(())
}

/// Reads and opens a `.tg` file, naming it in any error.
///
/// # Errors
/// When the file cannot be read or is not a valid `.tg` file.
pub fn read_tg(path: &Path) -> Result<Vec<u8>> {
    let bytes = crate::fsutil::read_file(path)?;
    TriGrid::open(&bytes, Verify::Full).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    Ok(bytes)
}

/// The `info` command.
///
/// # Errors
/// When the file cannot be read or is invalid.
pub fn run(path: &Path, json: bool) -> Result<()> {
    if crate::qsplat::is_qs(path)? {
        return run_qs(path, json);
    }
    let bytes = read_tg(path)?;
    let tg = TriGrid::open(&bytes, Verify::Structure)
        .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    let info = tg_info(&tg);
    if json {
        println!("{}", serde_json::to_string(&info)?);
        return Ok(());
    }
    println!(
        "{}: .tg version {}, rho {} ({}), depth {}",
        path.display(),
        tg.header().version,
        info.rho,
        match info.rho {
            2 => "octree",
            3 => "tri-grid",
            _ => "rho-grid",
        },
        info.depth
    );
    println!(
        "  root cube: corner ({}, {}, {}), side {}",
        info.root_cube[0], info.root_cube[1], info.root_cube[2], info.root_cube[3]
    );
    println!(
        "  attributes: 13-bit normal, {} material bits, colour {}; blocks of {} bytes",
        info.material_bits,
        if info.color { "RGB565" } else { "none" },
        info.block_bytes
    );
    println!("  level      samples   alpha");
    for l in &info.levels {
        let kind = if l.depth == info.depth { "leaf" } else { "" };
        match l.alpha {
            Some(a) => println!("  {:>5} {:>12} {:>7.3}", l.depth, l.samples, a),
            None => println!("  {:>5} {:>12}    -    {kind}", l.depth, l.samples),
        }
    }
    println!(
        "  samples: {} ({} leaf, {} interior)",
        info.total_samples, info.leaf_samples, info.interior_samples
    );
    println!(
        "  file: {} bytes, {:.3} bytes per leaf sample; structure {:.2} bits per leaf sample \
         (paper's count {:.2}, group pointers {:.3})",
        info.file_bytes,
        info.bytes_per_leaf,
        info.structure_bits_per_leaf,
        info.paper_structure_bits_per_leaf,
        info.pointer_bits_per_leaf
    );
    Ok(())
}
