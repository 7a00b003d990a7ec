//! # pocketsplat-handheld
//!
//! pocketsplat on a real handheld: a 240×320 RGB565 panel, an SD card, six buttons that move an
//! orbit camera, and (feature `defmt`) defmt logging. The viewer is generic over an embedded-sdmmc
//! [`BlockDevice`] (the card) and an embedded-graphics [`DrawTarget`] (the panel), so that the same
//! loop runs on the board and in a host test against a FAT image and a recording display; a board
//! is a pin binding: `src/bin/pico2-restouch.rs` binds it to a Raspberry Pi Pico 2 with a Waveshare
//! Pico-ResTouch-LCD-2.8 (an ST7789 through mipidsi, [`init_panel`]; wiring in `../README.md`).
//!
//! The model is `MODEL.TG` (or else `MODEL.QS`, a QSplat file) in the card's root, of any size: it
//! is never read whole but streamed through a 64 KB block cache ([`TgStream`], [`QsStream`], the
//! QEMU firmware's `stream` build,
//! `pocketsplat_qemu::stream`), or else a model linked into flash, streamed the same way. The frame
//! is the QEMU firmware's (same camera, shading and traversal:
//! [`pocketsplat_qemu::render_stream_view`]). One [`Viewer::step`] is one turn of the loop:
//!
//! - while a button is held, a whole frame at the cutoff a [`FrameRateController`] picks, drawn from
//!   what is resident (coarser where blocks are absent), then up to [`IO_BUDGET_BYTES`] read;
//! - when nothing is held, the same frame again until it misses nothing, then finer ones (√2 a step,
//!   QSplat §4.2) while they fit the cache whole; the first that does not is drawn at 1 px in passes
//!   ([`pocketsplat_qemu::render_stream_pass`]) off screen, the panel keeping the last frame, and
//!   shown when complete: exactly the frame the resident file gives;
//! - then nothing, until a button is pressed ([`StepOutcome::Idle`]).
//!
//! A read that fails (a card that errs or is pulled) leaves its block absent: frames go on from
//! what is resident, with the red read-error marker in the top right corner
//! ([`pocketsplat_qemu::stream::draw_error_marker`]), and a refinement that cannot finish ends there.
//!
//! With neither model on the card, a scene pack, `SCENE.PAK`, is shown with its shadows by a
//! [`PackViewer`] ([`scene`]): the QEMU firmware's streamed pack, in eight bands and a 128² shadow
//! map, driven by the same buttons. A model's memory and a pack's are one [`Arena`] ([`memory`]),
//! laid out for the file the card holds: the larger of the two, not both.
#![no_std]
#![deny(clippy::float_arithmetic)]

use core::fmt::Write as _;

use embedded_graphics::mono_font::{ascii::FONT_6X10, MonoTextStyle};
use embedded_graphics::pixelcolor::Rgb565;
use embedded_graphics::prelude::*;
use embedded_graphics::text::Text;
use embedded_hal::delay::DelayNs;
use embedded_hal::digital::{InputPin, OutputPin};
use embedded_hal::spi::SpiDevice;
use embedded_sdmmc::{BlockDevice, Mode, RawFile, VolumeIdx, VolumeManager};
use mipidsi::interface::SpiInterface;
use mipidsi::models::ST7789;
use mipidsi::options::ColorInversion;
use pocketsplat_core::camera::{View, STANDARD_VIEWS};
use pocketsplat_core::format::QS_MAGIC;
use pocketsplat_core::lod::{FrameRateController, FINEST_CUTOFF_PX};
use pocketsplat_core::raster::Framebuffer;
use pocketsplat_core::stream::sdmmc::SdFile;
use pocketsplat_core::stream::{
    ChunkSource, MemSource, OutOfRange, QsStream, StreamCounters, StreamError, TgStream,
};
use pocketsplat_core::tg::TgError;
use pocketsplat_qemu::stream::QS_BLOCK_LOG2;
use pocketsplat_qemu::stream::{
    draw_error_marker, IO_BUDGET_BYTES, MAX_CONVERGE_FRAMES, MAX_IDLE_PASSES, MAX_PASSES,
    REFINE_IO_BUDGET_BYTES,
};
use pocketsplat_qemu::{render_model_stream, ModelStream, StreamPass};
use pocketsplat_qemu::{HEIGHT, WIDTH};

pub use pocketsplat_core::stream::sdmmc::NoClock;
/// Bytes of block cache, the QEMU firmware's (64 KB).
pub use pocketsplat_qemu::stream::CACHE_BYTES;
pub use pocketsplat_qemu::StreamTargets;

