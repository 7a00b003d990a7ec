//! Rendering point files on the desktop through the same core code the firmware runs.

use std::time::{Duration, Instant};

use pocketsplat_core::camera::{self, Camera, Placement, Sphere, View, DEFAULT_FOV_DEG};
use pocketsplat_core::normal::{NORMALS_Q14, NORMAL_COUNT};
use pocketsplat_core::raster::Splat;
use pocketsplat_core::raster::{Framebuffer, Kernel};
use pocketsplat_core::shade::{Material, ShadingTable, DEFAULT_LIGHT_AZ_EL, DEFAULT_MATERIAL};
pub use pocketsplat_core::shadow::ShadowMode;
use pocketsplat_core::shadow::{render_tg_shadowed, LightFrame, ShadowMap};
use pocketsplat_core::splat::{LevelTint, SampleSplat, ShadedRaster, SplatSink, Stats};

use crate::levels::Levels;
use pocketsplat_core::render::RenderOptions;
use pocketsplat_core::tg::read::Header;
use pocketsplat_core::tg::{render_tg, TgFrame, TriGrid};

/// Width and height of every frame.
pub use pocketsplat_core::camera::{HEIGHT, WIDTH};

/// Colour rows of a frame.
pub type Rows = Box<[[u16; WIDTH]; HEIGHT]>;

/// An owned frame: colour and depth on the heap, and a shadow map once shadows are used.
pub struct FrameBuffers {
    /// RGB565 rows.
    pub color: Rows,
    /// Depth rows.
    pub depth: Rows,
    /// Shadow-map depths, allocated on first use.
    pub shadow: Vec<u16>,
}

impl Default for FrameBuffers {
    fn default() -> Self {
        Self::new()
    }
}

impl FrameBuffers {
    /// Black, depth cleared.
    pub fn new() -> Self {
        let rows = || -> Rows {
            vec![[0u16; WIDTH]; HEIGHT]
                .into_boxed_slice()
                .try_into()
                .expect("HEIGHT rows")
        };
        let mut f = Self {
            color: rows(),
            depth: rows(),
            shadow: Vec::new(),
        };
        f.framebuffer().clear(0);
        f
    }
    /// The core framebuffer over these buffers.
    pub fn framebuffer(&mut self) -> Framebuffer<'_> {
        Framebuffer::new(&mut self.color, &mut self.depth)
    }
    /// Pixels in row order.
    pub fn pixels(&self) -> &[u16] {
        self.color.as_flattened()
    }
    /// Whether each pixel was drawn (depth written).
    pub fn covered(&self) -> Vec<bool> {
        self.depth
            .as_flattened()
            .iter()
            .map(|&d| d != pocketsplat_core::raster::DEPTH_FAR)
            .collect()
    }
    /// CRC-32 of the colour buffer, as the firmware computes it.
    pub fn crc(&mut self) -> u32 {
        self.framebuffer().crc()
    }
}

/// Default shadow-map side: 256² texels (128 KB), about one texel per 3 leaf cells of a depth-6
/// tri-grid.
pub const DEFAULT_SHADOW_MAP_SIZE: usize = 256;

/// Everything that decides a frame, with the defaults of the `render` command.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// Orbit view.
    pub view: View,
    /// Vertical field of view, degrees.
    pub fov_deg: f64,
    /// LOD cutoff, pixels.
    pub cutoff_px: f32,
    /// Splat kernel.
    pub kernel: Kernel,
    /// Light azimuth and elevation, degrees (a directional light; ignored with `light_pos`).
    pub light_az_el: (f64, f64),
    /// A point light instead: its position in bounding-sphere radii from the sphere's centre (the
    /// views' unit). Shadows from it are two-pass; shading uses the direction from the centre.
    pub light_pos: Option<[f64; 3]>,
    /// Material of every sample.
    pub material: Material,
    /// Shadow algorithm.
    pub shadows: ShadowMode,
    /// Side of the shadow map, texels.
    pub shadow_map_size: usize,
    /// Tint each splat by how many levels above full detail it is ([`crate::levels`]).
    pub color_by_level: bool,
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            view: camera::standard_view("std").expect("std view"),
            fov_deg: DEFAULT_FOV_DEG,
            cutoff_px: 1.0,
            kernel: Kernel::Square,
            light_az_el: DEFAULT_LIGHT_AZ_EL,
            light_pos: None,
            material: DEFAULT_MATERIAL,
            shadows: ShadowMode::Off,
            shadow_map_size: DEFAULT_SHADOW_MAP_SIZE,
            color_by_level: false,
        }
    }
}

/// A model's bounding box, `f32` (QSplat files, a `.tg` header's `bounds`) or `f64` (a `.tg`
/// header's `bounds64`, precise for a mesh far from its origin).
pub trait ModelBounds {
    /// The bounding sphere of the box.
    fn sphere(self) -> Sphere;
}

impl ModelBounds for [[f32; 3]; 2] {
    fn sphere(self) -> Sphere {
        Sphere::from_bounds(self)
    }
}

