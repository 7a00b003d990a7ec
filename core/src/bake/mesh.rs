//! The triangle mesh the baker reads: what every importer (PLY, procedural models, scenes) produces.

use std::vec::Vec;

/// An indexed triangle mesh in model units, Y up.
///
/// Importers fill it; [`TriMesh::validate`] checks it once before baking.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriMesh {
    /// Vertex positions.
    pub positions: Vec<[f64; 3]>,
    /// Triangles as indices into `positions`, counter-clockwise seen from outside ([`TriMesh::orient`]
    /// makes a mesh so when its file winds it otherwise).
    pub triangles: Vec<[u32; 3]>,
    /// Optional material index per triangle (0..8); `None` means material 0 everywhere.
    pub materials: Option<Vec<u8>>,
    /// Optional RGB colour per vertex; baked as RGB565 when present.
    pub colors: Option<Vec<[u8; 3]>>,
}

/// What is wrong with a mesh, naming the offending element.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshError {
    /// The mesh has no vertices or no triangles.
    Empty {
        /// Number of vertices.
        vertices: usize,
        /// Number of triangles.
        triangles: usize,
    },
    /// A vertex coordinate is NaN or infinite.
    NonFinite {
        /// Index of the vertex.
        vertex: usize,
    },
    /// A vertex coordinate is beyond ±[`MAX_COORDINATE`]: the root cube around the mesh could not be
    /// stored (`.tg` files keep it as `f32`).
    TooLarge {
        /// Index of the vertex.
        vertex: usize,
    },
    /// A triangle refers to a vertex that does not exist.
    IndexOutOfRange {
        /// Index of the triangle (face).
        face: usize,
        /// The offending vertex index.
        index: u32,
        /// Number of vertices.
        vertices: usize,
    },
    /// A material index is 8 or more.
    MaterialOutOfRange {
        /// Index of the triangle (face).
        face: usize,
        /// The offending material index.
        material: u8,
    },
    /// The materials or colours list does not have one entry per triangle / vertex.
    AttributeCount {
        /// Expected number of entries.
        expected: usize,
        /// Number found.
        found: usize,
    },
    /// Every triangle has zero area: there is no surface to sample.
    NoArea,
}

impl core::fmt::Display for MeshError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            MeshError::Empty {
                vertices,
                triangles,
            } => {
                write!(
                    f,
                    "mesh is empty ({vertices} vertices, {triangles} triangles)"
                )
            }
            MeshError::NonFinite { vertex } => {
                write!(f, "vertex {vertex} has a NaN or infinite coordinate")
            }
            MeshError::TooLarge { vertex } => write!(
                f,
                "vertex {vertex} has a coordinate beyond ±{MAX_COORDINATE:e}, too large to bake"
            ),
            MeshError::IndexOutOfRange {
                face,
                index,
                vertices,
            } => write!(
                f,
                "face {face} refers to vertex {index}, but there are only {vertices} vertices"
            ),
            MeshError::MaterialOutOfRange { face, material } => {
                write!(f, "face {face} has material {material}; at most 8 materials (0..=7) are supported")
            }
            MeshError::AttributeCount { expected, found } => {
                write!(f, "attribute list has {found} entries, expected {expected}")
            }
            MeshError::NoArea => write!(f, "every triangle has zero area"),
        }
    }
}

impl std::error::Error for MeshError {}

/// Largest coordinate magnitude a mesh may have: the root cube around it (twice as wide at most)
/// must fit in an `f32`, whose largest value is about 3.4e38.
pub const MAX_COORDINATE: f64 = 1e38;

/// Largest material index plus one that a `.tg` file can carry (3 material bits).
pub const MAX_MATERIALS: u8 = 8;

impl TriMesh {
    /// Checks the mesh once: finite coordinates within ±[`MAX_COORDINATE`], indices in range,
    /// attribute counts, some area.
    ///
    /// # Errors
    /// The first problem found, naming the vertex or face.
    pub fn validate(&self) -> Result<(), MeshError> {
        if self.positions.is_empty() || self.triangles.is_empty() {
            return Err(MeshError::Empty {
                vertices: self.positions.len(),
                triangles: self.triangles.len(),
            });
        }
        if let Some(vertex) = self
            .positions
            .iter()
            .position(|p| p.iter().any(|c| !c.is_finite()))
        {
            return Err(MeshError::NonFinite { vertex });
        }
        if let Some(vertex) = self
            .positions
            .iter()
            .position(|p| p.iter().any(|c| c.abs() > MAX_COORDINATE))
        {
            return Err(MeshError::TooLarge { vertex });
        }
        let n = self.positions.len();
        for (face, t) in self.triangles.iter().enumerate() {
            if let Some(&index) = t.iter().find(|&&i| i as usize >= n) {
                return Err(MeshError::IndexOutOfRange {
                    face,
                    index,
                    vertices: n,
                });
            }
        }
        if let Some(m) = &self.materials {
            if m.len() != self.triangles.len() {
                return Err(MeshError::AttributeCount {
                    expected: self.triangles.len(),
                    found: m.len(),
                });
            }
            if let Some(face) = m.iter().position(|&x| x >= MAX_MATERIALS) {
                return Err(MeshError::MaterialOutOfRange {
                    face,
                    material: m[face],
                });
            }
        }
        if let Some(c) = &self.colors {
            if c.len() != n {
                return Err(MeshError::AttributeCount {
                    expected: n,
                    found: c.len(),
                });
            }
        }
        if !self.triangles.iter().any(|t| self.area2(t) > 0.0) {
            return Err(MeshError::NoArea);
        }
        Ok(())
    }

    /// Axis-aligned bounding box of the referenced vertices: (min, max).
    pub fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for t in &self.triangles {
            for &i in t {
                let p = self.positions[i as usize];
                for a in 0..3 {
                    lo[a] = lo[a].min(p[a]);
                    hi[a] = hi[a].max(p[a]);
                }
            }
        }
        (lo, hi)
    }

    /// The bounding box rounded outwards to f32, as `.tg` files store it: the box whose centre and
    /// half-diagonal define the views' bounding sphere, for the mesh and its bakes alike.
    pub fn bounds_f32(&self) -> [[f32; 3]; 2] {
        let (lo, hi) = self.bounds();
        bounds_f32(lo, hi)
    }

    /// Number of distinct materials used (1 when there is no material list).
    pub fn material_count(&self) -> u8 {
        match &self.materials {
            None => 1,
            Some(m) => m.iter().copied().max().map_or(1, |x| x + 1),
        }
    }

    /// Twice the area of a triangle (the length of the edge cross product).
    pub(crate) fn area2(&self, t: &[u32; 3]) -> f64 {
        let [a, b, c] = t.map(|i| self.positions[i as usize]);
        let n = super::geom::cross(super::geom::sub(b, a), super::geom::sub(c, a));
        super::geom::dot(n, n).sqrt()
    }
}

/// The box `(lo, hi)` rounded outwards to f32 ([`TriMesh::bounds_f32`]).
pub fn bounds_f32(lo: [f64; 3], hi: [f64; 3]) -> [[f32; 3]; 2] {
    let down = |x: f64| {
        let f = x as f32;
        if f64::from(f) > x {
            f.next_down()
        } else {
            f
        }
    };
    let up = |x: f64| {
        let f = x as f32;
        if f64::from(f) < x {
            f.next_up()
        } else {
            f
        }
    };
    [lo.map(down), hi.map(up)]
}
