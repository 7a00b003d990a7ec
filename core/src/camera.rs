//! The camera convention every renderer shares, in f64 (per-frame setup, never per node).
//!
//! Models are Y-up. The camera orbits the centre of the model's bounding sphere (the sphere around its
//! bounding box): azimuth `az` degrees around +Y from +Z towards +X, elevation `el` degrees up,
//! distance `dist` in bounding-sphere radii, looking at the centre. The image is a [`Viewport`], 240 ×
//! 320 (portrait) unless the caller's buffers say otherwise; pixel `(i, j)` covers `[i, i+1) × [j, j+1)`
//! with `j` growing downwards.
//!
//! Only `libm` functions and IEEE-exact operations are used, so x86 and ARM compute the same bits.

/// Width of the reference framebuffer in pixels ([`Viewport::DEFAULT`]).
pub const WIDTH: usize = 240;
/// Height of the reference framebuffer in pixels ([`Viewport::DEFAULT`]).
pub const HEIGHT: usize = 320;

/// The size of the image a camera projects onto, pixels: the caller's buffers' size.
///
/// Each side is 1 to [`Viewport::MAX_SIDE`]; the frames' integer range is shared between the
/// image's larger side and the depth (`max(|X|, |Y|) + max(width, height)·|W| ≤ 2³⁰`, `fixed.rs`),
/// so a larger image has a little less depth precision, and 240 × 320 draws what it always drew.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Viewport {
    /// Width, pixels.
    pub width: u16,
    /// Height, pixels.
    pub height: u16,
}

impl Viewport {
    /// The reference 240 × 320 portrait frame.
    pub const DEFAULT: Viewport = Viewport {
        width: WIDTH as u16,
        height: HEIGHT as u16,
    };
    /// The largest side a viewport may have, pixels.
    pub const MAX_SIDE: u16 = 2048;

    /// A viewport of `width × height`, or `None` when a side is 0 or above [`Viewport::MAX_SIDE`].
    pub const fn new(width: u32, height: u32) -> Option<Self> {
        if width == 0
            || height == 0
            || width > Self::MAX_SIDE as u32
            || height > Self::MAX_SIDE as u32
        {
            return None;
        }
        Some(Viewport {
            width: width as u16,
            height: height as u16,
        })
    }

    /// Whether both sides are within 1..=[`Viewport::MAX_SIDE`].
    pub const fn is_valid(self) -> bool {
        Self::new(self.width as u32, self.height as u32).is_some()
    }

    /// The larger side, pixels (the frames' range bound, above).
    pub fn max_side(self) -> u16 {
        self.width.max(self.height)
    }

    /// The number of pixels.
    pub const fn pixels(self) -> usize {
        self.width as usize * self.height as usize
    }

    /// The centre of the image, pixels.
    pub fn center(self) -> (f64, f64) {
        (f64::from(self.width) / 2.0, f64::from(self.height) / 2.0)
    }
}

impl Default for Viewport {
    fn default() -> Self {
        Self::DEFAULT
    }
}
/// Default vertical field of view, degrees.
pub const DEFAULT_FOV_DEG: f64 = 45.0;
/// Near plane distance, in bounding-sphere radii.
pub const NEAR_RADII: f64 = 1e-3;

/// A direction or position, f64.
pub type Vec3 = [f64; 3];

/// An orbit view: azimuth and elevation in degrees, distance in bounding-sphere radii.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View {
    /// Degrees around +Y, from +Z towards +X.
    pub az_deg: f64,
    /// Degrees above the horizontal plane.
    pub el_deg: f64,
    /// Distance from the centre, in bounding-sphere radii.
    pub dist: f64,
}

impl View {
    /// A view from its three numbers.
    pub const fn new(az_deg: f64, el_deg: f64, dist: f64) -> Self {
        Self {
            az_deg,
            el_deg,
            dist,
        }
    }
}

/// The standard views, shared by tests, benchmarks and reports.
pub const STANDARD_VIEWS: [(&str, View); 4] = [
    ("std", View::new(30.0, 20.0, 2.5)),
    ("front", View::new(0.0, 0.0, 3.0)),
    // Inside the bounding sphere.
    ("close", View::new(60.0, 10.0, 0.8)),
    ("far", View::new(-45.0, 30.0, 20.0)),
];

/// Looks up a standard view by name.
pub fn standard_view(name: &str) -> Option<View> {
    STANDARD_VIEWS
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, v)| *v)
}

