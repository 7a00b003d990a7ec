//! The streamed frame sequence (`stream` feature): the firmware reads the bunny from a FAT image
//! through embedded-sdmmc and a 64 KB block cache, and draws, one line per frame:
//!
//! 1. the std view from a cold cache until a frame misses no block ([`Leg::Std`]);
//! 2. an orbit of the std view's camera, [`ORBIT_STEPS`] steps of [`ORBIT_STEP_DEG`] in azimuth, one
//!    frame each, reading at most [`IO_BUDGET_BYTES`] after each ([`Leg::Orbit`]);
//! 3. the std view again until converged, after the orbit has evicted what it held
//!    ([`Leg::Return`]);
//! 4. the std view refined at 2 px and then at 1 px ([`Leg::Px2`], [`Leg::Px1`]): frames that need
//!    far more blocks than the cache holds, drawn in passes over their walk
//!    ([`TgStream::render_pass`], one line per pass, the buffers kept between passes) until the
//!    last pass completes the frame the resident file gives.
//!
//! A build with `qsplat` streams a QSplat file (`MODEL.QS`) instead: [`qs_stream_frames`] draws its
//! std view at 1 px in passes from the first, one line per pass ([`Leg::QsPx1`]), in 2 KB blocks.
//!
//! The sequence is [`stream_frames`], called by the firmware over semihosting and by the host tests
//! over the same image file, so both print the same lines; a converged frame is the frame the
//! resident file gives ([`crate::render_view`]), and the tests check that too.
//!
//! Why [`STREAM_CUTOFF_PX`] is 16 for the first three legs: a frame drawn whole converges only
//! when every block it wants is resident at once. The depth-6 bunny in 4 KB blocks holds 16 of them in 64 KB; its std view wants about 40 at
//! 8 px and more still below (nearly all 5 MB at 1 px), and 5 at 16 px. Finer frames are drawn
//! coarser where blocks are absent, which is the point of streaming, but never converge whole;
//! the refined legs draw them in passes instead.

use core::fmt;

use pocketsplat_core::camera::{View, STANDARD_VIEWS};
use pocketsplat_core::stream::torture::Flaky;
use pocketsplat_core::stream::{
    table_entries, BlockEntry, ChunkSource, SlotEntry, TgStream, QUEUE_CAPACITY,
};

use crate::{render_stream_pass, render_stream_view, Drawn, Phase, RenderError, Targets, WIDTH};

/// Bytes of block cache (RAM, a static on the device).
pub const CACHE_BYTES: usize = 64 * 1024;
/// Cache slots: enough for the smallest block a `.tg` has (512 bytes); a file with larger blocks
/// uses `CACHE_BYTES / block size` of them.
pub const CACHE_SLOTS: usize = CACHE_BYTES / 512;
/// Entries of the block table (16 bytes each): the blocks the stream deals with at once (resident,
/// queued or waiting out a failure's backoff) for a full request queue, whatever the file's size.
pub const TABLE_ENTRIES: usize = table_entries(CACHE_SLOTS, QUEUE_CAPACITY);
/// Bytes read after each frame at most: 16 KB, half a 30 fps frame of a 1 MB/s SPI SD card.
pub const IO_BUDGET_BYTES: u32 = 16 * 1024;
/// LOD cutoff of every streamed frame, pixels (module docs: why 16).
pub const STREAM_CUTOFF_PX: u8 = 16;
/// Frames of the orbit.
pub const ORBIT_STEPS: u32 = 24;
/// Azimuth step of the orbit, degrees (24 × 15° = one turn).
pub const ORBIT_STEP_DEG: u32 = 15;
/// Frames a leg that waits for convergence may take before the sequence moves on (drawing what it
/// has: a card that stopped answering must not stop the firmware).
pub const MAX_CONVERGE_FRAMES: u32 = 64;
/// Passes a refined leg may take before the sequence moves on.
pub const MAX_PASSES: u32 = 1024;
/// Consecutive passes that read nothing intact after which a refined leg gives up (a card that
/// stopped answering): twice the longest backoff of a failed block (64 frames), so that a pass
/// waiting out a backoff is not taken for a card that is gone.
pub const MAX_IDLE_PASSES: u32 = 130;
/// Bytes read after each pass of a refined leg at most: what one pass queues fits in it.
pub const REFINE_IO_BUDGET_BYTES: u32 = 32 * 1024;

