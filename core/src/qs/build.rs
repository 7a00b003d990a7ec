//! The QSplat tree built from points (QSplat §2.2): a leaf per usable vertex, interior nodes
//! from their children, top-down splits two binary levels at a time, and the spheres quantized
//! top-down against the decoded parents (§3). [`super::write`] lays one tree out whole;
//! [`super::pieces`] builds a large one piece by piece with the same functions.

use rayon::prelude::*;
use std::vec::Vec;

use super::normal::{self, cone_code};
use super::table::{unpack, SPHERES, SPHERE_COUNT};
use crate::bake::TriMesh;

/// One node of the baked tree: exact values, and what was stored.
#[derive(Clone, Debug, PartialEq)]
pub struct BakedNode {
    /// Exact centre, model units.
    pub center: [f64; 3],
    /// Exact radius.
    pub radius: f64,
    /// The centre a reader decodes.
    pub decoded_center: [f64; 3],
    /// The radius a reader decodes.
    pub decoded_radius: f64,
    /// Table index (unused for the root, whose sphere is in the header).
    pub sphere: u16,
    /// Exact unit normal (zero when undefined).
    pub normal_exact: [f64; 3],
    /// 14-bit normal index.
    pub normal: u16,
    /// Exact cone half-angle around the decoded normal, radians (π when undefined).
    pub cone_exact: f64,
    /// 2-bit cone code.
    pub cone: u8,
    /// RGB565 colour (0 without colours).
    pub color: u16,
    /// Children (indices into [`BakedQs::nodes`](super::write::BakedQs::nodes)), 2–4, or none for a leaf.
    pub children: Vec<u32>,
    /// Nodes in this subtree, itself included.
    pub subtree: u32,
}

/// Build calls below which splits fall back from the midpoint to the median (bounds the depth).
const MEDIAN_DEPTH: u32 = 32;
/// A model of at least this many points has its root's subtrees built in parallel.
const PARALLEL_POINTS: usize = 1 << 15;

pub(super) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
pub(super) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
pub(super) fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
pub(super) fn len(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}
pub(super) fn angle(a: [f64; 3], b: [f64; 3]) -> f64 {
    dot(a, b).clamp(-1.0, 1.0).acos()
}

/// Radius of the smallest sphere around a triangle: the circumradius when it is acute, half the
/// longest edge otherwise (and for degenerate triangles).
pub fn triangle_bounding_radius(p: [[f64; 3]; 3]) -> f64 {
    let e = [sub(p[1], p[0]), sub(p[2], p[1]), sub(p[0], p[2])];
    let mut l2 = e.map(|v| dot(v, v));
    l2.sort_by(f64::total_cmp);
    let half_longest = 0.5 * l2[2].sqrt();
    let area2 = len(cross(e[0], e[2]));
    if l2[2] >= l2[0] + l2[1] || area2 <= 0.0 {
        return half_longest;
    }
    // R = abc / (4·area) = abc / (2·|e₀ × e₂|).
    let r = (l2[0] * l2[1] * l2[2]).sqrt() / (2.0 * area2);
    r.max(half_longest)
}

/// A usable vertex: a leaf of the tree.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Point {
    /// Position.
    pub p: [f64; 3],
    /// Radius: the largest bounding sphere of the triangles around it.
    pub r: f64,
    /// The sum of their normals (cross products, area-weighted), in triangle order.
    pub n: [f64; 3],
    /// Colour, 0..=255 per channel (0 without colours).
    pub rgb: [f64; 3],
}

/// What one triangle adds to its vertices' points: its bounding radius and its normal (the
/// cross product, area-weighted).
pub fn triangle_contribution(p: [[f64; 3]; 3]) -> (f64, [f64; 3]) {
    (
        triangle_bounding_radius(p),
        cross(sub(p[1], p[0]), sub(p[2], p[0])),
    )
}