/// Name of the model file in the SD card's root directory (8.3): a tri-grid, or else
/// [`QS_MODEL_FILE`], or else [`SCENE_FILE`].
pub const MODEL_FILE: &str = "MODEL.TG";
/// A QSplat file in the card's root, shown when there is no [`MODEL_FILE`] (streamed in 2 KB
/// blocks, `pocketsplat_qemu::stream::QS_BLOCK_LOG2`).
pub const QS_MODEL_FILE: &str = "MODEL.QS";
/// A scene pack in the card's root, shown when there is neither [`MODEL_FILE`] nor
/// [`QS_MODEL_FILE`]: drawn with its one-pass shadows ([`scene`]).
pub const SCENE_FILE: &str = pocketsplat_qemu::pack_stream::PACK_FILE;
/// Frame time the controller aims at while the camera moves, microseconds (5 fps).
pub const TARGET_FRAME_US: u32 = 200_000;
/// Cutoff of the first frame, pixels.
pub const FIRST_CUTOFF_PX: f32 = 4.0;

/// Logs with defmt when the `defmt` feature is on; otherwise nothing (the arguments are still
/// evaluated by reference, so that nothing is unused).
macro_rules! log {
    ($level:ident, $fmt:literal $(, $arg:expr)* $(,)?) => {{
        #[cfg(feature = "defmt")]
        defmt::$level!($fmt $(, $arg)*);
        #[cfg(not(feature = "defmt"))]
        {
            $(let _ = &$arg;)*
        }
    }};
}

/// A value shown through its `Display` in a log line.
#[cfg(feature = "defmt")]
macro_rules! shown {
    ($e:expr) => {
        defmt::Display2Format(&$e)
    };
}
#[cfg(not(feature = "defmt"))]
macro_rules! shown {
    ($e:expr) => {
        $e
    };
}

pub mod memory;
pub mod scene;

pub use memory::{Arena, ModelArena, PackArena};
pub use scene::{open_scene, PackViewer};

/// The camera buttons, in the order [`Buttons::pins`] holds them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Button {
    /// Orbit left (azimuth −).
    Left,
    /// Orbit right (azimuth +).
    Right,
    /// Orbit up (elevation +).
    Up,
    /// Orbit down (elevation −).
    Down,
    /// Move closer.
    ZoomIn,
    /// Move away.
    ZoomOut,
}

impl Button {
    /// Every button, in pin order.
    pub const ALL: [Button; 6] = [
        Button::Left,
        Button::Right,
        Button::Up,
        Button::Down,
        Button::ZoomIn,
        Button::ZoomOut,
    ];

    /// `held` with only this button down.
    pub fn alone(self) -> [bool; 6] {
        Button::ALL.map(|b| b == self)
    }
}

/// Six active-low buttons (to ground, with pull-ups), in [`Button::ALL`] order.
pub struct Buttons<P> {
    /// The input pins.
    pub pins: [P; 6],
}

impl<P: InputPin> Buttons<P> {
    /// Which buttons are held now. A pin that cannot be read counts as released.
    pub fn held(&mut self) -> [bool; 6] {
        let mut held = [false; 6];
        for (h, pin) in held.iter_mut().zip(&mut self.pins) {
            *h = pin.is_low().unwrap_or(false);
        }
        held
    }
}

/// An orbit camera driven by the buttons (per-frame setup: floats allowed).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Orbit {
    /// The current view.
    pub view: View,
}

impl Default for Orbit {
    fn default() -> Self {
        Orbit {
            view: STANDARD_VIEWS[0].1,
        }
    }
}

impl Orbit {
    /// Degrees per frame a held orbit button turns.
    pub const STEP_DEG: f64 = 8.0;
    /// Distance factor per frame a held zoom button applies.
    pub const ZOOM: f64 = 1.12;

    /// Applies the held buttons; returns whether the view changed.
    #[allow(clippy::float_arithmetic)]
    pub fn step(&mut self, held: [bool; 6]) -> bool {
        let before = self.view;
        let v = &mut self.view;
        for (button, _) in Button::ALL.iter().zip(held).filter(|(_, h)| *h) {
            match button {
                Button::Left => v.az_deg -= Self::STEP_DEG,
                Button::Right => v.az_deg += Self::STEP_DEG,
                Button::Up => v.el_deg = (v.el_deg + Self::STEP_DEG).min(85.0),
                Button::Down => v.el_deg = (v.el_deg - Self::STEP_DEG).max(-85.0),
                Button::ZoomIn => v.dist = (v.dist / Self::ZOOM).max(0.6),
                Button::ZoomOut => v.dist = (v.dist * Self::ZOOM).min(40.0),
            }
        }
        if v.az_deg > 180.0 {
            v.az_deg -= 360.0;
        } else if v.az_deg < -180.0 {
            v.az_deg += 360.0;
        }
        self.view != before
    }
}