/// `src` through core's torture source with this build's fixed seed: 10 % of reads fail, 10 % arrive
/// with one bit flipped. The `selftest-flaky` firmware and its host twin stream through it, so that
/// both see the same failures.
pub fn flaky<S: ChunkSource>(src: S) -> Flaky<S> {
    Flaky::new(src, 0x5EED_F1A4, 10, 10)
}

/// Reads a `selftest-pulled` card answers before it is pulled: enough for the std view to converge
/// from cold; then every read fails, as when the card leaves its slot during the orbit.
pub const PULLED_AFTER_READS: u32 = 24;

/// `src` on a card that is pulled after [`PULLED_AFTER_READS`] reads.
pub fn pulled<S: ChunkSource>(src: S) -> Pulled<S> {
    Pulled {
        inner: src,
        reads: 0,
    }
}

/// A medium whose card is pulled after [`PULLED_AFTER_READS`] reads ([`pulled`]).
#[derive(Debug)]
pub struct Pulled<S> {
    inner: S,
    reads: u32,
}

/// A failed read of a [`Pulled`] card.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PulledError<E> {
    /// The card is gone.
    Gone,
    /// The medium failed before.
    Inner(E),
}

impl<S: ChunkSource> ChunkSource for Pulled<S> {
    type Error = PulledError<S::Error>;
    fn byte_len(&self) -> Option<u64> {
        self.inner.byte_len()
    }
    fn read_at(&mut self, offset: u64, buf: &mut [u8]) -> Result<(), Self::Error> {
        self.reads = self.reads.saturating_add(1);
        if self.reads > PULLED_AFTER_READS {
            return Err(PulledError::Gone);
        }
        self.inner.read_at(offset, buf).map_err(PulledError::Inner)
    }
}

/// The tables a [`TgStream`] of this sequence needs beside its cache blocks, in one piece (one
/// `static mut` for cortex-m-rt's entry to hand over; a box on the host): the same for a file of
/// any size.
pub struct StreamTables {
    /// Cache slots.
    pub slots: [SlotEntry; CACHE_SLOTS],
    /// The block table.
    pub blocks: [BlockEntry; TABLE_ENTRIES],
}

impl StreamTables {
    /// Tables before a file is opened, all zero bits (`.bss` on the device): the stream opened
    /// over them empties every entry it uses first.
    pub const EMPTY: Self = Self {
        slots: [SlotEntry::UNSET; CACHE_SLOTS],
        blocks: [BlockEntry::UNSET; TABLE_ENTRIES],
    };

    /// These tables and the cache blocks `data`, as [`stream_frames`] takes them.
    pub fn with_cache<'a>(&'a mut self, data: &'a mut [u8; CACHE_BYTES]) -> StreamMemory<'a> {
        StreamMemory {
            data,
            slots: &mut self.slots,
            blocks: &mut self.blocks,
        }
    }
}

/// The caller's memory for a [`TgStream`] (statics on the device).
pub struct StreamMemory<'a> {
    /// Cache blocks, [`CACHE_BYTES`].
    pub data: &'a mut [u8; CACHE_BYTES],
    /// Cache slots.
    pub slots: &'a mut [SlotEntry; CACHE_SLOTS],
    /// The block table.
    pub blocks: &'a mut [BlockEntry; TABLE_ENTRIES],
}

