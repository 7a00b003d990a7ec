//! Reading what a frame asked for, the same for every streamed format (Streaming QSplat §3.4): the
//! request queue (a block's priority is its best node's; a full queue keeps the best), the reads of
//! one [`serve`](crate::stream::TgStream::serve) within its byte budget, the check of each block as
//! it arrives, and the backoff of a block that failed; with what both count ([`StreamCounters`],
//! [`ServeReport`]) and the phases of a pass ([`Phase`]).

use heapless::Vec;

use super::cache::{BlockCache, Evict, NO_SLOT};
use super::priority::{QUEUE_CAPACITY, ROOT_PRIORITY};
use super::ChunkSource;

/// Longest backoff after repeated failures, frames.
const MAX_BACKOFF: u32 = 64;

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
    /// Blocks that passed their CRC but not the structure check
    /// ([`check_block`](crate::tg::read::check_block)), and bricks that
    /// failed theirs ([`crate::tg::brick::check_brick`], when the walk first entered them): absent,
    /// as if damaged.
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

/// What one serve did ([`TgStream::serve`](super::TgStream::serve), or a `.qs` stream's).
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
    /// Blocks not read because the cache had no slot the eviction policy may give (every one
    /// pinned or kept): of a frame drawn whole, any it asked for (when nothing else was read, the
    /// next frame is this one again: draw it in passes); of a pass, those where it stopped (the
    /// next pass would stop there again: the cache is too small for this view).
    pub no_room: u32,
}

/// A queued block read.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Request {
    pub priority: u32,
    pub block: u32,
}

/// What a pass does at this point of its walk.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Phase {
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

/// What the format's check says of a block that arrived.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Verdict {
    /// Its bytes are the file's, as far as the format can tell.
    Good,
    /// It fails its CRC.
    Crc,
    /// What checking it needs could not be read (a `.tg` block's CRC): a failed read.
    Unread,
    /// Its CRC is right (or it has none) but its structure is not.
    Structure,
}

/// A stream's cache, queue and counts, borrowed for one serve or one descent's requests.
pub(crate) struct Feed<'s, 'a> {
    pub cache: &'s mut BlockCache<'a>,
    pub queue: &'s mut Vec<Request, QUEUE_CAPACITY>,
    pub counters: &'s mut StreamCounters,
    /// The frame being served (the last one drawn).
    pub frame: u32,
    /// Bytes per block.
    pub block_size: usize,
    /// Bytes in the file (its last block may be short).
    pub file_len: u64,
}

/// Queues block `b` of `cache` with `priority`, raising it if already queued (a block's priority is
/// its best node's, §3.4); when the queue is full the lowest request makes room or this one is
/// dropped (counted in `dropped`). Returns whether the block was newly queued.
pub(crate) fn push(
    cache: &mut BlockCache<'_>,
    queue: &mut Vec<Request, QUEUE_CAPACITY>,
    dropped: &mut u32,
    b: usize,
    priority: u32,
) -> bool {
    if b >= cache.file_blocks() {
        *dropped += 1; // outside the file: a damaged directory or pointer; never converges
        return false;
    }
    if let Some(e) = cache.entry(b) {
        if e.slot != NO_SLOT {
            return false;
        }
        if let Some(r) = queue.get_mut(usize::from(e.queued)) {
            r.priority = r.priority.max(priority);
            return false;
        }
    }
    let req = Request {
        priority,
        block: b as u32,
    };
    if queue.len() < cache.queue_room && queue.push(req).is_ok() {
        if cache.set_queued(b, queue.len() - 1) {
            return true;
        }
        queue.pop();
    }
    let Some((i, low)) = queue
        .iter()
        .enumerate()
        .min_by_key(|(_, r)| r.priority)
        .map(|(i, r)| (i, *r))
    else {
        *dropped += 1;
        return false;
    };
    *dropped += 1;
    if priority > low.priority {
        cache.unqueue(low.block as usize);
        if cache.set_queued(b, i) {
            queue[i] = req;
        } else {
            // No room in the table for the new one: the old one keeps its place.
            cache.set_queued(low.block as usize, i);
        }
    }
    false
}

/// Empties the queue (a new frame asks afresh, §3.4).
pub(crate) fn clear_queue(cache: &mut BlockCache<'_>, queue: &mut Vec<Request, QUEUE_CAPACITY>) {
    for r in queue.iter() {
        cache.unqueue(r.block as usize);
    }
    queue.clear();
}