/// The card's file system: one volume, one directory and one file open at a time (the viewer
/// opens the root and [`MODEL_FILE`], and keeps them open).
pub type Volumes<D> = VolumeManager<D, NoClock, 1, 1, 1>;

/// The file system on `card` (nothing is read yet).
pub fn volumes<D: BlockDevice>(card: D) -> Volumes<D> {
    VolumeManager::new_with_limits(card, NoClock, 0)
}

/// [`MODEL_FILE`] on a card, as a stream's source.
pub type CardFile<'v, D> = SdFile<'v, D, NoClock, 1, 1, 1>;

/// Why no model could be shown.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LoadError {
    /// No card, no FAT volume or no [`MODEL_FILE`] in its root.
    NoFile,
    /// The header or the CRC table could not be read.
    Read,
    /// The file is not a valid tri-grid.
    Invalid,
    /// A `.tg` of a version that cannot be streamed (1 or 2): it must be migrated to version 3.
    OldVersion(u16),
    /// A scene pack whose objects need more of something than the viewer has at once.
    PackMemory {
        /// What (cache bytes, block entries, object streams).
        what: &'static str,
        /// How many the pack needs.
        need: u32,
        /// How many the viewer has.
        have: u32,
    },
}

impl core::fmt::Display for LoadError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            LoadError::NoFile => write!(
                f,
                "No {MODEL_FILE}, {QS_MODEL_FILE}\nor {SCENE_FILE} on the\nSD card and no model\nin flash. See README."
            ),
            LoadError::Read => write!(f, "{MODEL_FILE}: the card\nfailed to read it."),
            LoadError::Invalid => write!(f, "The model is not a\nvalid .tg or .qs file."),
            LoadError::OldVersion(v) => write!(
                f,
                "{MODEL_FILE} is version {v}.\nConvert it on a PC:\npocketsplat migrate"
            ),
            LoadError::PackMemory { what, need, have } => write!(
                f,
                "{SCENE_FILE} needs {need}\n{what}; this viewer\nhas {have}."
            ),
        }
    }
}

/// Opens [`MODEL_FILE`], or else [`QS_MODEL_FILE`], or else [`SCENE_FILE`], in the root of the first FAT volume of
/// `volumes`. On an SD card in SPI mode call it with the bus at ≤ 400 kHz (the card initialises on
/// the first read).
///
/// # Errors
/// [`LoadError::NoFile`]: no card, volume or file.
pub fn open_model<D: BlockDevice>(volumes: &Volumes<D>) -> Result<CardFile<'_, D>, LoadError> {
    let volume = volumes.open_raw_volume(VolumeIdx(0)).map_err(|e| {
        log!(warn, "SD card: {}", defmt_debug(&e));
        LoadError::NoFile
    })?;
    let root = volumes
        .open_root_dir(volume)
        .map_err(|_| LoadError::NoFile)?;
    let file: RawFile = volumes
        .open_file_in_dir(root, MODEL_FILE, Mode::ReadOnly)
        .or_else(|_| volumes.open_file_in_dir(root, QS_MODEL_FILE, Mode::ReadOnly))
        .or_else(|_| volumes.open_file_in_dir(root, SCENE_FILE, Mode::ReadOnly))
        .map_err(|_| LoadError::NoFile)?;
    Ok(SdFile::new(volumes, file))
}

/// What a log line can show of an embedded-sdmmc error.
#[cfg(feature = "defmt")]
fn defmt_debug<E: core::fmt::Debug>(e: &E) -> defmt::Debug2Format<'_, E> {
    defmt::Debug2Format(e)
}
#[cfg(not(feature = "defmt"))]
fn defmt_debug<E>(e: &E) -> &E {
    e
}

