//! Shape cases: one triangle, a flat plane (α = ρ²), a needle, and the stiff cluster.

use std::fmt::Write as _;

use pocketsplat_core::camera::{self, View, WIDTH};
use pocketsplat_core::tg::frame::PRECISION_ERROR_PX;
use pocketsplat_core::tg::TgFrame;

use crate::report::stability::baked::{world_sphere, Baked};
use crate::report::stability::frame::{check, check_drawn, shoot};
use crate::report::stability::meshes::{
    cluster_with_outliers, flat_plane, needle, single_triangle,
};
use crate::report::stability::outcome::Outcome;
use crate::report::stability::runner::Runner;
use crate::report::stability::shot::{view_from, Shot, STD};

/// A single triangle, a flat plane (α = 9 exactly), a needle, and a dense cluster with far outliers.
pub(super) fn shapes(r: &mut Runner) {
    // Single triangle.
    if let Some(b) = r.setup("single triangle, depth 5", || {
        Baked::new(&single_triangle(), 3, 5)
    }) {
        let n = {
            let m = single_triangle();
            let p = m.positions;
            camera::normalize(camera::cross(
                camera::sub(p[1], p[0]),
                camera::sub(p[2], p[0]),
            ))
        };
        r.case("single triangle, std view", || {
            check_drawn(&Shot::orbit(&b, STD, 45.0))
        });
        r.case("single triangle, face on", || {
            check_drawn(&Shot::orbit(&b, view_from(n, 2.0), 45.0))
        });
        r.case("single triangle, edge on", || {
            let edge = camera::normalize(camera::cross(n, [0.0, 1.0, 0.0]));
            check(&Shot::orbit(&b, view_from(edge, 2.0), 45.0))
        });
        r.case("single triangle, from behind (all backfacing)", || {
            let m = shoot(&Shot::orbit(
                &b,
                view_from(camera::scale(n, -1.0), 2.0),
                45.0,
            ));
            let mut o = m.outcome();
            let _ = write!(o.notes, "; {} backfacing skipped", m.stats.backfacing);
            o
        });
    }
    // Flat plane, α = 9.
    if let Some(b) = r.setup("flat plane, depth 5", || Baked::new(&flat_plane(), 3, 5)) {
        r.case("flat plane: alpha = 9 exactly at every level", || {
            let alphas: Vec<f64> = (0..usize::from(b.grid.depth()))
                .map_while(|l| b.grid.alpha(l))
                .collect();
            let worst = alphas.iter().map(|a| (a - 9.0).abs()).fold(0.0, f64::max);
            let mut o = Outcome {
                worst,
                unit: "",
                limit: 0.0,
                notes: format!("alpha per level {alphas:?}"),
                ..Outcome::default()
            };
            if worst != 0.0 {
                o.fail("alpha is not exactly 9");
            }
            o
        });
        for (name, view, drawn) in [
            (
                "flat plane from straight above (EL 90)",
                View::new(0.0, 90.0, 2.0),
                true,
            ),
            (
                "flat plane from straight above (EL 90, AZ 45)",
                View::new(45.0, 90.0, 2.0),
                true,
            ),
            (
                "flat plane edge on (EL 0)",
                View::new(30.0, 0.0, 2.0),
                false,
            ),
            (
                "flat plane at grazing EL 0.5",
                View::new(30.0, 0.5, 2.0),
                true,
            ),
            (
                "flat plane from below (EL -90, backfacing)",
                View::new(0.0, -90.0, 2.0),
                false,
            ),
            (
                "flat plane, eye 0.01 radii above it",
                View::new(10.0, 0.4, 0.9),
                true,
            ),
        ] {
            r.case(name, || {
                let shot = Shot::orbit(&b, view, 45.0);
                if drawn {
                    check_drawn(&shot)
                } else {
                    check(&shot)
                }
            });
        }
        // The grid turned in the image: squares of the projected side would leave pixel centres
        // between them (a turn of 45° needs √2 sides); the flat model's footprint must not.
        for (az, el) in [
            (0.0, 90.0),
            (20.0, 70.0),
            (45.0, 60.0),
            (30.0, 20.0),
            (-45.0, 30.0),
        ] {
            for cutoff in [1.0, 4.0, 8.0, 16.0] {
                let name = format!("flat plane turned, AZ {az} EL {el}, {cutoff} px: no holes");
                r.case(&name, || {
                    let mut shot = Shot::orbit(&b, View::new(az, el, 2.0), 45.0);
                    shot.opts.cutoff_px = cutoff;
                    plane_holes(&shot)
                });
            }
        }
    }
    // Needle.
    if let Some(b) = r.setup("needle, depth 7", || Baked::new(&needle(), 3, 7)) {
        for (name, view) in [
            ("needle, std view", STD),
            ("needle, along its axis", View::new(90.0, 0.0, 2.0)),
            ("needle, across it", View::new(0.0, 0.0, 2.0)),
            ("needle, eye at 0.01 radii", View::new(80.0, 3.0, 0.01)),
        ] {
            r.case(name, || check(&Shot::orbit(&b, view, 45.0).culling(false)));
        }
    }
    // Dense cluster with far outliers.
    if let Some(b) = r.setup("cluster with outliers, depth 9", || {
        Baked::new(&cluster_with_outliers(), 3, 9)
    }) {
        for (name, view) in [
            ("cluster + outliers (1e6), std view", STD),
            (
                "cluster + outliers (1e6), eye at 0.001 radii",
                View::new(30.0, 20.0, 1e-3),
            ),
            (
                "cluster + outliers (1e6), eye at 0.01 radii",
                View::new(-60.0, -10.0, 1e-2),
            ),
        ] {
            r.case(name, || {
                let mut shot = Shot::orbit(&b, view, 45.0).culling(false);
                shot.opts.cutoff_px = 0.5;
                check_drawn(&shot)
            });
        }
        // Beyond the orbit camera (whose near plane is 10⁻³ radii): an eye 100 and 10 cluster radii
        // from the cluster, near plane 10⁻⁸ radii. One frame scale covers the root cube, so `W` has
        // about 2²¹ steps over it and the cluster is some 100 or 10 steps from the eye, where the
        // rounding of the tables could move it by pixels (0.2 and 0.8 px were measured before
        // issue 18): the frame's precision plane (`TgFrame::near_depth`) must clip it, as a near
        // plane would, rather than draw it misplaced.
        for (name, dist) in [
            (
                "cluster + outliers (1e6), eye 1e-4 radii from the cluster",
                1e-4,
            ),
            (
                "cluster + outliers (1e6), eye 1e-5 radii from the cluster",
                1e-5,
            ),
        ] {
            r.case(name, || {
                let mut shot = Shot::orbit(&b, View::new(20.0, 10.0, dist), 45.0).culling(false);
                let radius = world_sphere(b.bounds(), &shot.placement).radius;
                shot.camera.near = 1e-8 * radius;
                shot.opts.cutoff_px = 0.5;
                let m = shoot(&shot);
                let mut o = m.outcome();
                if m.near_depth < 2.0 * dist * radius {
                    o.fail(format!(
                        "the frame's near plane is at {:.2e} radii, in front of the cluster",
                        m.near_depth / radius
                    ));
                }
                if m.stats.splats != 0 {
                    o.fail(format!(
                        "{} splats drawn nearer than the precision plane",
                        m.stats.splats
                    ));
                }
                let _ = write!(
                    o.notes,
                    "; the frame's precision plane at {:.2e} radii clips the cluster",
                    m.near_depth / radius
                );
                o
            });
        }
        // The precision plane's bound, checked where it is tightest: the eye just beyond it from
        // the cluster, whose cell must be drawn within `PRECISION_ERROR_PX` (0.4 px).
        r.case(
            "cluster + outliers (1e6), eye 1.1 precision planes from the cluster",
            || {
                let view = |dist| View::new(20.0, 10.0, dist);
                let mut shot = Shot::orbit(&b, view(1e-5), 45.0).culling(false);
                let radius = world_sphere(b.bounds(), &shot.placement).radius;
                // The plane's depth hardly depends on where the eye is (the frame's scale is set by
                // the whole root cube), so one look at it places the eye.
                let probe =
                    TgFrame::new(b.tg().header(), &shot.placement, &shot.camera, &shot.opts)
                        .expect("frame set-up");
                let dist = 1.1 * probe.near_depth() / radius;
                shot = Shot::orbit(&b, view(dist), 45.0).culling(false);
                shot.camera.near = 1e-8 * radius;
                shot.opts.cutoff_px = 0.5;
                let mut o = check_drawn(&shot);
                let m = shoot(&shot);
                if m.stats.splats == 0 || m.near_depth > dist * radius {
                    o.fail(format!(
                        "the cluster at {dist:.2e} radii is not drawn (precision plane at {:.2e})",
                        m.near_depth / radius
                    ));
                }
                if o.worst > PRECISION_ERROR_PX {
                    o.fail(format!(
                        "error {:.3} px beyond the precision plane (bound {PRECISION_ERROR_PX} px)",
                        o.worst
                    ));
                }
                let _ = write!(o.notes, "; eye {dist:.2e} radii from the cluster");
                o
            },
        );
        r.case(
            "cluster + outliers (1e6): the cluster's cell is drawn",
            || {
                // The cluster is far below a depth-9 cell (10⁻⁶ vs 10⁻⁴): one leaf holds it, and an eye 0.01
                // radii away must see that leaf at the f64 position of its centre.
                let mut shot = Shot::orbit(&b, View::new(0.0, 0.0, 0.01), 45.0).culling(false);
                shot.opts.cutoff_px = 0.5;
                let m = shoot(&shot);
                let mut o = m.outcome();
                if m.stats.max_level != 9 {
                    o.fail(format!(
                        "deepest level drawn {} (want 9)",
                        m.stats.max_level
                    ));
                }
                o
            },
        );
    }
}

