//! The standard views of a memory-resident model, rendered by one function that the firmware and
//! the host tests both call, so that an ARM frame and a host frame can only differ by what the two
//! machines compute, never by what the code asks them to (docs/ARCHITECTURE.md: same frames, same CRC).
//!
//! A [`Model`] is a tri-grid (`.tg`) or, with the `qsplat` feature, a QSplat file (`.qs`), told apart
//! by its magic at run time ([`Model::open`]). A frame is what `pocketsplat-sim`'s `render_tg_with`
//! (or `render_qs_with`) does with default settings (square kernel, default material and light, 45°
//! field of view, a [`SHADOW_MAP_SIZE`]² shadow map): the camera from the model's bounds, the
//! format's per-frame tables ([`TgFrame::new`] and the light's tables when shadows are on, or
//! [`QsFrame::new`]), [`ShadingTable::update`], clear, the format's traversal, CRC. Camera, light,
//! shading table and clearing are one code path for both formats; only the per-frame tables and the
//! traversal are the format's. The steps are separated by [`Phase`] marks, which the firmware turns
//! into calls of marker functions so that an instruction counter in QEMU can attribute the cost of
//! each step.
//!
//! Shadows need a tri-grid and the `shadows` feature (which turns on `pocketsplat-core/shadows`);
//! without it, [`SHADOW_MODES`] holds [`Shadows::Off`] only and no shadow code is linked (docs/ARCHITECTURE.md:
//! leave out what a scene does not need). A QSplat model renders [`Shadows::Off`] only
//! ([`Model::shadow_modes`]).

use core::fmt;

use pocketsplat_core::camera::{
    self, Camera, Placement, Sphere, View, DEFAULT_FOV_DEG, STANDARD_VIEWS,
};
#[cfg(feature = "qsplat")]
use pocketsplat_core::qs::{
    render_qs_colored, shading_material, QSplat, QsError, QsFrame, QsFrameError, QsRenderOptions,
};
use pocketsplat_core::raster::{Framebuffer, Kernel};
use pocketsplat_core::shade::{Material, ShadingTable, DEFAULT_LIGHT_AZ_EL, DEFAULT_MATERIAL};
#[cfg(feature = "shadows")]
use pocketsplat_core::shadow::{render_tg_shadowed, LightFrame, ShadowMap};
use pocketsplat_core::splat::{ShadedRaster, Stats};
#[cfg(feature = "stream")]
use pocketsplat_core::stream::TgStream;
use pocketsplat_core::tg::{
    render_tg, FrameError, Header, RenderOptions, TgError, TgFrame, TriGrid, Verify,
};

use crate::{HEIGHT, WIDTH};

/// LOD cutoffs the firmware renders each standard view at, pixels.
pub const CUTOFFS_PX: [u8; 4] = [1, 2, 4, 8];

/// Side of the shadow map, texels: the simulator's default (`pocketsplat render --shadows`), so that
/// the firmware's shadowed frames are the golden images' (256² × 2 bytes = 128 KB of RAM).
pub const SHADOW_MAP_SIZE: usize = 256;

/// The shadow algorithm of a frame: the core's [`ShadowMode`](pocketsplat_core::shade::ShadowMode),
/// always compiled, so that a build without the `shadows` feature still names its frames.
pub use pocketsplat_core::shade::ShadowMode as Shadows;

/// The shadow modes this build renders: all three with the `shadows` feature, `off` without.
#[cfg(feature = "shadows")]
pub const SHADOW_MODES: &[Shadows] = &Shadows::ALL;
/// The shadow modes this build renders: all three with the `shadows` feature, `off` without.
#[cfg(not(feature = "shadows"))]
pub const SHADOW_MODES: &[Shadows] = &[Shadows::Off];

/// One frame of the sequence: a standard view, a cutoff and a shadow mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FrameSpec {
    /// Index into [`STANDARD_VIEWS`].
    pub view: usize,
    /// LOD cutoff, pixels.
    pub cutoff_px: u8,
    /// Shadow algorithm.
    pub shadows: Shadows,
}

impl FrameSpec {
    /// The view's name (`std`, `front`, `close`, `far`).
    pub fn view_name(&self) -> &'static str {
        STANDARD_VIEWS[self.view].0
    }
}

