//! The ρ-grid baker (Duguet & Drettakis §4): recursive subdivision of the root cube, a sample at every
//! non-empty cell, levels in breadth-first order. Subtrees below the second level bake in parallel.

use std::vec;
use std::vec::Vec;

use rayon::prelude::*;

use super::cell::{corners, sample_at, Cell, Closest, Surface};
use super::geom::{cross, dot, sub, V3};
use super::mesh::{MeshError, TriMesh};

/// What to bake.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BakeOptions {
    /// Cells per axis per subdivision: 2 (octree), 3 (tri-grid), 4 or 5.
    pub rho: u8,
    /// Number of subdivisions (ρ^depth cells per axis). The paper's level L is depth L + 1.
    pub depth: u8,
}

impl Default for BakeOptions {
    fn default() -> Self {
        Self { rho: 3, depth: 6 }
    }
}

/// One level of a baked grid, in breadth-first order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BakedLevel {
    /// Attribute per sample: normal code (13 bits) | material << 13.
    pub attrs: Vec<u16>,
    /// RGB565 per sample, when the mesh has vertex colours.
    pub colors: Option<Vec<u16>>,
    /// Child mask per cell (bit `i + ρ(j + ρk)`), empty at the leaf level.
    pub masks: Vec<u128>,
}

/// A baked ρ-grid, ready for [`crate::tg::write::write_tg`].
#[derive(Clone, Debug, PartialEq)]
pub struct BakedGrid {
    /// Cells per axis per subdivision.
    pub rho: u8,
    /// Material bits per attribute (0 for one material).
    pub material_bits: u8,
    /// Minimum corner of the root cube (exactly representable as f32).
    pub origin: [f64; 3],
    /// Side of the root cube (exactly representable as f32).
    pub side: f64,
    /// Bounding box of the mesh (min, max), rounded outwards to f32.
    pub bounds: [[f32; 3]; 2],
    /// The root cube and bounding box in `f64`, when the `f32` cube above is too coarse for the
    /// mesh (far from its origin: at 10⁷ the `f32` spacing is 1): the grid is then built on this
    /// cube, the file stores it too (FORMAT.md, flag bit 2) and `origin`, `side` and `bounds` are
    /// an `f32` cube and box that contain it, for readers that do not know the flag.
    pub precise: Option<PreciseCube>,
    /// Levels 0..=depth.
    pub levels: Vec<BakedLevel>,
    /// Store normal cones in the file (ρ = 3 only; FORMAT.md), so that the traversal culls
    /// subtrees that face away from the eye. On by default.
    pub cones: bool,
}

/// A root cube and bounding box in `f64` ([`BakedGrid::precise`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PreciseCube {
    /// Minimum corner.
    pub origin: [f64; 3],
    /// Side.
    pub side: f64,
    /// Bounding box of the mesh (min, max).
    pub bounds: [[f64; 3]; 2],
}

/// Largest slack, as a fraction of the side, that the `f32` root cube may add around the mesh's
/// box (beyond its largest extent, or off its centre) before the grid is built on the `f64` cube
/// instead: 2⁻¹⁶, far above the `f32` rounding of a mesh near its origin (~2⁻²³), so that such
/// bakes (every Stanford scan, every scene) keep their `f32` cube and their bytes.
const MAX_F32_SLACK: f64 = 1.0 / 65536.0;

impl BakedGrid {
    /// The root cube the grid is built on: the precise one when there is one.
    pub fn root_cube(&self) -> ([f64; 3], f64) {
        match &self.precise {
            Some(p) => (p.origin, p.side),
            None => (self.origin, self.side),
        }
    }

    /// Number of subdivisions.
    pub fn depth(&self) -> u8 {
        (self.levels.len() - 1) as u8
    }
    /// α per level: the mean number of non-empty children of a cell at that level (§4.3).
    pub fn alpha(&self, level: usize) -> Option<f64> {
        let next = self.levels.get(level + 1)?;
        Some(next.attrs.len() as f64 / self.levels[level].attrs.len() as f64)
    }
}

/// Progress of a bake: called with (cells finished, cells in all) at the parallel level.
pub type BakeProgress<'a> = &'a (dyn Fn(u64, u64) + Sync);

/// Below this level subtrees are independent tasks.
const PARALLEL_LEVELS: u8 = 2;

