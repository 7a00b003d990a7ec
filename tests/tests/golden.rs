//! Golden images: the four standard views of the bunny at paper level 5 (depth 6), cutoff 1 px,
//! without shadows, with one-pass and two-pass shadows, and (std view) two-pass shadows from a point
//! light, compared whole-frame with the checked-in PNGs in `tests/golden/`. A mismatch names the
//! first differing pixel and the count. Every frame also has a quality floor against the f64
//! reference renderer of the mesh, shadowed frames against its exact ray-cast shadows. The same views of the bunny's QSplat file (`bunny-qs-*.png`).
//!
//! Re-recording is a deliberate, separate command:
//! `POCKETSPLAT_RECORD=1 cargo test -p pocketsplat-tests --test all golden::`.

use pocketsplat_core::bake::BakeOptions;
use pocketsplat_core::camera::STANDARD_VIEWS;
use pocketsplat_core::qs::write::{bake_qs, QsBakeOptions};
use pocketsplat_core::qs::QSplat;
use pocketsplat_core::shade::rgb565_to_rgb888;
use pocketsplat_core::tg::{TriGrid, Verify};
use pocketsplat_sim::bvh::Bvh;
use pocketsplat_sim::image::{read_rgb8_frame, write_rgb8_png};
use pocketsplat_sim::metrics::{compare_frames, psnr_rgb8, shadow_disagreement};
use pocketsplat_sim::reference::shadow_light;
use pocketsplat_sim::reference::{render_reference, render_reference_shadowed, ShadowRays};
use pocketsplat_sim::render::{render_tg_classified, FrameBuffers, Settings, ShadowMode};
use pocketsplat_tests::{model, workspace_root};

fn recording() -> bool {
    std::env::var("POCKETSPLAT_RECORD").is_ok_and(|v| v == "1")
}

/// Compares a frame with its golden image (or records it), adding any difference to `failures`.
fn check(file: &str, rgb: &[[u8; 3]], failures: &mut Vec<String>) {
    let golden = workspace_root().join("tests/golden").join(file);
    if recording() {
        write_rgb8_png(&golden, rgb).unwrap();
        eprintln!("recorded {}", golden.display());
        return;
    }
    let expected = read_rgb8_frame(&golden).unwrap_or_else(|e| {
        panic!(
            "{e:#}; record with POCKETSPLAT_RECORD=1 cargo test -p pocketsplat-tests --test all golden::"
        )
    });
    if let Some(diff) = compare_frames(&expected, rgb) {
        let actual = std::env::temp_dir().join(format!("pocketsplat-actual-{file}"));
        write_rgb8_png(&actual, rgb).unwrap();
        failures.push(format!(
            "{file}: {diff} (actual frame written to {})",
            actual.display()
        ));
    }
}

#[test]
fn bunny_standard_views_match_golden_images_and_the_reference() {
    let Some(path) = model("bun_zipper.ply.gz") else {
        return;
    };
    let mesh = pocketsplat_sim::ply::load_mesh(&path).unwrap();
    let (_, bytes) =
        pocketsplat_sim::bake::bake_mesh(&mesh, BakeOptions { rho: 3, depth: 6 }, 12, false)
            .unwrap();
    let grid = TriGrid::open(&bytes, Verify::Full).unwrap();
    let bvh = Bvh::new(&mesh);
    let mut failures = Vec::new();
    let point = [1.2, 2.0, 1.6]; // bounding radii from the centre
    for (name, view) in STANDARD_VIEWS {
        let mut off_rgb = Vec::new();
        for (mode, light_pos, suffix) in [
            (ShadowMode::Off, None, ""),
            (ShadowMode::OnePass, None, "-onepass"),
            (ShadowMode::TwoPass, None, "-twopass"),
            (ShadowMode::TwoPass, Some(point), "-point-twopass"),
        ] {
            if light_pos.is_some() && name != "std" {
                continue;
            }
            let settings = Settings {
                view,
                shadows: mode,
                light_pos,
                ..Settings::default()
            };
            let mut fb = FrameBuffers::new();
            let classified = render_tg_classified(&grid, &settings, &mut fb).unwrap();
            let rgb: Vec<[u8; 3]> = fb.pixels().iter().map(|&p| rgb565_to_rgb888(p)).collect();
            if let Some(light) = shadow_light(&settings, mesh.bounds_f32()) {
                // Against exact shadows: the lit/shadowed classification mostly agrees (measured
                // 6-7 % disagreement on the near views, 10 % far; see README) and the image is
                // closer to the shadowed reference than the unshadowed frame is.
                let camera = settings.camera(mesh.bounds_f32());
                let rays = ShadowRays { bvh: &bvh, light };
                let reference = render_reference_shadowed(
                    &mesh,
                    &camera,
                    &[settings.material],
                    settings.light_dir(),
                    Some(&rays),
                );
                let disagreement = shadow_disagreement(
                    &reference.covered,
                    &reference.shadowed,
                    &classified.covered,
                    &classified.shadowed,
                );
                let psnr = psnr_rgb8(&reference.to_rgb8(), &rgb);
                assert!(
                    disagreement < 0.12,
                    "{name}{suffix}: {:.1} % of pixels lit/shadowed unlike the ray-cast reference",
                    100.0 * disagreement
                );
                assert!(psnr > 20.0, "{name}{suffix}: PSNR {psnr:.2} dB");
                if light_pos.is_none() {
                    let off = psnr_rgb8(&reference.to_rgb8(), &off_rgb);
                    assert!(
                        psnr > off,
                        "{name}{suffix}: {psnr:.2} dB, unshadowed {off:.2} dB"
                    );
                }
            } else {
                off_rgb.clone_from(&rgb);
            }
            if mode == ShadowMode::Off {
                // Quality floor against the f64 reference (measured 27-35 dB; see README).
                let camera = settings.camera(mesh.bounds_f32());
                let reference =
                    render_reference(&mesh, &camera, &[settings.material], settings.light_dir());
                let psnr = psnr_rgb8(&reference.to_rgb8(), &rgb);
                assert!(
                    psnr > 25.0,
                    "{name}: PSNR {psnr:.2} dB against the reference"
                );
            }
            check(&format!("bunny-d6-{name}{suffix}.png"), &rgb, &mut failures);
        }
    }
    assert!(
        failures.is_empty(),
        "golden images differ:\n{}",
        failures.join("\n")
    );
}

