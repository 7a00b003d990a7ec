//! What decides one checked frame ([`Shot`]: a bake, its placement, the camera, the options, the
//! light), the suite's views, and the f64 camera-space geometry the checks use.

use pocketsplat_core::camera::{self, Camera, Placement, Vec3, View};
use pocketsplat_core::render::RenderOptions;
use pocketsplat_core::shadow::ShadowMode;

use super::baked::{world_sphere, Baked};

/// Expected shadow state of a sample: `Some(true)` surely in shadow, `Some(false)` surely lit, `None`
/// too close to a shadow boundary to say.
pub(super) type ShadowTruth<'a> = &'a dyn Fn(usize, Vec3) -> Option<bool>;

/// Everything that decides one checked frame.
#[derive(Clone, Copy)]
pub struct Shot<'a> {
    /// The grid.
    pub baked: &'a Baked,
    /// Where the model sits.
    pub placement: Placement,
    /// The camera.
    pub camera: Camera,
    /// Cutoff, kernel, backface culling.
    pub opts: RenderOptions,
    /// Shadow mode and the world direction to the light.
    pub light: (ShadowMode, Vec3),
}

impl<'a> Shot<'a> {
    /// An orbit view of the unit placement, cutoff 1 px, square splats, backface culling on.
    pub fn orbit(baked: &'a Baked, view: View, fov_deg: f64) -> Self {
        Self::placed(baked, Placement::IDENTITY, view, fov_deg)
    }

    /// An orbit view around the placed model's bounding sphere.
    pub fn placed(baked: &'a Baked, placement: Placement, view: View, fov_deg: f64) -> Self {
        let camera = Camera::orbit(world_sphere(baked.bounds(), &placement), view, fov_deg);
        Self {
            baked,
            placement,
            camera,
            opts: RenderOptions::default(),
            light: (ShadowMode::Off, camera::direction(-40.0, 60.0)),
        }
    }

    pub(super) fn culling(mut self, on: bool) -> Self {
        self.opts.backface_culling = on;
        self
    }
}

/// Camera-space position of a model point under `placement`, computed as `R·(s·p) + (t − eye)` so that
/// a small model far from the origin keeps its precision (`placement.apply(p) − eye` would round the
/// world point to the spacing of f64 at `t` first).
pub(super) fn model_to_camera(camera: &Camera, placement: &Placement, p: Vec3) -> Vec3 {
    let r = &placement.rotation;
    let q = camera::scale(p, placement.scale);
    let d = camera::add(
        [
            camera::dot(r[0], q),
            camera::dot(r[1], q),
            camera::dot(r[2], q),
        ],
        camera::sub(placement.translation, camera.eye),
    );
    [
        camera::dot(d, camera.right),
        camera::dot(d, camera.up),
        camera::dot(d, camera.forward),
    ]
}

/// Projected screen rectangle `[x0, x1] × [y0, y1]` (pixels) of camera-space points, or `None` when
/// one of them is not in front of the eye.
pub(super) fn screen_box(camera: &Camera, pts: impl IntoIterator<Item = Vec3>) -> Option<[f64; 4]> {
    let mut b = [
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    ];
    for [x, y, z] in pts {
        if z <= 0.0 {
            return None;
        }
        let s = camera.screen(x, y, z);
        b = [
            b[0].min(s[0]),
            b[1].max(s[0]),
            b[2].min(s[1]),
            b[3].max(s[1]),
        ];
    }
    Some(b)
}

pub(super) const STD: View = View::new(30.0, 20.0, 2.5);

/// Builds a View whose eye direction (from the pivot) is `d`.
pub(super) fn view_from(d: Vec3, dist: f64) -> View {
    let d = camera::normalize(d);
    View::new(
        d[0].atan2(d[2]).to_degrees(),
        d[1].clamp(-1.0, 1.0).asin().to_degrees(),
        dist,
    )
}
