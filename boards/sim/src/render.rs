//! Rendering point files on the desktop through the core's one pipeline, the firmware's code
//! ([`pocketsplat_core::render`](mod@pocketsplat_core::render)): every format, every size, into [`FrameBuffers`].
//!
//! The frame is an [`Image`] of any size (an embedded-graphics display, which the core draws into
//! through a [`DisplayTarget`] with the depth buffer beside it, as a user's display), so that
//! `--size` is the size of the buffers and the projection follows it.

use std::time::{Duration, Instant};

use embedded_graphics::pixelcolor::raw::RawU16;
use embedded_graphics::pixelcolor::Rgb565;
use embedded_graphics::prelude::*;
use embedded_graphics::primitives::Rectangle;
use pocketsplat_core::camera::{self, Camera, Sphere, View, Viewport, DEFAULT_FOV_DEG};
use pocketsplat_core::normal::{NORMALS_Q14, NORMAL_COUNT};
use pocketsplat_core::raster::{crc565, draw_splat, Band, DisplayTarget, Kernel, Splat, DEPTH_FAR};
use pocketsplat_core::render::{render_marked, Layer, Model, Phase, RenderOptions, Target, Walk};
use pocketsplat_core::scene::SceneStats;
use pocketsplat_core::shade::{Material, ShadingTable, DEFAULT_LIGHT_AZ_EL, DEFAULT_MATERIAL};
use pocketsplat_core::shadow::LightFrame;
pub use pocketsplat_core::shadow::ShadowMode;
use pocketsplat_core::splat::{ColorSink, LevelTint, SampleSplat, SplatSink, Stats};
use pocketsplat_core::tg::TriGrid;

use crate::levels::Levels;

/// Width and height of the reference frame (`--size` picks another).
pub use pocketsplat_core::camera::{HEIGHT, WIDTH};

/// An RGB565 image of any size on the heap: the simulator's display. The core draws a frame into it
/// through a [`DisplayTarget`]; overlays (the viewer's HUD, the colour key) draw with
/// embedded-graphics.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Image {
    viewport: Viewport,
    pixels: Vec<u16>,
}

impl Image {
    /// A black image of `viewport`'s size.
    pub fn new(viewport: Viewport) -> Self {
        Self {
            viewport,
            pixels: vec![0; viewport.pixels()],
        }
    }

    /// Its size.
    pub fn viewport(&self) -> Viewport {
        self.viewport
    }

    /// The pixels, row by row.
    pub fn pixels(&self) -> &[u16] {
        &self.pixels
    }

    /// Pixel `(x, y)`.
    pub fn at(&self, x: usize, y: usize) -> u16 {
        self.pixels[y * usize::from(self.viewport.width) + x]
    }
}

impl OriginDimensions for Image {
    fn size(&self) -> Size {
        Size::new(self.viewport.width.into(), self.viewport.height.into())
    }
}

impl DrawTarget for Image {
    type Color = Rgb565;
    type Error = core::convert::Infallible;

    fn draw_iter<I: IntoIterator<Item = Pixel<Rgb565>>>(
        &mut self,
        pixels: I,
    ) -> Result<(), Self::Error> {
        let (w, h) = (
            i32::from(self.viewport.width),
            i32::from(self.viewport.height),
        );
        for Pixel(p, c) in pixels {
            if (0..w).contains(&p.x) && (0..h).contains(&p.y) {
                self.pixels[(p.y * w + p.x) as usize] = RawU16::from(c).into_inner();
            }
        }
        Ok(())
    }

    fn fill_solid(&mut self, area: &Rectangle, color: Rgb565) -> Result<(), Self::Error> {
        let area = area.intersection(&self.bounding_box());
        let Some(br) = area.bottom_right() else {
            return Ok(());
        };
        let raw = RawU16::from(color).into_inner();
        let w = usize::from(self.viewport.width);
        for y in area.top_left.y as usize..=br.y as usize {
            self.pixels[y * w + area.top_left.x as usize..=y * w + br.x as usize].fill(raw);
        }
        Ok(())
    }
}

