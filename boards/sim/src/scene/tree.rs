//! Procedurally generated trees: recursive branching of tapered cylinders with leaves at the tips,
//! deterministic for a given seed (a splitmix64 generator and `libm`'s functions, so the same seed
//! gives the same bits on every machine).
//!
//! A branch is a truncated cone of `sides` faces from its base to its tip. At its tip it forks into
//! `branches` children (the first one close to the parent's direction, a leader; the others spread
//! around it by the golden angle and tilted 30–50°), each 0.65–0.8 as long and 0.6 as thick; after
//! `levels` generations the tips carry `leaves` leaves. A leaf is a flattened octahedron (a
//! closed, two-sided diamond), so it has samples facing both ways and is seen from either side
//! with backface culling on. Material index 0 is bark, 1 is leaves.

use pocketsplat_core::bake::TriMesh;
use serde::Deserialize;

type V3 = [f64; 3];

/// `tree = { seed = 7, levels = 5, ... }`. Sizes are in model units (the trunk starts at the origin
/// and grows up +Y).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TreeSpec {
    /// Seed of the generator: the same seed, the same tree.
    pub seed: u64,
    /// Branching generations after the trunk (1..=7).
    #[serde(default = "default_levels")]
    pub levels: u8,
    /// Children per fork (1..=5).
    #[serde(default = "default_branches")]
    pub branches: u8,
    /// Trunk length.
    #[serde(default = "default_height")]
    pub height: f64,
    /// Trunk radius at the base.
    #[serde(default = "default_radius")]
    pub radius: f64,
    /// Leaf length.
    #[serde(default = "default_leaf")]
    pub leaf_size: f64,
    /// Leaves per tip (0..=32).
    #[serde(default = "default_leaves")]
    pub leaves: u8,
    /// Faces around a branch (3..=16).
    #[serde(default = "default_sides")]
    pub sides: u8,
}

fn default_levels() -> u8 {
    4
}
fn default_branches() -> u8 {
    3
}
fn default_height() -> f64 {
    0.45
}
fn default_radius() -> f64 {
    0.04
}
fn default_leaf() -> f64 {
    0.09
}
fn default_leaves() -> u8 {
    8
}
fn default_sides() -> u8 {
    7
}

impl TreeSpec {
    /// A tree with the default shape.
    pub fn new(seed: u64) -> Self {
        Self {
            seed,
            levels: default_levels(),
            branches: default_branches(),
            height: default_height(),
            radius: default_radius(),
            leaf_size: default_leaf(),
            leaves: default_leaves(),
            sides: default_sides(),
        }
    }

    /// Checks the numbers.
    ///
    /// # Errors
    /// A message naming the bad field.
    pub fn check(&self) -> Result<(), String> {
        if !(1..=7).contains(&self.levels) {
            return Err(format!("levels {}: must be 1..=7", self.levels));
        }
        if !(1..=5).contains(&self.branches) {
            return Err(format!("branches {}: must be 1..=5", self.branches));
        }
        if !(3..=16).contains(&self.sides) {
            return Err(format!("sides {}: must be 3..=16", self.sides));
        }
        if self.leaves > 32 {
            return Err(format!("leaves {}: at most 32", self.leaves));
        }
        for (name, v) in [
            ("height", self.height),
            ("radius", self.radius),
            ("leaf_size", self.leaf_size),
        ] {
            if !(v > 0.0 && v < 1e6) {
                return Err(format!("{name} {v}: must be positive"));
            }
        }
        Ok(())
    }

    /// The tree's mesh: material 0 bark, 1 leaves.
    pub fn mesh(&self) -> TriMesh {
        let mut g = Grower {
            spec: self,
            rng: SplitMix(self.seed),
            mesh: TriMesh {
                materials: Some(Vec::new()),
                ..TriMesh::default()
            },
        };
        g.branch([0.0; 3], [0.0, 1.0, 0.0], self.height, self.radius, 0);
        g.mesh
    }
}

/// splitmix64 (Steele, Lea & Flood 2014): tiny, fast, and the same everywhere.
struct SplitMix(u64);

impl SplitMix {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Uniform in [lo, hi).
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
}

fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn scale(a: V3, s: f64) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}
fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn normalize(a: V3) -> V3 {
    scale(a, 1.0 / libm::sqrt(dot(a, a)))
}

