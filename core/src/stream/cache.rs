//! The block cache: a fixed number of file blocks in caller-provided memory, the state of the blocks
//! a stream is dealing with (resident, queued, or waiting out a failure's backoff) and the eviction
//! policy.
//!
//! Streaming QSplat §3.3 keeps two bits per block of the file (absent, desired, requested, present).
//! A file of 30,000 blocks would then cost a board a table as large as its cache; here only the
//! blocks in one of those states have a [`BlockEntry`], in a small open-addressed table
//! ([`table_entries`]) sized by the cache and the request queue, not by the file. An absent block nobody asked for has no
//! entry; its class (the coarsest level with data in it) is worked out from its index when it gets
//! one, and a `.tg` block's CRC is read from the file's CRC table when the block arrives
//! (`crcs.rs`).

use super::priority::QUEUE_CAPACITY;
use crate::tg::MAX_LEVELS;

/// No slot: the block is absent.
pub(crate) const NO_SLOT: u16 = u16::MAX;
/// Not in the request queue.
pub(crate) const NOT_QUEUED: u16 = u16::MAX;
/// No block in this slot, or no block in this table entry.
pub(crate) const NO_BLOCK: u32 = u32::MAX;
/// [`BlockEntry::flags`]: the brick that starts at this block passed its check (version 3 bricks
/// are checked the first time the walk enters them after the block arrives; their bytes are sealed
/// by their CRCs).
pub(crate) const BRICK_OK: u8 = 1;
/// [`BlockEntry::flags`]: the brick that starts at this block failed its check.
pub(crate) const BRICK_BAD: u8 = 2;
/// Fewest blocks a cache may hold: the coarse levels plus room to refine.
pub const MIN_SLOTS: usize = 4;
/// Fewest requests a stream's queue may hold (a table of [`table_entries`] of the slots and
/// `MIN_QUEUE` is the least a cache takes).
pub const MIN_QUEUE: usize = 16;

/// Entries of the block table a cache of `slots` blocks needs for a request queue of `queue`
/// (at least [`MIN_QUEUE`]; a stream's queue holds at most [`QUEUE_CAPACITY`]): twice the blocks
/// that can be resident or queued at once (half the table for those, half for blocks waiting out
/// a backoff), rounded up to a power of two. A board short of RAM asks for a short queue (a frame
/// then asks for fewer blocks at a time, a pass reads fewer); the simulator for the whole one.
pub const fn table_entries(slots: usize, queue: usize) -> usize {
    let queue = if queue < MIN_QUEUE { MIN_QUEUE } else { queue };
    (2 * (slots + queue + 1)).next_power_of_two()
}

/// What a load may evict ([`BlockCache::victim`]); free slots are taken first in every case.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Evict {
    /// A block a frame drawn whole asked for: a block this frame did not use, or one of a strictly
    /// finer class (coarse levels first).
    Demand,
    /// A prefetch: only a block this frame did not use, of a strictly finer class.
    Prefetch,
    /// A block a pass asked for: only a block this pass did not keep (those it keeps are the ones
    /// the next pass needs to reach where this one stopped, and what this serve loads).
    Pass,
}

/// A block the stream is dealing with: resident, queued or failed (16 bytes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BlockEntry {
    /// The file block, or [`NO_BLOCK`] for an empty entry.
    pub(crate) block: u32,
    /// Frame before which a failed block is not read again (backoff).
    pub(crate) retry_at: u32,
    /// Cache slot holding the block, or [`NO_SLOT`].
    pub(crate) slot: u16,
    /// Index in the request queue, or [`NOT_QUEUED`].
    pub(crate) queued: u16,
    /// Failed reads or checks since the block was last loaded.
    pub(crate) fails: u8,
    /// Coarsest level with data in the block (eviction keeps coarse classes).
    pub(crate) class: u8,
    /// What the format notes of the resident block ([`BRICK_OK`] or [`BRICK_BAD`] once the brick
    /// starting here was checked); cleared when it is evicted.
    pub(crate) flags: u8,
}

impl BlockEntry {
    /// An empty entry.
    pub const EMPTY: Self = Self {
        block: NO_BLOCK,
        retry_at: 0,
        slot: NO_SLOT,
        queued: NOT_QUEUED,
        fails: 0,
        class: 0,
        flags: 0,
    };