/// An owned frame: the image, its depth buffer, and the shadow map and light tables once shadows
/// are used. The reference 240 × 320 by default, any [`Viewport`] with [`FrameBuffers::sized`].
pub struct FrameBuffers {
    /// The pixels.
    pub image: Image,
    depth: Vec<u16>,
    /// Shadow-map depths, allocated on first use.
    shadow: Vec<u16>,
    light: Box<LightFrame>,
    /// Horizontal bands a frame is drawn in ([`FrameBuffers::in_bands`]; 1: whole).
    bands: u16,
}

impl Default for FrameBuffers {
    fn default() -> Self {
        Self::new()
    }
}

impl FrameBuffers {
    /// Black, depth cleared, 240 × 320.
    pub fn new() -> Self {
        Self::sized(Viewport::DEFAULT)
    }

    /// Black, depth cleared, of `viewport`'s size.
    pub fn sized(viewport: Viewport) -> Self {
        Self {
            image: Image::new(viewport),
            depth: vec![DEPTH_FAR; viewport.pixels()],
            shadow: Vec::new(),
            light: Box::new(LightFrame::UNSET),
            bands: 1,
        }
    }

    /// Frames drawn into these buffers are drawn as the handheld draws them: in `bands`
    /// horizontal bands (at least 1, at most one per row), each into buffers of its own rows
    /// through [`pocketsplat_core::raster::Band`] and then copied here. The frame is the same,
    /// bit for bit; what changes is the RAM a device needs (a band's colour and depth) and the
    /// work (a walk per band).
    #[must_use]
    pub fn in_bands(mut self, bands: u16) -> Self {
        self.bands = bands.clamp(1, self.viewport().height);
        self
    }

    /// Rows of each band but perhaps the last (fewer there).
    pub fn band_rows(&self) -> u16 {
        self.viewport().height.div_ceil(self.bands)
    }

    /// The frame's size.
    pub fn viewport(&self) -> Viewport {
        self.image.viewport
    }

    /// Pixels in row order.
    pub fn pixels(&self) -> &[u16] {
        self.image.pixels()
    }

    /// Depths in row order ([`DEPTH_FAR`] where nothing was drawn).
    pub fn depths(&self) -> &[u16] {
        &self.depth
    }

    /// Shadow-map depths kept for the frames that ask for shadows (empty until one does).
    pub fn shadow_map(&self) -> &[u16] {
        &self.shadow
    }

    /// Whether each pixel was drawn (depth written).
    pub fn covered(&self) -> Vec<bool> {
        self.depth.iter().map(|&d| d != DEPTH_FAR).collect()
    }

    /// CRC-32 of the colour buffer, as the firmware computes it.
    pub fn crc(&self) -> u32 {
        crc565(self.pixels())
    }

