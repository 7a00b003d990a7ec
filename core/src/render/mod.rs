//! One way in: open a model, set a camera, draw it into your display.
//!
//! ```
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! use pocketsplat_core::{render, DisplayTarget, Model, RenderOptions, ShadingTable, Target, View};
//! use pocketsplat_core::TestPanel;
//! // Any embedded-graphics display (here the crate's test panel, 128 × 160, which counts what
//! // it is sent) and a depth value per pixel.
//! let mut panel = TestPanel::new(128, 160);
//! let mut depth = vec![0u16; 128 * 160];
//! // The shading table (16 KB), kept between frames: rebuilt only when the view turns.
//! let mut table = ShadingTable::<1>::new();
//!
//! // A .tg, .qs or .pack file (by its magic), here linked in; from flash, read in place.
//! let model = Model::open(include_bytes!("../../examples/data/trefoil.tg"))?;
//! let camera = model.orbit(View::new(30.0, 20.0, 2.5)); // the projection follows the panel
//! let mut target = Target::new(DisplayTarget::new(&mut panel, &mut depth).unwrap(), &mut table);
//! render(&model, &camera, &RenderOptions::default(), &mut target)?;
//! assert!(panel.lit() > 1000, "the knot covers {} pixels", panel.lit());
//! # Ok(())
//! # }
//! ```
//!
//! [`render`] is the pipeline every caller of the project goes through (the firmware's views, the
//! simulator's `render` and `view`, scenes, streams, reports): the camera for the target's size,
//! the format's per-frame tables (and the light's, with shadows) as a [`Walk`], then one code path
//! for every format: the shading table, clear, the walk through the shaded raster. A [`Layer`]
//! puts a sink of the caller's between the walk and the raster (colour by resolution, a recording
//! tee); [`Phase`] marks let a benchmark attribute the cost of each step.
//!
//! What a target is: pixels with a depth test ([`DepthTarget`]: the project's
//! [`Framebuffer`](crate::raster::Framebuffer) or any display as a
//! [`DisplayTarget`](crate::raster::DisplayTarget)), the shading table, and, for shadows, a shadow
//! map and the light's tables ([`Target::with_shadows`]). Nothing is allocated: a firmware keeps
//! them in statics.

mod error;
mod formats;
mod model;
#[cfg(feature = "stream")]
mod stream;

pub use crate::frame::{FrameError, RenderOptions, Shading, Walk, DEFAULT_SHADOW_MAP_SIZE};
pub use error::{ModelError, RenderError};
#[cfg(feature = "scene")]
pub use formats::render_scene_marked;
pub use model::Model;
#[cfg(all(feature = "stream", feature = "qsplat"))]
pub use stream::render_qs_stream;
#[cfg(all(feature = "stream", feature = "scene"))]
pub use stream::render_scene_stream;
#[cfg(feature = "stream")]
pub use stream::{render_stream, StreamPass};

use crate::camera::{self, Camera, Vec3};
use crate::raster::DepthTarget;
use crate::shade::{ShadingTable, ShadowMode};
use crate::splat::{ColorSink, ShadedRaster, Stats};

#[cfg(feature = "shadows")]
use crate::shadow::LightFrame;

