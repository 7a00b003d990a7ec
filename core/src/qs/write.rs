//! Baking a triangle mesh into a `.qs` file (QSplat §2.2, §3; desktop only, `bake` feature).
//!
//! 1. Every referenced vertex becomes a leaf: its radius is the largest minimal bounding sphere of the
//!    triangles around it (so neighbouring splats touch, no holes), its normal the area-weighted sum
//!    of theirs. Unreferenced and zero-radius vertices are dropped.
//! 2. The tree is built top-down, splitting at the bounding-box midpoint of the longest axis two
//!    levels at a time (2–4 children); parents get the mean centre, an enclosing radius, the
//!    normalized normal sum, the mean colour, and a cone around their quantized normal.
//! 3. Spheres are quantized top-down against the *decoded* parent, each to the smallest table entry
//!    that encloses it; the tree is laid out breadth-first with one pointer per sibling group.
//!
//! Everything is deterministic: the same mesh gives the same bytes.

use std::vec::Vec;

use super::build::{
    decode_root, dot, mesh_points, normal_errors, quantize, set_colors, sub, table_index, Builder,
    Codes,
};
use super::normal::{self, cone_sin_bound};
use super::read::{QSplat, QsError};
use super::{HEADER_BYTES, MAGIC, MAX_DEPTH, OPT_COLOR, OPT_COMMENT, POINTER_BYTES};
use crate::bake::{MeshError, TriMesh};

pub use super::build::triangle_bounding_radius;

/// What to write.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct QsBakeOptions {
    /// Store RGB565 colours when the mesh has vertex colours.
    pub colors: bool,
    /// Write pocketsplat's comment fragment with the mesh's bounding box first.
    pub comment: bool,
}

impl Default for QsBakeOptions {
    fn default() -> Self {
        Self {
            colors: true,
            comment: true,
        }
    }
}

/// Why a mesh cannot be baked into a `.qs` file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum QsBakeError {
    /// The mesh is invalid.
    Mesh(MeshError),
    /// Fewer than two usable vertices (referenced, with a positive radius): a root needs 2 children.
    TooFewPoints(usize),
    /// The fragment would exceed the format's 31-bit pointers.
    TooLarge(u64),
    /// The tree came out deeper than readers accept.
    TooDeep(u32),
}

impl core::fmt::Display for QsBakeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            QsBakeError::Mesh(e) => write!(f, "{e}"),
            QsBakeError::TooFewPoints(n) => write!(
                f,
                "{n} usable vertices (referenced, positive radius); a .qs tree needs at least 2"
            ),
            QsBakeError::TooLarge(n) => {
                write!(f, "the .qs fragment would be {n} bytes; at most 2^31 - 1")
            }
            QsBakeError::TooDeep(d) => {
                write!(f, "the tree is {d} levels deep; readers accept {MAX_DEPTH}")
            }
        }
    }
}

impl std::error::Error for QsBakeError {}

impl From<MeshError> for QsBakeError {
    fn from(e: MeshError) -> Self {
        QsBakeError::Mesh(e)
    }
}

pub use super::build::BakedNode;

/// Counts and quantization errors of a bake.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct QsStats {
    /// Leaves (the points).
    pub leaves: u64,
    /// Interior nodes, the root included.
    pub interior: u64,
    /// Group pointers.
    pub pointers: u64,
    /// Bytes of node records.
    pub node_bytes: u64,
    /// File size.
    pub file_bytes: u64,
    /// Deepest level (the root's children are level 1).
    pub depth: u32,
    /// Mean absolute error of a child's centre per axis, in decoded parent radii.
    pub position_error: f64,
    /// Mean radius increase (decoded − exact), in decoded parent radii.
    pub radius_error: f64,
    /// Mean angle between a node's exact and quantized normal, radians.
    pub normal_error: f64,
    /// Largest such angle.
    pub normal_error_max: f64,
}

