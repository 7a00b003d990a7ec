//! Streaming a `.tg` file: draw what is resident, queue what is missing, read the best of it within
//! a budget per frame (Streaming QSplat §3, Fig. 3).

use core::cell::Cell;

use heapless::Vec;

use super::cache::{BlockCache, BlockEntry, SlotEntry, NOT_QUEUED, NO_SLOT};
use super::{ChunkSource, StreamError};
use crate::crc::crc32;
use crate::splat::{SampleSplat, SplatSink, Stats};
use crate::tg::read::{check_block, check_counts, parse_header, Header, LevelDir};
use crate::tg::traverse::{render_nodes, NoShadows, NodeData, ShadowHooks};
use crate::tg::{TgError, TgFrame, DIRECTORY_ENTRY, DIRECTORY_OFFSET, MAX_LEVELS};

/// Requests one frame may queue; further ones replace the lowest or are dropped (and counted).
pub const QUEUE_CAPACITY: usize = 256;
/// Attempts at the header and at each CRC-table block when opening.
pub const OPEN_ATTEMPTS: u32 = 8;
/// Smallest block a `.tg` file has (the header's own block size is read from its first 512 bytes).
const MIN_BLOCK: usize = 512;
/// Longest backoff after repeated failures, frames.
const MAX_BACKOFF: u32 = 64;
/// Priority of the root's own blocks: before anything else.
const ROOT_PRIORITY: u32 = u32::MAX;
/// Descents a pass walks past the place it stops, looking for the blocks the next passes need.
const LOOKAHEAD_DESCENTS: u32 = 1 << 13;

/// Splat size class: ⌊log_√2 size⌋ of the diameter in Q8 pixels (Streaming QSplat §4.2 uses
/// k = √2: each class holds about twice the nodes of the one above).
pub fn size_class(size_q8: i32) -> u32 {
    let s = size_q8.max(1) as u32;
    let l = 31 - s.leading_zeros();
    let half = u64::from(s) * u64::from(s) >= 1u64 << (2 * l + 1);
    2 * l + u32::from(half)
}

/// Streaming QSplat's priority (§4.2), larger first: the size class, then the screen row from the
/// top, so that the model refines in top-to-bottom sweeps of decreasing splat size.
pub fn stream_priority(size_q8: i32, y_q8: i32) -> u32 {
    let row = (y_q8 >> crate::fixed::SUBPIXEL_BITS).clamp(0, 0xFFFF) as u32;
    size_class(size_q8) << 16 | (0xFFFF - row)
}

/// Reads and checks the header block of a `.tg` file through `scratch` (at least one block; 64 KB
/// covers every block size), trying [`OPEN_ATTEMPTS`] times. Returns the header, the level
/// directory and the number of failed attempts.
///
/// A header that parses is then checked against the medium and itself, at once (a sealed header
/// reads the same every time): its block count against [`ChunkSource::byte_len`] where the medium
/// knows it ([`TgError::LengthMismatch`]), and its level counts against each other
/// ([`crate::tg::read::check_counts`]), before anything is sized by them.
///
/// # Errors
/// The last failure when every attempt failed: [`StreamError::Device`] for the medium,
/// [`StreamError::Format`] for the header, [`StreamError::CacheTooSmall`] when `scratch` is smaller
/// than the file's blocks.
pub fn read_tg_header<C: ChunkSource + ?Sized>(
    src: &mut C,
    scratch: &mut [u8],
) -> Result<(Header, [LevelDir; MAX_LEVELS], u32), StreamError<C::Error>> {
    let mut last = StreamError::Format(TgError::TooShort(0));
    for attempt in 0..OPEN_ATTEMPTS {
        match try_header(src, scratch) {
            Ok((h, d)) => {
                // Bound what the header sizes (the block table, the walk) by the source before
                // anything is allocated from it: a header that parses is sealed, so these faults
                // do not go away on a second read.
                let expected = u64::from(h.blocks) << h.block_log2;
                if let Some(found) = src.byte_len().filter(|&n| n != expected) {
                    return Err(StreamError::Format(TgError::LengthMismatch {
                        expected,
                        found,
                    }));
                }
                check_counts(&h, &d).map_err(StreamError::Format)?;
                return Ok((h, d, attempt));
            }
            Err(e @ StreamError::CacheTooSmall { .. }) => return Err(e),
            Err(e) => last = e,
        }
    }
    Err(last)
}

fn try_header<C: ChunkSource + ?Sized>(
    src: &mut C,
    scratch: &mut [u8],
) -> Result<(Header, [LevelDir; MAX_LEVELS]), StreamError<C::Error>> {
    let too_small = |bs: usize| StreamError::CacheTooSmall {
        block_size: bs as u32,
        slots: 0,
    };
    let first = scratch.get_mut(..MIN_BLOCK).ok_or(too_small(MIN_BLOCK))?;
    src.read_at(0, first).map_err(StreamError::Device)?;
    let log2 = first[12];
    if !crate::tg::BLOCK_LOG2_RANGE.contains(&log2) {
        // Let the parser name the first thing wrong (magic, version, block size).
        return Err(StreamError::Format(
            parse_header(first).err().unwrap_or(TgError::BlockCrc(0)),
        ));
    }
    let bs = 1usize << log2;
    let block = scratch.get_mut(..bs).ok_or(too_small(bs))?;
    if bs > MIN_BLOCK {
        src.read_at(MIN_BLOCK as u64, &mut block[MIN_BLOCK..])
            .map_err(StreamError::Device)?;
    }
    parse_header(block).map_err(StreamError::Format)
}