impl ModelBounds for [[f64; 3]; 2] {
    fn sphere(self) -> Sphere {
        Sphere::from_bounds_f64(self)
    }
}

impl Settings {
    /// The camera for a model with this bounding box.
    pub fn camera(&self, bounds: impl ModelBounds) -> Camera {
        Camera::orbit(bounds.sphere(), self.view, self.fov_deg)
    }
    /// Unit direction to the light (for a point light, from the bounding-sphere centre).
    pub fn light_dir(&self) -> [f64; 3] {
        match self.light_pos {
            Some(p) => camera::normalize(p),
            None => camera::direction(self.light_az_el.0, self.light_az_el.1),
        }
    }
    /// The point light's position in model units, for a model with this bounding box.
    pub fn light_position(&self, bounds: impl ModelBounds) -> Option<[f64; 3]> {
        let s = bounds.sphere();
        self.light_pos
            .map(|p| camera::add(s.center, camera::scale(p, s.radius)))
    }
}

/// The light's tables for a grid (shadows on).
///
/// # Errors
/// One-pass shadows with a point light, or a point light inside the sphere around the grid's root
/// cube.
pub fn light_frame(header: &Header, settings: &Settings) -> anyhow::Result<LightFrame> {
    let n = settings.shadow_map_size;
    match settings.light_position(header.bounds64) {
        None => Ok(LightFrame::new(
            header,
            &Placement::IDENTITY,
            settings.light_dir(),
            n,
        )),
        Some(_) if settings.shadows == ShadowMode::OnePass => anyhow::bail!(
            "one-pass shadows need a directional light (Duguet §5.3); use --shadows two-pass \
             with --light-pos"
        ),
        Some(at) => LightFrame::point(header, &Placement::IDENTITY, at, n).map_err(|e| {
            let p = settings.light_pos.unwrap_or_default();
            anyhow::anyhow!("--light-pos {},{},{}: {e}", p[0], p[1], p[2])
        }),
    }
}

/// Draws a set-up frame into `sink`, with the shadows `settings` ask for (the map in `shadow`,
/// grown on first use).
fn draw<S: SplatSink>(
    grid: &TriGrid<'_>,
    settings: &Settings,
    frame: &TgFrame,
    shadow: &mut Vec<u16>,
    sink: &mut S,
) -> anyhow::Result<Stats> {
    Ok(if settings.shadows == ShadowMode::Off {
        render_tg(grid, frame, sink)
    } else {
        let light = light_frame(grid.header(), settings)?;
        let n = settings.shadow_map_size;
        shadow.resize(n * n, u16::MAX);
        let mut map = ShadowMap::new(shadow, n);
        render_tg_shadowed(grid, frame, &light, &mut map, settings.shadows, sink)
    })
}

/// Statistics of a rendered frame.
#[derive(Clone, Copy, Debug)]
pub struct FrameReport {
    /// Traversal counts.
    pub stats: Stats,
    /// Wall time of setup + traversal + raster (no clearing).
    pub time: Duration,
}

/// Renders one frame of a tri-grid into `out` (cleared first).
///
/// # Errors
/// When the frame cannot be set up (ρ above 3, bad camera).
pub fn render_tg_frame(
    grid: &TriGrid<'_>,
    settings: &Settings,
    out: &mut FrameBuffers,
) -> anyhow::Result<FrameReport> {
    let mut table = Box::new(ShadingTable::<1>::new());
    render_tg_with(grid, settings, &mut table, out, |_, _| {})
}

