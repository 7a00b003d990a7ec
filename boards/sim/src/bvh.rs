//! A bounding-volume hierarchy over a mesh's triangles, in f64, for exact shadow rays in the
//! reference renderer ([`crate::reference`]).
//!
//! - **Build:** binned surface-area heuristic (16 bins on each axis, centroids), leaves of at most
//!   [`MAX_LEAF`] triangles; the two halves of a large node are built in parallel (rayon), and the
//!   result does not depend on the number of threads. Zero-area triangles and triangles with a
//!   non-finite vertex are left out: they cannot block a ray (the reference renderer draws neither).
//! - **Query:** [`Bvh::occluded`], an any-hit test: Möller–Trumbore against each triangle, both
//!   sides, and slab tests against the boxes made conservative by a few ulps (Ize 2013, "Robust BVH
//!   ray traversal"), so a box never hides a hit that the triangle test would report.
//!
//! # Example
//!
//! ```
//! use pocketsplat_core::bake::TriMesh;
//! use pocketsplat_sim::bvh::Bvh;
//!
//! let mesh = TriMesh {
//!     positions: vec![[-1.0, 0.0, -1.0], [1.0, 0.0, -1.0], [0.0, 0.0, 1.0]],
//!     triangles: vec![[0, 1, 2]],
//!     ..TriMesh::default()
//! };
//! let bvh = Bvh::new(&mesh);
//! // Straight up through the triangle at y = 0 …
//! assert!(bvh.occluded([0.0, -1.0, 0.0], [0.0, 1.0, 0.0], 0.0, f64::INFINITY));
//! // … but not when the segment stops short of it.
//! assert!(!bvh.occluded([0.0, -1.0, 0.0], [0.0, 1.0, 0.0], 0.0, 0.5));
//! ```

use pocketsplat_core::bake::TriMesh;
use pocketsplat_core::camera::{self, Vec3};

/// Most triangles in a leaf. A node with more is always split.
pub const MAX_LEAF: usize = 8;

/// SAH bins per axis.
const BINS: usize = 16;

/// Nodes with more triangles than this build their two halves in parallel.
const PARALLEL_MIN: usize = 4096;

/// Beyond this depth nodes are split at the median (halving), which bounds the tree's depth by
/// `SAH_MAX_DEPTH + 32` whatever the input, and so the traversal stack.
const SAH_MAX_DEPTH: usize = 64;

/// Traversal stack entries: enough for the deepest possible tree (see [`SAH_MAX_DEPTH`]).
const STACK: usize = SAH_MAX_DEPTH + 40;

/// SAH cost of visiting a node, relative to one ray–triangle test.
const TRAVERSAL_COST: f64 = 1.0;

/// γ(3) = 3ε / (1 − 3ε), ε = 2⁻⁵³ (Pharr et al., PBRT 3.9): the relative error bound of a slab
/// distance, by which the far distance is enlarged so the box test is conservative.
const GAMMA3: f64 = 3.0 * (f64::EPSILON / 2.0) / (1.0 - 3.0 * (f64::EPSILON / 2.0));

/// A node: its box, and either a leaf's triangle range or an interior node's children. The left
/// child of an interior node is the next node (depth-first order).
#[derive(Clone, Copy, Debug)]
struct Node {
    lo: Vec3,
    hi: Vec3,
    /// Leaf: index of its first triangle. Interior: offset from this node to its right child.
    index: u32,
    /// Leaf: number of triangles (≥ 1). Interior: 0.
    count: u16,
    /// Interior: the split axis (the side a ray enters first is visited first).
    axis: u8,
}

/// A triangle ready for Möller–Trumbore: a vertex and the two edges from it.
#[derive(Clone, Copy, Debug)]
struct Tri {
    v0: Vec3,
    e1: Vec3,
    e2: Vec3,
}

/// A triangle's box and index during the build.
#[derive(Clone, Copy, Debug)]
struct PrimRef {
    lo: Vec3,
    hi: Vec3,
    index: u32,
}

