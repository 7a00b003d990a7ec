//! A scene pack streamed as a 520 KB board draws it (features `stream` and `scene`): the firmware
//! reads `SCENE.PAK` from a FAT image through embedded-sdmmc, every object's file through its own
//! share of one static block cache ([`cache_shares`]), and draws the pack's first view at 1 px
//! with the pack's shadows, refined in passes ([`Leg::PackPx1`], one line per pass), in
//! [`PACK_BANDS`] horizontal bands with a [`PACK_MAP_SIZE`]² shadow map: each band's refined frame
//! in its own passes (a band's colour and depth are all the board keeps between passes), the next
//! band begun when one is complete.
//!
//! A pass's line carries the CRC of the rows finished so far and of the band at hand, so that the
//! last pass's CRC is the whole frame's: the frame the pack opened whole gives at the same map
//! size (the simulator's `render --shadow-map 128`), which the tests check on the host and under
//! QEMU.

use pocketsplat_core::crc::Crc32;
use pocketsplat_core::raster::Band;
use pocketsplat_core::render::{render_scene_stream, Direct, StreamPass};
use pocketsplat_core::scene::{Kind, MAX_META_BYTES, MAX_OBJECTS, MAX_SLOTS};
#[cfg(feature = "shadows")]
use pocketsplat_core::shadow::LightFrame;
use pocketsplat_core::stream::{
    cache_shares, read_pack_meta, table_entries, BlockEntry, ChunkSource, ObjectStream,
    SceneStream, SlotEntry, StreamError, TgStream, Window, MIN_QUEUE,
};

use crate::scene::{SceneTable, SceneTargets};
use crate::stream::{
    Leg, StreamFrame, StreamRunError, StreamTotals, MAX_IDLE_PASSES, REFINE_IO_BUDGET_BYTES,
};
use crate::{Phase, HEIGHT, PANEL, WIDTH};

/// The pack's file name in the volume's root directory (8.3).
pub const PACK_FILE: &str = "SCENE.PAK";
/// Bands of the panel a streamed pack's frame is drawn in: eight bands of 40 rows (19.2 KB of
/// colour and as much of depth, not 307.2 KB for both at once), for a walk of the scene per band.
/// Four bands (76.8 KB for both) do not fit 520 KB beside the eight-slot shading table (148 KB),
/// the cache the paper-scale Big Scene's six objects need at least (126 KB), its block tables and
/// the object streams.
pub const PACK_BANDS: usize = 8;
/// Rows of a band.
pub const PACK_BAND_ROWS: usize = HEIGHT / PACK_BANDS;
const _: () = assert!(
    PACK_BAND_ROWS * PACK_BANDS == HEIGHT,
    "bands tile the panel"
);
/// Side of the shadow map a streamed pack is drawn with at most, texels (32 KB; a pack that asks
/// for a smaller one keeps it). The Big Scene asks for 512² (512 KB), which no such board has.
pub const PACK_MAP_SIZE: usize = 128;
/// Texels of that map.
pub const PACK_MAP_TEXELS: usize = PACK_MAP_SIZE * PACK_MAP_SIZE;
/// Bytes of block cache the pack's objects share (a static on the device): the least caches of
/// the paper-scale Big Scene's six objects in 1 KB blocks (126 KB, `pocketsplat info`) and a few
/// blocks more.
pub const PACK_CACHE_BYTES: usize = 130 * 1024;
/// Cache slots: one per block of the smallest block size (512 bytes).
pub const PACK_CACHE_SLOTS: usize = PACK_CACHE_BYTES / 512;
/// Entries of the block tables the pack's objects share: each object's stream gets
/// [`table_entries`] of its slots and [`PACK_QUEUE`] (16 bytes each), whatever the size of its
/// file: the paper-scale Big Scene's 32 MB in 1 KB blocks takes no more than the Big Scene's 3 MB.
pub const PACK_TABLE_ENTRIES: usize = 1024;
/// Requests each object's stream may queue at once (its table's share; [`PACK_TABLE_ENTRIES`]
/// too few for that many gives each [`pocketsplat_core::stream::MIN_QUEUE`]).
pub const PACK_QUEUE: usize = 32;
/// Passes the refined frame may take before the run ends on what it has (a card that stops
/// answering ends it sooner: [`MAX_IDLE_PASSES`]): each pass stops where a block it needs is
/// absent, and the cache holds a few hundred blocks of a frame that needs thousands (the
/// paper-scale Big Scene's std view, tens of thousands).
pub const PACK_MAX_PASSES: u32 = 1 << 17;
/// Objects a streamed pack may have (a pack holds up to 16; each stream is 3.3 KB of RAM).
pub const PACK_MAX_OBJECTS: usize = 8;
/// Blocks of a streamed `.qs` object: 2 KB, as a streamed `.qs` file's
/// ([`crate::stream::QS_BLOCK_LOG2`]).
#[cfg(feature = "qsplat")]
const QS_BLOCK_LOG2: u8 = crate::stream::QS_BLOCK_LOG2;

