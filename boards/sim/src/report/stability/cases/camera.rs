//! Camera cases: distances from 10⁻³ to 10⁴ radii, eyes inside the model and near planes through
//! it, fields of view of 1° and 170°, views along each axis and over the poles.

use pocketsplat_core::camera::{self, Camera, Placement, Vec3, View};

use crate::report::stability::baked::{blob_grid, world_sphere, Baked};
use crate::report::stability::frame::check_drawn;
use crate::report::stability::meshes::blob;
use crate::report::stability::outcome::{Outcome, MAX_ERROR_PX};
use crate::report::stability::runner::Runner;
use crate::report::stability::shot::Shot;

/// Camera distances from 0.001 to 10 000 bounding radii (backface culling off, so that views from
/// inside draw the far walls).
pub(super) fn distance(r: &mut Runner) {
    let Some(b) = r.setup("blob, tri-grid depth 4", blob_grid) else {
        return;
    };
    for dist in [1e-3, 1e-2, 0.1, 0.5, 1.0, 2.5, 10.0, 100.0, 1e3, 1e4] {
        r.case(format!("blob at {dist} radii"), || {
            check_drawn(&Shot::orbit(&b, View::new(30.0, 20.0, dist), 45.0).culling(false))
        });
    }
}

/// Inside the model, and the near plane through it.
pub(super) fn inside(r: &mut Runner) {
    let Some(b) = r.setup("blob, tri-grid depth 5", || Baked::new(&blob(40), 3, 5)) else {
        return;
    };
    for (az, el) in [(0.0, 0.0), (123.0, -35.0), (-70.0, 60.0)] {
        r.case(format!("eye inside at 0.3 radii, view {az},{el}"), || {
            check_drawn(&Shot::orbit(&b, View::new(az, el, 0.3), 45.0).culling(false))
        });
    }
    // The blob's surface is about 0.55 bounding radii from its centre: the near plane (10⁻³ radii in
    // front of the eye) cuts it from just outside.
    r.case("eye on the surface, near plane through it", || {
        check_drawn(&Shot::orbit(&b, View::new(0.0, 0.0, 0.575), 45.0))
    });
    // A far near plane, through the middle of the model.
    for near in [0.3, 0.9] {
        r.case(
            format!("near plane at {near} radii through the middle"),
            || {
                let mut shot = Shot::orbit(&b, View::new(20.0, 10.0, 1.0), 60.0).culling(false);
                shot.camera.near = near * world_sphere(b.bounds(), &shot.placement).radius;
                check_drawn(&shot)
            },
        );
    }
    r.case(
        "eye inside at 0.3 radii, cutoff 0.25 px (descends to the leaves)",
        || {
            let mut shot = Shot::orbit(&b, View::new(45.0, 30.0, 0.3), 45.0).culling(false);
            shot.opts.cutoff_px = 0.25;
            check_drawn(&shot)
        },
    );
}

/// Field of view 1° and 170°, near and far.
pub(super) fn fov(r: &mut Runner) {
    let Some(b) = r.setup("blob, tri-grid depth 4", blob_grid) else {
        return;
    };
    for (fov, dist) in [
        (1.0, 2.5),
        (1.0, 1e4),
        (1.0, 0.3),
        (170.0, 2.5),
        (170.0, 0.3),
        (170.0, 1e3),
    ] {
        r.case(format!("FOV {fov}° at {dist} radii"), || {
            check_drawn(&Shot::orbit(&b, View::new(30.0, 20.0, dist), fov).culling(dist >= 1.0))
        });
    }
}

/// Angle between two unit vectors, degrees.
fn angle_deg(a: Vec3, b: Vec3) -> f64 {
    let c = camera::cross(a, b);
    camera::dot(c, c)
        .sqrt()
        .atan2(camera::dot(a, b))
        .to_degrees()
}

/// Looking straight along each axis, including straight up and down (elevation ±90°, where +Y is no
/// use as the camera's up reference).
pub(super) fn axes(r: &mut Runner) {
    let Some(b) = r.setup("blob, tri-grid depth 4", blob_grid) else {
        return;
    };
    for (name, az, el) in [
        ("along -Z (from +Z)", 0.0, 0.0),
        ("along +Z (from -Z)", 180.0, 0.0),
        ("along -X (from +X)", 90.0, 0.0),
        ("along +X (from -X)", -90.0, 0.0),
        ("straight down (EL 90, AZ 0)", 0.0, 90.0),
        ("straight down (EL 90, AZ 90)", 90.0, 90.0),
        ("straight up (EL -90, AZ 0)", 0.0, -90.0),
        ("straight up (EL -90, AZ 210)", 210.0, -90.0),
    ] {
        r.case(name, || {
            check_drawn(&Shot::orbit(&b, View::new(az, el, 2.5), 45.0))
        });
    }
    // The up-vector degeneracy: at EL ±90 the camera must be the limit of the cameras just off the
    // pole at the same azimuth, so that orbiting over the top turns the image continuously.
    for el in [90.0, -90.0] {
        r.case(format!("pole continuity at EL {el} (AZ 0..360)"), || {
            let s = world_sphere(b.bounds(), &Placement::IDENTITY);
            let mut worst = 0.0f64;
            let mut worst_pixels = 0.0f64;
            for az in [0.0, 30.0, 90.0, 135.0, 180.0, 270.0] {
                let at = Camera::orbit(s, View::new(az, el, 2.5), 45.0);
                let near = Camera::orbit(s, View::new(az, el - el.signum() * 1e-3, 2.5), 45.0);
                let d = angle_deg(at.right, near.right).max(angle_deg(at.up, near.up));
                worst = worst.max(d);
                // The same in pixels: how far the model's bounding-box corners move on screen.
                let (lo, hi) = (b.bounds()[0], b.bounds()[1]);
                for k in 0..8 {
                    let p: Vec3 =
                        std::array::from_fn(|a| if k >> a & 1 == 1 { hi[a] } else { lo[a] });
                    if let (Some(p1), Some(p2)) = (at.project(p), near.project(p)) {
                        worst_pixels = worst_pixels
                            .max((p1[0] - p2[0]).abs().max((p1[1] - p2[1]).abs()));
                    }
                }
            }
            let mut o = Outcome {
                worst: worst_pixels,
                unit: "px",
                limit: MAX_ERROR_PX,
                notes: format!(
                    "camera basis at the pole vs 0.001° off it: up to {worst:.4}° apart"
                ),
                ..Outcome::default()
            };
            if worst_pixels > MAX_ERROR_PX {
                o.fail(format!(
                    "the image jumps by {worst_pixels:.1} px (basis turns {worst:.1}°) onto the pole"
                ));
            }
            o
        });
    }
}