/// The unit direction of an azimuth/elevation pair (the convention of views and lights).
pub fn direction(az_deg: f64, el_deg: f64) -> Vec3 {
    let (az, el) = (az_deg.to_radians(), el_deg.to_radians());
    let ce = libm::cos(el);
    [libm::sin(az) * ce, libm::sin(el), libm::cos(az) * ce]
}

/// A bounding sphere.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    /// Centre.
    pub center: Vec3,
    /// Radius (> 0).
    pub radius: f64,
}

impl Sphere {
    /// The sphere around a bounding box: its centre and half its diagonal.
    pub fn from_bounds(bounds: [[f32; 3]; 2]) -> Self {
        Self::from_bounds_f64(bounds.map(|c| c.map(f64::from)))
    }

    /// [`Sphere::from_bounds`] of an `f64` box (a `.tg` header's `bounds64`).
    pub fn from_bounds_f64(bounds: [[f64; 3]; 2]) -> Self {
        let [lo, hi] = bounds;
        let center = [
            0.5 * (lo[0] + hi[0]),
            0.5 * (lo[1] + hi[1]),
            0.5 * (lo[2] + hi[2]),
        ];
        let d = sub(hi, lo);
        let radius = 0.5 * libm::sqrt(dot(d, d));
        Self {
            center,
            radius: if radius > 0.0 { radius } else { 1.0 },
        }
    }
}

/// A perspective camera for an image of [`Camera::viewport`] pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Eye position, model units.
    pub eye: Vec3,
    /// Unit vector to the right of the image.
    pub right: Vec3,
    /// Unit vector to the top of the image.
    pub up: Vec3,
    /// Unit viewing direction.
    pub forward: Vec3,
    /// Focal length in pixels: `(height / 2) / tan(fov / 2)`.
    pub focal_px: f64,
    /// Near plane distance, model units.
    pub near: f64,
    /// The image the camera projects onto.
    pub viewport: Viewport,
}

impl Camera {
    /// The orbit camera of `view` around `sphere`, with vertical field of view `fov_deg`, for the
    /// reference 240 × 320 image ([`Camera::for_viewport`] gives it another).
    pub fn orbit(sphere: Sphere, view: View, fov_deg: f64) -> Self {
        let dir = direction(view.az_deg, view.el_deg);
        let eye = add(sphere.center, scale(dir, view.dist * sphere.radius));
        let forward = scale(dir, -1.0);
        // Off the poles, right = forward × Y normalised = (cos az, 0, −sin az). Straight up or down
        // (+Y useless as a reference) take that same vector, its limit at the pole, so that the image
        // turns continuously as the view orbits onto the pole at any azimuth.
        let right = if libm::fabs(dir[1]) > 1.0 - 1e-12 {
            let az = view.az_deg.to_radians();
            [libm::cos(az), 0.0, -libm::sin(az)]
        } else {
            normalize(cross(forward, [0.0, 1.0, 0.0]))
        };
        let up = cross(right, forward);
        let focal_px = (HEIGHT as f64 / 2.0) / libm::tan(0.5 * fov_deg.to_radians());
        Self {
            eye,
            right,
            up,
            forward,
            focal_px,
            near: NEAR_RADII * sphere.radius,
            viewport: Viewport::DEFAULT,
        }
    }

    /// The same camera for an image of `viewport`: the vertical field of view is kept (the focal
    /// length scales with the height), the image centre moves to the new centre. The camera itself
    /// when the viewport is its own, bit for bit.
    pub fn for_viewport(&self, viewport: Viewport) -> Self {
        if viewport == self.viewport {
            return *self;
        }
        Self {
            focal_px: self.focal_px * f64::from(viewport.height) / f64::from(self.viewport.height),
            viewport,
            ..*self
        }
    }

    /// Camera-space coordinates of a point: x right, y up, z along the view (depth).
    pub fn to_camera(&self, p: Vec3) -> Vec3 {
        let d = sub(p, self.eye);
        [dot(d, self.right), dot(d, self.up), dot(d, self.forward)]
    }

    /// Screen position (pixels, y down) and depth of a point, or `None` in front of the near plane.
    pub fn project(&self, p: Vec3) -> Option<Vec3> {
        let [x, y, z] = self.to_camera(p);
        if z < self.near {
            return None;
        }
        Some(self.screen(x, y, z))
    }