/// Where the model comes from: the card, or the model linked into flash.
pub enum ModelSource<'v, D: BlockDevice> {
    /// [`MODEL_FILE`] on the card.
    Card(CardFile<'v, D>),
    /// A `.tg` in flash (the `model` feature of the board binary).
    Flash(MemSource<'static>),
}

/// A failed read of a [`ModelSource`].
#[derive(Debug)]
pub enum SourceError<E> {
    /// The card's (an embedded-sdmmc error).
    Card(E),
    /// Past the end of the flash model.
    Flash(OutOfRange),
}

impl<D: BlockDevice> ChunkSource for ModelSource<'_, D> {
    type Error = SourceError<embedded_sdmmc::Error<D::Error>>;
    fn read_at(&mut self, offset: u64, buf: &mut [u8]) -> Result<(), Self::Error> {
        match self {
            ModelSource::Card(f) => f.read_at(offset, buf).map_err(SourceError::Card),
            ModelSource::Flash(m) => m.read_at(offset, buf).map_err(SourceError::Flash),
        }
    }
    fn byte_len(&self) -> Option<u64> {
        match self {
            ModelSource::Card(f) => f.byte_len(),
            ModelSource::Flash(m) => m.byte_len(),
        }
    }
}

/// The block cache's tables (the same for a file of any size): in the board's arena, a box on the
/// host.
pub type StreamTables = pocketsplat_qemu::stream::StreamTables;

/// Opens the model on `src` for streaming through the [`CACHE_BYTES`] of `cache`: a QSplat file by
/// its magic (its fragment headers read), else a `.tg` (its header and CRC table read).
///
/// # Errors
/// [`LoadError`]: the header cannot be read, or is neither a tri-grid's nor a QSplat file's.
pub fn open_stream<'a, C: ChunkSource + ?Sized>(
    src: &mut C,
    cache: &'a mut [u8; CACHE_BYTES],
    tables: &'a mut StreamTables,
) -> Result<ModelStream<'a>, LoadError> {
    let mut magic = [0u8; 8];
    let qsplat = src.read_at(0, &mut magic).is_ok() && magic == QS_MAGIC;
    let opened = if qsplat {
        QsStream::open(
            src,
            QS_BLOCK_LOG2,
            cache,
            &mut tables.slots,
            &mut tables.blocks,
        )
        .map(ModelStream::Qs)
    } else {
        TgStream::open(src, cache, &mut tables.slots, &mut tables.blocks).map(ModelStream::Tg)
    };
    opened.map_err(|e| {
        log!(warn, "model: {}", shown!(e));
        match e {
            StreamError::Device(_) => LoadError::Read,
            StreamError::Format(TgError::NotStreamable { version }) => {
                LoadError::OldVersion(version)
            }
            _ => LoadError::Invalid,
        }
    })
}

/// A monotonic clock in microseconds (the board's timer).
pub trait Clock {
    /// Microseconds since some fixed point.
    fn now_us(&mut self) -> u64;
}

/// What one drawn frame (or pass) was.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameInfo {
    /// LOD cutoff, pixels.
    pub cutoff_px: f32,
    /// Splats drawn.
    pub splats: u32,
    /// Nodes visited.
    pub nodes: u32,
    /// Blocks the frame wanted and did not have (0: the resident file's frame).
    pub missing: u32,
    /// Whether the read-error marker is up.
    pub marker: bool,
    /// Bytes read after the frame.
    pub read: u32,
    /// Render and read time, microseconds.
    pub frame_us: u32,
}

/// What one [`Viewer::step`] did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StepOutcome {
    /// A whole frame from what is resident, sent to the panel: coarse while a button is held, or a
    /// step of refinement (with the HUD line).
    Frame(FrameInfo),
    /// A pass of the refined 1 px frame, drawn off screen (the panel keeps the last frame).
    Pass(FrameInfo),
    /// Full detail is on the panel, without the HUD: the resident file's 1 px frame.
    Refined(FrameInfo),
    /// Refinement stopped short because reads keep failing: the panel keeps the last frame, with
    /// the marker.
    GaveUp(FrameInfo),
    /// Nothing to draw: nothing is held and the panel shows all it can.
    Idle,
}

/// Where refinement stands.
#[derive(Clone, Copy, Debug, PartialEq)]
enum State {
    /// Whole frames at the controller's cutoff: `converged` whether the last one missed nothing,
    /// `tries` frames drawn at this cutoff.
    Whole { converged: bool, tries: u32 },
    /// The 1 px frame in passes: `first` before its first pass, `idle` consecutive passes that
    /// read nothing intact.
    Passes { first: bool, idle: u32 },
    /// Nothing more to draw until a button is pressed.
    Rest,
}

