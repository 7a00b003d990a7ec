//! `--size WxH`: a frame of any size, its projection following the buffers, matches the reference
//! renderer at that size as well as the 240 × 320 frame matches it at 240 × 320 (issue 20).

use crate::common;

use common::{model, pocketsplat};
use pocketsplat_core::bake::BakeOptions;
use pocketsplat_core::camera::Viewport;
use pocketsplat_core::render::Model;
use pocketsplat_core::tg::Verify;
use pocketsplat_sim::image::read_rgb8_png;
use pocketsplat_sim::metrics::{coverage_mismatch, psnr_rgb8};
use pocketsplat_sim::reference::render_reference;
use pocketsplat_sim::render::{render_frame, Settings};

/// PSNR (dB) and coverage mismatch of the tri-grid's frame against the reference's, at `size`.
fn against_reference(
    mesh: &pocketsplat_core::bake::TriMesh,
    tg: &Model<'_>,
    size: Viewport,
) -> (f64, f64) {
    let settings = Settings {
        size,
        ..Settings::default()
    };
    let mut fb = settings.buffers();
    render_frame(tg, &settings, &mut fb).unwrap();
    assert_eq!(fb.pixels().len(), size.pixels());
    let ours: Vec<[u8; 3]> = fb
        .pixels()
        .iter()
        .map(|&p| pocketsplat_core::shade::rgb565_to_rgb888(p))
        .collect();
    // The reference renderer at the same size, from the same camera (which `settings.camera` fits
    // to the size).
    let cam = settings.camera(mesh.bounds_f32());
    assert_eq!(cam.viewport, size);
    let reference = render_reference(mesh, &cam, &[settings.material], settings.light_dir());
    assert_eq!(reference.covered.len(), size.pixels());
    (
        psnr_rgb8(&reference.to_rgb8(), &ours),
        coverage_mismatch(&reference.covered, &fb.covered()),
    )
}

#[test]
fn every_size_matches_the_reference_as_well_as_the_reference_frame_does() {
    let Some(path) = model("bun_zipper.ply.gz") else {
        return;
    };
    let mesh = pocketsplat_sim::ply::load_mesh(&path).unwrap();
    let (_, bytes) =
        pocketsplat_sim::bake::bake_mesh(&mesh, BakeOptions { rho: 3, depth: 6 }, 12, false)
            .unwrap();
    let tg = Model::open_with(&bytes, Verify::Full).unwrap();
    let (psnr, mismatch) = against_reference(&mesh, &tg, Viewport::DEFAULT);
    eprintln!(
        "240x320: {psnr:.2} dB, coverage mismatch {:.3} %",
        mismatch * 100.0
    );
    for (w, h) in [(320, 240), (128, 160), (240, 240), (96, 64), (480, 320)] {
        let size = Viewport::new(w, h).unwrap();
        let (p, m) = against_reference(&mesh, &tg, size);
        eprintln!("{w}x{h}: {p:.2} dB, coverage mismatch {:.3} %", m * 100.0);
        // As well as the reference frame: within 2 dB (a smaller image has fewer, larger splats,
        // whose edges weigh more) and no worse coverage than twice its mismatch plus a pixel row.
        assert!(
            p > psnr - 2.0,
            "{w}x{h}: {p:.2} dB against {psnr:.2} dB at 240x320"
        );
        assert!(
            m < 2.0 * mismatch + 1.0 / f64::from(h),
            "{w}x{h}: coverage mismatch {m} against {mismatch} at 240x320"
        );
    }
}

#[test]
fn render_size_writes_an_image_of_that_size_and_refuses_bad_sizes() {
    let dir = tempfile::tempdir().unwrap();
    let tg = dir.path().join("knot.tg");
    std::fs::write(&tg, pocketsplat_sim::demo::example_tg().unwrap()).unwrap();
    for (size, w, h) in [
        ("320x240", 320, 240),
        ("128x160", 128, 160),
        ("240x240", 240, 240),
    ] {
        let out = dir.path().join(format!("{size}.png"));
        let run = pocketsplat(
            &[
                "render",
                "knot.tg",
                "-o",
                out.to_str().unwrap(),
                "--size",
                size,
            ],
            dir.path(),
        );
        assert!(
            run.status.success(),
            "{}",
            String::from_utf8_lossy(&run.stderr)
        );
        let img = read_rgb8_png(&out).unwrap();
        assert_eq!((img.width, img.height), (w, h), "{size}");
        assert!(
            img.pixels.iter().filter(|p| **p != [0, 0, 0]).count() > 500,
            "{size}"
        );
    }
    for (bad, says) in [
        ("320", "WIDTHxHEIGHT"),
        ("0x240", "from 16"),
        ("320x99999", "from 16"),
        ("ax240", "whole number"),
    ] {
        let run = pocketsplat(
            &["render", "knot.tg", "-o", "x.png", "--size", bad],
            dir.path(),
        );
        let err = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success() && err.contains(says), "{bad}: {err}");
        assert!(!dir.path().join("x.png").exists());
    }
}
