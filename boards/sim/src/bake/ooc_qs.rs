//! A `.qs` bake out of core: the PLY read once (vertices in memory, faces spilled), a pass over
//! the faces for each vertex's radius and normal sum, then the tree's top split over point ids
//! alone until each part fits the budget, and the parts (pieces) built, placed and written
//! straight into the output file where the breadth-first layout puts them
//! (`core/src/qs/pieces.rs`): the same bytes as the in-memory bake.
//!
//! Memory: per vertex its position (12 bytes for `float` coordinates, 24 for `double`), radius
//! (8) and normal sum (24), per point its id (4), and one piece per thread at a time (about 400
//! bytes a point while it is built). The file is never held whole.

use std::path::Path;

use anyhow::{bail, Context, Result};
use pocketsplat_core::bake::MeshError;
use pocketsplat_core::qs::pieces::{
    accumulate, triangle_contribution, PieceErrors, PieceRoot, Point, PointSource, QsPlan,
};
use pocketsplat_core::qs::write::{QsBakeOptions, QsStats};
use rayon::prelude::*;

use super::budget::{free_disk, human};
use super::ooc_tg::BASE_BYTES;
use super::progress::{Phases, Unit};
use super::scan::{scan, Positions};
use super::spill::{SpillDir, TRIANGLE_BYTES};
use super::OocOptions;
use crate::fsutil::AtomicFile;
use crate::limits::Limits;

/// Bytes a point takes while its piece is built (the builder's nodes, about 1.33 a point, the
/// points and ids).
const PIECE_BYTES_PER_POINT: u64 = 400;
/// Bytes per vertex besides its position: radius, normal sum, id.
const POINT_BYTES: u64 = 8 + 24 + 4;
/// Fewest points a piece is cut to, whatever the budget.
pub const MIN_PIECE_POINTS: u64 = 64;
/// Most points a piece has, whatever the budget: a piece is built on one core, so a few large
/// pieces leave a core idle at the end and miss the caches (measured: 16 M points in 4 pieces of
/// 4 M took 78 s to build and write, 50 M in 64 pieces of up to 1.2 M 129 s).
pub const MAX_PIECE_POINTS: u64 = 1 << 20;

/// A `.qs` file baked out of core.
pub struct OocQs {
    /// Its statistics.
    pub stats: QsStats,
    /// Whether it has colours.
    pub color: bool,
    /// Pieces it was built in.
    pub pieces: usize,
    /// Points of the largest.
    pub largest_piece: u64,
    /// The phases' names and times.
    pub phases: Vec<(&'static str, std::time::Duration)>,
    /// The file wound inward and was read turned (`scan`'s facing pass).
    pub turned: bool,
}

/// The points: every vertex's position, radius and normal sum (a vertex with radius 0 is no
/// point).
struct Points<'a> {
    positions: &'a Positions,
    radius: Vec<f64>,
    nsum: Vec<[f64; 3]>,
    colors: Option<&'a [[u8; 3]]>,
}

impl PointSource for Points<'_> {
    fn position(&self, id: u32) -> [f64; 3] {
        self.positions.get(id)
    }
    fn point(&self, id: u32) -> Point {
        let i = id as usize;
        Point {
            p: self.positions.get(id),
            r: self.radius[i],
            n: self.nsum[i],
            rgb: self.colors.map_or([0.0; 3], |c| c[i].map(f64::from)),
        }
    }
}