impl StreamMemory<'_> {
    /// The same memory for another stream (one file after another).
    pub fn reborrow(&mut self) -> StreamMemory<'_> {
        StreamMemory {
            data: self.data,
            slots: self.slots,
            blocks: self.blocks,
        }
    }
}

/// A part of the sequence.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Leg {
    /// The std view from a cold cache, until converged.
    Std,
    /// The orbit.
    Orbit,
    /// The std view again, until converged.
    Return,
    /// The std view at 2 px, drawn in passes until the refined frame is complete.
    Px2,
    /// The std view at 1 px, likewise.
    Px1,
    /// A QSplat file's std view at 1 px, drawn in passes from the first ([`qs_stream_frames`]).
    QsPx1,
    /// A scene pack's first view at 1 px, drawn in passes band by band
    /// (`pack_stream::pack_stream_frames`).
    PackPx1,
}

impl Leg {
    /// Every leg, in order.
    pub const ALL: [Leg; 5] = [Leg::Std, Leg::Orbit, Leg::Return, Leg::Px2, Leg::Px1];

    /// `std`, `orbit`, `return`, `px2` or `px1`.
    pub fn name(self) -> &'static str {
        match self {
            Leg::Std => "std",
            Leg::Orbit => "orbit",
            Leg::Return => "return",
            Leg::Px2 => "px2",
            Leg::Px1 => "px1",
            Leg::QsPx1 => "qs-px1",
            Leg::PackPx1 => "pack-px1",
        }
    }

    /// The LOD cutoff of the leg's frames, pixels.
    pub fn cutoff_px(self) -> u8 {
        match self {
            Leg::Std | Leg::Orbit | Leg::Return => STREAM_CUTOFF_PX,
            Leg::Px2 => 2,
            Leg::Px1 | Leg::QsPx1 | Leg::PackPx1 => 1,
        }
    }

    /// Whether the leg draws a refined frame in passes (one line per pass).
    pub fn passes(self) -> bool {
        matches!(self, Leg::Px2 | Leg::Px1 | Leg::QsPx1 | Leg::PackPx1)
    }

    /// The leg called `name`.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL
            .into_iter()
            .chain([Leg::QsPx1, Leg::PackPx1])
            .find(|l| l.name() == name)
    }
}

/// The std view turned by `az_deg` degrees of azimuth.
// Camera setup, once a frame: floats are allowed there (docs/ARCHITECTURE.md, Numbers), and an integer step
// in degrees is exact in f64 on both machines.
#[allow(clippy::float_arithmetic)]
pub fn orbit_view(az_deg: u32) -> View {
    let std = STANDARD_VIEWS[0].1;
    View::new(std.az_deg + f64::from(az_deg), std.el_deg, std.dist)
}

/// One streamed frame: `stream <leg> <n> az <deg> crc 0x… missing M failed F marker 0|1 read B
/// prefetched P splats S nodes N`. `missing` counts the blocks the frame wanted and did not have (0:
/// converged); `failed` the reads since the previous frame that erred or failed their CRC;
/// `marker` whether the frame shows [`draw_error_marker`]'s square: from a failed read until reads
/// succeed again; `read` the bytes read after it (`prefetched` of them ahead of need, when nothing
/// was missing).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StreamFrame {
    /// Which leg.
    pub leg: Leg,
    /// Frame number within the leg, from 0.
    pub index: u32,
    /// Azimuth turned from the std view, degrees.
    pub az_deg: u32,
    /// CRC-32 of the colour buffer.
    pub crc: u32,
    /// Blocks missing from the frame.
    pub missing: u32,
    /// Reads that failed since the previous frame.
    pub failed: u32,
    /// Whether the frame carries the error marker.
    pub marker: bool,
    /// Bytes read after the frame.
    pub read: u32,
    /// Of those, bytes prefetched.
    pub prefetched: u32,
    /// Splats drawn.
    pub splats: u32,
    /// Nodes visited.
    pub nodes: u32,
}

