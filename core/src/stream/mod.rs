//! Streaming: drawing a model while it is read in blocks from flash, an SD card, a file or a web
//! server (Rusinkiewicz & Levoy, *Streaming QSplat*, §3; docs/ARCHITECTURE.md "The way data flows").
//!
//! - [`ChunkSource`] is the one thing a medium must do: "read these bytes". Flash is a slice
//!   ([`MemSource`], zero copy through [`ChunkSource::mapped`]); the simulator reads a file or HTTP
//!   byte ranges; an SD card goes through embedded-sdmmc (`sdmmc` feature, [`sdmmc`]).
//! - [`BlockCache`] holds a fixed number of file blocks in caller-provided memory (no heap; its size
//!   is chosen per scene), and evicts the finest, least recently used blocks first so that the coarse
//!   levels stay resident.
//! - [`TgStream`] draws a `.tg` from whatever is resident: where a cell's children are absent the
//!   descent stops and the cell is drawn (§3.2), and the missing blocks are queued by the Streaming
//!   QSplat priority, log-quantized splat size then screen row (§4.2). [`TgStream::serve`] reads the
//!   best of them within an I/O budget per frame; the queue is cleared every frame (§3.4); when no
//!   visible block is missing it prefetches the rest of the file coarse-to-fine.
//! - A refined frame that needs more blocks than the cache holds is drawn in passes
//!   ([`TgStream::render_pass`]): each pass skips the subtrees earlier passes drew, draws until its
//!   first absent descent, then walks on without drawing to queue the blocks the next passes need
//!   (as many as the unpinned cache keeps), which [`TgStream::serve`] reads in ascending block
//!   order. The colour and depth buffers persist between passes and every splat is drawn once, in
//!   the resident walk's order, so the last pass leaves exactly the resident frame.
//! - A block that fails its CRC, or whose read fails, is absent: it is retried later with an
//!   exponential backoff, counted in [`StreamCounters`], and the frame is drawn coarser meanwhile.
//!   So is a block whose CRC is right but whose structure is not (`tg::read::check_block`); rules
//!   that span blocks are checked as the walk uses them, and a frame never visits more nodes than
//!   the file has samples (FORMAT.md "Validation").
//!
//! ```
//! use pocketsplat_core::{ChunkSource, MemSource};
//! let file = [1u8, 2, 3, 4];
//! let mut src = MemSource::new(&file);
//! let mut buf = [0u8; 2];
//! src.read_at(1, &mut buf).unwrap();
//! assert_eq!(buf, [2, 3]);
//! assert!(src.mapped().is_some()); // flash: draw it in place, no cache needed
//! ```
#![deny(clippy::float_arithmetic)]

mod cache;
mod crcs;
mod need;
mod nodes;
mod open;
mod priority;
#[cfg(feature = "qsplat")]
mod qs;
#[cfg(feature = "scene")]
mod scene;
mod serve;
mod tg;
// Test helpers (sources that mistreat another): public for the project's own tests and the
// streaming firmware's self-test, hidden from the docs a firmware author reads.
#[doc(hidden)]
pub mod torture;

#[cfg(feature = "sdmmc")]
pub mod sdmmc;

pub use cache::{table_entries, BlockCache, BlockEntry, SlotEntry, MIN_QUEUE, MIN_SLOTS};
pub use open::{read_tg_header, OPEN_ATTEMPTS};
pub use priority::{size_class, stream_priority, QUEUE_CAPACITY};
#[cfg(feature = "qsplat")]
pub use qs::{QsStream, QsStreamWalk, QS_MAX_TREES};
#[cfg(feature = "scene")]
pub use scene::{
    cache_shares, read_pack_meta, ObjectStream, SceneStream, SceneStreamError, Window, WindowError,
};
pub use serve::{ServeReport, StreamCounters};
pub use tg::{StreamWalk, TgStream};

use core::cell::Cell;

#[cfg(feature = "qsplat")]
use crate::qs::QsError;
use crate::splat::{ColorSink, SampleSplat, SplatSink};
use crate::tg::traverse::ShadowHooks;
use crate::tg::TgError;

/// A sink that draws only while a pass has drawn nothing out of order yet (a refined frame's pass
/// stops drawing at its first absent block).
pub(crate) struct PassSink<'a, S> {
    pub inner: &'a mut S,
    pub drawing: &'a Cell<bool>,
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

