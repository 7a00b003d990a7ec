//! One way in: open a model, set a camera, draw it into your display.
//!
//! ```
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! use pocketsplat_core::render::{render, Model, RenderOptions, Target};
//! use pocketsplat_core::raster::DisplayTarget;
//! use pocketsplat_core::shade::ShadingTable;
//! use pocketsplat_core::camera::View;
//! # use core::convert::Infallible;
//! # use embedded_graphics_core::{prelude::*, pixelcolor::Rgb565};
//! # /// A display that counts the lit pixels it is sent.
//! # struct Panel(u32);
//! # impl OriginDimensions for Panel { fn size(&self) -> Size { Size::new(128, 160) } }
//! # impl DrawTarget for Panel {
//! #     type Color = Rgb565;
//! #     type Error = Infallible;
//! #     fn draw_iter<I: IntoIterator<Item = Pixel<Rgb565>>>(&mut self, px: I) -> Result<(), Infallible> {
//! #         self.0 += px.into_iter().filter(|Pixel(_, c)| *c != Rgb565::BLACK).count() as u32;
//! #         Ok(())
//! #     }
//! # }
//! // Any embedded-graphics display (here a 128 × 160 panel) and a depth value per pixel.
//! let mut panel = Panel(0);
//! let mut depth = vec![0u16; 128 * 160];
//! // The shading table (16 KB), kept between frames: rebuilt only when the view turns.
//! let mut table = ShadingTable::<1>::new();
//!
//! // A .tg, .qs or .pack file (by its magic), here linked in; from flash, read in place.
//! let model = Model::open(include_bytes!("../../examples/data/trefoil.tg"))?;
//! let camera = model.orbit(View::new(30.0, 20.0, 2.5)); // the projection follows the panel
//! let mut target = Target::new(DisplayTarget::new(&mut panel, &mut depth).unwrap(), &mut table);
//! render(&model, &camera, &RenderOptions::default(), &mut target)?;
//! drop(target);
//! assert!(panel.0 > 1000, "the knot covers {} pixels", panel.0);
//! # Ok(())
//! # }
//! ```
//!
//! [`render`] is the pipeline every caller of the project goes through (the firmware's views, the
//! simulator's `render` and `view`, scenes, reports): the camera for the target's size, the
//! format's per-frame tables (and the light's, with shadows), the shading table, clear, the
//! format's traversal through the shaded raster. A [`Layer`] puts a sink of the caller's between
//! the traversal and the raster (colour by resolution, a recording tee); [`Phase`] marks let a
//! benchmark attribute the cost of each step.
//!
//! What a target is: pixels with a depth test ([`DepthTarget`]: the project's
//! [`Framebuffer`](crate::raster::Framebuffer) or any display as a
//! [`DisplayTarget`](crate::raster::DisplayTarget)), the shading table, and, for shadows, a shadow
//! map and the light's tables ([`Target::with_shadows`]). Nothing is allocated: a firmware keeps
//! them in statics.

// A build with no format feature has nothing to draw: the pipeline's steps go unused.
#![cfg_attr(not(any(feature = "trigrid", feature = "qsplat")), allow(dead_code))]

use core::fmt;

mod model;
mod options;

pub use model::{Model, ModelError};
pub use options::{FrameError, RenderOptions, DEFAULT_SHADOW_MAP_SIZE};

use crate::camera::{self, Camera, Vec3};
use crate::format::FileFormat;
use crate::raster::{DepthTarget, Kernel};
use crate::shade::{Material, ShadingTable, ShadowMode};
use crate::splat::{ColorSink, ShadedRaster, Stats};