/// The caller's memory for a streamed pack (statics on the device, the heap on the host).
pub struct PackMemory<'a> {
    /// The pack's metadata ([`pocketsplat_core::scene::MAX_META_BYTES`]).
    pub meta: &'a mut [u8],
    /// Cache blocks, shared out among the objects.
    pub data: &'a mut [u8],
    /// Cache slots, likewise.
    pub slots: &'a mut [SlotEntry],
    /// The objects' block tables, shared out likewise.
    pub blocks: &'a mut [BlockEntry],
    /// The objects' streams (kilobytes each: in a static, not on the stack).
    pub objects: &'a mut PackObjects<'a>,
}

/// Room for the streams of a pack's objects: [`PACK_MAX_OBJECTS`] of them.
pub type PackObjects<'a> = heapless::Vec<ObjectStream<'a>, PACK_MAX_OBJECTS>;

/// A streamed pack's buffers, all zero at first (the device's `.bss`): a band's colour and depth,
/// the shading table (eight slots), the shadow map, the pack's metadata and the block cache.
pub struct PackBuffers {
    /// A band's colour rows.
    pub color: [[u16; WIDTH]; PACK_BAND_ROWS],
    /// A band's depth rows.
    pub depth: [[u16; WIDTH]; PACK_BAND_ROWS],
    /// The scene's shading table.
    pub table: SceneTable,
    /// The shadow map.
    #[cfg(feature = "shadows")]
    pub shadow: [u16; PACK_MAP_TEXELS],
    /// The pack's metadata.
    pub meta: [u8; MAX_META_BYTES],
    /// The block cache the objects share.
    pub cache: [u8; PACK_CACHE_BYTES],
}

impl PackBuffers {
    /// Zeroed buffers and an empty table.
    pub const EMPTY: Self = Self {
        color: [[0; WIDTH]; PACK_BAND_ROWS],
        depth: [[0; WIDTH]; PACK_BAND_ROWS],
        table: SceneTable::new(),
        #[cfg(feature = "shadows")]
        shadow: [0; PACK_MAP_TEXELS],
        meta: [0; MAX_META_BYTES],
        cache: [0; PACK_CACHE_BYTES],
    };
}

/// A streamed pack's tables: the cache's slots and the objects' block tables.
pub struct PackTables {
    /// Cache slots.
    pub slots: [SlotEntry; PACK_CACHE_SLOTS],
    /// The objects' block tables.
    pub blocks: [BlockEntry; PACK_TABLE_ENTRIES],
}

impl PackTables {
    /// Tables before a pack is opened, all zero bits (`.bss` on the device): each object's stream
    /// empties the entries it uses first.
    pub const EMPTY: Self = Self {
        slots: [SlotEntry::UNSET; PACK_CACHE_SLOTS],
        blocks: [BlockEntry::UNSET; PACK_TABLE_ENTRIES],
    };
}

/// What [`pack_stream_frames`] takes, from the buffers, the tables, the room for the objects'
/// streams and the light frame (with `shadows`).
pub fn pack_memory<'a>(
    buffers: &'a mut PackBuffers,
    tables: &'a mut PackTables,
    objects: &'a mut PackObjects<'a>,
    #[cfg(feature = "shadows")] light: &'a mut LightFrame,
) -> (SceneTargets<'a, PACK_BAND_ROWS>, PackMemory<'a>) {
    let PackBuffers {
        color,
        depth,
        table,
        #[cfg(feature = "shadows")]
        shadow,
        meta,
        cache,
    } = buffers;
    (
        SceneTargets {
            color,
            depth,
            table,
            #[cfg(feature = "shadows")]
            shadow,
            #[cfg(not(feature = "shadows"))]
            shadow: &mut [],
            #[cfg(feature = "shadows")]
            light,
        },
        PackMemory {
            meta,
            data: cache,
            slots: &mut tables.slots,
            blocks: &mut tables.blocks,
            objects,
        },
    )
}

