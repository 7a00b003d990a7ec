//! Golden images: the four standard views of the bunny at paper level 5 (depth 6), cutoff 1 px,
//! compared whole-frame with the checked-in PNGs in `tests/golden/`. A mismatch names the first
//! differing pixel and the count.
//!
//! Re-recording is a deliberate, separate command:
//! `POCKETSPLAT_RECORD=1 cargo test -p pocketsplat-tests --test golden`.

use pocketsplat_core::bake::BakeOptions;
use pocketsplat_core::camera::STANDARD_VIEWS;
use pocketsplat_core::shade::rgb565_to_rgb888;
use pocketsplat_core::tg::{TriGrid, Verify};
use pocketsplat_sim::image::{read_rgb8_frame, write_rgb8_png};
use pocketsplat_sim::metrics::{compare_frames, psnr_rgb8};
use pocketsplat_sim::reference::render_reference;
use pocketsplat_sim::render::{render_tg_frame, FrameBuffers, Settings};
use pocketsplat_tests::{model, workspace_root};

fn recording() -> bool {
    std::env::var("POCKETSPLAT_RECORD").is_ok_and(|v| v == "1")
}

#[test]
fn bunny_standard_views_match_golden_images_and_the_reference() {
    let Some(path) = model("bun_zipper.ply.gz") else {
        return;
    };
    let mesh = pocketsplat_sim::ply::load_mesh(&path).unwrap();
    let (_, bytes) =
        pocketsplat_sim::cmd::bake::bake_mesh(&mesh, BakeOptions { rho: 3, depth: 6 }, 12, false)
            .unwrap();
    let grid = TriGrid::open(&bytes, Verify::Full).unwrap();
    let mut failures = Vec::new();
    for (name, view) in STANDARD_VIEWS {
        let settings = Settings {
            view,
            ..Settings::default()
        };
        let mut fb = FrameBuffers::new();
        render_tg_frame(&grid, &settings, &mut fb).unwrap();
        let rgb: Vec<[u8; 3]> = fb.pixels().iter().map(|&p| rgb565_to_rgb888(p)).collect();

        // Quality floor against the f64 reference (measured 27-35 dB; see README).
        let reference = render_reference(
            &mesh,
            &settings.camera(mesh.bounds_f32()),
            &[settings.material],
            settings.light_dir(),
        );
        let psnr = psnr_rgb8(&reference.to_rgb8(), &rgb);
        assert!(
            psnr > 25.0,
            "{name}: PSNR {psnr:.2} dB against the reference"
        );

        let golden = workspace_root().join(format!("tests/golden/bunny-d6-{name}.png"));
        if recording() {
            write_rgb8_png(&golden, &rgb).unwrap();
            eprintln!("recorded {}", golden.display());
            continue;
        }
        let expected = read_rgb8_frame(&golden)
            .unwrap_or_else(|e| panic!("{e:#}; record with POCKETSPLAT_RECORD=1 cargo test -p pocketsplat-tests --test golden"));
        if let Some(diff) = compare_frames(&expected, &rgb) {
            let actual =
                std::env::temp_dir().join(format!("pocketsplat-actual-bunny-d6-{name}.png"));
            write_rgb8_png(&actual, &rgb).unwrap();
            failures.push(format!(
                "{name}: {diff} (actual frame written to {})",
                actual.display()
            ));
        }
    }
    assert!(
        failures.is_empty(),
        "golden images differ:\n{}",
        failures.join("\n")
    );
}
