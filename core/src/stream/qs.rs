//! Streaming a `.qs` file (Streaming QSplat §3): the file is cut into blocks of `2^log2` bytes; a
//! sibling group (at most 28 bytes, in one block or two) is available when its blocks are resident.
//! Where a group is absent the walk draws its parent and queues the group's blocks by the parent's
//! splat size and screen row (§4.2); [`QsStream::serve`] reads the best of them within a budget.
//! A refined frame that needs more blocks than the cache holds is drawn in passes, as for
//! tri-grids ([`super::TgStream::render_pass`]): each pass skips what earlier passes drew, draws
//! until its first absent group, then only queues what the next passes need.
//!
//! Files as QSplat 1.0 wrote them stream as they are: nothing is added to the file. The format has
//! no CRCs, so a block is checked by structure as the walk first reads each of its groups: the
//! group lies inside its fragment, after every group already read at its level this frame (a
//! breadth-first file meets each level's groups in order: no group is read twice, and pointers
//! cannot run backwards or alias), its child counts, sphere indices and grandchildren bits are
//! ones the format allows, its pointer leads forward within the fragment, and a frame reads no
//! more nodes than the file can hold. A group that fails is refused: its parent is drawn, the
//! failure counted, and the frame never counts as converged. A damaged byte that still makes a
//! valid group (a normal index, a sphere index within the table) cannot be told from the file's
//! own: it draws that node wrongly, within its parent's sphere, never outside the model's bounds
//! and never a fault.
#![deny(clippy::float_arithmetic)]

use core::cell::Cell;

use heapless::Vec;

use super::cache::{BlockCache, BlockEntry, Evict, SlotEntry, MIN_SLOTS, NO_BLOCK};
use super::open::OPEN_ATTEMPTS;
use super::priority::{stream_priority, QUEUE_CAPACITY, ROOT_PRIORITY};
use super::serve::{
    clear_queue, first_absent, push, Feed, Phase, Request, ServeReport, StreamCounters, Verdict,
};
use super::{ChunkSource, PassSink, StreamError};
use crate::bytes::ByteOrder;
use crate::frame::Walk;
use crate::qs::read::{
    node_at, parse_bounds, tree_bounds_by, Group, GroupBytes, Records, TreeHead, BOUNDS_DEPTH,
};
use crate::qs::table::SPHERE_COUNT;
use crate::qs::traverse::{walk_tree, QsNodes};
use crate::qs::{
    QsError, QsFrame, COMMENT_HEADER_BYTES, HEADER_BYTES, MAGIC, MAX_DEPTH, OPT_COLOR, OPT_COMMENT,
};
use crate::splat::{ColorSink, SampleSplat, Stats};

/// Tree fragments a streamed `.qs` file may have.
pub const QS_MAX_TREES: usize = 16;
/// Fragments (comments included) opening a stream walks at most.
const MAX_FRAGMENTS: u32 = 1024;
/// Bytes of a comment read for pocketsplat's bounds.
const COMMENT_READ: usize = 256;
/// Levels of a tree, the root's (0) included, with one to spare.
const LEVELS: usize = MAX_DEPTH + 2;
/// Bytes of the largest group: a pointer and four coloured records.
const GROUP_MAX: usize = 4 + 4 * 6;
/// Groups a pass reads past the place it stops, looking for the blocks the next passes need.
const LOOKAHEAD_GROUPS: u32 = 1 << 13;
/// [`BlockEntry`] class of a block no group has been read from yet: the finest.
const UNSEEN: u8 = u8::MAX;
/// [`BlockEntry`] flags of a `.qs` stream: the deepest level read from the block, plus one.
const LEVEL_MASK: u8 = 0x7F;
/// [`BlockEntry`] flags: a pass drew from the block since it was loaded.
const DRAWN: u8 = 0x80;

/// Where a refined frame drawn in passes stands: the node the last pass stopped at, by the path of
/// member indices from its tree (index 0: the tree; `k`: the member at level `k`).
#[derive(Clone, Copy, Debug)]
struct Resume {
    path: [u8; LEVELS],
    /// Level of the node the last pass stopped at; `None`: the frame starts at the first tree.
    stop: Option<u8>,
    passes: u32,
    done: bool,
    refused: u32,
}

impl Resume {
    const START: Self = Self {
        path: [0; LEVELS],
        stop: None,
        passes: 0,
        done: false,
        refused: 0,
    };
}

/// A `.qs` file being streamed: its fragments' heads, the block cache and the request queue.
#[derive(Debug)]
pub struct QsStream<'a> {
    order: ByteOrder,
    trees: Vec<TreeHead, QS_MAX_TREES>,
    bounds: [[f32; 3]; 2],
    file_len: u64,
    cache: BlockCache<'a>,
    queue: Vec<Request, QUEUE_CAPACITY>,
    missing: u32,
    inconsistent: u32,
    frame: u32,
    counters: StreamCounters,
    refine: Resume,
    passing: bool,
    /// Deepest level a frame has read a group at.
    deepest: u8,
    /// Where the last pass stopped ([`PassState::frontier`]).
    frontier: Option<(u32, [u32; LEVELS])>,
}

/// A streamed QSplat file's frame ready to walk ([`Walk`]): what is resident is drawn and what is
/// missing queued ([`QsStream::render`]), or, `refined`, the next pass of a refined frame
/// ([`QsStream::render_pass`]).
pub struct QsStreamWalk<'a, 's> {
    /// The stream.
    pub stream: &'a mut QsStream<'s>,
    /// Its frame.
    pub frame: &'a QsFrame,
    /// The next pass of a refined frame instead of a frame from what is resident.
    pub refined: bool,
}

