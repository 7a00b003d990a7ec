//! A QSplat tree too large to hold in memory, baked piece by piece into the same bytes as
//! [`bake_qs`](super::write::bake_qs) (`bake` feature; the desktop program's out-of-core bake).
//!
//! The tree is built top-down by splits that need only the points' positions and ids, so the
//! top of it — the *skeleton* — is split here over ids alone ([`QsPlan::new`]), exactly as the
//! in-memory builder splits them, until each part has at most a given number of points: those
//! parts are the *pieces*, each a subtree the builder makes alone. Then:
//!
//! 1. [`QsPlan::measure`] builds each piece (in any order, on any thread) and keeps only its
//!    root (exact centre, radius, normal, cone, colour) and its bytes per tree level;
//! 2. [`QsPlan::arrange`] makes the skeleton's nodes from the pieces' roots, quantizes it
//!    top-down (which gives each piece's root its decoded sphere), and places every group of the
//!    breadth-first file: per tree level, the skeleton's groups and the pieces' in the order a
//!    depth-first walk of the skeleton meets them;
//! 3. [`QsPlan::write_piece`] builds each piece again (the build is deterministic), quantizes it
//!    from its root and writes its groups where step 2 placed them.
//!
//! Memory is the positions and ids of every point (the caller's), the skeleton (a node per
//! piece or so), and one piece per thread at a time.

use std::io;
use std::vec::Vec;

pub use super::build::{accumulate, triangle_contribution, Point};
use super::build::{
    decode_root, normal_errors, parts, quantize, set_colors, table_index, Builder, Codes, Errors,
};
use super::write::{
    file_head, record, write_group, BakedNode, QsBakeError, QsBakeOptions, QsStats,
};
use super::{HEADER_BYTES, MAX_DEPTH};

/// The points of a bake, by id: ids ascend in the order of the mesh's vertices (the in-memory
/// bake's order, which breaks its ties).
pub trait PointSource: Sync {
    /// The position of point `id`.
    fn position(&self, id: u32) -> [f64; 3];
    /// Point `id`.
    fn point(&self, id: u32) -> Point;
}

/// A child of a skeleton node.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Child {
    Node(u32),
    Piece(u32),
}

/// A skeleton node: its tree depth and children.
#[derive(Clone, Debug)]
struct SkelNode {
    depth: u32,
    children: Vec<Child>,
}

/// A piece: its ids (a range of the plan's) and its root's tree depth.
#[derive(Clone, Copy, Debug)]
struct PieceSpec {
    start: usize,
    end: usize,
    depth: u32,
}

/// What step 1 keeps of a piece.
#[derive(Clone, Debug)]
pub struct PieceRoot {
    /// The root node (its children left out).
    node: BakedNode,
    rgb: [f64; 3],
    /// Children of the root, and whether any of them has children.
    kids: usize,
    grand: bool,
    /// Deepest leaf (tree depth).
    depth: u32,
    /// Bytes of the piece's groups at each tree depth from its root's.
    sizes: Vec<u64>,
    interior: u64,
    pointers: u64,
}

/// A planned bake: every usable point's id in build order, the skeleton and the pieces.
pub struct QsPlan {
    ids: Vec<u32>,
    skel: Vec<SkelNode>,
    pieces: Vec<PieceSpec>,
    color: bool,
    codes: Codes,
    map: Vec<u16>,
}

/// Where step 2 placed everything, and the skeleton's bytes.
pub struct Arrangement {
    /// The bytes of the file before the tree's first group, and the skeleton's groups: each
    /// `(offset in the file, bytes)`.
    pub head: Vec<(u64, Vec<u8>)>,
    /// The file's length.
    pub file_len: u64,
    /// The file's statistics but for the quantization errors, which the pieces add.
    pub stats: QsStats,
    errors: Errors,
    /// Per piece: its root's decoded centre, radius and sphere index, and the file offset of its
    /// groups at each tree depth from its root's.
    roots: Vec<([f64; 3], f64, u16)>,
    bases: Vec<Vec<u64>>,
    /// The whole tree is one piece (no skeleton): its root is the file's root.
    single: bool,
}