/// Cumulative counts of a stream: what was read, what failed, what was evicted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StreamCounters {
    /// Frames rendered.
    pub frames: u32,
    /// Block reads issued (header and CRC table included).
    pub reads: u32,
    /// Bytes those reads asked for.
    pub bytes_read: u64,
    /// Reads the medium failed.
    pub read_errors: u32,
    /// Blocks that arrived but failed their CRC.
    pub crc_errors: u32,
    /// Blocks that passed their CRC but not the structure check ([`check_block`]): absent, as if
    /// damaged.
    pub structure_errors: u32,
    /// Descents the walk refused because what it read from several resident blocks disagrees
    /// (children outside their level, sibling groups that overlap or run backwards, more nodes than
    /// the file holds): the cell is drawn instead, and the frame does not converge.
    pub inconsistent: u32,
    /// Blocks evicted to make room.
    pub evictions: u32,
    /// Blocks read by prefetch (nothing visible was missing).
    pub prefetched: u32,
    /// Requests dropped because the queue was full.
    pub dropped: u32,
}

/// What one [`TgStream::serve`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ServeReport {
    /// Block reads issued.
    pub reads: u32,
    /// Bytes read.
    pub bytes: u32,
    /// Reads that failed or arrived damaged (CRC or structure).
    pub failed: u32,
    /// Reads that were prefetches.
    pub prefetched: u32,
}

#[derive(Clone, Copy, Debug)]
struct Request {
    priority: u32,
    block: u32,
}

/// Byte offsets and counts of one level's arrays.
#[derive(Clone, Copy, Debug, Default)]
struct Level {
    count: u32,
    attr: u64,
    mask: u64,
    group: u64,
}

/// A `.tg` file being streamed: header, level directory, block cache and request queue.
#[derive(Debug)]
pub struct TgStream<'a> {
    header: Header,
    dirs: [LevelDir; MAX_LEVELS],
    levels: [Level; MAX_LEVELS],
    /// Samples in the file: the most nodes a frame may visit (FORMAT.md: one visit per sample).
    samples: u64,
    cache: BlockCache<'a>,
    queue: Vec<Request, QUEUE_CAPACITY>,
    /// Blocks the last frame wanted (queued or dropped) plus the descents it refused as
    /// inconsistent: 0 means it was drawn at full detail.
    missing: u32,
    /// Descents the last frame refused as inconsistent.
    inconsistent: u32,
    frame: u32,
    counters: StreamCounters,
    /// Blocks of the pinned (never evicted) coarse levels.
    pinned_blocks: u32,
    /// The refined frame being drawn in passes ([`TgStream::render_pass`]).
    refine: Refine,
    /// Whether the last frame was a pass: [`TgStream::serve`] then reads in block order.
    passing: bool,
}

/// Where a refined frame drawn in passes stands: the cell the last pass stopped at (the path of
/// indices from the root to it), or the frame's start.
#[derive(Clone, Copy, Debug)]
struct Refine {
    /// Indices of the cursor's ancestors and itself, per level `0..=level`.
    path: [u32; MAX_LEVELS],
    /// Level of the cursor; `None`: the frame starts from the root.
    level: Option<u8>,
    /// Passes drawn of this refined frame.
    passes: u32,
    /// Whether the last pass drew the rest of the frame (nothing it needed was absent).
    done: bool,
}

impl Refine {
    const START: Self = Self {
        path: [0; MAX_LEVELS],
        level: None,
        passes: 0,
        done: false,
    };
}

/// What a pass does at this point of its walk.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    /// A frame drawn whole from what is resident, coarser where blocks are absent.
    Progressive,
    /// A pass before its first absent block: skip what earlier passes drew, draw the rest.
    Draw,
    /// After the first absent block: draw nothing more, walk on through resident blocks to queue
    /// the next ones the frame needs, in file order.
    Lookahead,
    /// Enough is queued: leave the rest of the frame alone.
    Done,
}

/// A sink that draws only while a pass has drawn nothing out of order yet.
struct PassSink<'a, S> {
    inner: &'a mut S,
    drawing: &'a Cell<bool>,
}

impl<S: SplatSink> SplatSink for PassSink<'_, S> {
    #[inline(always)]
    fn splat(&mut self, s: &SampleSplat) {
        if self.drawing.get() {
            self.inner.splat(s);
        }
    }
    #[inline(always)]
    fn pixel(&mut self, s: &SampleSplat, x: i32, y: i32) {
        if self.drawing.get() {
            self.inner.pixel(s, x, y);
        }
    }
}