/// The viewer: a stream, its source, the panel, the frame's buffers and the camera.
pub struct Viewer<'a, C: ChunkSource, P: DrawTarget<Color = Rgb565>, K: Clock> {
    stream: ModelStream<'a>,
    src: C,
    panel: P,
    clock: K,
    targets: StreamTargets<'a>,
    orbit: Orbit,
    lod: FrameRateController,
    state: State,
    marker: Marker,
}

impl<'a, C: ChunkSource, P: DrawTarget<Color = Rgb565>, K: Clock> Viewer<'a, C, P, K> {
    /// A viewer of `stream` (opened on `src` by [`open_stream`]) drawing into `targets` and onto
    /// `panel`, from the std view.
    pub fn new(
        stream: ModelStream<'a>,
        src: C,
        panel: P,
        clock: K,
        targets: StreamTargets<'a>,
    ) -> Self {
        Viewer {
            stream,
            src,
            panel,
            clock,
            targets,
            orbit: Orbit::default(),
            lod: FrameRateController::new(TARGET_FRAME_US, FIRST_CUTOFF_PX),
            state: State::Whole {
                converged: false,
                tries: 0,
            },
            marker: Marker::default(),
        }
    }

    /// The camera's view now.
    pub fn view(&self) -> View {
        self.orbit.view
    }

