//! One frame of an input file written as a PNG, with the statistics `render --stats-json` prints:
//! the work of `pocketsplat render` without its command line. A `.tg` or `.qs` file goes through
//! the integer renderer, a scene pack through the scene renderer ([`render_pack_file`]), a mesh
//! through the f64 reference renderer with the same camera, light and material; with shadows other
//! than `off`, a mesh gets exact shadow rays against its own triangles (the ground truth of both
//! shadow algorithms). (`--stream` is [`crate::stream::cmd`].)

use std::path::Path;
use std::time::Instant;

use anyhow::{anyhow, bail, Context, Result};
use pocketsplat_core::camera::Viewport;
use pocketsplat_core::raster::Kernel;
use pocketsplat_core::scene::{Pack, ShadowMode};
use pocketsplat_core::tg::{TriGrid, Verify};
use serde_json::json;

use crate::args::parse_pack_view;
use crate::bvh::Bvh;
use crate::input::{self, InputKind};
use crate::reference::{shadow_light, ShadowRays};
use crate::render::{render_tg_frame, FrameBuffers, Settings};
use crate::scene::render::{ram_json, render_pack, stats_json, PackSettings};
use crate::{image, ply, reference};

/// A PNG written, and what to say about it.
#[derive(Clone, Debug)]
pub struct Snapshot {
    /// The frame's statistics, the object `render --stats-json` prints.
    pub stats: serde_json::Value,
    /// The line `render` prints without `--stats-json`: what was written, in how long.
    pub summary: String,
}

/// `"square"` or `"round"`, as the statistics name a kernel.
fn kernel_name(kernel: Kernel) -> &'static str {
    match kernel {
        Kernel::Square => "square",
        Kernel::Round => "round",
    }
}

/// Renders `input` (a `.tg` or `.qs` file, or a PLY mesh for the reference renderer) with
/// `settings` and writes the frame to `out`.
///
/// # Errors
/// Bad settings or input, naming the file; no output is written then.
pub fn render_file(input: &Path, out: &Path, settings: &Settings) -> Result<Snapshot> {
    let t = Instant::now();
    let stats = match input::kind(input)? {
        InputKind::QSplat => render_qs(input, out, settings)?,
        InputKind::TriGrid => render_tg(input, out, settings)?,
        InputKind::Pack => bail!(
            "{}: a scene pack (render it with its own settings: render_pack_file)",
            input.display()
        ),
        InputKind::Other => render_mesh(input, out, settings)?,
    };
    let summary = format!(
        "wrote {} in {:.1} ms",
        out.display(),
        t.elapsed().as_secs_f64() * 1e3
    );
    Ok(Snapshot { stats, summary })
}

/// Writes the frame to `out` as a PNG, with the key of colour by resolution when its splats are
/// tinted by level.
fn write_frame(out: &Path, fb: &mut FrameBuffers, color_by_level: bool) -> Result<()> {
    if color_by_level {
        // The image draws infallibly.
        let _ = crate::levels::legend_in_corner(&mut fb.image);
    }
    image::write_image_png(out, &fb.image)
}

fn render_qs(input: &Path, out: &Path, settings: &Settings) -> Result<serde_json::Value> {
    let bytes = crate::qsplat::read_qs(input)?;
    let file = pocketsplat_core::qs::QSplat::open(&bytes)
        .map_err(|e| anyhow!("{}: {e}", input.display()))?;
    let mut fb = settings.buffers();
    let r = crate::qsplat::render_qs_frame(&file, settings, &mut fb)
        .map_err(|e| anyhow!("{}: {e:#}", input.display()))?;
    write_frame(out, &mut fb, settings.color_by_level)?;
    let s = r.stats;
    Ok(json!({
        "input": input.display().to_string(), "renderer": "qsplat",
        "nodes_visited": s.nodes_visited, "splats": s.splats, "max_level": s.max_level,
        "culled": s.culled, "backfacing": s.backfacing,
        "ms": r.time.as_secs_f64() * 1e3, "cutoff_px": settings.cutoff_px,
        "kernel": kernel_name(settings.kernel),
    }))
}

fn render_tg(input: &Path, out: &Path, settings: &Settings) -> Result<serde_json::Value> {
    let bytes = crate::fsutil::read_file(input)?;
    let grid =
        TriGrid::open(&bytes, Verify::Full).map_err(|e| anyhow!("{}: {e}", input.display()))?;
    let mut fb = settings.buffers();
    let r =
        render_tg_frame(&grid, settings, &mut fb).with_context(|| input.display().to_string())?;
    write_frame(out, &mut fb, settings.color_by_level)?;
    let s = r.stats;
    Ok(json!({
        "input": input.display().to_string(), "renderer": "tg",
        "nodes_visited": s.nodes_visited, "splats": s.splats, "max_level": s.max_level,
        "culled": s.culled, "backfacing": s.backfacing, "shadowed": s.shadowed,
        "shadows": format!("{:?}", settings.shadows),
        "ms": r.time.as_secs_f64() * 1e3, "cutoff_px": settings.cutoff_px,
        "kernel": kernel_name(settings.kernel),
    }))
}

