//! Rendering point files on the desktop through the same core code the firmware runs.

use std::time::{Duration, Instant};

use pocketsplat_core::camera::{self, Camera, Placement, Sphere, View, DEFAULT_FOV_DEG};
use pocketsplat_core::raster::{Framebuffer, Kernel};
use pocketsplat_core::shade::{Material, ShadingTable, DEFAULT_LIGHT_AZ_EL, DEFAULT_MATERIAL};
pub use pocketsplat_core::shadow::ShadowMode;
use pocketsplat_core::shadow::{render_tg_shadowed, LightFrame, ShadowMap};
use pocketsplat_core::splat::{ShadedRaster, Stats};
use pocketsplat_core::tg::{render_tg, RenderOptions, TgFrame, TriGrid};

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
    /// Light azimuth and elevation, degrees.
    pub light_az_el: (f64, f64),
    /// Material of every sample.
    pub material: Material,
    /// Shadow algorithm.
    pub shadows: ShadowMode,
    /// Side of the shadow map, texels.
    pub shadow_map_size: usize,
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            view: camera::standard_view("std").expect("std view"),
            fov_deg: DEFAULT_FOV_DEG,
            cutoff_px: 1.0,
            kernel: Kernel::Square,
            light_az_el: DEFAULT_LIGHT_AZ_EL,
            material: DEFAULT_MATERIAL,
            shadows: ShadowMode::Off,
            shadow_map_size: DEFAULT_SHADOW_MAP_SIZE,
        }
    }
}

impl Settings {
    /// The camera for a model with this bounding box.
    pub fn camera(&self, bounds: [[f32; 3]; 2]) -> Camera {
        Camera::orbit(Sphere::from_bounds(bounds), self.view, self.fov_deg)
    }
    /// Unit direction to the light.
    pub fn light_dir(&self) -> [f64; 3] {
        camera::direction(self.light_az_el.0, self.light_az_el.1)
    }
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
    let cam = settings.camera(grid.header().bounds);
    render_tg_from(grid, settings, &cam, table, out, |fb, report| {
        overlay(fb, &report.stats)
    })
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
    let opts = RenderOptions {
        cutoff_px: settings.cutoff_px,
        kernel: settings.kernel,
        ..RenderOptions::default()
    };
    let t = Instant::now();
    let frame = TgFrame::new(grid.header(), &Placement::IDENTITY, cam, &opts)?;
    table.update(
        &[settings.material],
        settings.light_dir(),
        camera::scale(cam.forward, -1.0),
    );
    // Borrow the fields apart: the shadow map is used while the framebuffer is.
    let mut fb = Framebuffer::new(&mut out.color, &mut out.depth);
    fb.clear(0);
    let mut sink = ShadedRaster {
        fb: &mut fb,
        table,
        kernel: settings.kernel,
    };
    let stats = if settings.shadows == ShadowMode::Off {
        render_tg(grid, &frame, &mut sink)
    } else {
        let n = settings.shadow_map_size;
        out.shadow.resize(n * n, u16::MAX);
        let light = LightFrame::new(grid.header(), &Placement::IDENTITY, settings.light_dir(), n);
        let mut map = ShadowMap::new(&mut out.shadow, n);
        render_tg_shadowed(grid, &frame, &light, &mut map, settings.shadows, &mut sink)
    };
    let report = FrameReport {
        stats,
        time: t.elapsed(),
    };
    overlay(&mut fb, &report);
    Ok(report)
}