    /// The pixels and depth buffer as the core's [`DisplayTarget`], for drawing splats directly.
    pub fn display(&mut self) -> DisplayTarget<'_, Image> {
        DisplayTarget::new(&mut self.image, &mut self.depth).expect("a depth value per pixel")
    }

    /// The core's render target over these buffers, shading through `table`; with a shadow map of
    /// `shadow_side`² depths (grown on first use) when the frame asks for shadows.
    pub fn target<'t, const M: usize>(
        &'t mut self,
        table: &'t mut ShadingTable<M>,
        shadow_side: Option<usize>,
    ) -> Target<'t, DisplayTarget<'t, Image>, M> {
        let pixels =
            DisplayTarget::new(&mut self.image, &mut self.depth).expect("a depth value per pixel");
        Self::shadowed(
            Target::new(pixels, table),
            &mut self.shadow,
            &mut self.light,
            shadow_side,
        )
    }

    /// The core's render target over these buffers as band `top..` of a frame of `full`'s size
    /// ([`Band`]: these buffers hold the band's rows), as [`FrameBuffers::target`].
    pub fn band_target<'t, const M: usize>(
        &'t mut self,
        table: &'t mut ShadingTable<M>,
        shadow_side: Option<usize>,
        top: u16,
        full: Viewport,
    ) -> Target<'t, Band<DisplayTarget<'t, Image>>, M> {
        let pixels =
            DisplayTarget::new(&mut self.image, &mut self.depth).expect("a depth value per pixel");
        let band = Band::new(pixels, top, full).expect("the band lies in the frame");
        Self::shadowed(
            Target::new(band, table),
            &mut self.shadow,
            &mut self.light,
            shadow_side,
        )
    }

    /// Copies `band`'s pixels and depths into rows `top..` of these buffers (as wide).
    pub fn put_band(&mut self, top: u16, band: &FrameBuffers) {
        let at = usize::from(top) * usize::from(self.viewport().width);
        let n = band.depth.len();
        self.image.pixels[at..at + n].copy_from_slice(band.image.pixels());
        self.depth[at..at + n].copy_from_slice(&band.depth);
    }

    /// Buffers for the band of `rows` rows starting at `top` of these buffers' frame (fewer at
    /// the bottom), or `None` past the last row.
    pub fn band_buffers(&self, top: u16) -> Option<FrameBuffers> {
        let full = self.viewport();
        let h = self.band_rows().min(full.height.checked_sub(top)?);
        Some(FrameBuffers::sized(Viewport::new(
            u32::from(full.width),
            u32::from(h),
        )?))
    }

    /// Draws the frame band by band: `draw` gets each band's own buffers and its first row, and
    /// the band is then copied into these buffers. Returns the first band's result (every band's
    /// walk is the frame's walk).
    ///
    /// # Errors
    /// The first error `draw` returns (the bands after it are not drawn).
    pub fn draw_bands<T, E>(
        &mut self,
        mut draw: impl FnMut(&mut FrameBuffers, u16) -> Result<T, E>,
    ) -> Result<Option<T>, E> {
        let (mut top, mut first) = (0, None);
        while let Some(mut part) = self.band_buffers(top) {
            let r = draw(&mut part, top)?;
            self.put_band(top, &part);
            first.get_or_insert(r);
            top += part.viewport().height;
        }
        Ok(first)
    }

    /// `target` with a shadow map of `shadow_side`² depths in `shadow` (grown on first use) and
    /// `light`, when the frame asks for shadows.
    fn shadowed<'t, P: pocketsplat_core::raster::DepthTarget, const M: usize>(
        target: Target<'t, P, M>,
        shadow: &'t mut Vec<u16>,
        light: &'t mut LightFrame,
        shadow_side: Option<usize>,
    ) -> Target<'t, P, M> {
        match shadow_side {
            Some(side) => {
                let need = side.saturating_mul(side);
                if shadow.len() < need {
                    shadow.resize(need, u16::MAX);
                }
                target.with_shadows(shadow, light)
            }
            None => target,
        }
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
    /// The frame's size (`--size`): the buffers' size, which the projection follows.
    pub size: Viewport,
    /// Horizontal bands the frame is drawn in (`--bands`, [`FrameBuffers::in_bands`]): the same
    /// frame, drawn as a device with a band's colour and depth draws it.
    pub bands: u16,
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
            size: Viewport::DEFAULT,
            bands: 1,
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
    /// The camera for a model with this bounding box, for a frame of [`Settings::size`].
    pub fn camera(&self, bounds: impl ModelBounds) -> Camera {
        Camera::orbit(bounds.sphere(), self.view, self.fov_deg).for_viewport(self.size)
    }

    /// Buffers for a frame of [`Settings::size`].
    pub fn buffers(&self) -> FrameBuffers {
        FrameBuffers::sized(self.size).in_bands(self.bands)
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

    /// The orbit camera of these settings about `model` (a tri-grid's precise bounds when it has
    /// them), for a frame of [`Settings::size`] (the core fits it to the buffers' size anyway).
    pub fn camera_for(&self, model: &Model<'_>) -> Camera {
        self.camera(model.sphere())
    }

    /// The core's options for `model`: these settings' cutoff, kernel, light, material and shadows.
    ///
    /// # Errors
    /// One-pass shadows with a point light (Duguet §5.3 needs one light direction), or a point
    /// light for a scene (lit by a directional light).
    pub fn options(&self, model: &Model<'_>) -> anyhow::Result<RenderOptions> {
        let light_position = match self.light_pos {
            None => None,
            Some(_) if matches!(model, Model::Scene(_)) => anyhow::bail!(
                "a scene is lit by a directional light; --light-pos is for single models"
            ),
            Some(_) if self.shadows == ShadowMode::OnePass => anyhow::bail!(
                "one-pass shadows need a directional light (Duguet §5.3); use --shadows two-pass \
                 with --light-pos"
            ),
            Some(_) => self.light_position(model.sphere()),
        };
        Ok(self.render_options(light_position))
    }

    /// The core's options of these settings, with a point light at `light_position` (model
    /// units) or none.
    pub fn render_options(&self, light_position: Option<[f64; 3]>) -> RenderOptions {
        RenderOptions {
            cutoff_px: self.cutoff_px,
            kernel: self.kernel,
            shadows: self.shadows,
            light_dir: self.light_dir(),
            light_position,
            shadow_map_size: self.shadow_map_size,
            material: self.material,
            ..RenderOptions::default()
        }
    }
}