/// A whole [`TriMesh`] as the baker's [`Surface`], with its area-weighted vertex normals.
struct WholeMesh<'m> {
    mesh: &'m TriMesh,
    vertex_normals: Vec<V3>,
}

impl Surface for WholeMesh<'_> {
    fn triangle(&self, t: u32) -> [u32; 3] {
        self.mesh.triangles[t as usize]
    }
    fn position(&self, v: u32) -> V3 {
        self.mesh.positions[v as usize]
    }
    fn vertex_normal(&self, v: u32) -> V3 {
        self.vertex_normals[v as usize]
    }
    fn color(&self, v: u32) -> Option<[u8; 3]> {
        self.mesh.colors.as_ref().map(|c| c[v as usize])
    }
    fn material(&self, t: u32) -> u8 {
        self.mesh.materials.as_ref().map_or(0, |m| m[t as usize])
    }
}

/// Area-weighted vertex normals (the cross products summed in triangle order) and the triangles
/// with area, in order: what [`bake_grid`] prepares once.
fn prepare(mesh: &TriMesh) -> (Vec<V3>, Vec<u32>) {
    let mut vertex_normals = vec![[0.0; 3]; mesh.positions.len()];
    let mut tris = Vec::with_capacity(mesh.triangles.len());
    for (t, idx) in mesh.triangles.iter().enumerate() {
        let [a, b, c] = idx.map(|i| mesh.positions[i as usize]);
        // The cross product's length is twice the area: summing it weights by area.
        let n = cross(sub(b, a), sub(c, a));
        if dot(n, n) > 0.0 {
            tris.push(t as u32);
            for &i in idx {
                let v = &mut vertex_normals[i as usize];
                for k in 0..3 {
                    v[k] += n[k];
                }
            }
        }
    }
    (vertex_normals, tris)
}

/// Bakes a mesh into a ρ-grid.
///
/// # Errors
/// [`MeshError`] when the mesh fails [`TriMesh::validate`].
///
/// # Panics
/// When `rho` is outside 2..=5 or `depth` above [`crate::tg::MAX_DEPTH`].
pub fn bake_grid(
    mesh: &TriMesh,
    opts: BakeOptions,
    progress: Option<BakeProgress<'_>>,
) -> Result<BakedGrid, MeshError> {
    assert!((2..=5).contains(&opts.rho), "rho must be 2..=5");
    assert!(opts.depth <= crate::tg::MAX_DEPTH, "depth too large");
    mesh.validate()?;
    let (vertex_normals, tris) = prepare(mesh);
    let material_bits = if mesh.material_count() > 1 { 3 } else { 0 };
    let surface = WholeMesh {
        mesh,
        vertex_normals,
    };
    let frame = GridFrame::new(mesh.bounds(), opts, material_bits);
    let total = u64::from(opts.rho).pow(3 * u32::from(PARALLEL_LEVELS.min(opts.depth)));
    let done = std::sync::atomic::AtomicU64::new(0);
    let ctx = Ctx {
        surface: &surface,
        opts,
        progress,
        done: &done,
        total,
    };
    let levels = ctx.build(frame.root(), &tris);
    Ok(frame.grid(levels))
}

/// The root cube of a bake and what its file stores beside the levels, from the bounding box of
/// the mesh's referenced vertices: what an out-of-core bake sets up before it has any level.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridFrame {
    /// What is baked.
    pub opts: BakeOptions,
    /// Material bits per attribute.
    pub material_bits: u8,
    /// [`BakedGrid::origin`].
    pub origin: [f64; 3],
    /// [`BakedGrid::side`].
    pub side: f64,
    /// [`BakedGrid::bounds`].
    pub bounds: [[f32; 3]; 2],
    /// [`BakedGrid::precise`].
    pub precise: Option<PreciseCube>,
}