    /// The stream (its counters).
    pub fn stream(&self) -> &ModelStream<'a> {
        &self.stream
    }

    /// The panel.
    pub fn panel(&self) -> &P {
        &self.panel
    }

    /// One turn of the loop with the buttons `held` ([`Button::ALL`] order): see the crate docs.
    pub fn step(&mut self, held: [bool; 6]) -> StepOutcome {
        let moved = self.orbit.step(held);
        if moved || held.contains(&true) {
            let info = self.whole_frame(self.lod.cutoff(), IO_BUDGET_BYTES, true);
            self.lod.update(info.frame_us);
            self.state = State::Whole {
                converged: false,
                tries: 0,
            };
            return StepOutcome::Frame(info);
        }
        match self.state {
            State::Rest => StepOutcome::Idle,
            State::Whole { converged, tries } => {
                let tries = if converged {
                    if self.lod.refine_idle().is_none() {
                        self.state = State::Rest;
                        return StepOutcome::Idle;
                    }
                    0
                } else {
                    tries
                };
                let cutoff = self.lod.cutoff();
                let finest = cutoff <= FINEST_CUTOFF_PX;
                let info = self.whole_frame(cutoff, REFINE_IO_BUDGET_BYTES, !finest);
                let converged = info.missing == 0;
                if converged && finest {
                    // Drawn without the HUD: the resident file's frame is on the panel.
                    self.state = State::Rest;
                    return StepOutcome::Refined(info);
                }
                let stuck = info.read == 0
                    || self.stream.working_set() as usize > self.stream.cache_capacity();
                if !converged && stuck {
                    // The frame wants more than the cache holds at once (its blocks would evict
                    // each other, or what it uses leaves no room for what it lacks): the 1 px
                    // frame, in passes.
                    self.state = State::Passes {
                        first: true,
                        idle: 0,
                    };
                } else if !converged && tries + 1 >= MAX_CONVERGE_FRAMES {
                    self.state = State::Rest;
                    return StepOutcome::GaveUp(info);
                } else {
                    self.state = State::Whole {
                        converged,
                        tries: tries + 1,
                    };
                }
                StepOutcome::Frame(info)
            }
            State::Passes { first, idle } => self.pass(first, idle),
        }
    }

    /// Draws a whole frame at `cutoff_px` from what is resident, with the marker (and the HUD line
    /// when `hud`), sends it to the panel and reads up to `budget` bytes.
    #[inline(never)]
    fn whole_frame(&mut self, cutoff_px: f32, budget: u32, hud: bool) -> FrameInfo {
        let t0 = self.clock.now_us();
        let drawn = render_model_stream(
            &mut self.stream,
            self.orbit.view,
            cutoff_px,
            &mut self.targets,
            StreamPass::Frame,
            |_| {},
        );
        let missing = self.stream.missing();
        let marker = self.update_marker();
        let read = self.stream.serve(&mut self.src, budget).bytes;
        let frame_us = elapsed(t0, self.clock.now_us());
        let stats = drawn.as_ref().map(|d| d.stats).unwrap_or_default();
        let info = FrameInfo {
            cutoff_px,
            splats: stats.splats,
            nodes: stats.nodes_visited,
            missing: if drawn.is_ok() {
                missing
            } else {
                missing.max(1)
            },
            marker,
            read,
            frame_us,
        };
        let mut fb = Framebuffer::new(self.targets.color, self.targets.depth);
        if let Err(e) = drawn {
            log!(error, "frame: {}", shown!(e));
        }
        if marker {
            // The framebuffer's drawing cannot fail (`Infallible`).
            let _ = draw_error_marker(&mut fb);
        }
        if hud {
            let mut line = Line::new();
            let _ = write!(
                line,
                "{} splats  cutoff {} px  {} ms",
                info.splats,
                cutoff_px as u32,
                frame_us / 1000
            );
            draw_text(&mut fb, &line, Point::new(2, HEIGHT as i32 - 4));
        }
        self.blit();
        log!(
            info,
            "frame: cutoff {} px, {} splats, {} nodes, missing {}, read {} B, {} us",
            cutoff_px,
            info.splats,
            info.nodes,
            info.missing,
            info.read,
            frame_us
        );
        info
    }

    /// The next pass of the 1 px frame; shown when it completes the frame.
    #[inline(never)]
    fn pass(&mut self, first: bool, idle: u32) -> StepOutcome {
        let t0 = self.clock.now_us();
        let intact = |s: &ModelStream<'_>| {
            let c = s.counters();
            c.reads - c.read_errors - c.crc_errors - c.structure_errors
        };
        let before = intact(&self.stream);
        let pass = if first {
            StreamPass::FirstPass
        } else {
            StreamPass::NextPass
        };
        let drawn = render_model_stream(
            &mut self.stream,
            self.orbit.view,
            FINEST_CUTOFF_PX,
            &mut self.targets,
            pass,
            |_| {},
        );
        let done = drawn.is_ok() && self.stream.refined_done();
        let missing = if done {
            self.stream.missing()
        } else {
            self.stream.missing().max(1)
        };
        let marker = self.update_marker();
        let read = if done && missing == 0 {
            0
        } else {
            self.stream
                .serve(&mut self.src, REFINE_IO_BUDGET_BYTES)
                .bytes
        };
        let stats = drawn.as_ref().map(|d| d.stats).unwrap_or_default();
        let info = FrameInfo {
            cutoff_px: FINEST_CUTOFF_PX,
            splats: stats.splats,
            nodes: stats.nodes_visited,
            missing,
            marker,
            read,
            frame_us: elapsed(t0, self.clock.now_us()),
        };
        if done {
            // The passes add up to the whole frame: show it (the marker over it on the panel only,
            // as the buffers hold the frame).
            self.blit();
            if marker {
                let _ = draw_error_marker(&mut self.panel);
            }
            self.state = State::Rest;
            log!(
                info,
                "refined: {} passes, missing {}",
                self.stream.passes(),
                missing
            );
            return if missing == 0 {
                StepOutcome::Refined(info)
            } else {
                StepOutcome::GaveUp(info)
            };
        }
        if marker {
            // The panel shows the last whole frame: mark it there, not in the buffers.
            let _ = draw_error_marker(&mut self.panel);
        }
        let idle = if intact(&self.stream) == before {
            idle + 1
        } else {
            0
        };
        if drawn.is_err() || idle >= MAX_IDLE_PASSES || self.stream.passes() >= MAX_PASSES {
            log!(
                warn,
                "refinement stopped after {} passes",
                self.stream.passes()
            );
            self.state = State::Rest;
            return StepOutcome::GaveUp(info);
        }
        self.state = State::Passes { first: false, idle };
        StepOutcome::Pass(info)
    }

    fn update_marker(&mut self) -> bool {
        self.marker
            .update(self.stream.counters(), self.stream.inconsistent())
    }

    /// Sends the colour buffer to the panel in one window write.
    fn blit(&mut self) {
        // The frame is an embedded-graphics image: one contiguous write of the whole panel.
        let fb = Framebuffer::new(self.targets.color, self.targets.depth);
        if fb.draw(&mut self.panel).is_err() {
            log!(error, "panel write failed");
        }
    }
}

/// The read-error marker's state, for a model's frames and a pack's alike.
#[derive(Clone, Copy, Debug, Default)]
struct Marker {
    /// Failed reads counted so far, and bytes read, when the marker was last decided.
    failed_before: u32,
    read_before: u64,
    up: bool,
}