/// Takes the first `n` items of `*rest`, leaving it the others.
fn take<'a, T>(rest: &mut &'a mut [T], n: usize) -> &'a mut [T] {
    let (head, tail) = core::mem::take(rest).split_at_mut(n);
    *rest = tail;
    head
}

/// Opens the pack on `src` over `mem`: its metadata, then every object's stream through its share
/// of the cache (what its stream needs at once, then the rest in proportion to its file).
///
/// # Errors
/// [`StreamRunError::Pack`] when the metadata or an object cannot be read or is invalid,
/// [`StreamRunError::PackMemory`] when the objects need more cache or block-table entries than
/// `mem` has.
pub fn open_pack<'a, C: ChunkSource + ?Sized>(
    src: &mut C,
    mem: PackMemory<'a>,
) -> Result<SceneStream<'a, 'a, 'a>, StreamRunError<C::Error>> {
    use pocketsplat_core::stream::SceneStreamError as E;
    let pack = read_pack_meta(src, mem.meta).map_err(StreamRunError::Pack)?;
    let n = pack.object_count();
    if n > mem.objects.capacity() {
        return Err(StreamRunError::PackMemory {
            what: "object streams",
            need: n as u32,
            have: mem.objects.capacity() as u32,
        });
    }
    let object = |i: usize| pack.object(i).ok_or(E::Scene(missing_object(i)));
    // Each object's block size and least cache: a tri-grid's found by opening it through
    // the whole pool (what it needs is known once its header and head are read), a QSplat file's
    // the most any file needs.
    let mut log2 = [0u8; MAX_OBJECTS];
    let (mut lens, mut needs) = ([0usize; MAX_OBJECTS], [0usize; MAX_OBJECTS]);
    for i in 0..n {
        let rec = object(i).map_err(StreamRunError::Pack)?;
        let win = &mut Window::of(src, &rec);
        let obj_err = |error| {
            StreamRunError::Pack(E::Object {
                object: i as u8,
                error,
            })
        };
        lens[i] = rec.data_len as usize;
        match rec.kind {
            Kind::TriGrid => {
                let need = match TgStream::open(win, mem.data, mem.slots, mem.blocks) {
                    Ok(s) => {
                        log2[i] = s.header().block_log2;
                        s.cache_need()
                    }
                    Err(StreamError::CacheTooSmall {
                        needed, block_size, ..
                    }) => {
                        log2[i] = block_size.trailing_zeros() as u8;
                        needed
                    }
                    Err(e) => return Err(obj_err(e)),
                };
                needs[i] = (need as usize) << log2[i];
            }
            #[cfg(feature = "qsplat")]
            Kind::QSplat => {
                log2[i] = QS_BLOCK_LOG2;
                // Opened once through the whole pool too, so that a file that is not what its
                // record says is refused by its reader, not by what its share would be.
                pocketsplat_core::stream::QsStream::open(
                    win,
                    QS_BLOCK_LOG2,
                    mem.data,
                    mem.slots,
                    mem.blocks,
                )
                .map_err(obj_err)?;
                let need = pocketsplat_core::stream::QsStream::MAX_CACHE_NEED as usize;
                needs[i] =
                    (need << QS_BLOCK_LOG2).min(lens[i].next_multiple_of(1 << QS_BLOCK_LOG2));
            }
            #[cfg(not(feature = "qsplat"))]
            Kind::QSplat => {
                return Err(StreamRunError::Pack(E::Scene(
                    pocketsplat_core::scene::SceneError::NoQSplat { object: i as u8 },
                )))
            }
        }
    }
    let mut shares = [0usize; MAX_OBJECTS];
    cache_shares(&lens[..n], &needs[..n], mem.data.len(), &mut shares[..n]).map_err(|need| {
        StreamRunError::PackMemory {
            what: "cache bytes",
            need: need as u32,
            have: mem.data.len() as u32,
        }
    })?;
    // Each object's block table: for a queue of PACK_QUEUE if they all fit, else of MIN_QUEUE.
    let held = |i: usize| (shares[i] >> log2[i]).min(mem.slots.len());
    let tables = |queue| (0..n).map(|i| table_entries(held(i), queue)).sum::<usize>();
    let queue = [PACK_QUEUE, MIN_QUEUE]
        .into_iter()
        .find(|&q| tables(q) <= mem.blocks.len())
        .ok_or(StreamRunError::PackMemory {
            what: "block-table entries",
            need: tables(MIN_QUEUE) as u32,
            have: mem.blocks.len() as u32,
        })?;
    let (mut data, mut slots, mut entries) = (mem.data, mem.slots, mem.blocks);
    // Each object's stream opened into the caller's room for it.
    let objects = mem.objects;
    objects.clear();
    for i in 0..n {
        let rec = object(i).map_err(StreamRunError::Pack)?;
        let win = &mut Window::of(src, &rec);
        // Whole blocks of the share; a slot for each (the slots are as many as 512-byte blocks in
        // the pool, so every share's fit).
        let whole = shares[i] >> log2[i];
        let d = take(&mut data, whole << log2[i]);
        let n_slots = whole.min(slots.len());
        let s = take(&mut slots, n_slots);
        let b = take(&mut entries, table_entries(n_slots, queue));
        let stream = match rec.kind {
            Kind::TriGrid => TgStream::open(win, d, s, b).map(ObjectStream::Grid),
            #[cfg(feature = "qsplat")]
            Kind::QSplat => pocketsplat_core::stream::QsStream::open(win, QS_BLOCK_LOG2, d, s, b)
                .map(ObjectStream::QSplat),
            #[cfg(not(feature = "qsplat"))]
            Kind::QSplat => unreachable!("refused above"),
        }
        .map_err(|error| {
            StreamRunError::Pack(E::Object {
                object: i as u8,
                error,
            })
        })?;
        // Room for `n` was checked above.
        let _ = objects.push(stream);
    }
    SceneStream::new(pack, objects.as_mut_slice()).map_err(|e| StreamRunError::Pack(E::Scene(e)))
}

