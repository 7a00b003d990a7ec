//! Model cases: scaled and translated models against the unit model, and depths 1 to 9.

use pocketsplat_core::camera::{self, Camera, Placement, Sphere, View};

use crate::render::FrameBuffers;
use crate::report::stability::baked::{world_sphere, Baked};
use crate::report::stability::frame::{check_drawn, shoot};
use crate::report::stability::meshes::{blob, transformed, wire};
use crate::report::stability::outcome::{Outcome, MAX_ERROR_PX};
use crate::report::stability::runner::Runner;
use crate::report::stability::shot::{Shot, STD};

/// Pixels that differ between two frames.
fn differing(a: &FrameBuffers, b: &FrameBuffers) -> usize {
    a.pixels()
        .iter()
        .zip(b.pixels())
        .filter(|(x, y)| x != y)
        .count()
}

/// Models scaled by 10⁻⁶ and 10⁶ and translated by 10⁷: by the renderer's placement, and in the mesh's
/// own coordinates before baking. The image must match the unit model's.
pub(super) fn scale(r: &mut Runner) {
    let unit_mesh = blob(40);
    let Some(unit) = r.setup("blob, tri-grid depth 4", || Baked::new(&unit_mesh, 3, 4)) else {
        return;
    };
    let views = [("std", STD), ("close", View::new(60.0, 10.0, 0.8))];
    let reference: Vec<FrameBuffers> = views
        .iter()
        .map(|(_, v)| shoot(&Shot::orbit(&unit, *v, 45.0)).fb)
        .collect();
    // 1. The renderer's placement: world = s·p + t.
    // The last one is beyond f64 world coordinates: at 10⁷ their spacing is 1.9·10⁻⁹, 10⁻³ of the
    // model's radius, so the orbit camera itself (eye and pivot) is off by that much against the
    // model and no renderer could match the unit image. That frame must still project exactly, and
    // match the unit model seen by the *same* camera (expressed in model units).
    for (name, s, t, same_camera) in [
        ("placement scale 1e-6", 1e-6, [0.0; 3], false),
        ("placement scale 1e6", 1e6, [0.0; 3], false),
        ("placement translation 1e7", 1.0, [1e7, -1e7, 1e7], false),
        (
            "placement scale 1e6, translation 1e7",
            1e6,
            [1e7, 1e7, -1e7],
            false,
        ),
        (
            "placement scale 1e-6, translation 1e7",
            1e-6,
            [1e7, 1e7, 1e7],
            true,
        ),
    ] {
        let reference = &reference;
        let unit = &unit;
        r.case(name, move || {
            let placement = Placement {
                scale: s,
                translation: t,
                ..Placement::IDENTITY
            };
            let mut o = Outcome::default();
            let mut diffs = Vec::new();
            for ((vname, v), want) in views.iter().zip(reference) {
                let shot = Shot::placed(unit, placement, *v, 45.0);
                let m = shoot(&shot);
                let mo = m.outcome();
                o.worst = o.worst.max(mo.worst);
                o.failures.extend(mo.failures);
                let d = differing(&m.fb, want);
                if same_camera {
                    let c = shot.camera;
                    let unit_camera = Camera {
                        eye: camera::scale(camera::sub(c.eye, t), 1.0 / s),
                        near: c.near / s,
                        ..c
                    };
                    let same = shoot(&Shot {
                        camera: unit_camera,
                        ..Shot::orbit(unit, *v, 45.0)
                    });
                    let d_same = differing(&m.fb, &same.fb);
                    diffs.push(format!(
                        "{vname}: {d} px differ (orbit camera), {d_same} with the same camera"
                    ));
                    if d_same > 20 {
                        o.fail(format!(
                            "{vname}: {d_same} pixels differ from the unit model's, same camera"
                        ));
                    }
                } else {
                    diffs.push(format!("{vname}: {d} px differ"));
                    if d != 0 {
                        o.fail(format!("{vname}: {d} pixels differ from the unit model's"));
                    }
                }
            }
            o.unit = "px";
            o.limit = MAX_ERROR_PX;
            o.notes = format!("image vs unit model: {}", diffs.join(", "));
            o
        });
    }
    // 2. The mesh itself scaled or moved, then baked: the `.tg` root cube is f32, and f64 where f32
    // would re-grid the mesh.
    for (name, f, exact) in [
        ("mesh scaled by 2^-20", 2f64.powi(-20), true),
        ("mesh scaled by 2^20", 2f64.powi(20), true),
        ("mesh scaled by 1e-6", 1e-6, false),
        ("mesh scaled by 1e6", 1e6, false),
    ] {
        let (reference, unit_mesh) = (&reference, &unit_mesh);
        r.case(name, move || {
            let b = Baked::new(&transformed(unit_mesh, |p| p.map(|c| c * f)), 3, 4);
            let mut o = Outcome::default();
            let mut diffs = Vec::new();
            for ((vname, v), want) in views.iter().zip(reference) {
                let m = shoot(&Shot::orbit(&b, *v, 45.0));
                let mo = m.outcome();
                o.worst = o.worst.max(mo.worst);
                o.failures.extend(mo.failures);
                let d = differing(&m.fb, want);
                diffs.push(format!("{vname}: {d} px differ"));
                // A power of two scales every f32 and f64 exactly: the frame must be bit-identical.
                // Otherwise the f32 root cube rounds differently at each scale (6·10⁻⁸ relative),
                // which moves splats by ~10⁻⁵ px: a handful of pixel-centre decisions may flip.
                let allowed = if exact { 0 } else { 20 };
                if d > allowed {
                    o.fail(format!("{vname}: {d} pixels differ (allowed {allowed})"));
                }
            }
            o.unit = "px";
            o.limit = MAX_ERROR_PX;
            o.notes = format!("image vs unit model: {}", diffs.join(", "));
            o
        });
    }
    let (reference, unit_mesh) = (&reference, &unit_mesh);
    r.case("mesh translated by 1e7, then baked", move || {
        let t = [1e7, -1e7, 1e7];
        let b = Baked::new(
            &transformed(unit_mesh, |p| [p[0] + t[0], p[1] + t[1], p[2] + t[2]]),
            3,
            4,
        );
        let mut o = Outcome::default();
        // The `f32` root cube and bounds have a spacing of 1 model unit (half the blob) at 10⁷: the
        // baker builds the grid on an `f64` cube and the file stores it in the header's extension
        // (FORMAT.md, flag bit 2), which the frame and the orbit camera use.
        if !b.tg().header().has_precise() {
            o.fail("the file has no precise (f64) root cube");
        }
        let mut diffs = Vec::new();
        for ((vname, v), want) in views.iter().zip(reference) {
            let m = shoot(&Shot::orbit(&b, *v, 45.0));
            let mo = m.outcome();
            o.worst = o.worst.max(mo.worst);
            o.failures.extend(mo.failures);
            let d = differing(&m.fb, want);
            diffs.push(format!("{vname}: {d} px differ"));
            // As for a mesh scaled by 10⁶: the f64 cube is not the unit model's f32 one bit for bit
            // (6·10⁻⁸ of the side apart), so a handful of pixel-centre decisions may flip.
            if d > 20 {
                o.fail(format!("{vname}: {d} pixels differ (allowed 20)"));
            }
        }
        o.unit = "px";
        o.limit = MAX_ERROR_PX;
        o.notes = format!("image vs unit model: {}", diffs.join(", "));
        o
    });
}

