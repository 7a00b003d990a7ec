//! Shadows (Duguet §5.3) on scenes whose answer is known: a square floating over a ground plane, lit
//! straight down (the light exactly along an axis: ties in the light order) and at angles, including
//! grazing light on a bare plane (no self-shadowing acne); and a box over a plane against the
//! reference renderer's exact ray-cast shadows, for both algorithms, at several cutoffs (samples of
//! different levels, so cells of different sizes) and under a point light.

use pocketsplat_core::bake::{bake_grid, BakeOptions, TriMesh};
use pocketsplat_core::camera::View;
use pocketsplat_core::tg::write::write_tg;
use pocketsplat_core::tg::{TriGrid, Verify};
use pocketsplat_sim::bvh::Bvh;
use pocketsplat_sim::metrics::shadow_disagreement;
use pocketsplat_sim::reference::shadow_light;
use pocketsplat_sim::reference::{render_reference_shadowed, ShadowRays};
use pocketsplat_sim::render::{
    render_tg_classified, render_tg_frame, FrameBuffers, Settings, ShadowMode,
};
use pocketsplat_sim::shapes::{boxmesh, merge, uv_sphere};

/// A unit ground square at y = 0 and, when `floating`, a 0.3-wide square at y = 0.5 above its centre.
fn scene(floating: bool) -> TriMesh {
    let mut positions = vec![
        [-1.0, 0.0, -1.0],
        [1.0, 0.0, -1.0],
        [1.0, 0.0, 1.0],
        [-1.0, 0.0, 1.0],
    ];
    let mut triangles = vec![[0, 2, 1], [0, 3, 2]];
    if floating {
        positions.extend([
            [-0.3, 0.5, -0.3],
            [0.3, 0.5, -0.3],
            [0.3, 0.5, 0.3],
            [-0.3, 0.5, 0.3],
        ]);
        triangles.extend([[4, 6, 5], [4, 7, 6]]);
    }
    // A zero-area triangle reaching y = 1 makes the bounding cube tall enough for both.
    positions.push([0.0, 1.0, 0.0]);
    let top = positions.len() as u32 - 1;
    triangles.push([top, top, top]);
    TriMesh {
        positions,
        triangles,
        materials: None,
        colors: None,
    }
}

fn tg(mesh: &TriMesh) -> Vec<u8> {
    let g = bake_grid(mesh, BakeOptions { rho: 3, depth: 5 }, None).unwrap();
    write_tg(&g, 12).unwrap()
}

/// Renders from straight above (looking down −Y) and returns (shadowed splats, splats, frame).
fn render(bytes: &[u8], light: (f64, f64), mode: ShadowMode) -> (u32, u32, FrameBuffers) {
    let grid = TriGrid::open(bytes, Verify::Full).unwrap();
    let settings = Settings {
        view: View::new(0.0, 89.9, 2.5),
        light_az_el: light,
        shadows: mode,
        ..Settings::default()
    };
    let mut fb = FrameBuffers::new();
    let r = render_tg_frame(&grid, &settings, &mut fb).unwrap();
    (r.stats.shadowed, r.stats.splats, fb)
}

#[test]
fn a_bare_plane_is_lit_everywhere_from_overhead_to_grazing() {
    let bytes = tg(&scene(false));
    let grid = TriGrid::open(&bytes, Verify::Full).unwrap();
    for el in [90.0, 60.0, 30.0, 10.0, 5.0] {
        for mode in [ShadowMode::OnePass, ShadowMode::TwoPass] {
            // Cutoffs above 1 px draw samples of several levels: cells of different sizes, each with
            // its own footprint and bias.
            for cutoff_px in [1.0, 3.0, 8.0] {
                let settings = Settings {
                    view: View::new(0.0, 89.9, 2.5),
                    light_az_el: (30.0, el),
                    shadows: mode,
                    cutoff_px,
                    ..Settings::default()
                };
                let r = render_tg_frame(&grid, &settings, &mut FrameBuffers::new()).unwrap();
                let (shadowed, splats) = (r.stats.shadowed, r.stats.splats);
                assert!(splats > 100, "{splats} splats");
                assert_eq!(
                    shadowed, 0,
                    "{mode:?} light elevation {el}, cutoff {cutoff_px}: {shadowed} of {splats} \
                     splats in shadow (acne)"
                );
            }
        }
    }
}