#[cfg(feature = "qsplat")]
use crate::qs::{render_qs_colored, QSplat, QsFrame};
#[cfg(feature = "scene")]
use crate::scene::{Scene, SceneError, SceneStats};
#[cfg(feature = "shadows")]
use crate::shadow::{render_tg_shadowed, LightError, LightFrame, ShadowMap};
#[cfg(feature = "stream")]
use crate::stream::TgStream;
#[cfg(feature = "trigrid")]
use crate::tg::{render_tg, TgFrame, TriGrid};

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
/// use pocketsplat_core::raster::Framebuffer;
/// use pocketsplat_core::shade::ShadingTable;
/// use pocketsplat_core::{render, Model, RenderOptions, Target, View};
/// # use core::convert::Infallible;
/// # use embedded_graphics_core::{prelude::*, pixelcolor::Rgb565};
/// # /// A 320 × 240 display that counts the lit pixels it is sent.
/// # struct Landscape(usize);
/// # impl OriginDimensions for Landscape { fn size(&self) -> Size { Size::new(320, 240) } }
/// # impl DrawTarget for Landscape {
/// #     type Color = Rgb565;
/// #     type Error = Infallible;
/// #     fn draw_iter<I: IntoIterator<Item = Pixel<Rgb565>>>(&mut self, px: I) -> Result<(), Infallible> {
/// #         self.0 += px.into_iter().filter(|Pixel(_, c)| *c != Rgb565::BLACK).count();
/// #         Ok(())
/// #     }
/// # }
/// // Statics on a device; boxes here.
/// let (mut color, mut depth) = (Box::new([[0u16; 320]; 240]), Box::new([[0u16; 320]; 240]));
/// let mut table = ShadingTable::<1>::new();
/// let model = Model::open(include_bytes!("../../examples/data/trefoil.tg"))?;
///
/// let mut target = Target::new(Framebuffer::new(&mut color, &mut depth), &mut table);
/// let options = RenderOptions { cutoff_px: 2.0, ..RenderOptions::default() };
/// render(&model, &model.orbit(View::new(0.0, 30.0, 2.2)), &options, &mut target)?;
///
/// let mut display = Landscape(0);
/// target.pixels.draw(&mut display)?; // one fill_contiguous of 320 × 240 pixels
/// assert!(display.0 > 1000);
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
    /// use pocketsplat_core::raster::DisplayTarget;
    /// use pocketsplat_core::shade::{ShadingTable, ShadowMode};
    /// use pocketsplat_core::shadow::LightFrame;
    /// use pocketsplat_core::{render, Model, RenderOptions, Target, View};
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
    pub scene: Option<SceneStats>,
}

/// Why [`render`] cannot draw a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RenderError {
    /// The format's per-frame tables ([`FrameError`]: a bad camera or cutoff, ρ above 3).
    Frame(FrameError),
    /// Shadows asked of a model that has none (QSplat), of a build without the `shadows` feature,
    /// or of a target without a shadow map ([`Target::with_shadows`]).
    NoShadows(FileFormat, ShadowMode),
    /// A shadow map smaller than the options' side² (`need` depths, `given`), or a side the light
    /// cannot use.
    ShadowMap {
        /// Depths the map needs.
        need: u32,
        /// Depths the target has.
        given: u32,
    },
    /// The light cannot be set up (a point light inside the model's cube, a map side it cannot
    /// use, a position that is not finite).
    #[cfg(feature = "shadows")]
    Light(LightError),
    /// A scene could not be drawn (its frames, its slots, its shadow map).
    #[cfg(feature = "scene")]
    Scene(SceneError),
}

impl core::error::Error for RenderError {}

impl fmt::Display for RenderError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RenderError::Frame(e) => write!(f, "{e}"),
            RenderError::NoShadows(format, mode) => write!(
                f,
                "shadows {} of a {} model: shadows need a tri-grid (or a scene), the `shadows` \
                 feature and a target with a shadow map",
                mode.name(),
                format.name()
            ),
            RenderError::ShadowMap { need, given } => write!(
                f,
                "the shadow map needs {need} depths, the target has {given}"
            ),
            #[cfg(feature = "shadows")]
            RenderError::Light(e) => write!(f, "{e}"),
            #[cfg(feature = "scene")]
            RenderError::Scene(e) => write!(f, "{e}"),
        }
    }
}

impl From<FrameError> for RenderError {
    fn from(e: FrameError) -> Self {
        RenderError::Frame(e)
    }
}

#[cfg(feature = "scene")]
impl From<SceneError> for RenderError {
    fn from(e: SceneError) -> Self {
        RenderError::Scene(e)
    }
}

/// A frame's traversal, set up and ready to run into any sink: what a [`Layer`] receives.
pub struct Pass<'p, 'd> {
    kind: PassKind<'p, 'd>,
}