    /// Screen position of camera-space coordinates with `z > 0`.
    pub fn screen(&self, x: f64, y: f64, z: f64) -> Vec3 {
        let (cx, cy) = self.viewport.center();
        [cx + self.focal_px * x / z, cy - self.focal_px * y / z, z]
    }
}

/// Bound on `max(|X|, |Y|) + max(width, height)·|W|` over everything a frame may draw, in the
/// frame's integer units (`fixed.rs`): a per-frame scale brings the [`Projection`] within it.
pub const PROJECTED_RANGE: f64 = (1u64 << 30) as f64;

/// The projection of a placed model's points onto a camera's image, in homogeneous pixels: `(X, Y,
/// W) = rows · [p; 1]` for a model point `p`, with `X/W`, `Y/W` pixels and `W` the camera depth in
/// world units. Linear in `p`, so that a frame turns it into tables a traversal only adds (Duguet
/// §5.1): the set-up every format's frame starts from, in one place.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Projection {
    /// The rows of `X`, `Y` and `W`: three coefficients of the model point, then the constant.
    pub rows: [[f64; 4]; 3],
    /// The image.
    pub viewport: Viewport,
}

impl Projection {
    /// The projection of a model placed by `placement` seen by `camera`, or `None` when the camera
    /// or the placement is not finite and positive (focal length, scale) or the viewport is empty.
    pub fn new(camera: &Camera, placement: &Placement) -> Option<Self> {
        if !(placement.scale > 0.0
            && placement.scale.is_finite()
            && camera.focal_px.is_finite()
            && camera.focal_px > 0.0
            && camera.viewport.is_valid())
        {
            return None;
        }
        let f = camera.focal_px;
        let (cx, cy) = camera.viewport.center();
        // Rows of (X, Y, W) as functions of the world point minus the eye.
        let rx = add(scale(camera.right, f), scale(camera.forward, cx));
        let ry = add(scale(camera.up, -f), scale(camera.forward, cy));
        let rw = camera.forward;
        // Composed with the placement: world = R·(s·p) + t, so the model-space row is s·Rᵀ·row and
        // the constant is row·(t − eye).
        let t_eye = sub(placement.translation, camera.eye);
        let model_row = |r: Vec3| -> [f64; 4] {
            let m = scale(placement.to_model_dir(r), placement.scale);
            [m[0], m[1], m[2], dot(r, t_eye)]
        };
        Some(Self {
            rows: [model_row(rx), model_row(ry), model_row(rw)],
            viewport: camera.viewport,
        })
    }

    /// Row `k` (0: `X`, 1: `Y`, 2: `W`) without its constant.
    pub fn row(&self, k: usize) -> Vec3 {
        let r = &self.rows[k];
        [r[0], r[1], r[2]]
    }

    /// `(X, Y, W)` of model point `p`.
    pub fn eval(&self, p: Vec3) -> Vec3 {
        core::array::from_fn(|k| dot(self.row(k), p) + self.rows[k][3])
    }

    /// The linear parts of the right and bottom plane functions, `width·W − X` and `height·W − Y`
    /// (a point is inside the image where `X`, `Y` and both are at least 0).
    pub fn right_bottom(&self) -> [Vec3; 2] {
        let w = self.row(2);
        [
            sub(scale(w, f64::from(self.viewport.width)), self.row(0)),
            sub(scale(w, f64::from(self.viewport.height)), self.row(1)),
        ]
    }

    /// The image's larger side, the weight of `|W|` in the range bound ([`PROJECTED_RANGE`]).
    pub fn side(&self) -> f64 {
        f64::from(self.viewport.max_side())
    }
}

/// Where a model sits in the world: `world = rotation · (scale · p) + translation`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    /// Row-major rotation matrix.
    pub rotation: [[f64; 3]; 3],
    /// Uniform scale (> 0).
    pub scale: f64,
    /// Translation, world units.
    pub translation: Vec3,
}

impl Placement {
    /// The identity placement.
    pub const IDENTITY: Placement = Placement {
        rotation: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        scale: 1.0,
        translation: [0.0; 3],
    };

    /// World position of a model point.
    pub fn apply(&self, p: Vec3) -> Vec3 {
        let r = &self.rotation;
        let q = scale(p, self.scale);
        add([dot(r[0], q), dot(r[1], q), dot(r[2], q)], self.translation)
    }