impl Walk for QsStreamWalk<'_, '_> {
    fn walk<S: ColorSink>(&mut self, sink: &mut S) -> Stats {
        if self.refined {
            self.stream.render_pass(self.frame, sink)
        } else {
            self.stream.render(self.frame, sink)
        }
    }
}

/// Reads `buf` at `offset`, retrying; counts the reads.
fn read_retry<C: ChunkSource + ?Sized>(
    src: &mut C,
    offset: u64,
    buf: &mut [u8],
    counters: &mut StreamCounters,
) -> Result<(), StreamError<C::Error>> {
    let mut last = None;
    for _ in 0..OPEN_ATTEMPTS {
        counters.reads += 1;
        counters.bytes_read += buf.len() as u64;
        match src.read_at(offset, buf) {
            Ok(()) => return Ok(()),
            Err(e) => {
                counters.read_errors += 1;
                last = Some(e);
            }
        }
    }
    Err(StreamError::Device(last.expect("at least one attempt")))
}

/// The fragments of a file of `len` bytes as `order` reads their lengths: each one's offset, its
/// first (up to) 40 bytes and its length; `Err` at the first that does not fit.
fn fragments<C: ChunkSource + ?Sized>(
    src: &mut C,
    len: u64,
    order: ByteOrder,
    counters: &mut StreamCounters,
    mut each: impl FnMut(u32, &[u8; HEADER_BYTES], u32) -> Result<(), QsError>,
) -> Result<(), StreamError<C::Error>> {
    let mut at = 0u64;
    let mut n = 0u32;
    while at < len {
        n += 1;
        if n > MAX_FRAGMENTS {
            return Err(StreamError::Qs(QsError::TooLarge(len as usize)));
        }
        let mut head = [0u8; HEADER_BYTES];
        let avail = (len - at).min(HEADER_BYTES as u64) as usize;
        read_retry(src, at, &mut head[..avail], counters)?;
        let offset = at as u32;
        if head[..8] != MAGIC {
            let mut magic = [0u8; 8];
            magic[..avail.min(8)].copy_from_slice(&head[..avail.min(8)]);
            return Err(StreamError::Qs(QsError::BadMagic { offset, magic }));
        }
        let length = order.u32(&head[..avail], 8).unwrap_or(0);
        if (length as usize) < COMMENT_HEADER_BYTES || at + u64::from(length) > len {
            return Err(StreamError::Qs(QsError::BadFragmentLength {
                offset,
                length: ByteOrder::Big.u32(&head, 8).unwrap_or(0),
            }));
        }
        each(offset, &head, length).map_err(StreamError::Qs)?;
        at += u64::from(length);
    }
    Ok(())
}

impl<'a> QsStream<'a> {
    /// Opens a `.qs` file on `src`: reads its fragment headers (and the start of a comment, for
    /// pocketsplat's bounds), and sets up a cache of `2^block_log2`-byte blocks in `data` (at most
    /// `slots.len()` of them) with a block table of `table` ([`table_entries`](super::table_entries)
    /// of the slots and the request queue wanted). Memory is the caller's: statics on a device;
    /// none of it grows with the file.
    ///
    /// # Errors
    /// A [`StreamError`]: the medium does not know the file's length, a header could not be read
    /// or is invalid, the file has more trees than [`QS_MAX_TREES`], or the memory given is too
    /// small for it.
    pub fn open<C: ChunkSource + ?Sized>(
        src: &mut C,
        block_log2: u8,
        data: &'a mut [u8],
        slots: &'a mut [SlotEntry],
        table: &'a mut [BlockEntry],
    ) -> Result<Self, StreamError<C::Error>> {
        let file_len = src.byte_len().ok_or(StreamError::UnknownLength)?;
        if file_len < COMMENT_HEADER_BYTES as u64 {
            return Err(StreamError::Qs(QsError::TooShort(file_len as usize)));
        }
        if file_len > u64::from(u32::MAX) {
            return Err(StreamError::Qs(QsError::TooLarge(usize::MAX)));
        }
        let mut counters = StreamCounters::default();
        // The byte order the fragment lengths add up in (FORMAT.md: big-endian, or a build of
        // QSplat 1.0 that did not swap).
        let order = match fragments(src, file_len, ByteOrder::Big, &mut counters, |_, _, _| {
            Ok(())
        }) {
            Ok(()) => ByteOrder::Big,
            Err(StreamError::Qs(e)) => {
                fragments(
                    src,
                    file_len,
                    ByteOrder::Little,
                    &mut counters,
                    |_, _, _| Ok(()),
                )
                .map_err(|f| match f {
                    StreamError::Qs(_) => StreamError::Qs(e),
                    f => f,
                })?;
                ByteOrder::Little
            }
            Err(e) => return Err(e),
        };
        let mut trees: Vec<TreeHead, QS_MAX_TREES> = Vec::new();
        let mut comment_at = None;
        let mut too_many = false;
        fragments(
            src,
            file_len,
            order,
            &mut counters,
            |offset, head, length| {
                let options = order.u32(head, 16).unwrap_or(0);
                if options & !(OPT_COLOR | OPT_COMMENT) != 0 {
                    return Err(QsError::UnknownOptions { offset, options });
                }
                if options & OPT_COMMENT != 0 {
                    if comment_at.is_none() {
                        comment_at = Some((offset, length));
                    }
                    return Ok(());
                }
                if (length as usize) < HEADER_BYTES {
                    return Err(QsError::TreeTooShort { offset, length });
                }
                let tree = TreeHead::parse(head, length, order, offset)
                    .ok_or(QsError::TreeTooShort { offset, length })?;
                let finite = tree.center.iter().all(|c| c.is_finite()) && tree.radius.is_finite();
                if !finite || tree.radius.is_sign_negative() || tree.radius.to_bits() == 0 {
                    return Err(QsError::BadRootSphere { offset });
                }
                let children = order.u32(head, 36).unwrap_or(0);
                if !(2..=4).contains(&children) {
                    return Err(QsError::BadRootChildren { offset, children });
                }
                too_many |= trees.push(tree).is_err();
                Ok(())
            },
        )?;
        if too_many {
            return Err(StreamError::TooManyTrees {
                capacity: QS_MAX_TREES as u32,
            });
        }
        if trees.is_empty() {
            return Err(StreamError::Qs(QsError::NoTree));
        }
        // pocketsplat's comment carries the mesh's box; without it, the root spheres' box.
        let mut bounds = None;
        if let Some((offset, length)) = comment_at {
            let mut text = [0u8; COMMENT_READ];
            let n = (length as usize - COMMENT_HEADER_BYTES).min(COMMENT_READ);
            let at = u64::from(offset) + COMMENT_HEADER_BYTES as u64;
            read_retry(src, at, &mut text[..n], &mut counters)?;
            let end = text[..n].iter().rposition(|&b| b != 0).map_or(0, |i| i + 1);
            bounds = parse_bounds(&text[..end]);
        }
        let bs = 1u64 << block_log2;
        let nblocks = file_len.div_ceil(bs);
        let slots_avail = (data.len() >> block_log2).min(slots.len()) as u32;
        let mut cache = BlockCache::new(block_log2, data, slots, table, nblocks as usize)
            .map_err(|e| StreamError::too_small(e, bs as usize, slots_avail))?;
        // No group has been read from any block yet: each is of the finest class until one is.
        cache.set_classes(&[0; crate::tg::MAX_LEVELS], UNSEEN);
        // Without pocketsplat's comment, the resident reader's box: the spheres of the top levels
        // (a breadth-first file's first bytes), read now through the cache.
        let bounds = match bounds {
            Some(b) => b,
            None => {
                let mut now = ReadNow {
                    cache: &mut cache,
                    src,
                    file_len,
                    counters: &mut counters,
                    order,
                    tick: 0,
                };
                let b = tree_bounds_by(trees.iter().map(|h| (*h, *h)), BOUNDS_DEPTH, |h, g| {
                    now.group(h, g)
                });
                for s in cache.slots.iter_mut() {
                    s.used = 0;
                }
                b
            }
        };
        Ok(Self {
            order,
            trees,
            bounds,
            file_len,
            cache,
            queue: Vec::new(),
            missing: 1,
            inconsistent: 0,
            frame: 0,
            counters,
            refine: Resume::START,
            passing: false,
            deepest: 1,
            frontier: None,
        })
    }

