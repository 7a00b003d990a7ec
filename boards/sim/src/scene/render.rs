//! Rendering scene packs on the desktop through the core's scene renderer (the firmware's code).
//!
//! [`render_pack`] is the call a report makes: a pack's view at a given cutoff, kernel and shadow
//! mode, into [`FrameBuffers`], with timing, statistics and the RAM the device would need.

use std::time::Duration;

use anyhow::{anyhow, bail, Result};
use pocketsplat_core::camera::{self, Camera, Sphere, View, Viewport};
use pocketsplat_core::raster::Kernel;
use pocketsplat_core::render::{Model, RenderOptions};
use pocketsplat_core::scene::{ram_budget, RamBudget, Scene, SceneStats, ShadowMode};
use pocketsplat_core::splat::Stats;

use crate::levels::Levels;
use crate::render::{render_from, FrameBuffers, FrameReport, Image, Layers, Settings, Tinted};

pub use crate::render::{scene_table, SceneTable};

/// What a frame of a scene did.
#[derive(Clone, Copy, Debug)]
pub struct SceneFrame {
    /// Per-object and total counts.
    pub stats: SceneStats,
    /// Wall time of setup, table update, traversal and raster (no clearing).
    pub time: Duration,
    /// RAM the device needs for this frame.
    pub ram: RamBudget,
}

impl SceneFrame {
    /// The frame as a single-model report (total counts).
    pub fn report(&self) -> FrameReport {
        FrameReport {
            stats: self.stats.total,
            time: self.time,
            scene: Some(self.stats),
        }
    }
}

/// How to draw a frame of a pack: the view and the knobs a report sweeps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PackSettings {
    /// Orbit about the scene's sphere.
    pub view: View,
    /// LOD cutoff, pixels.
    pub cutoff_px: f32,
    /// Splat kernel.
    pub kernel: Kernel,
    /// Shadows (`None`: the pack's).
    pub shadows: Option<ShadowMode>,
    /// Light azimuth and elevation, degrees (`None`: the pack's).
    pub light_az_el: Option<(f64, f64)>,
    /// Vertical field of view, degrees (`None`: the pack's).
    pub fov_deg: Option<f64>,
    /// Shadow map side (`None`: the pack's, or 256 when it has none).
    pub shadow_map_size: Option<usize>,
    /// Tint each splat by how many levels above full detail it is ([`crate::levels`]).
    pub color_by_level: bool,
}

impl PackSettings {
    /// The pack's own light, shadows and field of view, at `view`, 1 px, square splats.
    pub fn new(view: View) -> Self {
        Self {
            view,
            cutoff_px: 1.0,
            kernel: Kernel::Square,
            shadows: None,
            light_az_el: None,
            fov_deg: None,
            shadow_map_size: None,
            color_by_level: false,
        }
    }

    /// From the simulator's single-model settings (the viewer's): their view, field of view,
    /// cutoff, kernel, directional light and shadows.
    ///
    /// # Errors
    /// A point light (scenes have a directional light).
    pub fn from_settings(s: &Settings) -> Result<Self> {
        if s.light_pos.is_some() {
            bail!("a scene is lit by a directional light; --light-pos is for single models");
        }
        Ok(Self {
            view: s.view,
            cutoff_px: s.cutoff_px,
            kernel: s.kernel,
            shadows: Some(match s.shadows {
                ShadowMode::Off => ShadowMode::Off,
                ShadowMode::OnePass => ShadowMode::OnePass,
                ShadowMode::TwoPass => ShadowMode::TwoPass,
            }),
            light_az_el: Some(s.light_az_el),
            fov_deg: Some(s.fov_deg),
            shadow_map_size: Some(s.shadow_map_size),
            color_by_level: s.color_by_level,
        })
    }