    /// An entry of all zero bits, for memory a board lays out before it opens a file (a `static`
    /// in `.bss`, not `.data`): the stream opened over it sets every entry to [`Self::EMPTY`]
    /// first.
    pub const UNSET: Self = Self {
        block: 0,
        retry_at: 0,
        slot: 0,
        queued: 0,
        fails: 0,
        class: 0,
        flags: 0,
    };

    /// Whether nothing is noted of the block (absent, not queued, no failure pending).
    fn idle(&self) -> bool {
        self.slot == NO_SLOT && self.queued == NOT_QUEUED && self.fails == 0
    }

    /// Whether the block may be read in frame `frame` (not waiting out a backoff).
    pub(crate) fn ready(&self, frame: u32) -> bool {
        self.retry_at == 0 || frame >= self.retry_at
    }
}

/// What one cache slot holds (8 bytes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SlotEntry {
    /// The file block, or [`NO_BLOCK`].
    pub(crate) block: u32,
    /// Last frame that read from the block (0 = never).
    pub(crate) used: u32,
}

impl SlotEntry {
    /// An empty slot.
    pub const EMPTY: Self = Self {
        block: NO_BLOCK,
        used: 0,
    };

    /// A slot of all zero bits (see [`BlockEntry::UNSET`]): the stream opened over it empties it
    /// first.
    pub const UNSET: Self = Self { block: 0, used: 0 };
}

/// Why a cache cannot be laid out in the memory given.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum TooSmall {
    /// Fewer than [`MIN_SLOTS`] blocks fit.
    Cache,
    /// The block table has fewer entries than [`table_entries`] of the slots and [`MIN_QUEUE`].
    Table { entries: u32, needed: u32 },
}

/// A fixed-capacity cache of file blocks over caller-provided memory (no heap): `data` holds the
/// blocks, `slots` says which block each holds, `table` has an entry per block the stream is
/// dealing with (found by hashing its index, linear probing).
///
/// Eviction keeps the coarse levels resident: blocks whose class is at most [`BlockCache::pinned`]
/// (the coarsest levels, at most half the cache) are never evicted; otherwise a block unused by the
/// current frame goes first, the finest first, then the least recently used. A block the current
/// frame used is evicted only for a strictly coarser one.
#[derive(Debug)]
pub struct BlockCache<'a> {
    pub(crate) log2: u8,
    pub(crate) data: &'a mut [u8],
    pub(crate) slots: &'a mut [SlotEntry],
    table: &'a mut [BlockEntry],
    /// Entries in use.
    entries: usize,
    /// Blocks in the file.
    blocks: usize,
    /// Requests the queue may hold: resident and queued blocks together fill at most half the
    /// table.
    pub(crate) queue_room: usize,
    /// Per class, the end of its data in the file (bytes): a block's class is the first whose end
    /// lies past the block's start, else [`BlockCache::class_after`].
    class_end: [u64; MAX_LEVELS],
    class_after: u8,
    /// Classes up to this one are never evicted (-1: none).
    pub(crate) pinned: i16,
}

impl<'a> BlockCache<'a> {
    /// A cache of `2^log2`-byte blocks in `data`, with at most `slots.len()` of them, for a file of
    /// `blocks` blocks, its block states in `table`.
    pub(crate) fn new(
        log2: u8,
        data: &'a mut [u8],
        slots: &'a mut [SlotEntry],
        table: &'a mut [BlockEntry],
        blocks: usize,
    ) -> Result<Self, TooSmall> {
        let n = (data.len() >> log2)
            .min(slots.len())
            .min(usize::from(NO_SLOT - 1));
        if n < MIN_SLOTS {
            return Err(TooSmall::Cache);
        }
        let len = if table.is_empty() {
            0
        } else {
            1usize << table.len().ilog2()
        };
        let needed = table_entries(n, MIN_QUEUE);
        if len < needed {
            return Err(TooSmall::Table {
                entries: table.len() as u32,
                needed: needed as u32,
            });
        }
        let slots = &mut slots[..n];
        slots.fill(SlotEntry::EMPTY);
        let table = &mut table[..len];
        table.fill(BlockEntry::EMPTY);
        Ok(Self {
            log2,
            data,
            slots,
            table,
            entries: 0,
            blocks,
            queue_room: (len / 2 - n - 1).min(QUEUE_CAPACITY),
            class_end: [0; MAX_LEVELS],
            class_after: 0,
            pinned: -1,
        })
    }

