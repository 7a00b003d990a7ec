//! The traversal's view of a streamed `.tg` file ([`NodeData`] over the block cache): reads through
//! the cache, asks for what is missing, refuses descents whose data disagree, enters bricks and
//! checks each the first time it is used, and keeps a pass's state (Streaming QSplat §3.2).

use core::cell::Cell;

use heapless::Vec;

use super::cache::{BlockCache, BRICK_BAD, BRICK_OK};
use super::priority::{stream_priority, QUEUE_CAPACITY, ROOT_PRIORITY};
use super::serve::{push, Phase, Request};
use crate::tg::brick::{check_brick, Array, Brick, BrickEntry};
use crate::tg::read::{Header, LevelDir};
use crate::tg::traverse::NodeData;
use crate::tg::MAX_LEVELS;

/// An array the level does not have, or a level in bricks no brick of which is entered: never a
/// base a level has (array offsets and sizes are even, so a base, wrapped or not, is even).
pub(crate) const ABSENT: u64 = u64::MAX;

/// Where a level's arrays are: byte offsets of element 0 as if the level were one array (for a
/// level in bricks, of the entered brick's slices less their first index's elements, wrapping), or
/// [`ABSENT`]; and the level's count.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Level {
    pub count: u32,
    pub attr: u64,
    pub mask: u64,
    pub group: u64,
}

impl Level {
    /// The arrays of a level directory entry (all of them absent for a level in bricks).
    pub(crate) fn of(d: &LevelDir) -> Self {
        let at = |off: u32| if off == 0 { ABSENT } else { u64::from(off) };
        Level {
            count: d.count,
            attr: at(d.attr_off),
            mask: at(d.mask_off),
            group: at(d.group_off),
        }
    }
}

/// Where a refined frame drawn in passes stands: the cell the last pass stopped at (the path of
/// indices from the root to it), or the frame's start.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Refine {
    /// Indices of the cursor's ancestors and itself, per level `0..=level`.
    pub path: [u32; MAX_LEVELS],
    /// Level of the cursor; `None`: the frame starts from the root.
    pub level: Option<u8>,
    /// Passes drawn of this refined frame.
    pub passes: u32,
    /// Whether the last pass drew the rest of the frame (nothing it needed was absent).
    pub done: bool,
    /// Descents the passes of this refined frame refused (malformed or inconsistent data): a
    /// frame whose pass refused one is drawn coarser there, and never complete.
    pub refused: u32,
}

impl Refine {
    pub(crate) const START: Self = Self {
        path: [0; MAX_LEVELS],
        level: None,
        passes: 0,
        done: false,
        refused: 0,
    };
}

/// A pass's walk state ([`super::TgStream::render_pass`]); a progressive frame has
/// [`Phase::Progressive`].
pub(crate) struct PassState<'s> {
    pub phase: Phase,
    /// What a touch marks a block used at: the frame, or the frame before while a pass draws
    /// (blocks it only drew from are not kept for the later passes).
    pub stamp: u32,
    /// Cleared at the pass's first absent block: nothing more is drawn.
    pub drawing: &'s Cell<bool>,
    /// Where this pass resumes: cells before this path in walk order are skipped.
    pub resume: Refine,
    /// Levels down to which the walk's position follows `resume.path`: the cell the walk is at
    /// on level `on` has its parent on the path (0: the root's level).
    pub on: u8,
    /// Per level (bit), whether the walk has met the path's cell there: its later siblings come
    /// after the path in walk order, whatever that order is (slot or light order).
    pub met: u32,
    /// Per level, the last descent taken: (cell, its first child, its children).
    pub stack: [(u32, u32, u32); MAX_LEVELS],
    /// The level of the cell this pass stopped at (its first absent descent), with `path`.
    pub stop: Option<u8>,
    pub path: [u32; MAX_LEVELS],
    /// Blocks the lookahead may keep or queue: the unpinned cache, less one.
    pub room: u32,
    /// Unpinned blocks marked used since the stop, plus those queued.
    pub kept: u32,
    /// Descents the lookahead may still take.
    pub lookahead: u32,
    /// The next request is the stop's own.
    pub stopping: bool,
}

