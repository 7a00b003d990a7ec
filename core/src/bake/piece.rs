//! The parts of an out-of-core ρ-grid bake that are arithmetic, not I/O (the desktop program
//! streams the triangles through them from spill files): a cell above the pieces that triangles
//! stream through ([`CellSplit`]), a piece baked alone ([`bake_piece`]), and the levels of every
//! part put back together ([`stitch`]).
//!
//! The grid is cut into *pieces*: cells whose subtrees bake alone in memory, below *coarse*
//! cells whose triangles are only streamed. A coarse cell's sample is the closest point over a
//! stream of its triangles in mesh order, and its children are the slots [`Cell::child_slots`]
//! gives each triangle; a piece is [`bake_grid`](super::bake_grid)'s recursion from its cell.
//! Both do what the in-memory bake does at the same cell with the same triangles in the same
//! order, so the levels [`stitch`] puts together are the in-memory bake's, bit for bit.

use std::vec;
use std::vec::Vec;

use super::cell::{sample_at, Cell, Closest, Surface};
use super::geom::V3;
use super::grid::{BakeOptions, BakedLevel, Ctx};

/// A coarse cell that a stream of triangles (in mesh order) passes through.
#[derive(Clone, Debug)]
pub struct CellSplit {
    /// The cell.
    pub cell: Cell,
    rho: u8,
    closest: Option<Closest<[u32; 3]>>,
    /// Triangles sent to each child slot so far.
    pub counts: Vec<u64>,
}

impl CellSplit {
    /// A cell of a grid of `rho` cells per axis per subdivision, nothing streamed yet.
    pub fn new(cell: Cell, rho: u8) -> Self {
        Self {
            cell,
            rho,
            closest: None,
            counts: vec![0; usize::from(rho).pow(3)],
        }
    }

    /// Streams a triangle (vertices `tri`, corners `c`) through the cell: it counts for the
    /// sample and `to` is called with each child slot it goes to, in slot order.
    pub fn offer(&mut self, tri: [u32; 3], c: &[V3; 3], mut to: impl FnMut(usize)) {
        let centre = self.cell.centre();
        self.closest
            .get_or_insert_with(|| Closest::new(tri))
            .offer(centre, tri, c);
        let counts = &mut self.counts;
        self.cell.child_slots(self.rho, c, |s| {
            counts[s] += 1;
            to(s);
        });
    }

    /// The cell's sample, once every triangle has been offered; `None` when none was.
    pub fn sample<S: Surface + ?Sized>(&self, surface: &S) -> Option<(u16, Option<u16>)> {
        self.closest.map(|c| sample_at(surface, c.t, 0, c.w))
    }

    /// The child mask (bit per non-empty slot).
    pub fn mask(&self) -> u128 {
        self.counts
            .iter()
            .enumerate()
            .filter(|(_, &n)| n > 0)
            .fold(0, |m, (s, _)| m | 1 << s)
    }
}

/// Bakes the subtree of `cell` from the triangles `tris` of `surface` (those that reach the cell,
/// in mesh order): its levels, the cell's first, each breadth-first.
///
/// # Panics
/// When `tris` is empty, or `cell` is below `opts.depth`.
pub fn bake_piece<S: Surface>(
    surface: &S,
    cell: Cell,
    tris: &[u32],
    opts: BakeOptions,
) -> Vec<BakedLevel> {
    assert!(!tris.is_empty() && cell.level <= opts.depth);
    let done = std::sync::atomic::AtomicU64::new(0);
    let ctx = Ctx {
        surface,
        opts,
        progress: None,
        done: &done,
        total: 0,
    };
    ctx.build(cell, tris)
}

/// A part of the grid: a coarse cell with its sample, mask and children (in slot order), or a
/// piece's levels.
#[derive(Clone, Debug, PartialEq)]
pub enum Part {
    /// A coarse cell.
    Coarse {
        /// Attribute and colour of its sample.
        sample: (u16, Option<u16>),
        /// Child mask.
        mask: u128,
        /// Its non-empty children, in slot order.
        children: Vec<Part>,
    },
    /// A piece's levels, its cell's first.
    Piece(Vec<BakedLevel>),
}