/// The error of a pack that counts an object it has no record of (a valid pack has none).
fn missing_object(i: usize) -> pocketsplat_core::scene::SceneError {
    pocketsplat_core::scene::SceneError::Streams {
        objects: i as u8,
        streams: i as u8,
    }
}

/// The camera and options a streamed pack's frames are drawn with at `view` and `cutoff_px`: the
/// pack's own, with its shadow map at most [`PACK_MAP_SIZE`]².
pub fn pack_frame_setup(
    stream: &SceneStream<'_, '_, '_>,
    view: pocketsplat_core::camera::View,
    cutoff_px: f32,
) -> (
    pocketsplat_core::camera::Camera,
    pocketsplat_core::render::RenderOptions,
) {
    let scene = stream.scene();
    let mut options = scene.options().with_cutoff(cutoff_px);
    options.shadow_map_size = options.shadow_map_size.min(PACK_MAP_SIZE);
    (scene.camera(view), options)
}

/// The pack's first view (the std view for a pack without views).
pub fn pack_first_view(stream: &SceneStream<'_, '_, '_>) -> pocketsplat_core::camera::View {
    stream
        .scene()
        .pack()
        .view(0)
        .map_or(pocketsplat_core::camera::STANDARD_VIEWS[0].1, |(_, v)| v)
}

/// Draws band `band` of a streamed pack's frame into `targets` (a frame from what is resident, or
/// with `pass` the next pass of its refined frame), its shadow map [`PACK_MAP_TEXELS`] at most.
///
/// # Errors
/// When the frame cannot be set up ([`pocketsplat_core::render::RenderError`]).
pub fn draw_band(
    stream: &mut SceneStream<'_, '_, '_>,
    camera: &pocketsplat_core::camera::Camera,
    options: &pocketsplat_core::render::RenderOptions,
    targets: &mut SceneTargets<'_, PACK_BAND_ROWS>,
    band: usize,
    pass: StreamPass,
    mark: impl FnMut(Phase),
) -> Result<pocketsplat_core::render::Drawn, pocketsplat_core::render::RenderError> {
    let target = targets.target(
        #[cfg(feature = "shadows")]
        PACK_MAP_TEXELS,
    );
    let top = (band * PACK_BAND_ROWS) as u16;
    let mut target = target.map_pixels(|f| {
        Band::new(f, top, PANEL).expect("PACK_BANDS bands of PACK_BAND_ROWS rows tile the panel")
    });
    render_scene_stream(
        stream,
        camera,
        options,
        &mut target,
        pass,
        &mut Direct,
        mark,
    )
}

