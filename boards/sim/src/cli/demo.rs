//! `pocketsplat` with no subcommand: the built-in trefoil knot in a window, or in a PNG without a
//! display.

use std::path::Path;

use anyhow::Result;
use pocketsplat_core::tg::{TriGrid, Verify};
use pocketsplat_sim::demo::demo_tg;
use pocketsplat_sim::render::{render_tg_frame, FrameBuffers, Settings};

/// Runs the demo: a window when there is a display, else a PNG in the current folder.
///
/// # Errors
/// When the PNG cannot be written.
pub fn run() -> Result<()> {
    eprintln!("pocketsplat demo: baking a procedural trefoil knot (tri-grid, depth 5)…");
    let bytes = demo_tg()?;
    let grid = TriGrid::open(&bytes, Verify::Full)?;
    #[cfg(feature = "window")]
    match pocketsplat_sim::view::Viewer::open("pocketsplat demo") {
        Ok(viewer) => return viewer.run(&grid, Settings::default()),
        Err(e) => eprintln!("no window ({e}); writing a PNG instead"),
    }
    let path = Path::new("pocketsplat-demo.png");
    let mut fb = FrameBuffers::new();
    let report = render_tg_frame(&grid, &Settings::default(), &mut fb)?;
    pocketsplat_sim::image::write_image_png(path, &fb.image)?;
    eprintln!(
        "wrote {} ({} splats, {} nodes, {:.1} ms)",
        path.display(),
        report.stats.splats,
        report.stats.nodes_visited,
        report.time.as_secs_f64() * 1e3
    );
    Ok(())
}