impl StreamFrame {
    /// Whether the frame missed nothing: it is the frame the resident file gives.
    pub fn converged(&self) -> bool {
        self.missing == 0
    }

    /// Parses a line printed by [`fmt::Display`]; `None` for any other line.
    pub fn parse(line: &str) -> Option<Self> {
        let mut w = line.split_ascii_whitespace();
        if w.next()? != "stream" {
            return None;
        }
        let leg = Leg::from_name(w.next()?)?;
        let index = w.next()?.parse().ok()?;
        let mut after = |key: &str| -> Option<&str> { (w.next()? == key).then(|| w.next())? };
        let az_deg = after("az")?.parse().ok()?;
        let crc = u32::from_str_radix(after("crc")?.strip_prefix("0x")?, 16).ok()?;
        let missing = after("missing")?.parse().ok()?;
        let failed = after("failed")?.parse().ok()?;
        let marker = match after("marker")? {
            "0" => false,
            "1" => true,
            _ => return None,
        };
        let read = after("read")?.parse().ok()?;
        let prefetched = after("prefetched")?.parse().ok()?;
        let splats = after("splats")?.parse().ok()?;
        let nodes = after("nodes")?.parse().ok()?;
        if w.next().is_some() {
            return None;
        }
        Some(Self {
            leg,
            index,
            az_deg,
            crc,
            missing,
            failed,
            marker,
            read,
            prefetched,
            splats,
            nodes,
        })
    }
}

impl fmt::Display for StreamFrame {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "stream {} {} az {} crc {:#010x} missing {} failed {} marker {} read {} prefetched {} splats {} nodes {}",
            self.leg.name(),
            self.index,
            self.az_deg,
            self.crc,
            self.missing,
            self.failed,
            u8::from(self.marker),
            self.read,
            self.prefetched,
            self.splats,
            self.nodes
        )
    }
}

/// What the whole sequence read: `stream total bytes B file F frames N read_errors E crc_errors C
/// evictions V cache_blocks K`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StreamTotals {
    /// Bytes read, the header and CRC table included.
    pub bytes: u64,
    /// Bytes in the file.
    pub file_bytes: u64,
    /// Frames drawn.
    pub frames: u32,
    /// Reads the medium failed.
    pub read_errors: u32,
    /// Blocks that failed their CRC.
    pub crc_errors: u32,
    /// Blocks evicted.
    pub evictions: u32,
    /// Cache capacity, blocks.
    pub cache_blocks: u32,
}

impl StreamTotals {
    /// The totals of a run whose streams counted `c`, over `file_bytes` through a cache of
    /// `cache_blocks` blocks.
    pub fn of(
        c: &pocketsplat_core::stream::StreamCounters,
        file_bytes: u64,
        cache_blocks: u32,
    ) -> Self {
        Self {
            bytes: c.bytes_read,
            file_bytes,
            frames: c.frames,
            read_errors: c.read_errors,
            crc_errors: c.crc_errors,
            evictions: c.evictions,
            cache_blocks,
        }
    }
}

impl fmt::Display for StreamTotals {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "stream total bytes {} file {} frames {} read_errors {} crc_errors {} evictions {} cache_blocks {}",
            self.bytes,
            self.file_bytes,
            self.frames,
            self.read_errors,
            self.crc_errors,
            self.evictions,
            self.cache_blocks
        )
    }
}

/// Why the sequence stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StreamRunError<E> {
    /// The stream could not be opened (header or CRC table unreadable, file too large).
    Open(pocketsplat_core::stream::StreamError<E>),
    /// A frame could not be set up.
    View(RenderError),
    /// A scene pack's metadata or one of its objects could not be opened.
    #[cfg(feature = "scene")]
    Pack(pocketsplat_core::stream::SceneStreamError<E>),
    /// A scene pack's objects need more of the memory given than there is.
    #[cfg(feature = "scene")]
    PackMemory {
        /// What they need more of.
        what: &'static str,
        /// How much they need.
        need: u32,
        /// How much there is.
        have: u32,
    },
}