/// Where [`render`] draws: pixels with a depth test, the shading table (kept between frames, so
/// that it is rebuilt only when the view or light turns: `M` material slots, 1 for a model, a
/// scene's slot count for a pack) and, for shadows, a shadow map and the light's tables.
///
/// The project's own [`Framebuffer`](crate::raster::Framebuffer) is the fastest pixels on a
/// device (its size is known at compile time); a finished frame goes to any display in one
/// contiguous write, as an embedded-graphics image. Here a landscape 320 × 240 frame:
///
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use embedded_graphics_core::image::ImageDrawable;
/// use pocketsplat_core::{render, Framebuffer, Model, RenderOptions, ShadingTable, Target};
/// use pocketsplat_core::{TestPanel, View};
/// // Statics on a device; boxes here.
/// let (mut color, mut depth) = (Box::new([[0u16; 320]; 240]), Box::new([[0u16; 320]; 240]));
/// let mut table = ShadingTable::<1>::new();
/// let model = Model::open(include_bytes!("../../examples/data/trefoil.tg"))?;
///
/// let mut target = Target::new(Framebuffer::new(&mut color, &mut depth), &mut table);
/// let options = RenderOptions { cutoff_px: 2.0, ..RenderOptions::default() };
/// render(&model, &model.orbit(View::new(0.0, 30.0, 2.2)), &options, &mut target)?;
///
/// let mut display = TestPanel::new(320, 240);
/// target.pixels.draw(&mut display)?; // one fill_contiguous of 320 × 240 pixels
/// assert_eq!(display.sent(), 320 * 240);
/// assert!(display.lit() > 1000);
/// # Ok(())
/// # }
/// ```
pub struct Target<'t, P, const M: usize = 1> {
    /// The pixels (a [`Framebuffer`](crate::raster::Framebuffer), a
    /// [`DisplayTarget`](crate::raster::DisplayTarget)).
    pub pixels: P,
    table: &'t mut ShadingTable<M>,
    #[cfg(feature = "shadows")]
    shadow: Option<(&'t mut [u16], &'t mut LightFrame)>,
}

impl<'t, P: DepthTarget, const M: usize> Target<'t, P, M> {
    /// `pixels` shaded through `table`, without shadows.
    pub fn new(pixels: P, table: &'t mut ShadingTable<M>) -> Self {
        Self {
            pixels,
            table,
            #[cfg(feature = "shadows")]
            shadow: None,
        }
    }

    /// With a shadow map (at least [`RenderOptions::shadow_map_size`]² depths) and a place for the
    /// light's per-frame tables (17 KB: a `static` on a device, [`LightFrame::UNSET`] to start),
    /// so that frames may ask for shadows (Duguet §5.3: one pass, the light's order).
    ///
    /// ```
    /// # fn main() -> Result<(), Box<dyn std::error::Error>> {
    /// use pocketsplat_core::{render, DisplayTarget, LightFrame, Model, RenderOptions, ShadowMode};
    /// use pocketsplat_core::{ShadingTable, Target, View};
    /// # use core::convert::Infallible;
    /// # use embedded_graphics_core::{prelude::*, pixelcolor::Rgb565};
    /// # /// A 160 × 128 display that keeps the pixels it is sent.
    /// # struct Tft(Vec<Rgb565>);
    /// # impl OriginDimensions for Tft { fn size(&self) -> Size { Size::new(160, 128) } }
    /// # impl DrawTarget for Tft {
    /// #     type Color = Rgb565;
    /// #     type Error = Infallible;
    /// #     fn draw_iter<I: IntoIterator<Item = Pixel<Rgb565>>>(&mut self, px: I) -> Result<(), Infallible> {
    /// #         for Pixel(p, c) in px { self.0[p.y as usize * 160 + p.x as usize] = c; }
    /// #         Ok(())
    /// #     }
    /// # }
    /// let mut tft = Tft(vec![Rgb565::BLACK; 160 * 128]);
    /// let mut depth = vec![0u16; 160 * 128];
    /// let (mut map, mut light) = (vec![0u16; 128 * 128], Box::new(LightFrame::UNSET));
    /// let mut table = ShadingTable::<1>::new();
    /// let model = Model::open(include_bytes!("../../examples/data/trefoil.tg"))?;
    ///
    /// let pixels = DisplayTarget::new(&mut tft, &mut depth).expect("a depth per pixel");
    /// let mut target = Target::new(pixels, &mut table).with_shadows(&mut map, &mut light);
    /// let options = RenderOptions {
    ///     shadows: ShadowMode::OnePass,
    ///     shadow_map_size: 128,
    ///     ..RenderOptions::default()
    /// };
    /// let drawn = render(&model, &model.orbit(View::new(30.0, 40.0, 2.5)), &options, &mut target)?;
    /// assert_eq!(drawn.shadows, ShadowMode::OnePass);
    /// // The knot shadows itself: some of what it draws is its material's ambient term only.
    /// let ambient = target.table().shadowed(0);
    /// drop(target);
    /// assert!(tft.0.iter().any(|c| c.into_storage() == ambient));
    /// # Ok(())
    /// # }
    /// ```
    #[cfg(feature = "shadows")]
    pub fn with_shadows(self, map: &'t mut [u16], light: &'t mut LightFrame) -> Self {
        Self {
            shadow: Some((map, light)),
            ..self
        }
    }

