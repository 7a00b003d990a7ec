//! Streaming a scene pack: the pack's metadata read once, each object's file streamed through its
//! own block cache from where it lies in the pack ([`Window`]), and every frame drawn by the
//! scene's own frame function (`scene::draw::render_objects`, through [`Objects`]), so that a
//! converged frame is the frame of the pack opened whole.
//!
//! - **Frames from what is resident** ([`SceneStream::render`]) draw each object as its stream
//!   allows (coarser where blocks are absent, Streaming QSplat §3.2), with the pack's shadows:
//!   one-pass shadows through the streamed walk's hooks; two-pass casts each object's resident
//!   blocks first, then draws ([`TgStream::fill_with`]). A frame converges when no object missed
//!   anything, in its cast or in its draw.
//! - **A refined frame in passes** ([`SceneStream::render_pass`], with the pack's shadows): the
//!   frame's steps in order (two-pass: every cast, then every draw; one-pass: the draws in light
//!   order), each in its own passes over the shared depth buffer and map, one finished before the
//!   next begins, so that the passes add up to the resident frame.
//! - [`SceneStream::serve`] reads for the objects that missed something first, then lets the
//!   others prefetch, within one I/O budget; during a refined frame only the object being drawn
//!   reads.

#[cfg(feature = "qsplat")]
use super::QsStream;
use super::{ChunkSource, ServeReport, StreamCounters, StreamError, TgStream};
use crate::camera::Camera;
use crate::frame::RenderOptions;
use crate::scene::draw::{render_objects, Objects};
use crate::scene::{Kind, MAX_META_BYTES, MAX_OBJECTS};
use crate::scene::{ObjectFile, ObjectRecord, Pack, PackError, Scene, SceneError, SceneStats};
#[cfg(feature = "shadows")]
use crate::shadow::LightFrame;
use crate::splat::{SplatSink, Stats};
use crate::tg::read::Header;
use crate::tg::traverse::ShadowHooks;
use crate::tg::TgFrame;

/// Part of a file on a medium seen as a file of its own: an object's file inside a pack.
#[derive(Debug)]
pub struct Window<'s, C: ?Sized> {
    src: &'s mut C,
    base: u64,
    len: u64,
}

impl<'s, C: ChunkSource + ?Sized> Window<'s, C> {
    /// Bytes `base .. base + len` of `src`.
    pub fn new(src: &'s mut C, base: u64, len: u64) -> Self {
        Self { src, base, len }
    }

    /// Object `rec`'s file in the pack on `src`.
    pub fn of(src: &'s mut C, rec: &ObjectRecord<'_>) -> Self {
        Self::new(src, u64::from(rec.data_offset), u64::from(rec.data_len))
    }
}

/// Why a [`Window`] read failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum WindowError<E> {
    /// The medium failed.
    Device(E),
    /// The read runs past the end of the window.
    OutOfRange {
        /// Start of the read, in the window.
        offset: u64,
        /// Its length.
        len: usize,
    },
}

impl<C: ChunkSource + ?Sized> ChunkSource for Window<'_, C> {
    type Error = WindowError<C::Error>;
    fn read_at(&mut self, offset: u64, buf: &mut [u8]) -> Result<(), Self::Error> {
        let len = buf.len();
        let end = offset.checked_add(len as u64);
        if end.is_none_or(|e| e > self.len) {
            return Err(WindowError::OutOfRange { offset, len });
        }
        self.src
            .read_at(self.base + offset, buf)
            .map_err(WindowError::Device)
    }
    fn mapped(&self) -> Option<&[u8]> {
        let start = usize::try_from(self.base).ok()?;
        let end = start.checked_add(usize::try_from(self.len).ok()?)?;
        self.src.mapped()?.get(start..end)
    }
    fn byte_len(&self) -> Option<u64> {
        Some(self.len)
    }
}

/// Why a scene pack cannot be streamed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SceneStreamError<E> {
    /// The medium failed on the pack's metadata, every attempt.
    Device(E),
    /// The metadata is not a valid pack's.
    Pack(PackError),
    /// The metadata is longer than the buffer given for it.
    MetaBuffer {
        /// Bytes of metadata.
        need: u32,
        /// Bytes of buffer.
        given: u32,
    },
    /// An object's file cannot be streamed.
    Object {
        /// The object.
        object: u8,
        /// Why.
        error: StreamError<WindowError<E>>,
    },
    /// An object's file does not fit its record, or the scene cannot be drawn.
    Scene(SceneError),
}