impl<'a> TgStream<'a> {
    /// Opens a `.tg` file on `src`: reads its header and CRC table (retrying each read), and sets up
    /// a cache of `data.len() / block_size` blocks (at most `slots.len()`) and a table of `blocks`
    /// (one entry per block of the file). Memory is the caller's: statics on a device.
    ///
    /// # Errors
    /// A [`StreamError`]: the header or CRC table could not be read or is invalid, or the memory
    /// given is too small for this file.
    pub fn open<C: ChunkSource + ?Sized>(
        src: &mut C,
        data: &'a mut [u8],
        slots: &'a mut [SlotEntry],
        blocks: &'a mut [BlockEntry],
    ) -> Result<Self, StreamError<C::Error>> {
        let (header, dirs, header_fails) = read_tg_header(src, data)?;
        let nblocks = header.blocks as usize;
        let bs = header.block_size();
        if blocks.len() < nblocks {
            return Err(StreamError::TooManyBlocks {
                blocks: header.blocks,
                capacity: blocks.len() as u32,
            });
        }
        let slots_avail = (data.len() / bs).min(slots.len()) as u32;
        let cache = BlockCache::new(header.block_log2, data, slots, &mut blocks[..nblocks]).ok_or(
            StreamError::CacheTooSmall {
                block_size: bs as u32,
                slots: slots_avail,
            },
        )?;
        let mut levels = [Level::default(); MAX_LEVELS];
        for (l, d) in levels.iter_mut().zip(&dirs) {
            *l = Level {
                count: d.count,
                attr: u64::from(d.attr_off),
                mask: u64::from(d.mask_off),
                group: u64::from(d.group_off),
            };
        }
        let mut s = TgStream {
            header,
            dirs,
            levels,
            samples: dirs.iter().map(|d| u64::from(d.count)).sum(),
            inconsistent: 0,
            cache,
            queue: Vec::new(),
            missing: 1,
            frame: 0,
            counters: StreamCounters::default(),
            pinned_blocks: 0,
            refine: Refine::START,
            passing: false,
        };
        s.counters.reads = header_fails + 1;
        s.counters.bytes_read = (u64::from(header_fails) + 1) * bs as u64;
        s.load_crc_table(src)?;
        s.classify(&dirs);
        Ok(s)
    }

    /// Reads each CRC-table block into slot 1 (as scratch; block 0 is still in slot 0, where
    /// [`read_tg_header`] read it), checks it against the header's list and copies the CRCs into the
    /// block table, so that the table itself never occupies the cache.
    fn load_crc_table<C: ChunkSource + ?Sized>(
        &mut self,
        src: &mut C,
    ) -> Result<(), StreamError<C::Error>> {
        let h = self.header;
        let bs = h.block_size();
        // parse_header checked that the list lies inside block 0.
        let list_at = DIRECTORY_OFFSET + DIRECTORY_ENTRY * h.levels();
        let per_table = bs / 4;
        for t in 1..=h.crc_table_blocks as usize {
            let at = list_at + 4 * (t - 1);
            let w = &self.cache.data[at..at + 4];
            let want = u32::from_le_bytes([w[0], w[1], w[2], w[3]]);
            let mut last = StreamError::Format(TgError::BlockCrc(t as u32));
            let mut ok = false;
            for _ in 0..OPEN_ATTEMPTS {
                self.counters.reads += 1;
                self.counters.bytes_read += bs as u64;
                let buf = self.cache.slot_bytes(1);
                match src.read_at((t * bs) as u64, buf) {
                    Err(e) => {
                        self.counters.read_errors += 1;
                        last = StreamError::Device(e);
                    }
                    Ok(()) if crc32(buf) != want => {
                        self.counters.crc_errors += 1;
                        last = StreamError::Format(TgError::BlockCrc(t as u32));
                    }
                    Ok(()) => {
                        ok = true;
                        break;
                    }
                }
            }
            if !ok {
                return Err(last);
            }
            let first = (t - 1) * per_table;
            for k in 0..per_table {
                let w = &self.cache.data[bs + 4 * k..bs + 4 * k + 4];
                let crc = u32::from_le_bytes([w[0], w[1], w[2], w[3]]);
                if let Some(e) = self.cache.blocks.get_mut(first + k) {
                    e.crc = crc;
                }
            }
        }
        Ok(())
    }

    /// Gives each data block its class (the coarsest level with data in it), and pins the coarsest
    /// levels that fit in half the cache.
    fn classify(&mut self, dirs: &[LevelDir; MAX_LEVELS]) {
        let h = self.header;
        let log2 = h.block_log2;
        let mb = u64::from(h.mask_bytes());
        let mut level_end = [0u64; MAX_LEVELS];
        for (l, d) in dirs.iter().enumerate().take(h.levels()) {
            let n = u64::from(d.count);
            let ends = [
                (d.attr_off, 2),
                (d.color_off, 2),
                (d.mask_off, mb),
                (d.group_off, 4),
            ]
            .map(|(off, size)| {
                if off == 0 {
                    0
                } else {
                    u64::from(off) + n * size
                }
            });
            level_end[l] = ends.into_iter().max().unwrap_or(0);
        }
        let first_data = h.crc_table_blocks as usize + 1;
        for (b, e) in self.cache.blocks.iter_mut().enumerate().skip(first_data) {
            let start = (b as u64) << log2;
            e.class = (0..h.levels())
                .find(|&l| level_end[l] > start)
                .unwrap_or(usize::from(h.depth)) as u8;
        }
        // Pin levels 0..=p while the blocks up to the end of level p fill at most half the cache.
        let half = self.cache.capacity() / 2;
        self.cache.pinned = -1;
        for (l, &end) in level_end.iter().enumerate().take(h.levels()) {
            let last = end.saturating_sub(1) >> log2;
            let count = (last + 1).saturating_sub(first_data as u64);
            if count as usize > half {
                break;
            }
            self.cache.pinned = l as i16;
            self.pinned_blocks = count as u32;
        }
    }

