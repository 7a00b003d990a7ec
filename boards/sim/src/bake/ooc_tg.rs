//! A `.tg` bake out of core: the PLY read once (vertices in memory, faces spilled), a pass for
//! the vertex normals, then the grid cut into pieces that fit the budget: each cell with more
//! triangles than a piece may hold streams them from its spill file into its children's
//! (`CellSplit`, its sample taken on the way), down to cells small enough, which bake alone in
//! memory, two at a time. The levels are stitched in file order and written as the in-memory
//! bake writes them: the same bytes (`core/src/bake/piece.rs`).
//!
//! Memory: the vertices (12 bytes a vertex for `float` coordinates, 24 for `double`) and their
//! normals (24), one piece per thread, and the grid itself, which the `.tg` writer lays out
//! whole (about 4 bytes a sample, and 32 while it is written): the grid, not the mesh, is what
//! bounds the depth of a bake under a budget.

use std::path::Path;

use anyhow::{bail, Context, Result};
use pocketsplat_core::bake::{
    bake_piece, stitch, triangle_normal, BakeOptions, BakedGrid, Cell, CellSplit, GridFrame,
    MeshError, Part, Surface,
};
use rayon::prelude::*;

use super::budget::{free_disk, human};
use super::progress::{Phases, Unit};
use super::scan::{scan, Positions, Scan};
use super::spill::{SpillDir, Spilled, TRIANGLE_BYTES};
use super::OocOptions;
use crate::limits::Limits;

/// Bytes a piece needs per triangle: the triangle, its place in every list down its cells, and
/// its share of the piece's levels while they are merged.
const PIECE_BYTES_PER_TRIANGLE: u64 = 96;
/// Bytes of the grid per sample while it is written (levels, normal cones, the file).
const WRITE_BYTES_PER_SAMPLE: u64 = 32;
/// Fewest triangles a piece is cut to, whatever the budget: below that the passes cost more
/// than the memory they save.
pub const MIN_PIECE_TRIANGLES: u64 = 256;
/// The program, its buffers and threads.
pub const BASE_BYTES: u64 = 32 << 20;

/// A grid baked out of core, and what it took.
pub struct OocGrid {
    /// The grid.
    pub grid: BakedGrid,
    /// Pieces it was cut into.
    pub pieces: usize,
    /// Triangles of the largest.
    pub largest_piece: u64,
    /// The phases' names and times.
    pub phases: Vec<(&'static str, std::time::Duration)>,
    /// The file wound inward and was read turned (`scan`'s facing pass).
    pub turned: bool,
}

/// The vertices' normals, summed in mesh order as the in-memory baker sums them.
struct Surf<'a> {
    positions: &'a Positions,
    normals: &'a [[f64; 3]],
    colors: Option<&'a [[u8; 3]]>,
}

/// A piece's triangles over the mesh's vertices.
struct PieceSurface<'a> {
    mesh: &'a Surf<'a>,
    tris: Vec<[u32; 3]>,
}

impl Surface for Surf<'_> {
    fn triangle(&self, _: u32) -> [u32; 3] {
        unreachable!("coarse cells sample through CellSplit, with the triangle's vertices")
    }
    fn position(&self, v: u32) -> [f64; 3] {
        self.positions.get(v)
    }
    fn vertex_normal(&self, v: u32) -> [f64; 3] {
        self.normals[v as usize]
    }
    fn color(&self, v: u32) -> Option<[u8; 3]> {
        self.colors.map(|c| c[v as usize])
    }
    fn material(&self, _: u32) -> u8 {
        0
    }
}

impl Surface for PieceSurface<'_> {
    fn triangle(&self, t: u32) -> [u32; 3] {
        self.tris[t as usize]
    }
    fn position(&self, v: u32) -> [f64; 3] {
        self.mesh.position(v)
    }
    fn vertex_normal(&self, v: u32) -> [f64; 3] {
        self.mesh.vertex_normal(v)
    }
    fn color(&self, v: u32) -> Option<[u8; 3]> {
        self.mesh.color(v)
    }
    fn material(&self, _: u32) -> u8 {
        0
    }
}

