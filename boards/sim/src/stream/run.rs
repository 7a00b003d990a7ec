//! The streaming frame loop on the desktop: memory for a [`TgStream`] or a [`QsStream`], one frame
//! drawn from what is resident, and `render --stream` (draw, serve the budget, repeat until a frame
//! misses nothing), the same loop for both formats ([`Streamed`]).

use anyhow::{bail, Context, Result};
use pocketsplat_core::camera::Camera;
use pocketsplat_core::camera::Sphere;
use pocketsplat_core::format::QS_MAGIC;
use pocketsplat_core::render::{render_qs_stream, render_stream, StreamPass};
use pocketsplat_core::shade::ShadingTable;
use pocketsplat_core::splat::Stats;
use pocketsplat_core::stream::{
    read_tg_header, table_entries, BlockEntry, ChunkSource, QsStream, ServeReport, SlotEntry,
    StreamCounters, StreamError, TgStream, QUEUE_CAPACITY,
};
use pocketsplat_core::tg::Header;

use crate::levels::Levels;
use crate::render::{FrameBuffers, Layers, Settings, ShadowMode, Tinted};

/// Largest block a `.tg` file has.
const MAX_BLOCK: usize = 1 << 16;

/// Heap memory for a [`TgStream`] (on a device these are statics sized for the scene).
#[derive(Debug)]
pub struct OwnedStream {
    /// The header, read once to size the rest.
    pub header: Header,
    data: Vec<u8>,
    slots: Vec<SlotEntry>,
    blocks: Vec<BlockEntry>,
    /// Blocks of the cache asked for (the memory may hold more, for opening).
    asked: usize,
}

/// A size as `--cache` takes it: `NM` or `NK` (rounded up), else bytes.
pub fn cache_arg(bytes: u64) -> String {
    if bytes >= 1 << 20 && bytes.is_multiple_of(1 << 20) {
        format!("{}M", bytes >> 20)
    } else if bytes >= 1024 {
        format!("{}K", bytes.div_ceil(1024))
    } else {
        bytes.to_string()
    }
}

/// The error of a cache smaller than the file needs: the cache given, and the one it needs.
fn too_small(cache_bytes: usize, block_size: usize, needed: u32) -> anyhow::Error {
    let need = u64::from(needed) * block_size as u64;
    anyhow::anyhow!(
        "--cache {} is too small for this file: a pass needs {needed} of its {block_size}-byte \
         blocks resident at once, so streaming it needs --cache {} or more (a smaller cache would \
         never finish the frame)",
        cache_arg(cache_bytes as u64),
        cache_arg(need.max(4096))
    )
}

impl OwnedStream {
    /// Reads the header of the `.tg` file on `src` and allocates a cache of `cache_bytes` (rounded
    /// down to whole blocks, at least 4 blocks) and its block table
    /// ([`table_entries`] of its slots).
    ///
    /// The block count is checked against the source first ([`read_tg_header`] against
    /// [`ChunkSource::byte_len`]; a source that does not know its length must answer a read of the
    /// last byte the header announces), so a header that declares more blocks than the source holds
    /// allocates nothing.
    ///
    /// # Errors
    /// When the header cannot be read or is invalid, announces more than the source holds, or
    /// claims a file over the `stream` limit.
    pub fn new<C: ChunkSource + ?Sized>(src: &mut C, cache_bytes: usize) -> Result<Self> {
        let mut scratch = vec![0u8; MAX_BLOCK];
        let (header, _, _) =
            read_tg_header(src, &mut scratch).map_err(|e| anyhow::anyhow!("{e}"))?;
        // What the header claims is bounded before anything is read by it.
        let claimed = u64::from(header.blocks) << header.block_log2;
        crate::limits::current().check("stream", "the file size its header claims", claimed)?;
        let bs = header.block_size();
        let expected = claimed;
        if src.byte_len().is_none() {
            let mut last = [0u8; 1];
            src.read_at(expected - 1, &mut last).map_err(|e| {
                anyhow::anyhow!(
                    "the header announces {} blocks ({expected} bytes), but the source cannot                      read byte {}: {e:?}",
                    header.blocks,
                    expected - 1
                )
            })?;
        }
        // Opening reads the head and brick table through a few slots, even when the cache asked
        // for is smaller than that: `open` then says what the file needs.
        let asked = cache_bytes / bs;
        let slots = asked.max(pocketsplat_core::stream::MIN_SLOTS);
        // Sized by `--cache`: asked for, so that a cache past the memory there is ends in an
        // error.
        let memory = || -> Result<Self> {
            Ok(Self {
                header,
                data: crate::memory::filled(0u8, slots * bs)?,
                slots: crate::memory::filled(SlotEntry::EMPTY, slots)?,
                blocks: crate::memory::filled(
                    BlockEntry::EMPTY,
                    table_entries(slots, QUEUE_CAPACITY),
                )?,
                asked,
            })
        };
        memory().context("cannot allocate the block cache and the table of blocks")
    }