/// Checks a frame of [`flat_plane`] (the square `|x|, |z| ≤ 1` at `y = 0`, identity placement)
/// for holes: pixel centres whose ray meets the plane inside it (0.1 in from its edges, where the
/// coarse cells' centroids move in) that no splat covers.
fn plane_holes(shot: &Shot<'_>) -> Outcome {
    let m = shoot(shot);
    let mut o = m.outcome();
    let cam = &shot.camera;
    let (cx, cy) = cam.viewport.center();
    let covered = m.fb.covered();
    let mut inside = 0usize;
    let mut holes = Vec::new();
    for (i, &c) in covered.iter().enumerate() {
        let (px, py) = ((i % WIDTH) as f64 + 0.5, (i / WIDTH) as f64 + 0.5);
        let d = camera::add(
            camera::add(
                camera::scale(cam.right, (px - cx) / cam.focal_px),
                camera::scale(cam.up, (cy - py) / cam.focal_px),
            ),
            cam.forward,
        );
        let t = -cam.eye[1] / d[1];
        let hit = camera::add(cam.eye, camera::scale(d, t));
        if t > cam.near && hit[0].abs() <= 0.9 && hit[2].abs() <= 0.9 {
            inside += 1;
            if !c {
                holes.push((i % WIDTH, i / WIDTH));
            }
        }
    }
    o.worst = holes.len() as f64;
    o.unit = "holes";
    o.limit = 0.0;
    let _ = write!(
        o.notes,
        "; {} of the plane's {inside} pixel centres uncovered, footprint {:.3} sides",
        holes.len(),
        m.footprint
    );
    if inside == 0 {
        o.fail("the plane covers no pixel centre: nothing checked");
    }
    if !holes.is_empty() {
        o.fail(format!(
            "{} pixel centres on the plane uncovered, first at {:?}",
            holes.len(),
            holes[0]
        ));
    }
    o
}