    /// The shading table.
    pub fn table(&self) -> &ShadingTable<M> {
        self.table
    }

    /// The same target with its pixels wrapped by `f` (e.g. in a
    /// [`Band`](crate::raster::Band)): table and shadow map kept.
    pub fn map_pixels<Q: DepthTarget>(self, f: impl FnOnce(P) -> Q) -> Target<'t, Q, M> {
        Target {
            pixels: f(self.pixels),
            table: self.table,
            #[cfg(feature = "shadows")]
            shadow: self.shadow,
        }
    }
}

/// The steps of a frame, in order: [`render_marked`] reports the start of each (and
/// [`Phase::End`] after the traversal), so that an instruction counter can attribute their cost.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Phase {
    /// Camera and per-frame integer tables (the format's, and the light's with shadows; soft
    /// floats on an FPU-less core).
    Setup,
    /// The shading table (rebuilt only when the view direction or the light changes).
    Table,
    /// Clearing colour and depth.
    Clear,
    /// Traversal and raster (with two-pass shadows, the light's pass first).
    Traverse,
    /// The frame is drawn.
    End,
}

impl Phase {
    /// Every phase, in frame order.
    pub const ALL: [Phase; 5] = [
        Phase::Setup,
        Phase::Table,
        Phase::Clear,
        Phase::Traverse,
        Phase::End,
    ];
}

/// What a frame did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Drawn {
    /// Traversal counts (all objects' added, for a scene; for two-pass shadows, `nodes_visited`
    /// counts both passes).
    pub stats: Stats,
    /// Whether the shading table was rebuilt for this frame.
    pub table_rebuilt: bool,
    /// The shadows drawn.
    pub shadows: ShadowMode,
    /// A scene's counts per object.
    #[cfg(feature = "scene")]
    pub scene: Option<crate::scene::SceneStats>,
}

/// What a caller puts between a frame's walk and the shaded raster: a sink of its own wrapping
/// the raster's (colour by resolution, a tee that records what is drawn). The default runs the
/// walk straight into the raster.
///
/// A layer that counts the splats of each level on their way to a 128 × 160 display:
///
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use pocketsplat_core::{render_marked, ColorSink, DisplayTarget, Layer, Model, Phase};
/// use pocketsplat_core::{RenderOptions, SampleSplat, ShadingTable, SplatSink, Stats, Target};
/// use pocketsplat_core::{TestPanel, View, Walk};
/// /// Splats per level, then on to the raster.
/// struct PerLevel([u32; 16]);
/// struct Counting<'a, S>(&'a mut [u32; 16], &'a mut S);
/// impl<S: ColorSink> SplatSink for Counting<'_, S> {
///     fn splat(&mut self, s: &SampleSplat) {
///         self.0[usize::from(s.level) & 15] += 1;
///         self.1.splat(s);
///     }
/// }
/// impl<S: ColorSink> ColorSink for Counting<'_, S> {
///     fn splat_colored(&mut self, s: &SampleSplat, rgb565: u16) {
///         self.0[usize::from(s.level) & 15] += 1;
///         self.1.splat_colored(s, rgb565);
///     }
/// }
/// impl Layer for PerLevel {
///     fn run<W: Walk, S: ColorSink>(&mut self, walk: &mut W, sink: &mut S) -> Stats {
///         walk.walk(&mut Counting(&mut self.0, sink))
///     }
/// }
///
/// let (mut panel, mut depth) = (TestPanel::new(128, 160), vec![0u16; 128 * 160]);
/// let mut table = ShadingTable::<1>::new();
/// let model = Model::open(include_bytes!("../../examples/data/trefoil.tg"))?;
/// let mut target = Target::new(DisplayTarget::new(&mut panel, &mut depth).unwrap(), &mut table);
/// let mut per_level = PerLevel([0; 16]);
/// let mut phases = Vec::new();
/// let options = RenderOptions { cutoff_px: 16.0, ..RenderOptions::default() };
/// let camera = model.orbit(View::new(-30.0, 10.0, 3.0));
/// render_marked(&model, &camera, &options, &mut target, &mut per_level, |p| phases.push(p))?;
/// assert_eq!(phases, Phase::ALL);
/// // At a 16 px cutoff the knot is drawn from cells above its leaves (level 4).
/// assert!(per_level.0[..4].iter().sum::<u32>() > 0, "{:?}", per_level.0);
/// drop(target);
/// assert!(panel.sent() > 500);
/// # Ok(())
/// # }
/// ```
pub trait Layer {
    /// Runs `walk` into `sink`, or into a sink of the layer's in front of it.
    fn run<W: Walk, S: ColorSink>(&mut self, walk: &mut W, sink: &mut S) -> Stats {
        walk.walk(sink)
    }
}

