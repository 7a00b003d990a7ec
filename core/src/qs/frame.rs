//! Per-frame setup of a QSplat render (floats allowed here, never per node): the camera becomes
//! integer tables that the traversal only adds, multiplies and compares.
//!
//! Units (written down once, `docs/ARCHITECTURE.md` convention 8):
//! - **model integers**: a tree's positions relative to its root centre, in units of
//!   `root radius / 2²⁸` ([`ROOT_RADIUS`]). A child's centre is its parent's plus `(a, b, c)·r₁₃` and its
//!   radius `s·r₁₃`, where `r₁₃ = ⌈r/13⌉` of the parent: one table look-up and a few multiplies.
//! - **projected homogeneous coordinates** `(X, Y, W)`, as for the tri-grid (`fixed.rs`): `X/W`, `Y/W`
//!   are pixels, `W` the camera depth, with one per-frame scale so that `max(|X|, |Y|) + S·|W| ≤ 2³⁰`
//!   over every root sphere (`S` the image's larger side). Being linear in the model point, a child's `(X, Y, W)` is its parent's
//!   plus `r₁₃ · (T_x[a] + T_y[b] + T_z[c]) / 2²³`, with per-frame tables `T` (Q23).
//! - **backface units**: model integers shifted right by `bshift`, chosen per frame so that every
//!   eye-to-node vector is below 2²⁴ and the cone test's squares fit in `i64`.

use super::read::{QSplat, TreeHead};
use crate::camera::{self, Camera, Placement, Projection, Vec3, Viewport, PROJECTED_RANGE};
use crate::frame::{FrameError, RenderOptions};
use crate::raster::Kernel;
use crate::shade::Material;

/// A root sphere's radius in model integers.
pub const ROOT_RADIUS: i32 = 1 << 28;
/// Fraction bits of the displacement tables.
pub const T_BITS: u32 = 23;
/// Backface vectors stay below this (in backface units) for every node of a valid tree.
pub const BACKFACE_RANGE: i64 = 1 << 24;

/// A positive constant as a fixed-point multiplier: `x ↦ (x · m) >> sh`, `m ∈ [2³¹, 2³²)`, so that any
/// `x < 2³¹` keeps 31 bits of precision and the product fits in a `u64`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Scale {
    m: u32,
    sh: u32,
}

impl Scale {
    /// The multiplier nearest to `k ≥ 0` (saturating at `2³²` and flushing below `2⁻³²`).
    pub fn new(k: f64) -> Self {
        if k.is_nan() || k <= 0.0 {
            return Self::default();
        }
        if k >= 4_294_967_295.0 {
            return Self { m: u32::MAX, sh: 0 };
        }
        let (mut m, mut sh) = (k, 0u32);
        while m < 2_147_483_648.0 && sh < 63 {
            m *= 2.0;
            sh += 1;
        }
        let m = libm::round(m).min(4_294_967_295.0);
        Self { m: m as u32, sh }
    }

    /// `(x · k)`, rounded down.
    #[inline(always)]
    pub fn apply(self, x: u32) -> u64 {
        let p = u64::from(x) * u64::from(self.m);
        // A frame's scales are small (`sh ≥ 32`): the high word shifted, which is the same floor
        // without a 64-bit shift by a variable (a dozen instructions on thumbv7m).
        if self.sh >= 32 {
            u64::from(((p >> 32) as u32) >> (self.sh - 32))
        } else {
            p >> self.sh
        }
    }

    /// The constant this stands for.
    pub fn value(self) -> f64 {
        f64::from(self.m) / libm::pow(2.0, f64::from(self.sh))
    }
}

/// The material `file` is shaded with: `base`, or, when its samples carry colours, `base` in white,
/// which the colours then tint ([`super::ColorSink`] modulates the shaded colour by the sample's).
/// One rule for every renderer of `.qs` files (the simulator, the firmware), so that their frames
/// agree.
pub fn shading_material(file: &QSplat<'_>, base: Material) -> Material {
    material_for_colors(file.counts().color_trees > 0, base)
}

/// [`shading_material`] of a file whose trees carry colours (`colored`) or not.
pub fn material_for_colors(colored: bool, base: Material) -> Material {
    if colored {
        Material {
            color: [1.0; 3],
            ..base
        }
    } else {
        base
    }
}

/// The per-frame quantities shared by every tree of a file.
#[derive(Clone, Debug)]
pub struct QsFrame {
    /// Rows of `(X, Y, W)` as affine functions of a model point, already scaled to integer units.
    rows: [[f64; 4]; 3],
    /// Model units per world unit of `(X, Y, W)`: the placement's scale times the frame scale.
    world_scale: f64,
    /// `W` units per world unit of camera depth (setup only: [`QsFrame::share_depth_range`]).
    w_per_unit: f64,
    /// Eye in model coordinates.
    eye: Vec3,
    focal_px: f64,
    pub(crate) near_w: i32,
    /// Depth = `(W − depth_w0) · depth_scale >> 32`.
    pub(crate) depth_w0: i32,
    pub(crate) depth_scale: u64,
    pub(crate) cutoff_px: f64,
    pub(crate) kernel: Kernel,
    pub(crate) backface: bool,
    /// The image's width and height, pixels.
    pub(crate) viewport: Viewport,
}