    /// Opens the stream over this memory.
    ///
    /// # Errors
    /// When the header or the CRC table cannot be read, or the cache asked for is smaller than what
    /// a pass over this file needs at once (the message names the `--cache` it needs).
    pub fn open<C: ChunkSource + ?Sized>(&mut self, src: &mut C) -> Result<TgStream<'_>> {
        let asked = self.asked;
        let bs = self.header.block_size();
        let stream = TgStream::open(src, &mut self.data, &mut self.slots, &mut self.blocks)
            .map_err(|e| match e {
                StreamError::CacheTooSmall { needed, .. } => too_small(asked * bs, bs, needed),
                e => anyhow::anyhow!("{e}"),
            })?;
        if (asked as u64) < u64::from(stream.cache_need()) {
            return Err(too_small(asked * bs, bs, stream.cache_need()));
        }
        Ok(stream)
    }

    /// The fewest bytes of cache a stream of this file takes ([`TgStream::cache_need`] blocks),
    /// found by opening it through this memory (any size).
    ///
    /// # Errors
    /// When the header, CRC table or head cannot be read or is invalid.
    pub fn need_bytes<C: ChunkSource + ?Sized>(&mut self, src: &mut C) -> Result<usize> {
        let bs = self.header.block_size();
        let blocks = match TgStream::open(src, &mut self.data, &mut self.slots, &mut self.blocks) {
            Ok(s) => s.cache_need(),
            Err(StreamError::CacheTooSmall { needed, .. }) => needed,
            Err(e) => bail!("{e}"),
        };
        Ok(blocks as usize * bs)
    }

    /// Bytes of the cache.
    pub fn cache_bytes(&self) -> usize {
        self.data.len()
    }
}

/// Blocks of a streamed `.qs` file: 512 bytes, an SD card's sector (a sibling group is at most 28
/// bytes, so a group lies in one block or two).
pub const QS_BLOCK_LOG2: u8 = 9;

/// Heap memory for a [`QsStream`].
#[derive(Debug)]
pub struct OwnedQsStream {
    data: Vec<u8>,
    slots: Vec<SlotEntry>,
    blocks: Vec<BlockEntry>,
    /// Bytes in the file.
    pub file_len: u64,
}

impl OwnedQsStream {
    /// A cache of `cache_bytes` (whole 512-byte blocks) and its block table for the `.qs` file on
    /// `src`, whose length the source must know.
    ///
    /// # Errors
    /// When the source does not know the file's length, the file is over the `stream` limit, or
    /// the memory cannot be had.
    pub fn new<C: ChunkSource + ?Sized>(src: &mut C, cache_bytes: usize) -> Result<Self> {
        let file_len = src
            .byte_len()
            .context("the source does not say how long the file is (a .qs stream needs it)")?;
        crate::limits::current().check("stream", "the file size", file_len)?;
        let bs = 1usize << QS_BLOCK_LOG2;
        let slots = (cache_bytes / bs).max(pocketsplat_core::stream::MIN_SLOTS);
        let memory = || -> Result<Self> {
            Ok(Self {
                data: crate::memory::filled(0u8, slots * bs)?,
                slots: crate::memory::filled(SlotEntry::EMPTY, slots)?,
                blocks: crate::memory::filled(
                    BlockEntry::EMPTY,
                    table_entries(slots, QUEUE_CAPACITY),
                )?,
                file_len,
            })
        };
        memory().context("cannot allocate the block cache and the table of blocks")
    }