#[test]
fn a_floating_square_casts_its_own_shape_straight_down() {
    let bytes = tg(&scene(true));
    for mode in [ShadowMode::OnePass, ShadowMode::TwoPass] {
        let (shadowed, splats, fb) = render(&bytes, (0.0, 90.0), mode);
        let (_, _, lit) = render(&bytes, (0.0, 90.0), ShadowMode::Off);
        assert!(shadowed > 0, "{mode:?}");
        // Seen from above, the square hides its own shadow: the image equals the unshadowed one
        // except where ground samples peek out around the square's edge.
        let differ = fb
            .pixels()
            .iter()
            .zip(lit.pixels())
            .filter(|(a, b)| a != b)
            .count();
        assert!(
            differ < 200,
            "{mode:?}: {differ} pixels differ from the unshadowed frame"
        );
        assert!(shadowed < splats / 4, "{mode:?}: {shadowed} of {splats}");
    }
}

#[test]
fn an_oblique_light_shadows_the_ground_beside_the_square_and_both_algorithms_agree() {
    let bytes = tg(&scene(true));
    let (one, splats, fb1) = render(&bytes, (90.0, 45.0), ShadowMode::OnePass);
    let (two, _, fb2) = render(&bytes, (90.0, 45.0), ShadowMode::TwoPass);
    let (_, _, lit) = render(&bytes, (90.0, 45.0), ShadowMode::Off);
    // The shadow falls 0.5 to the −X side, onto the ground square [-0.8, -0.2] × [-0.3, 0.3]:
    // count the pixels darkened against the unshadowed frame.
    let dark = |fb: &FrameBuffers| {
        fb.pixels()
            .iter()
            .zip(lit.pixels())
            .filter(|(a, b)| a != b)
            .count()
    };
    let (d1, d2) = (dark(&fb1), dark(&fb2));
    assert!(
        one > splats / 30 && two > splats / 30,
        "one-pass {one}, two-pass {two} of {splats}"
    );
    assert!(d1 > 1000 && d2 > 1000, "darkened pixels: {d1}, {d2}");
    let rel = (d1 as f64 - d2 as f64).abs() / d2 as f64;
    assert!(
        rel < 0.15,
        "one-pass and two-pass shadows differ by {:.0}%",
        rel * 100.0
    );
    // And the shadow is on the −X side of the image (the camera looks down with +X to the right).
    let left = |fb: &FrameBuffers| {
        fb.pixels()
            .iter()
            .zip(lit.pixels())
            .enumerate()
            .filter(|(i, (a, b))| a != b && i % 240 < 120)
            .count()
    };
    assert!(left(&fb1) > d1 * 9 / 10, "shadow on the wrong side");
}

/// A box floating over the ground.
fn box_scene() -> TriMesh {
    merge(
        scene(false),
        &boxmesh([-0.35, 0.25, -0.3], [0.3, 0.6, 0.35]),
    )
}

/// A sphere floating over the ground: no face is edge-on to a light along an axis (a box's sides
/// would be, and `n·l = 0` has no robust lit/unlit answer).
fn sphere_scene() -> TriMesh {
    merge(scene(false), &uv_sphere([0.1, 0.5, -0.1], 0.3, 32, 64))
}

/// The lit/shadowed disagreement of a frame with the reference's ray-cast shadows (same light,
/// same view), and the reference's unlit pixel count.
fn against_rays(
    mesh: &TriMesh,
    bvh: &Bvh,
    grid: &TriGrid<'_>,
    settings: &Settings,
) -> (f64, usize) {
    let lit = Settings {
        shadows: ShadowMode::TwoPass,
        ..*settings
    };
    let rays = ShadowRays {
        bvh,
        light: shadow_light(&lit, mesh.bounds_f32()).unwrap(),
    };
    let reference = render_reference_shadowed(
        mesh,
        &settings.camera(mesh.bounds_f32()),
        &[settings.material],
        settings.light_dir(),
        Some(&rays),
    );
    let c = render_tg_classified(grid, settings, &mut FrameBuffers::new()).unwrap();
    let d = shadow_disagreement(
        &reference.covered,
        &reference.shadowed,
        &c.covered,
        &c.shadowed,
    );
    (d, reference.shadowed_count())
}

