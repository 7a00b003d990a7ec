//! Bakes in memory, with the f64 geometry of their cells (centre, side, children's centroid) that
//! every check compares the integer renderer with.

use pocketsplat_core::bake::{bake_grid, BakeOptions, BakedGrid, TriMesh};
use pocketsplat_core::camera::{Placement, Sphere, Vec3};
use pocketsplat_core::tg::write::write_tg;
use pocketsplat_core::tg::{TriGrid, Verify};

use super::meshes::blob;

/// A baked grid in memory, with the f64 centre of every cell.
pub struct Baked {
    /// What the baker produced (for α).
    pub grid: BakedGrid,
    /// The `.tg` file.
    pub bytes: Vec<u8>,
    /// Cell centres per level in file order, model units (from the file's root cube and masks).
    pub centres: Vec<Vec<Vec3>>,
    /// Cell side per level, model units.
    pub side: Vec<f64>,
    /// The centroid of each cell's children's centres, per level in file order (`None` for a leaf).
    pub centroids: Vec<Vec<Option<Vec3>>>,
}

impl Baked {
    /// Bakes `mesh` as a ρ-grid of `depth` subdivisions.
    ///
    /// # Panics
    /// When the mesh cannot be baked (the suite's meshes can).
    pub fn new(mesh: &TriMesh, rho: u8, depth: u8) -> Self {
        let grid = bake_grid(mesh, BakeOptions { rho, depth }, None).expect("bake");
        let bytes = write_tg(&grid, 12).expect("write");
        let tg = TriGrid::open(&bytes, Verify::Full).expect("open");
        let (centres, side) = cell_centres(&tg);
        let centroids = child_centroids(&tg, &centres);
        Self {
            grid,
            bytes,
            centres,
            side,
            centroids,
        }
    }

    /// The file, opened.
    pub fn tg(&self) -> TriGrid<'_> {
        TriGrid::open(&self.bytes, Verify::Structure).expect("open")
    }

    /// The model's bounding box as the file gives it to views (`bounds64`: precise when the header
    /// has the `f64` extension).
    pub fn bounds(&self) -> [[f64; 3]; 2] {
        self.tg().header().bounds64
    }
}

/// The f64 centre of every cell of `tg`, per level in file order (a breadth-first walk of the
/// masks from the file's root cube), model units; and the side of a cell per level.
pub fn cell_centres(tg: &TriGrid<'_>) -> (Vec<Vec<Vec3>>, Vec<f64>) {
    let h = tg.header();
    let rho = usize::from(h.rho);
    let side0 = h.side64;
    let mut centres = vec![vec![h.origin64.map(|o| o + 0.5 * side0)]];
    let mut side = vec![side0];
    for l in 0..h.depth {
        let parent = side[usize::from(l)];
        side.push(parent / rho as f64);
        let mut next = Vec::with_capacity(tg.level(l + 1).count as usize);
        for (i, c) in centres[usize::from(l)].iter().enumerate() {
            let mask = tg.mask(l, i as u32);
            for s in 0..rho * rho * rho {
                if mask >> s & 1 == 1 {
                    let ijk = [s % rho, (s / rho) % rho, s / (rho * rho)];
                    next.push(std::array::from_fn(|k| {
                        c[k] + ((ijk[k] as f64 + 0.5) / rho as f64 - 0.5) * parent
                    }));
                }
            }
        }
        centres.push(next);
    }
    (centres, side)
}

/// The centroid of each cell's children's centres, per level in file order (`None` for a leaf):
/// where the walk may draw a cell instead of its centre (Duguet §4.1: the surface in the cell).
pub fn child_centroids(tg: &TriGrid<'_>, centres: &[Vec<Vec3>]) -> Vec<Vec<Option<Vec3>>> {
    let mut centroids = Vec::with_capacity(centres.len());
    for l in 0..=tg.header().depth {
        let (here, below) = (&centres[usize::from(l)], centres.get(usize::from(l) + 1));
        let mut first = 0usize;
        centroids.push(
            (0..here.len())
                .map(|i| {
                    let kids = below?;
                    let k = tg.mask(l, i as u32).count_ones() as usize;
                    let kids = &kids[first..first + k];
                    first += k;
                    (k > 0).then(|| {
                        std::array::from_fn(|a| kids.iter().map(|c| c[a]).sum::<f64>() / k as f64)
                    })
                })
                .collect(),
        );
    }
    centroids
}

/// The bounding sphere of a placed model (the orbit camera's pivot).
pub fn world_sphere(bounds: [[f64; 3]; 2], placement: &Placement) -> Sphere {
    let s = Sphere::from_bounds_f64(bounds);
    Sphere {
        center: placement.apply(s.center),
        radius: s.radius * placement.scale,
    }
}

pub(super) fn blob_grid() -> Baked {
    Baked::new(&blob(40), 3, 4)
}