impl GridFrame {
    /// The frame of a mesh whose referenced vertices span `(lo, hi)` ([`TriMesh::bounds`]).
    ///
    /// # Panics
    /// When `opts.rho` is outside 2..=5 or `opts.depth` above [`crate::tg::MAX_DEPTH`].
    pub fn new((lo64, hi64): ([f64; 3], [f64; 3]), opts: BakeOptions, material_bits: u8) -> Self {
        assert!((2..=5).contains(&opts.rho), "rho must be 2..=5");
        assert!(opts.depth <= crate::tg::MAX_DEPTH, "depth too large");
        // Root cube: the bounding box's largest extent, centred on the box; stored as f32, so round
        // the corner down and the side up to f32 values that still contain the mesh.
        let bounds = super::mesh::bounds_f32(lo64, hi64);
        let (lo, hi) = (bounds[0].map(f64::from), bounds[1].map(f64::from));
        let extent = (0..3).map(|a| hi[a] - lo[a]).fold(0.0, f64::max);
        let mut side = f64::from(next_up_f32(extent as f32));
        let mut origin = [0.0; 3];
        for a in 0..3 {
            let c = 0.5 * (lo[a] + hi[a]);
            origin[a] = f64::from(next_down_f32((c - 0.5 * side) as f32));
        }
        // Rounding the corner down may leave the far faces short of the box. Grow the side to the
        // smallest f32 that reaches them, in one step: stepping one f32 at a time takes billions of
        // steps for a small mesh far from the origin (the corner's rounding is then much larger
        // than the side).
        let reach = (0..3).map(|a| hi[a] - origin[a]).fold(side, f64::max);
        if reach > side {
            let s = reach as f32;
            side = f64::from(if f64::from(s) < reach { s.next_up() } else { s });
        }
        while (0..3).any(|a| origin[a] + side < hi[a]) {
            side = f64::from(next_up_f32(side as f32));
        }
        let precise = precise_cube((lo64, hi64), origin, side);
        Self {
            opts,
            material_bits,
            origin,
            side,
            bounds,
            precise,
        }
    }

    /// The root cell: on the precise cube when there is one.
    pub fn root(&self) -> Cell {
        let (min, side) = self
            .precise
            .map_or((self.origin, self.side), |p| (p.origin, p.side));
        Cell {
            level: 0,
            min,
            side,
        }
    }

    /// The grid of these levels (0..=depth, breadth-first).
    pub fn grid(&self, levels: Vec<BakedLevel>) -> BakedGrid {
        BakedGrid {
            rho: self.opts.rho,
            material_bits: self.material_bits,
            bounds: self.bounds,
            origin: self.origin,
            side: self.side,
            precise: self.precise,
            levels,
            cones: self.opts.rho == 3,
        }
    }
}

/// The `f64` root cube of a mesh with box `(lo, hi)` when the `f32` cube `(origin, side)` has more
/// slack than [`MAX_F32_SLACK`]: the box's largest extent, centred on the box, grown by an `f64`
/// step at a time until it contains the box; none when that cube's corner is more than
/// `MAX_CORNER_SIDES` sides from 0 (FORMAT.md), which the reader refuses.
fn precise_cube(
    (lo, hi): ([f64; 3], [f64; 3]),
    origin: [f64; 3],
    side: f64,
) -> Option<PreciseCube> {
    let extent = (0..3).map(|a| hi[a] - lo[a]).fold(0.0, f64::max);
    if extent.is_nan() || extent <= 0.0 {
        return None;
    }
    let centre: [f64; 3] = core::array::from_fn(|a| 0.5 * (lo[a] + hi[a]));
    let slack = (side - extent).max(
        (0..3)
            .map(|a| (origin[a] + 0.5 * side - centre[a]).abs())
            .fold(0.0, f64::max),
    );
    if slack <= MAX_F32_SLACK * side {
        return None;
    }
    let mut side = extent;
    let mut origin: [f64; 3] = core::array::from_fn(|a| centre[a] - 0.5 * side);
    for a in 0..3 {
        while origin[a] > lo[a] {
            origin[a] = origin[a].next_down();
        }
    }
    while (0..3).any(|a| origin[a] + side < hi[a]) {
        side = side.next_up();
    }
    // A cube the reader takes: its corner at most 2³² sides from 0 (a mesh tinier than that
    // against its distance from the origin keeps the f32 cube, grown to satisfy the same rule),
    // and its numbers within the f32 range the renderer draws.
    use crate::tg::read::{MAX_CORNER_SIDES, PRECISE_MAX, PRECISE_MIN_SIDE};
    if origin.iter().any(|o| o.abs() > MAX_CORNER_SIDES * side)
        || side < PRECISE_MIN_SIDE
        || origin
            .iter()
            .chain(&lo)
            .chain(&hi)
            .chain([&side])
            .any(|v| v.abs() > PRECISE_MAX)
    {
        return None;
    }
    Some(PreciseCube {
        origin,
        side,
        bounds: [lo, hi],
    })
}