impl QsPlan {
    /// Plans the bake of the points `ids` (ascending, at least 2) of `src` in pieces of at most
    /// `max_points` (at least 4) points, splitting the skeleton as the in-memory builder splits.
    ///
    /// # Errors
    /// [`QsBakeError::TooFewPoints`] for fewer than 2 points.
    pub fn new(
        src: &impl PointSource,
        mut ids: Vec<u32>,
        max_points: usize,
        color: bool,
    ) -> Result<Self, QsBakeError> {
        if ids.len() < 2 {
            return Err(QsBakeError::TooFewPoints(ids.len()));
        }
        let max_points = max_points.max(4);
        let mut plan = Self {
            ids: Vec::new(),
            skel: Vec::new(),
            pieces: Vec::new(),
            color,
            codes: Codes::new(),
            map: table_index(),
        };
        if ids.len() <= max_points {
            plan.pieces.push(PieceSpec {
                start: 0,
                end: ids.len(),
                depth: 0,
            });
        } else {
            plan.split(src, &mut ids, 0, 0, max_points);
        }
        plan.ids = ids;
        Ok(plan)
    }

    /// Splits a skeleton node over `ids` (more than `max_points`, which is at least 4: so not a
    /// group of leaves) starting at `start` of the plan's ids; returns its index.
    fn split(
        &mut self,
        src: &impl PointSource,
        ids: &mut [u32],
        start: usize,
        depth: u32,
        max_points: usize,
    ) -> u32 {
        let mut children = Vec::with_capacity(4);
        let mut at = start;
        for part in parts(ids, depth, |i| src.position(i)) {
            let n = part.len();
            children.push(if n > max_points {
                Child::Node(self.split(src, part, at, depth + 1, max_points))
            } else {
                self.pieces.push(PieceSpec {
                    start: at,
                    end: at + n,
                    depth: depth + 1,
                });
                Child::Piece(self.pieces.len() as u32 - 1)
            });
            at += n;
        }
        self.skel.push(SkelNode { depth, children });
        self.skel.len() as u32 - 1
    }

    /// Number of pieces.
    pub fn pieces(&self) -> usize {
        self.pieces.len()
    }

    /// Points of piece `k`.
    pub fn piece_points(&self, k: usize) -> usize {
        self.pieces[k].end - self.pieces[k].start
    }

    /// Every point's id in the order the in-memory build leaves them: pieces are ranges of it.
    pub fn ids(&self) -> &[u32] {
        &self.ids
    }

    /// Record bytes of a node.
    fn ns(&self) -> u64 {
        if self.color {
            6
        } else {
            4
        }
    }

    /// Builds piece `k`: its nodes (colours set), root, and deepest leaf.
    fn build(&self, src: &impl PointSource, k: usize) -> (Vec<BakedNode>, Vec<[f64; 3]>, u32, u32) {
        let spec = self.pieces[k];
        let slice = &self.ids[spec.start..spec.end];
        // The piece's points in id order, so that local ids break ties as global ones do.
        let mut sorted = slice.to_vec();
        sorted.sort_unstable();
        let pts: Vec<Point> = sorted.iter().map(|&i| src.point(i)).collect();
        let mut local: Vec<u32> = slice
            .iter()
            .map(|i| sorted.binary_search(i).unwrap_or_default() as u32)
            .collect();
        drop(sorted);
        let mut b = Builder {
            pts: &pts,
            codes: &self.codes,
            nodes: Vec::with_capacity(pts.len() * 3 / 2),
            rgb: Vec::with_capacity(pts.len() * 3 / 2),
            depth: 0,
        };
        let root = b.child(&mut local, spec.depth);
        set_colors(&mut b.nodes, &b.rgb, self.color);
        (b.nodes, b.rgb, root, b.depth)
    }

    /// Step 1 for piece `k`: builds it and keeps its root and sizes.
    pub fn measure(&self, src: &impl PointSource, k: usize) -> PieceRoot {
        let (nodes, rgb, root, depth) = self.build(src, k);
        let single = self.skel.is_empty();
        let levels = by_level(&nodes, root);
        let ns = self.ns();
        let sizes = levels
            .iter()
            .map(|level| {
                level
                    .iter()
                    .map(|&p| group_bytes(&nodes, p, ns, single && p == root))
                    .sum()
            })
            .collect();
        let interior: Vec<u32> = levels.into_iter().flatten().collect();
        let pointers = interior
            .iter()
            .filter(|&&p| has_pointer(&nodes, p, single && p == root))
            .count() as u64;
        let r = &nodes[root as usize];
        PieceRoot {
            kids: r.children.len(),
            grand: r
                .children
                .iter()
                .any(|&c| !nodes[c as usize].children.is_empty()),
            node: BakedNode {
                children: Vec::new(),
                ..r.clone()
            },
            rgb: rgb[root as usize],
            depth,
            sizes,
            interior: interior.len() as u64,
            pointers,
        }
    }