/// The bricks of a version 3 file, and the one the walk entered last.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Bricks {
    /// The brick level.
    pub level: u8,
    /// Where bricks must end ([`crate::tg::brick::band_end`]).
    pub band_end: u64,
    /// The brick entered last.
    pub entered: Entered,
}

/// What entering the brick of a brick-level cell found. (One per walk, on the stack: no heap to
/// box the brick in.)
#[derive(Clone, Copy, Debug)]
#[allow(clippy::large_enum_variant)]
pub(crate) enum Entered {
    /// Nothing entered yet.
    None,
    /// The table entry needed lies in this absent block.
    Missing(usize),
    /// The brick, its table entries resident (and the table block that holds its entry).
    Brick(Brick, usize),
}

/// Byte ranges (offset, length) one descent reads: the children's attributes and masks, the
/// parent's group entry, and, entering a brick, its table entry, the whole brick and the head's
/// masks of its cells (to check it the first time).
pub(crate) type Ranges = [(u64, u64); 6];

/// Every block of `ranges` (blocks of `2^log2` bytes), once each in order: all of them, however
/// many (a descent into a brick larger than the cache can hold is then missing blocks, never
/// dropped; `need.rs` refuses such a cache at open).
fn each_block(log2: u8, ranges: &Ranges, mut f: impl FnMut(usize)) {
    let mut prev = usize::MAX;
    for &(off, len) in ranges {
        if len == 0 {
            continue;
        }
        let (a, z) = (off >> log2, off.saturating_add(len - 1) >> log2);
        for b in a..=z {
            let b = usize::try_from(b).unwrap_or(usize::MAX);
            if b != prev {
                f(b);
                prev = b;
            }
        }
    }
}

/// The traversal's view of a stream: reads through the cache, asks for what is missing.
pub(crate) struct StreamNodes<'s, 'a, 'p> {
    pub cache: &'s mut BlockCache<'a>,
    pub queue: &'s mut Vec<Request, QUEUE_CAPACITY>,
    pub dropped: &'s mut u32,
    /// Descents refused by [`StreamNodes::claim`] or a brick that fails its check.
    pub inconsistent: &'s mut u32,
    /// Bricks that failed their check this frame (counted once, when found).
    pub bad_bricks: &'s mut u32,
    /// Per level, the index after the last sibling group this frame descended into there: a
    /// depth-first walk in slot order meets each level's groups in index order, so a group that
    /// starts before it overlaps one already visited (aliased or backward group pointers).
    pub next_free: [u32; MAX_LEVELS],
    /// Whether the walk visits siblings in slot order (no light-ordered levels).
    pub in_order: bool,
    /// Nodes this frame may still enter by descents: the file's samples less those entered.
    pub nodes_left: u64,
    pub levels: [Level; MAX_LEVELS],
    pub header: Header,
    pub dirs: [LevelDir; MAX_LEVELS],
    pub bricks: Option<Bricks>,
    pub frame: u32,
    pub pass: &'s mut PassState<'p>,
    /// What the last refused descent needed, for [`NodeData::request_children`].
    pub need: Ranges,
}

