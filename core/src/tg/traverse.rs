//! The integer-only tri-grid traversal (Duguet §5.1–5.2): per node a few adds and compares, per drawn
//! splat one reciprocal look-up and three multiplies. No floats here.
#![deny(clippy::float_arithmetic)]

use super::frame::TgFrame;
use super::read::{LevelArrays, TriGrid};
use super::MAX_LEVELS;
use crate::fixed::{recip, SUBPIXEL_BITS};
use crate::splat::{SampleSplat, SplatSink, Stats};

/// Draws one frame of `grid` set up by `frame` into `sink`, and returns what it did.
///
/// The descent stops where a cell's projected diameter is below the cutoff (multi-level rendering,
/// drawing the stored intermediate sample), culls whole subtrees outside the frustum or behind the
/// near plane, stops testing below a cell that is entirely inside, and skips backfacing samples.
/// The work is bounded by the file: each node is visited at most once.
pub fn render_tg<S: SplatSink>(grid: &TriGrid<'_>, frame: &TgFrame, sink: &mut S) -> Stats {
    let mut arrays = [LevelArrays::default(); MAX_LEVELS];
    for (l, a) in arrays
        .iter_mut()
        .enumerate()
        .take(usize::from(frame.depth) + 1)
    {
        *a = grid.arrays(l as u8);
    }
    let octree = grid.header().rho == 2;
    let mut w = Walker {
        arrays,
        octree,
        frame,
        sink,
        stats: Stats::default(),
    };
    if grid.header().rho == frame.rho && grid.header().depth == frame.depth {
        let mask = w.mask(0, 0);
        w.node(0, 0, mask, 0, frame.root, false);
    }
    w.stats
}

struct Walker<'g, 'f, 's, S> {
    arrays: [LevelArrays<'g>; MAX_LEVELS],
    octree: bool,
    frame: &'f TgFrame,
    sink: &'s mut S,
    stats: Stats,
}

impl<S: SplatSink> Walker<'_, '_, '_, S> {
    #[inline(always)]
    fn mask(&self, level: u8, i: u32) -> u32 {
        let a = &self.arrays[usize::from(level)];
        if self.octree {
            a.mask_u8(i)
        } else {
            a.mask_u32(i)
        }
    }

    /// Visits cell `index` at `level` with child mask `mask`, whose children start at `first_child`
    /// on the next level, with projected centre `c`; `inside` when an ancestor was entirely inside the
    /// frustum (QSplat's flag: no more tests below it).
    fn node(
        &mut self,
        level: u8,
        index: u32,
        mask: u32,
        first_child: u32,
        c: [i32; 3],
        inside: bool,
    ) {
        self.stats.nodes_visited += 1;
        let f = self.frame;
        let l = usize::from(level);
        let e = &f.ext[l];
        let [x, y, w] = c;
        let mut inside = inside;
        if !inside {
            let r = 240 * w - x;
            let b = 320 * w - y;
            if w + e.w < f.near_w || x + e.x < 0 || r + e.r < 0 || y + e.y < 0 || b + e.b < 0 {
                self.stats.culled += 1;
                return;
            }
            inside =
                x - e.x >= 0 && r - e.r >= 0 && y - e.y >= 0 && b - e.b >= 0 && w - e.w >= f.near_w;
        }
        if level == f.depth || w - e.w >= f.lod_w[l] {
            self.draw(level, index, c);
            return;
        }
        // Descend: children in slot order; the group pointer finds the grandchildren.
        let next = level + 1;
        let has_grandchildren = next < f.depth;
        let mut grand = if has_grandchildren {
            self.arrays[l].group(index)
        } else {
            0
        };
        let disp = &f.disp[usize::from(next)];
        let mut child = first_child;
        let mut m = mask;
        while m != 0 {
            let s = m.trailing_zeros() as usize;
            m &= m - 1;
            let d = disp[s];
            let cm = if has_grandchildren {
                self.mask(next, child)
            } else {
                0
            };
            self.node(
                next,
                child,
                cm,
                grand,
                [x + d[0], y + d[1], w + d[2]],
                inside,
            );
            grand += cm.count_ones();
            child += 1;
        }
    }

    #[inline]
    fn draw(&mut self, level: u8, index: u32, c: [i32; 3]) {
        let f = self.frame;
        let [x, y, w] = c;
        if w < f.near_w {
            return;
        }
        let attr = self.arrays[usize::from(level)].attr(index);
        let code = usize::from(attr & 0x1FFF);
        if f.backface[code / 32] >> (code % 32) & 1 != 0 {
            self.stats.backfacing += 1;
            return;
        }
        let (r, shift) = recip(w as u32);
        let r = i64::from(r);
        let sh = shift - SUBPIXEL_BITS;
        let half = 1i64 << (sh - 1);
        let x_q4 = ((i64::from(x) * r + half) >> sh) as i32;
        let y_q4 = ((i64::from(y) * r + half) >> sh) as i32;
        let (k, kshift) = f.size_k[usize::from(level)];
        let size_q4 = if shift > kshift {
            ((u64::from(k) * r as u64) >> (shift - kshift)).min(i32::MAX as u64) as i32
        } else {
            i32::MAX
        };
        let dz = (w - f.depth_w0).max(0) as u64;
        let depth = ((dz * f.depth_scale) >> 32).min(65534) as u16;
        self.stats.splats += 1;
        self.stats.max_level = self.stats.max_level.max(level);
        self.sink.splat(&SampleSplat {
            x_q4,
            y_q4,
            size_q4,
            depth,
            attr,
            level,
            index,
        });
    }
}
