//! Consistent outward orientation of a mesh's triangles, computed from its geometry alone
//! (issue 30: meshes whose triangles wind the other way, or both ways, as scans often do).
//!
//! The baker takes a triangle's winding as its outside: the vertex normals sum the triangles'
//! cross products, and the device culls and shades by them. A mesh wound inward is then lit from
//! inside and culled where it faces the eye, and a mesh wound both ways has vertex normals that
//! cancel. [`orientation_flips`] decides, from positions and connectivity only, which triangles to
//! turn so that the mesh winds one way and that way is out; so a mesh, the same mesh reversed and
//! the same mesh with any triangles reversed all orient to the same triangles, and the bake, the
//! device and the f64 reference all see the oriented mesh ([`TriMesh::orient`]).
//!
//! 1. **Consistent patches.** Vertices at the same position are one (a mesh cut along seams is one
//!    surface). Two triangles that share an edge and no third one (a manifold edge)
//!    must cross it in opposite directions. A breadth-first walk over those edges, from the lowest
//!    numbered triangle not yet reached, gives each triangle a parity (turn it or not) relative to
//!    its patch's first triangle. A triangle reached twice with different parities (a Möbius strip,
//!    or a fold) keeps the first: counted in [`Orientation::conflicts`].
//! 2. **Which way is out, per patch**, largest patch first:
//!    - a patch that meets patches already decided along edges of three triangles or more (a
//!      decimated scan's fins) is wound so that those edges are crossed as often one way as the
//!      other, as a consistent file crosses them; if that does not decide, it turns if they did;
//!    - a speck (under 10⁻³ of the mesh's area: a scan's floating debris) turns if most of the mesh
//!      did, and so do triangles on the same three vertices as another (duplicates), left out of
//!      step 1, and triangles of no area, left out too (they have no side);
//!    - a ground (normals mostly one way, and that way along Y: `|Σn| > 0.7 · Σ|n|`) faces up,
//!      hollows and all;
//!    - any other patch: the sign of its signed volume about its area centroid
//!      (`Σ det(a − c, b − c, d − c) / 6`: positive when it winds counter-clockwise seen from
//!      outside, for closed surfaces and open ones such as a scan with holes or a tube); where the
//!      volume is negligible (`|V| ≤ 10⁻³ · A^{3/2}`: a flat or nearly flat sheet, which has no
//!      inside) and its summed normal is mostly along Y, up (a ground faces +Y: models are Y up)
//!      ([`Facing`]); any other sheet (a wall, a single triangle, a closed flat double sheet)
//!      turns if most of the mesh did, and keeps the winding most of its area has when it is the
//!      first decided.
//!
//! A mesh already wound outward is left as it is (every Stanford scan in `../shared/models`: not a
//! triangle turned); the same mesh reversed orients to it exactly; with triangles reversed at
//! random, to it but for specks and duplicates.
//!
//! Time `O(T log T)`; at most 72 bytes per triangle while it runs ([`ORIENT_BYTES_PER_TRIANGLE`]).

use rayon::prelude::*;
use std::collections::{HashMap, HashSet};
use std::vec;
use std::vec::Vec;

use super::geom::{cross, dot, sub, V3};
use super::TriMesh;

/// What [`TriMesh::orient`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Orientation {
    /// Triangles whose winding was reversed.
    pub flipped: usize,
    /// Consistent patches found (connected through manifold edges).
    pub patches: usize,
    /// Triangles reached from two neighbours that disagreed (a non-orientable patch).
    pub conflicts: usize,
}

impl TriMesh {
    /// Turns the triangles that [`orientation_flips`] says to turn (swapping their last two
    /// vertices): afterwards the mesh winds one way, counter-clockwise seen from outside, whatever
    /// way its file wound it. A mesh that already does is left unchanged.
    pub fn orient(&mut self) -> Orientation {
        let (flips, report) = orientation_flips(&self.positions, &self.triangles);
        for (t, flip) in self.triangles.iter_mut().zip(flips) {
            if flip {
                t.swap(1, 2);
            }
        }
        report
    }
}

/// Below this `|V| / A^{3/2}` a patch is a sheet (a hemisphere has 0.13, a long thin open tube
/// more than 0.01).
const SHEET_VOLUME: f64 = 1e-3;

/// Above this `|Σn| / Σ|n|` with `Σn` mostly along Y, a surface is a ground.
const GROUND: f64 = 0.7;