    /// The header.
    pub fn header(&self) -> &Header {
        &self.header
    }

    /// The block cache.
    pub fn cache(&self) -> &BlockCache<'a> {
        &self.cache
    }

    /// Cumulative counts.
    pub fn counters(&self) -> &StreamCounters {
        &self.counters
    }

    /// Blocks the last frame found missing (0: it was drawn as the resident file would be).
    pub fn missing(&self) -> u32 {
        self.missing
    }

    /// Descents the last frame refused because resident blocks disagree (see
    /// [`StreamCounters::inconsistent`]); such a frame never counts as converged.
    pub fn inconsistent(&self) -> u32 {
        self.inconsistent
    }

    /// Whether the last frame was drawn at full detail: nothing it wanted was absent, so it is the
    /// frame the fully resident file gives.
    pub fn converged(&self) -> bool {
        self.missing == 0 && self.counters.frames > 0
    }

    /// Draws one frame from the resident blocks into `sink`, queueing the missing ones; the queue
    /// of the previous frame is cleared first (§3.4).
    pub fn render<S: SplatSink>(&mut self, frame: &TgFrame, sink: &mut S) -> Stats {
        self.render_with(frame, &mut NoShadows, sink)
    }

    /// [`TgStream::render`] with shadow hooks.
    pub fn render_with<S: SplatSink, H: ShadowHooks>(
        &mut self,
        frame: &TgFrame,
        hooks: &mut H,
        sink: &mut S,
    ) -> Stats {
        let drawing = Cell::new(true);
        self.walk(frame, hooks, sink, Phase::Progressive, &drawing)
    }

    /// Starts a refined frame drawn in passes ([`TgStream::render_pass`]): the next pass begins at
    /// the root. The caller clears its framebuffer once, here, not between passes.
    pub fn begin_refined(&mut self) {
        self.refine = Refine::START;
    }

    /// Draws the next pass of a refined frame into `sink`, whose colour and depth persist between
    /// passes: a frame that needs more blocks than the cache holds is drawn as consecutive runs of
    /// its depth-first walk, so that, once [`TgStream::refined_done`], the framebuffer holds exactly
    /// the frame of the resident file (every splat drawn once, in the resident order).
    ///
    /// A pass skips the subtrees earlier passes drew, draws until the first descent whose blocks
    /// are absent, and stops drawing there (that cell is where the next pass resumes); it then walks
    /// on through resident blocks, queueing the absent ones it meets, until what it touched and
    /// queued would fill the unpinned cache. [`TgStream::serve`] then reads the queue in ascending
    /// block order (the resume point's blocks first), each block about once per refined frame.
    /// The walk never descends where resident blocks disagree (drawn coarser, as in
    /// [`TgStream::render`], and the frame does not converge).
    pub fn render_pass<S: SplatSink>(&mut self, frame: &TgFrame, sink: &mut S) -> Stats {
        let drawing = Cell::new(true);
        let mut pass = PassSink {
            inner: sink,
            drawing: &drawing,
        };
        self.refine.passes += 1;
        self.walk(frame, &mut NoShadows, &mut pass, Phase::Draw, &drawing)
    }

    /// Whether the last [`TgStream::render_pass`] finished its refined frame.
    pub fn refined_done(&self) -> bool {
        self.refine.done
    }

    /// Passes drawn of the current refined frame.
    pub fn passes(&self) -> u32 {
        self.refine.passes
    }

    /// Blocks the last frame (or pass) used that the eviction policy keeps for it, unpinned, plus
    /// those it queued: more than the cache holds means the frame cannot be drawn whole from the
    /// cache, and needs [`TgStream::render_pass`].
    pub fn working_set(&self) -> u32 {
        let used = self
            .cache
            .slots
            .iter()
            .filter(|e| e.used == self.frame && e.block != super::cache::NO_BLOCK)
            .count() as u32;
        used + self.queue.len() as u32
    }

    fn walk<S: SplatSink, H: ShadowHooks>(
        &mut self,
        frame: &TgFrame,
        hooks: &mut H,
        sink: &mut S,
        phase: Phase,
        drawing: &Cell<bool>,
    ) -> Stats {
        self.frame = self.frame.wrapping_add(1).max(1);
        self.counters.frames += 1;
        self.passing = phase != Phase::Progressive;
        for r in &self.queue {
            if let Some(e) = self.cache.blocks.get_mut(r.block as usize) {
                e.queued = NOT_QUEUED;
            }
        }
        self.queue.clear();
        let mut dropped = 0u32;
        let mut inconsistent = 0u32;
        // Light-ordered levels visit siblings out of index order: there only the node budget holds.
        let in_order = (0..self.header.levels()).all(|l| !hooks.ordered(l));
        let slots = self.cache.capacity() as u32;
        // A descent touches or queues at most 3 blocks (attributes, masks, the group entry) past
        // the check, so the lookahead stops 3 short of the unpinned cache.
        let room = slots.saturating_sub(self.pinned_blocks + 3).max(1);
        let mut pass = PassState {
            phase,
            // Before its first absent block a pass's touches do not keep blocks for it: what it
            // draws there is done for this refined frame.
            stamp: if phase == Phase::Progressive {
                self.frame
            } else {
                self.frame.wrapping_sub(1)
            },
            drawing,
            resume: self.refine,
            stack: [(0, 0, 0); MAX_LEVELS],
            stop: None,
            path: [0; MAX_LEVELS],
            room: room.min(QUEUE_CAPACITY as u32),
            kept: 0,
            lookahead: LOOKAHEAD_DESCENTS,
            stopping: false,
        };
        let mut nodes = StreamNodes {
            cache: &mut self.cache,
            queue: &mut self.queue,
            dropped: &mut dropped,
            inconsistent: &mut inconsistent,
            next_free: [0; MAX_LEVELS],
            in_order,
            // The root is visited without a descent.
            nodes_left: self.samples.saturating_sub(1),
            levels: self.levels,
            rho: self.header.rho,
            depth: self.header.depth,
            mask_bytes: u64::from(self.header.mask_bytes()),
            frame: self.frame,
            pass: &mut pass,
        };
        // The root's own attribute and mask are what the first splat needs.
        let root = nodes.ranges(0, 0, 1, None);
        let stats = if nodes.resident(&root) {
            render_nodes(nodes, frame, hooks, sink)
        } else {
            nodes.request(&root, ROOT_PRIORITY);
            nodes.pass.phase = Phase::Lookahead;
            Stats::default()
        };
        if phase != Phase::Progressive {
            // A pass that met no absent block drew the rest of the frame; one that did resumes
            // there next time.
            self.refine.done = pass.phase == Phase::Draw;
            if let Some(level) = pass.stop {
                self.refine.level = Some(level);
                self.refine.path = pass.path;
            }
        }
        self.counters.dropped += dropped;
        self.counters.inconsistent += inconsistent;
        self.inconsistent = inconsistent;
        self.missing = self.queue.len() as u32 + dropped + inconsistent;
        stats
    }

    /// Reads queued blocks, best first, until `budget_bytes` are spent (at least one block per call);
    /// when the last frame missed nothing, prefetches the rest of the file coarse-to-fine into free
    /// room. Damaged or failed blocks stay absent and wait out a backoff before being read again.
    pub fn serve<C: ChunkSource + ?Sized>(
        &mut self,
        src: &mut C,
        budget_bytes: u32,
    ) -> ServeReport {
        let bs = self.header.block_size();
        let mut left = (budget_bytes as usize).max(bs);
        let mut report = ServeReport::default();
        if self.passing {
            // A pass's queue, best first within the budget, then read in ascending block order:
            // an SD card (or a disk) serves a forward sweep best.
            let mut batch: Vec<u32, QUEUE_CAPACITY> = Vec::new();
            while left >= bs {
                let Some(b) = self.pop_best() else { break };
                if batch.push(b as u32).is_err() {
                    break;
                }
                left -= bs;
            }
            batch.sort_unstable();
            for &b in &batch {
                self.load(src, b as usize, false, &mut report);
            }
            return report;
        }
        while left >= bs {
            let (b, prefetch) = match self.pop_best() {
                Some(b) => (b, false),
                None if self.missing == 0 => match self.next_prefetch() {
                    Some(b) => (b, true),
                    None => break,
                },
                None => break,
            };
            match self.load(src, b, prefetch, &mut report) {
                Some(()) => left -= bs,
                None if prefetch => break,
                None => {}
            }
        }
        report
    }

    /// Reads block `b` into a slot the eviction policy gives (`None`: it gives none) and checks it;
    /// a damaged or failed block stays absent and waits out a backoff.
    fn load<C: ChunkSource + ?Sized>(
        &mut self,
        src: &mut C,
        b: usize,
        prefetch: bool,
        report: &mut ServeReport,
    ) -> Option<()> {
        let bs = self.header.block_size();
        let class = self.cache.blocks[b].class;
        let s = self.cache.victim(class, self.frame, prefetch)?;
        if self.cache.evict(s) {
            self.counters.evictions += 1;
        }
        report.reads += 1;
        report.bytes += bs as u32;
        report.prefetched += u32::from(prefetch);
        self.counters.reads += 1;
        self.counters.bytes_read += bs as u64;
        self.counters.prefetched += u32::from(prefetch);
        let want = self.cache.blocks[b].crc;
        let buf = self.cache.slot_bytes(s);
        let ok = match src.read_at((b as u64) * bs as u64, buf) {
            Err(_) => {
                self.counters.read_errors += 1;
                false
            }
            Ok(()) if crc32(buf) != want => {
                self.counters.crc_errors += 1;
                false
            }
            // Sealed but malformed: absent, exactly as a damaged block (issue 17).
            Ok(()) if check_block(&self.header, &self.dirs, b as u32, buf).is_err() => {
                self.counters.structure_errors += 1;
                false
            }
            Ok(()) => true,
        };
        if ok {
            self.cache.install(s, b, self.frame);
        } else {
            report.failed += 1;
            let e = &mut self.cache.blocks[b];
            e.fails = e.fails.saturating_add(1);
            let backoff = (1u32 << u32::from(e.fails).min(6)).min(MAX_BACKOFF);
            e.retry_at = self.frame.wrapping_add(backoff);
        }
        Some(())
    }

    /// Whether block `b` may be read now (not waiting out a backoff).
    fn ready(&self, e: &BlockEntry) -> bool {
        e.retry_at == 0 || self.frame >= e.retry_at
    }

    /// Removes and returns the best queued block that may be read now.
    fn pop_best(&mut self) -> Option<usize> {
        let mut best: Option<(usize, u32)> = None;
        for (i, r) in self.queue.iter().enumerate() {
            let e = &self.cache.blocks[r.block as usize];
            if e.slot == NO_SLOT && self.ready(e) && best.is_none_or(|(_, p)| r.priority > p) {
                best = Some((i, r.priority));
            }
        }
        let (i, _) = best?;
        let r = self.queue.swap_remove(i);
        self.cache.blocks[r.block as usize].queued = NOT_QUEUED;
        if let Some(moved) = self.queue.get(i) {
            self.cache.blocks[moved.block as usize].queued = i as u16;
        }
        Some(r.block as usize)
    }

    /// The first absent data block in file order (coarse levels first) that may be read now.
    fn next_prefetch(&self) -> Option<usize> {
        let first = self.header.crc_table_blocks as usize + 1;
        (first..self.cache.blocks.len()).find(|&b| {
            let e = &self.cache.blocks[b];
            e.slot == NO_SLOT && self.ready(e)
        })
    }
}