/// The integer tables of one tree in one frame.
#[derive(Clone, Debug)]
pub struct TreeFrame {
    /// `(X, Y, W)` of the root centre.
    pub(crate) root: [i32; 3],
    /// `T[axis][a + 13]`: `(X, Y, W)` of `a` model integers along `axis`, Q23. Indexed by
    /// `s + 2x` of a table entry (`a = s + 2x − 13`), 32 entries so that an index masked to
    /// 5 bits needs no bounds check (0 and 26.. are never read).
    pub(crate) t: [[[i32; 3]; 32]; 3],
    /// Plane extents per model integer of radius: X (left), Y (top), W (near), width·W − X
    /// (right), height·W − Y (bottom).
    pub(crate) ext: [Scale; 5],
    /// Draw instead of descending when `lod(r) ≤ W`.
    pub(crate) lod: Scale,
    /// `size(r) / W` is the splat diameter in Q8 pixels.
    pub(crate) size: Scale,
    /// Eye in backface units, relative to the root centre.
    pub(crate) eye: [i32; 3],
    pub(crate) bshift: u32,
    /// Backface culling possible (the eye is within range).
    pub(crate) backface: bool,
}

fn row(a: &[f64; 4]) -> Vec3 {
    [a[0], a[1], a[2]]
}

fn norm(v: Vec3) -> f64 {
    libm::sqrt(camera::dot(v, v))
}

fn to_i32(x: f64) -> i32 {
    libm::round(x).clamp(-2_147_483_647.0, 2_147_483_647.0) as i32
}

impl QsFrame {
    /// Sets up a frame of `file`, placed in the world by `placement`, seen by `camera`.
    ///
    /// # Errors
    /// [`FrameError::BadCamera`] for non-finite input or a cutoff that is not positive.
    pub fn new(
        file: &QSplat<'_>,
        placement: &Placement,
        camera: &Camera,
        opts: &RenderOptions,
    ) -> Result<Self, FrameError> {
        Self::of_trees(file.trees().map(|t| t.head()), placement, camera, opts)
    }