    /// Step 2: the skeleton from the pieces' roots (in piece order), quantized, and every group
    /// placed; `bounds` is the mesh's box for the comment fragment.
    ///
    /// # Errors
    /// [`QsBakeError::TooDeep`] or [`QsBakeError::TooLarge`], before anything is written.
    ///
    /// # Panics
    /// When `roots` is not one per piece.
    pub fn arrange(
        &self,
        roots: &[PieceRoot],
        opts: &QsBakeOptions,
        bounds: [[f32; 3]; 2],
    ) -> Result<Arrangement, QsBakeError> {
        assert_eq!(roots.len(), self.pieces.len());
        let depth = roots.iter().map(|r| r.depth).max().unwrap_or(0);
        if depth as usize > MAX_DEPTH {
            return Err(QsBakeError::TooDeep(depth));
        }
        let ns = self.ns();
        let single = self.skel.is_empty();
        // The skeleton's nodes: the pieces' roots first (node k is piece k's), then each
        // skeleton node from its children, in the order split made them (children first).
        let mut b = Builder {
            pts: &[],
            codes: &self.codes,
            nodes: roots.iter().map(|r| r.node.clone()).collect(),
            rgb: roots.iter().map(|r| r.rgb).collect(),
            depth,
        };
        let node_of = |c: Child, skel_base: u32| match c {
            Child::Piece(k) => k,
            Child::Node(s) => skel_base + s,
        };
        let base = roots.len() as u32;
        for s in &self.skel {
            let children = s.children.iter().map(|&c| node_of(c, base)).collect();
            b.interior(children);
        }
        let mut nodes = b.nodes;
        set_colors(&mut nodes, &b.rgb, self.color);
        let root = nodes.len() as u32 - 1;
        decode_root(&mut nodes[root as usize]);
        let mut errors = if single {
            Errors::default()
        } else {
            quantize(&mut nodes, root, &self.map)
        };
        let skel_nodes = &nodes[base as usize..];
        if !single {
            normal_errors(skel_nodes, Some(root - base), &self.codes, &mut errors);
        }

        // Bytes per tree depth: the skeleton's groups and the pieces'.
        let interior = |c: Child| match c {
            Child::Node(_) => true,
            Child::Piece(k) => roots[k as usize].kids > 0,
        };
        let skel_group = |s: &SkelNode, is_root: bool| -> u64 {
            let pointer = is_root || s.children.iter().any(|&c| interior(c));
            u64::from(pointer) * 4 + ns * s.children.len() as u64
        };
        let mut totals = std::vec![0u64; depth as usize + 1];
        for (i, s) in self.skel.iter().enumerate() {
            totals[s.depth as usize] += skel_group(s, i as u32 + base == root);
        }
        for (spec, r) in self.pieces.iter().zip(roots) {
            for (d, n) in r.sizes.iter().enumerate() {
                totals[spec.depth as usize + d] += n;
            }
        }
        let mut cursor = std::vec![HEADER_BYTES as u64; totals.len() + 1];
        for d in 0..totals.len() {
            cursor[d + 1] = cursor[d] + totals[d];
        }
        let tree_len = cursor[totals.len()].div_ceil(4) * 4;
        if tree_len > i32::MAX as u64 {
            return Err(QsBakeError::TooLarge(tree_len));
        }
        // A depth-first walk of the skeleton in child order meets each tree depth's groups in
        // breadth-first order.
        let mut group_at = std::vec![0u64; self.skel.len()];
        let mut bases = std::vec![Vec::new(); self.pieces.len()];
        let mut walk: Vec<Child> = std::vec![if single {
            Child::Piece(0)
        } else {
            Child::Node(root - base)
        }];
        while let Some(c) = walk.pop() {
            match c {
                Child::Node(s) => {
                    let node = &self.skel[s as usize];
                    group_at[s as usize] = cursor[node.depth as usize];
                    cursor[node.depth as usize] += skel_group(node, s + base == root);
                    walk.extend(node.children.iter().rev());
                }
                Child::Piece(k) => {
                    let spec = self.pieces[k as usize];
                    for (d, n) in roots[k as usize].sizes.iter().enumerate() {
                        let at = &mut cursor[spec.depth as usize + d];
                        bases[k as usize].push(*at);
                        *at += n;
                    }
                }
            }
        }

        let r = &nodes[root as usize];
        let root_children = if single {
            roots[0].kids
        } else {
            self.skel[(root - base) as usize].children.len()
        };
        let head_bytes = file_head(
            opts,
            bounds,
            tree_len,
            self.ids.len() as u32,
            self.color,
            r,
            root_children as u32,
        );
        let start = head_bytes.len() as u64 - HEADER_BYTES as u64;
        let mut head = std::vec![(0u64, head_bytes)];
        // The skeleton's groups: pointer and records.
        let group_of = |c: Child| match c {
            Child::Node(s) => group_at[s as usize],
            Child::Piece(k) => bases[k as usize][0],
        };
        let mut pointers = 0;
        for (i, s) in self.skel.iter().enumerate() {
            let here = group_at[i];
            let mut bytes = Vec::with_capacity(skel_group(s, false) as usize + 4);
            if i as u32 + base == root || s.children.iter().any(|&c| interior(c)) {
                pointers += 1;
                let target = s
                    .children
                    .iter()
                    .find(|&&c| interior(c))
                    .map_or(here + 4 + ns * s.children.len() as u64, |&c| group_of(c));
                bytes.extend_from_slice(&((target - here) as i32).to_be_bytes());
            }
            for &c in &s.children {
                let n = &nodes[node_of(c, base) as usize];
                let (kids, grand) = match c {
                    Child::Node(t) => (
                        self.skel[t as usize].children.len(),
                        self.skel[t as usize].children.iter().any(|&g| interior(g)),
                    ),
                    Child::Piece(k) => (roots[k as usize].kids, roots[k as usize].grand),
                };
                bytes.extend_from_slice(&record(n, kids, grand, self.color));
            }
            head.push((start + here, bytes));
        }
        let file_len = start + tree_len;
        // Padding to a multiple of 4 after the last group.
        let end = start + cursor[totals.len()];
        if file_len > end {
            head.push((end, std::vec![0; (file_len - end) as usize]));
        }

        let leaves = self.ids.len() as u64;
        let all_interior = self.skel.len() as u64 + roots.iter().map(|r| r.interior).sum::<u64>();
        let stats = QsStats {
            leaves,
            interior: all_interior,
            pointers: pointers + roots.iter().map(|r| r.pointers).sum::<u64>(),
            node_bytes: (leaves + all_interior - 1) * ns,
            file_bytes: file_len,
            depth,
            ..QsStats::default()
        };
        Ok(Arrangement {
            head,
            file_len,
            stats,
            errors,
            roots: (0..self.pieces.len())
                .map(|k| {
                    let n = &nodes[k];
                    (n.decoded_center, n.decoded_radius, n.sphere)
                })
                .collect(),
            bases: bases
                .into_iter()
                .map(|b| b.into_iter().map(|at| start + at).collect())
                .collect(),
            single,
        })
    }