    /// Opens the stream over this memory.
    ///
    /// # Errors
    /// When a fragment header cannot be read or is invalid.
    pub fn open<C: ChunkSource + ?Sized>(&mut self, src: &mut C) -> Result<QsStream<'_>> {
        QsStream::open(
            src,
            QS_BLOCK_LOG2,
            &mut self.data,
            &mut self.slots,
            &mut self.blocks,
        )
        .map_err(|e| anyhow::anyhow!("{e}"))
    }
}

/// What the frame loop needs of a stream, whatever its format.
pub trait Streamed {
    /// The camera of `settings` for the stream's model.
    fn camera(&self, settings: &Settings) -> Camera;
    /// Draws a frame from what is resident, or a pass of a refined frame, into `out`.
    ///
    /// # Errors
    /// When the frame cannot be set up or asks for what streams do not draw (shadows).
    fn draw(
        &mut self,
        cam: &Camera,
        settings: &Settings,
        table: &mut ShadingTable<1>,
        out: &mut FrameBuffers,
        pass: StreamPass,
    ) -> Result<Stats>;
    /// Reads what the last frame asked for, within `budget` bytes.
    fn serve<C: ChunkSource + ?Sized>(&mut self, src: &mut C, budget: u32) -> ServeReport;
    /// Whether the last frame missed nothing.
    fn converged(&self) -> bool;
    /// Whether the last pass finished its refined frame.
    fn refined_done(&self) -> bool;
    /// Passes of the refined frame.
    fn passes(&self) -> u32;
    /// Blocks the last frame used and queued.
    fn working_set(&self) -> u32;
    /// Blocks the cache (or caches) hold, and how many are resident.
    fn cache_blocks(&self) -> (usize, usize);
    /// Cumulative counts.
    fn stream_counters(&self) -> StreamCounters;
    /// What the last frame missed.
    fn missing(&self) -> u32;
    /// Descents the last frame refused as malformed.
    fn inconsistent(&self) -> u32;
    /// The fewest blocks the cache must hold.
    fn cache_need(&self) -> u32;
    /// What a refused descent of this format means, for the error that says the file is
    /// malformed.
    fn refused_means(&self) -> &'static str;
}

impl Streamed for TgStream<'_> {
    fn camera(&self, settings: &Settings) -> Camera {
        camera_for(self, settings)
    }
    fn draw(
        &mut self,
        cam: &Camera,
        settings: &Settings,
        table: &mut ShadingTable<1>,
        out: &mut FrameBuffers,
        pass: StreamPass,
    ) -> Result<Stats> {
        draw(self, cam, settings, table, out, pass)
    }
    fn serve<C: ChunkSource + ?Sized>(&mut self, src: &mut C, budget: u32) -> ServeReport {
        TgStream::serve(self, src, budget)
    }
    fn converged(&self) -> bool {
        TgStream::converged(self)
    }
    fn refined_done(&self) -> bool {
        TgStream::refined_done(self)
    }
    fn passes(&self) -> u32 {
        TgStream::passes(self)
    }
    fn working_set(&self) -> u32 {
        TgStream::working_set(self)
    }
    fn cache_blocks(&self) -> (usize, usize) {
        (self.cache().capacity(), self.cache().resident())
    }
    fn stream_counters(&self) -> StreamCounters {
        *self.counters()
    }
    fn missing(&self) -> u32 {
        TgStream::missing(self)
    }
    fn inconsistent(&self) -> u32 {
        TgStream::inconsistent(self)
    }
    fn cache_need(&self) -> u32 {
        TgStream::cache_need(self)
    }
    fn refused_means(&self) -> &'static str {
        "children outside their level, sibling groups that overlap, run backwards or do not add up"
    }
}

