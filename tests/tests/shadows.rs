//! Shadows (Duguet §5.3) on scenes whose answer is known: a square floating over a ground plane, lit
//! straight down (the light exactly along an axis: ties in the light order) and at angles, including
//! grazing light on a bare plane (no self-shadowing acne).

use pocketsplat_core::bake::{bake_grid, BakeOptions, TriMesh};
use pocketsplat_core::camera::View;
use pocketsplat_core::tg::write::write_tg;
use pocketsplat_core::tg::{TriGrid, Verify};
use pocketsplat_sim::render::{render_tg_frame, FrameBuffers, Settings, ShadowMode};

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
    for el in [90.0, 60.0, 30.0, 10.0, 5.0] {
        for mode in [ShadowMode::OnePass, ShadowMode::TwoPass] {
            let (shadowed, splats, _) = render(&bytes, (30.0, el), mode);
            assert!(splats > 1000);
            assert_eq!(
                shadowed, 0,
                "{mode:?} light elevation {el}: {shadowed} of {splats} splats in shadow (acne)"
            );
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