/// What a pass of [`BandPasses`] finished.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PassEnd {
    /// Nothing yet: the band needs more passes.
    More,
    /// The band is complete (its rows are in the targets' colour buffer); the next pass begins the
    /// next band.
    Band,
    /// The last band is complete: the frame is done.
    Frame,
    /// [`MAX_IDLE_PASSES`] passes in a row read nothing intact: the frame ends on what it has.
    Stuck,
}

/// A streamed pack's refined frame, drawn in passes band by band (each band's refined frame in its
/// own passes, the next band begun when one is complete), one [`BandPasses::pass`] at a time: what
/// the firmware's loop ([`pack_stream_frames`]) and a viewer that shows each band as it completes
/// both step.
#[derive(Clone)]
pub struct BandPasses {
    band: usize,
    first: bool,
    index: u32,
    idle: u32,
    failed_before: u32,
    rows_crc: Crc32,
}

impl Default for BandPasses {
    fn default() -> Self {
        Self::new()
    }
}

impl BandPasses {
    /// A refined frame not yet begun (its first pass draws band 0).
    pub fn new() -> Self {
        BandPasses {
            band: 0,
            first: true,
            index: 0,
            idle: 0,
            failed_before: 0,
            rows_crc: Crc32::new(),
        }
    }

    /// The band the next pass draws (or the last one drew, once the frame is done).
    pub fn band(&self) -> usize {
        self.band
    }

    /// Passes drawn so far.
    pub fn passes(&self) -> u32 {
        self.index
    }

    /// One pass: draws the band at hand into `targets`, reads up to [`REFINE_IO_BUDGET_BYTES`]
    /// from `src`, and says what the pass was (its line: CRC of the finished bands' rows and of
    /// the band at hand, so that the last pass's is the whole frame's) and what it finished.
    ///
    /// # Errors
    /// When the pass cannot be set up ([`pocketsplat_core::render::RenderError`]).
    #[allow(clippy::too_many_arguments)]
    pub fn pass<C: ChunkSource + ?Sized>(
        &mut self,
        stream: &mut SceneStream<'_, '_, '_>,
        src: &mut C,
        camera: &pocketsplat_core::camera::Camera,
        options: &pocketsplat_core::render::RenderOptions,
        targets: &mut SceneTargets<'_, PACK_BAND_ROWS>,
        mark: impl FnMut(Phase),
    ) -> Result<(StreamFrame, PassEnd), pocketsplat_core::render::RenderError> {
        let pass = if self.first {
            StreamPass::FirstPass
        } else {
            StreamPass::NextPass
        };
        self.first = false;
        let drawn = draw_band(stream, camera, options, targets, self.band, pass, mark)?;
        let done = stream.refined_done();
        let last = self.band + 1 == PACK_BANDS;
        let mut crc = self.rows_crc.clone();
        crc.update_u16_le(targets.color.as_flattened());
        let c = stream.counters();
        let failed = c.read_errors + c.crc_errors + c.structure_errors - self.failed_before;
        self.failed_before += failed;
        let missing = if done && last {
            stream.missing()
        } else {
            stream.missing().max(1)
        };
        let served = stream.serve(src, REFINE_IO_BUDGET_BYTES, true);
        let line = StreamFrame {
            leg: Leg::PackPx1,
            index: self.index,
            az_deg: 0,
            crc: crc.finish(),
            missing,
            failed,
            marker: failed > 0 || stream.inconsistent() > 0,
            read: served.bytes,
            // Not counted for a pack: its objects' blocks differ in size.
            prefetched: 0,
            splats: drawn.stats.splats,
            nodes: drawn.stats.nodes_visited,
        };
        self.index += 1;
        let end = if done {
            if last {
                PassEnd::Frame
            } else {
                self.rows_crc.update_u16_le(targets.color.as_flattened());
                (self.band, self.first, self.idle) = (self.band + 1, true, 0);
                PassEnd::Band
            }
        } else {
            self.idle = if served.reads > served.failed {
                0
            } else {
                self.idle + 1
            };
            if self.idle >= MAX_IDLE_PASSES {
                PassEnd::Stuck
            } else {
                PassEnd::More
            }
        };
        Ok((line, end))
    }
}