/// The most memory [`orientation_flips`] takes per triangle, beside the mesh: 36 bytes of edge
/// uses and about 12 of manifold pairs at the peak, with the welded triangles (12) and a few flags.
pub const ORIENT_BYTES_PER_TRIANGLE: u64 = 72;

/// A patch with less than this share of the mesh's area is a speck.
const SPECK: f64 = 1e-3;

/// For each triangle, whether to reverse it (see the module documentation); indices must be in
/// range ([`TriMesh::validate`]).
pub fn orientation_flips(positions: &[V3], triangles: &[[u32; 3]]) -> (Vec<bool>, Orientation) {
    let n = triangles.len();
    let welded = weld(positions, triangles);
    // Triangles of no area have no side: left out, and turned with the mesh.
    let flat: Vec<bool> = triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| positions[i as usize]);
            let n = cross(sub(b, a), sub(c, a));
            dot(n, n) == 0.0
        })
        .collect();
    let mut adjacency = Adjacency::new(&welded, &flat);
    // Triangles on the same three vertices as another (duplicates, either winding: a decimated
    // scan's two-sided slivers) are left out too, and turned only if most of the mesh is: their
    // edges would look branching and unbalanced, and which of them is the outside cannot be told.
    // Only a mesh with a branching edge or a pair crossing an edge the same way can have ones that
    // matter (a lone two-sided pair is a closed patch with no side, which turns with the mesh
    // anyway): the others are spared the search.
    let mut left_out = flat;
    if !adjacency.clean {
        for (out, twin) in left_out.iter_mut().zip(twins(&welded)) {
            *out |= twin;
        }
        adjacency = Adjacency::new(&welded, &left_out);
    }
    // Parity per triangle: 0 or 1, 2 while not reached. Patches: ranges of `order`.
    let mut parity = vec![2u8; n];
    let mut report = Orientation::default();
    let mut order: Vec<u32> = Vec::with_capacity(n);
    let mut patches: Vec<(usize, usize)> = Vec::new();
    for seed in 0..n {
        if parity[seed] != 2 || left_out[seed] {
            continue;
        }
        let first = order.len();
        parity[seed] = 0;
        order.push(seed as u32);
        let mut next = first;
        while next < order.len() {
            let t = order[next];
            next += 1;
            let p = parity[t as usize];
            for (u, same) in adjacency.of(t) {
                // Crossing a shared edge the same way as the neighbour: one of the two must turn.
                let want = p ^ u8::from(same);
                match parity[u as usize] {
                    2 => {
                        parity[u as usize] = want;
                        order.push(u);
                    }
                    q if q != want => report.conflicts += 1,
                    _ => {}
                }
            }
        }
        // In file order from here on: the passes below then read the mesh in sequence.
        order[first..].par_sort_unstable();
        patches.push((first, order.len()));
    }
    report.patches = patches.len();
    // Each disagreement is seen from both triangles.
    report.conflicts /= 2;
    let corners = |t: u32| {
        let [a, b, c] = triangles[t as usize].map(|i| positions[i as usize]);
        if parity[t as usize] == 1 {
            [a, c, b]
        } else {
            [a, b, c]
        }
    };
    let area2 = |&(s, e): &(usize, usize)| -> f64 {
        order[s..e]
            .iter()
            .map(|&t| {
                let [a, b, c] = corners(t);
                let n = cross(sub(b, a), sub(c, a));
                dot(n, n).sqrt()
            })
            .sum()
    };
    let areas: Vec<f64> = patches.iter().map(area2).collect();
    let total: f64 = areas.iter().sum();
    // Largest patches first: a later one that meets them along an edge of three triangles or
    // more faces the way that balances the edge's directions (a consistent file crosses every
    // edge as often one way as the other).
    let mut by_area: Vec<usize> = (0..patches.len()).collect();
    by_area.sort_by(|&i, &j| areas[j].total_cmp(&areas[i]).then(i.cmp(&j)));
    // Per branching edge, decided triangles crossing it forward minus backward.
    let mut balance: HashMap<u64, i64> = HashMap::new();
    let mut flips = vec![false; n];
    let mut own: HashMap<u64, i64> = HashMap::new();
    // The area of the patches kept as filed and of those turned.
    let (mut kept_area, mut turned_area) = (0.0, 0.0);
    // Per branching edge, patches on it kept as filed (+1) or turned (−1).
    let mut verdicts: HashMap<u64, i64> = HashMap::new();
    for p in by_area {
        let (s, e) = patches[p];
        let patch = &order[s..e];
        own.clear();
        for &t in patch
            .iter()
            .filter(|&&t| adjacency.on_branching[t as usize])
        {
            let tri = welded[t as usize];
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                let key = key(a, b);
                if a != b && adjacency.branching.contains(&key) {
                    // As the patch is wound now (parity applied).
                    let forward = (a < b) != (parity[t as usize] == 1);
                    *own.entry(key).or_insert(0) += if forward { 1 } else { -1 };
                }
            }
        }
        let score: i64 = own
            .iter()
            .map(|(key, &q)| {
                let d = balance.get(key).copied().unwrap_or(0);
                (d - q).abs() - (d + q).abs()
            })
            .sum();
        // Whether most of the patch's area is wound as the file has it.
        let as_filed = areas_turned(&corners, patch, &parity) * 2.0 <= areas[p];
        // Whether the decided triangles on those edges were mostly kept (+) or turned (−).
        let verdict: i64 = own.keys().filter_map(|key| verdicts.get(key)).sum();
        let out = if score != 0 {
            // Kept as wound when that leaves the edges more balanced.
            score > 0
        } else if verdict != 0 {
            // Touching but balanced either way (a fin of two sheets): turned if its neighbours were.
            as_filed == (verdict > 0)
        } else if let Some(out) = (areas[p] >= SPECK * total)
            .then(|| facing(&corners, patch))
            .flatten()
        {
            out
        } else {
            // A speck (a scan's floating debris), or a sheet that is not a ground: nothing tells,
            // so turned if most of the mesh was (the largest patches come first); with nothing
            // decided yet, as the file has most of it.
            as_filed != file_turned(kept_area, turned_area)
        };
        let mut turned = 0i64;
        for &t in patch {
            let flip = (parity[t as usize] == 1) == out;
            flips[t as usize] = flip;
            report.flipped += usize::from(flip);
            turned += i64::from(flip);
        }
        let kept = if turned * 2 > patch.len() as i64 {
            turned_area += areas[p];
            -1
        } else {
            kept_area += areas[p];
            1
        };
        for (key, q) in own.drain() {
            *balance.entry(key).or_insert(0) += if out { q } else { -q };
            *verdicts.entry(key).or_insert(0) += kept;
        }
    }
    // Duplicates and triangles of no area turn with the mesh.
    if file_turned(kept_area, turned_area) {
        for (flip, _) in flips.iter_mut().zip(&left_out).filter(|(_, &t)| t) {
            *flip = true;
            report.flipped += 1;
        }
    }
    (flips, report)
}