impl QsStats {
    /// Bytes per leaf.
    pub fn bytes_per_leaf(&self) -> f64 {
        self.file_bytes as f64 / self.leaves.max(1) as f64
    }
    /// Share of the file taken by group pointers.
    pub fn pointer_share(&self) -> f64 {
        (self.pointers * u64::from(POINTER_BYTES)) as f64 / self.file_bytes.max(1) as f64
    }
}

/// Backface culling of one view with exact cone widths and with the stored 2-bit codes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ConeCulling {
    /// Nodes discarded (culled subtrees, every node counted) with exact cones.
    pub exact: u64,
    /// Nodes discarded with the quantized cones.
    pub quantized: u64,
}

/// A baked tree and its file.
#[derive(Clone, Debug)]
pub struct BakedQs {
    /// Every node; the root is [`BakedQs::root`].
    pub nodes: Vec<BakedNode>,
    /// Index of the root.
    pub root: u32,
    /// The `.qs` bytes.
    pub bytes: Vec<u8>,
    /// Counts and errors.
    pub stats: QsStats,
    /// Whether colours were written.
    pub color: bool,
}

/// Bakes `mesh` into a `.qs` file.
///
/// # Errors
/// [`QsBakeError`] for an invalid mesh, fewer than 2 usable vertices, or a file too large.
pub fn bake_qs(mesh: &TriMesh, opts: &QsBakeOptions) -> Result<BakedQs, QsBakeError> {
    mesh.validate()?;
    let color = opts.colors && mesh.colors.is_some();
    let pts = mesh_points(mesh);
    if pts.len() < 2 {
        return Err(QsBakeError::TooFewPoints(pts.len()));
    }
    let codes = Codes::new();
    let mut b = Builder {
        pts: &pts,
        codes: &codes,
        nodes: Vec::with_capacity(pts.len() * 3 / 2),
        rgb: Vec::with_capacity(pts.len() * 3 / 2),
        depth: 0,
    };
    let mut ids: Vec<u32> = (0..pts.len() as u32).collect();
    let root = b.build(&mut ids, 0);
    if b.depth as usize > MAX_DEPTH {
        return Err(QsBakeError::TooDeep(b.depth));
    }
    let depth = b.depth;
    let mut nodes = b.nodes;
    set_colors(&mut nodes, &b.rgb, color);

    // Quantize top-down against the decoded parents.
    let map = table_index();
    decode_root(&mut nodes[root as usize]);
    let mut errors = quantize(&mut nodes, root, &map);
    normal_errors(&nodes, Some(root), &codes, &mut errors);

    let (bytes, pointers) = layout(mesh, opts, &nodes, root, color, pts.len() as u32)?;
    let leaves = pts.len() as u64;
    let interior = nodes.len() as u64 - leaves;
    let node_bytes = (nodes.len() as u64 - 1) * if color { 6 } else { 4 };
    Ok(BakedQs {
        stats: QsStats {
            leaves,
            interior,
            pointers,
            node_bytes,
            file_bytes: bytes.len() as u64,
            depth,
            position_error: errors.position / errors.quantized.max(1) as f64,
            radius_error: errors.radius / errors.quantized.max(1) as f64,
            normal_error: errors.normal / errors.normals.max(1) as f64,
            normal_error_max: errors.normal_max,
        },
        nodes,
        root,
        bytes,
        color,
    })
}

fn put_u32(out: &mut Vec<u8>, v: u32) {
    out.extend_from_slice(&v.to_be_bytes());
}

fn pad4(out: &mut Vec<u8>, start: usize) {
    while !(out.len() - start).is_multiple_of(4) {
        out.push(0);
    }
}