impl<E: core::fmt::Debug> core::fmt::Display for SceneStreamError<E> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            SceneStreamError::Device(e) => write!(f, "read failed: {e:?}"),
            SceneStreamError::Pack(e) => write!(f, "{e}"),
            SceneStreamError::MetaBuffer { need, given } => write!(
                f,
                "the pack's metadata is {need} bytes, more than the {given} bytes given for it"
            ),
            SceneStreamError::Object { object, error } => write!(f, "object {object}: {error}"),
            SceneStreamError::Scene(e) => write!(f, "{e}"),
        }
    }
}

impl<E: core::fmt::Debug> core::error::Error for SceneStreamError<E> {}

/// Reads and validates the metadata of the pack on `src` into `meta` (at most
/// [`MAX_META_BYTES`]), retrying each read: the header, then the tables it announces.
///
/// # Errors
/// [`SceneStreamError::Device`] when a read fails every attempt, [`SceneStreamError::Pack`] when
/// the metadata is not valid, [`SceneStreamError::MetaBuffer`] when `meta` is too small.
pub fn read_pack_meta<'m, C: ChunkSource + ?Sized>(
    src: &mut C,
    meta: &'m mut [u8],
) -> Result<Pack<'m>, SceneStreamError<C::Error>> {
    let head = crate::scene::HEADER_BYTES;
    let given = meta.len() as u32;
    let buf = meta.get_mut(..head).ok_or(SceneStreamError::MetaBuffer {
        need: head as u32,
        given,
    })?;
    // A medium that knows its length says a short pack is short (not that a read failed).
    let known = src.byte_len();
    let short = |need: usize| {
        known.filter(|&found| found < need as u64).map(|found| {
            SceneStreamError::Pack(PackError::TooShort {
                need: need as u64,
                found,
            })
        })
    };
    if let Some(e) = short(head) {
        return Err(e);
    }
    read_retrying(src, 0, buf)?;
    let need = Pack::meta_len_of(buf);
    // A header that claims more metadata than any pack has is refused by the pack's own check;
    // only what a valid pack may have is read.
    let len = (need as usize).clamp(head, MAX_META_BYTES);
    if len > meta.len() {
        return Err(SceneStreamError::MetaBuffer { need, given });
    }
    if let Some(e) = short(len) {
        return Err(e);
    }
    read_retrying(src, head as u64, &mut meta[head..len])?;
    // The pack's length: the medium's, else the header's own (a read past the real end then
    // fails, and its blocks stay absent).
    let file_len = src
        .byte_len()
        .unwrap_or_else(|| u64::from(u32::from_le_bytes([meta[8], meta[9], meta[10], meta[11]])));
    Pack::open_meta(&meta[..len], file_len).map_err(SceneStreamError::Pack)
}

fn read_retrying<C: ChunkSource + ?Sized>(
    src: &mut C,
    offset: u64,
    buf: &mut [u8],
) -> Result<(), SceneStreamError<C::Error>> {
    let mut last = None;
    for _ in 0..super::OPEN_ATTEMPTS {
        match src.read_at(offset, buf) {
            Ok(()) => return Ok(()),
            Err(e) => last = Some(e),
        }
    }
    Err(SceneStreamError::Device(
        last.expect("at least one attempt"),
    ))
}

/// Bytes of cache each of a pack's objects streams through, out of `cache_bytes` shared by all,
/// into `shares`: first what its stream needs at once (`needs[i]`, at most its file and the block
/// its last bytes share), then the rest in proportion to what its file (`lens[i]` bytes) has beyond
/// that, so that an object keeps resident as much more of itself as it has more to keep. The
/// simulator's heap streams and the firmware's one static pool split their cache so.
///
/// # Errors
/// The bytes the objects need at once, when that is more than `cache_bytes` (or the slices differ
/// in length).
pub fn cache_shares(
    lens: &[usize],
    needs: &[usize],
    cache_bytes: usize,
    shares: &mut [usize],
) -> Result<(), usize> {
    let need = needs.iter().fold(0usize, |a, &n| a.saturating_add(n));
    if need > cache_bytes || lens.len() != needs.len() || shares.len() != needs.len() {
        return Err(need);
    }
    let spare = (cache_bytes - need) as u128;
    let beyond = |i: usize| lens[i].saturating_sub(needs[i]) as u128;
    let total = (0..lens.len()).map(beyond).sum::<u128>().max(1);
    for (i, share) in shares.iter_mut().enumerate() {
        *share = needs[i] + (spare * beyond(i) / total) as usize;
    }
    Ok(())
}