/// Opens the pack on `src` over `mem` and draws its first view (the std view if it has none) at
/// 1 px with its shadows, refined in passes band by band ([`BandPasses`]) into `targets` (their
/// shadow map at least [`PACK_MAP_TEXELS`]), handing each pass's line to `report` (`mark` as
/// [`crate::render_standard_view`]'s), until the last band's refined frame is complete, or for
/// [`PACK_MAX_PASSES`] passes, or [`MAX_IDLE_PASSES`] passes that read nothing. A failed read
/// leaves its block absent and is read again later.
///
/// # Errors
/// As [`open_pack`]; [`StreamRunError::View`] when a pass cannot be set up.
pub fn pack_stream_frames<C: ChunkSource + ?Sized>(
    src: &mut C,
    mem: PackMemory<'_>,
    targets: &mut SceneTargets<'_, PACK_BAND_ROWS>,
    mut mark: impl FnMut(Phase),
    mut report: impl FnMut(&StreamFrame),
) -> Result<StreamTotals, StreamRunError<C::Error>> {
    let mut stream = open_pack(src, mem)?;
    let (camera, options) = pack_frame_setup(&stream, pack_first_view(&stream), 1.0);
    // The materials' power tables, once, before the first pass.
    targets
        .table
        .prepare(&stream.scene().materials::<MAX_SLOTS>());
    let mut passes = BandPasses::new();
    while passes.passes() < PACK_MAX_PASSES {
        let (line, end) = passes
            .pass(&mut stream, src, &camera, &options, targets, &mut mark)
            .map_err(StreamRunError::View)?;
        report(&line);
        if matches!(end, PassEnd::Frame | PassEnd::Stuck) {
            break;
        }
    }
    let cache_blocks = stream.objects().iter().map(|o| o.cache_blocks().0 as u32);
    Ok(StreamTotals::of(
        &stream.counters(),
        stream.scene().pack().file_len(),
        cache_blocks.sum(),
    ))
}

/// The name of hostile pack `index` on the volume (8.3): `H000.PAK`… (`selftest-hostile` with
/// `scene`).
pub fn hostile_pack_name(index: u32) -> [u8; 8] {
    let d = |k: u32| b'0' + (index / k % 10) as u8;
    [b'H', d(100), d(10), d(1), b'.', b'P', b'A', b'K']
}

/// How a hostile pack ended: `hostile-pack <index> refused <reason>`, or `hostile-pack <index>
/// drawn converged 0|1 crc 0x… passes N` (the refined frame's last pass).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HostilePackLine<E> {
    /// Which file.
    pub index: u32,
    /// Refused, and why; or the last pass drawn.
    pub verdict: Result<(StreamFrame, u32), StreamRunError<E>>,
}

impl<E: core::fmt::Debug> core::fmt::Display for HostilePackLine<E> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match &self.verdict {
            Err(e) => write!(f, "hostile-pack {} refused {e}", self.index),
            Ok((last, passes)) => write!(
                f,
                "hostile-pack {} drawn converged {} crc {:#010x} passes {passes}",
                self.index,
                u8::from(last.converged()),
                last.crc
            ),
        }
    }
}

/// Streams hostile pack `index` on `src` as [`pack_stream_frames`] streams a pack, and says how it
/// ended: refused with the reason, or its last pass (a pack that opens is drawn from what is
/// resident; a bad block stays absent).
pub fn hostile_pack_run<C: ChunkSource + ?Sized>(
    index: u32,
    src: &mut C,
    mem: PackMemory<'_>,
    targets: &mut SceneTargets<'_, PACK_BAND_ROWS>,
    mark: impl FnMut(Phase),
) -> HostilePackLine<C::Error> {
    let (mut last, mut passes) = (None, 0);
    let verdict = pack_stream_frames(src, mem, targets, mark, |f| {
        last = Some(*f);
        passes += 1;
    })
    .map(|_| {
        let last = last.unwrap_or(StreamFrame {
            leg: Leg::PackPx1,
            index: 0,
            az_deg: 0,
            crc: 0,
            missing: 1,
            failed: 0,
            marker: false,
            read: 0,
            prefetched: 0,
            splats: 0,
            nodes: 0,
        });
        (last, passes)
    });
    HostilePackLine { index, verdict }
}