/// Lays the tree out breadth-first and writes the file; returns it and its pointer count.
fn layout(
    mesh: &TriMesh,
    opts: &QsBakeOptions,
    nodes: &[BakedNode],
    root: u32,
    color: bool,
    leaves: u32,
) -> Result<(Vec<u8>, u64), QsBakeError> {
    let ns: u64 = if color { 6 } else { 4 };
    // One byte a node, read in the order of the walk below (the nodes are much larger and are
    // stored in the order of the build).
    let interior: Vec<bool> = nodes.iter().map(|n| !n.children.is_empty()).collect();
    let is_interior = |i: u32| interior[i as usize];
    // Groups in breadth-first order of their parents.
    let mut parents = std::vec![root];
    let mut k = 0;
    while k < parents.len() {
        let p = parents[k];
        parents.extend(
            nodes[p as usize]
                .children
                .iter()
                .copied()
                .filter(|&c| is_interior(c)),
        );
        k += 1;
    }
    let has_pointer = |p: u32| {
        let kids = &nodes[p as usize].children;
        // The root group always has one: QSplat 1.0's writer left it out for a model of exactly 4
        // leaves, but its reader always reads one (and loses a leaf without it). The reader here
        // takes both forms.
        kids.iter().any(|&c| is_interior(c)) || p == root
    };
    // Offsets within the fragment of each group (of its pointer, when it has one).
    let mut group_at = std::vec![0u64; nodes.len()];
    let mut at = HEADER_BYTES as u64;
    for &p in &parents {
        group_at[p as usize] = at;
        at += if has_pointer(p) { 4 } else { 0 } + ns * nodes[p as usize].children.len() as u64;
    }
    let tree_len = at.div_ceil(4) * 4;
    if tree_len > i32::MAX as u64 {
        return Err(QsBakeError::TooLarge(tree_len));
    }

    let r = &nodes[root as usize];
    let mut out = file_head(
        opts,
        mesh.bounds_f32(),
        tree_len,
        leaves,
        color,
        r,
        r.children.len() as u32,
    );
    let start = out.len() - HEADER_BYTES;
    out.reserve(tree_len as usize);
    let mut pointers = 0u64;
    for &p in &parents {
        debug_assert_eq!((out.len() - start) as u64, group_at[p as usize]);
        pointers += u64::from(has_pointer(p));
        write_group(
            nodes,
            p,
            has_pointer(p),
            |c| group_at[c as usize],
            color,
            &mut out,
        );
    }
    pad4(&mut out, start);
    debug_assert_eq!((out.len() - start) as u64, tree_len);
    Ok((out, pointers))
}

/// The bytes of a file before its tree's first group: the comment fragment with the mesh's
/// bounding box `bounds` (when `opts.comment`) and the tree fragment's header (`tree_len` bytes
/// from its magic on, `leaves` points, the root's decoded sphere and `root_children`).
pub(super) fn file_head(
    opts: &QsBakeOptions,
    bounds: [[f32; 3]; 2],
    tree_len: u64,
    leaves: u32,
    color: bool,
    root: &BakedNode,
    root_children: u32,
) -> Vec<u8> {
    let mut out = Vec::with_capacity(128);
    if opts.comment {
        let [lo, hi] = bounds;
        let text = std::format!(
            "{} bounds={},{},{},{},{},{}",
            super::BOUNDS_COMMENT_PREFIX,
            lo[0],
            lo[1],
            lo[2],
            hi[0],
            hi[1],
            hi[2]
        );
        let length = (20 + text.len()).div_ceil(4) * 4;
        out.extend_from_slice(&MAGIC);
        put_u32(&mut out, length as u32);
        put_u32(&mut out, 0);
        put_u32(&mut out, OPT_COMMENT);
        out.extend_from_slice(text.as_bytes());
        pad4(&mut out, 0);
    }
    out.extend_from_slice(&MAGIC);
    put_u32(&mut out, tree_len as u32);
    put_u32(&mut out, leaves);
    put_u32(&mut out, if color { OPT_COLOR } else { 0 });
    for v in root.decoded_center {
        out.extend_from_slice(&(v as f32).to_be_bytes());
    }
    out.extend_from_slice(&(root.decoded_radius as f32).to_be_bytes());
    put_u32(&mut out, root_children);
    out
}