/// Whether most of the mesh decided so far was turned.
fn file_turned(kept_area: f64, turned_area: f64) -> bool {
    turned_area > kept_area
}

/// The triangles with every vertex replaced by the first vertex at the same position: a mesh cut
/// along seams (vertices repeated for texture or normal breaks, a generated sphere's cube faces)
/// is one surface to orient, not a patch per piece.
fn weld(positions: &[V3], triangles: &[[u32; 3]]) -> Vec<[u32; 3]> {
    // `+ 0.0`: −0 and 0 are one position.
    let mut order: Vec<([u64; 3], u32)> = positions
        .iter()
        .enumerate()
        .map(|(v, p)| (p.map(|c| (c + 0.0).to_bits()), v as u32))
        .collect();
    order.par_sort_unstable();
    let mut canon: Vec<u32> = (0..positions.len() as u32).collect();
    for run in order.chunk_by(|u, v| u.0 == v.0) {
        for &(_, v) in run {
            canon[v as usize] = run[0].1;
        }
    }
    drop(order);
    triangles
        .iter()
        .map(|t| t.map(|v| canon[v as usize]))
        .collect()
}

/// For each triangle, whether another one is on the same three vertices.
fn twins(triangles: &[[u32; 3]]) -> Vec<bool> {
    let mut keys: Vec<([u32; 3], u32)> = triangles
        .iter()
        .enumerate()
        .map(|(t, tri)| {
            let mut k = *tri;
            k.sort_unstable();
            (k, t as u32)
        })
        .collect();
    keys.par_sort_unstable();
    let mut twin = vec![false; triangles.len()];
    for w in keys.windows(2) {
        if w[0].0 == w[1].0 {
            twin[w[0].1 as usize] = true;
            twin[w[1].1 as usize] = true;
        }
    }
    twin
}