/// The recursion of a bake over a [`Surface`]: [`bake_grid`]'s whole mesh, or one piece of an
/// out-of-core bake ([`super::piece::bake_piece`]).
pub(super) struct Ctx<'a, S> {
    pub(super) surface: &'a S,
    pub(super) opts: BakeOptions,
    pub(super) progress: Option<BakeProgress<'a>>,
    pub(super) done: &'a std::sync::atomic::AtomicU64,
    pub(super) total: u64,
}

impl<S: Surface> Ctx<'_, S> {
    /// Bakes the subtree of a non-empty cell; returns its levels (this cell's level first), each in
    /// breadth-first order — concatenating siblings' results level by level keeps that order.
    pub(super) fn build(&self, cell: Cell, tris: &[u32]) -> Vec<BakedLevel> {
        let rho = usize::from(self.opts.rho);
        let mut closest = Closest::new(tris[0]);
        let centre = cell.centre();
        for &t in tris {
            closest.offer(centre, t, &corners(self.surface, t));
        }
        let (t, w) = (closest.t, closest.w);
        let s = self.surface;
        let (attr, color) = sample_at(s, s.triangle(t), s.material(t), w);
        let mut here = BakedLevel {
            attrs: vec![attr],
            colors: color.map(|c| vec![c]),
            masks: Vec::new(),
        };
        if cell.level == self.opts.depth {
            return vec![here];
        }

        let mut lists: Vec<Vec<u32>> = vec![Vec::new(); rho * rho * rho];
        for &t in tris {
            cell.child_slots(self.opts.rho, &corners(self.surface, t), |s| {
                lists[s].push(t);
            });
        }
        let mut mask = 0u128;
        let mut children = Vec::new();
        for (s, list) in lists.iter().enumerate() {
            if !list.is_empty() {
                mask |= 1 << s;
                children.push((cell.child(self.opts.rho, s), s));
            }
        }
        here.masks.push(mask);
        let sub: Vec<Vec<BakedLevel>> = if cell.level < PARALLEL_LEVELS {
            children
                .par_iter()
                .map(|&(c, s)| self.build(c, &lists[s]))
                .collect()
        } else {
            children
                .iter()
                .map(|&(c, s)| self.build(c, &lists[s]))
                .collect()
        };
        if cell.level + 1 == PARALLEL_LEVELS.min(self.opts.depth) {
            // Children of this cell are the parallel tasks: count them, and the empty ones too.
            let n = (rho * rho * rho) as u64;
            let d = self.done.fetch_add(n, std::sync::atomic::Ordering::Relaxed) + n;
            if let Some(p) = self.progress {
                p(d, self.total);
            }
        }
        drop(lists);
        merge(here, sub)
    }
}

/// Concatenates children's levels after this cell's own.
pub(super) fn merge(here: BakedLevel, sub: Vec<Vec<BakedLevel>>) -> Vec<BakedLevel> {
    let depth = sub.iter().map(Vec::len).max().unwrap_or(0);
    let mut out = Vec::with_capacity(depth + 1);
    out.push(here);
    for l in 0..depth {
        let mut level = BakedLevel::default();
        let with_color = sub.iter().any(|s| s[l].colors.is_some());
        let mut colors = Vec::new();
        let n: usize = sub.iter().map(|s| s[l].attrs.len()).sum();
        level.attrs.reserve_exact(n);
        for s in &sub {
            level.attrs.extend_from_slice(&s[l].attrs);
            level.masks.extend_from_slice(&s[l].masks);
            if let Some(c) = &s[l].colors {
                colors.extend_from_slice(c);
            }
        }
        level.colors = with_color.then_some(colors);
        out.push(level);
    }
    out
}

fn next_up_f32(x: f32) -> f32 {
    let r = x.next_up();
    if x == 0.0 {
        f32::MIN_POSITIVE
    } else {
        r
    }
}