/// The frames the firmware renders of a tri-grid, in order: each standard view, in each mode of
/// [`SHADOW_MODES`], at each cutoff of [`CUTOFFS_PX`] ([`frame_specs_for`] of [`SHADOW_MODES`]; for
/// any model, [`Model::frame_specs`]).
pub fn frame_specs() -> impl Iterator<Item = FrameSpec> {
    frame_specs_for(SHADOW_MODES)
}

/// The frame sequence of a build rendering `modes`. The light is fixed, so the shading table changes
/// only with the view, at its first frame.
pub fn frame_specs_for(modes: &'static [Shadows]) -> impl Iterator<Item = FrameSpec> {
    (0..STANDARD_VIEWS.len()).flat_map(move |view| {
        modes.iter().flat_map(move |&shadows| {
            CUTOFFS_PX.iter().map(move |&cutoff_px| FrameSpec {
                view,
                cutoff_px,
                shadows,
            })
        })
    })
}

/// The steps of a frame, in order. [`render_standard_view`] reports the start of each (and
/// [`Phase::End`] after the traversal) to its `mark` callback.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Phase {
    /// Camera and per-frame integer tables ([`TgFrame::new`], and the light's with shadows; soft
    /// floats on an FPU-less core).
    Setup,
    /// The shading table ([`ShadingTable::update`]; rebuilds only when the view direction changes).
    Table,
    /// Clearing colour and depth.
    Clear,
    /// Traversal and raster ([`render_tg`]; with two-pass shadows, the light's pass first).
    Traverse,
    /// The frame is drawn (the CRC that follows is not part of the frame).
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

/// Where a frame is drawn: colour and depth rows, the shading table and, with shadows, the shadow
/// map (statics on the device, the heap on the host).
pub struct Targets<'a> {
    /// RGB565 rows.
    pub color: &'a mut [[u16; WIDTH]; HEIGHT],
    /// Depth rows.
    pub depth: &'a mut [[u16; WIDTH]; HEIGHT],
    /// The shading table, kept between frames (rebuilt only when the view direction changes).
    pub table: &'a mut ShadingTable<1>,
    /// Shadow-map depths, [`SHADOW_MAP_SIZE`]² of them.
    #[cfg(feature = "shadows")]
    pub shadow: &'a mut [u16; SHADOW_MAP_SIZE * SHADOW_MAP_SIZE],
    /// Where a shadowed frame keeps the light's tables (17 KB, most of it the per-normal and
    /// per-level look-ups of the shadow test), set in place ([`LightFrame::set`]): beside the map
    /// rather than on the stack, which would otherwise hold them more than once on their way into
    /// the frame. [`LightFrame::UNSET`] to start with.
    #[cfg(feature = "shadows")]
    pub light: &'a mut LightFrame,
}

/// Where a streamed frame is drawn ([`render_stream_view`], [`render_stream_pass`]): colour and
/// depth rows and the shading table, without the shadow map (the streamed traversal takes no light
/// pass). The same fields whatever this crate's features, so that a board crate can build it.
#[cfg(feature = "stream")]
pub struct StreamTargets<'a> {
    /// RGB565 rows.
    pub color: &'a mut [[u16; WIDTH]; HEIGHT],
    /// Depth rows.
    pub depth: &'a mut [[u16; WIDTH]; HEIGHT],
    /// The shading table, kept between frames.
    pub table: &'a mut ShadingTable<1>,
}

#[cfg(feature = "stream")]
impl Targets<'_> {
    /// The buffers a streamed frame draws into, borrowed from these.
    pub fn streamed(&mut self) -> StreamTargets<'_> {
        StreamTargets {
            color: self.color,
            depth: self.depth,
            table: self.table,
        }
    }
}

/// Where [`Frame::new`] puts the light's tables: [`Targets::light`], or nothing without shadows.
#[cfg(feature = "shadows")]
type LightSlot<'s> = &'s mut LightFrame;
#[cfg(not(feature = "shadows"))]
type LightSlot<'s> = core::marker::PhantomData<&'s ()>;

/// What one frame did: the line the firmware prints, `frame <view> cutoff <px> shadows <mode> crc
/// 0x… splats N nodes N` (for two-pass shadows, `nodes` counts both passes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FrameReport {
    /// Which frame.
    pub spec: FrameSpec,
    /// CRC-32 of the colour buffer ([`Framebuffer::crc`]).
    pub crc: u32,
    /// Traversal counts.
    pub stats: Stats,
    /// Whether the shading table was rebuilt for this frame.
    pub table_rebuilt: bool,
}