/// The traversal's view of a stream: reads through the cache, asks for what is missing.
struct StreamNodes<'s, 'a, 'p> {
    cache: &'s mut BlockCache<'a>,
    queue: &'s mut Vec<Request, QUEUE_CAPACITY>,
    dropped: &'s mut u32,
    /// Descents refused by [`StreamNodes::claim`].
    inconsistent: &'s mut u32,
    /// Per level, the index after the last sibling group this frame descended into there: a
    /// depth-first walk in slot order meets each level's groups in index order, so a group that
    /// starts before it overlaps one already visited (aliased or backward group pointers).
    next_free: [u32; MAX_LEVELS],
    /// Whether the walk visits siblings in slot order (no light-ordered levels).
    in_order: bool,
    /// Nodes this frame may still enter by descents: the file's samples less those entered.
    nodes_left: u64,
    levels: [Level; MAX_LEVELS],
    rho: u8,
    depth: u8,
    mask_bytes: u64,
    frame: u32,
    pass: &'s mut PassState<'p>,
}

/// A pass's walk state ([`TgStream::render_pass`]); a progressive frame has [`Phase::Progressive`].
struct PassState<'s> {
    phase: Phase,
    /// What a touch marks a block used at: the frame, or the frame before while a pass draws
    /// (blocks it only drew from are not kept for the later passes).
    stamp: u32,
    /// Cleared at the pass's first absent block: nothing more is drawn.
    drawing: &'s Cell<bool>,
    /// Where this pass resumes: cells before this path in walk order are skipped.
    resume: Refine,
    /// Per level, the last descent taken: (cell, its first child, its children).
    stack: [(u32, u32, u32); MAX_LEVELS],
    /// The level of the cell this pass stopped at (its first absent descent), with `path`.
    stop: Option<u8>,
    path: [u32; MAX_LEVELS],
    /// Blocks the lookahead may keep or queue: the unpinned cache, less one.
    room: u32,
    /// Unpinned blocks marked used since the stop, plus those queued.
    kept: u32,
    /// Descents the lookahead may still take.
    lookahead: u32,
    /// The next request is the stop's own.
    stopping: bool,
}

