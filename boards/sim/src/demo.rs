//! The built-in demo model (`pocketsplat` with no arguments): a trefoil-knot tube generated here, so
//! the first run needs no download, baked at depth 5 in memory ([`demo_tg`]). The command line
//! shows it in a window, or writes a PNG when there is no display. Tests, reports and fuzz targets
//! use the knot as a model that needs no file.

use std::f64::consts::TAU;

use anyhow::Result;
use pocketsplat_core::bake::{BakeOptions, TriMesh};

/// A trefoil knot as a closed tube: `segments` rings of `sides` vertices.
pub fn trefoil(segments: usize, sides: usize, tube: f64) -> TriMesh {
    let curve = |t: f64| {
        [
            t.sin() + 2.0 * (2.0 * t).sin(),
            t.cos() - 2.0 * (2.0 * t).cos(),
            -(3.0 * t).sin(),
        ]
    };
    let mut positions = Vec::with_capacity(segments * sides);
    for i in 0..segments {
        let t = TAU * i as f64 / segments as f64;
        let p = curve(t);
        let q = curve(t + 1e-4);
        let tangent = normalize(sub(q, p));
        // A frame around the tangent (the curve never runs along Z for long enough to matter).
        let side = normalize(cross(tangent, [0.3, 0.5, 1.0]));
        let up = cross(side, tangent);
        for j in 0..sides {
            let a = TAU * j as f64 / sides as f64;
            let (s, c) = (a.sin(), a.cos());
            positions.push([
                p[0] + tube * (c * side[0] + s * up[0]),
                p[1] + tube * (c * side[1] + s * up[1]),
                p[2] + tube * (c * side[2] + s * up[2]),
            ]);
        }
    }
    let mut triangles = Vec::with_capacity(segments * sides * 2);
    for i in 0..segments {
        let i2 = (i + 1) % segments;
        for j in 0..sides {
            let j2 = (j + 1) % sides;
            let v = |a: usize, b: usize| (a * sides + b) as u32;
            triangles.push([v(i, j), v(i2, j), v(i2, j2)]);
            triangles.push([v(i, j), v(i2, j2), v(i, j2)]);
        }
    }
    TriMesh {
        positions,
        triangles,
        materials: None,
        colors: None,
    }
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn normalize(a: [f64; 3]) -> [f64; 3] {
    let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    [a[0] / l, a[1] / l, a[2] / l]
}

/// Bakes the demo model into `.tg` bytes.
///
/// # Errors
/// Never for the built-in model; bake errors are passed on.
pub fn demo_tg() -> Result<Vec<u8>> {
    let mesh = trefoil(600, 32, 0.45);
    let (_, bytes) = crate::bake::bake_mesh(&mesh, BakeOptions { rho: 3, depth: 5 }, 12, true)?;
    Ok(bytes)
}

/// The model the core's documentation and examples draw (`core/examples/data/trefoil.tg`): the demo
/// trefoil at depth 4 in 512-byte blocks, small enough to link into a firmware example, without
/// bricks (`bake --layout unbricked`: a file drawn in place from flash) (a test holds the committed
/// file equal to this bake: `tests/tests/example_model.rs`).
///
/// # Errors
/// Never for the built-in model; bake errors are passed on.
pub fn example_tg() -> Result<Vec<u8>> {
    use pocketsplat_core::tg::write::{write_tg_as, Layout};
    let mesh = trefoil(300, 16, 0.45);
    let (grid, _) = crate::bake::bake_mesh(&mesh, BakeOptions { rho: 3, depth: 4 }, 9, false)?;
    Ok(write_tg_as(&grid, 9, Layout::Unbricked)?)
}