#[test]
fn both_algorithms_agree_with_ray_cast_shadows_where_no_shadows_do_not() {
    let scenes = [box_scene(), sphere_scene()];
    let bvhs = scenes.each_ref().map(Bvh::new);
    let bytes = scenes.each_ref().map(tg);
    let grids = bytes
        .each_ref()
        .map(|b| TriGrid::open(b, Verify::Full).unwrap());
    for (k, light, view) in [
        (0, (30.0, 50.0), View::new(200.0, 55.0, 2.5)),
        // Exactly along an axis: layers of sub-cells tie in the light order.
        (1, (0.0, 90.0), View::new(200.0, 30.0, 2.2)),
        // Grazing: a long shadow, and the largest slope bias.
        (0, (-70.0, 12.0), View::new(110.0, 50.0, 2.5)),
        (1, (60.0, 15.0), View::new(-100.0, 45.0, 2.5)),
    ] {
        let (mesh, bvh, grid) = (&scenes[k], &bvhs[k], &grids[k]);
        // Cutoffs above 1 px draw samples of several levels.
        for cutoff_px in [1.0, 4.0] {
            let at = |shadows| Settings {
                view,
                light_az_el: light,
                shadows,
                cutoff_px,
                ..Settings::default()
            };
            let (off, unlit) = against_rays(mesh, bvh, grid, &at(ShadowMode::Off));
            let (one, _) = against_rays(mesh, bvh, grid, &at(ShadowMode::OnePass));
            let (two, _) = against_rays(mesh, bvh, grid, &at(ShadowMode::TwoPass));
            eprintln!(
                "scene {k} light {light:?} cutoff {cutoff_px}: reference unlit {unlit}, disagreement off \
                 {:.2} %, one-pass {:.2} %, two-pass {:.2} %",
                100.0 * off,
                100.0 * one,
                100.0 * two
            );
            assert!(unlit > 1000);
            assert!(
                one < 0.03 && two < 0.03,
                "light {light:?} cutoff {cutoff_px}: one-pass {one:.4}, two-pass {two:.4}"
            );
            assert!(off > 3.0 * one.max(two), "light {light:?}: off {off:.4}");
        }
    }
}

#[test]
fn a_point_light_casts_two_pass_shadows_that_agree_with_rays_to_the_point() {
    let mesh = box_scene();
    let bvh = Bvh::new(&mesh);
    let bytes = tg(&mesh);
    let grid = TriGrid::open(&bytes, Verify::Full).unwrap();
    for (pos, view) in [
        ([1.3, 1.1, 0.3], View::new(-60.0, 50.0, 2.5)),
        ([-0.6, 1.6, 1.4], View::new(170.0, 45.0, 2.5)),
    ] {
        let at = |shadows| Settings {
            view,
            light_pos: Some(pos),
            shadows,
            ..Settings::default()
        };
        let (off, unlit) = against_rays(&mesh, &bvh, &grid, &at(ShadowMode::Off));
        let (two, _) = against_rays(&mesh, &bvh, &grid, &at(ShadowMode::TwoPass));
        eprintln!(
            "point {pos:?}: reference unlit {unlit}, disagreement off {:.2} %, two-pass {:.2} %",
            100.0 * off,
            100.0 * two
        );
        assert!(unlit > 1000);
        assert!(two < 0.03, "point {pos:?}: two-pass {two:.4}");
        assert!(off > 3.0 * two, "point {pos:?}: off {off:.4}");
        // The same direction as a directional light shadows differently: the point matters.
        let parallel = Settings {
            light_pos: None,
            light_az_el: {
                let d = pocketsplat_core::camera::normalize(pos);
                (d[0].atan2(d[2]).to_degrees(), d[1].asin().to_degrees())
            },
            ..at(ShadowMode::TwoPass)
        };
        let (_, unlit_parallel) = against_rays(&mesh, &bvh, &grid, &parallel);
        assert!(
            unlit.abs_diff(unlit_parallel) > 200,
            "{unlit} vs {unlit_parallel}"
        );
        // One pass needs a single light direction.
        let err = render_tg_frame(&grid, &at(ShadowMode::OnePass), &mut FrameBuffers::new())
            .unwrap_err()
            .to_string();
        assert!(err.contains("directional"), "{err}");
    }
}

#[test]
fn a_frame_without_shadows_allocates_no_shadow_map() {
    let bytes = tg(&box_scene());
    let grid = TriGrid::open(&bytes, Verify::Full).unwrap();
    let mut fb = FrameBuffers::new();
    render_tg_frame(&grid, &Settings::default(), &mut fb).unwrap();
    assert!(fb.shadow_map().is_empty(), "shadows off allocated a map");
    for mode in [ShadowMode::OnePass, ShadowMode::TwoPass] {
        let settings = Settings {
            shadows: mode,
            shadow_map_size: 100,
            ..Settings::default()
        };
        render_tg_frame(&grid, &settings, &mut fb).unwrap();
        assert_eq!(
            fb.shadow_map().len(),
            100 * 100,
            "{mode:?}: the map is the size asked for"
        );
    }
}