impl<E: fmt::Debug> fmt::Display for StreamRunError<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            StreamRunError::Open(e) => write!(f, "opening the stream: {e}"),
            StreamRunError::View(e) => write!(f, "{e}"),
            #[cfg(feature = "scene")]
            StreamRunError::Pack(e) => write!(f, "opening the pack: {e}"),
            #[cfg(feature = "scene")]
            StreamRunError::PackMemory { what, need, have } => write!(
                f,
                "the pack's objects need {need} {what} at once; this build has {have}"
            ),
        }
    }
}

/// Side of the read-error marker, pixels.
pub const MARKER_PX: u32 = 8;

/// Red, RGB565.
pub const MARKER_COLOR: u16 = 0xF800;

/// The read-error marker: a red square in the top right corner, over the frame (a framebuffer, or a
/// panel that shows a frame drawn earlier).
///
/// # Errors
/// The target's (a [`Framebuffer`](pocketsplat_core::raster::Framebuffer)'s drawing cannot fail).
pub fn draw_error_marker<D>(target: &mut D) -> Result<(), D::Error>
where
    D: embedded_graphics::draw_target::DrawTarget<Color = embedded_graphics::pixelcolor::Rgb565>,
{
    use embedded_graphics::pixelcolor::{raw::RawU16, Rgb565};
    use embedded_graphics::prelude::*;
    use embedded_graphics::primitives::{PrimitiveStyle, Rectangle};
    let side = MARKER_PX;
    let at = Point::new((WIDTH as u32 - side - 2) as i32, 2);
    let red = Rgb565::from(RawU16::new(MARKER_COLOR));
    Rectangle::new(at, Size::new(side, side))
        .into_styled(PrimitiveStyle::with_fill(red))
        .draw(target)
}

