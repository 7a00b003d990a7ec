//! A very large input, measured once by hand, never in CI (issue 9): a generated binary PLY of a
//! bumpy torus with `POCKETSPLAT_LARGE_TRIANGLES` triangles (default 50 M, about 950 MB), baked by
//! `pocketsplat bake` under `/usr/bin/time -v` so that its progress bar, wall time and peak RSS are
//! printed:
//!
//! ```text
//! cargo test --release -p pocketsplat-sim --test all large_mesh:: -- --ignored --nocapture
//! ```
//!
//! `POCKETSPLAT_LARGE_DIR` sets the working folder (default: the system's temporary folder); the PLY
//! is kept there for reruns and the `.tg` is removed afterwards.
//!
//! Measured on 2026-12-01 (2 cores, 24 GB, shared with a CI run and QEMU builds, so the job got
//! 50 % of one core's worth on average): 50 M triangles, 25 M vertices, a 950 MB PLY written in
//! 11.5 s; `pocketsplat bake` loaded it in 18.0 s and baked depth 6 in 74.1 s (1.67 M samples,
//! 4.2 MB `.tg`), 1 min 32 s wall, peak RSS 2.24 GB.

use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::process::Command;

/// Writes a closed torus of `rings × sides` quads (two triangles each), radii 1 and 0.35, with a
/// small ripple so that normals vary at every scale, as binary little-endian PLY.
fn write_torus(path: &Path, rings: u32, sides: u32) -> std::io::Result<()> {
    let mut w = BufWriter::with_capacity(1 << 22, std::fs::File::create(path)?);
    let vertices = u64::from(rings) * u64::from(sides);
    write!(
        w,
        "ply\nformat binary_little_endian 1.0\ncomment pocketsplat large-input test: torus {rings}x{sides}\n\
         element vertex {vertices}\nproperty float x\nproperty float y\nproperty float z\n\
         element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        2 * vertices
    )?;
    let tau = std::f64::consts::TAU;
    for i in 0..rings {
        let u = tau * f64::from(i) / f64::from(rings);
        for j in 0..sides {
            let v = tau * f64::from(j) / f64::from(sides);
            let r = 0.35 * (1.0 + 0.02 * (37.0 * u).sin() * (11.0 * v).sin());
            let p = [
                (1.0 + r * v.cos()) * u.cos(),
                r * v.sin(),
                (1.0 + r * v.cos()) * u.sin(),
            ];
            for c in p {
                w.write_all(&(c as f32).to_le_bytes())?;
            }
        }
    }
    let id = |i: u32, j: u32| ((i % rings) * sides + j % sides) as i32;
    for i in 0..rings {
        for j in 0..sides {
            for t in [
                [id(i, j), id(i, j + 1), id(i + 1, j + 1)],
                [id(i, j), id(i + 1, j + 1), id(i + 1, j)],
            ] {
                w.write_all(&[3])?;
                for k in t {
                    w.write_all(&k.to_le_bytes())?;
                }
            }
        }
    }
    w.flush()
}

#[test]
#[ignore = "generates a ~1 GB mesh and bakes it: run by hand, see the file's docs"]
fn bake_a_very_large_mesh() {
    let triangles: u64 = std::env::var("POCKETSPLAT_LARGE_TRIANGLES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(50_000_000);
    let dir = std::env::var_os("POCKETSPLAT_LARGE_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(std::env::temp_dir);
    // rings = 4 × sides keeps the quads near square on this torus.
    let sides = ((triangles / 8) as f64).sqrt().round().max(3.0) as u32;
    let rings = (triangles / (2 * u64::from(sides))).max(3) as u32;
    let ply = dir.join(format!("pocketsplat-torus-{rings}x{sides}.ply"));
    if !ply.is_file() {
        let t = std::time::Instant::now();
        write_torus(&ply, rings, sides).unwrap();
        eprintln!(
            "wrote {} in {:.1} s",
            ply.display(),
            t.elapsed().as_secs_f64()
        );
    }
    let out = dir.join("pocketsplat-large.tg");
    let status = Command::new("/usr/bin/time")
        .arg("-v")
        .arg(env!("CARGO_BIN_EXE_pocketsplat"))
        .args(["bake", ply.to_str().unwrap(), "-o", out.to_str().unwrap()])
        // Past the default limits (32M triangles, 1G of bake memory): see the README's Limits.
        .args(["--limits", "vertices=1G,triangles=1G", "--force"])
        .status()
        .expect("/usr/bin/time runs");
    let _ = std::fs::remove_file(&out);
    assert!(status.success(), "bake failed: {status}");
}