fn next_down_f32(x: f32) -> f32 {
    x.next_down()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tg::{write::write_tg, TgError, TriGrid, Verify};

    /// A unit square in the plane y = 0.5 of the cube [0,1]³ (two triangles): every level of a
    /// tri-grid has α = 9 exactly (Duguet §4.3, Fig. 2).
    fn plane() -> TriMesh {
        TriMesh {
            positions: vec![
                [0.0, 0.5, 0.0],
                [1.0, 0.5, 0.0],
                [1.0, 0.5, 1.0],
                [0.0, 0.5, 1.0],
                [0.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
            ],
            triangles: vec![[0, 2, 1], [0, 3, 2], [4, 5, 4]],
            materials: None,
            colors: None,
        }
    }

    #[test]
    fn mesh_touching_cell_boundaries_keeps_every_interior_cell_non_empty() {
        // An octahedron: its vertices lie exactly on the root cube's faces (found by the CLI tests).
        let oct = TriMesh {
            positions: vec![
                [1.0, 0.0, 0.0],
                [-1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, -1.0, 0.0],
                [0.0, 0.0, 1.0],
                [0.0, 0.0, -1.0],
            ],
            triangles: vec![
                [0, 2, 4],
                [2, 1, 4],
                [1, 3, 4],
                [3, 0, 4],
                [2, 0, 5],
                [1, 2, 5],
                [3, 1, 5],
                [0, 3, 5],
            ],
            materials: None,
            colors: None,
        };
        for rho in 2..=3 {
            for depth in 1..=5 {
                let g = bake_grid(&oct, BakeOptions { rho, depth }, None).unwrap();
                assert!(
                    g.levels.iter().flat_map(|l| &l.masks).all(|&m| m != 0),
                    "rho {rho} depth {depth}"
                );
                let bytes = write_tg(&g, 12).unwrap();
                TriGrid::open(&bytes, Verify::Full).unwrap();
            }
        }
    }

    #[test]
    fn a_mesh_far_from_its_origin_keeps_its_grid_through_the_f64_extension() {
        use crate::tg::{write::seal, FLAG_PRECISE};
        let near = bake_grid(&plane(), BakeOptions { rho: 3, depth: 3 }, None).unwrap();
        let bytes = write_tg(&near, 9).unwrap();
        let h = *TriGrid::open(&bytes, Verify::Full).unwrap().header();
        // Near the origin: the f32 cube, no extension, the f64 fields are the f32 ones.
        assert!(near.precise.is_none() && !h.has_precise());
        assert_eq!(h.origin64, h.origin.map(f64::from));
        assert_eq!(h.side64, f64::from(h.side));
        assert_eq!(h.bounds64, h.bounds.map(|c| c.map(f64::from)));

        let t = [1e7, -3e7, 2.5e6];
        let mut m = plane();
        for p in &mut m.positions {
            *p = core::array::from_fn(|a| p[a] + t[a]);
        }
        let far = bake_grid(&m, BakeOptions { rho: 3, depth: 3 }, None).unwrap();
        let p = far.precise.expect("a precise cube at 10⁷");
        // The same cube as the unit plane's, moved, to within the f64 rounding at 10⁷ (its f32
        // cube is 0.5 off and 2 sides wide).
        assert!(
            (p.side - near.side).abs() < 1e-6,
            "{} vs {}",
            p.side,
            near.side
        );
        for a in 0..3 {
            assert!(
                (p.origin[a] - t[a] - near.origin[a]).abs() < 1e-6,
                "axis {a}"
            );
        }
        // The same cells, and the file reads them back.
        assert_eq!(far.levels, near.levels);
        let mut bytes = write_tg(&far, 9).unwrap();
        let h = *TriGrid::open(&bytes, Verify::Full).unwrap().header();
        assert!(h.has_precise());
        assert_eq!(
            (h.origin64, h.side64, h.bounds64),
            (p.origin, p.side, p.bounds)
        );
        // Its f32 fields still hold a cube around the mesh, for readers without the flag.
        for a in 0..3 {
            let lo = f64::from(h.origin[a]);
            assert!(lo <= p.bounds[0][a] && p.bounds[1][a] <= lo + f64::from(h.side));
        }
        // A bad f64 is caught: a side of 0 (offset: the CRC list's end + 24).
        let list_end = 72 + 24 * 4 + 4 * h.crc_table_blocks as usize;
        bytes[list_end + 24..list_end + 32].copy_from_slice(&0f64.to_le_bytes());
        seal(&mut bytes);
        assert_eq!(
            TriGrid::open(&bytes, Verify::Full).unwrap_err(),
            TgError::BadPrecise {
                offset: (list_end + 24) as u16
            }
        );
        // Without the flag the extension is unread padding, and the f32 cube is used.
        let flags = u16::from_le_bytes([bytes[6], bytes[7]]) & !FLAG_PRECISE;
        bytes[6..8].copy_from_slice(&flags.to_le_bytes());
        seal(&mut bytes);
        let h = *TriGrid::open(&bytes, Verify::Full).unwrap().header();
        assert_eq!(h.side64, f64::from(h.side));
    }

    #[test]
    fn flat_plane_has_alpha_nine() {
        let g = bake_grid(&plane(), BakeOptions { rho: 3, depth: 4 }, None).unwrap();
        for l in 0..4 {
            assert_eq!(g.alpha(l), Some(9.0), "level {l}");
        }
        assert_eq!(g.levels[4].attrs.len(), 81 * 81);
        // Every sample's normal is ±Y.
        let up = crate::normal::encode([0.0, 1.0, 0.0]);
        let down = crate::normal::encode([0.0, -1.0, 0.0]);
        assert!(g
            .levels
            .iter()
            .flat_map(|l| &l.attrs)
            .all(|&a| a == up || a == down));
    }

    #[test]
    fn written_file_reads_back_with_the_same_structure() {
        let g = bake_grid(&plane(), BakeOptions { rho: 3, depth: 3 }, None).unwrap();
        let bytes = write_tg(&g, 9).unwrap();
        let tg = TriGrid::open(&bytes, Verify::Full).unwrap();
        assert_eq!(tg.header().depth, 3);
        for (l, level) in g.levels.iter().enumerate() {
            assert_eq!(tg.level(l as u8).count as usize, level.attrs.len());
            for (i, &a) in level.attrs.iter().enumerate() {
                assert_eq!(tg.attr(l as u8, i as u32), a);
            }
            for (i, &m) in level.masks.iter().enumerate() {
                assert_eq!(tg.mask(l as u8, i as u32), m);
                // The stored word: the child bits, and the cone class above them.
                let word = tg.mask32(l as u8, i as u32);
                assert_eq!(u128::from(word & 0x07FF_FFFF), m);
                assert_eq!(word >> 27, u32::from(tg.cone(l as u8, i as u32)));
                assert!(tg.cone(l as u8, i as u32) > 0 && word >> 30 == 0);
            }
        }
    }

    #[test]
    fn octree_and_bigger_rho_bake_and_validate() {
        for rho in 2..=5 {
            let g = bake_grid(&plane(), BakeOptions { rho, depth: 2 }, None).unwrap();
            let bytes = write_tg(&g, 12).unwrap();
            let tg = TriGrid::open(&bytes, Verify::Full).unwrap();
            assert_eq!(tg.header().rho, rho);
            // A plane through the middle: ρ² cells for odd ρ; for even ρ it lies on (or within
            // rounding of) a cell boundary, which closed cells share: ρ² or 2ρ².
            let per = u32::from(rho).pow(2);
            let found = tg.level(1).count;
            assert!(
                found == per || (rho % 2 == 0 && found == 2 * per),
                "rho {rho}: {found}"
            );
        }
    }

    #[test]
    fn materials_and_colours_are_stored_only_when_used() {
        let mut m = plane();
        m.materials = Some(vec![0, 5, 0]);
        m.colors = Some(vec![[255, 0, 0]; 6]);
        let g = bake_grid(&m, BakeOptions { rho: 3, depth: 2 }, None).unwrap();
        assert_eq!(g.material_bits, 3);
        assert!(g
            .levels
            .iter()
            .flat_map(|l| l.colors.as_ref().unwrap())
            .all(|&c| c == 0xF800));
        assert!(g.levels[2].attrs.iter().any(|&a| a >> 13 == 5));
        let plain = bake_grid(&plane(), BakeOptions { rho: 3, depth: 2 }, None).unwrap();
        assert_eq!(plain.material_bits, 0);
        assert!(plain.levels[0].colors.is_none());
    }
}
