//! Meshes wound the other way, or both ways (issue 30): a mesh file whose triangles are all
//! reversed, or reversed at random, loads wound outward (core `bake::orient`), so its bake, the
//! integer renderer and the f64 reference agree, and it renders at the PSNR of the same mesh wound
//! the usual way. Real PLY files on disk, read by the importer every command uses; a real scan
//! (the decimated Stanford bunny, with its duplicate slivers and fins) and models made here: a
//! thin tube, a flat ground, a rough rock.

use std::path::Path;

use pocketsplat_core::bake::{bake_grid, BakeOptions, TriMesh};
use pocketsplat_core::tg::write::write_tg;
use pocketsplat_sim::image::decode_rgb8_png;
use pocketsplat_sim::metrics::psnr_rgb8;
use pocketsplat_sim::render::Settings;
use pocketsplat_sim::snapshot::render_file;
use pocketsplat_sim::{demo, ply};

use crate::common::{model, write_ply};

/// `m` with every triangle reversed, or (`mixed`) about half of them, chosen by a fixed hash.
fn rewound(m: &TriMesh, mixed: bool) -> TriMesh {
    let mut out = m.clone();
    for (k, t) in out.triangles.iter_mut().enumerate() {
        let h = (k as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 40;
        if !mixed || h & 1 == 1 {
            t.swap(1, 2);
        }
    }
    out
}

/// A flat ground facing up (+Y), `n × n` quads, as a scene's ground is modelled.
fn ground(n: u32) -> TriMesh {
    let mut m = TriMesh::default();
    for i in 0..=n {
        for j in 0..=n {
            let (x, z) = (
                f64::from(i) / f64::from(n) * 2.0 - 1.0,
                f64::from(j) / f64::from(n) * 2.0 - 1.0,
            );
            m.positions.push([x, 0.0, z]);
        }
    }
    let v = |i: u32, j: u32| i * (n + 1) + j;
    for i in 0..n {
        for j in 0..n {
            // Counter-clockwise seen from above.
            m.triangles.push([v(i, j), v(i, j + 1), v(i + 1, j + 1)]);
            m.triangles.push([v(i, j), v(i + 1, j + 1), v(i + 1, j)]);
        }
    }
    m
}

/// A ground with a hollow in it (a crater, a valley): its signed volume says down, a ground is up.
fn hollow_ground(n: u32) -> TriMesh {
    let mut m = ground(n);
    for p in &mut m.positions {
        p[1] = -0.5 * (-(p[0] * p[0] + p[2] * p[2]) / 0.2).exp();
    }
    m
}

/// A rough rock: a sphere of `n` rings displaced by a fixed bumpy pattern, wound outward.
fn rock(n: usize) -> TriMesh {
    let mut m = pocketsplat_sim::report::stability::blob(n);
    for (k, p) in m.positions.iter_mut().enumerate() {
        let bump =
            1.0 + 0.06 * (((k as u64).wrapping_mul(0x2545_F491_4F6C_DD1D) >> 58) as f64 / 63.0);
        *p = p.map(|x| x * bump);
    }
    m
}

/// The std view at 1 px of `mesh` baked at depth 6, as RGB8.
fn device_frame(mesh: &TriMesh, dir: &Path, name: &str) -> Vec<[u8; 3]> {
    let grid = bake_grid(mesh, BakeOptions { rho: 3, depth: 6 }, None).unwrap();
    let tg = dir.join(format!("{name}.tg"));
    std::fs::write(&tg, write_tg(&grid, 12).unwrap()).unwrap();
    frame(&tg, dir, name)
}

/// The std view at 1 px of the file at `path` (a `.tg`, or a PLY for the f64 reference), as RGB8.
fn frame(path: &Path, dir: &Path, name: &str) -> Vec<[u8; 3]> {
    let png = dir.join(format!("{name}.png"));
    render_file(path, &png, &Settings::default()).unwrap();
    decode_rgb8_png(&std::fs::read(&png).unwrap())
        .unwrap()
        .pixels
}

/// The PSNR of `mesh` written as a PLY and read back through the importer every command uses,
/// baked and drawn, against the f64 reference of the same file; and that reference.
fn psnr_through_files(mesh: &TriMesh, dir: &Path, name: &str) -> (f64, Vec<[u8; 3]>) {
    let ply_path = dir.join(format!("{name}.ply"));
    write_ply(mesh, &ply_path);
    let reference = frame(&ply_path, dir, &format!("{name}-ref"));
    let loaded = ply::load_mesh(&ply_path).unwrap();
    let device = device_frame(&loaded, dir, name);
    (psnr_rgb8(&reference, &device), reference)
}

fn check(name: &str, mesh: &TriMesh) {
    let dir = tempfile::tempdir().unwrap();
    let (normal, reference) = psnr_through_files(mesh, dir.path(), name);
    let (reversed, _) =
        psnr_through_files(&rewound(mesh, false), dir.path(), &format!("{name}-rev"));
    let (mixed, _) = psnr_through_files(&rewound(mesh, true), dir.path(), &format!("{name}-mixed"));
    // Baked as filed, not oriented (what happened before): the device culls what faces the eye
    // and lights the inside, and the frame is far from what the user should see.
    let raw = device_frame(&rewound(mesh, false), dir.path(), "raw");
    let unoriented = psnr_rgb8(&reference, &raw);
    println!(
        "{name}: normal {normal:.2} dB, reversed {reversed:.2} dB, mixed {mixed:.2} dB \
         (reversed, baked as filed: {unoriented:.2} dB)"
    );
    assert!(
        (reversed - normal).abs() <= 0.3,
        "{name}: reversed {reversed:.2} vs {normal:.2} dB"
    );
    assert!(
        (mixed - normal).abs() <= 0.3,
        "{name}: mixed {mixed:.2} vs {normal:.2} dB"
    );
    assert!(
        unoriented < normal - 1.0,
        "{name}: the reversed mesh baked as filed ({unoriented:.2} dB) should show the defect"
    );
}

#[test]
fn a_thin_tube_wound_either_way_renders_alike() {
    check("tube", &demo::trefoil(160, 8, 0.08));
}

#[test]
fn a_flat_ground_wound_either_way_renders_alike() {
    check("ground", &ground(24));
}

#[test]
fn a_ground_with_a_hollow_wound_either_way_renders_alike() {
    check("hollow", &hollow_ground(32));
}

#[test]
fn a_rough_rock_wound_either_way_renders_alike() {
    check("rock", &rock(24));
}

#[test]
fn scans_wound_either_way_render_alike() {
    for name in ["bun_zipper_res4.ply", "dragon_vrip_res4.ply.gz"] {
        let Some(path) = model(name) else {
            return;
        };
        // As filed: outward, which orientation keeps (not a triangle turned).
        let mesh = ply::load_mesh(&path).unwrap();
        check(name, &mesh);
    }
}

/// A scan reversed orients to the scan's own triangles, one for one (the full bunny: one closed
/// patch; the decimated dragon: 40 patches, fins along edges of four triangles, duplicates and
/// specks): what the bake, the device and the reference then see is the same mesh exactly.
#[test]
fn scans_reversed_orient_to_their_own_triangles() {
    for name in ["bun_zipper.ply.gz", "dragon_vrip_res2.ply.gz"] {
        let Some(path) = model(name) else {
            return;
        };
        let mesh = ply::load_mesh(&path).unwrap();
        let mut reversed = rewound(&mesh, false);
        let report = reversed.orient();
        assert_eq!(reversed, mesh, "{name}: {report:?}");
        assert_eq!(report.flipped, mesh.triangles.len(), "{name}");
    }
}