    /// Blocks the cache holds.
    pub fn capacity(&self) -> usize {
        self.slots.len()
    }

    /// Blocks resident now.
    pub fn resident(&self) -> usize {
        self.slots.iter().filter(|s| s.block != NO_BLOCK).count()
    }

    /// Blocks in the file.
    pub fn file_blocks(&self) -> usize {
        self.blocks
    }

    /// Coarsest classes that are never evicted: levels `0..=pinned` (`None`: nothing pinned).
    pub fn pinned(&self) -> Option<u8> {
        u8::try_from(self.pinned).ok()
    }

    /// Sets the classes of blocks: the first `c` whose `ends[c]` lies past a block's start, else
    /// `after`.
    pub(crate) fn set_classes(&mut self, ends: &[u64; MAX_LEVELS], after: u8) {
        self.class_end = *ends;
        self.class_after = after;
        for e in self.table.iter_mut().filter(|e| e.block != NO_BLOCK) {
            let start = u64::from(e.block) << self.log2;
            e.class = class_at(&self.class_end, self.class_after, start);
        }
    }

    /// The table entry of block `b`, if it has one.
    #[inline]
    fn find(&self, b: usize) -> Option<usize> {
        let b = u32::try_from(b).ok().filter(|&b| b != NO_BLOCK)?;
        let mask = self.table.len() - 1;
        let mut i = home(b, mask);
        loop {
            let k = self.table.get(i)?.block;
            if k == b {
                return Some(i);
            }
            if k == NO_BLOCK {
                return None;
            }
            i = (i + 1) & mask;
        }
    }

    /// The entry of block `b`, if the stream is dealing with it.
    #[inline]
    pub(crate) fn entry(&self, b: usize) -> Option<&BlockEntry> {
        self.find(b).map(|i| &self.table[i])
    }

    /// The entry of block `b`, if the stream is dealing with it.
    #[inline]
    pub(crate) fn entry_mut(&mut self, b: usize) -> Option<&mut BlockEntry> {
        self.find(b).map(|i| &mut self.table[i])
    }

    /// The entry of block `b` of the file, made when it has none and fewer than `limit` entries
    /// are in use (`None`: no room, or no such block).
    fn entry_or_new(&mut self, b: usize, limit: usize) -> Option<&mut BlockEntry> {
        if b >= self.blocks {
            return None;
        }
        if let Some(i) = self.find(b) {
            return Some(&mut self.table[i]);
        }
        if self.entries >= limit.min(self.table.len() - 1) {
            return None;
        }
        let b32 = b as u32;
        let mask = self.table.len() - 1;
        let mut i = home(b32, mask);
        while self.table[i].block != NO_BLOCK {
            i = (i + 1) & mask;
        }
        self.entries += 1;
        let class = class_at(&self.class_end, self.class_after, (b as u64) << self.log2);
        self.table[i] = BlockEntry {
            block: b32,
            class,
            ..BlockEntry::EMPTY
        };
        Some(&mut self.table[i])
    }

    /// Drops the entry of block `b` when nothing is noted of it any more.
    fn release(&mut self, b: usize) {
        let Some(mut i) = self.find(b) else {
            return;
        };
        if !self.table[i].idle() {
            return;
        }
        // Backward-shift deletion: move up each later entry of the run that may live at `i`.
        let mask = self.table.len() - 1;
        let mut j = i;
        loop {
            j = (j + 1) & mask;
            let k = self.table[j].block;
            if k == NO_BLOCK {
                break;
            }
            let h = home(k, mask);
            let stays = if i <= j {
                i < h && h <= j
            } else {
                i < h || h <= j
            };
            if !stays {
                self.table[i] = self.table[j];
                i = j;
            }
        }
        self.table[i] = BlockEntry::EMPTY;
        self.entries -= 1;
    }

    /// Whether block `b` is resident.
    #[inline]
    pub fn contains(&self, b: usize) -> bool {
        self.entry(b).is_some_and(|e| e.slot != NO_SLOT)
    }

    /// Whether block `b` is in the request queue.
    #[inline]
    pub(crate) fn queued(&self, b: usize) -> bool {
        self.entry(b).is_some_and(|e| e.queued != NOT_QUEUED)
    }

