//! `pocketsplat report views`: the first error-against-run-time table. For each standard view and
//! cutoff, the integer renderer's PSNR and coverage mismatch against the f64 reference renderer of the
//! original mesh, with the host time per frame (median of repeats) and the nodes visited, for the
//! tri-grid and the octree side by side.

use std::fmt::Write as _;
use std::path::Path;
use std::time::Duration;

use anyhow::Result;
use pocketsplat_core::bake::{BakeOptions, TriMesh};
use pocketsplat_core::camera::STANDARD_VIEWS;
use pocketsplat_core::shade::rgb565_to_rgb888;
use pocketsplat_core::tg::{TriGrid, Verify};
use serde::Serialize;

use crate::bake::bake_mesh;
use crate::metrics::{coverage_mismatch, psnr_rgb8};
use crate::reference::render_reference;
use crate::render::{render_tg_frame, FrameBuffers, Settings};

/// One measured frame.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    /// "trigrid" or "octree".
    pub format: String,
    /// ρ and depth of the bake.
    pub rho: u8,
    /// Subdivisions.
    pub depth: u8,
    /// Standard view name.
    pub view: String,
    /// LOD cutoff, pixels.
    pub cutoff_px: f32,
    /// PSNR against the reference, dB (RGB, 8-bit).
    pub psnr_db: f64,
    /// Fraction of pixels covered by one image and not the other.
    pub coverage_mismatch: f64,
    /// Pixels the reference covers and the splats miss (holes), as a fraction of the frame.
    pub holes: f64,
    /// Median host time per frame (setup, traversal, raster), ms.
    pub ms: f64,
    /// Nodes visited.
    pub nodes_visited: u32,
    /// Splats drawn.
    pub splats: u32,
}

/// Median of `repeats` timings of `f`.
pub fn median_time(repeats: usize, mut f: impl FnMut() -> Duration) -> Duration {
    let mut t: Vec<Duration> = (0..repeats.max(1)).map(|_| f()).collect();
    t.sort();
    t[t.len() / 2]
}

/// Measures every standard view at every cutoff for one bake of `mesh`.
///
/// # Errors
/// When the bake fails.
pub fn measure(
    mesh: &TriMesh,
    rho: u8,
    depth: u8,
    cutoffs: &[f32],
    repeats: usize,
) -> Result<Vec<Row>> {
    let (_, bytes) = bake_mesh(mesh, BakeOptions { rho, depth }, 12, false)?;
    let grid = TriGrid::open(&bytes, Verify::Structure)?;
    let mut rows = Vec::new();
    for (name, view) in STANDARD_VIEWS {
        let base = Settings {
            view,
            ..Settings::default()
        };
        let reference = render_reference(
            mesh,
            &base.camera(mesh.bounds_f32()),
            &[base.material],
            base.light_dir(),
        );
        let ref_rgb = reference.to_rgb8();
        for &cutoff in cutoffs {
            let settings = Settings {
                cutoff_px: cutoff,
                ..base
            };
            let mut fb = FrameBuffers::new();
            let mut last = None;
            let time = median_time(repeats, || {
                let r = render_tg_frame(&grid, &settings, &mut fb).expect("frame");
                last = Some(r.stats);
                r.time
            });
            let stats = last.expect("at least one frame");
            let rgb: Vec<[u8; 3]> = fb.pixels().iter().map(|&p| rgb565_to_rgb888(p)).collect();
            let covered = fb.covered();
            let holes = reference
                .covered
                .iter()
                .zip(&covered)
                .filter(|&(&r, &c)| r && !c)
                .count();
            rows.push(Row {
                format: if rho == 2 { "octree" } else { "trigrid" }.into(),
                rho,
                depth,
                view: name.into(),
                cutoff_px: cutoff,
                psnr_db: psnr_rgb8(&ref_rgb, &rgb),
                coverage_mismatch: coverage_mismatch(&reference.covered, &covered),
                holes: holes as f64 / covered.len() as f64,
                ms: time.as_secs_f64() * 1e3,
                nodes_visited: stats.nodes_visited,
                splats: stats.splats,
            });
        }
    }
    Ok(rows)
}

/// Markdown table of rows.
pub fn markdown(rows: &[Row]) -> String {
    let mut out = String::from(
        "| format | depth | view | cutoff px | PSNR dB | coverage mismatch | holes | ms/frame | nodes visited | splats |\n\
         |---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {:.2} | {:.2}% | {:.3}% | {:.2} | {} | {} |",
            r.format,
            r.depth,
            r.view,
            r.cutoff_px,
            r.psnr_db,
            100.0 * r.coverage_mismatch,
            100.0 * r.holes,
            r.ms,
            r.nodes_visited,
            r.splats
        );
    }
    out
}

/// The `report views` command: bunny (or `mesh_path`) as tri-grid depth 6 and octree depth 9.
///
/// # Errors
/// When the mesh cannot be loaded or baked.
pub fn run(mesh_path: &Path, repeats: usize) -> Result<String> {
    let mesh = crate::ply::load_mesh(mesh_path)?;
    let cutoffs = [1.0, 2.0, 4.0, 8.0];
    let mut rows = measure(&mesh, 3, 6, &cutoffs, repeats)?;
    rows.extend(measure(&mesh, 2, 9, &cutoffs, repeats)?);
    Ok(markdown(&rows))
}