impl Streamed for QsStream<'_> {
    fn camera(&self, settings: &Settings) -> Camera {
        settings.camera(Sphere::from_bounds(self.bounds()))
    }
    fn draw(
        &mut self,
        cam: &Camera,
        settings: &Settings,
        table: &mut ShadingTable<1>,
        out: &mut FrameBuffers,
        pass: StreamPass,
    ) -> Result<Stats> {
        if settings.shadows != ShadowMode::Off {
            bail!("a .qs file has no shadows");
        }
        let options = settings.render_options(None);
        let levels = settings
            .color_by_level
            .then(|| Levels::of_stream(settings.cutoff_px));
        let mut layer = match &levels {
            Some(l) => Layers::Tinted(Tinted(l)),
            None => Layers::Direct,
        };
        let mut target = out.target(table, None);
        let drawn = render_qs_stream(self, cam, &options, &mut target, pass, &mut layer, |_| {})
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        Ok(drawn.stats)
    }
    fn serve<C: ChunkSource + ?Sized>(&mut self, src: &mut C, budget: u32) -> ServeReport {
        QsStream::serve(self, src, budget)
    }
    fn converged(&self) -> bool {
        QsStream::converged(self)
    }
    fn refined_done(&self) -> bool {
        QsStream::refined_done(self)
    }
    fn passes(&self) -> u32 {
        QsStream::passes(self)
    }
    fn working_set(&self) -> u32 {
        QsStream::working_set(self)
    }
    fn cache_blocks(&self) -> (usize, usize) {
        (self.cache().capacity(), self.cache().resident())
    }
    fn stream_counters(&self) -> StreamCounters {
        *self.counters()
    }
    fn missing(&self) -> u32 {
        QsStream::missing(self)
    }
    fn inconsistent(&self) -> u32 {
        QsStream::inconsistent(self)
    }
    fn cache_need(&self) -> u32 {
        QsStream::cache_need(self)
    }
    fn refused_means(&self) -> &'static str {
        "sibling groups outside their fragment, out of breadth-first order, or with child counts, \
         sphere indices or pointers the format does not allow"
    }
}

/// The camera of `settings` for the stream's model.
pub fn camera_for(stream: &TgStream<'_>, settings: &Settings) -> Camera {
    settings.camera(stream.header().bounds64)
}

/// A streamed frame or pass through the core's pipeline ([`render_stream`]), tinted by level when
/// the settings ask.
fn draw(
    stream: &mut TgStream<'_>,
    cam: &Camera,
    settings: &Settings,
    table: &mut ShadingTable<1>,
    out: &mut FrameBuffers,
    pass: StreamPass,
) -> Result<Stats> {
    if settings.shadows != ShadowMode::Off {
        bail!("--stream draws without shadows for now");
    }
    let options = settings.render_options(None);
    let levels = settings
        .color_by_level
        .then(|| Levels::of_grid(stream.header().depth));
    let mut layer = match &levels {
        Some(l) => Layers::Tinted(Tinted(l)),
        None => Layers::Direct,
    };
    let mut target = out.target(table, None);
    let drawn = render_stream(stream, cam, &options, &mut target, pass, &mut layer, |_| {})
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    Ok(drawn.stats)
}

/// How `render --stream` reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StreamOptions {
    /// Bytes read per frame at most (rounded up to one block).
    pub io_budget: u32,
    /// Bytes of block cache.
    pub cache_bytes: usize,
    /// Give up after this many frames.
    pub max_frames: u32,
    /// An HTTP source's deadline per request ([`super::http::REQUEST_DEADLINE`]).
    pub request_deadline: std::time::Duration,
    /// An HTTP source's deadline per frame, and for opening the stream
    /// ([`super::http::FRAME_DEADLINE`]).
    pub frame_deadline: std::time::Duration,
}

impl Default for StreamOptions {
    fn default() -> Self {
        Self {
            io_budget: 64 * 1024,
            cache_bytes: 16 << 20,
            max_frames: 100_000,
            request_deadline: super::http::REQUEST_DEADLINE,
            frame_deadline: super::http::FRAME_DEADLINE,
        }
    }
}

/// What a streamed render did.
#[derive(Clone, Debug, Default)]
pub struct StreamOutcome {
    /// Frames drawn, the converged one included.
    pub frames: u32,
    /// The stream's counts (header and CRC table reads included).
    pub counters: StreamCounters,
    /// What each frame's serve read.
    pub per_frame: Vec<ServeReport>,
    /// Traversal counts of the final frame.
    pub stats: Stats,
    /// Bytes in the file.
    pub file_bytes: u64,
    /// Blocks resident at the end, and the cache's capacity.
    pub resident_blocks: usize,
    /// Capacity of the cache, blocks.
    pub cache_blocks: usize,
    /// Passes of the refined frame, when it needed more blocks than the cache holds (0: the last
    /// frame was drawn whole).
    pub passes: u32,
    /// Blocks and bytes read while drawing the refined frame in passes.
    pub refined_reads: u32,
    /// Bytes of those reads.
    pub refined_bytes: u64,
}

