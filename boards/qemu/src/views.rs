//! The standard views of a memory-resident model, rendered by one function that the firmware and
//! the host tests both call, so that an ARM frame and a host frame can only differ by what the two
//! machines compute, never by what the code asks them to (docs/ARCHITECTURE.md: same frames, same CRC).
//!
//! A [`Model`] is the core's: a tri-grid (`.tg`) or, with the `qsplat` feature, a QSplat file
//! (`.qs`), told apart by its magic at run time ([`Model::open_with`]). A frame is the core's
//! [`render_marked`] with the defaults of `pocketsplat render` (square kernel, default material and
//! light, 45° field of view, a [`SHADOW_MAP_SIZE`]² shadow map) into the firmware's static buffers
//! ([`Targets`]), then the CRC. The steps are separated by [`Phase`] marks, which the firmware turns
//! into calls of marker functions so that an instruction counter in QEMU can attribute the cost of
//! each step.
//!
//! Shadows need a tri-grid and the `shadows` feature (which turns on `pocketsplat-core/shadows`);
//! without it, [`SHADOW_MODES`] holds [`Shadows::Off`] only and no shadow code is linked (docs/ARCHITECTURE.md:
//! leave out what a scene does not need). A QSplat model renders [`Shadows::Off`] only
//! ([`Model::shadow_modes`]).

use core::fmt;

use pocketsplat_core::camera::{View, STANDARD_VIEWS};
use pocketsplat_core::raster::{Framebuffer, Kernel};
use pocketsplat_core::render::{render_marked, Direct, RenderOptions, Target};
#[cfg(feature = "stream")]
use pocketsplat_core::render::{render_stream, StreamPass};
pub use pocketsplat_core::render::{Drawn, Model, ModelError, Phase, RenderError};
use pocketsplat_core::shade::ShadingTable;
#[cfg(feature = "shadows")]
use pocketsplat_core::shadow::LightFrame;
use pocketsplat_core::splat::Stats;
#[cfg(feature = "stream")]
use pocketsplat_core::stream::TgStream;
#[cfg(all(feature = "stream", feature = "qsplat"))]
use pocketsplat_core::{render::render_qs_stream, stream::QsStream};

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
/// any model, [`model_frame_specs`]).
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

/// Where a frame is drawn: colour and depth rows, the shading table and, with shadows, the shadow
/// map (statics on the device, the heap on the host). The panel's size by default ([`WIDTH`] ×
/// [`HEIGHT`], a build-time choice); the frame's projection follows whatever size the rows have.
pub struct Targets<'a, const W: usize = WIDTH, const H: usize = HEIGHT> {
    /// RGB565 rows.
    pub color: &'a mut [[u16; W]; H],
    /// Depth rows.
    pub depth: &'a mut [[u16; W]; H],
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

/// The frames the firmware renders of `model`, in order ([`frame_specs_for`] of
/// [`Model::shadow_modes`]).
pub fn model_frame_specs(model: &Model<'_>) -> impl Iterator<Item = FrameSpec> {
    frame_specs_for(model.shadow_modes())
}