/// Opens the `.tg` on `src` over `mem` and draws the sequence into `targets`, handing each frame's
/// line to `report` as it is drawn (`mark` as [`crate::render_standard_view`]'s). A failed read
/// leaves its block absent: the frame is drawn coarser and the block read again later.
///
/// # Errors
/// A [`StreamRunError`]: the stream cannot be opened, a frame cannot be set up, or a leg does not
/// converge.
pub fn stream_frames<C: ChunkSource + ?Sized>(
    src: &mut C,
    mem: StreamMemory<'_>,
    targets: &mut Targets<'_>,
    mut mark: impl FnMut(Phase),
    mut report: impl FnMut(&StreamFrame),
) -> Result<StreamTotals, StreamRunError<C::Error>> {
    let mut stream =
        TgStream::open(src, mem.data, mem.slots, mem.blocks).map_err(StreamRunError::Open)?;
    let (mut failed_before, mut read_before, mut marker) = (0, 0, false);
    let mut frame = |stream: &mut TgStream<'_>,
                     src: &mut C,
                     leg: Leg,
                     index: u32,
                     az_deg: u32|
     -> Result<StreamFrame, StreamRunError<C::Error>> {
        let cutoff = f32::from(leg.cutoff_px());
        let view = orbit_view(az_deg);
        let drawn: Drawn = if leg.passes() {
            render_stream_pass(
                stream,
                view,
                cutoff,
                &mut targets.streamed(),
                index == 0,
                &mut mark,
            )
        } else {
            render_stream_view(stream, view, cutoff, &mut targets.streamed(), &mut mark)
        }
        .map_err(StreamRunError::View)?;
        // A read that failed since the last frame (the card erred, or was pulled): the frame is
        // drawn with what is resident, and says so on screen.
        // The marker stays up from a failed read until reads succeed again with none failing (a
        // pulled card keeps it up; a frame that reads nothing keeps what the last one showed).
        // A block that arrived sealed but malformed counts as a failed read, and a frame that
        // refused descents into inconsistent blocks is marked as long as it does (issue 17).
        let c = stream.counters();
        let failed = c.read_errors + c.crc_errors + c.structure_errors - failed_before;
        let read_ok = c.bytes_read > read_before;
        (failed_before, read_before) = (failed_before + failed, c.bytes_read);
        marker = failed > 0 || stream.inconsistent() > 0 || (marker && !read_ok);
        let mut fb = pocketsplat_core::raster::Framebuffer::new(targets.color, targets.depth);
        // A refined frame's buffers carry over between its passes: the marker is not painted into
        // them (the line still says it), or it would stay in the frame.
        if marker && !leg.passes() {
            // The framebuffer's drawing cannot fail (`Infallible`).
            let _ = draw_error_marker(&mut fb);
        }
        let crc = fb.crc();
        // A pass before the last is not a whole frame: it misses at least its resume point.
        let missing = if leg.passes() && !stream.refined_done() {
            stream.missing().max(1)
        } else {
            stream.missing()
        };
        let budget = if leg.passes() {
            REFINE_IO_BUDGET_BYTES
        } else {
            IO_BUDGET_BYTES
        };
        let served = stream.serve(src, budget);
        let line = StreamFrame {
            leg,
            index,
            az_deg,
            crc,
            missing,
            failed,
            marker,
            read: served.bytes,
            prefetched: served.prefetched << stream.header().block_log2,
            splats: drawn.stats.splats,
            nodes: drawn.stats.nodes_visited,
        };
        report(&line);
        Ok(line)
    };
    for leg in Leg::ALL {
        if leg == Leg::Orbit {
            for k in 0..ORBIT_STEPS {
                frame(&mut stream, src, leg, k, k * ORBIT_STEP_DEG)?;
            }
            continue;
        }
        if leg.passes() {
            // Until the refined frame is complete, or while reads keep coming.
            let intact = |s: &TgStream<'_>| {
                let c = s.counters();
                c.reads - c.read_errors - c.crc_errors - c.structure_errors
            };
            let (mut index, mut idle) = (0, 0);
            loop {
                let before = intact(&stream);
                if frame(&mut stream, src, leg, index, 0)?.converged() {
                    break;
                }
                idle = if intact(&stream) == before {
                    idle + 1
                } else {
                    0
                };
                index += 1;
                if index >= MAX_PASSES || idle >= MAX_IDLE_PASSES {
                    break;
                }
            }
            continue;
        }
        // Until the frame misses nothing, or for MAX_CONVERGE_FRAMES: then the leg ends on what
        // is resident (its last line says what was missing).
        let mut index = 0;
        while !frame(&mut stream, src, leg, index, 0)?.converged() {
            index += 1;
            if index >= MAX_CONVERGE_FRAMES {
                break;
            }
        }
    }
    Ok(StreamTotals::of(
        stream.counters(),
        u64::from(stream.header().blocks) << stream.header().block_log2,
        stream.cache().capacity() as u32,
    ))
}

/// Blocks of a streamed `.qs` file in this sequence: 2 KB (fewer reads than an SD card's 512-byte
/// sectors), so that its deepest path
/// ([`QsStream::cache_need`](pocketsplat_core::stream::QsStream::cache_need)) fits the 64 KB cache.
#[cfg(feature = "qsplat")]
pub const QS_BLOCK_LOG2: u8 = 11;