/// Streams the `.tg` on `src` with a fixed camera until a frame misses nothing, leaving that frame
/// (the one the resident file gives) in `out`.
///
/// # Errors
/// When the header or CRC table cannot be read, the frame cannot be set up, or it does not
/// converge within `opts.max_frames` (a block that keeps failing).
pub fn stream_render<C: ChunkSource + ?Sized>(
    src: &mut C,
    settings: &Settings,
    opts: &StreamOptions,
    out: &mut FrameBuffers,
) -> Result<StreamOutcome> {
    stream_render_with(src, settings, opts, out, |_| Ok(()))
}

/// [`stream_render`] with `before_serve` called before each frame's reads: a source's own frame
/// bookkeeping (an HTTP source's deadline per frame), and a way to stop with its error where
/// retrying cannot help.
///
/// # Errors
/// As [`stream_render`], and `before_serve`'s.
pub fn stream_render_with<C: ChunkSource + ?Sized>(
    src: &mut C,
    settings: &Settings,
    opts: &StreamOptions,
    out: &mut FrameBuffers,
    before_serve: impl FnMut(&mut C) -> Result<()>,
) -> Result<StreamOutcome> {
    // A `.tg` file by its header, else a `.qs` file by its magic (read only then: a `.tg`
    // stream reads nothing more than before).
    let mut mem = match OwnedStream::new(src, opts.cache_bytes) {
        Ok(mem) => mem,
        Err(e) => {
            let mut magic = [0u8; 8];
            if src.read_at(0, &mut magic).is_err() || magic != QS_MAGIC {
                return Err(e);
            }
            let mut mem = OwnedQsStream::new(src, opts.cache_bytes)?;
            let file_bytes = mem.file_len;
            let mut stream = mem.open(src)?;
            let bs = stream.block_size();
            return converge(
                &mut stream,
                src,
                settings,
                opts,
                out,
                before_serve,
                file_bytes,
                bs,
            );
        }
    };
    let file_bytes = u64::from(mem.header.blocks) << mem.header.block_log2;
    let bs = mem.header.block_size();
    let mut stream = mem.open(src)?;
    converge(
        &mut stream,
        src,
        settings,
        opts,
        out,
        before_serve,
        file_bytes,
        bs,
    )
}

/// Draws one frame from what is resident into `out` (cleared first), queueing what is missing.
///
/// # Errors
/// When the frame cannot be set up, or shadows are asked for (not streamed yet).
pub fn stream_frame<T: Streamed>(
    stream: &mut T,
    cam: &Camera,
    settings: &Settings,
    table: &mut ShadingTable<1>,
    out: &mut FrameBuffers,
) -> Result<Stats> {
    stream.draw(cam, settings, table, out, StreamPass::Frame)
}

/// Draws the next pass of a refined frame into `out`, which is cleared only for the first pass
/// (`first`): the passes' splats meet in one colour and depth buffer.
///
/// # Errors
/// As [`stream_frame`].
pub fn stream_pass<T: Streamed>(
    stream: &mut T,
    cam: &Camera,
    settings: &Settings,
    table: &mut ShadingTable<1>,
    out: &mut FrameBuffers,
    first: bool,
) -> Result<Stats> {
    let pass = if first {
        StreamPass::FirstPass
    } else {
        StreamPass::NextPass
    };
    stream.draw(cam, settings, table, out, pass)
}