/// Adds a triangle's [`triangle_contribution`] to a vertex's radius and normal sum.
pub fn accumulate(radius: &mut f64, nsum: &mut [f64; 3], (r, n): (f64, [f64; 3])) {
    *radius = radius.max(r);
    for k in 0..3 {
        nsum[k] += n[k];
    }
}

/// The usable points of a mesh (referenced vertices with a positive radius), in vertex order.
pub(super) fn mesh_points(mesh: &TriMesh) -> Vec<Point> {
    let nv = mesh.positions.len();
    let mut radius = std::vec![0.0f64; nv];
    let mut nsum = std::vec![[0.0f64; 3]; nv];
    for t in &mesh.triangles {
        let c = triangle_contribution(t.map(|i| mesh.positions[i as usize]));
        for &i in t {
            let i = i as usize;
            accumulate(&mut radius[i], &mut nsum[i], c);
        }
    }
    // An unreferenced vertex keeps radius 0 and so is dropped with the zero-radius ones.
    (0..nv)
        .filter(|&i| radius[i] > 0.0)
        .map(|i| Point {
            p: mesh.positions[i],
            r: radius[i],
            n: nsum[i],
            rgb: mesh
                .colors
                .as_ref()
                .map_or([0.0; 3], |c| c[i].map(f64::from)),
        })
        .collect()
}

/// Every 14-bit normal code decoded once: a bake encodes each node's normal against nine candidate
/// codes and measures its cones against decoded codes, and `normal::decode` costs two `tan`s.
pub(super) struct Codes(Vec<[f64; 3]>);

impl Codes {
    pub(super) fn new() -> Self {
        Self((0..1u16 << 14).map(normal::decode).collect())
    }
    pub(super) fn decode(&self, index: u16) -> [f64; 3] {
        self.0[usize::from(index & 0x3FFF)]
    }
    fn encode(&self, n: [f64; 3]) -> u16 {
        normal::encode_with(n, |i| self.decode(i))
    }
}

/// Splits `ids` in two non-empty parts, reordering them in place: at the midpoint of the longest
/// axis of their positions' bounding box, or at the median along it (ties broken by id) when the
/// midpoint leaves a side empty or the tree is `MEDIAN_DEPTH` deep. Returns the size of the
/// first part. The parts and their order depend on the ids' order, which the pieces of an
/// out-of-core bake keep.
pub(super) fn split_ids(ids: &mut [u32], depth: u32, pos: impl Fn(u32) -> [f64; 3]) -> usize {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for &i in ids.iter() {
        let p = pos(i);
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let ext = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
    let axis = if ext[0] >= ext[1] && ext[0] >= ext[2] {
        0
    } else if ext[1] >= ext[2] {
        1
    } else {
        2
    };
    if depth < MEDIAN_DEPTH {
        let mid = 0.5 * (lo[axis] + hi[axis]);
        // Two-pointer partition: `< mid` first (deterministic).
        let (mut i, mut j) = (0usize, ids.len());
        while i < j {
            if pos(ids[i])[axis] < mid {
                i += 1;
            } else {
                j -= 1;
                ids.swap(i, j);
            }
        }
        if i > 0 && i < ids.len() {
            return i;
        }
    }
    let m = ids.len() / 2;
    ids.select_nth_unstable_by(m, |&a, &b| {
        pos(a)[axis].total_cmp(&pos(b)[axis]).then(a.cmp(&b))
    });
    m
}

/// The 2, 3 or 4 parts a node over `ids` splits into, two binary levels at a time (as
/// [`Builder::build`] splits): a half of 3 or 4 points stays whole (one group of leaves below
/// it); splitting it would take as many interior nodes or more. A half of 2 splits into two
/// leaves.
pub(super) fn parts(
    ids: &mut [u32],
    depth: u32,
    pos: impl Fn(u32) -> [f64; 3] + Copy,
) -> Vec<&mut [u32]> {
    let m = split_ids(ids, depth, pos);
    let (a, b) = ids.split_at_mut(m);
    let mut parts: Vec<&mut [u32]> = Vec::with_capacity(4);
    for half in [a, b] {
        if half.len() == 2 || half.len() > 4 {
            let k = split_ids(half, depth, pos);
            let (x, y) = half.split_at_mut(k);
            parts.push(x);
            parts.push(y);
        } else {
            parts.push(half);
        }
    }
    parts
}

/// Builds trees (or subtrees) over points: every node in `nodes`, children before parents.
pub(super) struct Builder<'a> {
    pub(super) pts: &'a [Point],
    pub(super) codes: &'a Codes,
    pub(super) nodes: Vec<BakedNode>,
    /// Exact mean colour per node.
    pub(super) rgb: Vec<[f64; 3]>,
    /// Deepest leaf.
    pub(super) depth: u32,
}