impl PrimRef {
    /// Twice the centroid of the box (the halving is left out: it changes no comparison).
    fn centroid2(&self, axis: usize) -> f64 {
        self.lo[axis] + self.hi[axis]
    }
}

/// A box, growable.
#[derive(Clone, Copy, Debug)]
struct Aabb {
    lo: Vec3,
    hi: Vec3,
}

impl Aabb {
    const EMPTY: Aabb = Aabb {
        lo: [f64::INFINITY; 3],
        hi: [f64::NEG_INFINITY; 3],
    };

    fn grow(&mut self, lo: Vec3, hi: Vec3) {
        for a in 0..3 {
            self.lo[a] = self.lo[a].min(lo[a]);
            self.hi[a] = self.hi[a].max(hi[a]);
        }
    }

    /// Half the surface area (the SAH only compares ratios); 0 when empty.
    fn half_area(&self) -> f64 {
        if self.lo[0] > self.hi[0] {
            return 0.0;
        }
        let d = camera::sub(self.hi, self.lo);
        d[0] * d[1] + d[1] * d[2] + d[2] * d[0]
    }
}

/// A bounding-volume hierarchy over the triangles of a [`TriMesh`], for any-hit ray queries.
///
/// The mesh is copied in (each triangle as a vertex and two edges, 72 bytes), so the hierarchy
/// does not borrow it.
#[derive(Clone, Debug)]
pub struct Bvh {
    nodes: Vec<Node>,
    tris: Vec<Tri>,
}

impl Bvh {
    /// Builds the hierarchy over `mesh`'s triangles (in parallel). Zero-area triangles and
    /// triangles with a non-finite vertex are left out.
    ///
    /// # Panics
    /// When a triangle refers to a vertex that does not exist ([`TriMesh::validate`] rejects such
    /// meshes).
    pub fn new(mesh: &TriMesh) -> Self {
        use rayon::prelude::*;
        let mut refs: Vec<PrimRef> = mesh
            .triangles
            .par_iter()
            .enumerate()
            .filter_map(|(t, idx)| {
                let [a, b, c] = idx.map(|i| mesh.positions[i as usize]);
                let n = camera::cross(camera::sub(b, a), camera::sub(c, a));
                let finite = [a, b, c].iter().flatten().all(|v| v.is_finite());
                (finite && camera::dot(n, n) > 0.0).then(|| {
                    let mut bb = Aabb::EMPTY;
                    for p in [a, b, c] {
                        bb.grow(p, p);
                    }
                    PrimRef {
                        lo: bb.lo,
                        hi: bb.hi,
                        index: t as u32,
                    }
                })
            })
            .collect();
        let mut nodes = Vec::new();
        if !refs.is_empty() {
            build(&mut refs, 0, 0, &mut nodes);
        }
        let tris = refs
            .par_iter()
            .map(|r| {
                let [a, b, c] =
                    mesh.triangles[r.index as usize].map(|i| mesh.positions[i as usize]);
                Tri {
                    v0: a,
                    e1: camera::sub(b, a),
                    e2: camera::sub(c, a),
                }
            })
            .collect();
        Self { nodes, tris }
    }

    /// Number of triangles in the hierarchy (the mesh's, less the zero-area and non-finite ones).
    pub fn triangle_count(&self) -> usize {
        self.tris.len()
    }