    /// The trees' heads (root spheres and where each fragment is).
    pub fn trees(&self) -> &[TreeHead] {
        &self.trees
    }

    /// Whether any tree carries colours (its samples then tint a white material,
    /// [`crate::qs::shading_material`]).
    pub fn has_color(&self) -> bool {
        self.trees.iter().any(|t| t.color)
    }

    /// The model's box, as the resident reader finds it ([`crate::qs::QSplat::bounds`]):
    /// pocketsplat's bounds comment, else the box of the spheres of the trees' top levels, read
    /// at open.
    pub fn bounds(&self) -> [[f32; 3]; 2] {
        self.bounds
    }

    /// Bytes in the file.
    pub fn file_len(&self) -> u64 {
        self.file_len
    }

    /// Bytes per block.
    pub fn block_size(&self) -> usize {
        1 << self.cache.log2
    }

    /// The block cache.
    pub fn cache(&self) -> &BlockCache<'a> {
        &self.cache
    }

    /// Cumulative counts.
    pub fn counters(&self) -> &StreamCounters {
        &self.counters
    }

    /// Groups the last frame found missing (or, for a refined frame, refused by any of its passes)
    /// plus those it refused as malformed: 0 means it was drawn as the resident file would be.
    pub fn missing(&self) -> u32 {
        self.missing
    }

    /// Groups the last frame refused as malformed.
    pub fn inconsistent(&self) -> u32 {
        self.inconsistent
    }

    /// Whether the last frame was drawn at full detail.
    pub fn converged(&self) -> bool {
        self.missing == 0 && self.counters.frames > 0
    }

    /// The fewest blocks a cache of this file needs for a pass to go on: the groups on the path
    /// from a root to the node a pass stopped at (one block or two per level, down to the deepest
    /// level read so far), and the stop's own. Known as the walk goes down: a pass that finds no
    /// room names it.
    pub fn cache_need(&self) -> u32 {
        (2 * u32::from(self.deepest) + 4).max(MIN_SLOTS as u32)
    }

    /// The most [`QsStream::cache_need`] can become for any file (a tree of the deepest the
    /// reader takes): a cache of this many blocks streams any view of any file that opens.
    pub const MAX_CACHE_NEED: u32 = 2 * LEVELS as u32 + 4;

    #[doc(hidden)]
    pub fn debug_resume(&self) -> (Option<u8>, [u8; LEVELS]) {
        (self.refine.stop, self.refine.path)
    }

    /// Starts a refined frame drawn in passes ([`QsStream::render_pass`]).
    pub fn begin_refined(&mut self) {
        self.refine = Resume::START;
    }

    /// Whether the last [`QsStream::render_pass`] finished its refined frame.
    pub fn refined_done(&self) -> bool {
        self.refine.done
    }

    /// Passes drawn of the current refined frame.
    pub fn passes(&self) -> u32 {
        self.refine.passes
    }

    /// Blocks the last frame used plus those it queued: more than the cache holds means the frame
    /// cannot be drawn whole from the cache, and needs [`QsStream::render_pass`].
    pub fn working_set(&self) -> u32 {
        let used = self
            .cache
            .slots
            .iter()
            .filter(|e| e.used == self.frame && e.block != NO_BLOCK)
            .count() as u32;
        used + self.queue.len() as u32
    }

    /// Draws one frame from the resident blocks into `sink`, queueing the missing ones (the queue
    /// of the previous frame is cleared first, §3.4).
    pub fn render<S: ColorSink>(&mut self, frame: &QsFrame, sink: &mut S) -> Stats {
        let drawing = Cell::new(true);
        self.walk(frame, sink, Phase::Progressive, &drawing)
    }

    /// Draws the next pass of a refined frame into `sink`, whose colour and depth persist between
    /// passes; once [`QsStream::refined_done`], the framebuffer holds exactly the resident file's
    /// frame (every splat drawn once, in the resident order).
    pub fn render_pass<S: ColorSink>(&mut self, frame: &QsFrame, sink: &mut S) -> Stats {
        let drawing = Cell::new(true);
        let mut pass = PassSink {
            inner: sink,
            drawing: &drawing,
        };
        self.refine.passes += 1;
        self.walk(frame, &mut pass, Phase::Draw, &drawing)
    }

    fn walk<S: ColorSink>(
        &mut self,
        frame: &QsFrame,
        sink: &mut S,
        phase: Phase,
        drawing: &Cell<bool>,
    ) -> Stats {
        self.frame = self.frame.wrapping_add(1).max(1);
        self.counters.frames += 1;
        self.passing = phase != Phase::Progressive;
        clear_queue(&mut self.cache, &mut self.queue);
        let mut dropped = 0u32;
        let mut refused = 0u32;
        // What a pass may keep and queue: half the cache (less a margin). A pass that queues more
        // reads blocks far ahead of where the next pass stops, which the passes between evict
        // before they are used (dragon std 1 px through 64 KB: 138 % of the file read with the
        // whole cache, 91 % with half; passes 192 -> 244).
        let room =
            ((self.cache.capacity() as u32).saturating_sub(2) / 2).clamp(1, QUEUE_CAPACITY as u32);
        let mut pass = PassState {
            phase,
            stamp: if phase == Phase::Progressive {
                self.frame
            } else {
                self.frame.wrapping_sub(1)
            },
            drawing,
            resume: self.refine,
            on: -1,
            cur: [0; LEVELS],
            ranges: [(0, 0); LEVELS],
            stop: None,
            path: [0; LEVELS],
            room,
            kept: 0,
            lookahead: LOOKAHEAD_GROUPS,
            deepest: self.deepest,
            frontier: None,
        };
        // A frame reads no more nodes than the file could hold.
        let mut nodes_left = self.file_len / 4;
        let mut stats = Stats::default();
        for (t, head) in self.trees.iter().enumerate() {
            let mut nodes = StreamGroups {
                cache: &mut self.cache,
                queue: &mut self.queue,
                dropped: &mut dropped,
                refused: &mut refused,
                head: *head,
                order: self.order,
                next_free: [0; LEVELS],
                nodes_left: &mut nodes_left,
                frame: self.frame,
                pass: &mut pass,
                need: None,
            };
            if nodes.skip(0, t) {
                continue;
            }
            let nodes = walk_tree(head, nodes, frame, sink, true, &mut stats);
            if nodes.done() {
                break;
            }
        }
        if phase != Phase::Progressive {
            // A pass that met no absent group drew the rest of the frame; one that did resumes
            // there next time.
            self.refine.done = pass.phase == Phase::Draw;
            if let Some(level) = pass.stop {
                self.refine.stop = Some(level);
                self.refine.path = pass.path;
            }
            self.refine.refused = self.refine.refused.saturating_add(refused);
        }
        self.deepest = pass.deepest;
        self.frontier = pass.frontier;
        self.counters.dropped += dropped;
        self.counters.inconsistent += refused;
        self.inconsistent = refused;
        let refused = if phase == Phase::Progressive {
            refused
        } else {
            self.refine.refused
        };
        self.missing = self.queue.len() as u32 + dropped + refused;
        stats
    }

    /// Reads queued blocks, best first, until `budget_bytes` are spent (at least one block per
    /// call); when the last frame missed nothing, prefetches the rest of the file in file order
    /// (coarse levels first: the file is breadth-first). A failed read stays absent and waits out
    /// a backoff.
    pub fn serve<C: ChunkSource + ?Sized>(
        &mut self,
        src: &mut C,
        budget_bytes: u32,
    ) -> ServeReport {
        if self.passing {
            self.make_room(budget_bytes);
        }
        let mut feed = Feed {
            block_size: self.block_size(),
            file_len: self.file_len,
            cache: &mut self.cache,
            queue: &mut self.queue,
            counters: &mut self.counters,
            frame: self.frame,
        };
        feed.serve(
            src,
            budget_bytes,
            self.passing,
            self.missing,
            |cache, frame| first_absent(cache, 0, frame),
            // No CRCs in the format: groups are checked as the walk reads them.
            |_, _, _| Verdict::Good,
        )
    }
}