    /// Step 3 for piece `k`: builds it again, quantizes it from the root `arr` decoded, and
    /// writes its groups with `write_at(offset in the file, bytes)`; returns its quantization
    /// errors for [`Arrangement::finish`].
    ///
    /// # Errors
    /// What `write_at` returns.
    pub fn write_piece(
        &self,
        src: &impl PointSource,
        k: usize,
        arr: &Arrangement,
        write_at: &mut dyn FnMut(u64, &[u8]) -> io::Result<()>,
    ) -> io::Result<PieceErrors> {
        let (mut nodes, _, root, _) = self.build(src, k);
        let mut e = Errors::default();
        {
            let r = &mut nodes[root as usize];
            if arr.single {
                decode_root(r);
            } else {
                (r.decoded_center, r.decoded_radius, r.sphere) = arr.roots[k];
            }
        }
        e.add(&quantize(&mut nodes, root, &self.map));
        normal_errors(&nodes, arr.single.then_some(root), &self.codes, &mut e);
        let ns = self.ns();
        let levels = by_level(&nodes, root);
        // Offsets within each level's bytes, then the groups.
        let mut group_at = std::vec![0u64; nodes.len()];
        for (d, level) in levels.iter().enumerate() {
            let mut at = arr.bases[k][d];
            for &p in level {
                group_at[p as usize] = at;
                at += group_bytes(&nodes, p, ns, arr.single && p == root);
            }
        }
        for (d, level) in levels.iter().enumerate() {
            let mut bytes = Vec::new();
            for &p in level {
                let pointer = has_pointer(&nodes, p, arr.single && p == root);
                write_group(
                    &nodes,
                    p,
                    pointer,
                    |c| group_at[c as usize],
                    self.color,
                    &mut bytes,
                );
            }
            if !bytes.is_empty() {
                write_at(arr.bases[k][d], &bytes)?;
            }
        }
        Ok(PieceErrors(e))
    }
}

/// A piece's quantization errors, summed into the file's statistics by [`Arrangement::finish`].
#[derive(Clone, Copy, Debug, Default)]
pub struct PieceErrors(Errors);

