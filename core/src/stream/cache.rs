//! The block cache: a fixed number of file blocks in caller-provided memory, the per-block table
//! (CRC, where the block is, whether it is queued, its failures) and the eviction policy.
//!
//! Streaming QSplat §3.3 keeps two bits per block (absent, desired, requested, present); here each
//! block has a [`BlockEntry`] that also holds its CRC (so the CRC table need not stay in the cache),
//! its slot, its place in the request queue and its retry time.

/// No slot: the block is absent.
pub(crate) const NO_SLOT: u16 = u16::MAX;
/// Not in the request queue.
pub(crate) const NOT_QUEUED: u16 = u16::MAX;
/// No block in this slot.
pub(crate) const NO_BLOCK: u32 = u32::MAX;
/// [`BlockEntry::flags`]: the brick that starts at this block passed its check (version 3 bricks
/// are checked once, the first time the walk enters them; their bytes are sealed by their CRCs).
pub(crate) const BRICK_OK: u8 = 1;
/// [`BlockEntry::flags`]: the brick that starts at this block failed its check.
pub(crate) const BRICK_BAD: u8 = 2;
/// Fewest blocks a cache may hold: the coarse levels plus room to refine.
pub const MIN_SLOTS: usize = 4;

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

/// What the stream knows of one block of the file (16 bytes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BlockEntry {
    /// CRC-32 of the block, from the file's CRC table.
    pub(crate) crc: u32,
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
    /// [`BRICK_OK`] or [`BRICK_BAD`] once the brick starting here was checked.
    pub(crate) flags: u8,
}

impl BlockEntry {
    /// An entry before the file is opened.
    pub const EMPTY: Self = Self {
        crc: 0,
        retry_at: 0,
        slot: NO_SLOT,
        queued: NOT_QUEUED,
        fails: 0,
        class: 0,
        flags: 0,
    };

    /// An entry of all zero bits, for memory a board lays out before it opens a file (a `static`
    /// in `.bss`, not `.data`): the stream opened over it sets every entry it uses to
    /// [`Self::EMPTY`] first.
    pub const UNSET: Self = Self {
        crc: 0,
        retry_at: 0,
        slot: 0,
        queued: 0,
        fails: 0,
        class: 0,
        flags: 0,
    };
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

/// A fixed-capacity cache of file blocks over caller-provided memory (no heap): `data` holds the
/// blocks, `slots` says which block each holds, `blocks` has one entry per block of the file.
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
    pub(crate) blocks: &'a mut [BlockEntry],
    /// Classes up to this one are never evicted (-1: none).
    pub(crate) pinned: i16,
}