fn render_mesh(input: &Path, out: &Path, settings: &Settings) -> Result<serde_json::Value> {
    if settings.color_by_level {
        bail!(
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
    let size = settings.size;
    image::write_rgb8_png_sized(out, size.width.into(), size.height.into(), &img.to_rgb8())?;
    let covered = img.covered.iter().filter(|&&c| c).count();
    Ok(json!({
        "input": input.display().to_string(), "renderer": "reference",
        "triangles": mesh.triangles.len(), "nodes_visited": 0, "splats": 0, "max_level": 0,
        "covered_pixels": covered, "shadowed_pixels": img.shadowed_count(),
        "shadows": if rays.is_some() { "ray-cast" } else { "off" }, "ms": ms,
    }))
}

/// What a pack is rendered with: `None` takes the pack's own value.
#[derive(Clone, Debug)]
pub struct PackArgs {
    /// A view of the pack, a standard view, `AZ,EL,DIST`, or `path@SECONDS`
    /// ([`parse_pack_view`]).
    pub view: String,
    /// Field of view, degrees.
    pub fov: Option<f64>,
    /// Cutoff, pixels.
    pub cutoff_px: f32,
    /// Kernel.
    pub kernel: Kernel,
    /// Light azimuth and elevation, degrees.
    pub light_az_el: Option<(f64, f64)>,
    /// Shadows.
    pub shadows: Option<ShadowMode>,
    /// Tint splats by their levels above full detail, with a key.
    pub color_by_level: bool,
    /// The frame's size.
    pub size: Viewport,
    /// Horizontal bands the frame is drawn in ([`FrameBuffers::in_bands`]).
    pub bands: u16,
    /// Shadow-map side, texels.
    pub shadow_map_size: Option<usize>,
}

impl PackArgs {
    /// The settings these arguments give for `pack` (whose views they may name).
    ///
    /// # Errors
    /// A view that is none of the pack's, a standard view, `AZ,EL,DIST` or `path@SECONDS`.
    pub fn settings(&self, pack: &Pack<'_>) -> Result<PackSettings> {
        let mut settings = PackSettings::new(parse_pack_view(pack, &self.view)?);
        settings.cutoff_px = self.cutoff_px;
        settings.kernel = self.kernel;
        settings.fov_deg = self.fov;
        settings.shadows = self.shadows;
        settings.light_az_el = self.light_az_el;
        settings.color_by_level = self.color_by_level;
        settings.shadow_map_size = self.shadow_map_size;
        Ok(settings)
    }
}

/// Renders the scene pack `input` and writes the frame to `out`.
///
/// # Errors
/// Bad arguments or input, naming the file; no output is written then.
pub fn render_pack_file(input: &Path, out: &Path, args: &PackArgs) -> Result<Snapshot> {
    let bytes = crate::fsutil::read_file(input)?;
    let scene = input::open_pack(input, &bytes)?;
    let pack = scene.pack();
    let settings = args.settings(pack)?;
    let mut fb = FrameBuffers::sized(args.size).in_bands(args.bands);
    let frame = render_pack(&scene, &settings, &mut fb)?;
    write_frame(out, &mut fb, args.color_by_level)?;
    let mut v = stats_json(&frame.stats.total);
    let o = v.as_object_mut().expect("an object");
    o.insert("input".into(), json!(input.display().to_string()));
    o.insert("renderer".into(), json!("scene"));
    o.insert("objects".into(), json!(scene.len()));
    o.insert("shadows".into(), json!(frame.stats.shadows.name()));
    o.insert(
        "shadow_fill_nodes".into(),
        json!(frame.stats.shadow_fill_nodes),
    );
    o.insert("ms".into(), json!(frame.time.as_secs_f64() * 1e3));
    o.insert("cutoff_px".into(), json!(args.cutoff_px));
    o.insert("kernel".into(), json!(kernel_name(args.kernel)));
    o.insert(
        "per_object".into(),
        json!((0..scene.len())
            .map(|i| {
                let mut s = stats_json(&frame.stats.objects[i]);
                let name = pack.object(i).map_or("", |r| r.name);
                s.as_object_mut()
                    .expect("an object")
                    .insert("name".into(), json!(name));
                s
            })
            .collect::<Vec<_>>()),
    );
    o.insert("ram".into(), ram_json(&frame.ram));
    let summary = format!(
        "wrote {} in {:.1} ms ({} objects, {} splats, shadows {}; device RAM {} bytes)",
        out.display(),
        frame.time.as_secs_f64() * 1e3,
        scene.len(),
        frame.stats.total.splats,
        frame.stats.shadows.name(),
        frame.ram.total()
    );
    Ok(Snapshot { stats: v, summary })
}