    /// Whether block `b` may be read in frame `frame` (not waiting out a backoff).
    #[inline]
    pub(crate) fn ready(&self, b: usize, frame: u32) -> bool {
        self.entry(b).is_none_or(|e| e.ready(frame))
    }

    /// The class of block `b` (the coarsest level with data in it, as far as the stream knows).
    #[inline]
    pub(crate) fn class(&self, b: usize) -> u8 {
        match self.entry(b) {
            Some(e) => e.class,
            None => class_at(&self.class_end, self.class_after, (b as u64) << self.log2),
        }
    }

    /// Notes that block `b` is at `index` of the request queue (`false`: no room in the table).
    pub(crate) fn set_queued(&mut self, b: usize, index: usize) -> bool {
        match self.entry_or_new(b, usize::MAX) {
            Some(e) => {
                e.queued = index as u16;
                true
            }
            None => false,
        }
    }

    /// Notes that block `b` left the request queue.
    pub(crate) fn unqueue(&mut self, b: usize) {
        if let Some(e) = self.entry_mut(b) {
            e.queued = NOT_QUEUED;
        }
        self.release(b);
    }

    /// Notes that a read or check of block `b` failed in frame `frame`: it waits out a backoff
    /// that doubles with each failure, up to `max_backoff` frames. Noted only while at most half
    /// the table is in use (the rest is kept for the resident and queued blocks); a failure not
    /// noted is read again sooner.
    pub(crate) fn fail(&mut self, b: usize, frame: u32, max_backoff: u32) {
        let half = self.table.len() / 2;
        let Some(e) = self.entry_or_new(b, half) else {
            return;
        };
        e.fails = e.fails.saturating_add(1);
        let backoff = (1u32 << u32::from(e.fails).min(6)).min(max_backoff);
        e.retry_at = frame.wrapping_add(backoff);
        if self.entries > half {
            if let Some(e) = self.entry_mut(b) {
                e.fails = 0;
            }
            self.release(b);
        }
    }

    /// Whether block `b` is resident; if so, notes that frame `frame` uses it.
    #[inline]
    pub(crate) fn touch(&mut self, b: usize, frame: u32) -> bool {
        match self.entry(b).map(|e| e.slot) {
            Some(slot) if slot != NO_SLOT => {
                if let Some(s) = self.slots.get_mut(usize::from(slot)) {
                    s.used = frame;
                }
                true
            }
            _ => false,
        }
    }

    /// The frame that last used block `b`, when it is resident.
    #[inline]
    pub(crate) fn used(&self, b: usize) -> Option<u32> {
        let e = self.entry(b)?;
        self.slots.get(usize::from(e.slot)).map(|s| s.used)
    }

    /// `n` bytes at file offset `off`, when their block is resident (they never straddle blocks:
    /// arrays are 16-byte aligned and blocks are at least 512 bytes).
    #[inline]
    pub(crate) fn bytes(&self, off: u64, n: usize) -> Option<&[u8]> {
        let b = usize::try_from(off >> self.log2).ok()?;
        let slot = self.entry(b)?.slot;
        if slot == NO_SLOT {
            return None;
        }
        let within = (off & ((1u64 << self.log2) - 1)) as usize;
        let start = (usize::from(slot) << self.log2) + within;
        self.data.get(start..start.checked_add(n)?)
    }

    /// The slot to load a block of class `class` into during frame `frame`, evicting per the policy
    /// and what the load is for ([`Evict`]).
    pub(crate) fn victim(&self, class: u8, frame: u32, mode: Evict) -> Option<usize> {
        let mut best: Option<(usize, (bool, u8, u32))> = None;
        for (s, e) in self.slots.iter().enumerate() {
            if e.block == NO_BLOCK {
                return Some(s); // free
            }
            let held = self.class(e.block as usize);
            if i16::from(held) <= self.pinned {
                continue;
            }
            let used_now = e.used == frame;
            let allowed = match mode {
                Evict::Demand => !used_now || held > class,
                Evict::Prefetch => !used_now && held > class,
                Evict::Pass => !used_now,
            };
            if !allowed {
                continue;
            }
            let key = (!used_now, held, frame.wrapping_sub(e.used));
            if best.is_none_or(|(_, k)| key > k) {
                best = Some((s, key));
            }
        }
        best.map(|(s, _)| s)
    }

