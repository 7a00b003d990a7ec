//! `pocketsplat view` as a user meets it: without a display it refuses with a hint; under Xvfb it
//! opens its window, refines to 1 px, and shows exactly what `pocketsplat render` draws, with the HUD
//! over it.
#![cfg(feature = "window")]

use crate::common;
use common::pocketsplat;
use common::under_ci;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

use pocketsplat_sim::image::{read_rgb8_frame, read_rgb8_png};
use pocketsplat_sim::render::{HEIGHT, WIDTH};

/// The demo's trefoil knot, baked once (tri-grid, depth 5; no model files needed).
fn trefoil_tg(dir: &Path) -> PathBuf {
    static BYTES: OnceLock<Vec<u8>> = OnceLock::new();
    let bytes = BYTES.get_or_init(|| pocketsplat_sim::demo::demo_tg().expect("demo bakes"));
    let path = dir.join("trefoil.tg");
    std::fs::write(&path, bytes).unwrap();
    path
}

/// `program` on the PATH, or `None` with a note (a failure under CI, where nothing may be skipped).
fn tool(program: &str, package: &str) -> Option<PathBuf> {
    let found = std::env::var_os("PATH").and_then(|paths| {
        std::env::split_paths(&paths)
            .map(|d| d.join(program))
            .find(|p| p.is_file())
    });
    if found.is_none() {
        assert!(
            !under_ci(),
            "{program} is missing: CI must run the viewer's smoke test (apt-get install {package})"
        );
        eprintln!("skipping: {program} is not installed (apt-get install {package})");
    }
    found
}

#[test]
fn without_a_display_it_says_so_and_points_to_render() {
    let dir = tempfile::tempdir().unwrap();
    trefoil_tg(dir.path());
    let out = pocketsplat(&["view", "trefoil.tg", "--frames", "1"], dir.path());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "must exit non-zero: {err}");
    assert!(err.contains("no display"), "{err}");
    assert!(err.contains("DISPLAY is not set"), "{err}");
    assert!(
        err.contains("pocketsplat render trefoil.tg -o OUT.png"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
}

/// Counts pixels of `img` (WIDTH × HEIGHT) in rows `rows` that satisfy `f`.
fn count(img: &[[u8; 3]], rows: std::ops::Range<usize>, f: impl Fn(&[u8; 3]) -> bool) -> usize {
    img[rows.start * WIDTH..rows.end * WIDTH]
        .iter()
        .filter(|p| f(p))
        .count()
}

/// Under Xvfb: `view --frames N --screenshot` on the trefoil with one-pass shadows. The screenshot
/// must show the model and the HUD; outside the HUD's rows it must equal `render` with the same
/// settings at 1 px (refinement ends there); and the window itself, captured by ImageMagick while
/// the viewer idles, must show the screenshot scaled ×2.
#[test]
fn under_xvfb_it_shows_the_model_refined_with_the_hud() {
    let (Some(xvfb_run), Some(import)) = (tool("xvfb-run", "xvfb"), tool("import", "imagemagick"))
    else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    trefoil_tg(dir.path());
    let flags = ["--shadows", "one-pass", "--light", "-30,50"];

    // The screenshot is written when the frame is final (1 px); the window keeps showing it until
    // the viewer quits after 180 updates (3 s at 60 Hz), which leaves time to capture it.
    let script = format!(
        r#""$1" view trefoil.tg --frames 180 --screenshot view.png {flags} &
pid=$!
i=0
while [ ! -f view.png ] && [ $i -lt 400 ]; do sleep 0.05; i=$((i+1)); done
"{import}" -window "pocketsplat view: trefoil.tg" PNG24:window.png || echo "import failed" >&2
wait $pid"#,
        flags = flags.join(" "),
        import = import.display()
    );
    let out = Command::new(&xvfb_run)
        .args([
            "-a",
            "-s",
            "-screen 0 1024x768x24",
            "sh",
            "-c",
            &script,
            "sh",
        ])
        .arg(env!("CARGO_BIN_EXE_pocketsplat"))
        .current_dir(dir.path())
        .output()
        .expect("xvfb-run runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "view under Xvfb failed: {err}");

    let shot = read_rgb8_frame(&dir.path().join("view.png")).unwrap();
    let lit = count(&shot, 0..HEIGHT, |p| *p != [0, 0, 0]);
    assert!(
        lit > WIDTH * HEIGHT / 10,
        "the screenshot is nearly blank: {lit} lit pixels"
    );
    // The HUD: white statistics in the top 4 text rows, the dim help lines in the bottom 3.
    let white = count(&shot, 0..41, |p| *p == [255, 255, 255]);
    assert!(
        white > 500,
        "no HUD statistics at the top ({white} white pixels)"
    );
    let help = count(&shot, HEIGHT - 31..HEIGHT, |p| *p != [0, 0, 0]);
    assert!(help > 500, "no HUD help at the bottom ({help} lit pixels)");

    // Between the HUD's rows, the frame is the renderer's frame at 1 px.
    let mut render = vec!["render", "trefoil.tg", "-o", "render.png", "--cutoff", "1"];
    render.extend(flags);
    let out = pocketsplat(&render, dir.path());
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let want = read_rgb8_frame(&dir.path().join("render.png")).unwrap();
    let rows = 41..HEIGHT - 31;
    let model = count(&want, rows.clone(), |p| *p != [0, 0, 0]);
    assert!(model > WIDTH * HEIGHT / 10, "{model}");
    let first_diff = (rows.start * WIDTH..rows.end * WIDTH).find(|&i| shot[i] != want[i]);
    assert_eq!(
        first_diff.map(|i| (i % WIDTH, i / WIDTH, shot[i], want[i])),
        None,
        "view and render differ at (x, y, view, render)"
    );

    // The window shows the frame, each pixel as 2 × 2.
    let window = read_rgb8_png(&dir.path().join("window.png"))
        .unwrap_or_else(|e| panic!("no capture of the window ({e:#}); xvfb-run said: {err}"));
    assert_eq!(
        (window.width, window.height),
        (2 * WIDTH as u32, 2 * HEIGHT as u32)
    );
    let mismatched = window
        .pixels
        .iter()
        .enumerate()
        .filter(|&(i, p)| {
            let (x, y) = (i % (2 * WIDTH) / 2, i / (2 * WIDTH) / 2);
            *p != shot[y * WIDTH + x]
        })
        .count();
    assert_eq!(mismatched, 0, "window pixels differ from the screenshot ×2");
}