/// Depths 1 to 9, tri-grid and octree, on a wire (few cells even at depth 9) and a sphere.
pub(super) fn depth(r: &mut Runner) {
    let w = wire();
    for (rho, depths) in [(3u8, 1..=9u8), (2, 1..=9)] {
        for d in depths {
            let w = &w;
            r.case(format!("wire, rho {rho}, depth {d}"), move || {
                let b = Baked::new(w, rho, d);
                let mut o = Outcome {
                    unit: "px",
                    limit: MAX_ERROR_PX,
                    ..Outcome::default()
                };
                let mut splats = 0;
                let mut deepest = 0;
                let sphere = world_sphere(b.bounds(), &Placement::IDENTITY);
                // The last view orbits a point of the wire 0.05 units away, so the descent reaches
                // the leaves at every depth.
                let on_wire = Sphere {
                    center: w.positions[0],
                    ..sphere
                };
                for (pivot, v, cutoff) in [
                    (sphere, STD, 1.0),
                    (sphere, View::new(10.0, 5.0, 0.2), 0.5),
                    (sphere, View::new(-100.0, -40.0, 0.01), 0.5),
                    (on_wire, View::new(40.0, 25.0, 0.05 / sphere.radius), 0.5),
                ] {
                    let mut shot = Shot::orbit(&b, v, 45.0).culling(false);
                    shot.camera = Camera::orbit(pivot, v, 45.0);
                    shot.opts.cutoff_px = cutoff;
                    let m = shoot(&shot);
                    let mo = m.outcome();
                    o.worst = o.worst.max(mo.worst);
                    o.failures.extend(mo.failures);
                    splats += m.stats.splats;
                    deepest = deepest.max(m.stats.max_level);
                }
                if deepest != d {
                    o.fail(format!(
                        "the nearest view draws down to level {deepest}, not {d}"
                    ));
                }
                let cells: usize = b.centres.iter().map(Vec::len).sum();
                o.notes =
                    format!("{cells} cells, {splats} splats over 4 views, down to level {deepest}");
                o
            });
        }
    }
    let s = blob(24);
    for d in 1..=5u8 {
        let s = &s;
        r.case(format!("blob, rho 3, depth {d}"), move || {
            let b = Baked::new(s, 3, d);
            check_drawn(&Shot::orbit(&b, View::new(-20.0, 35.0, 0.9), 45.0))
        });
    }
}
