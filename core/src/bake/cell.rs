//! One cell of the ρ-grid and what the baker does there, over any [`Surface`]: which children a
//! triangle goes to (Duguet §4.1 *IntersectAxisAlignedBox*) and the sample at the point closest to
//! the centre (*GetSampleAt*). The in-memory bake and the pieces of an out-of-core bake share
//! these, so that both make the same cells and the same samples.

use super::geom::{at_bary, closest_on_triangle, cross, dot, sub, tri_box_overlap, V3};
use crate::normal;

/// The triangles a bake samples: a whole mesh, or the part of one an out-of-core piece holds.
/// Triangle and vertex numbers are the surface's own.
pub trait Surface: Sync {
    /// The vertices of triangle `t`.
    fn triangle(&self, t: u32) -> [u32; 3];
    /// The position of vertex `v`.
    fn position(&self, v: u32) -> V3;
    /// The area-weighted normal of vertex `v` (the cross products of its triangles with area,
    /// summed in the mesh's triangle order).
    fn vertex_normal(&self, v: u32) -> V3;
    /// The colour of vertex `v`, when the mesh has colours.
    fn color(&self, v: u32) -> Option<[u8; 3]>;
    /// The material of triangle `t` (0 without materials).
    fn material(&self, t: u32) -> u8;
}

/// The corners of triangle `t`.
pub fn corners<S: Surface + ?Sized>(surface: &S, t: u32) -> [V3; 3] {
    surface.triangle(t).map(|v| surface.position(v))
}

/// A cell: level, minimum corner, side.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cell {
    /// Level (0: the root cube).
    pub level: u8,
    /// Minimum corner.
    pub min: V3,
    /// Side.
    pub side: f64,
}

impl Cell {
    /// The centre, where the sample is taken from.
    pub fn centre(&self) -> V3 {
        let half = 0.5 * self.side;
        [self.min[0] + half, self.min[1] + half, self.min[2] + half]
    }

    /// Child `slot` (`i + ρ(j + ρk)`).
    pub fn child(&self, rho: u8, slot: usize) -> Cell {
        let rho = usize::from(rho);
        let child_side = self.side / rho as f64;
        let (i, j, k) = (slot % rho, (slot / rho) % rho, slot / (rho * rho));
        Cell {
            level: self.level + 1,
            min: [
                self.min[0] + i as f64 * child_side,
                self.min[1] + j as f64 * child_side,
                self.min[2] + k as f64 * child_side,
            ],
            side: child_side,
        }
    }

    /// Calls `to` with each child slot the triangle with corners `c` goes to, in slot order
    /// (exact test only where the triangle's box spans more than one child).
    pub fn child_slots(&self, rho: u8, c: &[V3; 3], mut to: impl FnMut(usize)) {
        let rho = usize::from(rho);
        let child_side = self.side / rho as f64;
        let mut range = [(0usize, 0usize); 3];
        for a in 0..3 {
            let lo = c[0][a].min(c[1][a]).min(c[2][a]);
            let hi = c[0][a].max(c[1][a]).max(c[2][a]);
            let f =
                |x: f64| (((x - self.min[a]) / child_side).floor().max(0.0) as usize).min(rho - 1);
            range[a] = (f(lo), f(hi));
        }
        let single = range.iter().all(|(l, h)| l == h);
        let mut placed = false;
        for k in range[2].0..=range[2].1 {
            for j in range[1].0..=range[1].1 {
                for i in range[0].0..=range[0].1 {
                    let min = [
                        self.min[0] + i as f64 * child_side,
                        self.min[1] + j as f64 * child_side,
                        self.min[2] + k as f64 * child_side,
                    ];
                    let h = 0.5 * child_side;
                    let cc = [min[0] + h, min[1] + h, min[2] + h];
                    if single || tri_box_overlap(c, cc, h) {
                        to(i + rho * (j + rho * k));
                        placed = true;
                    }
                }
            }
        }
        // A triangle that only touches this cell's boundary can miss every child once the child
        // boxes are rounded; it still belongs to the cell, so give it the nearest child. This
        // keeps "every interior cell has a child" true.
        if !placed {
            to(range[0].0 + rho * (range[1].0 + rho * range[2].0));
        }
    }
}

/// The point closest to a cell's centre among the triangles offered so far, in the order
/// offered: the first of equals wins, so a stream of triangles in mesh order finds the point the
/// in-memory bake finds. `T` names a triangle: its number in a [`Surface`], or its vertices.
#[derive(Clone, Copy, Debug)]
pub struct Closest<T> {
    d2: f64,
    /// The triangle.
    pub t: T,
    /// Barycentric weights of the point on it.
    pub w: V3,
}

impl<T: Copy> Closest<T> {
    /// Nothing offered yet: `first`, the first triangle that will be, stands in.
    pub fn new(first: T) -> Self {
        Self {
            d2: f64::INFINITY,
            t: first,
            w: [1.0, 0.0, 0.0],
        }
    }

    /// Offers triangle `t` with corners `c`.
    pub fn offer(&mut self, centre: V3, t: T, c: &[V3; 3]) {
        let w = closest_on_triangle(centre, c);
        let d = sub(at_bary(c, w), centre);
        let d2 = dot(d, d);
        if d2 < self.d2 {
            *self = Self { d2, t, w };
        }
    }
}

/// The sample at the point with weights `w` on the triangle of vertices `idx` and material
/// `material` (§4.1 *GetSampleAt*): the interpolated area-weighted vertex normal (the triangle's
/// own where that is zero) and the material as an attribute, and the interpolated colour as RGB565
/// when the surface has colours.
pub fn sample_at<S: Surface + ?Sized>(
    surface: &S,
    idx: [u32; 3],
    material: u8,
    w: V3,
) -> (u16, Option<u16>) {
    let mut n = [0.0; 3];
    for k in 0..3 {
        let vn = surface.vertex_normal(idx[k]);
        for a in 0..3 {
            n[a] += w[k] * vn[a];
        }
    }
    if dot(n, n) == 0.0 {
        let c = idx.map(|v| surface.position(v));
        n = cross(sub(c[1], c[0]), sub(c[2], c[0]));
    }
    let attr = normal::encode(n) | u16::from(material) << normal::NORMAL_BITS;
    let color = surface.color(idx[0]).map(|_| {
        let mut rgb = [0.0f64; 3];
        for k in 0..3 {
            let c = surface.color(idx[k]).unwrap_or_default();
            for a in 0..3 {
                rgb[a] += w[k] * f64::from(c[a]);
            }
        }
        crate::shade::rgb255_to_rgb565(rgb)
    });
    (attr, color)
}