impl fmt::Display for FrameReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "frame {} cutoff {} shadows {} crc {:#010x} ",
            self.spec.view_name(),
            self.spec.cutoff_px,
            self.spec.shadows.name(),
            self.crc,
        )?;
        write_counts(f, &self.stats)
    }
}

/// Whether this build counts splats and nodes (the `stats` feature): a frame line then carries
/// them; without it the traversal keeps no per-node counts and the line says `splats - nodes -`.
pub const COUNTED: bool = cfg!(feature = "stats");

/// `splats N nodes N` of a frame line, or `splats - nodes -` in a build that does not count.
pub(crate) fn write_counts(f: &mut fmt::Formatter<'_>, stats: &Stats) -> fmt::Result {
    if COUNTED {
        write!(f, "splats {} nodes {}", stats.splats, stats.nodes_visited)
    } else {
        write!(f, "splats - nodes -")
    }
}

/// A frame line as printed by the firmware, read back (tests and `arm-bench`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameLine<'a> {
    /// View name.
    pub view: &'a str,
    /// Cutoff, pixels.
    pub cutoff_px: u8,
    /// Shadow mode.
    pub shadows: Shadows,
    /// Frame CRC.
    pub crc: u32,
    /// Splats drawn (`None` from a build without counts, [`COUNTED`]).
    pub splats: Option<u32>,
    /// Nodes visited (`None` from a build without counts).
    pub nodes: Option<u32>,
}

impl<'a> FrameLine<'a> {
    /// Parses `frame <view> cutoff <px> shadows <mode> crc 0x… splats N nodes N`; `None` for any
    /// other line.
    pub fn parse(line: &'a str) -> Option<Self> {
        let mut w = line.split_ascii_whitespace();
        let mut after = |key: &str| -> Option<&'a str> { (w.next()? == key).then(|| w.next())? };
        let view = after("frame")?;
        let cutoff_px = after("cutoff")?.parse().ok()?;
        let shadows = Shadows::from_name(after("shadows")?)?;
        let crc = u32::from_str_radix(after("crc")?.strip_prefix("0x")?, 16).ok()?;
        let count = |s: &str| match s {
            "-" => Some(None),
            n => n.parse().ok().map(Some),
        };
        let splats = count(after("splats")?)?;
        let nodes = count(after("nodes")?)?;
        if w.next().is_some() {
            return None;
        }
        Some(Self {
            view,
            cutoff_px,
            shadows,
            crc,
            splats,
            nodes,
        })
    }

    /// The frame this line reports, or `None` when its view is not a standard view.
    pub fn spec(&self) -> Option<FrameSpec> {
        let view = STANDARD_VIEWS.iter().position(|(n, _)| *n == self.view)?;
        Some(FrameSpec {
            view,
            cutoff_px: self.cutoff_px,
            shadows: self.shadows,
        })
    }

    /// Whether this line reports the same frame, CRC and counts (where it has them) as `report`.
    pub fn matches(&self, report: &FrameReport) -> bool {
        self.spec() == Some(report.spec)
            && self.crc == report.crc
            && self.splats.is_none_or(|n| n == report.stats.splats)
            && self.nodes.is_none_or(|n| n == report.stats.nodes_visited)
    }
}

/// How every QSplat file starts (`QSplat11` for version 11; the core's `format` module).
pub const QSPLAT_MAGIC_PREFIX: [u8; 6] = pocketsplat_core::format::QS_MAGIC_PREFIX;

/// The file formats a [`Model`] can be.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Format {
    /// Tri-grid (`.tg`).
    TriGrid,
    /// QSplat 1.0 (`.qs`).
    QSplat,
}

impl Format {
    /// Both formats.
    pub const ALL: [Format; 2] = [Format::TriGrid, Format::QSplat];

