//! Streaming a `.tg` file: draw what is resident, queue what is missing, read the best of it within
//! a budget per frame (Streaming QSplat §3, Fig. 3).

use core::cell::Cell;

use heapless::Vec;

use super::cache::{BlockCache, BlockEntry, SlotEntry, MIN_SLOTS, NO_BLOCK};
use super::crcs::CrcWindow;
use super::need::{LevelEnds, Need};
use super::nodes::{Bricks, Entered, Level, PassState, Refine, StreamNodes};
use super::open::{check_head_and_table, read_tg_header, OPEN_ATTEMPTS};
use super::priority::{QUEUE_CAPACITY, ROOT_PRIORITY};
use super::serve::{
    clear_queue, first_absent, Feed, Phase, Request, ServeReport, StreamCounters, Verdict,
};
use super::{ChunkSource, PassHooks, PassSink, StreamError};
use crate::crc::crc32;
use crate::frame::Walk;
use crate::splat::{ColorSink, SplatSink, Stats};
use crate::tg::brick::band_end;
use crate::tg::read::{check_block, Header, LevelDir};
use crate::tg::traverse::{fill_nodes, render_nodes, NoShadows, ShadowHooks};
use crate::tg::{TgError, TgFrame, DIRECTORY_ENTRY, DIRECTORY_OFFSET, MAX_LEVELS};

/// Descents a pass walks past the place it stops, looking for the blocks the next passes need.
const LOOKAHEAD_DESCENTS: u32 = 1 << 13;

/// Which walk of a frame [`TgStream`] takes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Pass {
    /// A frame's (or a refined frame's pass's) only walk.
    Draw,
    /// The light pass of two-pass shadows: casts into the map, draws nothing.
    Cast,
    /// The draw after a cast in the same frame.
    DrawAfterCast,
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
    /// The CRCs of the blocks being read.
    crcs: CrcWindow,
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
    /// The fewest blocks a cache of this file may hold ([`TgStream::cache_need`]).
    need_blocks: u32,
    /// The refined frame being drawn in passes ([`TgStream::render_pass`]).
    refine: Refine,
    /// Whether the last frame was a pass: [`TgStream::serve`] then reads in block order.
    passing: bool,
}

/// A streamed tri-grid's frame ready to walk ([`Walk`]): what is resident is drawn and what is
/// missing queued ([`TgStream::render`]), or, `refined`, the next pass of a refined frame
/// ([`TgStream::render_pass`]).
pub struct StreamWalk<'a, 's> {
    /// The stream.
    pub stream: &'a mut TgStream<'s>,
    /// Its frame.
    pub frame: &'a TgFrame,
    /// The next pass of a refined frame instead of a frame from what is resident.
    pub refined: bool,
}

impl Walk for StreamWalk<'_, '_> {
    fn walk<S: ColorSink>(&mut self, sink: &mut S) -> Stats {
        if self.refined {
            self.stream.render_pass(self.frame, sink)
        } else {
            self.stream.render(self.frame, sink)
        }
    }
}