impl Marker {
    /// Whether the marker is up after the frame just drawn (stream counters `c`, `inconsistent`
    /// descents refused): from a failed read until reads succeed again with none failing (the QEMU
    /// firmware's rule, `pocketsplat_qemu::stream`).
    fn update(&mut self, c: &StreamCounters, inconsistent: u32) -> bool {
        let failed_total = c.read_errors + c.crc_errors + c.structure_errors;
        let failed = failed_total - self.failed_before;
        let read_ok = c.bytes_read > self.read_before;
        self.failed_before = failed_total;
        self.read_before = c.bytes_read;
        self.up = failed > 0 || inconsistent > 0 || (self.up && !read_ok);
        self.up
    }

    /// Whether it is up.
    fn up(&self) -> bool {
        self.up
    }
}

fn elapsed(t0: u64, t1: u64) -> u32 {
    u32::try_from(t1.saturating_sub(t0)).unwrap_or(u32::MAX)
}

/// Clears `panel` and writes `why` on it.
pub fn show_message<P: DrawTarget<Color = Rgb565>>(panel: &mut P, why: &LoadError) {
    let _ = panel.clear(Rgb565::BLACK);
    let mut text = Line::new();
    let _ = write!(text, "{why}");
    let style = MonoTextStyle::new(&FONT_6X10, Rgb565::WHITE);
    let _ = Text::new(text.as_str(), Point::new(8, 20), style).draw(panel);
}

/// Runs the viewer forever on `card` and `panel`: streams [`MODEL_FILE`], [`QS_MODEL_FILE`] or
/// [`SCENE_FILE`] from the card or, when it has none, `flash` (a `.tg` linked in; empty for none),
/// with its memory laid out in `arena` for the kind of file, moving the camera with `buttons` and
/// polling them at 50 Hz once full detail is on screen. Without a file the panel says what to do.
pub fn run<'a, D, P, B, DL, K>(
    card: D,
    mut panel: P,
    buttons: Buttons<B>,
    mut delay: DL,
    clock: K,
    arena: &'a mut Arena<'a>,
    flash: &'static [u8],
) -> !
where
    D: BlockDevice,
    P: DrawTarget<Color = Rgb565>,
    B: InputPin,
    DL: DelayNs,
    K: Clock,
{
    let volumes = volumes(card);
    let mut src = match open_model(&volumes) {
        Ok(file) => ModelSource::Card(file),
        Err(e) if !flash.is_empty() => {
            log!(info, "{}: {}; streaming the model in flash", MODEL_FILE, e);
            ModelSource::Flash(MemSource::new(flash))
        }
        Err(e) => {
            show_message(&mut panel, &e);
            halt("no model", &mut delay);
        }
    };
    let mut magic = [0u8; 8];
    let _ = src.read_at(0, &mut magic);
    let board = Board {
        panel,
        buttons,
        delay,
        clock,
    };
    if pocketsplat_qemu::scene::is_pack(&magic) {
        board.run_pack(src, arena)
    }
    board.run_model(src, arena)
}

/// What [`run`] drives besides the card: the panel, the buttons, a delay and the clock.
struct Board<P, B, DL, K> {
    panel: P,
    buttons: Buttons<B>,
    delay: DL,
    clock: K,
}

impl<P, B, DL, K> Board<P, B, DL, K>
where
    P: DrawTarget<Color = Rgb565>,
    B: InputPin,
    DL: DelayNs,
    K: Clock,
{
    /// [`run`] for a scene pack: apart (and not inlined) so that the stack holds one viewer's
    /// frame, not both.
    #[inline(never)]
    fn run_pack<'a, D: BlockDevice>(
        mut self,
        mut src: ModelSource<'_, D>,
        arena: &'a mut Arena<'a>,
    ) -> ! {
        let (stream, targets) = match open_scene(&mut src, arena.pack()) {
            Ok(s) => s,
            Err(e) => self.refuse(&e),
        };
        log!(
            info,
            "scene: a pack, {} bytes, {} objects",
            stream.scene().pack().file_len(),
            stream.objects().len()
        );
        let mut viewer = PackViewer::new(stream, src, self.panel, self.clock, targets);
        forever(|held| viewer.step(held), &mut self.buttons, &mut self.delay)
    }

    /// [`run`] for a `.tg` or `.qs` model (see [`Board::run_pack`]).
    #[inline(never)]
    fn run_model<'a, D: BlockDevice>(
        mut self,
        mut src: ModelSource<'_, D>,
        arena: &'a mut Arena<'a>,
    ) -> ! {
        let (cache, tables, targets) = arena.model().parts();
        let stream = match open_stream(&mut src, cache, tables) {
            Ok(s) => s,
            Err(e) => self.refuse(&e),
        };
        match &stream {
            ModelStream::Tg(s) => {
                let h = *s.header();
                log!(
                    info,
                    "model: a tri-grid, {} blocks of {} bytes, rho {}, depth {}",
                    h.blocks,
                    h.block_size(),
                    h.rho,
                    h.depth
                );
            }
            ModelStream::Qs(s) => {
                log!(
                    info,
                    "model: a QSplat file, {} bytes, {} trees",
                    s.file_len(),
                    s.trees().len()
                );
            }
        }
        let mut viewer = Viewer::new(stream, src, self.panel, self.clock, targets);
        forever(|held| viewer.step(held), &mut self.buttons, &mut self.delay)
    }

    /// Says on the panel why the file cannot be shown, and idles.
    fn refuse(&mut self, why: &LoadError) -> ! {
        show_message(&mut self.panel, why);
        halt("no file to show", &mut self.delay);
    }
}