impl QsStream<'_> {
    /// Before a pass's reads of up to `budget_bytes`: makes room for them in the slots this pass
    /// does not keep, emptying first blocks the refined frame's walk has passed at every level read
    /// from them (a breadth-first file lays each level's groups in walk order: the walk will not
    /// come back to them), then blocks a pass drew from, oldest first, and only then blocks read
    /// ahead that no pass has used yet. Only a preference: a block wrongly emptied is read again.
    fn make_room(&mut self, budget_bytes: u32) {
        let log2 = self.cache.log2;
        let wanted = self.queue.len().min((budget_bytes as usize >> log2).max(1));
        let free = self
            .cache
            .slots
            .iter()
            .filter(|s| s.block == NO_BLOCK)
            .count();
        let (tree, free_at) = self.frontier.unwrap_or((0, [0; LEVELS]));
        let passed = |block: u32, e: &BlockEntry| -> bool {
            let deepest = e.flags & LEVEL_MASK;
            if self.frontier.is_none() || e.class == UNSEEN || deepest == 0 {
                return false;
            }
            let start = u64::from(block) << log2;
            let end = start + (1u64 << log2);
            start >= u64::from(tree)
                && (e.class..deepest).all(|k| {
                    free_at
                        .get(usize::from(k))
                        .is_some_and(|&f| f > 0 && end <= u64::from(tree) + u64::from(f))
                })
        };
        for _ in free..wanted {
            let mut best: Option<(usize, (bool, bool, u32))> = None;
            for (s, slot) in self.cache.slots.iter().enumerate() {
                let Some(e) = self.cache.entry(slot.block as usize) else {
                    continue;
                };
                if slot.used == self.frame {
                    continue; // kept by this pass
                }
                let key = (
                    passed(slot.block, e),
                    e.flags & DRAWN != 0,
                    self.frame.wrapping_sub(slot.used),
                );
                if best.is_none_or(|(_, k)| key > k) {
                    best = Some((s, key));
                }
            }
            let Some((s, _)) = best else {
                break;
            };
            // (What is noted of the block goes with it.)
            if self.cache.evict(s) {
                self.counters.evictions += 1;
            }
        }
    }
}