impl Feed<'_, '_> {
    /// Reads queued blocks, best first, until `budget_bytes` are spent (at least one block per
    /// call); when the last frame missed nothing (`missing == 0`), prefetches what `prefetch`
    /// names into free room. After a pass (`passing`), reads its queue in ascending block order,
    /// the pass's stop first, evicting nothing the pass kept. `check` judges each block that
    /// arrives: one that fails stays absent and waits out a backoff before being read again.
    pub(crate) fn serve<C: ChunkSource + ?Sized>(
        &mut self,
        src: &mut C,
        budget_bytes: u32,
        passing: bool,
        missing: u32,
        mut prefetch: impl FnMut(&BlockCache<'_>, u32) -> Option<usize>,
        mut check: impl FnMut(usize, &[u8], &mut C) -> Verdict,
    ) -> ServeReport {
        let bs = self.block_size;
        let mut left = (budget_bytes as usize).max(bs);
        let mut report = ServeReport::default();
        if passing {
            // A pass's queue, best first within the budget: the blocks where the pass stopped
            // first (what the next pass needs to go on), then the rest in ascending block order,
            // as an SD card (or a disk) serves a forward sweep best. Nothing the pass kept is
            // evicted for them.
            let mut batch: Vec<(bool, u32), QUEUE_CAPACITY> = Vec::new();
            while left >= bs {
                let Some((b, priority)) = self.pop_best() else {
                    break;
                };
                if batch.push((priority != ROOT_PRIORITY, b as u32)).is_err() {
                    break;
                }
                left -= bs;
            }
            batch.sort_unstable();
            for &(later, b) in &batch {
                if self
                    .load(src, b as usize, Evict::Pass, &mut report, &mut check)
                    .is_none()
                    && !later
                {
                    report.no_room += 1;
                }
            }
            return report;
        }
        while left >= bs {
            let (b, mode) = match self.pop_best() {
                Some((b, _)) => (b, Evict::Demand),
                None if missing == 0 => match prefetch(self.cache, self.frame) {
                    Some(b) => (b, Evict::Prefetch),
                    None => break,
                },
                None => break,
            };
            match self.load(src, b, mode, &mut report, &mut check) {
                Some(()) => left -= bs,
                None if mode == Evict::Prefetch => break,
                None => report.no_room += 1,
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
        mode: Evict,
        report: &mut ServeReport,
        check: &mut impl FnMut(usize, &[u8], &mut C) -> Verdict,
    ) -> Option<()> {
        let bs = self.block_size;
        let class = self.cache.class(b);
        let prefetch = mode == Evict::Prefetch;
        let s = self.cache.victim(class, self.frame, mode)?;
        if self.cache.evict(s) {
            self.counters.evictions += 1;
        }
        report.reads += 1;
        report.bytes += bs as u32;
        report.prefetched += u32::from(prefetch);
        self.counters.reads += 1;
        self.counters.bytes_read += bs as u64;
        self.counters.prefetched += u32::from(prefetch);
        let at = (b as u64) * bs as u64;
        let n = self.file_len.saturating_sub(at).min(bs as u64) as usize;
        let buf = &mut self.cache.slot_bytes(s)[..n];
        let ok = match src.read_at(at, buf) {
            Err(_) => {
                self.counters.read_errors += 1;
                false
            }
            Ok(()) => match check(b, buf, src) {
                Verdict::Good => true,
                Verdict::Crc => {
                    self.counters.crc_errors += 1;
                    false
                }
                Verdict::Unread => {
                    self.counters.read_errors += 1;
                    false
                }
                // Sealed but malformed: absent, exactly as a damaged block (issue 17).
                Verdict::Structure => {
                    self.counters.structure_errors += 1;
                    false
                }
            },
        };
        if !(ok && self.cache.install(s, b, self.frame)) {
            report.failed += 1;
            self.cache.fail(b, self.frame, MAX_BACKOFF);
        }
        Some(())
    }

    /// Removes and returns the best queued block that may be read now, with its priority.
    fn pop_best(&mut self) -> Option<(usize, u32)> {
        let mut best: Option<(usize, u32)> = None;
        for (i, r) in self.queue.iter().enumerate() {
            let readable = self
                .cache
                .entry(r.block as usize)
                .is_some_and(|e| e.slot == NO_SLOT && e.ready(self.frame));
            if readable && best.is_none_or(|(_, p)| r.priority > p) {
                best = Some((i, r.priority));
            }
        }
        let (i, _) = best?;
        let r = self.queue.swap_remove(i);
        self.cache.unqueue(r.block as usize);
        if let Some(moved) = self.queue.get(i) {
            self.cache.set_queued(moved.block as usize, i);
        }
        Some((r.block as usize, r.priority))
    }
}

/// The first absent block from `first` on, in file order, that may be read in frame `frame`.
pub(crate) fn first_absent(cache: &BlockCache<'_>, first: usize, frame: u32) -> Option<usize> {
    (first..cache.file_blocks()).find(|&b| !cache.contains(b) && cache.ready(b, frame))
}