impl<'a> TgStream<'a> {
    /// Opens a `.tg` file on `src`: reads its header and checks its CRC table (retrying each
    /// read), and sets up a cache of `data.len() / block_size` blocks (at most `slots.len()`) with
    /// a block table of `table` ([`table_entries`](super::table_entries) of the slots and the
    /// request queue wanted). Memory is the caller's: statics on a device; none of it grows with
    /// the file.
    ///
    /// # Errors
    /// A [`StreamError`]: the header or CRC table could not be read or is invalid, or the memory
    /// given is too small for this file.
    pub fn open<C: ChunkSource + ?Sized>(
        src: &mut C,
        data: &'a mut [u8],
        slots: &'a mut [SlotEntry],
        table: &'a mut [BlockEntry],
    ) -> Result<Self, StreamError<C::Error>> {
        let (header, dirs, header_fails) = read_tg_header(src, data)?;
        let nblocks = header.blocks as usize;
        let bs = header.block_size();
        let slots_avail = (data.len() / bs).min(slots.len()) as u32;
        let cache = BlockCache::new(header.block_log2, data, slots, table, nblocks)
            .map_err(|e| StreamError::too_small(e, bs, slots_avail))?;
        let levels = dirs.map(|d| Level::of(&d));
        let mut s = TgStream {
            header,
            dirs,
            levels,
            samples: dirs.iter().map(|d| u64::from(d.count)).sum(),
            inconsistent: 0,
            cache,
            crcs: CrcWindow::new(bs as u64, header.blocks),
            queue: Vec::new(),
            missing: 1,
            frame: 0,
            counters: StreamCounters::default(),
            pinned_blocks: 0,
            need_blocks: MIN_SLOTS as u32,
            refine: Refine::START,
            passing: false,
        };
        s.counters.reads = header_fails + 1;
        s.counters.bytes_read = (u64::from(header_fails) + 1) * bs as u64;
        s.check_crc_table(src)?;
        // The head and the brick table, checked whole before the first frame (the bricks are
        // checked one by one as the walk first enters them).
        let reads = check_head_and_table(&header, &dirs, &mut s.cache, &mut s.crcs, src)?;
        s.counters.reads += reads.reads;
        s.counters.bytes_read += u64::from(reads.reads) * bs as u64;
        s.counters.read_errors += reads.read_errors;
        s.counters.crc_errors += reads.crc_errors;
        s.counters.reads += s.crcs.reads;
        s.counters.bytes_read += s.crcs.bytes_read;
        // A cache that cannot hold what one pass needs would never converge: refused here, with
        // the size this file needs (issue 33).
        let level_end = s.level_ends(&dirs);
        let need = Need {
            header: &header,
            dirs: &dirs,
            spans: reads.spans,
            level_end: &level_end,
        };
        s.need_blocks = need.min_cache_blocks();
        let capacity = s.cache.capacity() as u32;
        let Some(pinned) = need.pinning(capacity) else {
            return Err(StreamError::CacheTooSmall {
                block_size: bs as u32,
                slots: capacity,
                needed: s.need_blocks,
            });
        };
        s.classify(&level_end, pinned, need.pinned_blocks(pinned));
        Ok(s)
    }