    /// `tg` or `qsplat` (the names of `pocketsplat bake --format`).
    pub fn name(self) -> &'static str {
        match self {
            Format::TriGrid => "tg",
            Format::QSplat => "qsplat",
        }
    }

    /// The format called `name`.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|f| f.name() == name)
    }

    /// The format of a file from its first bytes: [`Format::QSplat`] when they are
    /// [`QSPLAT_MAGIC_PREFIX`], otherwise [`Format::TriGrid`] (whose reader checks its own magic).
    pub fn of(bytes: &[u8]) -> Self {
        match pocketsplat_core::format::FileFormat::sniff(bytes) {
            Some(pocketsplat_core::format::FileFormat::QSplat) => Format::QSplat,
            _ => Format::TriGrid,
        }
    }
}

/// A validated, memory-resident model: what the views draw.
// Unboxed: there is no heap, and a firmware holds one model (a tri-grid's header and level
// directory are its largest part, about 300 bytes).
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug)]
pub enum Model<'a> {
    /// A tri-grid.
    TriGrid(TriGrid<'a>),
    /// A QSplat file.
    #[cfg(feature = "qsplat")]
    QSplat(QSplat<'a>),
}

impl<'a> From<TriGrid<'a>> for Model<'a> {
    fn from(grid: TriGrid<'a>) -> Self {
        Model::TriGrid(grid)
    }
}

#[cfg(feature = "qsplat")]
impl<'a> From<QSplat<'a>> for Model<'a> {
    fn from(file: QSplat<'a>) -> Self {
        Model::QSplat(file)
    }
}

impl<'a> Model<'a> {
    /// Opens `bytes` in the format its magic names ([`Format::of`]); `verify` is how much of a
    /// tri-grid to check (a QSplat file is always checked whole: its reader has one level).
    ///
    /// # Errors
    /// When the file is not a valid model of its format, or is a QSplat file and this build has no
    /// `qsplat` feature.
    pub fn open(bytes: &'a [u8], verify: Verify) -> Result<Self, ModelError> {
        match Format::of(bytes) {
            Format::TriGrid => TriGrid::open(bytes, verify)
                .map(Model::TriGrid)
                .map_err(ModelError::TriGrid),
            #[cfg(feature = "qsplat")]
            Format::QSplat => QSplat::open(bytes)
                .map(Model::QSplat)
                .map_err(ModelError::QSplat),
            #[cfg(not(feature = "qsplat"))]
            Format::QSplat => Err(ModelError::QSplatNotBuilt),
        }
    }

    /// The model's format.
    pub fn format(&self) -> Format {
        match self {
            Model::TriGrid(_) => Format::TriGrid,
            #[cfg(feature = "qsplat")]
            Model::QSplat(_) => Format::QSplat,
        }
    }

    /// The model's bounding box (min, max corners), which frames the standard views.
    pub fn bounds(&self) -> [[f32; 3]; 2] {
        match self {
            Model::TriGrid(grid) => grid.header().bounds,
            #[cfg(feature = "qsplat")]
            Model::QSplat(file) => file.bounds(),
        }
    }

    /// The shadow modes this build renders the model in: [`SHADOW_MODES`] for a tri-grid,
    /// [`Shadows::Off`] for a QSplat file (shadows are tri-grid only).
    pub fn shadow_modes(&self) -> &'static [Shadows] {
        match self {
            Model::TriGrid(_) => SHADOW_MODES,
            #[cfg(feature = "qsplat")]
            Model::QSplat(_) => &[Shadows::Off],
        }
    }

    /// The frames the firmware renders of this model, in order ([`frame_specs_for`] of
    /// [`Model::shadow_modes`]).
    pub fn frame_specs(&self) -> impl Iterator<Item = FrameSpec> {
        frame_specs_for(self.shadow_modes())
    }

    /// The material every sample is shaded with: the default, in white for a coloured QSplat file
    /// (`pocketsplat render`'s rule, [`shading_material`]).
    pub fn material(&self) -> Material {
        match self {
            Model::TriGrid(_) => DEFAULT_MATERIAL,
            #[cfg(feature = "qsplat")]
            Model::QSplat(file) => shading_material(file, DEFAULT_MATERIAL),
        }
    }
}

/// Why a model cannot be opened.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ModelError {
    /// Not a valid tri-grid.
    TriGrid(TgError),
    /// Not a valid QSplat file.
    #[cfg(feature = "qsplat")]
    QSplat(QsError),
    /// A QSplat file, and this build has no `qsplat` feature.
    QSplatNotBuilt,
}

impl core::error::Error for ModelError {}

