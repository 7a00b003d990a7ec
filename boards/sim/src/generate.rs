//! Large test scans made on the spot (`pocketsplat generate`), so that anyone can measure a
//! scan-scale bake without downloading one: a sphere displaced by a few octaves of smooth bumps,
//! sampled as a scanner's range grids are (six grids, one per face of a cube projected onto it,
//! nearly even spacing, each point jittered a little, seams duplicated as merged scans have them),
//! written as a binary little-endian PLY of `float` coordinates and `uchar int` face lists (13
//! bytes a face), row by row, in bounded memory. The same arguments give the same bytes.

use std::io::{BufWriter, Write};
use std::path::Path;

use anyhow::{bail, Context, Result};
use rayon::prelude::*;

use crate::fsutil::AtomicFile;

/// Bumps summed over the sphere: (direction, frequency, phase, amplitude).
type Bump = ([f64; 3], f64, f64, f64);

/// A displaced sphere of about `triangles` triangles: `12 n²` for the `n` nearest.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    /// Quads per side of each cube face.
    pub n: u32,
    /// Seed of the bumps and the jitter.
    pub seed: u64,
}

impl Sphere {
    /// The sphere with the number of triangles nearest `triangles` (at least 12 × 2²).
    pub fn with_triangles(triangles: u64, seed: u64) -> Self {
        let n = ((triangles as f64 / 12.0).sqrt().round() as u32).max(2);
        Self { n, seed }
    }

    /// Triangles.
    pub fn triangles(&self) -> u64 {
        12 * u64::from(self.n).pow(2)
    }

    /// Vertices.
    pub fn vertices(&self) -> u64 {
        6 * u64::from(self.n + 1).pow(2)
    }

    /// Bytes of the PLY file.
    pub fn file_bytes(&self) -> u64 {
        self.header().len() as u64 + 12 * self.vertices() + 13 * self.triangles()
    }

    fn header(&self) -> String {
        format!(
            "ply\nformat binary_little_endian 1.0\ncomment pocketsplat generate: displaced sphere \
             n={} seed={}\nelement vertex {}\nproperty float x\nproperty float y\nproperty float \
             z\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
            self.n,
            self.seed,
            self.vertices(),
            self.triangles()
        )
    }

    /// The bumps: octaves of sines along fixed random directions, amplitude halving as the
    /// frequency doubles: within 10 % of the radius.
    fn bumps(&self) -> Vec<Bump> {
        let mut next = lcg(self.seed);
        let mut out = Vec::new();
        for octave in 0..6 {
            let f = 3.0 * f64::from(1u32 << octave);
            for _ in 0..4 {
                let d = [next(), next(), next()];
                let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt().max(1e-9);
                out.push((
                    d.map(|c| c / l),
                    f,
                    std::f64::consts::PI * next(),
                    0.012 / f64::from(1u32 << octave),
                ));
            }
        }
        out
    }

    /// Vertex `(i, j)` of cube face `face`.
    fn vertex(&self, face: u32, i: u32, j: u32, bumps: &[Bump]) -> [f32; 3] {
        let n = f64::from(self.n);
        // A little jitter in the grid, as a scanner's samples are not on a lattice; none on the
        // face's border, so that the seams meet.
        let border = i == 0 || j == 0 || i == self.n || j == self.n;
        let h = hash(self.seed, face, i, j);
        let (ju, jv) = if border {
            (0.0, 0.0)
        } else {
            (0.3 * h.0, 0.3 * h.1)
        };
        // tan warps the cube face so that the sphere's samples are nearly evenly spaced.
        // The cube's edges exactly (tan(π/4) is not 1 in f64), so that the faces' copies of a
        // seam are the same points.
        let warp = |k: u32, jitter: f64| match k {
            0 => -1.0,
            k if k == self.n => 1.0,
            k => ((2.0 * (f64::from(k) + jitter) / n - 1.0) * std::f64::consts::FRAC_PI_4).tan(),
        };
        let (u, v) = (warp(i, ju), warp(j, jv));
        let c = match face {
            0 => [1.0, v, -u],
            1 => [-1.0, v, u],
            2 => [u, 1.0, -v],
            3 => [u, -1.0, v],
            4 => [u, v, 1.0],
            _ => [-u, v, -1.0],
        };
        let l = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
        let d = c.map(|x| x / l);
        let r = 1.0
            + bumps
                .iter()
                .map(|(k, f, phase, a)| {
                    a * (f * (k[0] * d[0] + k[1] * d[1] + k[2] * d[2]) + phase).sin()
                })
                .sum::<f64>();
        d.map(|x| (x * r) as f32)
    }