/// Opens the `.qs` file on `src` over `mem` and draws its std view at 1 px in passes
/// ([`QsStream::render_pass`](pocketsplat_core::stream::QsStream::render_pass), [`Leg::QsPx1`],
/// one line per pass) until the refined frame is the resident file's, or for [`MAX_PASSES`] passes, or [`MAX_IDLE_PASSES`] passes that read nothing.
///
/// # Errors
/// As [`stream_frames`].
#[cfg(feature = "qsplat")]
pub fn qs_stream_frames<C: ChunkSource + ?Sized>(
    src: &mut C,
    mem: StreamMemory<'_>,
    targets: &mut Targets<'_>,
    mut mark: impl FnMut(Phase),
    mut report: impl FnMut(&StreamFrame),
) -> Result<StreamTotals, StreamRunError<C::Error>> {
    use pocketsplat_core::stream::QsStream;
    let mut stream = QsStream::open(src, QS_BLOCK_LOG2, mem.data, mem.slots, mem.blocks)
        .map_err(StreamRunError::Open)?;
    let leg = Leg::QsPx1;
    let (mut failed_before, mut idle) = (0, 0);
    for index in 0..MAX_PASSES {
        let drawn = crate::render_qs_stream_pass(
            &mut stream,
            orbit_view(0),
            f32::from(leg.cutoff_px()),
            &mut targets.streamed(),
            index == 0,
            &mut mark,
        )
        .map_err(StreamRunError::View)?;
        let c = *stream.counters();
        let failed = c.read_errors - failed_before;
        failed_before = c.read_errors;
        let crc = pocketsplat_core::raster::Framebuffer::new(targets.color, targets.depth).crc();
        let done = stream.refined_done();
        let missing = if done {
            stream.missing()
        } else {
            stream.missing().max(1)
        };
        let served = stream.serve(src, REFINE_IO_BUDGET_BYTES);
        let line = StreamFrame {
            leg,
            index,
            az_deg: 0,
            crc,
            missing,
            failed,
            marker: failed > 0 || stream.inconsistent() > 0,
            read: served.bytes,
            prefetched: served.prefetched << QS_BLOCK_LOG2,
            splats: drawn.stats.splats,
            nodes: drawn.stats.nodes_visited,
        };
        report(&line);
        if done {
            break;
        }
        idle = if served.reads > served.failed {
            0
        } else {
            idle + 1
        };
        if idle >= MAX_IDLE_PASSES {
            break;
        }
    }
    Ok(StreamTotals::of(
        stream.counters(),
        stream.file_len(),
        stream.cache().capacity() as u32,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stream_lines_round_trip() {
        let f = StreamFrame {
            leg: Leg::Orbit,
            index: 3,
            az_deg: 45,
            crc: 0xdead_beef,
            missing: 2,
            failed: 1,
            marker: true,
            read: 16384,
            prefetched: 0,
            splats: 10,
            nodes: 20,
        };
        let line = f.to_string();
        assert_eq!(
            line,
            "stream orbit 3 az 45 crc 0xdeadbeef missing 2 failed 1 marker 1 read 16384 prefetched 0 splats 10 nodes 20"
        );
        assert_eq!(StreamFrame::parse(&line), Some(f));
        assert_eq!(StreamFrame::parse(&format!("{line} x")), None);
        assert_eq!(StreamFrame::parse("stream total bytes 1"), None);
        assert_eq!(orbit_view(0), STANDARD_VIEWS[0].1);
    }

    #[test]
    fn the_error_marker_is_a_red_square_in_the_top_right_corner_and_nothing_else() {
        use crate::HEIGHT;
        let mut color = std::vec![[0u16; WIDTH]; HEIGHT];
        let mut depth = std::vec![[u16::MAX; WIDTH]; HEIGHT];
        let (c, d): (&mut [[u16; WIDTH]; HEIGHT], &mut [[u16; WIDTH]; HEIGHT]) = (
            (&mut color[..]).try_into().unwrap(),
            (&mut depth[..]).try_into().unwrap(),
        );
        let mut fb = pocketsplat_core::raster::Framebuffer::new(c, d);
        draw_error_marker(&mut fb).unwrap();
        let side = MARKER_PX as usize;
        for (y, row) in color.iter().enumerate() {
            for (x, &p) in row.iter().enumerate() {
                let inside =
                    (2..2 + side).contains(&y) && (WIDTH - side - 2..WIDTH - 2).contains(&x);
                assert_eq!(p, if inside { MARKER_COLOR } else { 0 }, "pixel ({x}, {y})");
            }
        }
    }
}