enum PassKind<'p, 'd> {
    #[cfg(feature = "trigrid")]
    TriGrid(&'p TriGrid<'p>, &'p TgFrame),
    #[cfg(feature = "shadows")]
    Shadowed {
        grid: &'p TriGrid<'p>,
        frame: &'p TgFrame,
        light: &'p LightFrame,
        map: &'p mut [u16],
        side: usize,
        mode: ShadowMode,
    },
    #[cfg(feature = "qsplat")]
    QSplat(&'p QSplat<'p>, &'p QsFrame),
    #[cfg(feature = "scene")]
    Scene {
        scene: &'p Scene<'p>,
        camera: &'p Camera,
        options: &'p RenderOptions,
        map: &'p mut [u16],
        #[cfg(feature = "shadows")]
        light: Option<&'p mut LightFrame>,
        stats: &'p mut Option<Result<SceneStats, SceneError>>,
    },
    #[cfg(feature = "stream")]
    Stream {
        stream: &'p mut TgStream<'d>,
        frame: &'p TgFrame,
        refined: bool,
    },
    #[allow(dead_code)] // A build without streaming or formats has no use for `'d`.
    Nothing(core::marker::PhantomData<(&'p (), &'d ())>),
}

impl Pass<'_, '_> {
    /// Runs the traversal into `sink`; returns its counts.
    pub fn run<S: ColorSink>(self, sink: &mut S) -> Stats {
        match self.kind {
            #[cfg(feature = "trigrid")]
            PassKind::TriGrid(grid, frame) => render_tg(grid, frame, sink),
            #[cfg(feature = "shadows")]
            PassKind::Shadowed {
                grid,
                frame,
                light,
                map,
                side,
                mode,
            } => {
                let mut map = ShadowMap::new(map, side);
                render_tg_shadowed(grid, frame, light, &mut map, mode, sink)
            }
            #[cfg(feature = "qsplat")]
            PassKind::QSplat(file, frame) => render_qs_colored(file, frame, sink),
            #[cfg(feature = "scene")]
            PassKind::Scene {
                scene,
                camera,
                options,
                map,
                #[cfg(feature = "shadows")]
                light,
                stats,
            } => {
                #[cfg(feature = "shadows")]
                let r = match light {
                    Some(light) => {
                        crate::scene::render_scene_in(scene, camera, options, map, light, sink)
                    }
                    None => crate::scene::render_scene(scene, camera, options, map, sink),
                };
                #[cfg(not(feature = "shadows"))]
                let r = crate::scene::render_scene(scene, camera, options, map, sink);
                let total = r.as_ref().map(|s| s.total).unwrap_or_default();
                *stats = Some(r);
                total
            }
            #[cfg(feature = "stream")]
            PassKind::Stream {
                stream,
                frame,
                refined,
            } => {
                if refined {
                    stream.render_pass(frame, sink)
                } else {
                    stream.render(frame, sink)
                }
            }
            PassKind::Nothing(_) => {
                let _ = sink;
                Stats::default()
            }
        }
    }
}

/// What a caller puts between a frame's traversal and the shaded raster: a sink of its own
/// wrapping the raster's (colour by resolution, a tee that records what is drawn). The default
/// runs the pass straight into the raster.
///
/// A layer that counts the splats of each level on their way to a 128 × 160 display:
///
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use pocketsplat_core::raster::DisplayTarget;
/// use pocketsplat_core::render::{render_marked, Layer, Pass, Phase};
/// use pocketsplat_core::shade::ShadingTable;
/// use pocketsplat_core::splat::{ColorSink, SampleSplat, SplatSink, Stats};
/// use pocketsplat_core::{Model, RenderOptions, Target, View};
/// # use core::convert::Infallible;
/// # use embedded_graphics_core::{prelude::*, pixelcolor::Rgb565};
/// # struct Panel(usize);
/// # impl OriginDimensions for Panel { fn size(&self) -> Size { Size::new(128, 160) } }
/// # impl DrawTarget for Panel {
/// #     type Color = Rgb565;
/// #     type Error = Infallible;
/// #     fn draw_iter<I: IntoIterator<Item = Pixel<Rgb565>>>(&mut self, px: I) -> Result<(), Infallible> {
/// #         self.0 += px.into_iter().count();
/// #         Ok(())
/// #     }
/// # }
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
///     fn run<S: ColorSink>(&mut self, pass: Pass<'_, '_>, sink: &mut S) -> Stats {
///         pass.run(&mut Counting(&mut self.0, sink))
///     }
/// }
///
/// let (mut panel, mut depth) = (Panel(0), vec![0u16; 128 * 160]);
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
/// assert!(panel.0 > 500);
/// # Ok(())
/// # }
/// ```
pub trait Layer {
    /// Runs `pass` into `sink`, or into a sink of the layer's in front of it.
    fn run<S: ColorSink>(&mut self, pass: Pass<'_, '_>, sink: &mut S) -> Stats {
        pass.run(sink)
    }
}

/// No layer: the traversal draws straight into the raster.
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
    let view_dir = camera::scale(camera.forward, -1.0);
    match model {
        #[cfg(feature = "trigrid")]
        Model::TriGrid(grid) => {
            let frame = TgFrame::new(
                grid.header(),
                &camera::Placement::IDENTITY,
                &camera,
                options,
            )?;
            let material = options.material;
            if options.shadows == ShadowMode::Off {
                let pass = PassKind::TriGrid(grid, &frame);
                return Ok(draw(
                    target,
                    material_table(material),
                    view_dir,
                    options,
                    pass,
                    layer,
                    &mut mark,
                ));
            }
            #[cfg(feature = "shadows")]
            if let Some((map, light)) = target.shadow.as_mut() {
                let side = options.shadow_map_size;
                set_light(light, grid, options, map.len())?;
                let (map, light): (&mut [u16], &LightFrame) = (map, light);
                // Borrowed apart from the pixels and the table, which the raster takes.
                let pass = PassKind::Shadowed {
                    grid,
                    frame: &frame,
                    light,
                    map,
                    side,
                    mode: options.shadows,
                };
                let (pixels, table) = (&mut target.pixels, &mut *target.table);
                return Ok(draw_parts(
                    pixels,
                    table,
                    material_table(material),
                    view_dir,
                    options,
                    pass,
                    layer,
                    &mut mark,
                ));
            }
            Err(RenderError::NoShadows(FileFormat::TriGrid, options.shadows))
        }
        #[cfg(feature = "qsplat")]
        Model::QSplat(file) => {
            if options.shadows != ShadowMode::Off {
                return Err(RenderError::NoShadows(FileFormat::QSplat, options.shadows));
            }
            let frame = QsFrame::new(file, &camera::Placement::IDENTITY, &camera, options)?;
            let material = model.material(options.material);
            let pass = PassKind::QSplat(file, &frame);
            Ok(draw(
                target,
                material_table(material),
                view_dir,
                options,
                pass,
                layer,
                &mut mark,
            ))
        }
        #[cfg(feature = "scene")]
        Model::Scene(scene) => scene_frame(scene, &camera, options, target, layer, &mut mark),
        #[cfg(not(any(feature = "trigrid", feature = "qsplat")))]
        Model::None(_, never) => {
            let _ = (camera, view_dir, options, layer, &mut mark, &target);
            match *never {}
        }
    }
}

/// [`render_marked`] of a scene pack's opened [`Scene`] (what [`Model::Scene`] holds), for a
/// caller that keeps the scene itself: `M` must be at least the pack's material slots.
///
/// # Errors
/// As [`render`].
#[cfg(feature = "scene")]
pub fn render_scene_marked<P: DepthTarget, L: Layer, const M: usize>(
    scene: &Scene<'_>,
    camera: &Camera,
    options: &RenderOptions,
    target: &mut Target<'_, P, M>,
    layer: &mut L,
    mut mark: impl FnMut(Phase),
) -> Result<Drawn, RenderError> {
    mark(Phase::Setup);
    let camera = camera.for_viewport(target.pixels.viewport());
    scene_frame(scene, &camera, options, target, layer, &mut mark)
}

/// A scene's frame after [`Phase::Setup`]: its slots' shading ([`Phase::Table`]), then every
/// object's traversal into the shared depth buffer.
#[cfg(feature = "scene")]
fn scene_frame<P: DepthTarget, L: Layer, const M: usize>(
    scene: &Scene<'_>,
    camera: &Camera,
    options: &RenderOptions,
    target: &mut Target<'_, P, M>,
    layer: &mut L,
    mark: &mut impl FnMut(Phase),
) -> Result<Drawn, RenderError> {
    mark(Phase::Table);
    let table_rebuilt = scene.update_table(target.table, camera, options.light_dir)?;
    let mut stats = None;
    #[cfg(feature = "shadows")]
    let (map, light): (&mut [u16], Option<&mut LightFrame>) = match target.shadow.as_mut() {
        Some((map, light)) => (&mut **map, Some(&mut **light)),
        None => (&mut [], None),
    };
    #[cfg(not(feature = "shadows"))]
    let map: &mut [u16] = &mut [];
    let pass = PassKind::Scene {
        scene,
        camera,
        options,
        map,
        #[cfg(feature = "shadows")]
        light,
        stats: &mut stats,
    };
    let (pixels, table) = (&mut target.pixels, &*target.table);
    clear_and_run(pixels, table, options, Pass { kind: pass }, layer, mark);
    // A layer that never ran the pass drew nothing: empty counts.
    let stats = stats.unwrap_or(Ok(SceneStats::default()))?;
    Ok(Drawn {
        stats: stats.total,
        table_rebuilt,
        shadows: stats.shadows,
        scene: Some(stats),
    })
}

/// A frame of a tri-grid streamed through a block cache ([`TgStream::render`]: it draws what is
/// resident and queues what is missing, [`TgStream::serve`] reads it), through the same camera,
/// shading table, clear and raster as [`render`]. `refined` draws the next pass of a refined frame
/// instead ([`TgStream::render_pass`]): the pixels are cleared only for the first pass (`first`,
/// which also starts the refined frame), so that the passes add up to the resident frame.
/// Without shadows: the streamed traversal takes no light pass.
///
/// # Errors
/// [`RenderError::Frame`] when the frame cannot be set up, [`RenderError::NoShadows`] when the
/// options ask for shadows.
#[cfg(feature = "stream")]
pub fn render_stream<P: DepthTarget, L: Layer, const M: usize>(
    stream: &mut TgStream<'_>,
    camera: &Camera,
    options: &RenderOptions,
    target: &mut Target<'_, P, M>,
    pass: StreamPass,
    layer: &mut L,
    mut mark: impl FnMut(Phase),
) -> Result<Drawn, RenderError> {
    mark(Phase::Setup);
    if options.shadows != ShadowMode::Off {
        return Err(RenderError::NoShadows(FileFormat::TriGrid, options.shadows));
    }
    let camera = camera.for_viewport(target.pixels.viewport());
    let frame = TgFrame::new(
        stream.header(),
        &camera::Placement::IDENTITY,
        &camera,
        options,
    )?;
    let view_dir = camera::scale(camera.forward, -1.0);
    mark(Phase::Table);
    let table_rebuilt = target
        .table
        .update(&[options.material; M], options.light_dir, view_dir);
    mark(Phase::Clear);
    let refined = pass != StreamPass::Frame;
    if pass != StreamPass::NextPass {
        target.pixels.clear(options.background);
    }
    if pass == StreamPass::FirstPass {
        stream.begin_refined();
    }
    let kind = PassKind::Stream {
        stream,
        frame: &frame,
        refined,
    };
    let stats = run_into(
        &mut target.pixels,
        target.table,
        options.kernel,
        Pass { kind },
        layer,
        &mut mark,
    );
    Ok(Drawn {
        stats,
        table_rebuilt,
        shadows: ShadowMode::Off,
        #[cfg(feature = "scene")]
        scene: None,
    })
}

/// Which frame of a stream [`render_stream`] draws.
#[cfg(feature = "stream")]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StreamPass {
    /// A whole frame from what is resident (coarser where blocks are absent).
    Frame,
    /// The first pass of a refined frame: clears and starts it.
    FirstPass,
    /// The next pass of the refined frame: draws over what the earlier passes drew.
    NextPass,
}