/// The `len` bytes of a group at file offset `off`, from one resident block or two.
fn copy_group(cache: &BlockCache<'_>, off: u64, len: usize) -> Option<[u8; GROUP_MAX]> {
    let mut buf = [0u8; GROUP_MAX];
    let log2 = cache.log2;
    let mut copied = 0usize;
    while copied < len {
        let o = off + copied as u64;
        let within = (1usize << log2) - (o & ((1u64 << log2) - 1)) as usize;
        let n = within.min(len - copied);
        buf.get_mut(copied..copied + n)?
            .copy_from_slice(cache.bytes(o, n)?);
        copied += n;
    }
    Some(buf)
}

/// Where group `g`'s first child group starts (fragment offset), from its pointer in `buf` (the
/// group's bytes); 0 without one.
fn group_cursor(buf: &[u8; GROUP_MAX], g: Group, order: ByteOrder) -> i64 {
    match g.pointer {
        Some(start) => {
            let p = order.u32(buf, 0).unwrap_or(0) as i32;
            i64::from(start) + i64::from(p)
        }
        None => 0,
    }
}

/// The records of group `g` copied into `buf`.
fn records(
    buf: [u8; GROUP_MAX],
    g: Group,
    color: bool,
    cursor: i64,
) -> Records<GroupBytes<GROUP_MAX>> {
    Records {
        bytes: GroupBytes {
            bytes: buf,
            base: g.pointer.unwrap_or(g.first),
        },
        color,
        at: g.first,
        left: g.count,
        cursor: u32::try_from(cursor).unwrap_or(u32::MAX),
    }
}

/// Groups read now, their blocks loaded through the cache where absent (least recently used
/// first): the bounds walk at open, before the first frame.
struct ReadNow<'c, 'a, C: ?Sized> {
    cache: &'c mut BlockCache<'a>,
    src: &'c mut C,
    file_len: u64,
    counters: &'c mut StreamCounters,
    order: ByteOrder,
    /// Reads so far: what a slot's last use is stamped with.
    tick: u32,
}

impl<C: ChunkSource + ?Sized> ReadNow<'_, '_, C> {
    /// Group `g` of tree `head` (`None`: outside its fragment, or a read failed every attempt).
    fn group(&mut self, head: &TreeHead, g: Group) -> Option<Records<GroupBytes<GROUP_MAX>>> {
        let start = g.pointer.unwrap_or(g.first);
        let end = u64::from(g.first) + u64::from(g.count) * u64::from(head.node_bytes());
        if !(2..=4).contains(&g.count) || start < HEADER_BYTES as u32 || end > u64::from(head.len) {
            return None;
        }
        let off = u64::from(head.offset) + u64::from(start);
        let len = (end - u64::from(start)) as usize;
        let log2 = self.cache.log2;
        for b in off >> log2..=(off + len as u64 - 1) >> log2 {
            let b = usize::try_from(b).ok()?;
            self.tick += 1;
            if self.cache.touch(b, self.tick) {
                continue;
            }
            let s = self.cache.victim(UNSEEN, self.tick, Evict::Demand)?;
            self.cache.evict(s);
            let at = (b as u64) << log2;
            let n = self.file_len.saturating_sub(at).min(1 << log2) as usize;
            read_retry(
                self.src,
                at,
                &mut self.cache.slot_bytes(s)[..n],
                self.counters,
            )
            .ok()?;
            self.cache.install(s, b, self.tick);
        }
        let buf = copy_group(self.cache, off, len)?;
        let cursor = group_cursor(&buf, g, self.order);
        Some(records(buf, g, head.color, cursor))
    }
}