/// Which way the patch, wound as `corners` gives it, faces ([`Facing::outward`]).
fn facing(corners: &impl Fn(u32) -> [V3; 3], patch: &[u32]) -> Option<bool> {
    let mut facing = Facing::default();
    for &t in patch {
        facing.add(corners(t));
    }
    facing.outward()
}

/// Which way a surface faces, accumulated one triangle at a time (as wound): its signed volume
/// about its area centroid and its summed normal; what [`orientation_flips`] decides a patch by,
/// and an out-of-core bake the whole mesh by, in one pass over its faces.
#[derive(Clone, Copy, Debug, Default)]
pub struct Facing {
    /// The first corner seen: every sum is taken about it, for precision.
    origin: Option<V3>,
    /// `Σ det(a, b, c)` about the origin.
    det: f64,
    /// `Σ n`, `n = (b − a) × (c − a)` (twice the area long).
    normal: V3,
    /// `Σ |n| · (a + b + c) / 3` about the origin.
    moment: V3,
    /// `Σ |n|`: twice the area.
    area2: f64,
}

impl Facing {
    /// Adds a triangle as wound.
    pub fn add(&mut self, corners: [V3; 3]) {
        let o = *self.origin.get_or_insert(corners[0]);
        let [a, b, c] = corners.map(|p| sub(p, o));
        let n = cross(sub(b, a), sub(c, a));
        let w = dot(n, n).sqrt();
        self.det += dot(a, cross(b, c));
        for k in 0..3 {
            self.normal[k] += n[k];
            // `b + c` first: the same sum for the triangle turned (`[a, c, b]`), so that a mesh
            // and its reverse decide alike to the last bit.
            self.moment[k] += w * (a[k] + (b[k] + c[k])) / 3.0;
        }
        self.area2 += w;
    }

    /// Whether the surface as wound faces out (`Some(true)`) or in (`Some(false)`), or `None`
    /// when nothing tells (a sheet that is not a ground; no area).
    ///
    /// A ground (normals mostly one way, `|Σn| > 0.7 · Σ|n|`, and that way along Y: models are Y
    /// up, and a ground is seen from above) faces out when it faces up, hollows and all. Else out
    /// when its signed volume about its area centroid `c`, `Σ det(a − c, b − c, d − c) / 6 =
    /// (Σ det(a, b, d) − c · Σ n) / 6`, is positive and not negligible (`|V| > 10⁻³ · A^{3/2}`);
    /// for a sheet (negligible volume) whose summed normal is mostly along Y, when it faces up.
    pub fn outward(&self) -> Option<bool> {
        if !(self.area2 > 0.0 && self.area2.is_finite()) {
            return None;
        }
        let [x, up, z] = self.normal;
        let mostly_y = up.abs() >= x.abs().max(z.abs());
        // A ground with hills and hollows (its normals mostly one way, `|Σn| > 0.7 Σ|n|`, and
        // that way Y): up, whatever its volume says (a hollow's would say down).
        if mostly_y && up.abs() > GROUND * self.area2 {
            return Some(up > 0.0);
        }
        let centroid = self.moment.map(|m| m / self.area2);
        let volume6 = self.det - dot(centroid, self.normal);
        let area = self.area2 / 2.0;
        if volume6.abs() / 6.0 > SHEET_VOLUME * area * area.sqrt() {
            return Some(volume6 > 0.0);
        }
        if mostly_y && up.abs() > SHEET_VOLUME * self.area2 {
            return Some(up > 0.0);
        }
        None
    }
}

/// Twice the area of the patch's turned triangles (parity 1).
fn areas_turned(corners: &impl Fn(u32) -> [V3; 3], patch: &[u32], parity: &[u8]) -> f64 {
    patch
        .iter()
        .filter(|&&t| parity[t as usize] == 1)
        .map(|&t| {
            let [a, b, c] = corners(t);
            let n = cross(sub(b, a), sub(c, a));
            dot(n, n).sqrt()
        })
        .sum()
}

/// For each triangle, its neighbours across manifold edges (edges of exactly two triangles) and
/// whether the neighbour crosses the edge in the same direction.
struct Adjacency {
    start: Vec<u32>,
    /// Neighbour `<< 1 | same`, by triangle from `start`.
    links: Vec<u32>,
    /// Edges of three triangles or more.
    branching: HashSet<u64>,
    /// Triangles with such an edge.
    on_branching: Vec<bool>,
    /// No branching edge, and no two triangles crossing an edge the same way.
    clean: bool,
}