    /// Writes the PLY to `path` (through a temporary name); `progress` is told the bytes written.
    ///
    /// # Errors
    /// When the file cannot be written; nothing is left at `path` then.
    pub fn write(&self, path: &Path, progress: &(dyn Fn(u64) + Sync)) -> Result<()> {
        if self.vertices() > i32::MAX as u64 {
            bail!(
                "{} vertices are too many for the PLY's int indices",
                self.vertices()
            );
        }
        let file = AtomicFile::create(path, 0)?;
        let io = |e| {
            anyhow::Error::new(e).context(format!("cannot write {}", file.tmp_path().display()))
        };
        let raw = std::fs::OpenOptions::new()
            .write(true)
            .open(file.tmp_path())
            .with_context(|| format!("cannot write {}", file.tmp_path().display()))?;
        let mut w = BufWriter::with_capacity(1 << 22, raw);
        let header = self.header();
        w.write_all(header.as_bytes()).map_err(io)?;
        let bumps = self.bumps();
        let side = self.n + 1;
        // Rows of vertices, computed in parallel a band at a time, written in order.
        const BAND: u32 = 64;
        for face in 0..6 {
            for band in (0..side).step_by(BAND as usize) {
                let rows: Vec<Vec<u8>> = (band..(band + BAND).min(side))
                    .into_par_iter()
                    .map(|j| {
                        let mut b = Vec::with_capacity(12 * side as usize);
                        for i in 0..side {
                            for c in self.vertex(face, i, j, &bumps) {
                                b.extend_from_slice(&c.to_le_bytes());
                            }
                        }
                        b
                    })
                    .collect();
                for r in rows {
                    w.write_all(&r).map_err(io)?;
                    progress(r.len() as u64);
                }
            }
        }
        for face in 0..6 {
            let base = face * side * side;
            for j in 0..self.n {
                let mut b = Vec::with_capacity(26 * self.n as usize);
                for i in 0..self.n {
                    let at = |i: u32, j: u32| (base + j * side + i) as i32;
                    for t in [
                        [at(i, j), at(i + 1, j), at(i + 1, j + 1)],
                        [at(i, j), at(i + 1, j + 1), at(i, j + 1)],
                    ] {
                        b.push(3);
                        for v in t {
                            b.extend_from_slice(&v.to_le_bytes());
                        }
                    }
                }
                w.write_all(&b).map_err(io)?;
                progress(b.len() as u64);
            }
        }
        w.flush().map_err(io)?;
        drop(w);
        file.commit()
    }
}

/// A little LCG: uniform in [−1, 1), the same sequence on every machine.
fn lcg(mut seed: u64) -> impl FnMut() -> f64 {
    move || {
        seed = seed
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }
}

/// Two numbers in [−1, 1) for a grid point (SplitMix64 of its coordinates).
fn hash(seed: u64, face: u32, i: u32, j: u32) -> (f64, f64) {
    let mut x = seed ^ (u64::from(face) << 58) ^ (u64::from(j) << 29) ^ u64::from(i);
    let mut next = || {
        x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = x;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    (next(), next())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_generated_sphere_is_a_valid_closed_mesh_of_its_size() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.ply");
        let s = Sphere::with_triangles(5000, 7);
        assert_eq!((s.n, s.triangles(), s.vertices()), (20, 4800, 2646));
        let written = std::sync::atomic::AtomicU64::new(0);
        s.write(&path, &|n| {
            written.fetch_add(n, std::sync::atomic::Ordering::Relaxed);
        })
        .unwrap();
        let len = std::fs::metadata(&path).unwrap().len();
        assert_eq!(len, s.file_bytes());
        assert_eq!(written.into_inner() + s.header().len() as u64, len);
        let mesh = crate::ply::load_mesh(&path).unwrap();
        assert_eq!(mesh.triangles.len() as u64, s.triangles());
        // Within the bumps of the unit sphere, everywhere.
        for p in &mesh.positions {
            let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
            assert!((0.9..1.1).contains(&r), "{r}");
        }
        // Closed: every edge is used twice, once each way, once the seams' copies are merged.
        let key = |v: u32| mesh.positions[v as usize].map(|c| (c + 0.0).to_bits()); // -0 is 0
        let mut edges = std::collections::HashMap::new();
        for t in &mesh.triangles {
            for k in 0..3 {
                *edges.entry((key(t[k]), key(t[(k + 1) % 3]))).or_insert(0) += 1;
            }
        }
        assert!(edges
            .iter()
            .all(|(&(a, b), &n)| n == 1 && edges.get(&(b, a)) == Some(&1)));
        // The same arguments, the same bytes.
        let again = dir.path().join("t.ply");
        s.write(&again, &|_| {}).unwrap();
        assert_eq!(
            std::fs::read(&path).unwrap(),
            std::fs::read(&again).unwrap()
        );
    }
}