impl fmt::Display for ModelError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ModelError::TriGrid(e) => write!(f, "tri-grid: {e}"),
            #[cfg(feature = "qsplat")]
            ModelError::QSplat(e) => write!(f, "QSplat: {e}"),
            ModelError::QSplatNotBuilt => {
                write!(f, "a QSplat file: this build has no `qsplat` feature")
            }
        }
    }
}

/// Why a frame cannot be set up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ViewError {
    /// The tri-grid's frame ([`FrameError`]: ρ above 3, degenerate bounds, a cutoff that is not
    /// positive).
    TriGrid(FrameError),
    /// The QSplat file's frame ([`QsFrameError`]: degenerate bounds, a cutoff that is not positive).
    #[cfg(feature = "qsplat")]
    QSplat(QsFrameError),
    /// Shadows asked of a QSplat model (shadows are tri-grid only), or of a build without the
    /// `shadows` feature.
    NoShadows(Format, Shadows),
}

impl core::error::Error for ViewError {}

impl fmt::Display for ViewError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ViewError::TriGrid(e) => write!(f, "{e}"),
            #[cfg(feature = "qsplat")]
            ViewError::QSplat(e) => write!(f, "{e}"),
            ViewError::NoShadows(format, shadows) => write!(
                f,
                "shadows {} of a {} model: shadows need a tri-grid and the `shadows` feature",
                shadows.name(),
                format.name()
            ),
        }
    }
}

/// Renders frame `spec` of `model` into `targets` and checksums it ([`render_view`] of the standard
/// view at the spec's cutoff, then the CRC of the colour buffer, after [`Phase::End`]).
///
/// # Errors
/// When the frame cannot be set up ([`ViewError`]), e.g. shadows of a QSplat model.
pub fn render_standard_view(
    model: &Model<'_>,
    spec: FrameSpec,
    targets: &mut Targets<'_>,
    mark: impl FnMut(Phase),
) -> Result<FrameReport, ViewError> {
    let (_, view) = STANDARD_VIEWS[spec.view];
    let frame = render_view(
        model,
        view,
        f32::from(spec.cutoff_px),
        spec.shadows,
        targets,
        mark,
    )?;
    Ok(FrameReport {
        spec,
        crc: Framebuffer::new(targets.color, targets.depth).crc(),
        stats: frame.stats,
        table_rebuilt: frame.table_rebuilt,
    })
}

/// What [`render_view`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Drawn {
    /// Traversal counts.
    pub stats: Stats,
    /// Whether the shading table was rebuilt for this frame.
    pub table_rebuilt: bool,
}

/// The splat kernel of every frame of a model (`pocketsplat render`'s default; a scene's is its
/// `SceneOptions`'). Public so that benchmarks can say which kernel their frames were drawn with.
pub const KERNEL: Kernel = Kernel::Square;

/// Renders `model` seen from the orbit `view` at `cutoff_px` into `targets` with the defaults of
/// `pocketsplat render` (square kernel, default material and light, 45° field of view). `mark` is
/// called at the start of each [`Phase`] and at [`Phase::End`]. The firmware's standard views and a
/// handheld's interactive camera draw through this one function, for either format.
///
/// # Errors
/// When the frame cannot be set up ([`ViewError`]: ρ above 3, degenerate bounds, a cutoff that is
/// not positive, shadows of a QSplat model or from a build without the `shadows` feature).
pub fn render_view(
    model: &Model<'_>,
    view: View,
    cutoff_px: f32,
    shadows: Shadows,
    targets: &mut Targets<'_>,
    mut mark: impl FnMut(Phase),
) -> Result<Drawn, ViewError> {
    mark(Phase::Setup);
    let (cam, light) = view_camera(model.bounds(), view);
    #[cfg(feature = "shadows")]
    let slot = &mut *targets.light;
    #[cfg(not(feature = "shadows"))]
    let slot = core::marker::PhantomData;
    let frame = Frame::new(model, &cam, cutoff_px, shadows, light, slot)?;
    #[cfg(feature = "shadows")]
    let shadow = &mut *targets.shadow;
    let canvas = Canvas {
        color: targets.color,
        depth: targets.depth,
        table: targets.table,
    };
    Ok(canvas.draw(
        model.material(),
        &cam,
        light,
        &mut mark,
        |sink| match &frame {
            Frame::TriGrid(grid, f) => render_tg(grid, f, sink),
            #[cfg(feature = "shadows")]
            Frame::TriGridShadowed(grid, f, light, mode) => {
                let mut map = ShadowMap::new(shadow, SHADOW_MAP_SIZE);
                render_tg_shadowed(grid, f, light, &mut map, *mode, sink)
            }
            #[cfg(feature = "qsplat")]
            Frame::QSplat(file, f) => render_qs_colored(file, f, sink),
        },
    ))
}