impl<S: ColorSink> ColorSink for PassSink<'_, S> {
    #[inline(always)]
    fn splat_colored(&mut self, s: &SampleSplat, rgb565: u16) {
        if self.drawing.get() {
            self.inner.splat_colored(s, rgb565);
        }
    }
}

/// Shadow hooks that fill the map only while a pass draws (a refined frame's pass stops drawing
/// at its first absent block; what it casts after that would be coarse stand-ins), as
/// [`PassSink`] draws.
pub(crate) struct PassHooks<'a, H> {
    pub inner: &'a mut H,
    pub drawing: &'a Cell<bool>,
}

impl<H: ShadowHooks> ShadowHooks for PassHooks<'_, H> {
    type Pos = H::Pos;
    const FILL_CULLED: bool = H::FILL_CULLED;
    const TESTS_FIRST: bool = H::TESTS_FIRST;
    #[inline(always)]
    fn ordered(&self, level: usize) -> bool {
        self.inner.ordered(level)
    }
    #[inline(always)]
    fn root(&self) -> H::Pos {
        self.inner.root()
    }
    #[inline(always)]
    fn child(&self, parent: H::Pos, level: usize, slot: usize) -> H::Pos {
        self.inner.child(parent, level, slot)
    }
    #[inline(always)]
    fn order(&self) -> &crate::tg::traverse::SlotOrder {
        self.inner.order()
    }
    #[inline(always)]
    fn drawn(&mut self, level: usize, p: H::Pos, attr: u16) -> bool {
        self.drawing.get() && self.inner.drawn(level, p, attr)
    }
    #[inline(always)]
    fn drawn_children(
        &mut self,
        parent: H::Pos,
        level: usize,
        mask: u32,
        attr: impl Fn(u32) -> u16,
    ) -> u32 {
        if self.drawing.get() {
            self.inner.drawn_children(parent, level, mask, attr)
        } else {
            0
        }
    }
    #[inline(always)]
    fn casts(&mut self, level: usize, p: H::Pos) {
        if self.drawing.get() {
            self.inner.casts(level, p);
        }
    }
    #[inline(always)]
    fn light_stop(&self, level: usize) -> bool {
        self.inner.light_stop(level)
    }
    #[inline(always)]
    fn unlit(&self, class: usize, code: usize) -> bool {
        self.inner.unlit(class, code)
    }
    #[inline(always)]
    fn casts_subtree(&mut self, level: usize, p: H::Pos, mask: u32) {
        if self.drawing.get() {
            self.inner.casts_subtree(level, p, mask);
        }
    }
    #[inline(always)]
    fn descended(&mut self, level: usize, p: H::Pos, mask: u32) {
        if self.drawing.get() {
            self.inner.descended(level, p, mask);
        }
    }
}

/// Reads bytes of one file from a medium: the one trait every streaming source implements.
pub trait ChunkSource {
    /// What a failed read reports.
    type Error: core::fmt::Debug;

    /// Fills `buf` with the file's bytes `offset..offset + buf.len()`.
    ///
    /// # Errors
    /// When the medium fails or the range runs past the end of the file. The caller treats the
    /// block as absent and tries again later.
    fn read_at(&mut self, offset: u64, buf: &mut [u8]) -> Result<(), Self::Error>;

    /// The whole file, when it is already in addressable memory (memory-mapped flash): a reader may
    /// then draw from it in place ([`crate::tg::TriGrid::open`]) with no cache and no copy.
    fn mapped(&self) -> Option<&[u8]> {
        None
    }

    /// The file's length in bytes, when the medium knows it without a read (a file system, a
    /// slice, a server's `Content-Range` seen on an earlier read). Opening a stream checks the
    /// header's block count against it before anything is sized by that count.
    fn byte_len(&self) -> Option<u64> {
        None
    }
}

impl<T: ChunkSource + ?Sized> ChunkSource for &mut T {
    type Error = T::Error;
    fn read_at(&mut self, offset: u64, buf: &mut [u8]) -> Result<(), Self::Error> {
        (**self).read_at(offset, buf)
    }
    fn mapped(&self) -> Option<&[u8]> {
        (**self).mapped()
    }
    fn byte_len(&self) -> Option<u64> {
        (**self).byte_len()
    }
}