    /// Empties slot `s`; returns whether it held a block.
    pub(crate) fn evict(&mut self, s: usize) -> bool {
        let Some(slot) = self.slots.get_mut(s) else {
            return false;
        };
        let old = core::mem::replace(slot, SlotEntry::EMPTY);
        if old.block == NO_BLOCK {
            return false;
        }
        let b = old.block as usize;
        if let Some(e) = self.entry_mut(b) {
            e.slot = NO_SLOT;
            e.flags = 0;
        }
        self.release(b);
        true
    }

    /// The memory of slot `s`.
    pub(crate) fn slot_bytes(&mut self, s: usize) -> &mut [u8] {
        let bs = 1usize << self.log2;
        &mut self.data[s * bs..(s + 1) * bs]
    }

    /// Records that slot `s` now holds block `b`, used by frame `frame`; `false` (and the slot left
    /// empty) when the table has no room for it, which the table's size rules out.
    pub(crate) fn install(&mut self, s: usize, b: usize, frame: u32) -> bool {
        let Some(e) = self.entry_or_new(b, usize::MAX) else {
            return false;
        };
        e.slot = s as u16;
        e.fails = 0;
        e.retry_at = 0;
        e.flags = 0;
        self.slots[s] = SlotEntry {
            block: b as u32,
            used: frame,
        };
        true
    }
}

/// Where block `b`'s probe starts in a table of `mask + 1` entries (Fibonacci hashing: nearby
/// blocks spread over the table).
#[inline]
fn home(b: u32, mask: usize) -> usize {
    (b.wrapping_mul(0x9E37_79B9) >> 7) as usize & mask
}

/// The class of the block starting at byte `start`.
#[inline]
fn class_at(ends: &[u64; MAX_LEVELS], after: u8, start: u64) -> u8 {
    ends.iter()
        .position(|&end| end > start)
        .map_or(after, |c| c as u8)
}

#[cfg(test)]
mod tests {
    use super::*;

    const TABLE: usize = 64;