/// Steps a viewer with the buttons held, forever, waiting 20 ms after each step that drew nothing.
fn forever<B: InputPin>(
    mut step: impl FnMut([bool; 6]) -> StepOutcome,
    buttons: &mut Buttons<B>,
    delay: &mut impl DelayNs,
) -> ! {
    loop {
        if step(buttons.held()) == StepOutcome::Idle {
            delay.delay_ms(20);
        }
    }
}

/// The panel and its pins.
pub struct Panel<S, DC, RST, BL> {
    /// The panel's SPI device (its chip select).
    pub spi: S,
    /// Data/command select.
    pub dc: DC,
    /// Reset, active low.
    pub reset: RST,
    /// Backlight enable.
    pub backlight: BL,
}

/// The panel did not initialise (an SPI write or its reset pin failed).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PanelInitFailed;

/// An ST7789 240×320 panel through mipidsi, as a [`DrawTarget`].
pub type St7789<'b, S, DC, RST> = mipidsi::Display<SpiInterface<'b, S, DC>, ST7789, RST>;

/// Initialises the panel (reset, inversion on for the 2.8" IPS panel's true colours) and turns its
/// backlight on; `spi_buffer` batches pixels (a few KB: larger is faster).
///
/// # Errors
/// When the panel does not initialise.
pub fn init_panel<'b, S, DC, RST, BL, D>(
    panel: Panel<S, DC, RST, BL>,
    delay: &mut D,
    spi_buffer: &'b mut [u8],
) -> Result<St7789<'b, S, DC, RST>, PanelInitFailed>
where
    S: SpiDevice,
    DC: OutputPin,
    RST: OutputPin,
    BL: OutputPin,
    D: DelayNs,
{
    let Panel {
        spi,
        dc,
        reset,
        mut backlight,
    } = panel;
    let interface = SpiInterface::new(spi, dc, spi_buffer);
    let display = mipidsi::Builder::new(ST7789, interface)
        .display_size(WIDTH as u16, HEIGHT as u16)
        .invert_colors(ColorInversion::Inverted)
        .reset_pin(reset)
        .init(delay)
        .map_err(|_| PanelInitFailed)?;
    let _ = backlight.set_high();
    Ok(display)
}

/// Up to 96 bytes of text; longer writes are cut (no heap).
struct Line {
    buf: [u8; 96],
    len: usize,
}

impl Line {
    fn new() -> Self {
        Line {
            buf: [0; 96],
            len: 0,
        }
    }

    fn as_str(&self) -> &str {
        core::str::from_utf8(&self.buf[..self.len]).unwrap_or("")
    }
}

impl core::fmt::Write for Line {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        let n = s.len().min(self.buf.len() - self.len);
        let n = (0..=n).rev().find(|&k| s.is_char_boundary(k)).unwrap_or(0);
        self.buf[self.len..self.len + n].copy_from_slice(&s.as_bytes()[..n]);
        self.len += n;
        Ok(())
    }
}

fn draw_text(fb: &mut Framebuffer<'_>, text: &Line, at: Point) {
    let style = MonoTextStyle::new(&FONT_6X10, Rgb565::WHITE);
    let _ = Text::new(text.as_str(), at, style).draw(fb);
}

/// Logs `why` and idles (the panel keeps its last image).
pub fn halt(why: &str, delay: &mut impl DelayNs) -> ! {
    log!(error, "halted: {}", why);
    loop {
        delay.delay_ms(1000);
    }
}