/// [`render_view`] of a tri-grid streamed through a block cache (`stream` feature): the same
/// camera, shading table, clear and splat sink, with [`TgStream::render`] as the traversal (it
/// draws what is resident and queues what is missing; [`TgStream::serve`] reads it). Without
/// shadows: the streamed traversal takes no light pass yet.
///
/// # Errors
/// When the frame cannot be set up ([`ViewError::TriGrid`]).
#[cfg(feature = "stream")]
pub fn render_stream_view(
    stream: &mut TgStream<'_>,
    view: View,
    cutoff_px: f32,
    targets: &mut StreamTargets<'_>,
    mut mark: impl FnMut(Phase),
) -> Result<Drawn, ViewError> {
    mark(Phase::Setup);
    let (cam, light) = view_camera(stream.header().bounds, view);
    let frame = tg_frame(stream.header(), &cam, cutoff_px)?;
    let canvas = Canvas {
        color: targets.color,
        depth: targets.depth,
        table: targets.table,
    };
    Ok(
        canvas.draw(DEFAULT_MATERIAL, &cam, light, &mut mark, |sink| {
            stream.render(&frame, sink)
        }),
    )
}

/// The next pass of a refined frame of `stream` ([`TgStream::render_pass`]) at `view` and
/// `cutoff_px` into `targets`: as [`render_stream_view`], but the colour and depth buffers are
/// cleared only for the first pass (`first`, which also starts the refined frame), so that the
/// passes add up to the frame the resident file gives.
///
/// # Errors
/// When the frame cannot be set up ([`ViewError::TriGrid`]).
#[cfg(feature = "stream")]
pub fn render_stream_pass(
    stream: &mut TgStream<'_>,
    view: View,
    cutoff_px: f32,
    targets: &mut StreamTargets<'_>,
    first: bool,
    mut mark: impl FnMut(Phase),
) -> Result<Drawn, ViewError> {
    mark(Phase::Setup);
    let (cam, light) = view_camera(stream.header().bounds, view);
    let frame = tg_frame(stream.header(), &cam, cutoff_px)?;
    mark(Phase::Table);
    let table_rebuilt =
        targets
            .table
            .update(&[DEFAULT_MATERIAL], light, camera::scale(cam.forward, -1.0));
    mark(Phase::Clear);
    let mut fb = Framebuffer::new(targets.color, targets.depth);
    if first {
        fb.clear(0);
        stream.begin_refined();
    }
    mark(Phase::Traverse);
    let mut sink = ShadedRaster {
        fb: &mut fb,
        table: targets.table,
        kernel: KERNEL,
    };
    let stats = stream.render_pass(&frame, &mut sink);
    mark(Phase::End);
    Ok(Drawn {
        stats,
        table_rebuilt,
    })
}

/// The camera of `view` around a model with `bounds`, and the light (a unit vector): the start of
/// every frame's setup.
fn view_camera(bounds: [[f32; 3]; 2], view: View) -> (Camera, camera::Vec3) {
    let cam = Camera::orbit(Sphere::from_bounds(bounds), view, DEFAULT_FOV_DEG);
    let light = camera::direction(DEFAULT_LIGHT_AZ_EL.0, DEFAULT_LIGHT_AZ_EL.1);
    (cam, light)
}

/// A tri-grid's per-frame tables for `cam` at `cutoff_px`, resident or streamed alike.
fn tg_frame(header: &Header, cam: &Camera, cutoff_px: f32) -> Result<TgFrame, ViewError> {
    let opts = RenderOptions {
        cutoff_px,
        kernel: KERNEL,
        ..RenderOptions::default()
    };
    TgFrame::new(header, &Placement::IDENTITY, cam, &opts).map_err(ViewError::TriGrid)
}