/// A cell of the cut: coarse (streamed) with its children, or piece `k`.
enum Node {
    Coarse {
        sample: (u16, Option<u16>),
        mask: u128,
        children: Vec<Node>,
    },
    Piece(usize),
}

/// What the cut makes: the tree of cells and the pieces (cell, spill) in file order.
struct Cut<'a> {
    surf: &'a Surf<'a>,
    spill: &'a SpillDir,
    rho: u8,
    depth: u8,
    max: u64,
    bar: &'a indicatif::ProgressBar,
}

impl Cut<'_> {
    /// Cuts `cell`, whose triangles are `source` (only those with area when `root`).
    fn cell(
        &self,
        cell: Cell,
        source: Spilled,
        root: bool,
    ) -> Result<(Node, Vec<(Cell, Spilled)>)> {
        if source.count <= self.max || cell.level == self.depth {
            return Ok((Node::Piece(0), vec![(cell, source)]));
        }
        let mut at = CellSplit::new(cell, self.rho);
        let mut writers: Vec<Option<super::spill::SpillWriter>> =
            (0..usize::from(self.rho).pow(3)).map(|_| None).collect();
        let mut written = 0u64;
        source.for_each(|t| {
            let c = t.map(|v| self.surf.positions.get(v));
            if root && !has_area(&c) {
                return Ok(());
            }
            let mut failed = None;
            at.offer(t, &c, |s| {
                let w = match &mut writers[s] {
                    Some(w) => w,
                    slot => match self.spill.file("cell") {
                        Ok(w) => slot.insert(w),
                        Err(e) => {
                            failed = Some(e);
                            return;
                        }
                    },
                };
                if let Err(e) = w.push(t) {
                    failed = Some(anyhow::Error::new(e).context(format!(
                        "cannot write the spill file {}",
                        w.path().display()
                    )));
                }
            });
            written += 1;
            if written.is_multiple_of(1 << 16) {
                self.bar.inc(1 << 16);
            }
            failed.map_or(Ok(()), Err)
        })?;
        self.bar.inc(written % (1 << 16));
        source.remove();
        let sample = at.sample(self.surf).context("a cell with no triangle")?;
        let mask = at.mask();
        let spilled: Vec<(usize, Spilled)> = writers
            .into_iter()
            .enumerate()
            .filter_map(|(s, w)| w.map(|w| (s, w)))
            .map(|(s, w)| Ok((s, w.finish()?)))
            .collect::<Result<_>>()?;
        // The children's cuts are independent: each reads its own spill file.
        let cuts: Vec<(Node, Vec<(Cell, Spilled)>)> = spilled
            .into_par_iter()
            .map(|(s, f)| self.cell(cell.child(self.rho, s), f, false))
            .collect::<Result<_>>()?;
        let mut pieces = Vec::new();
        let mut children = Vec::with_capacity(cuts.len());
        for (mut node, p) in cuts {
            renumber(&mut node, pieces.len());
            pieces.extend(p);
            children.push(node);
        }
        Ok((
            Node::Coarse {
                sample,
                mask,
                children,
            },
            pieces,
        ))
    }
}

/// Whether a triangle has area, as the in-memory baker decides it.
fn has_area(c: &[[f64; 3]; 3]) -> bool {
    let n = triangle_normal(c);
    n[0] * n[0] + n[1] * n[1] + n[2] * n[2] > 0.0
}

/// Adds `by` to every piece number below `node`.
fn renumber(node: &mut Node, by: usize) {
    match node {
        Node::Piece(k) => *k += by,
        Node::Coarse { children, .. } => children.iter_mut().for_each(|c| renumber(c, by)),
    }
}