/// A pass's walk state; a frame drawn whole has [`Phase::Progressive`].
struct PassState<'s> {
    phase: Phase,
    /// What a touch marks a block used at: the frame, or the frame before while a pass draws
    /// (blocks it only drew from are not kept for the later passes).
    stamp: u32,
    /// Cleared at the pass's first absent group: nothing more is drawn.
    drawing: &'s Cell<bool>,
    resume: Resume,
    /// Deepest level down to which the walk's position follows `resume.path` (-1: none).
    on: i16,
    /// The member index the walk is at, per level (0: the tree).
    cur: [u8; LEVELS],
    /// Per level, the blocks of the group read last there (the current node's ancestors').
    ranges: [(u64, u64); LEVELS],
    /// Where this pass stopped: the level of the node whose group was absent, and its path.
    stop: Option<u8>,
    path: [u8; LEVELS],
    /// Blocks the lookahead may keep or queue.
    room: u32,
    /// Blocks marked kept since the stop, plus those queued.
    kept: u32,
    /// Groups the lookahead may still read.
    lookahead: u32,
    /// Deepest level a group was read at.
    deepest: u8,
    /// At the stop: the tree's fragment offset and, per level, where the walk's next group there
    /// starts (the walk never reads that level below it again in this refined frame).
    frontier: Option<(u32, [u32; LEVELS])>,
}

/// The walk's view of one tree of a stream: groups read through the cache and checked.
struct StreamGroups<'s, 'a, 'p> {
    cache: &'s mut BlockCache<'a>,
    queue: &'s mut Vec<Request, QUEUE_CAPACITY>,
    dropped: &'s mut u32,
    refused: &'s mut u32,
    head: TreeHead,
    order: ByteOrder,
    /// Per level, the fragment offset after the last group read there this frame.
    next_free: [u32; LEVELS],
    nodes_left: &'s mut u64,
    frame: u32,
    pass: &'s mut PassState<'p>,
    /// The blocks the last unavailable group needs (`None`: it was refused, not absent).
    need: Option<(u64, u64)>,
}

impl StreamGroups<'_, '_, '_> {
    /// Whether block `b` is resident; marks it used at the pass's stamp, counting what the
    /// lookahead newly keeps.
    fn touch(&mut self, b: usize, level: u8) -> bool {
        let stamp = self.pass.stamp;
        if self.pass.phase == Phase::Lookahead && self.cache.used(b).is_some_and(|u| u != stamp) {
            self.pass.kept += 1;
        }
        let drawing = self.pass.phase == Phase::Draw;
        if let Some(e) = self.cache.entry_mut(b) {
            e.class = e.class.min(level);
            // The deepest level read from the block, plus one (0: none yet), and whether a pass
            // drew from it.
            let deepest = (e.flags & LEVEL_MASK).max(level.saturating_add(1));
            e.flags = deepest | (e.flags & DRAWN) | if drawing { DRAWN } else { 0 };
        }
        self.cache.touch(b, stamp)
    }

    fn refuse(&mut self) -> Option<Records<GroupBytes<GROUP_MAX>>> {
        *self.refused += 1;
        self.need = None;
        None
    }

    /// Queues block `b`, which a group of `level` lies in; returns whether it was newly queued.
    fn queue(&mut self, b: u64, priority: u32, level: u8) -> bool {
        let b = usize::try_from(b).unwrap_or(usize::MAX);
        let newly = push(self.cache, self.queue, self.dropped, b, priority);
        if let Some(e) = self.cache.entry_mut(b) {
            e.class = e.class.min(level);
        }
        newly
    }

    /// The pass stops drawing at the node at `level` on the current path, whose group is absent:
    /// the next pass resumes there, and the blocks of the groups down to it are kept for it.
    fn stop_at(&mut self, level: u8) {
        let l = usize::from(level);
        // A node above the last stop on the resume path: this pass drew nothing yet, and the next
        // one resumes where the last one stopped.
        let above = self
            .pass
            .resume
            .stop
            .is_some_and(|s| level < s && self.pass.on >= i16::from(level));
        if !above {
            self.pass.stop = Some(level);
            self.pass.path[..=l].copy_from_slice(&self.pass.cur[..=l]);
        }
        self.pass.phase = Phase::Lookahead;
        self.pass.drawing.set(false);
        self.pass.stamp = self.frame;
        self.pass.frontier = Some((self.head.offset, self.next_free));
        for k in 1..=l {
            let (a, z) = self.pass.ranges[k];
            for b in a..=z {
                self.touch(b as usize, k as u8);
            }
        }
        // The frontier below: at each level, the block where the walk's next group there starts
        // (a breadth-first file lays each level's groups in walk order, so a block holds the
        // groups of one stretch of the walk; without this, a block left between two of its groups
        // would be read again).
        let log2 = self.cache.log2;
        for k in l + 1..LEVELS {
            let free = self.next_free[k];
            if free == 0 {
                continue;
            }
            if self.pass.kept >= self.pass.room {
                break;
            }
            let b = (u64::from(self.head.offset) + u64::from(free)) >> log2;
            if self.cache.contains(b as usize) {
                self.touch(b as usize, k as u8);
            }
        }
    }
}