impl<'a> BlockCache<'a> {
    /// A cache of `2^log2`-byte blocks in `data`, with at most `slots.len()` of them, for a file of
    /// `blocks.len()` blocks. Returns `None` when it holds fewer than [`MIN_SLOTS`] blocks.
    pub(crate) fn new(
        log2: u8,
        data: &'a mut [u8],
        slots: &'a mut [SlotEntry],
        blocks: &'a mut [BlockEntry],
    ) -> Option<Self> {
        let n = (data.len() >> log2)
            .min(slots.len())
            .min(usize::from(NO_SLOT - 1));
        if n < MIN_SLOTS {
            return None;
        }
        let slots = &mut slots[..n];
        slots.fill(SlotEntry::EMPTY);
        blocks.fill(BlockEntry::EMPTY);
        Some(Self {
            log2,
            data,
            slots,
            blocks,
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

    /// Coarsest classes that are never evicted: levels `0..=pinned` (`None`: nothing pinned).
    pub fn pinned(&self) -> Option<u8> {
        u8::try_from(self.pinned).ok()
    }

    /// Whether block `b` is resident.
    #[inline]
    pub fn contains(&self, b: usize) -> bool {
        self.blocks.get(b).is_some_and(|e| e.slot != NO_SLOT)
    }

    /// Whether block `b` is resident; if so, notes that frame `frame` uses it.
    #[inline]
    pub(crate) fn touch(&mut self, b: usize, frame: u32) -> bool {
        match self.blocks.get(b) {
            Some(e) if e.slot != NO_SLOT => {
                if let Some(s) = self.slots.get_mut(usize::from(e.slot)) {
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
        let e = self.blocks.get(b)?;
        self.slots.get(usize::from(e.slot)).map(|s| s.used)
    }

    /// `n` bytes at file offset `off`, when their block is resident (they never straddle blocks:
    /// arrays are 16-byte aligned and blocks are at least 512 bytes).
    #[inline]
    pub(crate) fn bytes(&self, off: u64, n: usize) -> Option<&[u8]> {
        let b = usize::try_from(off >> self.log2).ok()?;
        let slot = self.blocks.get(b)?.slot;
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
            let Some(b) = self.blocks.get(e.block as usize) else {
                return Some(s); // free
            };
            if i16::from(b.class) <= self.pinned {
                continue;
            }
            let used_now = e.used == frame;
            let allowed = match mode {
                Evict::Demand => !used_now || b.class > class,
                Evict::Prefetch => !used_now && b.class > class,
                Evict::Pass => !used_now,
            };
            if !allowed {
                continue;
            }
            let key = (!used_now, b.class, frame.wrapping_sub(e.used));
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
        match self.blocks.get_mut(old.block as usize) {
            Some(e) => {
                e.slot = NO_SLOT;
                true
            }
            None => false,
        }
    }

    /// The memory of slot `s`.
    pub(crate) fn slot_bytes(&mut self, s: usize) -> &mut [u8] {
        let bs = 1usize << self.log2;
        &mut self.data[s * bs..(s + 1) * bs]
    }

    /// Records that slot `s` now holds block `b`, used by frame `frame`.
    pub(crate) fn install(&mut self, s: usize, b: usize, frame: u32) {
        self.slots[s] = SlotEntry {
            block: b as u32,
            used: frame,
        };
        let e = &mut self.blocks[b];
        e.slot = s as u16;
        e.fails = 0;
        e.retry_at = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cache<'a>(
        data: &'a mut [u8],
        slots: &'a mut [SlotEntry],
        blocks: &'a mut [BlockEntry],
        classes: &[u8],
    ) -> BlockCache<'a> {
        let c = BlockCache::new(9, data, slots, blocks).unwrap();
        for (e, &k) in c.blocks.iter_mut().zip(classes) {
            e.class = k;
        }
        c
    }

    #[test]
    fn too_small_a_cache_is_refused() {
        let (mut d, mut s, mut b) = (
            [0u8; 3 * 512],
            [SlotEntry::EMPTY; 8],
            [BlockEntry::EMPTY; 8],
        );
        assert!(BlockCache::new(9, &mut d, &mut s, &mut b).is_none());
        let (mut d, mut s) = ([0u8; 8 * 512], [SlotEntry::EMPTY; 3]);
        assert!(BlockCache::new(9, &mut d, &mut s, &mut b).is_none());
    }

    #[test]
    fn free_slots_first_then_unused_finest_then_oldest() {
        let (mut d, mut s, mut b) = (
            [0u8; 4 * 512],
            [SlotEntry::EMPTY; 4],
            [BlockEntry::EMPTY; 8],
        );
        let mut c = cache(&mut d, &mut s, &mut b, &[0, 1, 2, 3, 3, 4, 4, 5]);
        assert_eq!(c.victim(3, 1, Evict::Demand), Some(0));
        // Slots: block 1 (class 1) used at 5, block 3 (class 3) at 2, block 4 (class 3) at 1, block 5
        // (class 4) at frame 6 = now.
        for (slot, (blk, used)) in [(1, 5), (3, 2), (4, 1), (5, 6)].into_iter().enumerate() {
            c.install(slot, blk, used);
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
        let (mut d, mut s, mut b) = (
            [0u8; 4 * 512],
            [SlotEntry::EMPTY; 4],
            [BlockEntry::EMPTY; 8],
        );
        let mut c = cache(&mut d, &mut s, &mut b, &[0; 8]);
        c.slot_bytes(2)[10..12].copy_from_slice(&[7, 9]);
        c.install(2, 5, 1);
        assert_eq!(c.bytes(5 * 512 + 10, 2), Some(&[7u8, 9][..]));
        assert_eq!(c.bytes(4 * 512 + 10, 2), None);
        assert_eq!(c.bytes(u64::MAX, 2), None);
        assert!(c.touch(5, 3) && !c.touch(4, 3) && !c.touch(99, 3));
        assert_eq!(c.slots[2].used, 3);
    }
}
