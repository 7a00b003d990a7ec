//! What a QSplat (`.qs`) file holds and what it costs: fragments, nodes, bytes per leaf, pointers.

use std::fmt::Write as _;
use std::path::Path;

use pocketsplat_core::qs::{ByteOrder, QSplat, QsCounts};
use serde::Serialize;

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
    qs_info_of(
        q.counts(),
        q.bytes().len() as u64,
        q.byte_order(),
        q.comments()
            .map(|t| String::from_utf8_lossy(t).into_owned())
            .collect(),
    )
}

/// Statistics of a `.qs` file of `file_bytes` bytes from its counts, byte order and comments.
pub fn qs_info_of(
    c: &QsCounts,
    file_bytes: u64,
    order: ByteOrder,
    comments: Vec<String>,
) -> QsInfo {
    let c = *c;
    let records = c.leaves + c.interior;
    let pointer_bytes = 4 * c.pointers;
    QsInfo {
        format: "qsplat",
        file_bytes,
        byte_order: match order {
            ByteOrder::Big => "big",
            ByteOrder::Little => "little",
        },
        fragments: c.fragments,
        comment_fragments: c.comments,
        tree_fragments: c.trees,
        comments,
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

impl QsInfo {
    /// The statistics as `info` prints them; `path` heads them.
    pub fn to_text(&self, path: &Path) -> String {
        let mut out = String::new();
        let _ = writeln!(
            out,
            "{}: QSplat version 11, {}-endian, {} fragments ({} tree, {} comment)",
            path.display(),
            self.byte_order,
            self.fragments,
            self.tree_fragments,
            self.comment_fragments
        );
        for c in &self.comments {
            let _ = writeln!(out, "  comment: {c}");
        }
        let _ = writeln!(
            out,
            "  nodes: {} leaves, {} interior (roots included), depth {}; colour {}",
            self.leaves,
            self.interior_nodes,
            self.depth,
            if self.color { "RGB565" } else { "none" }
        );
        let _ = writeln!(
            out,
            "  file: {} bytes, {:.2} bytes per node, {:.3} bytes per leaf; pointers {} ({} bytes, {:.1} % of the file); headers {} bytes",
            self.file_bytes,
            self.bytes_per_node,
            self.bytes_per_leaf,
            self.pointers,
            self.pointer_bytes,
            100.0 * self.pointer_share,
            self.header_bytes
        );
        out
    }
}