/// The parts of `node`, with each piece's levels taken from `levels`.
fn parts(node: Node, levels: &mut [Option<Vec<pocketsplat_core::bake::BakedLevel>>]) -> Part {
    match node {
        Node::Piece(k) => Part::Piece(levels[k].take().unwrap_or_default()),
        Node::Coarse {
            sample,
            mask,
            children,
        } => Part::Coarse {
            sample,
            mask,
            children: children.into_iter().map(|c| parts(c, levels)).collect(),
        },
    }
}

/// Samples a grid of `depth` is expected to have over a surface of `area` in a root cube of
/// `side`: the leaves a surface of that area crosses (about 1.5 cells per cell-face of area, for a
/// surface at any angle to the grid), and the levels above them, α = ρ² times fewer each
/// (Duguet §4.3).
fn expected_samples(area: f64, side: f64, opts: BakeOptions) -> u64 {
    let rho = f64::from(opts.rho);
    let cell = side / rho.powi(i32::from(opts.depth));
    let leaves = (1.5 * area / (cell * cell)).min(rho.powi(3 * i32::from(opts.depth)));
    (leaves * rho * rho / (rho * rho - 1.0)).min(u64::MAX as f64) as u64
}

/// Bakes the mesh at `path` out of core within `o.budget` bytes.
///
/// # Errors
/// The mesh's errors (naming the file), a budget or disk too small for it (said before either is
/// used up), and I/O errors of the spill files (naming them).
pub fn bake_tg(
    path: &Path,
    out: &Path,
    opts: BakeOptions,
    o: &OocOptions,
    limits: &Limits,
) -> Result<OocGrid> {
    let name = path.display();
    let counts = crate::ply::read_counts(path, limits)?;
    let per_vertex =
        Positions::bytes_per_vertex(counts.exact_f32) + 24 + if counts.color { 3 } else { 0 };
    let vertex_bytes = counts.vertices.saturating_mul(per_vertex);
    if vertex_bytes.saturating_add(BASE_BYTES) > o.budget {
        bail!(
            "{name}: cannot bake out of core within --memory {}: its {} vertices alone need {} \
             (raise --memory)",
            human(o.budget),
            counts.vertices,
            human(vertex_bytes + BASE_BYTES)
        );
    }
    let spill_parent = o.spill_parent(out);
    // The faces, then at most two levels of cells' copies of them (each with the triangles that
    // straddle cells twice, ~10 %).
    let disk = counts
        .faces
        .saturating_mul(TRIANGLE_BYTES)
        .saturating_mul(3);
    if let Some(free) = free_disk(&spill_parent) {
        if disk > free {
            bail!(
                "{name}: an out-of-core bake of its {} faces needs about {} of disk for spill \
                 files, but {} has {} free (choose another folder with --spill-dir)",
                counts.faces,
                human(disk),
                spill_parent.display(),
                human(free)
            );
        }
    }
    let spill = SpillDir::create(
        &spill_parent,
        &out.file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default(),
    )?;
    let mut phases = Phases::new(5, o.progress);
    let file_len = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
    let bar = phases.start("reading", file_len, Unit::Bytes);
    let s = scan(path, limits, &spill, &|n| bar.inc(n))?;
    let turned = s.faces.turned;

    let bar = phases.start("normals", s.faces.count, Unit::Triangles);
    let (normals, bounds, area) = normals(&s, &bar)?;
    let frame = GridFrame::new(bounds, opts, 0);
    let samples = expected_samples(area, frame.side, opts);
    let grid_bytes = samples.saturating_mul(WRITE_BYTES_PER_SAMPLE);
    let fixed = BASE_BYTES + vertex_bytes;
    let threads = rayon::current_num_threads() as u64;
    let room = o
        .budget
        .saturating_sub(fixed)
        .saturating_sub(grid_bytes / 8);
    let max = o.piece_limit.map_or(
        (room / threads / PIECE_BYTES_PER_TRIANGLE).max(MIN_PIECE_TRIANGLES),
        |n| n.max(1),
    );
    if grid_bytes
        .max(fixed + grid_bytes / 8 + threads * MIN_PIECE_TRIANGLES * PIECE_BYTES_PER_TRIANGLE)
        > o.budget
    {
        bail!(
            "{name}: depth {} would make about {} samples and need about {} of memory to write, \
             over --memory {} (bake less deep, raise --memory, or bake in memory with --force)",
            opts.depth,
            samples,
            human(grid_bytes.max(fixed + grid_bytes / 8)),
            human(o.budget)
        );
    }

    let surf = Surf {
        positions: &s.positions,
        normals: &normals,
        colors: s.colors.as_deref(),
    };
    let bar = phases.start("partitioning", s.faces.count, Unit::Triangles);
    let cut = Cut {
        surf: &surf,
        spill: &spill,
        rho: opts.rho,
        depth: opts.depth,
        max,
        bar: &bar,
    };
    let faces = Spilled {
        path: s.faces.path.clone(),
        count: s.faces.count,
        turned: s.faces.turned,
    };
    let (tree, pieces) = cut.cell(frame.root(), faces, true)?;

    let total: u64 = pieces.iter().map(|(_, f)| f.count).sum();
    let largest_piece = pieces.iter().map(|(_, f)| f.count).max().unwrap_or(0);
    let bar = phases.start("baking pieces", total, Unit::Triangles);
    let n_pieces = pieces.len();
    let mut levels: Vec<Option<_>> = pieces
        .into_par_iter()
        .map(|(cell, f)| {
            let mut tris = f.read_all()?;
            let n = tris.len() as u64;
            f.remove();
            // Only the root's spill (the faces) can hold triangles without area.
            tris.retain(|t| has_area(&t.map(|v| surf.positions.get(v))));
            let idx: Vec<u32> = (0..tris.len() as u32).collect();
            let piece = PieceSurface { mesh: &surf, tris };
            let baked = bake_piece(&piece, cell, &idx, opts);
            bar.inc(n);
            Ok(Some(baked))
        })
        .collect::<Result<_>>()?;
    drop(s);
    drop(normals);

    let bar = phases.start("stitching", 1, Unit::Triangles);
    let grid = frame.grid(stitch(parts(tree, &mut levels), opts.depth));
    bar.inc(1);
    let (_, phases) = phases.finish();
    Ok(OocGrid {
        grid,
        pieces: n_pieces,
        largest_piece,
        phases,
        turned,
    })
}