/// Byte ranges (offset, length) one descent reads: children's attributes and masks, parent's group.
type Ranges = [(u64, u64); 3];

impl StreamNodes<'_, '_, '_> {
    /// Whether the walk may enter the `n` cells from `first` at `level` (a sibling group): they lie
    /// inside the level, after every group already entered there this frame (each cell has one
    /// parent, so a valid file never enters a cell twice), and within the frame's node budget. This
    /// is what makes a frame's work bounded by the file's sample count whatever the pointers say:
    /// every node but the root is entered through one accepted claim.
    #[inline]
    fn claim(&mut self, level: u8, first: u32, n: u32) -> bool {
        let l = usize::from(level);
        let (Some(dir), Some(&free)) = (self.levels.get(l), self.next_free.get(l)) else {
            return false;
        };
        let end = u64::from(first) + u64::from(n);
        if end > u64::from(dir.count)
            || (self.in_order && first < free)
            || u64::from(n) > self.nodes_left
        {
            return false;
        }
        self.next_free[l] = end as u32;
        self.nodes_left -= u64::from(n);
        true
    }

    /// What reading samples `first..first + n` of level `level` needs, plus the group pointer of
    /// cell `parent` on the level above when those samples have grandchildren.
    fn ranges(&self, level: u8, first: u32, n: u32, parent: Option<u32>) -> Ranges {
        let l = &self.levels[usize::from(level)];
        let (first, n) = (u64::from(first), u64::from(n));
        let mut r = [(0, 0); 3];
        r[0] = (l.attr + 2 * first, 2 * n);
        if level < self.depth {
            r[1] = (l.mask + self.mask_bytes * first, self.mask_bytes * n);
        }
        if let (Some(p), true) = (parent, level < self.depth) {
            // The parent's group entry and the next cell's, which ends the parent's grandchildren
            // (`group_consistent`); the level's count ends the last cell's.
            let up = &self.levels[usize::from(level) - 1];
            let len = if p + 1 < up.count { 8 } else { 4 };
            r[2] = (up.group + 4 * u64::from(p), len);
        }
        r
    }

    /// Whether the group entry of cell `index` at `level` (resident, as the masks of its `n`
    /// children from `first`) spans exactly its children's children: it ends where the next cell's
    /// entry starts, or at the end of the level two below for the last cell (FORMAT.md "Group").
    /// With [`StreamNodes::claim`] this catches aliased, backward and skewed pointers between
    /// blocks that each passed [`check_block`]; a whole run of entries shifted alike is only caught
    /// where the walk reaches one of its ends.
    fn group_consistent(&self, level: u8, index: u32, first: u32, n: u32) -> bool {
        let l = usize::from(level);
        if l + 2 > usize::from(self.depth) {
            return true;
        }
        let slots = if self.rho == 2 { 0xFF } else { (1 << 27) - 1 };
        let mut below = u64::from(self.group(level, index));
        for k in first..first.saturating_add(n) {
            below += u64::from((self.mask(level + 1, k) & slots).count_ones());
        }
        let end = if index + 1 < self.levels[l].count {
            self.group(level, index + 1)
        } else {
            self.levels[l + 2].count
        };
        below == u64::from(end)
    }

    /// Every block of `ranges`, once each in order.
    fn blocks(&self, ranges: &Ranges, mut f: impl FnMut(usize)) {
        let log2 = self.cache.log2;
        let mut prev = usize::MAX;
        for &(off, len) in ranges {
            if len == 0 {
                continue;
            }
            let (a, z) = (off >> log2, (off + len - 1) >> log2);
            for b in a..=z {
                let b = b as usize;
                if b != prev {
                    f(b);
                    prev = b;
                }
            }
        }
    }

    fn resident(&mut self, ranges: &Ranges) -> bool {
        let mut all = true;
        let mut touch = [usize::MAX; 8];
        let mut n = 0;
        self.blocks(ranges, |b| {
            if n < touch.len() {
                touch[n] = b;
                n += 1;
            } else {
                all = false;
            }
        });
        let stamp = self.pass.stamp;
        for &b in &touch[..n] {
            if self.pass.phase == Phase::Lookahead
                && self.cache.used(b).is_some_and(|u| u != stamp)
                && self.unpinned(b)
            {
                self.pass.kept += 1;
            }
            all &= self.cache.touch(b, stamp);
        }
        all
    }

    /// Whether block `b` may be evicted (its class is not pinned).
    fn unpinned(&self, b: usize) -> bool {
        self.cache
            .blocks
            .get(b)
            .is_some_and(|e| i16::from(e.class) > self.cache.pinned)
    }

    /// The pass stops drawing at cell `index` of `level`, whose children are absent: the next pass
    /// resumes there. The blocks of the descents down to it are kept for that pass.
    fn stop_at(&mut self, level: u8, index: u32) {
        let l = usize::from(level);
        for k in 0..l {
            self.pass.path[k] = self.pass.stack[k].0;
        }
        self.pass.path[l] = index;
        self.pass.stop = Some(level);
        self.pass.phase = Phase::Lookahead;
        self.pass.drawing.set(false);
        self.pass.stamp = self.frame;
        for k in 0..l {
            let (i, first, n) = self.pass.stack[k];
            let r = self.ranges(k as u8 + 1, first, n, Some(i));
            self.resident(&r);
        }
    }

    fn request(&mut self, ranges: &Ranges, priority: u32) {
        let mut want = [usize::MAX; 8];
        let mut n = 0;
        self.blocks(ranges, |b| {
            if n < want.len() {
                want[n] = b;
                n += 1;
            }
        });
        for &b in &want[..n] {
            // A pass reads in file order (what an SD card serves best), its stop first.
            let p = match self.pass.phase {
                Phase::Lookahead if priority != ROOT_PRIORITY => {
                    u32::MAX - 1 - (b as u32).min(u32::MAX - 2)
                }
                _ => priority,
            };
            if self.push(b, p) && self.pass.phase == Phase::Lookahead {
                self.pass.kept += 1;
            }
        }
        if self.pass.phase == Phase::Lookahead && self.pass.kept >= self.pass.room {
            self.pass.phase = Phase::Done;
        }
    }

    /// Queues block `b` with `priority`, raising it if already queued (a block's priority is its
    /// best node's, §3.4); when the queue is full the lowest request makes room or this one is
    /// dropped.
    /// Returns whether the block was newly queued.
    fn push(&mut self, b: usize, priority: u32) -> bool {
        let Some(e) = self.cache.blocks.get(b) else {
            *self.dropped += 1; // outside the file: a damaged directory; never converges
            return false;
        };
        if e.slot != NO_SLOT {
            return false;
        }
        if e.queued != NOT_QUEUED {
            let r = &mut self.queue[usize::from(e.queued)];
            r.priority = r.priority.max(priority);
            return false;
        }
        let req = Request {
            priority,
            block: b as u32,
        };
        if self.queue.push(req).is_ok() {
            self.cache.blocks[b].queued = (self.queue.len() - 1) as u16;
            return true;
        }
        let (i, low) = self
            .queue
            .iter()
            .enumerate()
            .min_by_key(|(_, r)| r.priority)
            .map(|(i, r)| (i, *r))
            .expect("a full queue is not empty");
        *self.dropped += 1;
        if priority > low.priority {
            self.cache.blocks[low.block as usize].queued = NOT_QUEUED;
            self.queue[i] = req;
            self.cache.blocks[b].queued = i as u16;
        }
        false
    }

    #[inline]
    fn read<const N: usize>(&self, off: u64) -> [u8; N] {
        match self.cache.bytes(off, N) {
            Some(b) => {
                let mut out = [0u8; N];
                out.copy_from_slice(b);
                out
            }
            None => [0; N],
        }
    }
}