impl Adjacency {
    fn new(triangles: &[[u32; 3]], left_out: &[bool]) -> Self {
        // Every edge use as (lower vertex, higher vertex, triangle << 1 | forward), sorted so that
        // an edge's uses meet: 36 bytes per triangle, the peak with the pairs below.
        let mut edges: Vec<[u32; 3]> = Vec::with_capacity(triangles.len() * 3);
        for (t, tri) in triangles.iter().enumerate() {
            if left_out[t] {
                continue;
            }
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                if a != b {
                    edges.push([a.min(b), a.max(b), ((t as u32) << 1) | u32::from(a < b)]);
                }
            }
        }
        // By edge only: the order of an edge's uses changes nothing below.
        edges.par_sort_unstable_by_key(|e| (u64::from(e[0]) << 32) | u64::from(e[1]));
        // Manifold edges as [s, t << 1 | same].
        let mut pairs: Vec<[u32; 2]> = Vec::new();
        let mut branching = HashSet::new();
        let mut on_branching = vec![false; triangles.len()];
        let mut clean = true;
        for run in edges.chunk_by(|e, f| e[..2] == f[..2]) {
            if let [e, f] = run {
                let (s, t) = (e[2], f[2]);
                if s >> 1 != t >> 1 {
                    let same = (s & 1) == (t & 1);
                    clean &= !same;
                    pairs.push([s >> 1, (t & !1) | u32::from(same)]);
                }
            } else if run.len() > 2 {
                branching.insert(key(run[0][0], run[0][1]));
                for e in run {
                    on_branching[(e[2] >> 1) as usize] = true;
                }
            }
        }
        drop(edges);
        let mut start = vec![0u32; triangles.len() + 1];
        for &[s, t] in &pairs {
            start[s as usize + 1] += 1;
            start[(t >> 1) as usize + 1] += 1;
        }
        for k in 1..start.len() {
            start[k] += start[k - 1];
        }
        let mut fill: Vec<u32> = start[..triangles.len()].to_vec();
        let mut links = vec![0u32; pairs.len() * 2];
        for &[s, t] in &pairs {
            let (t, same) = (t >> 1, t & 1);
            links[fill[s as usize] as usize] = (t << 1) | same;
            fill[s as usize] += 1;
            links[fill[t as usize] as usize] = (s << 1) | same;
            fill[t as usize] += 1;
        }
        Self {
            start,
            links,
            clean: clean && branching.is_empty(),
            branching,
            on_branching,
        }
    }

    /// The neighbours of `t` and whether each crosses the shared edge the same way.
    fn of(&self, t: u32) -> impl Iterator<Item = (u32, bool)> + '_ {
        self.links[self.start[t as usize] as usize..self.start[t as usize + 1] as usize]
            .iter()
            .map(|&l| (l >> 1, l & 1 == 1))
    }
}

