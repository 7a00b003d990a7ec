//! Opening a streamed `.tg` file: the header (checked against the medium before anything is sized
//! by it) and, once the CRC table is in, the head and the brick table, read through the cache's
//! slots and checked as the resident reader checks them (FORMAT.md "Validation").

use super::cache::BlockCache;
use super::crcs::CrcWindow;
use super::{ChunkSource, StreamError};
use crate::crc::crc32;
use crate::tg::brick::{check_head, check_table, BrickSpans};
use crate::tg::read::{check_counts, parse_header, Header, LevelDir};
use crate::tg::{TgError, MAX_LEVELS, VERSION_BRICKS};

/// Attempts at the header and at each block read while opening.
pub const OPEN_ATTEMPTS: u32 = 8;
/// Smallest block a `.tg` file has (the header's own block size is read from its first 512 bytes).
const MIN_BLOCK: usize = 512;

/// Reads and checks the header block of a `.tg` file through `scratch` (at least one block; 64 KB
/// covers every block size), trying [`OPEN_ATTEMPTS`] times. Returns the header, the level
/// directory and the number of failed attempts.
///
/// A header that parses is then checked against the medium and itself, at once (a sealed header
/// reads the same every time): its version (streaming reads version 3, whose bricks are checked one
/// by one: [`TgError::NotStreamable`] for older files), its block count against
/// [`ChunkSource::byte_len`] where the medium knows it ([`TgError::LengthMismatch`]), and its level
/// counts against each other ([`crate::tg::read::check_counts`]), before anything is sized by them.
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
                if h.version < VERSION_BRICKS {
                    return Err(StreamError::Format(TgError::NotStreamable {
                        version: h.version,
                    }));
                }
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
        needed: 1,
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

/// What opening read: reads issued and the medium's and the CRC's failures; and what the largest
/// bricks span (from the brick table, for the cache the file needs).
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct OpenReads {
    pub reads: u32,
    pub read_errors: u32,
    pub crc_errors: u32,
    pub spans: BrickSpans,
}

/// Reads words of the file through the cache's slots, each block checked by its CRC (retried
/// [`OPEN_ATTEMPTS`] times), the least recently used slot reused: the head and the brick table are
/// read a few times over in a few sequential runs (masks of a level, of the level below, its group
/// pointers), which a handful of slots serves.
struct SlotReader<'c, 'a, C: ChunkSource + ?Sized> {
    cache: &'c mut BlockCache<'a>,
    crcs: &'c mut CrcWindow,
    src: &'c mut C,
    tick: u32,
    reads: OpenReads,
    /// The first failure of the block that could not be read intact (a later attempt may fail
    /// otherwise: a server that has stopped answering).
    failed: Option<StreamError<C::Error>>,
}

impl<C: ChunkSource + ?Sized> SlotReader<'_, '_, C> {
    fn word(&mut self, off: u64, n: usize) -> Option<u128> {
        let log2 = self.cache.log2;
        let b = usize::try_from(off >> log2).ok()?;
        if !self.cache.contains(b) {
            self.load(b)?;
        }
        self.tick += 1;
        let t = self.tick;
        self.cache.touch(b, t);
        let bytes = self.cache.bytes(off, n)?;
        let mut w = [0u8; 16];
        w.get_mut(..n)?.copy_from_slice(bytes);
        Some(u128::from_le_bytes(w))
    }

    fn load(&mut self, b: usize) -> Option<()> {
        let b32 = u32::try_from(b).ok()?;
        // The least recently used slot (free ones first: their `used` is 0).
        let s = (0..self.cache.capacity()).min_by_key(|&s| self.cache.slots[s].used)?;
        self.cache.evict(s);
        let bs = 1usize << self.cache.log2;
        self.failed = None;
        for _ in 0..OPEN_ATTEMPTS {
            self.reads.reads += 1;
            let buf = self.cache.slot_bytes(s);
            match self.src.read_at(b as u64 * bs as u64, buf) {
                Err(e) => {
                    self.reads.read_errors += 1;
                    self.failed.get_or_insert(StreamError::Device(e));
                }
                Ok(()) => match self.crcs.crc(self.src, b32) {
                    Err(e) => {
                        self.reads.read_errors += 1;
                        self.failed.get_or_insert(StreamError::Device(e));
                    }
                    Ok(want) if want != Some(crc32(buf)) => {
                        self.crcs.forget();
                        self.reads.crc_errors += 1;
                        self.failed
                            .get_or_insert(StreamError::Format(TgError::BlockCrc(b as u32)));
                    }
                    Ok(_) => {
                        self.failed = None;
                        return self.cache.install(s, b, 0).then_some(());
                    }
                },
            }
        }
        None
    }
}

/// Checks the head of a version 3 file (every level in the level directory, as the resident reader
/// does) and its brick table, reading them through `cache` (each block checked against its CRC
/// from `crcs`). The blocks read stay in the cache, marked unused.
///
/// # Errors
/// [`StreamError::Format`] naming the fault, or, when a block could not be read intact, the
/// medium's or the CRC's failure.
pub(crate) fn check_head_and_table<C: ChunkSource + ?Sized>(
    h: &Header,
    levels: &[LevelDir; MAX_LEVELS],
    cache: &mut BlockCache<'_>,
    crcs: &mut CrcWindow,
    src: &mut C,
) -> Result<OpenReads, StreamError<C::Error>> {
    let mut r = SlotReader {
        cache,
        crcs,
        src,
        tick: 0,
        reads: OpenReads::default(),
        failed: None,
    };
    let mut read = |off: u64, n: usize| r.word(off, n);
    let result = check_head(h, levels, &mut read).and_then(|()| {
        if h.bricked() {
            check_table(h, levels, &mut read)
        } else {
            Ok(BrickSpans::default())
        }
    });
    for s in r.cache.slots.iter_mut() {
        s.used = 0;
    }
    match (result, r.failed) {
        (Ok(spans), _) => Ok(OpenReads { spans, ..r.reads }),
        (Err(_), Some(e)) => Err(e),
        (Err(e), None) => Err(StreamError::Format(e)),
    }
}