    fn cache<'a>(
        data: &'a mut [u8],
        slots: &'a mut [SlotEntry],
        table: &'a mut [BlockEntry],
        classes: &[u8],
    ) -> BlockCache<'a> {
        let mut c = BlockCache::new(9, data, slots, table, classes.len()).unwrap();
        // Block b's class: classes[b] (ascending), as a file's levels give them.
        let mut ends = [0u64; MAX_LEVELS];
        for (b, &k) in classes.iter().enumerate() {
            ends[usize::from(k)] = ((b as u64) + 1) << 9;
        }
        c.set_classes(&ends, 15);
        c
    }

    #[test]
    fn too_small_a_cache_or_table_is_refused() {
        let (mut d, mut s, mut t) = (
            [0u8; 3 * 512],
            [SlotEntry::EMPTY; 8],
            [BlockEntry::EMPTY; TABLE],
        );
        assert_eq!(
            BlockCache::new(9, &mut d, &mut s, &mut t, 8).err(),
            Some(TooSmall::Cache)
        );
        let (mut d, mut s) = ([0u8; 8 * 512], [SlotEntry::EMPTY; 3]);
        assert!(BlockCache::new(9, &mut d, &mut s, &mut t, 8).is_err());
        let mut s = [SlotEntry::EMPTY; 8];
        let mut t = [BlockEntry::EMPTY; 32];
        assert_eq!(
            BlockCache::new(9, &mut d, &mut s, &mut t, 8).err(),
            Some(TooSmall::Table {
                entries: 32,
                needed: 64
            })
        );
        assert_eq!(table_entries(8, 0), 64);
        assert_eq!(table_entries(8, QUEUE_CAPACITY), 1024);
    }

    #[test]
    fn free_slots_first_then_unused_finest_then_oldest() {
        let (mut d, mut s, mut t) = (
            [0u8; 4 * 512],
            [SlotEntry::EMPTY; 4],
            [BlockEntry::EMPTY; TABLE],
        );
        let mut c = cache(&mut d, &mut s, &mut t, &[0, 1, 2, 3, 3, 4, 4, 5]);
        assert_eq!(c.victim(3, 1, Evict::Demand), Some(0));
        // Slots: block 1 (class 1) used at 5, block 3 (class 3) at 2, block 4 (class 3) at 1, block 5
        // (class 4) at frame 6 = now.
        for (slot, (blk, used)) in [(1, 5), (3, 2), (4, 1), (5, 6)].into_iter().enumerate() {
            assert!(c.install(slot, blk, used));
        }
        // Unused this frame first: block 1 (class 1) vs blocks 3 and 4 (class 3): the finest, then
        // the oldest, so block 4 in slot 2.
        assert_eq!(c.victim(2, 6, Evict::Demand), Some(2));
        // With classes up to 3 pinned, only block 5 (class 4, used now) is left: evicted for a
        // strictly coarser demand, not for a prefetch nor for an equal class.
        c.pinned = 3;
        assert_eq!(c.victim(2, 6, Evict::Demand), Some(3));
        assert_eq!(c.victim(4, 6, Evict::Demand), None);
        assert_eq!(c.victim(2, 6, Evict::Prefetch), None);
        // Next frame block 5 is unused: a prefetch of a coarser class may take it.
        assert_eq!(c.victim(2, 7, Evict::Prefetch), Some(3));
        assert_eq!(c.victim(4, 7, Evict::Prefetch), None);
        assert!(c.evict(3));
        assert!(!c.contains(5));
        assert_eq!(c.victim(4, 7, Evict::Prefetch), Some(3));
    }

    #[test]
    fn bytes_come_from_the_block_slot() {
        let (mut d, mut s, mut t) = (
            [0u8; 4 * 512],
            [SlotEntry::EMPTY; 4],
            [BlockEntry::EMPTY; TABLE],
        );
        let mut c = cache(&mut d, &mut s, &mut t, &[0; 8]);
        c.slot_bytes(2)[10..12].copy_from_slice(&[7, 9]);
        assert!(c.install(2, 5, 1));
        assert_eq!(c.bytes(5 * 512 + 10, 2), Some(&[7u8, 9][..]));
        assert_eq!(c.bytes(4 * 512 + 10, 2), None);
        assert_eq!(c.bytes(u64::MAX, 2), None);
        assert!(c.touch(5, 3) && !c.touch(4, 3) && !c.touch(99, 3));
        assert_eq!(c.slots[2].used, 3);
    }

    #[test]
    fn only_blocks_in_play_have_entries_and_the_table_stays_bounded() {
        let (mut d, mut s, mut t) = (
            [0u8; 4 * 512],
            [SlotEntry::EMPTY; 4],
            [BlockEntry::EMPTY; TABLE],
        );
        let mut c = BlockCache::new(9, &mut d, &mut s, &mut t, 100_000).unwrap();
        assert_eq!(c.queue_room, TABLE / 2 - 4 - 1);
        // Blocks far apart and close together, resident, queued and failed, in and out: the table
        // holds exactly those in play, whatever runs of probes their hashes make.
        let blocks = (0..27usize)
            .map(|i| i * 3_697 % 100_000)
            .collect::<std::vec::Vec<_>>();
        for (i, &b) in blocks.iter().enumerate() {
            assert!(c.set_queued(b, i));
        }
        assert_eq!(c.entries, 27);
        for &b in blocks.iter().step_by(2) {
            c.unqueue(b);
        }
        for (i, &b) in blocks.iter().enumerate() {
            assert_eq!(c.queued(b), i % 2 == 1, "block {b}");
        }
        assert_eq!(c.entries, 13);
        for (s, &b) in blocks.iter().skip(1).step_by(2).take(4).enumerate() {
            c.unqueue(b);
            assert!(c.install(s, b, 1));
            assert!(c.contains(b) && !c.queued(b));
        }
        assert_eq!(c.entries, 13);
        for s in 0..4 {
            assert!(c.evict(s));
        }
        assert_eq!(c.entries, 9);
        for &b in &blocks {
            c.unqueue(b);
        }
        assert_eq!(c.entries, 0);
        // Failures: noted (with a backoff) while half the table is free, then read again sooner.
        for b in 0..100 {
            c.fail(b * 7, 10, 64);
        }
        assert_eq!(c.entries, TABLE / 2);
        assert!(!c.ready(0, 11) && c.ready(0, 12));
        assert!(c.ready(99 * 7, 11));
        // A block that arrives forgets its failures.
        assert!(c.install(0, 0, 12));
        assert_eq!(c.entry(0).map(|e| e.fails), Some(0));
        assert!(c.evict(0));
        assert_eq!(c.entries, TABLE / 2 - 1);
        // Blocks past the end of the file have no entry.
        assert!(!c.set_queued(100_000, 0) && !c.install(0, 100_000, 1));
    }
}