impl QsNodes for StreamGroups<'_, '_, '_> {
    type Records = Records<GroupBytes<GROUP_MAX>>;

    fn group(&mut self, g: Group, level: u8) -> Option<Self::Records> {
        self.need = None;
        if self.pass.phase == Phase::Done {
            return None;
        }
        let l = usize::from(level);
        let h = self.head;
        let nb = h.node_bytes();
        let start = g.pointer.unwrap_or(g.first);
        let end = u64::from(g.first) + u64::from(g.count) * u64::from(nb);
        let ok = (2..=4).contains(&g.count)
            && l < LEVELS
            && start >= HEADER_BYTES as u32
            && g.first.wrapping_sub(start) <= 4
            && end <= u64::from(h.len)
            && start >= self.next_free.get(l).copied().unwrap_or(u32::MAX)
            && u64::from(g.count) <= *self.nodes_left;
        if !ok {
            return self.refuse();
        }
        if self.pass.phase == Phase::Lookahead {
            // A group touches or queues at most 2 blocks: stop before what the pass keeps could
            // pass its room.
            if self.pass.lookahead == 0 || self.pass.kept + 2 > self.pass.room {
                self.pass.phase = Phase::Done;
                return None;
            }
            self.pass.lookahead -= 1;
        }
        let off = u64::from(h.offset) + u64::from(start);
        let len = (end - u64::from(start)) as usize;
        let log2 = self.cache.log2;
        let (b0, b1) = (off >> log2, (off + len as u64 - 1) >> log2);
        let mut all = true;
        for b in b0..=b1 {
            all &= self.touch(b as usize, level);
        }
        if !all {
            self.need = Some((b0, b1));
            return None;
        }
        let Some(buf) = copy_group(self.cache, off, len) else {
            return self.refuse();
        };
        let cursor = group_cursor(&buf, g, self.order);
        let mut parents = false;
        for i in 0..u32::from(g.count) {
            let node = node_at(&buf, (g.first - start + i * nb) as usize, h.color);
            let leaf = node.children == 0;
            if usize::from(node.sphere) >= SPHERE_COUNT || (leaf && node.grandchildren) {
                return self.refuse();
            }
            parents |= !leaf;
        }
        if parents
            && (g.pointer.is_none()
                || l + 1 >= LEVELS
                || cursor < end as i64
                || cursor > i64::from(h.len))
        {
            return self.refuse();
        }
        self.next_free[l] = end as u32;
        self.pass.deepest = self.pass.deepest.max(level);
        *self.nodes_left -= u64::from(g.count);
        self.pass.ranges[l] = (b0, b1);
        Some(records(buf, g, h.color, cursor))
    }

    fn absent(&mut self, _g: Group, level: u8, parent: Option<&SampleSplat>) {
        // Refused: drawn coarser, nothing to read.
        let Some((b0, b1)) = self.need.take() else {
            return;
        };
        match self.pass.phase {
            Phase::Progressive => {
                let p = parent.map_or(ROOT_PRIORITY, |s| stream_priority(s.size_q8, s.y_q8));
                for b in b0..=b1 {
                    self.queue(b, p, level);
                }
            }
            Phase::Draw => {
                self.stop_at(level - 1);
                for b in b0..=b1 {
                    // A group across two blocks, one of them resident: the next pass needs both,
                    // so the resident one is kept too (else reading the other could evict it).
                    if !self.touch(b as usize, level) && self.queue(b, ROOT_PRIORITY, level) {
                        self.pass.kept += 1;
                    }
                }
            }
            Phase::Lookahead => {
                for b in b0..=b1 {
                    // A pass reads in file order (what an SD card serves best).
                    let p =
                        u32::MAX - 1 - u32::try_from(b).unwrap_or(u32::MAX - 2).min(u32::MAX - 2);
                    if self.queue(b, p, level) {
                        self.pass.kept += 1;
                    }
                }
            }
            Phase::Done => {}
        }
        if self.pass.phase == Phase::Lookahead && self.pass.kept >= self.pass.room {
            self.pass.phase = Phase::Done;
        }
    }

    fn skip(&mut self, level: u8, index: usize) -> bool {
        let l = usize::from(level);
        let i = index as u8;
        if let Some(c) = self.pass.cur.get_mut(l) {
            *c = i;
        }
        let on = &mut self.pass.on;
        if *on + 1 < i16::from(level) {
            return false; // off the path: nothing here was drawn before
        }
        *on = i16::from(level) - 1;
        match self.pass.resume.stop {
            Some(stop) if level <= stop => {
                let want = self.pass.resume.path[l];
                if i < want {
                    return true;
                }
                if i == want {
                    *on = i16::from(level);
                }
                false
            }
            _ => false,
        }
    }

    fn done(&self) -> bool {
        self.pass.phase == Phase::Done
    }
}

#[cfg(all(test, feature = "bake"))]
mod tests {
    #![allow(clippy::float_arithmetic)]
    use super::*;
    use crate::camera::{Camera, Placement, Sphere, STANDARD_VIEWS};
    use crate::frame::RenderOptions;
    use crate::qs::write::{bake_qs, qsplat1_layout, tests::uv_sphere, QsBakeOptions};
    use crate::qs::{render_qs_colored, QSplat};
    use crate::splat::SplatSink;
    use crate::stream::MemSource;
    use std::vec::Vec as StdVec;

    /// Every splat a walk hands over, with its colour.
    #[derive(Default)]
    struct Record(StdVec<(SampleSplat, Option<u16>)>);
    impl SplatSink for Record {
        fn splat(&mut self, s: &SampleSplat) {
            self.0.push((*s, None));
        }
    }
    impl ColorSink for Record {
        fn splat_colored(&mut self, s: &SampleSplat, rgb: u16) {
            self.0.push((*s, Some(rgb)));
        }
    }

    struct Mem {
        data: StdVec<u8>,
        slots: StdVec<SlotEntry>,
        blocks: StdVec<BlockEntry>,
    }

    impl Mem {
        fn new(slots: usize, log2: u8, _file: usize) -> Self {
            Self {
                data: std::vec![0; slots << log2],
                slots: std::vec![SlotEntry::EMPTY; slots],
                blocks: std::vec![BlockEntry::EMPTY; crate::stream::table_entries(slots, QUEUE_CAPACITY)],
            }
        }
    }

    fn frame_of(
        trees: impl Iterator<Item = TreeHead> + Clone,
        bounds: [[f32; 3]; 2],
        cutoff: f32,
    ) -> QsFrame {
        let cam = Camera::orbit(Sphere::from_bounds(bounds), STANDARD_VIEWS[0].1, 45.0);
        let opts = RenderOptions::default().with_cutoff(cutoff);
        QsFrame::of_trees(trees, &Placement::IDENTITY, &cam, &opts).unwrap()
    }

