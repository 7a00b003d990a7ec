//! Baking triangle meshes into hierarchical point files (desktop only, `bake` feature).
//!
//! Duguet & Drettakis §4.1: every non-empty cell of the ρ-grid, interior or leaf, gets a sample at the
//! point of the mesh closest to the cell centre, with the interpolated mesh normal there.

// Geometry reads best with explicit axis indices (x, y, z), which this lint would rewrite.
#![allow(clippy::needless_range_loop)]

mod cell;
pub mod cone;
mod geom;
mod grid;
mod mesh;
pub mod orient;
pub mod piece;

pub use piece::{bake_piece, stitch, CellSplit, Part};

pub use cell::{corners, sample_at, Cell, Closest, Surface};
pub use geom::triangle_normal;
pub use grid::{
    bake_grid, BakeOptions, BakeProgress, BakedGrid, BakedLevel, GridFrame, PreciseCube,
};
pub use mesh::{bounds_f32, MeshError, TriMesh, MAX_COORDINATE, MAX_MATERIALS};
pub use orient::{orientation_flips, Facing, Orientation};
