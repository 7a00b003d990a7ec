//! `pocketsplat render INPUT -o OUT.png`: a `.tg` file through the integer renderer, or a mesh through
//! the f64 reference renderer, with the same camera, light and material. With `--shadows` other than
//! `off`, a mesh gets exact shadow rays against its own triangles (the ground truth of both shadow
//! algorithms).

use std::path::Path;
use std::time::Instant;

use anyhow::Result;
use pocketsplat_core::format::FileFormat;
use pocketsplat_core::raster::Kernel;
use pocketsplat_core::tg::{TriGrid, Verify};
use serde_json::json;

use crate::bvh::Bvh;
use crate::reference::{shadow_light, ShadowRays};
use crate::render::{render_tg_frame, FrameBuffers, Settings};
use crate::{image, ply, reference};

/// Is this path a `.tg` file (by its magic), rather than a mesh?
fn is_tg(path: &Path) -> Result<bool> {
    Ok(crate::fsutil::sniff(path)? == Some(FileFormat::TriGrid))
}

/// The `render` command.
///
/// # Errors
/// Bad arguments or input, naming the file; no output is written then.
pub fn run(input: &Path, out: &Path, settings: &Settings, stats_json: bool) -> Result<()> {
    let t = Instant::now();
    if crate::qsplat::is_qs(input)? {
        let bytes = crate::qsplat::read_qs(input)?;
        let file = pocketsplat_core::qs::QSplat::open(&bytes)
            .map_err(|e| anyhow::anyhow!("{}: {e}", input.display()))?;
        let mut fb = FrameBuffers::new();
        let r = crate::qsplat::render_qs_frame(&file, settings, &mut fb)
            .map_err(|e| anyhow::anyhow!("{}: {e:#}", input.display()))?;
        if settings.color_by_level {
            crate::levels::legend_in_corner(&mut fb.framebuffer());
        }
        image::write_rgb565_png(out, fb.pixels())?;
        if stats_json {
            let s = r.stats;
            println!(
                "{}",
                json!({
                    "input": input.display().to_string(), "renderer": "qsplat",
                    "nodes_visited": s.nodes_visited, "splats": s.splats, "max_level": s.max_level,
                    "culled": s.culled, "backfacing": s.backfacing,
                    "ms": r.time.as_secs_f64() * 1e3, "cutoff_px": settings.cutoff_px,
                    "kernel": match settings.kernel { Kernel::Square => "square", Kernel::Round => "round" },
                })
            );
        } else {
            eprintln!(
                "wrote {} in {:.1} ms",
                out.display(),
                t.elapsed().as_secs_f64() * 1e3
            );
        }
        return Ok(());
    }
    if is_tg(input)? {
        let bytes = crate::fsutil::read_file(input)?;
        let grid = TriGrid::open(&bytes, Verify::Full)
            .map_err(|e| anyhow::anyhow!("{}: {e}", input.display()))?;
        let mut fb = FrameBuffers::new();
        let r = render_tg_frame(&grid, settings, &mut fb)?;
        if settings.color_by_level {
            crate::levels::legend_in_corner(&mut fb.framebuffer());
        }
        image::write_rgb565_png(out, fb.pixels())?;
        if stats_json {
            let s = r.stats;
            println!(
                "{}",
                json!({
                    "input": input.display().to_string(), "renderer": "tg",
                    "nodes_visited": s.nodes_visited, "splats": s.splats, "max_level": s.max_level,
                    "culled": s.culled, "backfacing": s.backfacing, "shadowed": s.shadowed,
                    "shadows": format!("{:?}", settings.shadows),
                    "ms": r.time.as_secs_f64() * 1e3, "cutoff_px": settings.cutoff_px,
                    "kernel": match settings.kernel { Kernel::Square => "square", Kernel::Round => "round" },
                })
            );
        }
    } else {
        if settings.color_by_level {
            anyhow::bail!(
                "{}: --color-by-level tints a point file's levels; a mesh has none (render a .tg, \
                 .qs or .pack file)",
                input.display()
            );
        }
        let mesh = ply::load_mesh(input)?;
        let camera = settings.camera(mesh.bounds_f32());
        let t_render = Instant::now();
        let bvh = shadow_light(settings, mesh.bounds_f32()).map(|light| (Bvh::new(&mesh), light));
        let rays = bvh
            .as_ref()
            .map(|(bvh, light)| ShadowRays { bvh, light: *light });
        let img = reference::render_reference_shadowed(
            &mesh,
            &camera,
            &[settings.material],
            settings.light_dir(),
            rays.as_ref(),
        );
        let ms = t_render.elapsed().as_secs_f64() * 1e3;
        image::write_rgb8_png(out, &img.to_rgb8())?;
        if stats_json {
            let covered = img.covered.iter().filter(|&&c| c).count();
            println!(
                "{}",
                json!({
                    "input": input.display().to_string(), "renderer": "reference",
                    "triangles": mesh.triangles.len(), "nodes_visited": 0, "splats": 0, "max_level": 0,
                    "covered_pixels": covered, "shadowed_pixels": img.shadowed_count(),
                    "shadows": if rays.is_some() { "ray-cast" } else { "off" }, "ms": ms,
                })
            );
        }
    }
    if !stats_json {
        eprintln!(
            "wrote {} in {:.1} ms",
            out.display(),
            t.elapsed().as_secs_f64() * 1e3
        );
    }
    Ok(())
}