    /// Number of nodes (interior and leaves).
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Whether the ray `origin + t · dir` meets a triangle for some `t_min < t < t_max` (any hit,
    /// either side of the triangle). `dir` need not be a unit vector (`t` is in units of `dir`);
    /// `t_max` may be `f64::INFINITY`. A ray in a triangle's plane does not meet it.
    pub fn occluded(&self, origin: Vec3, dir: Vec3, t_min: f64, t_max: f64) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        // A zero component gives ±∞ with the sign of the zero, which the slab test expects.
        let inv = dir.map(|d| 1.0 / d);
        let neg = inv.map(|i| i.is_sign_negative());
        let mut stack = [0u32; STACK];
        let mut top = 0;
        let mut at = 0usize;
        loop {
            let node = &self.nodes[at];
            if slab(node, origin, inv, neg, t_min, t_max) {
                if node.count > 0 {
                    let first = node.index as usize;
                    let leaf = &self.tris[first..first + usize::from(node.count)];
                    if leaf.iter().any(|tri| hits(tri, origin, dir, t_min, t_max)) {
                        return true;
                    }
                } else {
                    // Nearer child first: an occluder is found sooner.
                    let (left, right) = (at + 1, at + node.index as usize);
                    let (first, second) = if neg[usize::from(node.axis)] {
                        (right, left)
                    } else {
                        (left, right)
                    };
                    stack[top] = second as u32;
                    top += 1;
                    at = first;
                    continue;
                }
            }
            if top == 0 {
                return false;
            }
            top -= 1;
            at = stack[top] as usize;
        }
    }
}

/// Slab test of a ray against a node's box over `t_min ..= t_max`, enlarged by [`GAMMA3`].
#[inline]
fn slab(node: &Node, o: Vec3, inv: Vec3, neg: [bool; 3], t_min: f64, t_max: f64) -> bool {
    let (mut t0, mut t1) = (t_min, t_max);
    for a in 0..3 {
        let (near, far) = if neg[a] {
            (node.hi[a], node.lo[a])
        } else {
            (node.lo[a], node.hi[a])
        };
        let tn = (near - o[a]) * inv[a];
        let tf = (far - o[a]) * inv[a];
        // 0 · ∞ (a ray along a face of the box) is NaN: the comparisons are false and the slab
        // does not restrict the interval, which errs on the side of visiting.
        if tn > t0 {
            t0 = tn;
        }
        if tf < t1 {
            t1 = tf;
        }
    }
    t0 <= t1 * (1.0 + 2.0 * GAMMA3)
}

/// Möller–Trumbore, both sides: whether the ray meets the triangle at `t_min < t < t_max`.
/// Barycentric coordinates on an edge count as inside.
#[inline]
fn hits(tri: &Tri, o: Vec3, d: Vec3, t_min: f64, t_max: f64) -> bool {
    let p = camera::cross(d, tri.e2);
    let det = camera::dot(tri.e1, p);
    if det == 0.0 || !det.is_finite() {
        return false;
    }
    let inv_det = 1.0 / det;
    let s = camera::sub(o, tri.v0);
    let u = camera::dot(s, p) * inv_det;
    if !(0.0..=1.0).contains(&u) {
        return false;
    }
    let q = camera::cross(s, tri.e1);
    let v = camera::dot(d, q) * inv_det;
    if v < 0.0 || u + v > 1.0 {
        return false;
    }
    let t = camera::dot(tri.e2, q) * inv_det;
    t > t_min && t < t_max
}

/// Builds the subtree over `refs` (whose first triangle is number `first` of the final order),
/// appending its nodes to `out` in depth-first order.
fn build(refs: &mut [PrimRef], first: usize, depth: usize, out: &mut Vec<Node>) {
    let mut bounds = Aabb::EMPTY;
    let mut centroids = Aabb::EMPTY;
    for r in refs.iter() {
        bounds.grow(r.lo, r.hi);
        let c = [r.centroid2(0), r.centroid2(1), r.centroid2(2)];
        centroids.grow(c, c);
    }
    let n = refs.len();
    let leaf = Node {
        lo: bounds.lo,
        hi: bounds.hi,
        index: first as u32,
        count: n as u16,
        axis: 0,
    };
    let split = if depth < SAH_MAX_DEPTH {
        sah_split(refs, &bounds, &centroids)
    } else {
        None
    };
    let (mid, axis) = match split {
        Some(s) => s,
        None if n <= MAX_LEAF => {
            out.push(leaf);
            return;
        }
        None => median_split(refs, &centroids),
    };
    let at = out.len();
    out.push(Node {
        lo: bounds.lo,
        hi: bounds.hi,
        index: 0,
        count: 0,
        axis: axis as u8,
    });
    let (left, right) = refs.split_at_mut(mid);
    if n > PARALLEL_MIN {
        let (l, r) = rayon::join(
            || {
                let mut v = Vec::new();
                build(left, first, depth + 1, &mut v);
                v
            },
            || {
                let mut v = Vec::new();
                build(right, first + mid, depth + 1, &mut v);
                v
            },
        );
        out.extend(l);
        out[at].index = (out.len() - at) as u32;
        out.extend(r);
    } else {
        build(left, first, depth + 1, out);
        out[at].index = (out.len() - at) as u32;
        build(right, first + mid, depth + 1, out);
    }
}

