//! The cache a streamed file needs: how many blocks a pass must hold at once to make progress
//! wherever it stops, worked out at open from the header, the level directory and the brick table,
//! so that a cache too small for a file is refused then, naming the size it needs, instead of a
//! frame that never converges (issue 33).
//!
//! A pass that stops at a cell must find, in the next pass, the blocks of every descent from the
//! root down to that cell and those of the cell's own descent resident together (nothing is evicted
//! during a walk, only between passes, and the blocks the walk used are kept over the others):
//!
//! - per level of the head, the blocks a sibling group's attributes and masks and its parent's
//!   group pointer lie in (a run of ρ³ elements touches at most one block more than its bytes
//!   fill; an array that spans no more than that counts its own blocks, shared with its neighbours);
//! - in a bricked file, the brick table's blocks its look-up reads (a binary search), the largest
//!   brick together with the head's masks of its cells (what checking it on first entry reads,
//!   and the path below the brick level lies in it), and a sibling group of leaves.
//!
//! The coarsest levels the cache pins (never evicted) count whole instead, as the blocks they
//! take. This is an upper bound: a view may converge through less, but every view converges
//! through this much.
#![deny(clippy::float_arithmetic)]

use heapless::Vec;

use super::cache::MIN_SLOTS;
use crate::tg::brick::{blocks_spanned, entry_bytes, BrickSpans};
use crate::tg::read::{Header, LevelDir};
use crate::tg::MAX_LEVELS;

/// Per level, the end of its data in the file (the brick table counts as the brick level's, the
/// bricks as the levels below it): the classes the cache evicts by.
pub(crate) type LevelEnds = [u64; MAX_LEVELS];

/// What a file needs of a cache: its layout, and what its bricks span.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Need<'h> {
    pub header: &'h Header,
    pub dirs: &'h [LevelDir; MAX_LEVELS],
    pub spans: BrickSpans,
    pub level_end: &'h LevelEnds,
}

impl Need<'_> {
    /// Blocks of the levels `0..=pinned` (none for −1): what pinning them takes of the cache.
    pub(crate) fn pinned_blocks(&self, pinned: i16) -> u32 {
        let Ok(p) = usize::try_from(pinned) else {
            return 0;
        };
        let first_data = u64::from(self.header.crc_table_blocks) + 1;
        let end = self.level_end.get(p).copied().unwrap_or(0);
        let last = end.saturating_sub(1) >> self.header.block_log2;
        u32::try_from((last + 1).saturating_sub(first_data)).unwrap_or(u32::MAX)
    }

    /// Blocks a pass needs at once besides the pinned levels `0..=pinned`, at most.
    pub(crate) fn unpinned_blocks(&self, pinned: i16) -> u32 {
        let h = self.header;
        let log2 = h.block_log2;
        let group = u64::from(h.rho).pow(3);
        let mb = u64::from(h.mask_bytes());
        let unpinned = |l: u8| i16::from(l) > pinned;
        // Blocks counted one by one (shared between small arrays), and blocks only counted.
        let mut exact: Vec<u64, 128> = Vec::new();
        let mut counted = 0u32;
        let mut array = |off: u32, count: u32, size: u64, window: u64| {
            if off == 0 || count == 0 {
                return;
            }
            let len = size * u64::from(count);
            let window = size * window.min(u64::from(count));
            let cover = blocks_spanned(0, window, log2).saturating_add(1);
            let own = blocks_spanned(u64::from(off), len, log2);
            if own <= cover {
                let first = u64::from(off) >> log2;
                for b in first..first + u64::from(own) {
                    if !exact.contains(&b) && exact.push(b).is_err() {
                        counted = counted.saturating_add(1);
                    }
                }
            } else {
                counted = counted.saturating_add(cover);
            }
        };
        for l in (0..=h.head_level()).filter(|&l| unpinned(l)) {
            let d = &self.dirs[usize::from(l)];
            // The root is read alone, every other level by sibling groups.
            let window = if l == 0 { 1 } else { group };
            array(d.attr_off, d.count, 2, window);
            if l < h.depth {
                array(d.mask_off, d.count, mb, window);
            }
            if h.group_listed(l) {
                array(d.group_off, d.count, 4, 1);
            }
        }
        if h.bricked() {
            let leaves = &self.dirs[usize::from(h.depth)];
            if unpinned(h.depth) {
                array(leaves.attr_off, leaves.count, 2, group);
            }
            let r = h.brick_level;
            if unpinned(r) {
                let entry = entry_bytes(r, h.depth) as u64;
                let table =
                    blocks_spanned(u64::from(h.brick_table), u64::from(h.bricks) * entry, log2);
                // The look-up: two guesses, a binary search, then two entries (at most two blocks).
                let search = 2 + (32 - h.bricks.leading_zeros()) + 2;
                counted = counted
                    .saturating_add(table.min(search))
                    .saturating_add(self.spans.checked);
            } else if unpinned(r + 1) {
                counted = counted.saturating_add(self.spans.brick);
            }
        }
        (exact.len() as u32).saturating_add(counted)
    }

    /// Blocks the whole cache must hold with levels `0..=pinned` pinned: those, and what a pass
    /// needs besides; pinning takes at most half the cache.
    pub(crate) fn cache_blocks(&self, pinned: i16) -> u32 {
        let p = self.pinned_blocks(pinned);
        p.saturating_add(self.unpinned_blocks(pinned))
            .max(p.saturating_mul(2))
            .max(MIN_SLOTS as u32)
    }

    /// The fewest blocks a cache of this file may hold, pinning whatever suits that size best.
    pub(crate) fn min_cache_blocks(&self) -> u32 {
        (-1..self.header.levels() as i16)
            .map(|p| self.cache_blocks(p))
            .min()
            .unwrap_or(u32::MAX)
    }

    /// The coarsest levels a cache of `slots` blocks pins, `0..=p` (−1: none): as many as fill at
    /// most half of it and leave a pass what it needs. `None` when no choice fits.
    pub(crate) fn pinning(&self, slots: u32) -> Option<i16> {
        (-1..self.header.levels() as i16)
            .take_while(|&p| self.pinned_blocks(p).saturating_mul(2) <= slots)
            .filter(|&p| self.cache_blocks(p) <= slots)
            .last()
    }
}