/// The shading table's materials: `material` in every slot.
fn material_table<const M: usize>(material: Material) -> impl FnOnce() -> [Material; M] {
    move || [material; M]
}

/// Sets the light's tables in `light` for `grid` (a directional light or a point light), checking
/// the map against the options.
#[cfg(feature = "shadows")]
fn set_light(
    light: &mut LightFrame,
    grid: &TriGrid<'_>,
    options: &RenderOptions,
    map_len: usize,
) -> Result<(), RenderError> {
    let side = options.shadow_map_size;
    let need = side.checked_mul(side).filter(|&n| n > 0);
    if need.is_none_or(|n| n > map_len) {
        return Err(RenderError::ShadowMap {
            need: need.map_or(u32::MAX, |n| n.min(u32::MAX as usize) as u32),
            given: map_len.min(u32::MAX as usize) as u32,
        });
    }
    let header = grid.header();
    let placement = camera::Placement::IDENTITY;
    match options.light_position {
        None => light.set(header, &placement, options.light_dir, side),
        Some(_) if options.shadows == ShadowMode::OnePass => {
            return Err(RenderError::NoShadows(
                FileFormat::TriGrid,
                ShadowMode::OnePass,
            ))
        }
        Some(at) => {
            *light = LightFrame::point(header, &placement, at, side).map_err(RenderError::Light)?
        }
    }
    Ok(())
}