/// A file in addressable memory: memory-mapped flash, or a file read into RAM.
#[derive(Clone, Copy, Debug)]
pub struct MemSource<'a> {
    bytes: &'a [u8],
}

impl<'a> MemSource<'a> {
    /// The file `bytes`.
    pub fn new(bytes: &'a [u8]) -> Self {
        Self { bytes }
    }
}

/// A read past the end of a [`MemSource`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct OutOfRange {
    /// Start of the read.
    pub offset: u64,
    /// Its length.
    pub len: usize,
}

impl ChunkSource for MemSource<'_> {
    type Error = OutOfRange;
    fn read_at(&mut self, offset: u64, buf: &mut [u8]) -> Result<(), OutOfRange> {
        let err = OutOfRange {
            offset,
            len: buf.len(),
        };
        let start = usize::try_from(offset).map_err(|_| err)?;
        let end = start.checked_add(buf.len()).ok_or(err)?;
        buf.copy_from_slice(self.bytes.get(start..end).ok_or(err)?);
        Ok(())
    }
    fn mapped(&self) -> Option<&[u8]> {
        Some(self.bytes)
    }
    fn byte_len(&self) -> Option<u64> {
        Some(self.bytes.len() as u64)
    }
}

/// Why a stream cannot be opened (a frame never fails: absent blocks are drawn coarser).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StreamError<E> {
    /// The medium failed on the header or the CRC table, every attempt.
    Device(E),
    /// The header is not a valid `.tg` header, or the CRC table fails its check every attempt.
    Format(TgError),
    /// The fragment headers of a `.qs` file are not valid.
    #[cfg(feature = "qsplat")]
    Qs(QsError),
    /// The medium cannot say how long the file is (a `.qs` stream needs it to find its fragments).
    UnknownLength,
    /// The `.qs` file has more tree fragments than a stream keeps heads for.
    TooManyTrees {
        /// Heads a stream keeps.
        capacity: u32,
    },
    /// The block table given has fewer entries than the cache needs
    /// ([`table_entries`] of its slots and [`MIN_QUEUE`]).
    TableTooSmall {
        /// Entries given.
        entries: u32,
        /// Entries the cache needs.
        needed: u32,
    },
    /// The cache memory holds fewer blocks of this file than a pass needs at once (at least
    /// [`cache::MIN_SLOTS`]; [`TgStream::cache_need`]): a stream through it would never converge.
    CacheTooSmall {
        /// The file's block size, bytes.
        block_size: u32,
        /// Blocks the cache memory holds.
        slots: u32,
        /// Blocks this file needs.
        needed: u32,
    },
}

impl<E: core::fmt::Debug> core::fmt::Display for StreamError<E> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            StreamError::Device(e) => write!(f, "read failed: {e:?}"),
            StreamError::Format(e) => write!(f, "{e}"),
            #[cfg(feature = "qsplat")]
            StreamError::Qs(e) => write!(f, "{e}"),
            StreamError::UnknownLength => {
                write!(f, "the medium does not say how long the file is")
            }
            StreamError::TooManyTrees { capacity } => write!(
                f,
                "the file has more than {capacity} tree fragments, more than a stream keeps"
            ),
            StreamError::TableTooSmall { entries, needed } => write!(
                f,
                "a block table of {entries} entries is too small for this cache: it needs {needed}"
            ),
            StreamError::CacheTooSmall {
                block_size,
                slots,
                needed,
            } => write!(
                f,
                "a cache of {slots} blocks of {block_size} bytes is too small for this file: \
                 streaming it needs {needed} blocks ({} KB) at once",
                (u64::from(*needed) * u64::from(*block_size)).div_ceil(1024)
            ),
        }
    }
}

impl<E: core::fmt::Debug> core::error::Error for StreamError<E> {}

impl<E> StreamError<E> {
    /// What a cache laid out in too little memory reports: `slots` blocks of `block_size` bytes
    /// fit.
    pub(crate) fn too_small(e: cache::TooSmall, block_size: usize, slots: u32) -> Self {
        match e {
            cache::TooSmall::Cache => StreamError::CacheTooSmall {
                block_size: block_size as u32,
                slots,
                needed: MIN_SLOTS as u32,
            },
            cache::TooSmall::Table { entries, needed } => {
                StreamError::TableTooSmall { entries, needed }
            }
        }
    }
}
