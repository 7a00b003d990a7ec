//! Simple meshes built in code, whose answers (areas, shadows, silhouettes) can be worked out by
//! hand: a box, a UV sphere, a square, and one mesh made of several. Tests of the reference renderer
//! and of shadows draw them; the demo's trefoil knot is [`crate::demo::trefoil`].

use pocketsplat_core::bake::TriMesh;
use pocketsplat_core::camera::Vec3;

/// Appends `other` to `mesh`.
pub fn merge(mut mesh: TriMesh, other: &TriMesh) -> TriMesh {
    let base = mesh.positions.len() as u32;
    mesh.positions.extend(&other.positions);
    mesh.triangles
        .extend(other.triangles.iter().map(|t| t.map(|i| i + base)));
    mesh
}

/// The square `[-h, h]²` at height `y`, facing +Y.
pub fn square(h: f64, y: f64) -> TriMesh {
    TriMesh {
        positions: vec![[-h, y, -h], [h, y, -h], [h, y, h], [-h, y, h]],
        triangles: vec![[0, 2, 1], [0, 3, 2]],
        ..TriMesh::default()
    }
}

/// An axis-aligned box with outward faces and no shared vertices between faces, so that each face
/// is shaded with its own normal.
pub fn boxmesh(lo: Vec3, hi: Vec3) -> TriMesh {
    let mut mesh = TriMesh::default();
    for axis in 0..3 {
        for positive in [false, true] {
            let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
            let c = if positive { hi[axis] } else { lo[axis] };
            let corner = |i: usize, j: usize| {
                let mut p = [0.0; 3];
                p[axis] = c;
                p[a] = if i == 0 { lo[a] } else { hi[a] };
                p[b] = if j == 0 { lo[b] } else { hi[b] };
                p
            };
            let n = mesh.positions.len() as u32;
            mesh.positions
                .extend([corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)]);
            // (a, b, axis) is right-handed, so (0,0) → (1,0) → (1,1) faces +axis.
            if positive {
                mesh.triangles
                    .extend([[n, n + 1, n + 2], [n, n + 2, n + 3]]);
            } else {
                mesh.triangles
                    .extend([[n, n + 2, n + 1], [n, n + 3, n + 2]]);
            }
        }
    }
    mesh
}

/// A UV sphere of radius `r` about `center`: `rings + 1` rings of `segs` vertices from pole to pole
/// (the poles' vertices repeated), faces outward.
pub fn uv_sphere(center: Vec3, r: f64, rings: u32, segs: u32) -> TriMesh {
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for j in 0..=rings {
        let th = std::f64::consts::PI * f64::from(j) / f64::from(rings);
        for i in 0..segs {
            let ph = 2.0 * std::f64::consts::PI * f64::from(i) / f64::from(segs);
            positions.push([
                center[0] + r * th.sin() * ph.sin(),
                center[1] + r * th.cos(),
                center[2] + r * th.sin() * ph.cos(),
            ]);
        }
    }
    let v = |i: u32, j: u32| j * segs + i % segs;
    for j in 0..rings {
        for i in 0..segs {
            triangles.push([v(i, j), v(i, j + 1), v(i + 1, j + 1)]);
            triangles.push([v(i, j), v(i + 1, j + 1), v(i + 1, j)]);
        }
    }
    TriMesh {
        positions,
        triangles,
        ..TriMesh::default()
    }
}