impl NodeData for StreamNodes<'_, '_, '_> {
    const STREAMED: bool = true;

    fn shape(&self) -> (u8, u8) {
        (self.rho, self.depth)
    }

    #[inline]
    fn attr(&self, level: u8, i: u32) -> u16 {
        let l = &self.levels[usize::from(level)];
        if i >= l.count {
            return 0;
        }
        u16::from_le_bytes(self.read(l.attr + 2 * u64::from(i)))
    }

    #[inline]
    fn mask(&self, level: u8, i: u32) -> u32 {
        let l = &self.levels[usize::from(level)];
        if i >= l.count || l.mask == 0 {
            return 0;
        }
        if self.rho == 2 {
            u32::from(self.read::<1>(l.mask + u64::from(i))[0])
        } else {
            u32::from_le_bytes(self.read(l.mask + 4 * u64::from(i)))
        }
    }

    #[inline]
    fn group(&self, level: u8, i: u32) -> u32 {
        let l = &self.levels[usize::from(level)];
        if i >= l.count || l.group == 0 {
            return 0;
        }
        u32::from_le_bytes(self.read(l.group + 4 * u64::from(i)))
    }

    fn children_resident(&mut self, level: u8, index: u32, first_child: u32, n: u32) -> bool {
        if !self.claim(level + 1, first_child, n) {
            *self.inconsistent += 1;
            return false;
        }
        let r = self.ranges(level + 1, first_child, n, Some(index));
        if !self.resident(&r) {
            if self.pass.phase == Phase::Draw {
                self.stop_at(level, index);
                self.pass.stopping = true;
                // What of the stop's own blocks is here stays for the next pass too.
                self.resident(&r);
            }
            return false;
        }
        if !self.group_consistent(level, index, first_child, n) {
            *self.inconsistent += 1;
            return false;
        }
        if self.pass.phase == Phase::Lookahead {
            // What the lookahead keeps must leave room for what it queues: stop when full.
            self.pass.lookahead = self.pass.lookahead.saturating_sub(1);
            if self.pass.lookahead == 0 || self.pass.kept >= self.pass.room {
                self.pass.phase = Phase::Done;
            }
        }
        if let Some(e) = self.pass.stack.get_mut(usize::from(level)) {
            *e = (index, first_child, n);
        }
        true
    }

    #[inline]
    fn skip(&mut self, level: u8, index: u32) -> bool {
        match self.pass.phase {
            Phase::Progressive => false,
            Phase::Done => true,
            Phase::Draw | Phase::Lookahead => match self.pass.resume.level {
                Some(c) if level <= c => index < self.pass.resume.path[usize::from(level)],
                _ => false,
            },
        }
    }

    fn request_children(
        &mut self,
        level: u8,
        index: u32,
        first_child: u32,
        n: u32,
        size_q8: i32,
        y_q8: i32,
    ) {
        let r = self.ranges(level + 1, first_child, n, Some(index));
        let priority = if core::mem::take(&mut self.pass.stopping) {
            ROOT_PRIORITY
        } else {
            stream_priority(size_q8, y_q8)
        };
        self.request(&r, priority);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn size_classes_are_half_octaves() {
        assert_eq!(size_class(0), 0);
        assert_eq!(size_class(1), 0);
        assert_eq!(size_class(2), 2);
        assert_eq!(size_class(3), 3);
        assert_eq!(size_class(16), 8);
        assert_eq!(size_class(23), 9);
        assert_eq!(size_class(22), 8);
        assert_eq!(size_class(32), 10);
        assert!(size_class(i32::MAX) < 64);
    }

    #[test]
    fn larger_splats_first_then_top_rows() {
        let big_low = stream_priority(64 * 256, 300 * 256);
        let big_high = stream_priority(64 * 256, 10 * 256);
        let small_high = stream_priority(8 * 256, 0);
        assert!(big_high > big_low && big_low > small_high);
        // Off-screen rows clamp instead of wrapping.
        assert_eq!(stream_priority(16, -5000), stream_priority(16, 0));
    }
}
