//! Baking triangle meshes into hierarchical point files (desktop only, `bake` feature).
//!
//! Duguet & Drettakis §4.1: every non-empty cell of the ρ-grid, interior or leaf, gets a sample at the
//! point of the mesh closest to the cell centre, with the interpolated mesh normal there.

// Geometry reads best with explicit axis indices (x, y, z), which this lint would rewrite.
#![allow(clippy::needless_range_loop)]

pub mod cone;
mod geom;
mod grid;
mod mesh;

pub use grid::{bake_grid, BakeOptions, BakeProgress, BakedGrid, BakedLevel, PreciseCube};
pub use mesh::{MeshError, TriMesh, MAX_COORDINATE, MAX_MATERIALS};
