//! The suite's meshes, generated here, so that it needs no model files: a bumpy unit blob, one
//! triangle, a plane, a needle, a stiff cluster with outliers, a thin wire.

use pocketsplat_core::bake::TriMesh;
use pocketsplat_core::camera::Vec3;

pub(super) fn mesh(positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> TriMesh {
    TriMesh {
        positions,
        triangles,
        materials: None,
        colors: None,
    }
}

/// A closed bumpy sphere of radius about 1, a little off the origin so that its bounds are not round
/// numbers: the "unit model" of the camera cases.
pub fn blob(n: usize) -> TriMesh {
    use std::f64::consts::PI;
    let mut positions = Vec::new();
    for i in 0..=n {
        let th = PI * i as f64 / n as f64;
        for j in 0..2 * n {
            let ph = PI * j as f64 / n as f64;
            let r = 1.0 + 0.12 * (3.0 * th).sin() * (4.0 * ph).cos() + 0.05 * (7.0 * ph).sin();
            positions.push([
                0.137 + r * th.sin() * ph.cos(),
                -0.071 + 0.9 * r * th.cos(),
                0.029 + r * th.sin() * ph.sin(),
            ]);
        }
    }
    let v = |i: usize, j: usize| (i * 2 * n + j % (2 * n)) as u32;
    let mut triangles = Vec::new();
    for i in 0..n {
        for j in 0..2 * n {
            // Counter-clockwise seen from outside.
            triangles.push([v(i, j), v(i + 1, j + 1), v(i + 1, j)]);
            triangles.push([v(i, j), v(i, j + 1), v(i + 1, j + 1)]);
        }
    }
    mesh(positions, triangles)
}

/// One triangle in general position.
pub fn single_triangle() -> TriMesh {
    mesh(
        vec![[0.1, 0.2, 0.3], [1.3, -0.4, 0.7], [-0.6, 0.9, -1.1]],
        vec![[0, 1, 2]],
    )
}

/// The square `[-1, 1]²` in the plane y = 0, facing +Y: the root cube's middle layer, so every cell
/// has exactly ρ² children (α = 9 for a tri-grid).
pub fn flat_plane() -> TriMesh {
    mesh(
        vec![
            [-1.0, 0.0, -1.0],
            [1.0, 0.0, -1.0],
            [1.0, 0.0, 1.0],
            [-1.0, 0.0, 1.0],
        ],
        vec![[0, 2, 1], [0, 3, 2]],
    )
}

/// A needle: a triangle 2 long and 2·10⁻⁴ wide (aspect 10⁴) along X.
pub fn needle() -> TriMesh {
    mesh(
        vec![[-1.0, -1e-4, 0.0], [1.0, 0.0, 0.0], [-1.0, 1e-4, 1e-5]],
        vec![[0, 1, 2]],
    )
}

/// The stiff case: a dense sphere of radius 10⁻⁶ at the origin (1 800 triangles) and eight small
/// triangles 1 away at the corners of the cube `[-1, 1]³`: scale ratio 10⁶.
pub fn cluster_with_outliers() -> TriMesh {
    let mut m = blob(30);
    let c = m.positions.len();
    for p in &mut m.positions {
        *p = p.map(|x| x * 1e-6);
    }
    for k in 0..8u32 {
        let s = [k & 1, k >> 1 & 1, k >> 2 & 1].map(|b| if b == 1 { 1.0 } else { -1.0 });
        let base = m.positions.len() as u32;
        m.positions.push(s);
        m.positions.push([s[0] * 0.999, s[1], s[2]]);
        m.positions.push([s[0], s[1] * 0.999, s[2]]);
        m.triangles.push([base, base + 1, base + 2]);
    }
    debug_assert!(m.positions.len() == c + 24);
    m
}

/// A thin tube along a trefoil knot (tube radius 10⁻⁴ of the knot's size): a curve, so even a depth-9
/// grid has few cells (the "tiny mesh" of the deep bakes).
pub fn wire() -> TriMesh {
    let mut m = crate::demo::trefoil(240, 3, 5e-4);
    // The knot is about 6 across; keep it in general position.
    for p in &mut m.positions {
        *p = [p[0] + 0.0123, p[1] - 0.0456, p[2] + 0.0789];
    }
    m
}

/// `m` with every vertex mapped by `f`.
pub(super) fn transformed(m: &TriMesh, f: impl Fn(Vec3) -> Vec3) -> TriMesh {
    TriMesh {
        positions: m.positions.iter().map(|&p| f(p)).collect(),
        ..m.clone()
    }
}