/// What the pass over the faces finds: vertex normals, the box of the referenced vertices, the
/// area.
type Normals = (Vec<[f64; 3]>, ([f64; 3], [f64; 3]), f64);

/// The pass over the faces: each index checked, the area-weighted vertex normals summed in face
/// order (those of faces with area), the box of the referenced vertices, and the total area.
fn normals(s: &Scan, bar: &indicatif::ProgressBar) -> Result<Normals> {
    let mut normals = vec![[0.0f64; 3]; s.positions.len()];
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    let (mut face, mut with_area, mut area) = (0u64, 0u64, 0.0f64);
    s.faces.for_each(|t| {
        s.check_face(face, t)?;
        face += 1;
        if face.is_multiple_of(1 << 16) {
            bar.inc(1 << 16);
        }
        let c = t.map(|v| s.positions.get(v));
        for p in &c {
            for a in 0..3 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
        let n = triangle_normal(&c);
        let l2 = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
        if l2 > 0.0 {
            with_area += 1;
            area += 0.5 * l2.sqrt();
            for &v in &t {
                let vn = &mut normals[v as usize];
                for a in 0..3 {
                    vn[a] += n[a];
                }
            }
        }
        Ok(())
    })?;
    if with_area == 0 {
        return Err(s.mesh_error(MeshError::NoArea).into());
    }
    Ok((normals, (lo, hi), area))
}