impl ModelBounds for Sphere {
    fn sphere(self) -> Sphere {
        self
    }
}

/// The shading table the simulator uses for every scene (8 slots, the most a pack has).
pub type SceneTable = ShadingTable<{ pocketsplat_core::scene::MAX_SLOTS }>;

/// A fresh, boxed scene shading table (148 KB: too big for a test thread's stack).
pub fn scene_table() -> Box<SceneTable> {
    Box::new(SceneTable::new())
}

/// Statistics of a rendered frame.
#[derive(Clone, Copy, Debug)]
pub struct FrameReport {
    /// Traversal counts.
    pub stats: Stats,
    /// Wall time of setup, table, traversal and raster (not the clearing).
    pub time: Duration,
    /// A scene pack's counts per object.
    pub scene: Option<SceneStats>,
}

/// Colour by resolution ([`crate::levels`]): every splat tinted by its levels above full detail.
pub struct Tinted<'l>(pub &'l Levels);

impl Layer for Tinted<'_> {
    fn run<W: Walk, S: ColorSink>(&mut self, walk: &mut W, sink: &mut S) -> Stats {
        let levels = self.0;
        let mut tinted = LevelTint {
            sink,
            levels: |object, s: &SampleSplat| levels.of(object, s),
            object: 0,
        };
        walk.walk(&mut tinted)
    }
}

/// No layer, or colour by resolution.
pub enum Layers<'l> {
    /// Straight into the raster.
    Direct,
    /// [`Tinted`].
    Tinted(Tinted<'l>),
}

impl Layer for Layers<'_> {
    fn run<W: Walk, S: ColorSink>(&mut self, walk: &mut W, sink: &mut S) -> Stats {
        match self {
            Layers::Direct => walk.walk(sink),
            Layers::Tinted(t) => t.run(walk, sink),
        }
    }
}

/// The levels colour by resolution needs for `model`.
///
/// # Errors
/// When the memory for a QSplat file's levels cannot be had ([`Levels::of_qsplat`]).
pub fn levels_of(model: &Model<'_>) -> anyhow::Result<Levels> {
    Ok(match model {
        Model::TriGrid(grid) => Levels::of_grid(grid.header().depth),
        Model::QSplat(file) => Levels::of_qsplat(file)?,
        Model::Scene(scene) => Levels::of_scene(scene)?,
        other => anyhow::bail!(
            "colour by resolution: no levels for a {} file",
            other.format().name()
        ),
    })
}