/// Appends node `p`'s group, which starts at `group_at(p)` (fragment offsets): its pointer when
/// `pointer` (to its first child with children, or past the group when none has), then its
/// children's records.
pub(super) fn write_group(
    nodes: &[BakedNode],
    p: u32,
    pointer: bool,
    group_at: impl Fn(u32) -> u64,
    color: bool,
    out: &mut Vec<u8>,
) {
    let ns: u64 = if color { 6 } else { 4 };
    let kids = &nodes[p as usize].children;
    let is_interior = |c: u32| !nodes[c as usize].children.is_empty();
    if pointer {
        let here = group_at(p);
        let target = kids
            .iter()
            .find(|&&c| is_interior(c))
            .map_or(here + 4 + ns * kids.len() as u64, |&c| group_at(c));
        out.extend_from_slice(&((target - here) as i32).to_be_bytes());
    }
    for &c in kids {
        let n = &nodes[c as usize];
        let grand = n.children.iter().any(|&g| is_interior(g));
        out.extend_from_slice(&record(n, n.children.len(), grand, color));
    }
}

/// A node's record as the file stores it: 4 bytes, or 6 with `color`.
pub(super) fn record(n: &BakedNode, children: usize, grandchildren: bool, color: bool) -> Vec<u8> {
    let rec = super::read::Node {
        sphere: n.sphere,
        children: children as u8,
        grandchildren,
        normal: n.normal,
        cone: n.cone,
        color: color.then_some(n.color),
    }
    .to_bytes();
    rec[..if color { 6 } else { 4 }].to_vec()
}

impl BakedQs {
    /// Backface culling seen from `eye` (model coordinates) over the whole tree (no frustum, no
    /// level of detail), with the exact cone widths and with the stored codes, using the decoded
    /// spheres and normals for both: QSplat §3.1's "over 90 percent of nodes that would be culled
    /// using exact normal cone widths".
    pub fn cone_culling(&self, eye: [f64; 3]) -> ConeCulling {
        ConeCulling {
            exact: self.culled(self.root, eye, false, true),
            quantized: self.culled(self.root, eye, false, false),
        }
    }

    fn culled(&self, i: u32, eye: [f64; 3], facing: bool, exact: bool) -> u64 {
        let n = &self.nodes[i as usize];
        let mut facing = facing;
        if i != self.root && !facing {
            let sin = if exact {
                (n.cone_exact < core::f64::consts::FRAC_PI_2).then(|| n.cone_exact.sin())
            } else {
                (n.cone < normal::CONE_NEVER).then(|| cone_sin_bound(n.cone))
            };
            if let Some(sin) = sin {
                let v = sub(eye, n.decoded_center);
                let d = dot(v, normal::decode(n.normal));
                let (r, dd) = (n.decoded_radius, dot(v, v));
                if d < -r && (d + r) * (d + r) > dd * sin * sin {
                    return u64::from(n.subtree);
                }
                if d > r && (d - r) * (d - r) > dd * sin * sin {
                    facing = true;
                }
            }
        }
        n.children
            .iter()
            .map(|&c| self.culled(c, eye, facing, exact))
            .sum()
    }
}