/// The buffers a frame draws into (the shadow map and light tables stay with the traversal).
struct Canvas<'t> {
    color: &'t mut [[u16; WIDTH]; HEIGHT],
    depth: &'t mut [[u16; WIDTH]; HEIGHT],
    table: &'t mut ShadingTable<1>,
}

/// The splat sink every frame draws through.
type Sink<'f, 'b, 't> = ShadedRaster<'f, 'b, 't, WIDTH, HEIGHT, 1>;

impl Canvas<'_> {
    /// The steps after setup that every frame shares, whatever draws its splats: the shading table
    /// for `material` under `light` seen from `cam` ([`Phase::Table`]), clearing ([`Phase::Clear`]),
    /// then `traverse` into the shaded raster ([`Phase::Traverse`]) and [`Phase::End`].
    fn draw(
        self,
        material: Material,
        cam: &Camera,
        light: camera::Vec3,
        mark: &mut impl FnMut(Phase),
        traverse: impl FnOnce(&mut Sink<'_, '_, '_>) -> Stats,
    ) -> Drawn {
        mark(Phase::Table);
        let table_rebuilt = self
            .table
            .update(&[material], light, camera::scale(cam.forward, -1.0));

        let stats = draw_shaded(self.color, self.depth, self.table, KERNEL, mark, traverse);
        Drawn {
            stats,
            table_rebuilt,
        }
    }
}

