//! A ground plane stored as a point set: a flat square mesh baked like any other object.
//!
//! The plane is `y = 0`, centred on the origin. Its root cube (the bounding box's largest extent,
//! centred on the box) puts the plane through the middle of the cube's middle layer of cells at
//! every level — for ρ = 3 no cell boundary is ever at the cube's centre — so each cell crossed by
//! the plane has exactly ρ² non-empty children: α = 9 exactly for a tri-grid, and level `L` holds
//! `9^L` samples.

use pocketsplat_core::bake::TriMesh;
use serde::Deserialize;

/// `ground = { size = 4.0, tiles = 8 }`.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GroundSpec {
    /// Side of the square, model units.
    pub size: f64,
    /// Tiles per side: with two materials the tiles alternate (a checkerboard); with one they only
    /// split the mesh.
    #[serde(default = "one")]
    pub tiles: u32,
}

fn one() -> u32 {
    1
}

impl GroundSpec {
    /// Checks the numbers.
    ///
    /// # Errors
    /// A message naming the bad field.
    pub fn check(&self) -> Result<(), String> {
        if !(self.size > 0.0 && self.size < 1e9) {
            return Err(format!("size {}: must be positive", self.size));
        }
        if !(1..=256).contains(&self.tiles) {
            return Err(format!("tiles {}: must be 1..=256", self.tiles));
        }
        Ok(())
    }

    /// The plane's mesh; `checker` alternates material indices 0 and 1 between tiles.
    pub fn mesh(&self, checker: bool) -> TriMesh {
        let n = self.tiles as usize;
        let half = 0.5 * self.size;
        let step = self.size / n as f64;
        let coord = |i: usize| {
            if i == n {
                half
            } else {
                -half + i as f64 * step
            }
        };
        let mut positions = Vec::with_capacity((n + 1) * (n + 1));
        for k in 0..=n {
            for i in 0..=n {
                positions.push([coord(i), 0.0, coord(k)]);
            }
        }
        let at = |i: usize, k: usize| (k * (n + 1) + i) as u32;
        let mut triangles = Vec::with_capacity(2 * n * n);
        let mut materials = Vec::with_capacity(2 * n * n);
        for k in 0..n {
            for i in 0..n {
                // Counter-clockwise seen from above (+Y): the normal points up.
                triangles.push([at(i, k), at(i, k + 1), at(i + 1, k + 1)]);
                triangles.push([at(i, k), at(i + 1, k + 1), at(i + 1, k)]);
                let m = u8::from(checker && (i + k) % 2 == 1);
                materials.extend([m, m]);
            }
        }
        TriMesh {
            positions,
            triangles,
            materials: checker.then_some(materials),
            colors: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use pocketsplat_core::bake::{bake_grid, BakeOptions};

    #[test]
    fn a_flat_plane_bakes_with_alpha_exactly_nine() {
        for tiles in [1, 4] {
            let g = GroundSpec { size: 2.0, tiles };
            let mesh = g.mesh(tiles > 1);
            mesh.validate().unwrap();
            let grid = bake_grid(&mesh, BakeOptions { rho: 3, depth: 4 }, None).unwrap();
            for (l, level) in grid.levels.iter().enumerate() {
                assert_eq!(
                    level.attrs.len(),
                    9usize.pow(l as u32),
                    "tiles {tiles} level {l}"
                );
            }
            for l in 0..4 {
                assert_eq!(grid.alpha(l), Some(9.0));
            }
            // Every sample's normal points up.
            let up = pocketsplat_core::normal::encode([0.0, 1.0, 0.0]);
            assert!(grid
                .levels
                .iter()
                .all(|l| l.attrs.iter().all(|&a| a & 0x1FFF == up)));
        }
    }

    #[test]
    fn tiles_alternate_materials_only_when_asked() {
        let g = GroundSpec {
            size: 1.0,
            tiles: 3,
        };
        let m = g.mesh(true);
        assert_eq!(m.material_count(), 2);
        assert_eq!(g.mesh(false).materials, None);
        assert!(GroundSpec {
            size: -1.0,
            tiles: 1
        }
        .check()
        .is_err());
        assert!(GroundSpec {
            size: 1.0,
            tiles: 0
        }
        .check()
        .is_err());
    }
}