/// The best binned-SAH split of `refs`, partitioned in place: `Some((left count, axis))`, or
/// `None` when a leaf is cheaper (and allowed) or every centroid is the same point.
fn sah_split(refs: &mut [PrimRef], bounds: &Aabb, centroids: &Aabb) -> Option<(usize, usize)> {
    let n = refs.len();
    if n == 1 {
        return None;
    }
    let mut best: Option<(f64, usize, usize)> = None; // (cost, axis, last bin of the left side)
    for axis in 0..3 {
        let (lo, hi) = (centroids.lo[axis], centroids.hi[axis]);
        if hi <= lo {
            continue;
        }
        let scale = BINS as f64 / (hi - lo);
        let bin = |r: &PrimRef| (((r.centroid2(axis) - lo) * scale) as usize).min(BINS - 1);
        let mut counts = [0usize; BINS];
        let mut boxes = [Aabb::EMPTY; BINS];
        for r in refs.iter() {
            let b = bin(r);
            counts[b] += 1;
            boxes[b].grow(r.lo, r.hi);
        }
        // Sweep from the right: the cost of everything right of each boundary.
        let mut right_cost = [0.0; BINS];
        let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
        for b in (1..BINS).rev() {
            acc.grow(boxes[b].lo, boxes[b].hi);
            cnt += counts[b];
            right_cost[b] = acc.half_area() * cnt as f64;
        }
        let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
        for b in 0..BINS - 1 {
            acc.grow(boxes[b].lo, boxes[b].hi);
            cnt += counts[b];
            if cnt == 0 || cnt == n {
                continue;
            }
            let cost = acc.half_area() * cnt as f64 + right_cost[b + 1];
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, b));
            }
        }
    }
    let (cost, axis, last) = best?;
    let area = bounds.half_area();
    let split_cost = TRAVERSAL_COST + if area > 0.0 { cost / area } else { n as f64 };
    if n <= MAX_LEAF && split_cost >= n as f64 {
        return None;
    }
    let (lo, hi) = (centroids.lo[axis], centroids.hi[axis]);
    let scale = BINS as f64 / (hi - lo);
    let mid = partition(refs, |r| {
        (((r.centroid2(axis) - lo) * scale) as usize).min(BINS - 1) <= last
    });
    Some((mid, axis))
}

/// Splits `refs` at the median centroid along the centroids' longest axis (the fallback when the
/// SAH gives no split but the node is too big for a leaf, or the tree is too deep).
fn median_split(refs: &mut [PrimRef], centroids: &Aabb) -> (usize, usize) {
    let d = camera::sub(centroids.hi, centroids.lo);
    let axis = (0..3).max_by(|&a, &b| d[a].total_cmp(&d[b])).unwrap_or(0);
    let mid = refs.len() / 2;
    refs.select_nth_unstable_by(mid, |a, b| a.centroid2(axis).total_cmp(&b.centroid2(axis)));
    (mid, axis)
}

/// Moves the elements for which `left` holds to the front; returns how many there are.
fn partition(refs: &mut [PrimRef], left: impl Fn(&PrimRef) -> bool) -> usize {
    let mut i = 0;
    for j in 0..refs.len() {
        if left(&refs[j]) {
            refs.swap(i, j);
            i += 1;
        }
    }
    i
}