    /// The core's options for `scene`.
    pub fn options(&self, scene: &Scene<'_>) -> RenderOptions {
        let mut o = scene.options();
        o.cutoff_px = self.cutoff_px;
        o.kernel = self.kernel;
        if let Some(s) = self.shadows {
            o.shadows = s;
        }
        if let Some((az, el)) = self.light_az_el {
            o.light_dir = camera::direction(az, el);
        }
        if let Some(n) = self.shadow_map_size {
            o.shadow_map_size = n;
        }
        o
    }

    /// The camera of this view about `sphere` (moved by `pan` radii, as the viewer pans).
    pub fn camera(&self, scene: &Scene<'_>, pan: [f64; 3]) -> Camera {
        let s = scene.sphere();
        let centre = camera::add(s.center, camera::scale(pan, s.radius));
        Camera::orbit(
            Sphere {
                center: centre,
                radius: s.radius,
            },
            self.view,
            self.fov_deg.unwrap_or_else(|| scene.pack().fov_deg()),
        )
    }
}

/// Renders a frame of `scene` from `camera` into `out` (cleared first) through the core's pipeline
/// ([`render_from`]), with a caller-owned table (rebuilt only for slots whose light, view or
/// material changed) and a hook that may draw over the frame; with `levels`, every splat is tinted
/// by its levels above full detail ([`crate::levels`]).
///
/// # Errors
/// When a frame cannot be set up (bad camera or cutoff).
pub fn render_pack_from(
    scene: &Scene<'_>,
    camera: &Camera,
    opts: &RenderOptions,
    levels: Option<&Levels>,
    table: &mut SceneTable,
    out: &mut FrameBuffers,
    overlay: impl FnOnce(&mut Image, &SceneFrame),
) -> Result<SceneFrame> {
    let model = Model::Scene(scene.clone());
    let mut layer = match levels {
        Some(l) => Layers::Tinted(Tinted(l)),
        None => Layers::Direct,
    };
    let mut frame = None;
    // What a device holds of the frame: a band's rows when it is drawn in bands.
    let band = Viewport::new(u32::from(out.viewport().width), u32::from(out.band_rows()))
        .expect("a band of a valid frame");
    render_from(
        &model,
        camera,
        opts,
        table,
        out,
        &mut layer,
        |image, report| {
            let stats = report.scene.unwrap_or_default();
            let f = SceneFrame {
                stats,
                time: report.time,
                ram: ram_budget(scene.pack(), stats.shadows, opts.shadow_map_size, band),
            };
            overlay(image, &f);
            frame = Some(f);
        },
    )?;
    frame.ok_or_else(|| anyhow!("the frame was not drawn"))
}

/// Renders one frame of a pack's scene as `settings` say, into `out`.
///
/// # Errors
/// When a frame cannot be set up.
pub fn render_pack(
    scene: &Scene<'_>,
    settings: &PackSettings,
    out: &mut FrameBuffers,
) -> Result<SceneFrame> {
    let mut table = scene_table();
    let cam = settings.camera(scene, [0.0; 3]);
    let levels = settings
        .color_by_level
        .then(|| Levels::of_scene(scene))
        .transpose()?;
    render_pack_from(
        scene,
        &cam,
        &settings.options(scene),
        levels.as_ref(),
        &mut table,
        out,
        |_, _| {},
    )
}

/// The counts of a frame as JSON fields.
pub fn stats_json(s: &Stats) -> serde_json::Value {
    serde_json::json!({
        "nodes_visited": s.nodes_visited, "splats": s.splats, "max_level": s.max_level,
        "culled": s.culled, "backfacing": s.backfacing, "shadowed": s.shadowed,
    })
}

/// The RAM budget as a JSON object (bytes).
pub fn ram_json(r: &RamBudget) -> serde_json::Value {
    serde_json::json!({
        "framebuffer": r.framebuffer, "depth": r.depth, "shadow_map": r.shadow_map,
        "shading_tables": r.shading_tables, "cache": r.cache, "frame_setup": r.frame_setup,
        "scene": r.scene, "total": r.total(),
    })
}