/// The steps of a frame after its table: [`Phase::Clear`] (colour and depth), [`Phase::Traverse`]
/// (`traverse` into a raster shading through `table` with `kernel`), [`Phase::End`]. One code path
/// for every format and for scene packs ([`crate::scene`]), whatever their table's slot count `M`.
pub(crate) fn draw_shaded<const M: usize, R>(
    color: &mut [[u16; WIDTH]; HEIGHT],
    depth: &mut [[u16; WIDTH]; HEIGHT],
    table: &ShadingTable<M>,
    kernel: Kernel,
    mark: &mut impl FnMut(Phase),
    traverse: impl FnOnce(&mut ShadedRaster<'_, '_, '_, WIDTH, HEIGHT, M>) -> R,
) -> R {
    mark(Phase::Clear);
    let mut fb = Framebuffer::new(color, depth);
    fb.clear(0);

    mark(Phase::Traverse);
    let mut sink = ShadedRaster {
        fb: &mut fb,
        table,
        kernel,
    };
    let drawn = traverse(&mut sink);
    mark(Phase::End);
    drawn
}

/// A frame set up for its model's traversal: the format's per-frame integer tables.
// Unboxed: there is no heap; one lives on the stack for one frame, as the tables always did.
#[allow(clippy::large_enum_variant)]
enum Frame<'m, 'a> {
    /// A tri-grid without shadows.
    TriGrid(&'m TriGrid<'a>, TgFrame),
    /// A tri-grid with shadows: the light's tables too.
    #[cfg(feature = "shadows")]
    TriGridShadowed(&'m TriGrid<'a>, TgFrame, &'m LightFrame, Shadows),
    /// A QSplat file.
    #[cfg(feature = "qsplat")]
    QSplat(&'m QSplat<'a>, QsFrame),
}

impl<'m, 'a> Frame<'m, 'a> {
    /// Setup (floats allowed): the tables of `model` for `cam` at `cutoff_px`, and of the light
    /// from `light` (a unit vector) into `slot` when `shadows` is on.
    fn new(
        model: &'m Model<'a>,
        cam: &Camera,
        cutoff_px: f32,
        shadows: Shadows,
        light: camera::Vec3,
        slot: LightSlot<'m>,
    ) -> Result<Self, ViewError> {
        match model {
            Model::TriGrid(grid) => {
                let frame = tg_frame(grid.header(), cam, cutoff_px)?;
                match shadows {
                    Shadows::Off => Ok(Frame::TriGrid(grid, frame)),
                    #[cfg(feature = "shadows")]
                    mode => {
                        slot.set(grid.header(), &Placement::IDENTITY, light, SHADOW_MAP_SIZE);
                        Ok(Frame::TriGridShadowed(grid, frame, slot, mode))
                    }
                    #[cfg(not(feature = "shadows"))]
                    mode => {
                        let _ = (light, slot);
                        Err(ViewError::NoShadows(Format::TriGrid, mode))
                    }
                }
            }
            #[cfg(feature = "qsplat")]
            Model::QSplat(file) => {
                if shadows != Shadows::Off {
                    return Err(ViewError::NoShadows(Format::QSplat, shadows));
                }
                let opts = QsRenderOptions {
                    cutoff_px,
                    kernel: KERNEL,
                    backface_culling: true,
                };
                let frame = QsFrame::new(file, &Placement::IDENTITY, cam, &opts)
                    .map_err(ViewError::QSplat)?;
                Ok(Frame::QSplat(file, frame))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_lines_round_trip() {
        let report = FrameReport {
            spec: FrameSpec {
                view: 2,
                cutoff_px: 4,
                shadows: Shadows::OnePass,
            },
            crc: 0x00ab_cdef,
            stats: Stats {
                splats: 12,
                nodes_visited: 345,
                ..Stats::default()
            },
            table_rebuilt: true,
        };
        let line = report.to_string();
        let counts = if COUNTED {
            "splats 12 nodes 345"
        } else {
            "splats - nodes -"
        };
        assert_eq!(
            line,
            format!("frame close cutoff 4 shadows one-pass crc 0x00abcdef {counts}")
        );
        let counted = FrameLine::parse(
            "frame close cutoff 4 shadows one-pass crc 0x00abcdef splats 12 nodes 345",
        )
        .unwrap();
        assert_eq!((counted.splats, counted.nodes), (Some(12), Some(345)));
        // A line's counts, when it has them, must be the report's.
        assert!(counted.matches(&report));
        let miscounted = FrameLine::parse(
            "frame close cutoff 4 shadows one-pass crc 0x00abcdef splats 13 nodes 345",
        )
        .unwrap();
        assert!(!miscounted.matches(&report));
        let parsed = FrameLine::parse(&line).unwrap();
        assert!(parsed.matches(&report));
        assert_eq!(parsed.spec(), Some(report.spec));
        let other = FrameReport { crc: 1, ..report };
        assert!(!parsed.matches(&other));
        assert_eq!(FrameLine::parse("frame 0 crc 0x12345678"), None);
        assert_eq!(FrameLine::parse("ram_bytes 12"), None);
        assert_eq!(FrameLine::parse(&format!("{line} extra")), None);
        let bad_mode = line.replace("one-pass", "three-pass");
        assert_eq!(FrameLine::parse(&bad_mode), None);
        let side = line.replace("close", "side");
        let bad_view = FrameLine::parse(&side).unwrap();
        assert_eq!(bad_view.spec(), None);
    }

    #[test]
    fn each_view_in_each_mode_at_each_cutoff() {
        let specs: Vec<_> = frame_specs_for(&Shadows::ALL).collect();
        assert_eq!(specs.len(), STANDARD_VIEWS.len() * 3 * CUTOFFS_PX.len());
        assert_eq!(specs[0].view_name(), "std");
        assert_eq!((specs[0].cutoff_px, specs[0].shadows), (1, Shadows::Off));
        assert_eq!(specs[CUTOFFS_PX.len()].shadows, Shadows::OnePass);
        assert_eq!(specs[3 * CUTOFFS_PX.len()].view_name(), "front");
        assert_eq!(frame_specs().count(), 4 * SHADOW_MODES.len() * 4);
        for m in Shadows::ALL {
            assert_eq!(Shadows::from_name(m.name()), Some(m));
        }
    }

    #[test]
    fn the_magic_tells_the_format_and_bad_files_are_errors() {
        assert_eq!(Format::of(b"QSplat11\0\0"), Format::QSplat);
        assert_eq!(Format::of(b"QSpla"), Format::TriGrid);
        assert_eq!(Format::of(b""), Format::TriGrid);
        for f in Format::ALL {
            assert_eq!(Format::from_name(f.name()), Some(f));
        }
        let junk = [0u8; 64];
        assert!(matches!(
            Model::open(&junk, Verify::Full),
            Err(ModelError::TriGrid(_))
        ));
        let mut qs = [0u8; 64];
        qs[..8].copy_from_slice(b"QSplat11");
        let err = Model::open(&qs, Verify::Full).unwrap_err();
        #[cfg(feature = "qsplat")]
        assert!(matches!(err, ModelError::QSplat(_)), "{err:?}");
        #[cfg(not(feature = "qsplat"))]
        assert_eq!(err, ModelError::QSplatNotBuilt);
        assert!(!err.to_string().is_empty());
    }
}