impl Builder<'_> {
    pub(super) fn leaf(&mut self, id: u32, depth: u32) -> u32 {
        let pt = &self.pts[id as usize];
        let l = len(pt.n);
        let (n, idx, theta) = if l > 0.0 {
            let n = pt.n.map(|c| c / l);
            let idx = self.codes.encode(n);
            (n, idx, angle(n, self.codes.decode(idx)))
        } else {
            (
                [0.0; 3],
                self.codes.encode([0.0, 0.0, 1.0]),
                core::f64::consts::PI,
            )
        };
        self.depth = self.depth.max(depth);
        self.push(
            BakedNode {
                center: pt.p,
                radius: pt.r,
                decoded_center: pt.p,
                decoded_radius: pt.r,
                sphere: 0,
                normal_exact: n,
                normal: idx,
                cone_exact: theta,
                cone: cone_code(theta),
                color: 0,
                children: Vec::new(),
                subtree: 1,
            },
            pt.rgb,
        )
    }

    pub(super) fn push(&mut self, node: BakedNode, rgb: [f64; 3]) -> u32 {
        self.nodes.push(node);
        self.rgb.push(rgb);
        (self.nodes.len() - 1) as u32
    }

    /// Builds the subtree over `ids` (at least 2 points) at tree depth `depth`; returns its node.
    pub(super) fn build(&mut self, ids: &mut [u32], depth: u32) -> u32 {
        if ids.len() <= 4 {
            // Four points or fewer are one group of leaves (as QSplat 1.0's maker groups them):
            // splitting them again only adds an interior node and a pointer.
            let children = ids.iter().map(|&i| self.leaf(i, depth + 1)).collect();
            return self.interior(children);
        }
        // Two binary levels at a time: 2, 3 or 4 parts.
        let ids_len = ids.len();
        let pts = self.pts;
        let parts = parts(ids, depth, |i| pts[i as usize].p);
        let children = if depth == 0 && ids_len >= PARALLEL_POINTS {
            // The root's 2–4 subtrees are built on other threads, each into its own node list, and
            // then adopted: the tree (and so the file, which is laid out from the root) is the
            // same. Only at the root, so that each node is copied once.
            let subtrees: Vec<Builder<'_>> = parts
                .into_par_iter()
                .map(|part| {
                    let mut sub = Builder {
                        pts: self.pts,
                        codes: self.codes,
                        nodes: Vec::with_capacity(part.len() * 3 / 2),
                        rgb: Vec::with_capacity(part.len() * 3 / 2),
                        depth: 0,
                    };
                    sub.child(part, depth + 1);
                    sub
                })
                .collect();
            subtrees.into_iter().map(|sub| self.adopt(sub)).collect()
        } else {
            parts
                .into_iter()
                .map(|part| self.child(part, depth + 1))
                .collect()
        };
        self.interior(children)
    }

    /// The node over `ids` (a leaf for one point) at tree depth `depth`.
    pub(super) fn child(&mut self, ids: &mut [u32], depth: u32) -> u32 {
        if ids.len() == 1 {
            self.leaf(ids[0], depth)
        } else {
            self.build(ids, depth)
        }
    }

    /// Appends the nodes of `sub` (whose last node is its subtree's root); returns that root.
    pub(super) fn adopt(&mut self, sub: Builder<'_>) -> u32 {
        let offset = self.nodes.len() as u32;
        self.depth = self.depth.max(sub.depth);
        self.rgb.extend(sub.rgb);
        self.nodes.extend(sub.nodes.into_iter().map(|mut n| {
            for c in &mut n.children {
                *c += offset;
            }
            n
        }));
        self.nodes.len() as u32 - 1
    }

    pub(super) fn interior(&mut self, children: Vec<u32>) -> u32 {
        let k = children.len() as f64;
        let mut c = [0.0; 3];
        let mut nsum = [0.0; 3];
        let mut rgb = [0.0; 3];
        let mut subtree = 1;
        for &i in &children {
            let n = &self.nodes[i as usize];
            for a in 0..3 {
                c[a] += n.center[a] / k;
                nsum[a] += n.normal_exact[a];
                rgb[a] += self.rgb[i as usize][a] / k;
            }
            subtree += n.subtree;
        }
        let mut radius: f64 = 0.0;
        for &i in &children {
            let n = &self.nodes[i as usize];
            radius = radius.max(len(sub(n.center, c)) + n.radius);
        }
        // Enclose the children despite rounding.
        let radius = radius * (1.0 + 1e-12);
        let l = len(nsum);
        let (n, idx) = if l > 1e-9 {
            let n = nsum.map(|v| v / l);
            (n, self.codes.encode(n))
        } else {
            ([0.0; 3], self.codes.encode([0.0, 0.0, 1.0]))
        };
        let q = self.codes.decode(idx);
        let theta = if l > 1e-9 {
            children
                .iter()
                .map(|&i| {
                    let ch = &self.nodes[i as usize];
                    angle(q, self.codes.decode(ch.normal)) + ch.cone_exact
                })
                .fold(0.0, f64::max)
                .min(core::f64::consts::PI)
        } else {
            core::f64::consts::PI
        };
        self.push(
            BakedNode {
                center: c,
                radius,
                decoded_center: c,
                decoded_radius: radius,
                sphere: 0,
                normal_exact: n,
                normal: idx,
                cone_exact: theta,
                cone: cone_code(theta),
                color: 0,
                children,
                subtree,
            },
            rgb,
        )
    }
}