/// One object's file being streamed.
// The two streams differ by a few hundred bytes of ~3 KB, and the core has no heap to box one.
#[allow(clippy::large_enum_variant)]
#[derive(Debug)]
pub enum ObjectStream<'a> {
    /// A tri-grid.
    Grid(TgStream<'a>),
    /// A QSplat file.
    #[cfg(feature = "qsplat")]
    QSplat(QsStream<'a>),
}

/// What [`ObjectStream`] forwards to the stream it holds.
macro_rules! each {
    ($s:expr, $x:ident => $e:expr) => {
        match $s {
            ObjectStream::Grid($x) => $e,
            #[cfg(feature = "qsplat")]
            ObjectStream::QSplat($x) => $e,
        }
    };
}

impl ObjectStream<'_> {
    /// Whether its last frame (or pass) missed nothing.
    pub fn converged(&self) -> bool {
        each!(self, s => s.converged())
    }
    /// What its last frame missed.
    pub fn missing(&self) -> u32 {
        each!(self, s => s.missing())
    }
    /// Descents its last frame refused as malformed.
    pub fn inconsistent(&self) -> u32 {
        each!(self, s => s.inconsistent())
    }
    /// Cumulative counts.
    pub fn counters(&self) -> &StreamCounters {
        each!(self, s => s.counters())
    }
    /// Whether its last pass finished its part of the refined frame.
    pub fn refined_done(&self) -> bool {
        each!(self, s => s.refined_done())
    }
    /// Passes of the refined frame so far.
    pub fn passes(&self) -> u32 {
        each!(self, s => s.passes())
    }
    /// Blocks its last frame used and queued.
    pub fn working_set(&self) -> u32 {
        each!(self, s => s.working_set())
    }
    /// Blocks its cache holds, and how many are resident.
    pub fn cache_blocks(&self) -> (usize, usize) {
        each!(self, s => (s.cache().capacity(), s.cache().resident()))
    }
    /// The fewest blocks its cache must hold.
    pub fn cache_need(&self) -> u32 {
        each!(self, s => s.cache_need())
    }
    /// Its block size, bytes.
    pub fn block_size(&self) -> usize {
        match self {
            ObjectStream::Grid(s) => s.header().block_size(),
            #[cfg(feature = "qsplat")]
            ObjectStream::QSplat(s) => s.block_size(),
        }
    }
    fn serve<C: ChunkSource + ?Sized>(&mut self, src: &mut C, budget: u32) -> ServeReport {
        each!(self, s => s.serve(src, budget))
    }
}

/// A scene pack being streamed: its metadata, and a stream per object (in the caller's memory:
/// kilobytes each, a board keeps them in a static rather than on its stack).
#[derive(Debug)]
pub struct SceneStream<'m, 'a, 'o> {
    scene: Scene<'m>,
    objects: &'o mut [ObjectStream<'a>],
    /// Where a refined frame drawn in passes stands.
    refine: Refine,
}

/// Where a refined frame drawn in passes stands: its steps are the scene frame's casts (two-pass
/// shadows) and draws, in the order the frame takes them, each an object drawn (or cast) in its
/// own passes.
#[derive(Clone, Copy, Debug, Default)]
struct Refine {
    /// The first step not finished.
    step: usize,
    /// Whether that step has begun (its stream began a refined frame of its own).
    started: bool,
    /// Steps the frame takes (known after its first pass).
    steps: usize,
    /// The object of the step the last pass stopped in: the one whose blocks are read.
    object: usize,
    /// Passes drawn.
    passes: u32,
}