/// Two unit vectors across unit `d`, with `u × v = d`.
fn across(d: V3) -> (V3, V3) {
    let helper = if libm::fabs(d[1]) < 0.9 {
        [0.0, 1.0, 0.0]
    } else {
        [1.0, 0.0, 0.0]
    };
    let u = normalize(cross(helper, d));
    (u, cross(d, u))
}

/// `d` tilted by `tilt` radians towards azimuth `phi` around it.
fn tilted(d: V3, tilt: f64, phi: f64) -> V3 {
    let (u, v) = across(d);
    let side = add(scale(u, libm::cos(phi)), scale(v, libm::sin(phi)));
    normalize(add(scale(d, libm::cos(tilt)), scale(side, libm::sin(tilt))))
}

const GOLDEN_ANGLE: f64 = 2.399_963_229_728_653;
const BARK: u8 = 0;
const LEAF: u8 = 1;

struct Grower<'s> {
    spec: &'s TreeSpec,
    rng: SplitMix,
    mesh: TriMesh,
}

impl Grower<'_> {
    fn vertex(&mut self, p: V3) -> u32 {
        self.mesh.positions.push(p);
        (self.mesh.positions.len() - 1) as u32
    }

    fn face(&mut self, t: [u32; 3], material: u8) {
        self.mesh.triangles.push(t);
        if let Some(m) = &mut self.mesh.materials {
            m.push(material);
        }
    }

    /// A branch from `base` along unit `dir`, then its children or leaves.
    fn branch(&mut self, base: V3, dir: V3, length: f64, radius: f64, generation: u8) {
        let tip = add(base, scale(dir, length));
        let taper = 0.65;
        self.cone(base, tip, dir, radius, radius * taper);
        if generation == self.spec.levels {
            for _ in 0..self.spec.leaves {
                self.leaf(tip, length);
            }
            return;
        }
        let phase = self.rng.range(0.0, std::f64::consts::TAU);
        for k in 0..self.spec.branches {
            let (tilt, phi) = if k == 0 {
                (self.rng.range(0.05, 0.25), phase)
            } else {
                (
                    self.rng.range(0.5, 0.9),
                    phase + f64::from(k) * GOLDEN_ANGLE + self.rng.range(-0.3, 0.3),
                )
            };
            // Branches bend a little towards the light above.
            let d = tilted(dir, tilt, phi);
            let d = normalize(add(d, [0.0, 0.15, 0.0]));
            let len = length * self.rng.range(0.65, 0.8);
            // Children start just below the tip so that their bases hide the fork.
            let start = sub(tip, scale(dir, 0.3 * radius * taper));
            self.branch(start, d, len, radius * taper * 0.9, generation + 1);
        }
    }

    /// A truncated cone (no caps) of `sides` faces, counter-clockwise seen from outside.
    fn cone(&mut self, base: V3, tip: V3, dir: V3, r0: f64, r1: f64) {
        let n = usize::from(self.spec.sides);
        let (u, v) = across(dir);
        let ring = |c: V3, r: f64, i: usize| {
            let a = std::f64::consts::TAU * i as f64 / n as f64;
            add(
                c,
                add(scale(u, r * libm::cos(a)), scale(v, r * libm::sin(a))),
            )
        };
        let first = self.mesh.positions.len() as u32;
        for i in 0..n {
            self.vertex(ring(base, r0, i));
            self.vertex(ring(tip, r1, i));
        }
        for i in 0..n {
            let j = (i + 1) % n;
            let (b0, t0) = (first + 2 * i as u32, first + 2 * i as u32 + 1);
            let (b1, t1) = (first + 2 * j as u32, first + 2 * j as u32 + 1);
            self.face([b0, b1, t1], BARK);
            self.face([b0, t1, t0], BARK);
        }
    }

    /// A leaf near `tip`: a thin diamond (flattened octahedron) in a random orientation.
    fn leaf(&mut self, tip: V3, branch_length: f64) {
        let s = self.spec.leaf_size;
        let r = &mut self.rng;
        let offset = [r.range(-1.0, 1.0), r.range(-0.5, 1.0), r.range(-1.0, 1.0)];
        let centre = add(tip, scale(offset, 0.5 * s.max(0.3 * branch_length)));
        let along = normalize([r.range(-1.0, 1.0), r.range(-0.2, 1.0), r.range(-1.0, 1.0)]);
        let (u, v) = across(along);
        let twist = r.range(0.0, std::f64::consts::TAU);
        let width = add(scale(u, libm::cos(twist)), scale(v, libm::sin(twist)));
        let normal = cross(along, width);
        let size = s * r.range(0.8, 1.2);
        let axes = [
            scale(along, 0.5 * size),
            scale(width, 0.25 * size),
            scale(normal, 0.04 * size),
        ];
        // Vertices ±a, ±b, ±c around the centre; faces are the octants, outward.
        let mut idx = [[0u32; 2]; 3];
        for (k, axis) in axes.iter().enumerate() {
            idx[k][0] = self.vertex(add(centre, *axis));
            idx[k][1] = self.vertex(sub(centre, *axis));
        }
        for sa in 0..2 {
            for sb in 0..2 {
                for sc in 0..2 {
                    let (a, b, c) = (idx[0][sa], idx[1][sb], idx[2][sc]);
                    // (+a, +b, +c) is counter-clockwise from outside for a right-handed frame;
                    // each sign flip mirrors the octant and reverses the winding.
                    if (sa + sb + sc) % 2 == 0 {
                        self.face([a, b, c], LEAF);
                    } else {
                        self.face([a, c, b], LEAF);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_same_seed_gives_the_same_tree_and_another_seed_another() {
        let a = TreeSpec::new(7).mesh();
        assert_eq!(a, TreeSpec::new(7).mesh());
        assert_ne!(a.positions, TreeSpec::new(8).mesh().positions);
        a.validate().unwrap();
        assert_eq!(a.material_count(), 2);
        // 1 + 3 + 9 + 27 + 81 branches of 7·2 faces, 81 tips of 8 leaves of 8 faces.
        let branches = 1 + 3 + 9 + 27 + 81;
        assert_eq!(a.triangles.len(), branches * 14 + 81 * 8 * 8);
    }

    fn grower(spec: &TreeSpec) -> Grower<'_> {
        Grower {
            spec,
            rng: SplitMix(spec.seed),
            mesh: TriMesh {
                materials: Some(Vec::new()),
                ..TriMesh::default()
            },
        }
    }

    #[test]
    fn every_face_winds_outwards() {
        let spec = TreeSpec::new(3);
        // Branches in several directions: each face's normal points away from the axis.
        for dir in [
            [0.0, 1.0, 0.0],
            [1.0, 0.2, -0.3],
            [0.0, -1.0, 0.0],
            [0.3, 0.0, 1.0],
        ] {
            let dir = normalize(dir);
            let mut g = grower(&spec);
            let base = [0.5, -1.0, 2.0];
            let tip = add(base, scale(dir, 0.7));
            g.cone(base, tip, dir, 0.1, 0.06);
            let m = &g.mesh;
            assert_eq!(m.triangles.len(), 2 * usize::from(spec.sides));
            for tri in &m.triangles {
                let [a, b, c] = tri.map(|i| m.positions[i as usize]);
                let n = cross(sub(b, a), sub(c, a));
                let centroid = scale(add(add(a, b), c), 1.0 / 3.0);
                let axis = add(base, scale(dir, dot(sub(centroid, base), dir)));
                assert!(
                    dot(n, sub(centroid, axis)) > 0.0,
                    "{dir:?}: bark face inwards"
                );
            }
        }
        // Leaves: each face's normal points away from the diamond's centre.
        let mut g = grower(&spec);
        for _ in 0..50 {
            g.leaf([0.0, 1.0, 0.0], 0.2);
        }
        let m = &g.mesh;
        assert_eq!(m.triangles.len(), 50 * 8);
        for (k, tri) in m.triangles.iter().enumerate() {
            let first = k / 8 * 6;
            let centre = scale(
                m.positions[first..first + 6]
                    .iter()
                    .fold([0.0; 3], |s, p| add(s, *p)),
                1.0 / 6.0,
            );
            let [a, b, c] = tri.map(|i| m.positions[i as usize]);
            let n = cross(sub(b, a), sub(c, a));
            let centroid = scale(add(add(a, b), c), 1.0 / 3.0);
            assert!(dot(n, sub(centroid, centre)) > 0.0, "leaf face {k} inwards");
        }
    }
}