/// The `(s, x, y, z)` → table index map.
pub(super) fn table_index() -> Vec<u16> {
    let mut map = std::vec![u16::MAX; 14 * 14 * 14 * 14];
    for (i, &p) in SPHERES.iter().enumerate() {
        let (s, x, y, z) = unpack(p).cell();
        map[((usize::from(s) * 14 + usize::from(x)) * 14 + usize::from(y)) * 14 + usize::from(z)] =
            i as u16;
    }
    map
}

/// The smallest table entry whose sphere encloses a child at `rel` (parent radii, relative to the
/// parent's centre) with radius `rr`, nearest first among equals: `(index, offset, radius)`.
pub(super) fn quantize_sphere(map: &[u16], rel: [f64; 3], rr: f64) -> (u16, [f64; 3], f64) {
    for s in 1..=13u32 {
        let big_r = f64::from(s) / 13.0;
        if rr > big_r {
            continue;
        }
        let cell = rel.map(|v| {
            let x = (((v + 1.0) * 13.0 - f64::from(s)) * 0.5).round();
            x.clamp(0.0, f64::from(13 - s)) as u32
        });
        let q = cell.map(|x| f64::from(s + 2 * x) / 13.0 - 1.0);
        if len(sub(rel, q)) + rr <= big_r {
            let i = map[((s as usize * 14 + cell[0] as usize) * 14 + cell[1] as usize) * 14
                + cell[2] as usize];
            if i != u16::MAX {
                return (i, q, big_r);
            }
        }
    }
    // Only rounding can get here (a child always fits its parent): the parent itself.
    ((SPHERE_COUNT - 1) as u16, [0.0; 3], 1.0)
}