impl StreamNodes<'_, '_, '_> {
    /// Whether the walk may enter the `n` cells from `first` at `level` (a sibling group): they lie
    /// inside the level, after every group already entered there this frame (each cell has one
    /// parent, so a valid file never enters a cell twice), and within the frame's node budget. This
    /// is what makes a frame's work bounded by the file's sample count whatever the pointers say:
    /// every node but the root is entered through one accepted claim.
    #[inline]
    fn claim(&mut self, level: u8, first: u32, n: u32) -> bool {
        let l = usize::from(level);
        let (Some(dir), Some(&free)) = (self.levels.get(l), self.next_free.get(l)) else {
            return false;
        };
        let end = u64::from(first) + u64::from(n);
        if end > u64::from(dir.count)
            || (self.in_order && first < free)
            || u64::from(n) > self.nodes_left
        {
            return false;
        }
        self.next_free[l] = end as u32;
        self.nodes_left -= u64::from(n);
        true
    }

    /// What reading samples `first..first + n` of level `level` needs, plus the group pointer of
    /// cell `parent` on the level above when those samples have grandchildren.
    pub(crate) fn ranges(&self, level: u8, first: u32, n: u32, parent: Option<u32>) -> Ranges {
        let l = &self.levels[usize::from(level)];
        let mb = u64::from(self.header.mask_bytes());
        let (first, n) = (u64::from(first), u64::from(n));
        let mut r = [(0, 0); 6];
        if l.attr != ABSENT {
            r[0] = (l.attr.wrapping_add(2 * first), 2 * n);
        }
        if level < self.header.depth && l.mask != ABSENT {
            r[1] = (l.mask.wrapping_add(mb * first), mb * n);
        }
        if let (Some(p), true) = (parent, level < self.header.depth) {
            let up = &self.levels[usize::from(level) - 1];
            if up.group != ABSENT {
                r[2] = (up.group.wrapping_add(4 * u64::from(p)), 4);
            }
        }
        r
    }

    pub(crate) fn resident(&mut self, ranges: &Ranges) -> bool {
        let mut all = true;
        let stamp = self.pass.stamp;
        each_block(self.cache.log2, ranges, |b| {
            if self.pass.phase == Phase::Lookahead
                && self.cache.used(b).is_some_and(|u| u != stamp)
                && self.unpinned(b)
            {
                self.pass.kept += 1;
            }
            all &= self.cache.touch(b, stamp);
        });
        all
    }

    /// Blocks of `ranges` a lookahead descent would add to what the pass keeps: unpinned resident
    /// ones not kept yet, and absent ones not queued yet (it would queue them).
    fn would_keep(&self, ranges: &Ranges) -> u32 {
        let stamp = self.pass.stamp;
        let mut n = 0u32;
        each_block(self.cache.log2, ranges, |b| {
            let add = match self.cache.used(b) {
                Some(u) => u != stamp && self.unpinned(b),
                None => b < self.cache.file_blocks() && !self.cache.queued(b),
            };
            n += u32::from(add);
        });
        n
    }

    /// Whether block `b` may be evicted (its class is not pinned).
    fn unpinned(&self, b: usize) -> bool {
        b < self.cache.file_blocks() && i16::from(self.cache.class(b)) > self.cache.pinned
    }

    /// The pass stops drawing at cell `index` of `level`, whose children are absent: the next pass
    /// resumes there. The blocks of the descents down to it are kept for that pass, and, below the
    /// brick level, the entered brick's table entry.
    fn stop_at(&mut self, level: u8, index: u32) {
        let l = usize::from(level);
        for k in 0..l {
            self.pass.path[k] = self.pass.stack[k].0;
        }
        self.pass.path[l] = index;
        self.pass.stop = Some(level);
        self.pass.phase = Phase::Lookahead;
        self.pass.drawing.set(false);
        self.pass.stamp = self.frame;
        // The root's own blocks, then the descents down to the stop.
        let root = self.ranges(0, 0, 1, None);
        self.resident(&root);
        for k in 0..l {
            let (i, first, n) = self.pass.stack[k];
            let r = self.ranges(k as u8 + 1, first, n, Some(i));
            self.resident(&r);
        }
        if let Some(Bricks {
            level: r, entered, ..
        }) = self.bricks
        {
            if level >= r {
                // The next pass looks up the brick of the stop's cell at the brick level afresh,
                // through the same blocks of the table (`need.rs` counts them): keep them.
                let cell = if level == r {
                    index
                } else {
                    self.pass.stack[usize::from(r)].0
                };
                self.set_entered(Entered::None);
                let _ = self.find_brick(cell);
                self.set_entered(entered);
            }
        }
    }

    /// Sets the brick the walk entered last (what [`StreamNodes::find_brick`] guesses from).
    fn set_entered(&mut self, entered: Entered) {
        if let Some(bk) = self.bricks.as_mut() {
            bk.entered = entered;
        }
    }

    pub(crate) fn request(&mut self, ranges: &Ranges, priority: u32) {
        each_block(self.cache.log2, ranges, |b| {
            // A pass reads in file order (what an SD card serves best), its stop first.
            let p = match self.pass.phase {
                Phase::Lookahead if priority != ROOT_PRIORITY => {
                    u32::MAX - 1 - (b as u32).min(u32::MAX - 2)
                }
                _ => priority,
            };
            if self.push(b, p) && self.pass.phase == Phase::Lookahead {
                self.pass.kept += 1;
            }
        });
        if self.pass.phase == Phase::Lookahead && self.pass.kept >= self.pass.room {
            self.pass.phase = Phase::Done;
        }
    }

    /// Queues block `b` ([`push`]).
    fn push(&mut self, b: usize, priority: u32) -> bool {
        push(self.cache, self.queue, self.dropped, b, priority)
    }

    #[inline]
    fn read<const N: usize>(&self, off: u64) -> [u8; N] {
        match self.cache.bytes(off, N) {
            Some(b) => {
                let mut out = [0u8; N];
                out.copy_from_slice(b);
                out
            }
            None => [0; N],
        }
    }

    /// Word `k` of brick-table entry `b`, or the absent block that holds it (marked used by the
    /// frame either way).
    fn table_word(&mut self, b: u32, k: usize) -> Result<u32, usize> {
        let h = &self.header;
        let entry = crate::tg::brick::entry_bytes(h.brick_level, h.depth) as u64;
        let off = u64::from(h.brick_table) + u64::from(b) * entry + 4 * k as u64;
        let block = (off >> self.cache.log2) as usize;
        let stamp = self.pass.stamp;
        if self.pass.phase == Phase::Lookahead
            && self.cache.used(block).is_some_and(|u| u != stamp)
            && self.unpinned(block)
        {
            self.pass.kept += 1;
        }
        if !self.cache.touch(block, stamp) {
            return Err(block);
        }
        Ok(u32::from_le_bytes(self.read(off)))
    }

    /// Entry `b` of the brick table (`Err`: the absent block that holds part of it).
    fn table_entry(&mut self, b: u32) -> Result<BrickEntry, usize> {
        let r = self.header.brick_level;
        let mut e = BrickEntry {
            first_cell: self.table_word(b, 0)?,
            block: self.table_word(b, 1)?,
            first: [0; MAX_LEVELS],
        };
        for l in r + 1..=self.header.depth {
            e.first[usize::from(l)] = self.table_word(b, 2 + usize::from(l - r - 1))?;
        }
        Ok(e)
    }

    /// The brick holding brick-level cell `index`: the one entered last, the next (a walk in slot
    /// order meets them in order), or what a binary search of the table finds.
    fn find_brick(&mut self, index: u32) -> Entered {
        let Some(bk) = self.bricks else {
            return Entered::None;
        };
        let count = self.header.bricks;
        let first = |s: &mut Self, b: u32| -> Result<u32, usize> {
            if b >= count {
                Ok(u32::MAX)
            } else {
                s.table_word(b, 0)
            }
        };
        let guess = match bk.entered {
            Entered::Brick(b, _) => b.index + 1,
            _ => 0,
        };
        let b = match (first(self, guess), first(self, guess + 1)) {
            (Ok(a), Ok(z)) if guess < count && a <= index && index < z => guess,
            _ => {
                let (mut lo, mut hi) = (0u32, count);
                while hi - lo > 1 {
                    let mid = lo + (hi - lo) / 2;
                    match first(self, mid) {
                        Ok(f) if f <= index => lo = mid,
                        Ok(_) => hi = mid,
                        Err(block) => return Entered::Missing(block),
                    }
                }
                lo
            }
        };
        let e = match self.table_entry(b) {
            Ok(e) => e,
            Err(block) => return Entered::Missing(block),
        };
        let next = if b + 1 < count {
            match self.table_entry(b + 1) {
                Ok(n) => Some(n),
                Err(block) => return Entered::Missing(block),
            }
        } else {
            None
        };
        let h = &self.header;
        let entry = crate::tg::brick::entry_bytes(h.brick_level, h.depth) as u64;
        let table = ((u64::from(h.brick_table) + u64::from(b) * entry) >> self.cache.log2) as usize;
        // The table passed its check at open: every entry makes a brick.
        match Brick::of(h, &self.dirs, b, &e, next.as_ref(), bk.band_end) {
            Ok(brick) => Entered::Brick(brick, table),
            Err(_) => Entered::None,
        }
    }

    /// Points the levels in bricks at `b`'s slices.
    fn set_bases(&mut self, b: &Brick) {
        let h = self.header;
        let r = usize::from(h.brick_level);
        let mb = u64::from(h.mask_bytes());
        for l in r..usize::from(h.depth) {
            let f = u64::from(b.first[l]);
            let base = |off: u64, size: u64| {
                if off == 0 {
                    ABSENT
                } else {
                    off.wrapping_sub(size * f)
                }
            };
            let a = b.arrays[l];
            let level = &mut self.levels[l];
            if l > r {
                level.attr = base(a[Array::Attr as usize], 2);
                level.mask = base(a[Array::Mask as usize], mb);
            }
            level.group = base(a[Array::Group as usize], 4);
        }
    }

    /// The ranges entering brick `b` needs the first time: its bytes and the head's masks of its
    /// cells (what [`check_brick`] reads), when it has not been checked yet.
    fn brick_ranges(&self, b: &Brick, r: &mut Ranges) {
        let h = &self.header;
        let rl = usize::from(h.brick_level);
        let mb = u64::from(h.mask_bytes());
        let mask_off = u64::from(self.dirs[rl].mask_off);
        r[4] = (b.start, b.end - b.start);
        r[5] = (
            mask_off + mb * u64::from(b.first[rl]),
            mb * u64::from(b.count[rl]),
        );
    }

    /// Checks brick `b` (every byte it and the head's masks of its cells need is resident) and
    /// records the verdict with its first block: a brick's bytes are sealed by their CRCs, so it
    /// is checked once.
    fn check(&mut self, b: &Brick) -> bool {
        let first = (b.start >> self.cache.log2) as usize;
        let (h, dirs) = (self.header, self.dirs);
        let cache = &*self.cache;
        let mut read = |off: u64, n: usize| -> Option<u128> {
            let bytes = cache.bytes(off, n)?;
            let mut w = [0u8; 16];
            w.get_mut(..n)?.copy_from_slice(bytes);
            Some(u128::from_le_bytes(w))
        };
        let ok = check_brick(&h, &dirs, b, &mut read).is_ok();
        if let Some(e) = self.cache.entry_mut(first) {
            e.flags |= if ok { BRICK_OK } else { BRICK_BAD };
        }
        if !ok {
            *self.bad_bricks += 1;
        }
        ok
    }
}