impl Arrangement {
    /// The file's statistics with every piece's errors added.
    pub fn finish(&self, pieces: &[PieceErrors]) -> QsStats {
        let mut e = self.errors;
        for p in pieces {
            e.add(&p.0);
        }
        QsStats {
            position_error: e.position / e.quantized.max(1) as f64,
            radius_error: e.radius / e.quantized.max(1) as f64,
            normal_error: e.normal / e.normals.max(1) as f64,
            normal_error_max: e.normal_max,
            ..self.stats
        }
    }
}

/// Whether node `p`'s group has a pointer: a child has children, or it is the file's root.
fn has_pointer(nodes: &[BakedNode], p: u32, is_root: bool) -> bool {
    is_root
        || nodes[p as usize]
            .children
            .iter()
            .any(|&c| !nodes[c as usize].children.is_empty())
}

/// Bytes of node `p`'s group: its pointer and its children's records.
fn group_bytes(nodes: &[BakedNode], p: u32, ns: u64, is_root: bool) -> u64 {
    u64::from(has_pointer(nodes, p, is_root)) * 4 + ns * nodes[p as usize].children.len() as u64
}

/// The interior nodes of the subtree below `root` by level from its own, each level in
/// breadth-first order.
fn by_level(nodes: &[BakedNode], root: u32) -> Vec<Vec<u32>> {
    let mut levels = Vec::new();
    let mut level = if nodes[root as usize].children.is_empty() {
        Vec::new()
    } else {
        std::vec![root]
    };
    while !level.is_empty() {
        let next = level
            .iter()
            .flat_map(|&p| nodes[p as usize].children.iter().copied())
            .filter(|&c| !nodes[c as usize].children.is_empty())
            .collect();
        levels.push(level);
        level = next;
    }
    levels
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bake::TriMesh;
    use crate::qs::build::mesh_points;
    use crate::qs::write::{bake_qs, tests::uv_sphere};

    impl PointSource for Vec<Point> {
        fn position(&self, id: u32) -> [f64; 3] {
            self[id as usize].p
        }
        fn point(&self, id: u32) -> Point {
            self[id as usize]
        }
    }

    /// Bakes in pieces of at most `max` points into a buffer, as the desktop bake does in a file.
    fn in_pieces(mesh: &TriMesh, opts: &QsBakeOptions, max: usize) -> (Vec<u8>, QsStats, usize) {
        let pts = mesh_points(mesh);
        let color = opts.colors && mesh.colors.is_some();
        let plan = QsPlan::new(&pts, (0..pts.len() as u32).collect(), max, color).unwrap();
        let roots: Vec<PieceRoot> = (0..plan.pieces()).map(|k| plan.measure(&pts, k)).collect();
        let arr = plan.arrange(&roots, opts, mesh.bounds_f32()).unwrap();
        let mut file = std::vec![0xEEu8; arr.file_len as usize];
        let mut put = |at: u64, b: &[u8]| {
            file[at as usize..at as usize + b.len()].copy_from_slice(b);
            Ok(())
        };
        for (at, b) in &arr.head {
            put(*at, b).unwrap();
        }
        // In reverse, to show that the order of the pieces' writes does not matter.
        let errors: Vec<PieceErrors> = (0..plan.pieces())
            .rev()
            .map(|k| plan.write_piece(&pts, k, &arr, &mut put).unwrap())
            .collect();
        (file, arr.finish(&errors), plan.pieces())
    }

    #[test]
    fn pieces_make_the_in_memory_bytes() {
        for (mesh, max) in [
            (uv_sphere(24, 48), 40),
            (uv_sphere(24, 48), 5),
            (uv_sphere(40, 80), 700),
            (uv_sphere(3, 4), 4),
            (uv_sphere(24, 48), usize::MAX),
        ] {
            for colors in [false, true] {
                let opts = QsBakeOptions {
                    colors,
                    comment: colors,
                };
                let whole = bake_qs(&mesh, &opts).unwrap();
                let (bytes, stats, pieces) = in_pieces(&mesh, &opts, max);
                assert!(max == usize::MAX || pieces > 1, "{max}: {pieces} pieces");
                assert!(bytes == whole.bytes, "max {max}, colours {colors}");
                let w = whole.stats;
                assert_eq!(
                    (stats.leaves, stats.interior, stats.pointers, stats.depth),
                    (w.leaves, w.interior, w.pointers, w.depth)
                );
                assert_eq!(
                    (stats.node_bytes, stats.file_bytes),
                    (w.node_bytes, w.file_bytes)
                );
                assert!((stats.position_error - w.position_error).abs() < 1e-9);
                assert!((stats.normal_error - w.normal_error).abs() < 1e-9);
            }
        }
    }
}