/// Rounds `x` to an `f32` no smaller than it.
pub(super) fn f32_up(x: f64) -> f32 {
    let f = x as f32;
    if f64::from(f) < x {
        f.next_up()
    } else {
        f
    }
}

/// Quantization errors summed over nodes ([`super::write::QsStats`] divides them).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct Errors {
    pub(super) position: f64,
    pub(super) radius: f64,
    pub(super) quantized: u64,
    pub(super) normal: f64,
    pub(super) normal_max: f64,
    pub(super) normals: u64,
}

impl Errors {
    pub(super) fn add(&mut self, o: &Errors) {
        self.position += o.position;
        self.radius += o.radius;
        self.quantized += o.quantized;
        self.normal += o.normal;
        self.normal_max = self.normal_max.max(o.normal_max);
        self.normals += o.normals;
    }
}

/// The root's decoded sphere, as the header stores it: its centre as `f32`, its radius rounded
/// up to an `f32` that still encloses the exact sphere around the moved centre.
pub(super) fn decode_root(r: &mut BakedNode) {
    let cf = r.center.map(|v| v as f32);
    let shift = len(sub(r.center, cf.map(f64::from)));
    r.decoded_center = cf.map(f64::from);
    r.decoded_radius = f64::from(f32_up(r.radius + shift));
}

/// Quantizes the spheres of the subtree below `top` (whose decoded sphere is set) top-down,
/// each against its decoded parent (§3); returns the errors.
pub(super) fn quantize(nodes: &mut [BakedNode], top: u32, map: &[u16]) -> Errors {
    let mut e = Errors::default();
    let mut stack = std::vec![top];
    while let Some(p) = stack.pop() {
        let (pc, pr) = (
            nodes[p as usize].decoded_center,
            nodes[p as usize].decoded_radius,
        );
        for k in 0..nodes[p as usize].children.len() {
            let ci = nodes[p as usize].children[k];
            let ch = &mut nodes[ci as usize];
            quantize_child(ch, pc, pr, map, &mut e);
            stack.push(ci);
        }
    }
    e
}

/// Quantizes one child against its parent's decoded centre `pc` and radius `pr`.
pub(super) fn quantize_child(
    ch: &mut BakedNode,
    pc: [f64; 3],
    pr: f64,
    map: &[u16],
    e: &mut Errors,
) {
    let rel = sub(ch.center, pc).map(|v| v / pr);
    let rr = ch.radius / pr;
    let (index, q, big_r) = quantize_sphere(map, rel, rr);
    ch.sphere = index;
    ch.decoded_center = [0, 1, 2].map(|k| pc[k] + pr * q[k]);
    ch.decoded_radius = pr * big_r;
    e.position += (0..3).map(|k| (q[k] - rel[k]).abs()).sum::<f64>() / 3.0;
    e.radius += big_r - rr;
    e.quantized += 1;
}

/// Adds the normal errors of `nodes` but `skip` (the root, whose normal is not stored).
pub(super) fn normal_errors(nodes: &[BakedNode], skip: Option<u32>, codes: &Codes, e: &mut Errors) {
    for (i, n) in nodes.iter().enumerate() {
        if Some(i as u32) != skip && len(n.normal_exact) > 0.0 {
            let err = angle(n.normal_exact, codes.decode(n.normal));
            e.normal += err;
            e.normal_max = e.normal_max.max(err);
            e.normals += 1;
        }
    }
}

/// The colours of `nodes` as stored: RGB565 of the mean colour when `color`, else 0.
pub(super) fn set_colors(nodes: &mut [BakedNode], rgb: &[[f64; 3]], color: bool) {
    for (n, rgb) in nodes.iter_mut().zip(rgb) {
        n.color = if color {
            crate::shade::rgb255_to_rgb565(*rgb)
        } else {
            0
        };
    }
}