/// The levels (0..=depth) of the grid whose root is `root`: each level's cells in breadth-first
/// order, which is the order a walk of the parts in slot order meets them level by level.
pub fn stitch(root: Part, depth: u8) -> Vec<BakedLevel> {
    let mut levels = vec![BakedLevel::default(); usize::from(depth) + 1];
    let mut colors: Vec<Vec<u16>> = vec![Vec::new(); levels.len()];
    let mut any_color = false;
    let mut stack = vec![(root, 0usize)];
    // A stack of parts, children pushed in reverse: the walk is depth-first in slot order.
    while let Some((part, level)) = stack.pop() {
        match part {
            Part::Coarse {
                sample: (attr, color),
                mask,
                children,
            } => {
                levels[level].attrs.push(attr);
                levels[level].masks.push(mask);
                if let Some(c) = color {
                    colors[level].push(c);
                    any_color = true;
                }
                stack.extend(children.into_iter().rev().map(|c| (c, level + 1)));
            }
            Part::Piece(piece) => {
                for (k, l) in piece.into_iter().enumerate() {
                    let out = &mut levels[level + k];
                    out.attrs.extend_from_slice(&l.attrs);
                    out.masks.extend_from_slice(&l.masks);
                    if let Some(c) = &l.colors {
                        colors[level + k].extend_from_slice(c);
                        any_color = true;
                    }
                }
            }
        }
    }
    if any_color {
        for (l, c) in levels.iter_mut().zip(colors) {
            l.colors = Some(c);
        }
    }
    levels
}

#[cfg(all(test, feature = "qsplat"))]
mod tests {
    use super::*;
    use crate::bake::{bake_grid, corners, GridFrame, TriMesh};
    use crate::qs::write::tests::uv_sphere;

    /// A whole mesh as a surface, with the baker's vertex normals.
    struct Mesh<'a>(&'a TriMesh, Vec<V3>);

    impl Surface for Mesh<'_> {
        fn triangle(&self, t: u32) -> [u32; 3] {
            self.0.triangles[t as usize]
        }
        fn position(&self, v: u32) -> V3 {
            self.0.positions[v as usize]
        }
        fn vertex_normal(&self, v: u32) -> V3 {
            self.1[v as usize]
        }
        fn color(&self, v: u32) -> Option<[u8; 3]> {
            self.0.colors.as_ref().map(|c| c[v as usize])
        }
        fn material(&self, _: u32) -> u8 {
            0
        }
    }

    /// Cuts the grid into pieces of at most `max` triangles, each coarse cell streamed, as the
    /// desktop's out-of-core bake does with files.
    fn split(s: &Mesh<'_>, cell: Cell, tris: Vec<u32>, opts: BakeOptions, max: usize) -> Part {
        if tris.len() <= max || cell.level == opts.depth {
            return Part::Piece(bake_piece(s, cell, &tris, opts));
        }
        let mut at = CellSplit::new(cell, opts.rho);
        let mut lists = vec![Vec::new(); usize::from(opts.rho).pow(3)];
        for &t in &tris {
            at.offer(s.triangle(t), &corners(s, t), |k| lists[k].push(t));
        }
        let (sample, mask) = (at.sample(s).unwrap(), at.mask());
        let children = lists
            .into_iter()
            .enumerate()
            .filter(|(_, l)| !l.is_empty())
            .map(|(k, l)| split(s, cell.child(opts.rho, k), l, opts, max))
            .collect();
        Part::Coarse {
            sample,
            mask,
            children,
        }
    }

    #[test]
    fn pieces_stitch_into_the_in_memory_grid() {
        let mesh = uv_sphere(30, 60);
        let mut normals = vec![[0.0; 3]; mesh.positions.len()];
        let mut tris = Vec::new();
        for (t, idx) in mesh.triangles.iter().enumerate() {
            let n = crate::bake::triangle_normal(&idx.map(|i| mesh.positions[i as usize]));
            if n != [0.0; 3] {
                tris.push(t as u32);
                for &i in idx {
                    for a in 0..3 {
                        normals[i as usize][a] += n[a];
                    }
                }
            }
        }
        let s = Mesh(&mesh, normals);
        for (rho, depth, max) in [(3, 4, 40), (2, 6, 300), (3, 3, 0), (4, 3, 100)] {
            let opts = BakeOptions { rho, depth };
            let whole = bake_grid(&mesh, opts, None).unwrap();
            let frame = GridFrame::new(mesh.bounds(), opts, 0);
            let root = split(&s, frame.root(), tris.clone(), opts, max);
            assert!(matches!(root, Part::Coarse { .. }), "split at all");
            assert_eq!(
                frame.grid(stitch(root, depth)),
                whole,
                "rho {rho} depth {depth}"
            );
        }
    }
}