    /// Streams `bytes` until converged (frames drawn whole while the cache keeps what they read,
    /// then passes); returns the splats of the converged frame in order, and the passes.
    fn stream(
        bytes: &[u8],
        slots: usize,
        log2: u8,
        cutoff: f32,
    ) -> (StdVec<(SampleSplat, Option<u16>)>, u32) {
        let mut mem = Mem::new(slots, log2, bytes.len());
        let mut src = MemSource::new(bytes);
        let mut s = QsStream::open(
            &mut src,
            log2,
            &mut mem.data,
            &mut mem.slots,
            &mut mem.blocks,
        )
        .unwrap();
        let frame = frame_of(s.trees().iter().copied(), s.bounds(), cutoff);
        let mut refining = false;
        let mut out = Record::default();
        for _ in 0..100_000 {
            let mut rec = Record::default();
            if refining {
                s.render_pass(&frame, &mut rec);
                out.0.extend(rec.0);
                if s.refined_done() {
                    assert_eq!(s.missing(), 0);
                    return (out.0, s.passes());
                }
            } else {
                s.render(&frame, &mut rec);
                if s.converged() {
                    return (rec.0, 0);
                }
                if s.working_set() as usize > s.cache().capacity() || s.counters().evictions > 0 {
                    refining = true;
                    s.begin_refined();
                    continue;
                }
            }
            let r = s.serve(&mut src, 4096);
            assert!(r.reads > 0 || !refining, "stuck: {r:?}");
        }
        panic!("did not converge");
    }

    #[test]
    fn files_in_qsplat_1_layout_stream_to_the_resident_frame() {
        let q = bake_qs(&uv_sphere(40, 80), &QsBakeOptions::default()).unwrap();
        for little in [false, true] {
            let bytes = qsplat1_layout(&q.bytes, little).unwrap();
            let file = QSplat::open(&bytes).unwrap();
            let frame = frame_of(file.trees().map(|t| t.head()), file.bounds(), 1.0);
            let mut want = Record::default();
            render_qs_colored(&file, &frame, &mut want);
            // The bounds the stream finds at open are the resident reader's (no comment: the
            // top levels' spheres), so the camera is the same.
            let mut mem = Mem::new(16, 9, bytes.len());
            let s = QsStream::open(
                &mut MemSource::new(&bytes),
                9,
                &mut mem.data,
                &mut mem.slots,
                &mut mem.blocks,
            )
            .unwrap();
            assert_eq!(s.bounds(), file.bounds());
            for slots in [256, 16] {
                let (got, _) = stream(&bytes, slots, 9, 1.0);
                assert!(got == want.0, "little {little}, {slots} slots");
            }
        }
    }

    /// Damaged bytes anywhere in the tree: every frame ends, reads no more nodes than the file
    /// can hold, and never panics; the frame never counts as converged where a group was refused.
    #[test]
    fn damaged_groups_are_refused_never_a_fault() {
        let q = bake_qs(&uv_sphere(20, 40), &QsBakeOptions::default()).unwrap();
        let mut seed = 0x2545_F491_4F6C_DD1Du64;
        let mut rnd = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        let mut refused = 0u32;
        for _ in 0..300 {
            let mut bytes = q.bytes.clone();
            let body = bytes.len() - 200;
            for _ in 0..1 + rnd() % 4 {
                let at = 200 + (rnd() as usize % body);
                bytes[at] ^= 1 << (rnd() % 8);
            }
            let Ok(file_nodes) = u32::try_from(bytes.len() / 4) else {
                continue;
            };
            let mut mem = Mem::new(8, 9, bytes.len());
            let mut src = MemSource::new(&bytes);
            let Ok(mut s) =
                QsStream::open(&mut src, 9, &mut mem.data, &mut mem.slots, &mut mem.blocks)
            else {
                continue;
            };
            let frame = frame_of(s.trees().iter().copied(), s.bounds(), 1.0);
            s.begin_refined();
            for _ in 0..200 {
                let stats = s.render_pass(&frame, &mut crate::splat::NullSink::default());
                assert!(stats.nodes_visited <= file_nodes + 1);
                if s.refined_done() {
                    break;
                }
                s.serve(&mut src, 4096);
            }
            refused += u32::from(s.counters().inconsistent > 0);
            if s.counters().inconsistent > 0 {
                assert!(!s.converged());
            }
        }
        assert!(refused > 10, "{refused}");
    }

    #[test]
    fn streamed_frames_are_the_resident_frame_splat_for_splat() {
        let q = bake_qs(&uv_sphere(60, 120), &QsBakeOptions::default()).unwrap();
        let file = QSplat::open(&q.bytes).unwrap();
        for cutoff in [1.0, 3.0] {
            let frame = frame_of(file.trees().map(|t| t.head()), file.bounds(), cutoff);
            let mut want = Record::default();
            render_qs_colored(&file, &frame, &mut want);
            assert!(want.0.len() > 1000, "{}", want.0.len());
            // A cache that holds the file: frames drawn whole converge.
            let (got, passes) = stream(&q.bytes, 256, 9, cutoff);
            assert_eq!(passes, 0);
            assert!(got == want.0, "cutoff {cutoff}: whole frames");
            // A cache of 24 blocks of 512 bytes for a file of about 100: passes.
            let (got, passes) = stream(&q.bytes, 24, 9, cutoff);
            assert!(passes > 1, "{passes}");
            assert_eq!(got.len(), want.0.len(), "cutoff {cutoff}: passes");
            assert!(got == want.0, "cutoff {cutoff}: passes");
        }
    }
}
