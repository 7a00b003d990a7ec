//! The camera convention every renderer shares, in f64 (per-frame setup, never per node).
//!
//! Models are Y-up. The camera orbits the centre of the model's bounding sphere (the sphere around its
//! bounding box): azimuth `az` degrees around +Y from +Z towards +X, elevation `el` degrees up,
//! distance `dist` in bounding-sphere radii, looking at the centre. The image is 240 × 320 (portrait);
//! pixel `(i, j)` covers `[i, i+1) × [j, j+1)` with `j` growing downwards.
//!
//! Only `libm` functions and IEEE-exact operations are used, so x86 and ARM compute the same bits.

/// Framebuffer width in pixels.
pub const WIDTH: usize = 240;
/// Framebuffer height in pixels.
pub const HEIGHT: usize = 320;
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

/// A perspective camera for the 240 × 320 framebuffer.
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
    /// Focal length in pixels: `(HEIGHT / 2) / tan(fov / 2)`.
    pub focal_px: f64,
    /// Near plane distance, model units.
    pub near: f64,
}

impl Camera {
    /// The orbit camera of `view` around `sphere`, with vertical field of view `fov_deg`.
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
        [
            WIDTH as f64 / 2.0 + self.focal_px * x / z,
            HEIGHT as f64 / 2.0 - self.focal_px * y / z,
            z,
        ]
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