impl<'m, 'a, 'o> SceneStream<'m, 'a, 'o> {
    /// The scene of `pack` (from [`read_pack_meta`]), its objects' files streamed by `objects`,
    /// one per object in the pack's order, each opened on its [`Window`].
    ///
    /// # Errors
    /// [`SceneError`] when a stream is not of its record's kind (`Rho` and `MaterialBits` as
    /// for a pack opened whole), or the count differs from the pack's.
    pub fn new(pack: Pack<'m>, objects: &'o mut [ObjectStream<'a>]) -> Result<Self, SceneError> {
        let given = objects.len();
        if given != pack.object_count() {
            return Err(SceneError::Streams {
                objects: pack.object_count() as u8,
                streams: given.min(255) as u8,
            });
        }
        for (i, o) in objects.iter().enumerate() {
            let kind = match o {
                ObjectStream::Grid(_) => Kind::TriGrid,
                #[cfg(feature = "qsplat")]
                ObjectStream::QSplat(_) => Kind::QSplat,
            };
            if pack.object(i).map(|r| r.kind) != Some(kind) {
                return Err(SceneError::StreamKind { object: i as u8 });
            }
        }
        let scene = Scene::streamed(pack, |i| match &objects[i] {
            ObjectStream::Grid(s) => ObjectFile::Grid(s.header()),
            #[cfg(feature = "qsplat")]
            ObjectStream::QSplat(s) => ObjectFile::QSplat(s.bounds()),
        })?;
        Ok(Self {
            scene,
            objects,
            refine: Refine::default(),
        })
    }

    /// The scene: camera, options, shading, light, as for the pack opened whole.
    pub fn scene(&self) -> &Scene<'m> {
        &self.scene
    }

    /// The objects' streams.
    pub fn objects(&self) -> &[ObjectStream<'a>] {
        self.objects
    }

    /// Draws one frame from what is resident into `sink` (as `scene::render_scene` draws the pack
    /// opened whole), queueing what each object misses; `shadow_depths` and `light` as there.
    ///
    /// # Errors
    /// As `scene::render_scene`.
    pub fn render<S: SplatSink>(
        &mut self,
        camera: &Camera,
        opts: &RenderOptions,
        shadow_depths: &mut [u16],
        #[cfg(feature = "shadows")] light: Option<&mut LightFrame>,
        sink: &mut S,
    ) -> Result<SceneStats, SceneError> {
        let mut objects = Streams {
            streams: self.objects,
            cast: [false; MAX_OBJECTS],
            pass: None,
        };
        render_objects(
            &self.scene,
            &mut objects,
            camera,
            opts,
            shadow_depths,
            #[cfg(feature = "shadows")]
            light,
            sink,
        )
    }

    /// Starts a refined frame drawn in passes ([`SceneStream::render_pass`]).
    pub fn begin_refined(&mut self) {
        self.refine = Refine::default();
    }

    /// Draws the next pass of a refined frame into `sink` (colour, depth and shadow map kept
    /// between passes): the frame's steps in its own order (two-pass shadows: every casting
    /// object's cast, [`TgStream::fill_pass`]; then every object drawn, [`TgStream::render_pass`]),
    /// each in as many passes as its cache needs, the next begun only when one is finished, so
    /// that once [`SceneStream::refined_done`] the framebuffer holds the frame of the pack opened
    /// whole. One-pass shadows' steps are the objects' draws in light order, each walk resumed
    /// where its last pass stopped in its own (light) order, the map filled only while a pass
    /// draws.
    ///
    /// # Errors
    /// As [`SceneStream::render`].
    pub fn render_pass<S: SplatSink>(
        &mut self,
        camera: &Camera,
        opts: &RenderOptions,
        shadow_depths: &mut [u16],
        #[cfg(feature = "shadows")] light: Option<&mut LightFrame>,
        sink: &mut S,
    ) -> Result<SceneStats, SceneError> {
        let r = self.refine;
        let mut objects = Streams {
            streams: self.objects,
            cast: [false; MAX_OBJECTS],
            pass: Some(Cursor {
                step: r.step,
                started: r.started,
                seen: 0,
                stopped: false,
                fresh: r.step == 0 && !r.started,
                object: r.object,
            }),
        };
        let stats = render_objects(
            &self.scene,
            &mut objects,
            camera,
            opts,
            shadow_depths,
            #[cfg(feature = "shadows")]
            light,
            sink,
        );
        if let Some(c) = objects.pass {
            self.refine = Refine {
                step: c.step,
                started: c.started,
                steps: c.seen,
                object: c.object,
                passes: r.passes + 1,
            };
        }
        stats
    }