/// Renders with a caller-owned shading table (rebuilt only when light or view change) and a hook
/// that may draw over the frame before it is returned.
///
/// # Errors
/// When the frame cannot be set up.
pub fn render_tg_with(
    grid: &TriGrid<'_>,
    settings: &Settings,
    table: &mut ShadingTable<1>,
    out: &mut FrameBuffers,
    overlay: impl FnOnce(&mut Framebuffer<'_>, &Stats),
) -> anyhow::Result<FrameReport> {
    let cam = settings.camera(grid.header().bounds64);
    render_tg_from(grid, settings, &cam, table, out, |fb, report| {
        overlay(fb, &report.stats)
    })
}

/// A frame's per-frame setup from `settings` and `cam`: the tri-grid frame tables of the model
/// described by `header`, and the shading table updated for the light and the viewer.
///
/// # Errors
/// When the frame cannot be set up.
pub fn frame_setup(
    header: &Header,
    settings: &Settings,
    cam: &Camera,
    table: &mut ShadingTable<1>,
) -> anyhow::Result<TgFrame> {
    let opts = RenderOptions {
        cutoff_px: settings.cutoff_px,
        kernel: settings.kernel,
        ..RenderOptions::default()
    };
    let frame = TgFrame::new(header, &Placement::IDENTITY, cam, &opts)?;
    table.update(
        &[settings.material],
        settings.light_dir(),
        camera::scale(cam.forward, -1.0),
    );
    Ok(frame)
}

/// As [`render_tg_with`], from `cam` instead of the orbit camera of `settings.view` (the viewer
/// pans the orbit centre); the hook also sees the frame's time.
///
/// # Errors
/// When the frame cannot be set up.
pub fn render_tg_from(
    grid: &TriGrid<'_>,
    settings: &Settings,
    cam: &Camera,
    table: &mut ShadingTable<1>,
    out: &mut FrameBuffers,
    overlay: impl FnOnce(&mut Framebuffer<'_>, &FrameReport),
) -> anyhow::Result<FrameReport> {
    let t = Instant::now();
    let frame = frame_setup(grid.header(), settings, cam, table)?;
    // Borrow the fields apart: the shadow map is used while the framebuffer is.
    let mut fb = Framebuffer::new(&mut out.color, &mut out.depth);
    fb.clear(0);
    let mut sink = ShadedRaster {
        fb: &mut fb,
        table,
        kernel: settings.kernel,
    };
    let stats = if settings.color_by_level {
        let levels = Levels::of_grid(grid.header().depth);
        let mut tinted = LevelTint {
            sink: &mut sink,
            levels: |object, s: &SampleSplat| levels.of(object, s),
            object: 0,
        };
        draw(grid, settings, &frame, &mut out.shadow, &mut tinted)?
    } else {
        draw(grid, settings, &frame, &mut out.shadow, &mut sink)?
    };
    let report = FrameReport {
        stats,
        time: t.elapsed(),
    };
    overlay(&mut fb, &report);
    Ok(report)
}

/// A frame with each pixel's lit/shadowed classification, for comparison with the reference
/// renderer's ([`crate::metrics::shadow_disagreement`]).
pub struct Classified {
    /// What the frame did.
    pub report: FrameReport,
    /// Whether each pixel was drawn.
    pub covered: Vec<bool>,
    /// Whether each pixel's splat is unlit: drawn in shadow, or with a normal facing away from the
    /// light (`n·l ≤ 0` in Q14, the shadow test's own criterion), so that a frame without shadows is
    /// classified by its attached shadows only.
    pub shadowed: Vec<bool>,
}

/// Splats through the shading table into the frame and, into a second framebuffer with the same
/// depth test, each splat's class (1 lit, 2 unlit): the same splats in the same order give the same
/// winner per pixel in both.
struct ClassTee<'f, 'b, 't, 'c, 'd> {
    shaded: ShadedRaster<'f, 't, Framebuffer<'b>, 1>,
    class: &'c mut Framebuffer<'d>,
    to_light_q14: [i32; 3],
}

impl SplatSink for ClassTee<'_, '_, '_, '_, '_> {
    fn splat(&mut self, s: &SampleSplat) {
        self.shaded.splat(s);
        let n = NORMALS_Q14[usize::from(s.attr) & (NORMAL_COUNT - 1)].map(i32::from);
        let l = self.to_light_q14;
        let cos = (n[0] * l[0] + n[1] * l[1] + n[2] * l[2]) >> 14;
        let splat = Splat {
            x_q8: s.x_q8,
            y_q8: s.y_q8,
            size_q8: s.size_q8,
            depth: s.depth,
            color: if s.shadowed || cos <= 0 { 2 } else { 1 },
        };
        self.class.splat(&splat, self.shaded.kernel, s.exact);
    }
}

/// Renders one frame like [`render_tg_frame`] and classifies every pixel lit or unlit (slower: a
/// second framebuffer; time it with [`render_tg_frame`]).
///
/// # Errors
/// When the frame cannot be set up.
pub fn render_tg_classified(
    grid: &TriGrid<'_>,
    settings: &Settings,
    out: &mut FrameBuffers,
) -> anyhow::Result<Classified> {
    let cam = settings.camera(grid.header().bounds64);
    let opts = RenderOptions {
        cutoff_px: settings.cutoff_px,
        kernel: settings.kernel,
        ..RenderOptions::default()
    };
    let t = Instant::now();
    let frame = TgFrame::new(grid.header(), &Placement::IDENTITY, &cam, &opts)?;
    let mut table = Box::new(ShadingTable::<1>::new());
    table.update(
        &[settings.material],
        settings.light_dir(),
        camera::scale(cam.forward, -1.0),
    );
    let mut class = FrameBuffers::new();
    let mut class_fb = class.framebuffer();
    class_fb.clear(0);
    let mut fb = Framebuffer::new(&mut out.color, &mut out.depth);
    fb.clear(0);
    let mut sink = ClassTee {
        shaded: ShadedRaster {
            fb: &mut fb,
            table: &table,
            kernel: settings.kernel,
        },
        class: &mut class_fb,
        to_light_q14: settings.light_dir().map(|c| (c * 16384.0).round() as i32),
    };
    let stats = draw(grid, settings, &frame, &mut out.shadow, &mut sink)?;
    let time = t.elapsed();
    Ok(Classified {
        report: FrameReport { stats, time },
        covered: class.pixels().iter().map(|&c| c != 0).collect(),
        shadowed: class.pixels().iter().map(|&c| c == 2).collect(),
    })
}