/// A `.qs` file as QSplat 1.0 lays it out, from one pocketsplat wrote: its first tree alone (no
/// comment fragment), and, `little`, the header fields and group pointers little-endian, as a
/// build of the original that did not swap wrote them (node records stay big-endian). For
/// checking that such files read, draw and stream as they are.
///
/// # Errors
/// When `bytes` is not a valid `.qs` file.
pub fn qsplat1_layout(bytes: &[u8], little: bool) -> Result<Vec<u8>, QsError> {
    let file = QSplat::open(bytes)?;
    let tree = file.trees().next().ok_or(QsError::NoTree)?;
    let mut out = tree.bytes().to_vec();
    if little {
        let mut swap = |at: usize| out[at..at + 4].reverse();
        for k in 0..8 {
            swap(8 + 4 * k);
        }
        let mut stack = std::vec![tree.root_group()];
        while let Some(g) = stack.pop() {
            if let Some(p) = g.pointer {
                swap(p as usize);
            }
            stack.extend(tree.children(g).filter_map(|(_, _, c)| c));
        }
    }
    Ok(out)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::qs::build::len;
    use crate::qs::read::{Group, QSplat, Tree};

    /// A UV sphere of radius 1 with `rings × segments` quads, coloured by position.
    pub(crate) fn uv_sphere(rings: u32, segments: u32) -> TriMesh {
        let mut m = TriMesh::default();
        let mut colors = Vec::new();
        for i in 0..=rings {
            let th = core::f64::consts::PI * f64::from(i) / f64::from(rings);
            for j in 0..segments {
                let ph = 2.0 * core::f64::consts::PI * f64::from(j) / f64::from(segments);
                let p = [th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin()];
                m.positions.push(p);
                colors.push(p.map(|c| ((c + 1.0) * 127.0) as u8));
            }
        }
        let at = |i: u32, j: u32| i * segments + j % segments;
        for i in 0..rings {
            for j in 0..segments {
                m.triangles.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
                m.triangles.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
            }
        }
        m.colors = Some(colors);
        m
    }

    #[test]
    fn triangle_radius_is_the_smallest_enclosing_sphere() {
        // Equilateral, side 1: circumradius 1/√3.
        let eq = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.5, 3f64.sqrt() / 2.0, 0.0],
        ];
        assert!((triangle_bounding_radius(eq) - 1.0 / 3f64.sqrt()).abs() < 1e-12);
        // Obtuse: half the longest edge.
        let ob = [[0.0, 0.0, 0.0], [4.0, 0.0, 0.0], [2.0, 0.5, 0.0]];
        assert!((triangle_bounding_radius(ob) - 2.0).abs() < 1e-12);
        // Degenerate.
        let dg = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [1.0, 0.0, 0.0]];
        assert!((triangle_bounding_radius(dg) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn quantized_spheres_enclose_the_exact_ones_and_errors_are_small() {
        let q = bake_qs(&uv_sphere(40, 80), &QsBakeOptions::default()).unwrap();
        for n in &q.nodes {
            let d = len(sub(n.center, n.decoded_center)) + n.radius;
            assert!(d <= n.decoded_radius * (1.0 + 1e-9), "{n:?}");
        }
        let s = q.stats;
        assert!(s.position_error < 0.08 && s.radius_error < 0.3, "{s:?}");
        assert!(s.normal_error < 0.02, "{s:?}");
        // Children of every interior node: 2–4.
        assert!(q
            .nodes
            .iter()
            .all(|n| n.children.is_empty() || (2..=4).contains(&n.children.len())));
    }

    /// The reader's tree, breadth-first: (sphere, children, normal, cone, colour) per node.
    fn read_back(tree: &Tree<'_>) -> Vec<(u16, u8, u16, u8, Option<u16>)> {
        let mut out = Vec::new();
        let mut queue: Vec<Group> = std::vec![tree.root_group()];
        let mut k = 0;
        while k < queue.len() {
            for (_, n, g) in tree.children(queue[k]) {
                out.push((n.sphere, n.children, n.normal, n.cone, n.color));
                queue.extend(g);
            }
            k += 1;
        }
        out
    }

    #[test]
    fn the_file_reads_back_to_the_same_tree_and_is_deterministic() {
        let mesh = uv_sphere(24, 48);
        for colors in [false, true] {
            let opts = QsBakeOptions {
                colors,
                comment: true,
            };
            let q = bake_qs(&mesh, &opts).unwrap();
            assert_eq!(
                q.bytes,
                bake_qs(&mesh, &opts).unwrap().bytes,
                "deterministic"
            );
            let file = QSplat::open(&q.bytes).unwrap();
            assert_eq!(file.counts().leaves, q.stats.leaves);
            assert_eq!(file.counts().interior + 1, q.stats.interior);
            assert_eq!(file.counts().pointers, q.stats.pointers);
            assert_eq!(file.bounds(), mesh.bounds_f32());
            let tree = file.trees().next().unwrap();
            assert_eq!(tree.has_color(), colors);
            let root = &q.nodes[q.root as usize];
            assert_eq!(tree.center(), root.decoded_center.map(|v| v as f32));
            // The writer's tree in the same breadth-first order.
            let mut want = Vec::new();
            let mut queue = std::vec![q.root];
            let mut k = 0;
            while k < queue.len() {
                for &c in &q.nodes[queue[k] as usize].children {
                    let n = &q.nodes[c as usize];
                    want.push((
                        n.sphere,
                        n.children.len() as u8,
                        n.normal,
                        n.cone,
                        colors.then_some(n.color),
                    ));
                    if !n.children.is_empty() {
                        queue.push(c);
                    }
                }
                k += 1;
            }
            assert_eq!(read_back(&tree), want);
        }
    }

    #[test]
    fn a_unit_square_has_its_root_pointer() {
        // Two triangles, four leaves: the 4-leaf root that QSplat 1.0's writer left without a
        // pointer. 40 header bytes + 4 for the pointer + 4 nodes of 4 bytes.
        let m = TriMesh {
            positions: std::vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [1.0, 1.0, 0.0],
                [0.0, 1.0, 0.0]
            ],
            triangles: std::vec![[0, 1, 2], [0, 2, 3]],
            ..TriMesh::default()
        };
        let q = bake_qs(&m, &QsBakeOptions::default()).unwrap();
        let file = QSplat::open(&q.bytes).unwrap();
        assert_eq!(file.counts().leaves, 4);
        let tree = file.trees().next().unwrap();
        assert_eq!(tree.bytes().len(), 60);
        assert!(tree.root_group().pointer.is_some());
        assert_eq!(tree.children(tree.root_group()).count(), 4);
    }

    #[test]
    fn tiny_models_always_have_a_root_pointer() {
        // 2, 3, 4, 5 usable vertices: a fan of triangles.
        for n in 2..=5u32 {
            let mut m = TriMesh::default();
            m.positions.push([0.0, 0.0, 0.0]);
            for i in 0..n.max(3) - 1 {
                let a = f64::from(i);
                m.positions.push([a.cos(), a.sin(), 0.1 * a]);
            }
            for i in 1..m.positions.len() as u32 - 1 {
                m.triangles.push([0, i, i + 1]);
            }
            let q = bake_qs(&m, &QsBakeOptions::default()).unwrap();
            let file = QSplat::open(&q.bytes).unwrap();
            let leaves = file.counts().leaves;
            let tree = file.trees().next().unwrap();
            assert_eq!(leaves, q.stats.leaves);
            assert!(tree.root_group().pointer.is_some(), "{leaves} leaves");
        }
    }

    #[test]
    fn exact_cones_cull_at_least_what_codes_do() {
        let q = bake_qs(&uv_sphere(30, 60), &QsBakeOptions::default()).unwrap();
        let c = q.cone_culling([0.0, 0.0, 5.0]);
        assert!(c.quantized <= c.exact && c.exact > 0, "{c:?}");
        assert!(c.quantized as f64 >= 0.5 * c.exact as f64, "{c:?}");
    }

    #[test]
    fn bad_meshes_are_specific_errors() {
        let mut m = TriMesh::default();
        assert!(matches!(
            bake_qs(&m, &QsBakeOptions::default()),
            Err(QsBakeError::Mesh(MeshError::Empty { .. }))
        ));
        m.positions = std::vec![[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]];
        m.triangles = std::vec![[0, 1, 2]];
        assert!(matches!(
            bake_qs(&m, &QsBakeOptions::default()),
            Err(QsBakeError::Mesh(MeshError::NoArea))
        ));
    }
}