    /// Whether the last [`SceneStream::render_pass`] finished the refined frame.
    pub fn refined_done(&self) -> bool {
        self.refine.passes > 0 && self.refine.step >= self.refine.steps
    }

    /// Passes of the refined frame so far.
    pub fn passes(&self) -> u32 {
        self.refine.passes
    }

    /// Whether the last frame missed nothing in any object.
    pub fn converged(&self) -> bool {
        self.objects.iter().all(ObjectStream::converged)
    }

    /// What the last frame missed, over the objects.
    pub fn missing(&self) -> u32 {
        self.objects.iter().map(ObjectStream::missing).sum()
    }

    /// Descents the last frame refused as malformed, over the objects.
    pub fn inconsistent(&self) -> u32 {
        self.objects.iter().map(ObjectStream::inconsistent).sum()
    }

    /// Blocks the last frame used and queued, over the objects.
    pub fn working_set(&self) -> u32 {
        self.objects.iter().map(ObjectStream::working_set).sum()
    }

    /// Whether some object's last frame needed more blocks than its cache holds.
    pub fn over_capacity(&self) -> bool {
        self.objects
            .iter()
            .any(|o| o.working_set() as usize > o.cache_blocks().0)
    }

    /// The objects' counts added (frames: the scene's).
    pub fn counters(&self) -> StreamCounters {
        let mut t = StreamCounters::default();
        for o in self.objects.iter() {
            let c = o.counters();
            t.frames = t.frames.max(c.frames);
            t.reads += c.reads;
            t.bytes_read += c.bytes_read;
            t.read_errors += c.read_errors;
            t.crc_errors += c.crc_errors;
            t.structure_errors += c.structure_errors;
            t.inconsistent += c.inconsistent;
            t.evictions += c.evictions;
            t.prefetched += c.prefetched;
            t.dropped += c.dropped;
        }
        t
    }

    /// Reads what the last frame asked for, within `budget_bytes` over all objects: the objects
    /// that missed something first, in the scene's order, then (budget left) the others'
    /// prefetch; during a refined frame, only the object being drawn. `src` is the pack.
    pub fn serve<C: ChunkSource + ?Sized>(
        &mut self,
        src: &mut C,
        budget_bytes: u32,
        refining: bool,
    ) -> ServeReport {
        let mut total = ServeReport::default();
        let pack = *self.scene.pack();
        let n = self.objects.len();
        let missed: [bool; MAX_OBJECTS] =
            core::array::from_fn(|i| self.objects.get(i).is_some_and(|o| o.missing() > 0));
        let order = (0..n)
            .filter(|&i| missed[i])
            .chain((0..n).filter(|&i| !missed[i]));
        for i in order {
            if refining && i != self.refine.object {
                continue;
            }
            let left = budget_bytes.saturating_sub(total.bytes);
            if left == 0 && total.reads > 0 {
                break;
            }
            let Some(rec) = pack.object(i) else { break };
            let r = self.objects[i].serve(&mut Window::of(src, &rec), left.max(1));
            total.reads += r.reads;
            total.bytes += r.bytes;
            total.failed += r.failed;
            total.prefetched += r.prefetched;
            total.no_room += r.no_room;
        }
        total
    }
}

/// Where a refined frame's pass is, step by step ([`Refine`]).
#[derive(Clone, Copy, Debug)]
struct Cursor {
    /// The first step not finished.
    step: usize,
    /// Whether it has begun.
    started: bool,
    /// Steps met so far in this pass's walk.
    seen: usize,
    /// A step's pass stopped at an absent block: nothing after it is done in this pass.
    stopped: bool,
    /// This is the refined frame's first pass: the shadow map starts empty.
    fresh: bool,
    /// The object of the step being done.
    object: usize,
}

/// The objects' streams as a scene frame reads them.
struct Streams<'o, 'a> {
    streams: &'o mut [ObjectStream<'a>],
    /// Objects whose tri-grid cast into the map this frame (two-pass): their draw keeps what the
    /// cast queued.
    cast: [bool; MAX_OBJECTS],
    /// Drawing a pass of a refined frame.
    pass: Option<Cursor>,
}