/// Renders one frame of `model` seen by `cam` into `out` through the core's pipeline
/// ([`render_marked`]), shading through `table` (kept by the caller, rebuilt only when the light
/// or view turns) and drawing `layer` between the traversal and the raster; `overlay` may draw over
/// the finished frame. The camera is fitted to `out`'s size.
///
/// # Errors
/// When the frame cannot be set up ([`pocketsplat_core::render::RenderError`]: a bad camera or
/// cutoff, shadows a model cannot have, a scene with more slots than `M`).
pub fn render_from<const M: usize>(
    model: &Model<'_>,
    cam: &Camera,
    options: &RenderOptions,
    table: &mut ShadingTable<M>,
    out: &mut FrameBuffers,
    layer: &mut impl Layer,
    overlay: impl FnOnce(&mut Image, &FrameReport),
) -> anyhow::Result<FrameReport> {
    let shadow_side = (options.shadows != ShadowMode::Off).then_some(options.shadow_map_size);
    let t = Instant::now();
    let (mut clear_at, mut clear_time) = (None, Duration::ZERO);
    let mut mark = |phase| match phase {
        Phase::Clear => clear_at = Some(Instant::now()),
        Phase::Traverse => {
            if let Some(c) = clear_at {
                clear_time += c.elapsed();
            }
        }
        _ => {}
    };
    let drawn = if out.bands > 1 {
        render_bands(
            model,
            cam,
            options,
            table,
            out,
            layer,
            shadow_side,
            &mut mark,
        )
    } else {
        let mut target = out.target(table, shadow_side);
        render_marked(model, cam, options, &mut target, layer, &mut mark)
    }
    .map_err(|e| anyhow::anyhow!("{e}"))?;
    let report = FrameReport {
        stats: drawn.stats,
        time: t.elapsed().saturating_sub(clear_time),
        scene: drawn.scene,
    };
    overlay(&mut out.image, &report);
    Ok(report)
}

/// [`render_marked`] in `out`'s bands ([`FrameBuffers::in_bands`]): each band drawn into buffers
/// of its own rows (and its own shadow map), then copied into `out`. The
/// counts are the first band's walk (every band's walk is the same walk).
#[allow(clippy::too_many_arguments)]
fn render_bands<const M: usize>(
    model: &Model<'_>,
    cam: &Camera,
    options: &RenderOptions,
    table: &mut ShadingTable<M>,
    out: &mut FrameBuffers,
    layer: &mut impl Layer,
    shadow_side: Option<usize>,
    mark: &mut impl FnMut(Phase),
) -> Result<pocketsplat_core::render::Drawn, pocketsplat_core::render::RenderError> {
    let full = out.viewport();
    let first = out.draw_bands(|part, top| {
        let mut target = part.band_target(&mut *table, shadow_side, top, full);
        render_marked(model, cam, options, &mut target, layer, &mut *mark)
    })?;
    Ok(first.expect("a frame has a row"))
}

/// Renders one frame of `model` from `cam` as `settings` say (their options; colour by resolution
/// when asked) into `out`, with a caller-owned table: the viewer's and the reports' frames.
///
/// # Errors
/// As [`render_from`], and a point light with one-pass shadows or for a scene.
pub fn render_with<const M: usize>(
    model: &Model<'_>,
    settings: &Settings,
    cam: &Camera,
    table: &mut ShadingTable<M>,
    out: &mut FrameBuffers,
    overlay: impl FnOnce(&mut Image, &FrameReport),
) -> anyhow::Result<FrameReport> {
    let options = settings.options(model)?;
    let levels = settings
        .color_by_level
        .then(|| levels_of(model))
        .transpose()?;
    let mut layer = match &levels {
        Some(l) => Layers::Tinted(Tinted(l)),
        None => Layers::Direct,
    };
    render_from(model, cam, &options, table, out, &mut layer, overlay)
}

/// Renders one frame of `model` as `settings` say (its orbit camera, its options; colour by
/// resolution when asked), into `out`, with a table of its own.
///
/// # Errors
/// As [`render_from`], and a point light with one-pass shadows.
pub fn render_frame(
    model: &Model<'_>,
    settings: &Settings,
    out: &mut FrameBuffers,
) -> anyhow::Result<FrameReport> {
    let cam = settings.camera_for(model);
    match model {
        Model::Scene(_) => {
            let mut table = scene_table();
            render_with(model, settings, &cam, &mut table, out, |_, _| {})
        }
        _ => {
            let mut table = Box::new(ShadingTable::<1>::new());
            render_with(model, settings, &cam, &mut table, out, |_, _| {})
        }
    }
}