/// An undirected edge's key.
fn key(a: u32, b: u32) -> u64 {
    (u64::from(a.min(b)) << 32) | u64::from(a.max(b))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A closed octahedron, wound outward.
    fn octahedron() -> TriMesh {
        let positions = vec![
            [1.0, 0.0, 0.0],
            [-1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
        ];
        let mut triangles = Vec::new();
        for &(x, sx) in &[(0u32, 1.0), (1, -1.0)] {
            for &(y, sy) in &[(2u32, 1.0), (3, -1.0)] {
                for &(z, sz) in &[(4u32, 1.0), (5, -1.0)] {
                    // Outward when the octant's sign product is positive.
                    let s: f64 = sx * sy * sz;
                    triangles.push(if s > 0.0 { [x, y, z] } else { [x, z, y] });
                }
            }
        }
        TriMesh {
            positions,
            triangles,
            ..TriMesh::default()
        }
    }

    fn signed_volume(m: &TriMesh) -> f64 {
        m.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| m.positions[i as usize]);
                dot(a, cross(b, c)) / 6.0
            })
            .sum()
    }

    #[test]
    fn an_outward_mesh_is_left_as_it_is() {
        let m = octahedron();
        assert!(signed_volume(&m) > 0.0);
        let mut o = m.clone();
        let r = o.orient();
        assert_eq!(o, m);
        assert_eq!((r.flipped, r.patches, r.conflicts), (0, 1, 0));
    }

    #[test]
    fn reversed_and_mixed_windings_orient_to_the_same_triangles() {
        let m = octahedron();
        let mut reversed = m.clone();
        for t in &mut reversed.triangles {
            t.swap(0, 1);
        }
        assert!(signed_volume(&reversed) < 0.0);
        let r = reversed.orient();
        assert_eq!(r.flipped, 8);
        // Same triangles up to rotation of their corners.
        assert!((signed_volume(&reversed) - signed_volume(&m)).abs() < 1e-12);
        for mask in 1..255u32 {
            let mut mixed = m.clone();
            for (k, t) in mixed.triangles.iter_mut().enumerate() {
                if mask >> k & 1 == 1 {
                    t.swap(1, 2);
                }
            }
            let r = mixed.orient();
            assert_eq!(mixed, m, "mask {mask:08b}");
            assert_eq!(r.flipped, mask.count_ones() as usize);
        }
    }

    #[test]
    fn a_ground_faces_up_and_a_wall_or_a_double_sheet_is_kept() {
        // A square in the XZ plane, facing down (−Y) as written.
        let sheet = TriMesh {
            positions: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [1.0, 0.0, 1.0],
                [0.0, 0.0, 1.0],
            ],
            triangles: vec![[0, 1, 2], [0, 2, 3]],
            ..TriMesh::default()
        };
        let n = |m: &TriMesh| {
            let [a, b, c] = m.triangles[0].map(|i| m.positions[i as usize]);
            cross(sub(b, a), sub(c, a))
        };
        assert!(n(&sheet)[1] < 0.0);
        let mut up = sheet.clone();
        up.orient();
        assert!(n(&up)[1] > 0.0, "a ground faces up");
        let mut again = up.clone();
        assert_eq!(again.orient().flipped, 0);
        // The same square stood up as a wall facing −Z: no side to tell, kept.
        let wall = TriMesh {
            positions: sheet.positions.iter().map(|p| [p[0], p[2], p[1]]).collect(),
            ..sheet.clone()
        };
        let mut kept = wall.clone();
        assert_eq!(kept.orient().flipped, 0);
        assert_eq!(kept, wall);
        // Both sides of the same square (a leaf): nothing to decide, nothing turned.
        let mut double = sheet.clone();
        double.triangles.extend([[0, 2, 1], [0, 3, 2]]);
        let before = double.clone();
        assert_eq!(double.orient().flipped, 0);
        assert_eq!(double, before);
    }

    #[test]
    fn a_mesh_cut_along_seams_is_one_surface() {
        // The octahedron with every triangle on its own three vertices (24 in all, as a mesh
        // exported with flat normals is): its bottom faces down, not up like a ground.
        let m = octahedron();
        let mut cut = TriMesh::default();
        for t in &m.triangles {
            let base = cut.positions.len() as u32;
            cut.positions.extend(t.map(|v| m.positions[v as usize]));
            cut.triangles.push([base, base + 1, base + 2]);
        }
        let outward = cut.clone();
        let mut reversed = cut.clone();
        for t in &mut reversed.triangles {
            t.swap(1, 2);
        }
        assert_eq!(cut.orient().flipped, 0);
        assert_eq!(cut, outward);
        assert_eq!(reversed.orient().flipped, 8);
        assert_eq!(reversed, outward);
    }

    #[test]
    fn a_moebius_strip_is_counted_not_looped() {
        // Six quads around a twisted loop: not orientable.
        let k = 6;
        let mut positions = Vec::new();
        for i in 0..k {
            let a = std::f64::consts::TAU * i as f64 / k as f64;
            let half = a / 2.0;
            let (dx, dz) = (half.cos() * 0.3, half.sin() * 0.3);
            let (cx, cy) = (a.cos(), a.sin());
            positions.push([cx * (1.0 + dx), cy * (1.0 + dx), dz]);
            positions.push([cx * (1.0 - dx), cy * (1.0 - dx), -dz]);
        }
        let mut triangles = Vec::new();
        for i in 0..k {
            let (a, b) = (2 * i as u32, 2 * i as u32 + 1);
            // The last quad joins with a half twist.
            let (c, d) = if i + 1 == k { (1, 0) } else { (a + 2, b + 2) };
            triangles.push([a, b, d]);
            triangles.push([a, d, c]);
        }
        let mut m = TriMesh {
            positions,
            triangles,
            ..TriMesh::default()
        };
        let r = m.orient();
        assert_eq!(r.patches, 1);
        assert!(r.conflicts >= 1, "{r:?}");
    }
}