impl NodeData for StreamNodes<'_, '_, '_> {
    const STREAMED: bool = true;
    const BRICKED: bool = true;

    fn shape(&self) -> (u8, u8) {
        (self.header.rho, self.header.depth)
    }

    #[inline]
    fn brick_level(&self) -> u8 {
        self.bricks.map_or(u8::MAX, |b| b.level)
    }

    fn enter(&mut self, index: u32) {
        let Some(bk) = self.bricks else {
            return;
        };
        let r = usize::from(bk.level);
        if let Entered::Brick(b, _) = bk.entered {
            if index.wrapping_sub(b.first[r]) < b.count[r] {
                return;
            }
        }
        let entered = self.find_brick(index);
        if let Entered::Brick(b, _) = &entered {
            let b = *b;
            self.set_bases(&b);
        } else {
            // Nothing below the brick level may be read until a brick is entered.
            for l in r..usize::from(self.header.depth) {
                let level = &mut self.levels[l];
                if l > r {
                    level.attr = ABSENT;
                    level.mask = ABSENT;
                }
                level.group = ABSENT;
            }
        }
        if let Some(bk) = self.bricks.as_mut() {
            bk.entered = entered;
        }
    }

    #[inline]
    fn attr(&self, level: u8, i: u32) -> u16 {
        let l = &self.levels[usize::from(level)];
        if i >= l.count || l.attr == ABSENT {
            return 0;
        }
        u16::from_le_bytes(self.read(l.attr.wrapping_add(2 * u64::from(i))))
    }

    #[inline]
    fn mask(&self, level: u8, i: u32) -> u32 {
        let l = &self.levels[usize::from(level)];
        if i >= l.count || l.mask == ABSENT {
            return 0;
        }
        if self.header.rho == 2 {
            u32::from(self.read::<1>(l.mask.wrapping_add(u64::from(i)))[0])
        } else {
            u32::from_le_bytes(self.read(l.mask.wrapping_add(4 * u64::from(i))))
        }
    }

    #[inline]
    fn group(&self, level: u8, i: u32) -> u32 {
        let l = &self.levels[usize::from(level)];
        if i >= l.count || l.group == ABSENT {
            return 0;
        }
        u32::from_le_bytes(self.read(l.group.wrapping_add(4 * u64::from(i))))
    }

    fn children_resident(&mut self, level: u8, index: u32, first_child: u32, n: u32) -> bool {
        self.need = [(0, 0); 6];
        if !self.claim(level + 1, first_child, n) {
            *self.inconsistent += 1;
            return false;
        }
        let mut r = self.ranges(level + 1, first_child, n, Some(index));
        let mut unchecked = None;
        if let Some(bk) = self.bricks.filter(|b| b.level == level) {
            match bk.entered {
                Entered::Missing(block) => r[3] = ((block as u64) << self.cache.log2, 1),
                Entered::Brick(b, table) => {
                    r[3] = ((table as u64) << self.cache.log2, 1);
                    let first = (b.start >> self.cache.log2) as usize;
                    let flags = self.cache.entry(first).map_or(0, |e| e.flags);
                    if flags & BRICK_BAD != 0 {
                        *self.inconsistent += 1;
                        return false;
                    }
                    if flags & BRICK_OK == 0 {
                        self.brick_ranges(&b, &mut r);
                        unchecked = Some(b);
                    }
                }
                Entered::None => {
                    *self.inconsistent += 1;
                    return false;
                }
            }
        }
        if self.pass.phase == Phase::Lookahead
            && self.pass.kept + self.would_keep(&r) > self.pass.room
        {
            // The lookahead keeps no more than leaves the next pass room for what it stopped at:
            // a descent that would take more ends it (and queues nothing).
            self.pass.phase = Phase::Done;
            return false;
        }
        self.need = r;
        if !self.resident(&r) {
            if self.pass.phase == Phase::Draw {
                self.stop_at(level, index);
                self.pass.stopping = true;
                // What of the stop's own blocks is here stays for the next pass too.
                self.resident(&r);
            }
            return false;
        }
        if let Some(b) = unchecked {
            if !self.check(&b) {
                *self.inconsistent += 1;
                return false;
            }
        }
        if self.pass.phase == Phase::Lookahead {
            // What the lookahead keeps must leave room for what it queues: stop when full.
            self.pass.lookahead = self.pass.lookahead.saturating_sub(1);
            if self.pass.lookahead == 0 || self.pass.kept >= self.pass.room {
                self.pass.phase = Phase::Done;
            }
        }
        if let Some(e) = self.pass.stack.get_mut(usize::from(level)) {
            *e = (index, first_child, n);
        }
        true
    }

    #[inline]
    fn skip(&mut self, level: u8, index: u32) -> bool {
        match self.pass.phase {
            Phase::Progressive => false,
            Phase::Done => true,
            Phase::Draw | Phase::Lookahead => match self.pass.resume.level {
                Some(c) if level <= c => {
                    // Walk order is slot order, or light order at one-pass shadows' ordered
                    // levels (Duguet §5.3): not index order, so the walk itself says what came
                    // first. A cell whose parent is off the path comes after it (a cell before
                    // it was skipped whole); among the path's siblings, those met before the
                    // path's own cell were drawn by earlier passes.
                    let pass = &mut *self.pass;
                    if pass.on < level {
                        return false;
                    }
                    // (The path's cell may be asked about twice: a culled cell's own cast asks
                    // again.)
                    let bit = 1u32 << (level & 31);
                    if index == pass.resume.path[usize::from(level)] {
                        pass.met |= bit;
                        pass.on = level + 1;
                        return false;
                    }
                    pass.on = level;
                    pass.met & bit == 0
                }
                _ => false,
            },
        }
    }

    fn request_children(
        &mut self,
        _level: u8,
        _index: u32,
        _first_child: u32,
        _n: u32,
        size_q8: i32,
        y_q8: i32,
    ) {
        let r = self.need;
        let priority = if core::mem::take(&mut self.pass.stopping) {
            ROOT_PRIORITY
        } else {
            stream_priority(size_q8, y_q8)
        };
        self.request(&r, priority);
    }
}