    /// Model-frame direction of a world direction (rotation transposed).
    pub fn to_model_dir(&self, d: Vec3) -> Vec3 {
        let r = &self.rotation;
        [
            r[0][0] * d[0] + r[1][0] * d[1] + r[2][0] * d[2],
            r[0][1] * d[0] + r[1][1] * d[1] + r[2][1] * d[2],
            r[0][2] * d[0] + r[1][2] * d[1] + r[2][2] * d[2],
        ]
    }
}

impl Default for Placement {
    fn default() -> Self {
        Self::IDENTITY
    }
}

/// a − b.
pub fn sub(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
/// a + b.
pub fn add(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
/// a · s.
pub fn scale(a: Vec3, s: f64) -> Vec3 {
    [a[0] * s, a[1] * s, a[2] * s]
}
/// a · b.
pub fn dot(a: Vec3, b: Vec3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
/// a × b.
pub fn cross(a: Vec3, b: Vec3) -> Vec3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
/// a / |a| (a zero vector stays zero).
pub fn normalize(a: Vec3) -> Vec3 {
    let l = libm::sqrt(dot(a, a));
    if l > 0.0 {
        scale(a, 1.0 / l)
    } else {
        a
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn front_view_looks_down_minus_z_and_centres_the_sphere() {
        let s = Sphere {
            center: [1.0, 2.0, 3.0],
            radius: 2.0,
        };
        let c = Camera::orbit(s, View::new(0.0, 0.0, 3.0), 45.0);
        assert!((c.eye[2] - 9.0).abs() < 1e-12);
        let p = c.project(s.center).unwrap();
        assert!(
            (p[0] - 120.0).abs() < 1e-9
                && (p[1] - 160.0).abs() < 1e-9
                && (p[2] - 6.0).abs() < 1e-12
        );
        // +X appears to the right, +Y up (smaller row).
        let px = c.project([2.0, 2.0, 3.0]).unwrap();
        let py = c.project([1.0, 3.0, 3.0]).unwrap();
        assert!(px[0] > 120.0 && py[1] < 160.0);
    }

    #[test]
    fn azimuth_goes_from_z_towards_x_and_poles_are_defined() {
        let d = direction(90.0, 0.0);
        assert!((d[0] - 1.0).abs() < 1e-12 && d[2].abs() < 1e-12);
        let s = Sphere {
            center: [0.0; 3],
            radius: 1.0,
        };
        for el in [90.0, -90.0] {
            let c = Camera::orbit(s, View::new(0.0, el, 2.0), 45.0);
            assert!(
                c.right.iter().all(|v| v.is_finite())
                    && (dot(c.right, c.right) - 1.0).abs() < 1e-12
            );
        }
    }

    #[test]
    fn orbiting_onto_a_pole_turns_the_camera_continuously() {
        // Found by the stability suite (`pocketsplat report stability`, axes group): at EL ±90 the
        // camera used a fixed reference whatever the azimuth, so at AZ 180 the image flipped.
        let s = Sphere {
            center: [0.0; 3],
            radius: 1.0,
        };
        for el in [90.0, -90.0] {
            for az in [0.0, 30.0, 90.0, 180.0, 270.0, -135.0] {
                let at = Camera::orbit(s, View::new(az, el, 2.0), 45.0);
                let off = Camera::orbit(s, View::new(az, el - 1e-3 * el / 90.0, 2.0), 45.0);
                for (a, b) in [(at.right, off.right), (at.up, off.up)] {
                    let d = sub(a, b);
                    assert!(dot(d, d).sqrt() < 1e-4, "EL {el} AZ {az}: {a:?} vs {b:?}");
                }
                assert!(dot(at.right, at.forward).abs() < 1e-12);
                assert!((dot(at.up, at.up) - 1.0).abs() < 1e-12);
            }
        }
    }
}

/// An interval of camera depth (distance along the view direction), world units: the depth range a
/// scene's objects share (`TgFrame::share_depth_range`, `QsFrame::share_depth_range`). Here rather
/// than with either format, so that each compiles without the other.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthRange {
    /// Nearest camera depth.
    pub near: f64,
    /// Farthest camera depth.
    pub far: f64,
}

impl DepthRange {
    /// The empty range, the identity of [`DepthRange::union`].
    pub const EMPTY: DepthRange = DepthRange {
        near: f64::INFINITY,
        far: f64::NEG_INFINITY,
    };

    /// The smallest range holding both.
    pub fn union(self, other: DepthRange) -> DepthRange {
        DepthRange {
            near: self.near.min(other.near),
            far: self.far.max(other.far),
        }
    }
}