#[test]
fn bunny_qsplat_standard_views_match_golden_images_and_the_reference() {
    let Some(path) = model("bun_zipper.ply.gz") else {
        return;
    };
    let mesh = pocketsplat_sim::ply::load_mesh(&path).unwrap();
    let baked = bake_qs(&mesh, &QsBakeOptions::default()).unwrap();
    let file = QSplat::open(&baked.bytes).unwrap();
    // The comment carries the mesh's box: the views frame the model as for the mesh and the .tg.
    assert_eq!(file.bounds(), mesh.bounds_f32());
    let mut failures = Vec::new();
    for (name, view) in STANDARD_VIEWS {
        let settings = Settings {
            view,
            ..Settings::default()
        };
        let mut fb = FrameBuffers::new();
        pocketsplat_sim::qsplat::render_qs_frame(&file, &settings, &mut fb).unwrap();
        let rgb: Vec<[u8; 3]> = fb.pixels().iter().map(|&p| rgb565_to_rgb888(p)).collect();
        let camera = settings.camera(mesh.bounds_f32());
        let reference =
            render_reference(&mesh, &camera, &[settings.material], settings.light_dir());
        let psnr = psnr_rgb8(&reference.to_rgb8(), &rgb);
        eprintln!("qsplat {name}: PSNR {psnr:.2} dB against the reference");
        // Quality floor (measured 20.0-36.0 dB: the bunny's 35k vertices are the leaves, each
        // splat as wide as the largest triangle around it; the depth-6 tri-grid resamples the
        // surface at 1.8M leaves and scores 27-35 dB).
        assert!(
            psnr > 19.0,
            "{name}: PSNR {psnr:.2} dB against the reference"
        );
        check(&format!("bunny-qs-{name}.png"), &rgb, &mut failures);
    }
    assert!(
        failures.is_empty(),
        "golden images differ:\n{}",
        failures.join("\n")
    );
}

/// Colour by resolution (issue 19): the bunny's QSplat file from the std view at a 12 px cutoff,
/// each splat tinted by its levels above full detail. Every pixel is its untinted self multiplied
/// by one of the tints (so no tint moves a splat or changes what wins a pixel), several levels show,
/// and the frame matches its golden image.
#[test]
fn bunny_qsplat_colored_by_level_matches_its_golden_image() {
    use pocketsplat_core::splat::{modulate, LEVEL_TINTS};
    let Some(path) = model("bun_zipper.ply.gz") else {
        return;
    };
    let mesh = pocketsplat_sim::ply::load_mesh(&path).unwrap();
    let baked = bake_qs(&mesh, &QsBakeOptions::default()).unwrap();
    let file = QSplat::open(&baked.bytes).unwrap();
    let plain = Settings {
        cutoff_px: 12.0,
        ..Settings::default()
    };
    let tinted = Settings {
        color_by_level: true,
        ..plain
    };
    let frame = |s: &Settings| {
        let mut fb = FrameBuffers::new();
        pocketsplat_sim::qsplat::render_qs_frame(&file, s, &mut fb).unwrap();
        fb.pixels().to_vec()
    };
    let (a, b) = (frame(&plain), frame(&tinted));
    let mut seen = [0usize; LEVEL_TINTS.len()];
    for (i, (&p, &q)) in a.iter().zip(&b).enumerate() {
        if p == 0 {
            assert_eq!(q, 0, "pixel {i}: drawn only when tinted");
            continue;
        }
        let k = LEVEL_TINTS
            .iter()
            .position(|&t| modulate(p, t) == q)
            .unwrap_or_else(|| panic!("pixel {i}: {q:#06x} is no tint of {p:#06x}"));
        seen[k] += 1;
    }
    eprintln!("pixels per level (0 = full detail): {seen:?}");
    assert!(
        seen.iter().filter(|&&n| n > 100).count() >= 3,
        "levels seen: {seen:?}"
    );
    let rgb: Vec<[u8; 3]> = b.iter().map(|&p| rgb565_to_rgb888(p)).collect();
    let mut failures = Vec::new();
    check("bunny-qs-std-levels.png", &rgb, &mut failures);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