/// The frame loop of [`stream_render_with`] over an open stream of either format.
#[allow(clippy::too_many_arguments)]
pub(crate) fn converge<T: Streamed, C: ChunkSource + ?Sized>(
    stream: &mut T,
    src: &mut C,
    settings: &Settings,
    opts: &StreamOptions,
    out: &mut FrameBuffers,
    mut before_serve: impl FnMut(&mut C) -> Result<()>,
    file_bytes: u64,
    mem_block_size: usize,
) -> Result<StreamOutcome> {
    let cam = stream.camera(settings);
    let mut table = Box::new(ShadingTable::<1>::new());
    let mut outcome = StreamOutcome {
        file_bytes,
        ..StreamOutcome::default()
    };
    // Progressive frames until one converges, or until a frame needs more blocks than the cache
    // holds: then the refined frame is drawn in passes over its walk (the depth buffer persists).
    let mut refining = false;
    let mut first_pass = false;
    let mut at_refine = StreamCounters::default();
    loop {
        if refining {
            let s = stream_pass(stream, &cam, settings, &mut table, out, first_pass)?;
            first_pass = false;
            outcome.stats.nodes_visited += s.nodes_visited;
            outcome.stats.splats += s.splats;
            outcome.stats.max_level = outcome.stats.max_level.max(s.max_level);
            outcome.passes = stream.passes();
        } else {
            outcome.stats = stream_frame(stream, &cam, settings, &mut table, out)?;
        }
        outcome.frames += 1;
        if stream.converged() && (!refining || stream.refined_done()) {
            break;
        }
        // Frames drawn whole converge only while the cache keeps everything they read: once it
        // evicts (it is full) they may take turns evicting what the next one needs, so the frame
        // goes on in passes, which converge through any cache `open` accepted.
        if !refining
            && (stream.working_set() as usize > stream.cache_blocks().0
                || stream.stream_counters().evictions > 0)
        {
            refining = true;
            first_pass = true;
            at_refine = stream.stream_counters();
            outcome.stats = Stats::default();
            continue;
        }
        // A block that passed its CRC holds what the file holds: one that fails the structure
        // check, or resident blocks that disagree, fail the same way on every later frame. This
        // frame needs them (a converged one would have stopped above), so it never converges.
        let c = stream.stream_counters();
        if c.structure_errors > 0 || stream.inconsistent() > 0 {
            let mut why = Vec::new();
            if c.structure_errors > 0 {
                why.push(format!(
                    "{} blocks failed the structure check (child masks or sibling-group pointers \
                     the format does not allow)",
                    c.structure_errors
                ));
            }
            if stream.inconsistent() > 0 {
                why.push(format!(
                    "frame {} refused {} descents into blocks that disagree ({})",
                    outcome.frames,
                    stream.inconsistent(),
                    stream.refused_means()
                ));
            }
            bail!(
                "the file is malformed: {}; nothing was written (`pocketsplat info` on the whole \
                 file names the first fault)",
                why.join(", and ")
            );
        }
        if outcome.frames >= opts.max_frames {
            bail!(
                "did not converge in {} frames: {} blocks still missing ({} read errors, {} CRC failures)",
                outcome.frames,
                stream.missing(),
                c.read_errors,
                c.crc_errors
            );
        }
        before_serve(src)?;
        let r = stream.serve(src, opts.io_budget);
        outcome.per_frame.push(r);
        if r.no_room > 0 && r.reads == 0 {
            // The cache gave no slot for what this frame needs, and nothing else was read: the
            // next frame would be this one again. A frame drawn whole goes on in passes; a pass
            // that cannot go on stops here, naming the cache (`open` accepted it: the need it
            // worked out was too low, which is a bug).
            if !refining {
                refining = true;
                first_pass = true;
                at_refine = stream.stream_counters();
                outcome.stats = Stats::default();
                continue;
            }
            let bs = mem_block_size;
            let need = stream.cache_need();
            let capacity = stream.cache_blocks().0;
            if need as usize > capacity {
                // Known as the walk goes down (a `.qs` file says nothing of its depth up front).
                return Err(too_small(capacity * bs, bs, need));
            }
            bail!(
                "a pass found no room in the cache of {} blocks ({} bytes) for the {} blocks it \
                 needs next, so the frame cannot be finished; this file was taken to need {} \
                 blocks (a bug in that bound): try a larger --cache",
                capacity,
                capacity * bs,
                r.no_room,
                stream.cache_need()
            );
        }
    }
    outcome.counters = stream.stream_counters();
    if refining {
        outcome.refined_reads = outcome.counters.reads - at_refine.reads;
        outcome.refined_bytes = outcome.counters.bytes_read - at_refine.bytes_read;
    }
    (outcome.cache_blocks, outcome.resident_blocks) = stream.cache_blocks();
    Ok(outcome)
}