    /// Reads each CRC-table block into slot 1 (as scratch; block 0 is still in slot 0, where
    /// [`read_tg_header`] read it) and checks it against the header's list. The CRCs are not kept:
    /// each block's is read again from the table when the block arrives ([`CrcWindow`]).
    fn check_crc_table<C: ChunkSource + ?Sized>(
        &mut self,
        src: &mut C,
    ) -> Result<(), StreamError<C::Error>> {
        let h = self.header;
        let bs = h.block_size();
        // parse_header checked that the list lies inside block 0.
        let list_at = DIRECTORY_OFFSET + DIRECTORY_ENTRY * h.levels();
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
        }
        Ok(())
    }

    /// Per level, the end of its data (for a bricked file the brick table counts as the brick
    /// level's, since every descent below it reads the table, and the bricks as the level below).
    fn level_ends(&self, dirs: &[LevelDir; MAX_LEVELS]) -> LevelEnds {
        let h = self.header;
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
        if h.bricked() {
            let r = usize::from(h.brick_level);
            let table = u64::from(h.brick_table)
                + u64::from(h.bricks)
                    * crate::tg::brick::entry_bytes(h.brick_level, h.depth) as u64;
            level_end[r] = level_end[r].max(table);
            let band = band_end(&h, dirs);
            for end in &mut level_end[r + 1..usize::from(h.depth)] {
                *end = band;
            }
        }
        level_end
    }

    /// Gives each block its class (the coarsest level with data in it), and pins the levels
    /// `0..=pinned` (their `pinned_blocks` blocks are never evicted; [`Need::pinning`] chose them).
    fn classify(&mut self, level_end: &LevelEnds, pinned: i16, pinned_blocks: u32) {
        let mut ends = [0u64; MAX_LEVELS];
        let levels = self.header.levels();
        ends[..levels].copy_from_slice(&level_end[..levels]);
        self.cache.set_classes(&ends, self.header.depth);
        self.cache.pinned = pinned;
        self.pinned_blocks = pinned_blocks;
    }

    /// The fewest blocks a cache of this file may hold (`need.rs`): smaller caches are refused at
    /// open ([`StreamError::CacheTooSmall`]); with this many, every view converges.
    pub fn cache_need(&self) -> u32 {
        self.need_blocks
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

    /// Blocks the last frame found missing, plus the descents it refused as malformed or
    /// inconsistent (for a refined frame drawn in passes, those of every pass so far): 0 means it
    /// was drawn as the resident file would be.
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
        self.walk(frame, hooks, sink, Phase::Progressive, &drawing, Pass::Draw)
    }

    /// [`TgStream::render_with`] after [`TgStream::fill_with`] in the same frame: what the cast
    /// queued stays queued, and [`TgStream::missing`] counts what either walk missed.
    pub fn render_after_fill<S: SplatSink, H: ShadowHooks>(
        &mut self,
        frame: &TgFrame,
        hooks: &mut H,
        sink: &mut S,
    ) -> Stats {
        let drawing = Cell::new(true);
        self.walk(
            frame,
            hooks,
            sink,
            Phase::Progressive,
            &drawing,
            Pass::DrawAfterCast,
        )
    }

    /// Casts what is resident into a shadow map through `hooks` (the light pass of two-pass
    /// shadows, a scene's two-pass light pass for a stream), queueing what is missing as a
    /// frame does: where children are absent the cell casts as a leaf. Returns nodes visited.
    ///
    /// A frame that casts and then draws counts as converged only if both found nothing missing:
    /// call [`TgStream::missing`] after each.
    pub fn fill_with<H: ShadowHooks>(&mut self, frame: &TgFrame, hooks: &mut H) -> u32 {
        let drawing = Cell::new(true);
        let mut sink = crate::splat::NullSink::default();
        self.walk(
            frame,
            hooks,
            &mut sink,
            Phase::Progressive,
            &drawing,
            Pass::Cast,
        )
        .nodes_visited
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
        self.render_pass_with(frame, &mut NoShadows, sink)
    }

    /// [`TgStream::render_pass`] with shadow hooks: two-pass shadows' test, or one-pass shadows,
    /// whose [`ShadowHooks::ordered`] levels visit siblings in light order (a pass resumes in
    /// the walk's own order, `StreamNodes::skip`). Their fills, like the sink's splats, happen
    /// only while the pass draws, so that the passes together fill and test in the resident
    /// walk's sequence.
    pub fn render_pass_with<S: SplatSink, H: ShadowHooks>(
        &mut self,
        frame: &TgFrame,
        hooks: &mut H,
        sink: &mut S,
    ) -> Stats {
        let drawing = Cell::new(true);
        let mut pass = PassSink {
            inner: sink,
            drawing: &drawing,
        };
        let mut hooks = PassHooks {
            inner: hooks,
            drawing: &drawing,
        };
        self.refine.passes += 1;
        self.walk(
            frame,
            &mut hooks,
            &mut pass,
            Phase::Draw,
            &drawing,
            Pass::Draw,
        )
    }

    /// The next pass of a refined cast into a shadow map (two-pass shadows' light pass through a
    /// cache smaller than what it reads), as [`TgStream::render_pass`] is of a frame: each pass
    /// skips the subtrees earlier passes cast, casts until its first absent descent and then only
    /// queues, so that once [`TgStream::refined_done`] the map holds what the resident file casts
    /// (fills keep the nearer depth, so a cast's order does not matter). Returns nodes visited.
    pub fn fill_pass<H: ShadowHooks>(&mut self, frame: &TgFrame, hooks: &mut H) -> u32 {
        let drawing = Cell::new(true);
        let mut hooks = PassHooks {
            inner: hooks,
            drawing: &drawing,
        };
        let mut sink = crate::splat::NullSink::default();
        self.refine.passes += 1;
        self.walk(
            frame,
            &mut hooks,
            &mut sink,
            Phase::Draw,
            &drawing,
            Pass::Cast,
        )
        .nodes_visited
    }

    /// Whether the last [`TgStream::render_pass`] finished its refined frame.
    pub fn refined_done(&self) -> bool {
        self.refine.done
    }

    /// Passes drawn of the current refined frame.
    pub fn passes(&self) -> u32 {
        self.refine.passes
    }

    /// Blocks the last frame (or pass) used that the eviction policy keeps for it, plus the pinned
    /// blocks (which it never evicts) and those it queued: more than the cache holds means the
    /// frame cannot be drawn whole from the cache, and needs [`TgStream::render_pass`].
    pub fn working_set(&self) -> u32 {
        let kept = self
            .cache
            .slots
            .iter()
            .filter(|e| {
                e.block != NO_BLOCK
                    && (e.used == self.frame
                        || i16::from(self.cache.class(e.block as usize)) <= self.cache.pinned)
            })
            .count() as u32;
        kept + self.queue.len() as u32
    }

    fn walk<S: SplatSink, H: ShadowHooks>(
        &mut self,
        frame: &TgFrame,
        hooks: &mut H,
        sink: &mut S,
        phase: Phase,
        drawing: &Cell<bool>,
        what: Pass,
    ) -> Stats {
        // What a cast earlier in this frame missed besides what it queued.
        let mut carried = 0;
        if what == Pass::DrawAfterCast {
            carried = self.missing.saturating_sub(self.queue.len() as u32);
        } else {
            self.frame = self.frame.wrapping_add(1).max(1);
            self.counters.frames += 1;
            clear_queue(&mut self.cache, &mut self.queue);
        }
        self.passing = phase != Phase::Progressive;
        let mut dropped = 0u32;
        let mut inconsistent = 0u32;
        let mut bad_bricks = 0u32;
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
            on: 0,
            met: 0,
            stack: [(0, 0, 0); MAX_LEVELS],
            stop: None,
            path: [0; MAX_LEVELS],
            room: room.min(QUEUE_CAPACITY as u32),
            kept: 0,
            lookahead: LOOKAHEAD_DESCENTS,
            stopping: false,
        };
        let h = self.header;
        let mut nodes = StreamNodes {
            cache: &mut self.cache,
            queue: &mut self.queue,
            dropped: &mut dropped,
            inconsistent: &mut inconsistent,
            bad_bricks: &mut bad_bricks,
            next_free: [0; MAX_LEVELS],
            in_order,
            // The root is visited without a descent.
            nodes_left: self.samples.saturating_sub(1),
            levels: self.levels,
            header: h,
            dirs: self.dirs,
            bricks: h.bricked().then(|| Bricks {
                level: h.brick_level,
                band_end: band_end(&h, &self.dirs),
                entered: Entered::None,
            }),
            frame: self.frame,
            pass: &mut pass,
            need: [(0, 0); 6],
        };
        // The root's own attribute and mask are what the first splat needs.
        let root = nodes.ranges(0, 0, 1, None);
        let stats = if !nodes.resident(&root) {
            nodes.request(&root, ROOT_PRIORITY);
            nodes.pass.phase = Phase::Lookahead;
            Stats::default()
        } else if what == Pass::Cast {
            Stats {
                nodes_visited: fill_nodes(nodes, frame, hooks),
                ..Stats::default()
            }
        } else {
            render_nodes(nodes, frame, hooks, sink)
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
        self.counters.structure_errors += bad_bricks;
        self.inconsistent = inconsistent;
        // A refined frame is whole only if no pass of it refused a descent (a later pass resumes
        // past the place an earlier one drew coarser).
        let refused = if phase == Phase::Progressive {
            inconsistent
        } else {
            self.refine.refused = self.refine.refused.saturating_add(inconsistent);
            self.refine.refused
        };
        self.missing = self.queue.len() as u32 + dropped + refused + carried;
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
        let (header, dirs) = (self.header, self.dirs);
        let first = header.crc_table_blocks as usize + 1;
        let crcs = &mut self.crcs;
        let (reads, bytes) = (crcs.reads, crcs.bytes_read);
        let mut feed = Feed {
            cache: &mut self.cache,
            queue: &mut self.queue,
            counters: &mut self.counters,
            frame: self.frame,
            block_size: header.block_size(),
            file_len: u64::from(header.blocks) << header.block_log2,
        };
        let report = feed.serve(
            src,
            budget_bytes,
            self.passing,
            self.missing,
            // The data blocks in file order: coarse levels first.
            |cache, frame| first_absent(cache, first, frame),
            |b, buf, src| match crcs.crc(src, b as u32) {
                Err(_) => Verdict::Unread,
                Ok(want) if want != Some(crc32(buf)) => {
                    crcs.forget();
                    Verdict::Crc
                }
                Ok(_) if check_block(&header, &dirs, b as u32, buf).is_err() => Verdict::Structure,
                Ok(_) => Verdict::Good,
            },
        );
        self.counters.reads += self.crcs.reads - reads;
        self.counters.bytes_read += self.crcs.bytes_read - bytes;
        report
    }
}