/// Renders one frame of a tri-grid into `out` (cleared first), as [`render_frame`].
///
/// # Errors
/// When the frame cannot be set up (ρ above 3, bad camera).
pub fn render_tg_frame(
    grid: &TriGrid<'_>,
    settings: &Settings,
    out: &mut FrameBuffers,
) -> anyhow::Result<FrameReport> {
    render_frame(&Model::TriGrid(*grid), settings, out)
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

/// Each splat into the raster and, into a second image with the same depth test, its class (1 lit,
/// 2 unlit): the same splats in the same order give the same winner per pixel in both.
struct ClassTee<'c> {
    class: DisplayTarget<'c, Image>,
    kernel: Kernel,
    to_light_q14: [i32; 3],
}

struct Tee<'t, 'c, S> {
    sink: &'t mut S,
    tee: &'t mut ClassTee<'c>,
}

impl<S: ColorSink> Tee<'_, '_, S> {
    fn classify(&mut self, s: &SampleSplat) {
        let n = NORMALS_Q14[usize::from(s.attr) & (NORMAL_COUNT - 1)].map(i32::from);
        let l = self.tee.to_light_q14;
        let cos = (n[0] * l[0] + n[1] * l[1] + n[2] * l[2]) >> 14;
        let splat = Splat {
            x_q8: s.x_q8,
            y_q8: s.y_q8,
            size_q8: s.size_q8,
            depth: s.depth,
            color: if s.shadowed || cos <= 0 { 2 } else { 1 },
        };
        draw_splat(&mut self.tee.class, &splat, self.tee.kernel, s.exact);
    }
}

impl<S: ColorSink> SplatSink for Tee<'_, '_, S> {
    fn splat(&mut self, s: &SampleSplat) {
        self.sink.splat(s);
        self.classify(s);
    }
}

impl<S: ColorSink> ColorSink for Tee<'_, '_, S> {
    fn splat_colored(&mut self, s: &SampleSplat, rgb565: u16) {
        self.sink.splat_colored(s, rgb565);
        self.classify(s);
    }
}

impl Layer for ClassTee<'_> {
    fn run<W: Walk, S: ColorSink>(&mut self, walk: &mut W, sink: &mut S) -> Stats {
        walk.walk(&mut Tee { sink, tee: self })
    }
}

/// Renders one frame like [`render_tg_frame`] and classifies every pixel lit or unlit (slower: a
/// second image; time it with [`render_tg_frame`]).
///
/// # Errors
/// When the frame cannot be set up.
pub fn render_tg_classified(
    grid: &TriGrid<'_>,
    settings: &Settings,
    out: &mut FrameBuffers,
) -> anyhow::Result<Classified> {
    let model = Model::TriGrid(*grid);
    let cam = settings.camera_for(&model);
    let options = settings.options(&model)?;
    let mut table = Box::new(ShadingTable::<1>::new());
    let viewport = out.viewport();
    let (mut class, mut class_depth) = (Image::new(viewport), vec![DEPTH_FAR; viewport.pixels()]);
    let mut tee = ClassTee {
        class: DisplayTarget::new(&mut class, &mut class_depth).expect("a depth per pixel"),
        kernel: options.kernel,
        to_light_q14: settings.light_dir().map(|c| (c * 16384.0).round() as i32),
    };
    // The class image is cleared with the frame: its depth test starts as the frame's.
    pocketsplat_core::raster::DepthTarget::clear(&mut tee.class, 0);
    let report = render_from(&model, &cam, &options, &mut table, out, &mut tee, |_, _| {})?;
    Ok(Classified {
        report,
        covered: class.pixels().iter().map(|&c| c != 0).collect(),
        shadowed: class.pixels().iter().map(|&c| c == 2).collect(),
    })
}