/// The steps after a model's setup: the shading table for its material, then [`clear_and_run`].
fn draw<P: DepthTarget, L: Layer, const M: usize>(
    target: &mut Target<'_, P, M>,
    materials: impl FnOnce() -> [Material; M],
    view_dir: Vec3,
    options: &RenderOptions,
    pass: PassKind<'_, '_>,
    layer: &mut L,
    mark: &mut impl FnMut(Phase),
) -> Drawn {
    let (pixels, table) = (&mut target.pixels, &mut *target.table);
    draw_parts(
        pixels, table, materials, view_dir, options, pass, layer, mark,
    )
}

#[allow(clippy::too_many_arguments)]
fn draw_parts<P: DepthTarget, L: Layer, const M: usize>(
    pixels: &mut P,
    table: &mut ShadingTable<M>,
    materials: impl FnOnce() -> [Material; M],
    view_dir: Vec3,
    options: &RenderOptions,
    pass: PassKind<'_, '_>,
    layer: &mut L,
    mark: &mut impl FnMut(Phase),
) -> Drawn {
    mark(Phase::Table);
    let table_rebuilt = table.update(&materials(), options.light_dir, view_dir);
    let shadows = match pass {
        #[cfg(feature = "shadows")]
        PassKind::Shadowed { mode, .. } => mode,
        _ => ShadowMode::Off,
    };
    let stats = clear_and_run(pixels, table, options, Pass { kind: pass }, layer, mark);
    Drawn {
        stats,
        table_rebuilt,
        shadows,
        #[cfg(feature = "scene")]
        scene: None,
    }
}