/// Bakes the mesh at `path` into the `.qs` file `out` out of core within `o.budget` bytes.
///
/// # Errors
/// The mesh's errors (naming the file), a budget or disk too small for it (said before either is
/// used up), and I/O errors of the spill files and the output (naming them); nothing is left at
/// `out` then.
pub fn bake_qs(
    path: &Path,
    out: &Path,
    opts: &QsBakeOptions,
    o: &OocOptions,
    limits: &Limits,
) -> Result<OocQs> {
    let name = path.display();
    let counts = crate::ply::read_counts(path, limits)?;
    let per_vertex = Positions::bytes_per_vertex(counts.exact_f32)
        + POINT_BYTES
        + if counts.color { 3 } else { 0 };
    let fixed = counts
        .vertices
        .saturating_mul(per_vertex)
        .saturating_add(BASE_BYTES);
    let threads = rayon::current_num_threads() as u64;
    let least = fixed + threads * MIN_PIECE_POINTS * PIECE_BYTES_PER_POINT;
    if least > o.budget {
        bail!(
            "{name}: cannot bake out of core within --memory {}: its {} vertices need at least {} \
             (raise --memory)",
            human(o.budget),
            counts.vertices,
            human(least)
        );
    }
    let spill_parent = o.spill_parent(out);
    // The faces' spill file, and the output (about 5.3 bytes a vertex, 8 with colours).
    let disk = counts.faces.saturating_mul(TRIANGLE_BYTES) + counts.vertices.saturating_mul(8);
    if let Some(free) = free_disk(&spill_parent) {
        if disk > free {
            bail!(
                "{name}: an out-of-core bake of its {} faces needs about {} of disk for its spill \
                 file and output, but {} has {} free (choose another folder with --spill-dir)",
                counts.faces,
                human(disk),
                spill_parent.display(),
                human(free)
            );
        }
    }
    let out_name = out
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let spill = SpillDir::create(&spill_parent, &out_name)?;
    let mut phases = Phases::new(5, o.progress);
    let file_len = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
    let bar = phases.start("reading", file_len, Unit::Bytes);
    let s = scan(path, limits, &spill, &|n| bar.inc(n))?;
    let turned = s.faces.turned;

    // Each vertex's radius and normal sum, over the faces in order.
    let bar = phases.start("points", s.faces.count, Unit::Triangles);
    let nv = s.positions.len();
    let mut radius = vec![0.0f64; nv];
    let mut nsum = vec![[0.0f64; 3]; nv];
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    let (mut face, mut area) = (0u64, false);
    s.faces.for_each(|t| {
        s.check_face(face, t)?;
        face += 1;
        if face.is_multiple_of(1 << 16) {
            bar.inc(1 << 16);
        }
        let p = t.map(|v| s.positions.get(v));
        for c in &p {
            for a in 0..3 {
                lo[a] = lo[a].min(c[a]);
                hi[a] = hi[a].max(c[a]);
            }
        }
        let contribution = triangle_contribution(p);
        let n = contribution.1;
        area |= (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt() > 0.0;
        for &v in &t {
            let v = v as usize;
            accumulate(&mut radius[v], &mut nsum[v], contribution);
        }
        Ok(())
    })?;
    if !area {
        return Err(s.mesh_error(MeshError::NoArea).into());
    }
    let ids: Vec<u32> = (0..nv as u32)
        .filter(|&v| radius[v as usize] > 0.0)
        .collect();
    let points = Points {
        positions: &s.positions,
        radius,
        nsum,
        colors: s.colors.as_deref(),
    };
    let color = opts.colors && points.colors.is_some();

    let bar = phases.start("planning", ids.len() as u64, Unit::Points);
    let room = o.budget.saturating_sub(fixed);
    let max = o.piece_limit.map_or(
        (room / threads / PIECE_BYTES_PER_POINT).clamp(MIN_PIECE_POINTS, MAX_PIECE_POINTS),
        |n| n.max(1),
    );
    let n_points = ids.len() as u64;
    let plan = QsPlan::new(
        &points,
        ids,
        usize::try_from(max).unwrap_or(usize::MAX),
        color,
    )
    .with_context(|| format!("{name}: cannot bake"))?;
    bar.inc(n_points);
    let largest_piece = (0..plan.pieces())
        .map(|k| plan.piece_points(k) as u64)
        .max()
        .unwrap_or(0);

    let bar = phases.start("building pieces", n_points, Unit::Points);
    let roots: Vec<PieceRoot> = (0..plan.pieces())
        .into_par_iter()
        .map(|k| {
            let r = plan.measure(&points, k);
            bar.inc(plan.piece_points(k) as u64);
            r
        })
        .collect();
    let bounds = pocketsplat_core::bake::bounds_f32(lo, hi);
    let arr = plan
        .arrange(&roots, opts, bounds)
        .with_context(|| format!("{name}: cannot bake"))?;
    drop(roots);
    if let Some(free) = free_disk(&spill_parent) {
        if arr.file_len > free {
            bail!(
                "{}: the file would be {} but the disk has {} free",
                out.display(),
                human(arr.file_len),
                human(free)
            );
        }
    }

    let bar = phases.start("writing pieces", n_points, Unit::Points);
    let file = AtomicFile::create(out, arr.file_len)?;
    let io = |e: std::io::Error| {
        anyhow::Error::new(e).context(format!("cannot write {}", file.tmp_path().display()))
    };
    for (at, bytes) in &arr.head {
        file.write_at(*at, bytes).map_err(io)?;
    }
    let errors: Vec<PieceErrors> = (0..plan.pieces())
        .into_par_iter()
        .map(|k| {
            let e = plan.write_piece(&points, k, &arr, &mut |at, b| file.write_at(at, b));
            bar.inc(plan.piece_points(k) as u64);
            e.map_err(io)
        })
        .collect::<Result<_>>()?;
    drop(points);
    drop(s);
    drop(spill);
    file.commit()?;
    let stats = arr.finish(&errors);
    let (_, phases) = phases.finish();
    Ok(OocQs {
        stats,
        color,
        pieces: plan.pieces(),
        largest_piece,
        phases,
        turned,
    })
}