impl<'a> Streams<'_, 'a> {
    /// In a pass, the walk's next step (a cast or a draw of object `i`): `None` when an earlier
    /// pass finished it or this pass stopped before it; else whether it begins now (its stream
    /// then begins a refined frame of its own).
    fn step(&mut self, i: usize) -> Option<bool> {
        let p = self.pass.as_mut()?;
        let k = p.seen;
        p.seen += 1;
        if k < p.step || p.stopped {
            return None;
        }
        p.object = i;
        let begins = !p.started;
        p.started = true;
        Some(begins)
    }

    /// In a pass, object `i`'s tri-grid step: begun if it begins now, taken by `pass`, ended as
    /// its stream says (nothing done when an earlier pass finished it or this one stopped before
    /// it). `None` outside a pass.
    fn grid_step<R: Default>(
        &mut self,
        i: usize,
        pass: impl FnOnce(&mut TgStream<'a>) -> R,
    ) -> Option<R> {
        self.pass?;
        let Some(begins) = self.step(i) else {
            return Some(R::default());
        };
        let Some(ObjectStream::Grid(s)) = self.streams.get_mut(i) else {
            self.stepped(true);
            return Some(R::default());
        };
        if begins {
            s.begin_refined();
        }
        let r = pass(s);
        let done = s.refined_done();
        self.stepped(done);
        Some(r)
    }

    /// The step [`Streams::step`] gave ended its pass, `done` or stopped at an absent block.
    fn stepped(&mut self, done: bool) {
        if let Some(p) = &mut self.pass {
            if done {
                p.step += 1;
                p.started = false;
            } else {
                p.stopped = true;
            }
        }
    }
}

impl Objects for Streams<'_, '_> {
    fn grid_header(&self, i: usize) -> Option<&Header> {
        match self.streams.get(i)? {
            ObjectStream::Grid(s) => Some(s.header()),
            #[cfg(feature = "qsplat")]
            ObjectStream::QSplat(_) => None,
        }
    }

    fn fresh_map(&self) -> bool {
        self.pass.is_none_or(|p| p.fresh)
    }

    fn draw_grid<S: SplatSink, H: ShadowHooks>(
        &mut self,
        i: usize,
        frame: &TgFrame,
        hooks: &mut H,
        sink: &mut S,
    ) -> Stats {
        if let Some(stats) = self.grid_step(i, |s| s.render_pass_with(frame, hooks, sink)) {
            return stats;
        }
        let cast = self.cast[i];
        let Some(ObjectStream::Grid(s)) = self.streams.get_mut(i) else {
            return Stats::default();
        };
        if cast {
            s.render_after_fill(frame, hooks, sink)
        } else {
            s.render_with(frame, hooks, sink)
        }
    }

    fn cast_grid<H: ShadowHooks>(&mut self, i: usize, frame: &TgFrame, hooks: &mut H) -> u32 {
        if let Some(nodes) = self.grid_step(i, |s| s.fill_pass(frame, hooks)) {
            return nodes;
        }
        let Some(ObjectStream::Grid(s)) = self.streams.get_mut(i) else {
            return 0;
        };
        self.cast[i] = true;
        s.fill_with(frame, hooks)
    }

    #[cfg(feature = "qsplat")]
    fn draw_qs<S: SplatSink>(
        &mut self,
        i: usize,
        rec: &ObjectRecord<'_>,
        camera: &Camera,
        opts: &RenderOptions,
        range: crate::tg::frame::DepthRange,
        sink: &mut S,
    ) -> Option<Result<Stats, crate::frame::FrameError>> {
        if !matches!(self.streams.get(i)?, ObjectStream::QSplat(_)) {
            return None;
        }
        let pass = self.pass.is_some();
        let begins = match self.step(i) {
            Some(b) => b,
            None if pass => return Some(Ok(Stats::default())),
            None => false,
        };
        let ObjectStream::QSplat(s) = self.streams.get_mut(i)? else {
            return None;
        };
        if begins {
            s.begin_refined();
        }
        let trees = s.trees().iter().copied();
        let mut frame = match crate::qs::QsFrame::of_trees(trees, &rec.placement, camera, opts) {
            Ok(f) => f,
            Err(e) => return Some(Err(e)),
        };
        frame.share_depth_range(range);
        let mut sink = crate::qs::NoColor(sink);
        Some(Ok(if pass {
            let stats = s.render_pass(&frame, &mut sink);
            let done = s.refined_done();
            self.stepped(done);
            stats
        } else {
            s.render(&frame, &mut sink)
        }))
    }
}