/// Renders frame `spec` of `model` into `targets` and checksums it ([`render_view`] of the standard
/// view at the spec's cutoff, then the CRC of the colour buffer, after [`Phase::End`]).
///
/// # Errors
/// When the frame cannot be set up ([`RenderError`]), e.g. shadows of a QSplat model.
pub fn render_standard_view<const W: usize, const H: usize>(
    model: &Model<'_>,
    spec: FrameSpec,
    targets: &mut Targets<'_, W, H>,
    mark: impl FnMut(Phase),
) -> Result<FrameReport, RenderError> {
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

/// The splat kernel of every frame of a model (`pocketsplat render`'s default; a scene's is its
/// `Scene::options`'). Public so that benchmarks can say which kernel their frames were drawn with.
pub const KERNEL: Kernel = Kernel::Square;

/// Renders `model` seen from the orbit `view` at `cutoff_px` into `targets` with the defaults of
/// `pocketsplat render` (square kernel, default material and light, 45° field of view): the core's
/// [`render_marked`]. `mark` is called at the start of each [`Phase`] and at [`Phase::End`]. The
/// firmware's standard views and a handheld's interactive camera draw through this one function,
/// for either format.
///
/// # Errors
/// When the frame cannot be set up ([`RenderError`]: ρ above 3, degenerate bounds, a cutoff that
/// is not positive, shadows of a QSplat model or from a build without the `shadows` feature).
pub fn render_view<const W: usize, const H: usize>(
    model: &Model<'_>,
    view: View,
    cutoff_px: f32,
    shadows: Shadows,
    targets: &mut Targets<'_, W, H>,
    mark: impl FnMut(Phase),
) -> Result<Drawn, RenderError> {
    let camera = model.orbit(view);
    let options = RenderOptions {
        cutoff_px,
        kernel: KERNEL,
        shadows,
        shadow_map_size: SHADOW_MAP_SIZE,
        ..model.options()
    };
    let target = Target::new(
        Framebuffer::new(targets.color, targets.depth),
        targets.table,
    );
    #[cfg(feature = "shadows")]
    let target = target.with_shadows(&mut targets.shadow[..], targets.light);
    let mut target = target;
    render_marked(model, &camera, &options, &mut target, &mut Direct, mark)
}

/// [`render_view`] of a tri-grid streamed through a block cache (`stream` feature): the core's
/// [`render_stream`] (it draws what is resident and queues what is missing; [`TgStream::serve`]
/// reads it) through the same camera, shading table, clear and splat sink. Without shadows: the
/// streamed traversal takes no light pass yet.
///
/// # Errors
/// When the frame cannot be set up ([`RenderError::Frame`]).
#[cfg(feature = "stream")]
pub fn render_stream_view(
    stream: &mut TgStream<'_>,
    view: View,
    cutoff_px: f32,
    targets: &mut StreamTargets<'_>,
    mark: impl FnMut(Phase),
) -> Result<Drawn, RenderError> {
    stream_frame(stream, view, cutoff_px, targets, StreamPass::Frame, mark)
}

/// The next pass of a refined frame of `stream` ([`TgStream::render_pass`]) at `view` and
/// `cutoff_px` into `targets`: as [`render_stream_view`], but the colour and depth buffers are
/// cleared only for the first pass (`first`, which also starts the refined frame), so that the
/// passes add up to the frame the resident file gives.
///
/// # Errors
/// When the frame cannot be set up ([`RenderError::Frame`]).
#[cfg(feature = "stream")]
pub fn render_stream_pass(
    stream: &mut TgStream<'_>,
    view: View,
    cutoff_px: f32,
    targets: &mut StreamTargets<'_>,
    first: bool,
    mark: impl FnMut(Phase),
) -> Result<Drawn, RenderError> {
    let pass = if first {
        StreamPass::FirstPass
    } else {
        StreamPass::NextPass
    };
    stream_frame(stream, view, cutoff_px, targets, pass, mark)
}

/// The next pass of a refined frame of a streamed QSplat file ([`QsStream::render_pass`]) at
/// `view` and `cutoff_px`, as [`render_stream_pass`] for a tri-grid: the same camera (the orbit of
/// the file's bounds), options and targets as [`render_view`] of the resident file.
///
/// # Errors
/// When the frame cannot be set up ([`RenderError::Frame`]).
#[cfg(all(feature = "stream", feature = "qsplat"))]
pub fn render_qs_stream_pass(
    stream: &mut QsStream<'_>,
    view: View,
    cutoff_px: f32,
    targets: &mut StreamTargets<'_>,
    first: bool,
    mark: impl FnMut(Phase),
) -> Result<Drawn, RenderError> {
    let pass = if first {
        StreamPass::FirstPass
    } else {
        StreamPass::NextPass
    };
    qs_stream_frame(stream, view, cutoff_px, targets, pass, mark)
}

/// A streamed QSplat frame or pass with the defaults of [`render_view`].
#[cfg(all(feature = "stream", feature = "qsplat"))]
fn qs_stream_frame(
    stream: &mut QsStream<'_>,
    view: View,
    cutoff_px: f32,
    targets: &mut StreamTargets<'_>,
    pass: StreamPass,
    mark: impl FnMut(Phase),
) -> Result<Drawn, RenderError> {
    let sphere = pocketsplat_core::camera::Sphere::from_bounds(stream.bounds());
    streamed(
        sphere,
        view,
        cutoff_px,
        targets,
        |camera, options, target| {
            render_qs_stream(stream, camera, options, target, pass, &mut Direct, mark)
        },
    )
}

/// A streamed model of either format: what a viewer that opens `MODEL.TG` or `MODEL.QS` holds.
/// One per viewer, by value: no heap on the device to box the larger variant in.
#[cfg(feature = "stream")]
#[allow(clippy::large_enum_variant)]
pub enum ModelStream<'a> {
    /// A tri-grid.
    Tg(TgStream<'a>),
    /// A QSplat file.
    #[cfg(feature = "qsplat")]
    Qs(QsStream<'a>),
}

/// `$body` with `$s` bound to the stream of either format.
#[cfg(feature = "stream")]
macro_rules! each_stream {
    ($self:expr, $s:ident => $body:expr) => {
        match $self {
            ModelStream::Tg($s) => $body,
            #[cfg(feature = "qsplat")]
            ModelStream::Qs($s) => $body,
        }
    };
}

#[cfg(feature = "stream")]
impl ModelStream<'_> {
    /// Reads what the last frame asked for ([`TgStream::serve`]).
    pub fn serve<C: pocketsplat_core::stream::ChunkSource + ?Sized>(
        &mut self,
        src: &mut C,
        budget_bytes: u32,
    ) -> pocketsplat_core::stream::ServeReport {
        each_stream!(self, s => s.serve(src, budget_bytes))
    }
    /// What the last frame missed (0: the resident file's frame).
    pub fn missing(&self) -> u32 {
        each_stream!(self, s => s.missing())
    }
    /// Descents the last frame refused as malformed.
    pub fn inconsistent(&self) -> u32 {
        each_stream!(self, s => s.inconsistent())
    }
    /// Blocks the last frame used and queued.
    pub fn working_set(&self) -> u32 {
        each_stream!(self, s => s.working_set())
    }
    /// Blocks the cache holds.
    pub fn cache_capacity(&self) -> usize {
        each_stream!(self, s => s.cache().capacity())
    }
    /// Cumulative counts.
    pub fn counters(&self) -> &pocketsplat_core::stream::StreamCounters {
        each_stream!(self, s => s.counters())
    }
    /// Whether the last pass completed its refined frame.
    pub fn refined_done(&self) -> bool {
        each_stream!(self, s => s.refined_done())
    }
    /// Passes of the refined frame.
    pub fn passes(&self) -> u32 {
        each_stream!(self, s => s.passes())
    }
    /// Bytes in the file.
    pub fn file_len(&self) -> u64 {
        match self {
            ModelStream::Tg(s) => u64::from(s.header().blocks) << s.header().block_log2,
            #[cfg(feature = "qsplat")]
            ModelStream::Qs(s) => s.file_len(),
        }
    }
}

/// [`render_stream_view`] or [`render_stream_pass`] (`pass`) of a stream of either format.
///
/// # Errors
/// When the frame cannot be set up ([`RenderError::Frame`]).
#[cfg(feature = "stream")]
pub fn render_model_stream(
    stream: &mut ModelStream<'_>,
    view: View,
    cutoff_px: f32,
    targets: &mut StreamTargets<'_>,
    pass: StreamPass,
    mark: impl FnMut(Phase),
) -> Result<Drawn, RenderError> {
    match stream {
        ModelStream::Tg(s) => stream_frame(s, view, cutoff_px, targets, pass, mark),
        #[cfg(feature = "qsplat")]
        ModelStream::Qs(s) => qs_stream_frame(s, view, cutoff_px, targets, pass, mark),
    }
}

/// A streamed frame or pass with the defaults of [`render_view`].
#[cfg(feature = "stream")]
fn stream_frame(
    stream: &mut TgStream<'_>,
    view: View,
    cutoff_px: f32,
    targets: &mut StreamTargets<'_>,
    pass: StreamPass,
    mark: impl FnMut(Phase),
) -> Result<Drawn, RenderError> {
    let sphere = pocketsplat_core::camera::Sphere::from_bounds_f64(stream.header().bounds64);
    streamed(
        sphere,
        view,
        cutoff_px,
        targets,
        |camera, options, target| {
            render_stream(stream, camera, options, target, pass, &mut Direct, mark)
        },
    )
}

/// The camera, options and target of a streamed frame of a model in `sphere` with the defaults
/// of [`render_view`], handed to `draw` (either format's stream).
#[cfg(feature = "stream")]
fn streamed(
    sphere: pocketsplat_core::camera::Sphere,
    view: View,
    cutoff_px: f32,
    targets: &mut StreamTargets<'_>,
    draw: impl FnOnce(
        &pocketsplat_core::camera::Camera,
        &RenderOptions,
        &mut Target<'_, Framebuffer<'_>, 1>,
    ) -> Result<Drawn, RenderError>,
) -> Result<Drawn, RenderError> {
    let camera = pocketsplat_core::camera::Camera::orbit(
        sphere,
        view,
        pocketsplat_core::camera::DEFAULT_FOV_DEG,
    );
    let options = RenderOptions {
        cutoff_px,
        kernel: KERNEL,
        ..RenderOptions::default()
    };
    let mut target = Target::new(
        Framebuffer::new(targets.color, targets.depth),
        targets.table,
    );
    draw(&camera, &options, &mut target)
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
}
