//! The first pass of an out-of-core bake: the PLY read once, its vertices kept in memory as
//! compactly as their type allows and its faces spilled to disk in order, then checked as
//! [`TriMesh::validate`](pocketsplat_core::bake::TriMesh::validate) checks a mesh in memory, in
//! the same order, so that a bad mesh gets the same error either way.

use std::path::Path;

use anyhow::Result;
use pocketsplat_core::bake::{Facing, MeshError, MAX_COORDINATE};

use super::spill::{SpillDir, SpillWriter, Spilled};
use crate::limits::Limits;
use crate::ply::{self, MeshSink, PlyError};

/// Vertex positions: `f32` when every coordinate's type fits one exactly (a scanner's `float`),
/// else `f64`; read back as `f64`, the same values either way.
pub enum Positions {
    /// Exact in `f32`.
    F32(Vec<[f32; 3]>),
    /// `f64`.
    F64(Vec<[f64; 3]>),
}

impl Positions {
    /// Position `v`.
    #[inline]
    pub fn get(&self, v: u32) -> [f64; 3] {
        match self {
            Positions::F32(p) => p[v as usize].map(f64::from),
            Positions::F64(p) => p[v as usize],
        }
    }

    /// Number of vertices.
    pub fn len(&self) -> usize {
        match self {
            Positions::F32(p) => p.len(),
            Positions::F64(p) => p.len(),
        }
    }

    /// Bytes a vertex takes.
    pub fn bytes_per_vertex(exact_f32: bool) -> u64 {
        if exact_f32 {
            12
        } else {
            24
        }
    }
}

/// A scanned mesh: vertices in memory, faces in a spill file.
pub struct Scan {
    /// The mesh file, as errors name it.
    pub file: String,
    /// Positions.
    pub positions: Positions,
    /// Colours, when the vertices have them.
    pub colors: Option<Vec<[u8; 3]>>,
    /// The faces, in order.
    pub faces: Spilled,
}

impl Scan {
    /// The error for face `face` (of vertices `t`) when it refers to a vertex that does not
    /// exist, as [`TriMesh::validate`](pocketsplat_core::bake::TriMesh::validate) words it.
    ///
    /// # Errors
    /// [`MeshError::IndexOutOfRange`], naming the file.
    pub fn check_face(&self, face: u64, t: [u32; 3]) -> Result<(), PlyError> {
        let n = self.positions.len();
        match t.iter().find(|&&i| i as usize >= n) {
            Some(&index) => Err(self.mesh_error(MeshError::IndexOutOfRange {
                face: face as usize,
                index,
                vertices: n,
            })),
            None => Ok(()),
        }
    }

    /// A mesh error, naming the file.
    pub fn mesh_error(&self, error: MeshError) -> PlyError {
        PlyError::Mesh {
            file: self.file.clone(),
            error,
        }
    }
}

/// The sink that fills a [`Scan`].
struct Sink {
    file: String,
    positions: Positions,
    colors: Option<Vec<[u8; 3]>>,
    faces: Option<SpillWriter>,
    read: usize,
    non_finite: Option<usize>,
    too_large: Option<usize>,
}

impl MeshSink for Sink {
    fn begin_vertices(
        &mut self,
        count: usize,
        color: bool,
        exact_f32: bool,
    ) -> Result<(), PlyError> {
        // The count was checked against the budget before the body was read; what is reserved
        // is what the body then fills.
        self.positions = if exact_f32 {
            Positions::F32(Vec::with_capacity(count))
        } else {
            Positions::F64(Vec::with_capacity(count))
        };
        if color {
            self.colors = Some(Vec::with_capacity(count));
        }
        Ok(())
    }

    fn vertex(&mut self, p: [f64; 3], color: [u8; 3]) -> Result<(), PlyError> {
        if self.non_finite.is_none() && p.iter().any(|c| !c.is_finite()) {
            self.non_finite = Some(self.read);
        }
        if self.too_large.is_none() && p.iter().any(|c| c.abs() > MAX_COORDINATE) {
            self.too_large = Some(self.read);
        }
        match &mut self.positions {
            // `exact_f32`: the value came from an f32 or a small integer, so the cast is exact.
            Positions::F32(v) => v.push(p.map(|c| c as f32)),
            Positions::F64(v) => v.push(p),
        }
        if let Some(c) = &mut self.colors {
            c.push(color);
        }
        self.read += 1;
        Ok(())
    }

    fn begin_faces(&mut self, _: usize) -> Result<(), PlyError> {
        Ok(())
    }

    fn face(&mut self, _: usize, t: [u32; 3]) -> Result<(), PlyError> {
        let Some(w) = &mut self.faces else {
            return Ok(());
        };
        w.push(t).map_err(|e| PlyError::Sink {
            file: self.file.clone(),
            what: format!("cannot write the spill file {}: {e}", w.path().display()),
        })
    }
}

/// Whether the mesh, taken whole, winds inward ([`Facing`] over every face): then every later
/// pass reads its faces turned. The in-memory importer decides per consistent patch
/// ([`TriMesh::orient`](pocketsplat_core::bake::TriMesh::orient)); out of core the edges are not
/// all at hand, so the mesh turns whole or not at all: the in-memory bytes for a file wound
/// outward or inward throughout, not for one wound both ways. Faces with an index past the
/// vertices are left to the pass that reports them.
fn wound_inward(s: &Scan) -> Result<bool> {
    let mut facing = Facing::default();
    let n = s.positions.len();
    s.faces.for_each(|t| {
        if t.iter().all(|&v| (v as usize) < n) {
            facing.add(t.map(|v| s.positions.get(v)));
        }
        Ok(())
    })?;
    Ok(facing.outward() == Some(false))
}

/// Reads `path` within `limits`: vertices into memory, faces into a spill file of `spill`;
/// `read` is told the bytes of the file as they are read. Then checks what
/// [`TriMesh::validate`](pocketsplat_core::bake::TriMesh::validate) checks of the vertices (the
/// faces' indices and areas are checked by the pass that reads them back).
///
/// # Errors
/// The PLY's errors, naming the file; an empty mesh, a non-finite or too large coordinate.
pub fn scan(
    path: &Path,
    limits: &Limits,
    spill: &SpillDir,
    read: &(dyn Fn(u64) + Sync),
) -> Result<Scan> {
    let file = path.display().to_string();
    let mut sink = Sink {
        file: file.clone(),
        positions: Positions::F32(Vec::new()),
        colors: None,
        faces: Some(spill.file("faces")?),
        read: 0,
        non_finite: None,
        too_large: None,
    };
    ply::read_file_counted(path, limits, &mut sink, read)?;
    let faces = sink.faces.take().map(SpillWriter::finish).transpose()?;
    let faces = faces.expect("the writer is there until now");
    let scan = Scan {
        file,
        positions: sink.positions,
        colors: sink.colors,
        faces,
    };
    let (vertices, triangles) = (scan.positions.len(), scan.faces.count as usize);
    if vertices == 0 || triangles == 0 {
        return Err(scan
            .mesh_error(MeshError::Empty {
                vertices,
                triangles,
            })
            .into());
    }
    if let Some(vertex) = sink.non_finite {
        return Err(scan.mesh_error(MeshError::NonFinite { vertex }).into());
    }
    if let Some(vertex) = sink.too_large {
        return Err(scan.mesh_error(MeshError::TooLarge { vertex }).into());
    }
    let mut scan = scan;
    scan.faces.turned = wound_inward(&scan)?;
    Ok(scan)
}