/// No layer: the walk draws straight into the raster.
#[derive(Clone, Copy, Debug, Default)]
pub struct Direct;

impl Layer for Direct {}

/// Draws one frame of `model` seen by `camera` into `target`: the whole pipeline, fitted to the
/// target's size (the camera keeps its vertical field of view).
///
/// # Errors
/// [`RenderError`]: a camera or cutoff that is not finite and positive, ρ above 3, shadows the
/// model, build or target cannot draw, a scene that needs more material slots than `M`.
pub fn render<P: DepthTarget, const M: usize>(
    model: &Model<'_>,
    camera: &Camera,
    options: &RenderOptions,
    target: &mut Target<'_, P, M>,
) -> Result<Drawn, RenderError> {
    render_marked(model, camera, options, target, &mut Direct, |_| {})
}

/// [`render`] through `layer`, with `mark` called at the start of each [`Phase`] and at
/// [`Phase::End`].
///
/// # Errors
/// As [`render`].
pub fn render_marked<P: DepthTarget, L: Layer, const M: usize>(
    model: &Model<'_>,
    camera: &Camera,
    options: &RenderOptions,
    target: &mut Target<'_, P, M>,
    layer: &mut L,
    mut mark: impl FnMut(Phase),
) -> Result<Drawn, RenderError> {
    mark(Phase::Setup);
    let camera = camera.for_viewport(target.pixels.viewport());
    model.draw(&camera, options, target, layer, &mut mark)
}

/// The direction towards the viewer, world frame: what the shading table lights for.
pub(crate) fn view_dir(camera: &Camera) -> Vec3 {
    camera::scale(camera.forward, -1.0)
}

impl<P: DepthTarget, const M: usize> Target<'_, P, M> {
    /// The pipeline after a model's set-up, one code path for every format, stream and scene:
    /// the shading table ([`Phase::Table`]), clearing when `clear` ([`Phase::Clear`]), the walk
    /// through `layer` into the shaded raster ([`Phase::Traverse`]), then [`Phase::End`].
    pub(crate) fn draw<W: Walk, L: Layer>(
        &mut self,
        walk: &mut W,
        shading: &Shading<M>,
        clear: bool,
        options: &RenderOptions,
        layer: &mut L,
        mark: &mut impl FnMut(Phase),
    ) -> Drawn {
        draw(
            &mut self.pixels,
            self.table,
            walk,
            shading,
            clear,
            options,
            layer,
            mark,
        )
    }
}

/// [`Target::draw`] with the target's parts borrowed apart (a shadowed walk holds its map).
#[allow(clippy::too_many_arguments)]
fn draw<P: DepthTarget, W: Walk, L: Layer, const M: usize>(
    pixels: &mut P,
    table: &mut ShadingTable<M>,
    walk: &mut W,
    shading: &Shading<M>,
    clear: bool,
    options: &RenderOptions,
    layer: &mut L,
    mark: &mut impl FnMut(Phase),
) -> Drawn {
    mark(Phase::Table);
    let table_rebuilt = shading.apply(table);
    mark(Phase::Clear);
    if clear {
        pixels.clear(options.background);
    }
    mark(Phase::Traverse);
    let mut sink = ShadedRaster {
        fb: pixels,
        table: &*table,
        kernel: options.kernel,
    };
    let stats = layer.run(walk, &mut sink);
    mark(Phase::End);
    Drawn {
        stats,
        table_rebuilt,
        shadows: options.shadows,
        #[cfg(feature = "scene")]
        scene: None,
    }
}

#[cfg(all(test, feature = "trigrid"))]
mod tests;