    /// [`QsFrame::new`] for the trees whose heads `trees` yields (a streamed file's, whose nodes
    /// are not in memory).
    ///
    /// # Errors
    /// As [`QsFrame::new`].
    pub fn of_trees(
        trees: impl Iterator<Item = TreeHead> + Clone,
        placement: &Placement,
        camera: &Camera,
        opts: &RenderOptions,
    ) -> Result<Self, FrameError> {
        let cutoff = f64::from(opts.cutoff_px);
        let projection = Projection::new(camera, placement)
            .filter(|_| cutoff > 0.0 && cutoff.is_finite())
            .ok_or(FrameError::BadCamera)?;
        let f = camera.focal_px;
        let mut rows = projection.rows;
        let eval = |rows: &[[f64; 4]; 3], p: Vec3| -> Vec3 {
            core::array::from_fn(|k| camera::dot(row(&rows[k]), p) + rows[k][3])
        };
        // The frame scale: every root sphere within 2³⁰.
        let mut bound = 0.0f64;
        for t in trees.clone() {
            let c = t.center.map(f64::from);
            let r = f64::from(t.radius);
            let [x, y, w] = eval(&rows, c);
            let e = |k: usize| r * norm(row(&rows[k]));
            let b = (libm::fabs(x) + e(0)).max(libm::fabs(y) + e(1))
                + projection.side() * (libm::fabs(w) + e(2));
            bound = bound.max(b);
        }
        if !(bound.is_finite() && bound > 0.0) {
            return Err(FrameError::BadCamera);
        }
        let scale = PROJECTED_RANGE / bound;
        for r in &mut rows {
            for v in r.iter_mut() {
                *v *= scale;
            }
        }
        let near_w = to_i32((camera.near * scale).max(1.0));
        // Depth: linear in W over all root spheres.
        let (mut w_lo, mut w_hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for t in trees {
            let c = t.center.map(f64::from);
            let w = eval(&rows, c)[2];
            let e = f64::from(t.radius) * norm(row(&rows[2]));
            w_lo = w_lo.min(w - e);
            w_hi = w_hi.max(w + e);
        }
        let w_lo = w_lo.max(f64::from(near_w));
        let w_hi = w_hi.max(w_lo + 1.0);
        let depth_w0 = to_i32(w_lo);
        let depth_scale = (65534.0 * 4_294_967_296.0 / (w_hi - w_lo + 1.0)) as u64;
        // The eye in model coordinates: p = Rᵀ(eye − t)/s.
        let eye = camera::scale(
            placement.to_model_dir(camera::sub(camera.eye, placement.translation)),
            1.0 / placement.scale,
        );
        Ok(Self {
            rows,
            world_scale: placement.scale * scale,
            w_per_unit: scale,
            eye,
            focal_px: f,
            near_w,
            depth_w0,
            depth_scale,
            cutoff_px: cutoff,
            kernel: opts.kernel,
            backface: opts.backface_culling,
            viewport: camera.viewport,
        })
    }

    /// Maps depth over `range` (camera depths, world units) instead of this file's own root
    /// spheres, so that several objects drawn into one depth buffer z-test against each other (a
    /// scene: `crate::scene`, as `TgFrame::share_depth_range` does for tri-grids).
    /// Depths outside the range clamp to its ends.
    pub fn share_depth_range(&mut self, range: crate::camera::DepthRange) {
        let near = f64::from(self.near_w);
        let lo = range.near * self.w_per_unit;
        let hi = range.far * self.w_per_unit;
        let w_lo = if lo.is_finite() { lo.max(near) } else { near };
        let w_hi = if hi.is_finite() {
            hi.max(w_lo + 1.0)
        } else {
            w_lo + 1.0
        };
        self.depth_w0 = to_i32(w_lo);
        self.depth_scale = (65534.0 * 4_294_967_296.0 / (w_hi - w_lo + 1.0)) as u64;
    }

    /// The splat kernel.
    pub fn kernel(&self) -> Kernel {
        self.kernel
    }

    /// The integer tables of one tree (setup: once per tree per frame).
    pub fn tree(&self, tree: &TreeHead) -> TreeFrame {
        let c = tree.center.map(f64::from);
        let radius = f64::from(tree.radius);
        // Model units per model integer.
        let unit = radius / f64::from(ROOT_RADIUS);
        let rows = &self.rows;
        let root: [i32; 3] =
            core::array::from_fn(|k| to_i32(camera::dot(row(&rows[k]), c) + rows[k][3]));
        // (X, Y, W) per model integer along each axis.
        let g = |k: usize, axis: usize| rows[k][axis] * unit;
        let t = core::array::from_fn(|axis| {
            core::array::from_fn(|i| {
                if !(1..=25).contains(&i) {
                    // Never read: no soft-float work for them.
                    return [0; 3];
                }
                let a = i as f64 - 13.0;
                core::array::from_fn(|k| to_i32(a * g(k, axis) * f64::from(1u32 << T_BITS)))
            })
        });
        let gx = [g(0, 0), g(0, 1), g(0, 2)];
        let gy = [g(1, 0), g(1, 1), g(1, 2)];
        let gw = [g(2, 0), g(2, 1), g(2, 2)];
        let gr = camera::sub(camera::scale(gw, f64::from(self.viewport.width)), gx);
        let gb = camera::sub(camera::scale(gw, f64::from(self.viewport.height)), gy);
        let ext = [gx, gy, gw, gr, gb].map(|v| Scale::new(norm(v)));
        // Projected diameter 2·r·f/z: per model integer, in W units (world size × frame scale).
        let k = 2.0 * self.focal_px * unit * self.world_scale;
        let lod = Scale::new(k / self.cutoff_px);
        let size = Scale::new(f64::from(crate::fixed::ONE_PX_Q8) * k);
        // Backface units: every eye-to-node vector (at most |eye| + ~2 root radii) below 2²⁴.
        let eye = camera::scale(camera::sub(self.eye, c), 1.0 / unit);
        let reach = norm(eye) + 2.0 * f64::from(ROOT_RADIUS);
        let mut bshift = 0u32;
        while reach / libm::pow(2.0, f64::from(bshift)) >= BACKFACE_RANGE as f64 && bshift < 62 {
            bshift += 1;
        }
        let div = libm::pow(2.0, f64::from(bshift));
        let backface = self.backface && reach.is_finite() && bshift <= 30;
        TreeFrame {
            root,
            t,
            ext,
            lod,
            size,
            eye: eye.map(|v| to_i32(v / div)),
            bshift: bshift.min(31),
            backface,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scale_keeps_31_bits() {
        for k in [1e-6, 0.37, 1.0, 2.76, 460.0, 1e7] {
            let s = Scale::new(k);
            assert!((s.value() / k - 1.0).abs() < 1e-9, "{k}");
            let x = 123_456_789u32;
            let want = f64::from(x) * k;
            assert!((s.apply(x) as f64 - want).abs() <= want * 1e-9 + 1.0, "{k}");
        }
        assert_eq!(Scale::new(0.0).apply(1 << 30), 0);
        assert_eq!(Scale::new(f64::NAN).apply(5), 0);
        assert_eq!(Scale::new(1e300).apply(2), 2 * u64::from(u32::MAX));
    }
}
