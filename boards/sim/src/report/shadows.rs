//! `pocketsplat report shadows`: both shadow algorithms (Duguet §5.3) against exact shadows. For each
//! standard view of the bunny and the dragon at the paper's level 5 (tri-grid depth 6), with shadows
//! off, two-pass and one-pass: the fraction of pixels (covered in both images) whose lit/shadowed
//! classification disagrees with the f64 reference renderer's ray-cast shadows, the PSNR against the
//! reference image shaded with those shadows, and the host time per frame (median of repeats).
//!
//! "Shadowed" means unlit, in both images: facing away from the light or in a cast shadow. The `off`
//! column therefore counts the cast shadows the unshadowed frame misses.

use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use anyhow::{Context, Result};
use pocketsplat_core::bake::{BakeOptions, TriMesh};
use pocketsplat_core::camera::STANDARD_VIEWS;
use pocketsplat_core::shade::rgb565_to_rgb888;
use pocketsplat_core::tg::{TriGrid, Verify};
use serde::Serialize;

use crate::bake::bake_mesh;
use crate::bvh::Bvh;
use crate::metrics::{psnr_rgb8, shadow_disagreement};
use crate::reference::shadow_light;
use crate::reference::{render_reference_shadowed, ShadowRays};
use crate::render::{render_tg_classified, render_tg_frame, FrameBuffers, Settings, ShadowMode};
use crate::report::views::median_time;

/// The modes compared, in column order.
pub const MODES: [(ShadowMode, &str); 3] = [
    (ShadowMode::Off, "off"),
    (ShadowMode::TwoPass, "two-pass"),
    (ShadowMode::OnePass, "one-pass"),
];

/// One frame of one mode.
#[derive(Clone, Debug, Serialize)]
pub struct Cell {
    /// "off", "two-pass" or "one-pass".
    pub mode: &'static str,
    /// Fraction of pixels covered in both images whose classification differs.
    pub disagreement: f64,
    /// PSNR against the reference with ray-cast shadows, dB.
    pub psnr_db: f64,
    /// Median host time per frame (setup, both passes, raster), ms.
    pub ms: f64,
    /// Nodes visited (both passes for two-pass).
    pub nodes_visited: u32,
}

/// One view of one model.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    /// Model name.
    pub model: String,
    /// Tri-grid depth.
    pub depth: u8,
    /// Standard view name.
    pub view: &'static str,
    /// Fraction of the reference's covered pixels that are unlit.
    pub reference_unlit: f64,
    /// Off, two-pass, one-pass.
    pub cells: Vec<Cell>,
}

/// Measures every standard view of `mesh` baked at `depth` with `base`'s light and shadow map.
///
/// # Errors
/// When the bake or a frame fails.
pub fn measure(
    model: &str,
    mesh: &TriMesh,
    depth: u8,
    base: &Settings,
    repeats: usize,
) -> Result<Vec<Row>> {
    let t = Instant::now();
    let (_, bytes) = bake_mesh(mesh, BakeOptions { rho: 3, depth }, 12, false)?;
    let grid = TriGrid::open(&bytes, Verify::Structure)?;
    let bvh = Bvh::new(mesh);
    eprintln!(
        "{model}: baked depth {depth} and built the ray hierarchy in {:.1} s",
        t.elapsed().as_secs_f64()
    );
    let lit = Settings {
        shadows: ShadowMode::TwoPass,
        ..*base
    };
    let light = shadow_light(&lit, mesh.bounds_f32()).context("shadows are on")?;
    let rays = ShadowRays { bvh: &bvh, light };
    let mut rows = Vec::new();
    for (view_name, view) in STANDARD_VIEWS {
        let at_view = Settings { view, ..*base };
        let reference = render_reference_shadowed(
            mesh,
            &at_view.camera(mesh.bounds_f32()),
            &[at_view.material],
            at_view.light_dir(),
            Some(&rays),
        );
        let ref_rgb = reference.to_rgb8();
        let mut cells = Vec::new();
        for (mode, mode_name) in MODES {
            if mode == ShadowMode::OnePass && at_view.light_pos.is_some() {
                continue;
            }
            let settings = Settings {
                shadows: mode,
                ..at_view
            };
            let mut fb = FrameBuffers::new();
            let classified = render_tg_classified(&grid, &settings, &mut fb)?;
            let rgb: Vec<[u8; 3]> = fb.pixels().iter().map(|&p| rgb565_to_rgb888(p)).collect();
            let time = median_time(repeats, || {
                render_tg_frame(&grid, &settings, &mut fb)
                    .expect("the same frame rendered once already")
                    .time
            });
            cells.push(Cell {
                mode: mode_name,
                disagreement: shadow_disagreement(
                    &reference.covered,
                    &reference.shadowed,
                    &classified.covered,
                    &classified.shadowed,
                ),
                psnr_db: psnr_rgb8(&ref_rgb, &rgb),
                ms: time.as_secs_f64() * 1e3,
                nodes_visited: classified.report.stats.nodes_visited,
            });
        }
        rows.push(Row {
            model: model.into(),
            depth,
            view: view_name,
            reference_unlit: reference.shadowed_count() as f64
                / reference.covered_count().max(1) as f64,
            cells,
        });
    }
    Ok(rows)
}

/// Markdown table of rows: one line per model and view, off / two-pass / one-pass side by side.
pub fn markdown(rows: &[Row], repeats: usize) -> String {
    let mut out = format!(
        "| model (depth) | view | unlit in reference | disagree: off | two-pass | one-pass | \
         PSNR dB: off | two-pass | one-pass | ms/frame (median of {repeats}): off | two-pass | one-pass |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|\n"
    );
    for r in rows {
        let col = |f: &dyn Fn(&Cell) -> String| -> String {
            MODES
                .iter()
                .map(|(_, name)| {
                    r.cells
                        .iter()
                        .find(|c| c.mode == *name)
                        .map_or_else(|| "–".into(), f)
                })
                .collect::<Vec<_>>()
                .join(" | ")
        };
        let _ = writeln!(
            out,
            "| {} ({}) | {} | {:.1} % | {} | {} | {} |",
            r.model,
            r.depth,
            r.view,
            100.0 * r.reference_unlit,
            col(&|c| format!("{:.2} %", 100.0 * c.disagreement)),
            col(&|c| format!("{:.2}", c.psnr_db)),
            col(&|c| format!("{:.1}", c.ms)),
        );
    }
    out
}

/// The `report shadows` command: bunny and dragon at depth 6 (`quick`: the bunny at depth 5), the
/// default light and a `map_size²` shadow map.
///
/// # Errors
/// When a model is missing or fails to load or bake, or the map size is 0.
pub fn run(models: &Path, repeats: usize, quick: bool, map_size: usize) -> Result<String> {
    if map_size == 0 {
        anyhow::bail!("--map 0: the shadow map needs at least one texel");
    }
    let base = Settings {
        shadow_map_size: map_size,
        ..Settings::default()
    };
    let names: &[&str] = if quick {
        &["bunny"]
    } else {
        &["bunny", "dragon"]
    };
    let depth = if quick { 5 } else { 6 };
    let mut rows = Vec::new();
    for name in names {
        let path = models.join(crate::report::paper::model_file(name));
        let mesh = crate::ply::load_mesh(&path)?;
        rows.extend(measure(name, &mesh, depth, &base, repeats)?);
    }
    Ok(format!(
        "Shadow map {map_size}², light {:?} (az, el), cutoff 1 px.\n\n{}",
        base.light_az_el,
        markdown(&rows, repeats.max(1))
    ))
}