/// [`Phase::Clear`], then the pass through `layer` into the shaded raster ([`Phase::Traverse`]),
/// then [`Phase::End`]: one code path for every format and for scenes.
fn clear_and_run<P: DepthTarget, L: Layer, const M: usize>(
    pixels: &mut P,
    table: &ShadingTable<M>,
    options: &RenderOptions,
    pass: Pass<'_, '_>,
    layer: &mut L,
    mark: &mut impl FnMut(Phase),
) -> Stats {
    mark(Phase::Clear);
    pixels.clear(options.background);
    run_into(pixels, table, options.kernel, pass, layer, mark)
}

/// [`Phase::Traverse`] and [`Phase::End`]: the pass through `layer` into the shaded raster.
fn run_into<P: DepthTarget, L: Layer, const M: usize>(
    pixels: &mut P,
    table: &ShadingTable<M>,
    kernel: Kernel,
    pass: Pass<'_, '_>,
    layer: &mut L,
    mark: &mut impl FnMut(Phase),
) -> Stats {
    mark(Phase::Traverse);
    let mut sink = ShadedRaster {
        fb: pixels,
        table,
        kernel,
    };
    let stats = layer.run(pass, &mut sink);
    mark(Phase::End);
    stats
}

#[cfg(all(test, feature = "trigrid"))]
mod tests;
