//! The integer-only QSplat traversal (QSplat §2.1): per node, decode the sphere relative to the parent
//! (a table look-up, three multiplies and three 64-bit multiply-adds), test it against the frustum
//! (skipped below a node wholly inside), test its normal cone (skipped below a node facing the eye
//! entirely), then draw it as a splat or descend. No floats here.
#![deny(clippy::float_arithmetic)]

use super::frame::{QsFrame, TreeFrame, ROOT_RADIUS, T_BITS};
use super::read::{Children, Group, Node, QSplat, Tree, TreeHead};
use super::table::SPHERES;
use super::{normal, QS_MAJOR_Q14, QS_SHADE_CODE, QS_TAN_Q14};
use crate::fixed::{recip, SUBPIXEL_BITS};
use crate::frame::Walk;
pub use crate::splat::ColorSink;
use crate::splat::{SampleSplat, SplatSink, Stats};

/// Any sink, with colours ignored.
pub(crate) struct NoColor<'s, S>(pub(crate) &'s mut S);

impl<S: SplatSink> SplatSink for NoColor<'_, S> {
    #[inline(always)]
    fn splat(&mut self, s: &SampleSplat) {
        self.0.splat(s);
    }
}

impl<S: SplatSink> ColorSink for NoColor<'_, S> {
    #[inline(always)]
    fn splat_colored(&mut self, s: &SampleSplat, _: u16) {
        self.0.splat(s);
    }
}

/// A QSplat file's frame ready to walk: what the pipeline runs ([`Walk`]), coloured samples to
/// [`ColorSink::splat_colored`].
pub struct QsWalk<'a, 'f> {
    /// The file.
    pub file: &'a QSplat<'f>,
    /// Its frame.
    pub frame: &'a QsFrame,
}

impl Walk for QsWalk<'_, '_> {
    #[inline]
    fn walk<S: ColorSink>(&mut self, sink: &mut S) -> Stats {
        render_qs_colored(self.file, self.frame, sink)
    }
}

/// Draws one frame of `file` into `sink` with one material (colours ignored): every sample's
/// attribute is its normal's 13-bit shading code.
///
/// The descent stops at leaves and where a node's projected diameter is at most the cutoff; it culls
/// subtrees outside the frustum or behind the near plane and subtrees whose normal cone faces away,
/// and stops testing below nodes wholly inside or wholly facing the eye. Each node is visited at most
/// once, so the work is bounded by the file.
pub fn render_qs<S: SplatSink>(file: &QSplat<'_>, frame: &QsFrame, sink: &mut S) -> Stats {
    walk(file, frame, &mut NoColor(sink), false)
}

/// [`render_qs`], handing coloured samples to [`ColorSink::splat_colored`].
pub fn render_qs_colored<S: ColorSink>(file: &QSplat<'_>, frame: &QsFrame, sink: &mut S) -> Stats {
    walk(file, frame, sink, true)
}

fn walk<S: ColorSink>(file: &QSplat<'_>, frame: &QsFrame, sink: &mut S, colored: bool) -> Stats {
    let mut stats = Stats::default();
    for tree in file.trees() {
        walk_tree(
            &tree.head(),
            InPlace(tree),
            frame,
            sink,
            colored,
            &mut stats,
        );
    }
    stats
}

/// Draws the tree `head` whose groups `nodes` reads, adding to `stats`; gives `nodes` back.
pub(crate) fn walk_tree<N: QsNodes, S: ColorSink>(
    head: &TreeHead,
    nodes: N,
    frame: &QsFrame,
    sink: &mut S,
    colored: bool,
    stats: &mut Stats,
) -> N {
    let tf = frame.tree(head);
    let mut w = Walker {
        offset: head.offset,
        root: head.root,
        nodes,
        tf: &tf,
        frame,
        sink,
        stats: *stats,
        colored: colored && head.color,
    };
    w.root();
    *stats = w.stats;
    w.nodes
}

/// Where a walk reads a tree's sibling groups: the file in memory ([`InPlace`]), or a stream's
/// block cache, where a group may be absent (the walk then draws its parent, Streaming QSplat §3.2).
pub(crate) trait QsNodes {
    /// A group's records in order.
    type Records: Iterator<Item = (u32, Node, Option<Group>)>;

    /// The records of group `g`, whose members are at `level` (the root's children are level 1),
    /// or `None` when they are not available: absent, or refused as malformed.
    fn group(&mut self, g: Group, level: u8) -> Option<Self::Records>;

    /// The walk wanted group `g` (members at `level`) and [`QsNodes::group`] had none: `parent`
    /// is the splat drawn in its place next (`None`: the root's group, nothing drawn).
    #[inline(always)]
    fn absent(&mut self, _g: Group, _level: u8, _parent: Option<&SampleSplat>) {}

    /// Whether to skip member `index` of the group at `level` (what earlier passes of a refined
    /// frame drew). Called for every member before it is visited.
    #[inline(always)]
    fn skip(&mut self, _level: u8, _index: usize) -> bool {
        false
    }

    /// Whether the walk should end now (a pass that queued all it may).
    #[inline(always)]
    fn done(&self) -> bool {
        false
    }
}

/// A tree in memory: every group is there, validated at open.
struct InPlace<'t>(Tree<'t>);

impl<'t> QsNodes for InPlace<'t> {
    type Records = Children<'t>;

    #[inline(always)]
    fn group(&mut self, g: Group, _level: u8) -> Option<Children<'t>> {
        Some(self.0.children(g))
    }
}

/// A decoded node: centre in model integers, projected centre, radius.
#[derive(Clone, Copy)]
struct Sphere {
    c: [i32; 3],
    xyw: [i32; 3],
    r: i32,
}

/// `256 · sin²θ` bounds of the cone codes 0–2 (code 3, never culled, is not tested).
static CONE_K: [i32; 4] = [1, 16, 81, 81];

/// Frustum tests off (the node is wholly inside) / backface tests off (the cone faces the eye).
#[derive(Clone, Copy)]
struct Flags {
    inside: bool,
    facing: bool,
}

/// Slack added to every plane extent, in `(X, Y, W)` units: the displacement tables round at every
/// level (far below a pixel, which is `W` units).
const PLANE_MARGIN: u64 = 256;

/// `⌈r / 13⌉` for `0 ≤ r < 2³¹ − 12`, by a multiply (exact in this range).
#[inline(always)]
fn thirteenth_up(r: i32) -> i32 {
    ((u64::from(r.max(0) as u32 + 12) * 330_382_100) >> 32) as i32
}

/// `(i / 52, i % 52)` for `i < 2¹⁵`, by a multiply.
#[inline(always)]
fn div52(i: u32) -> (u32, u32) {
    let q = (i * 20165) >> 20;
    (q, i - 52 * q)
}

/// The unit normal of a 14-bit index in Q14, or `None` for the codes that leave the unit sphere
/// (never culled).
#[inline]
fn normal_q14(index: u16) -> Option<[i32; 3]> {
    let i = u32::from(index);
    if i >= normal::NORMAL_CODES {
        return Some([0, 0, 16384]);
    }
    let (fu, v) = div52(i);
    let (face, u) = div52(fu);
    let major = i32::from(QS_MAJOR_Q14[(i % normal::FACE_CODES) as usize]);
    if major < 0 {
        return None;
    }
    let m = if face & 1 == 1 { -major } else { major };
    let (u, v) = (
        i32::from(QS_TAN_Q14[u as usize]),
        i32::from(QS_TAN_Q14[v as usize]),
    );
    Some(match face >> 1 {
        0 => [m, u, v],
        1 => [v, m, u],
        _ => [u, v, m],
    })
}

struct Walker<'f, 's, N, S> {
    /// The tree's fragment offset and root group.
    offset: u32,
    root: Group,
    nodes: N,
    tf: &'f TreeFrame,
    frame: &'f QsFrame,
    sink: &'s mut S,
    stats: Stats,
    colored: bool,
}

impl<N: QsNodes, S: ColorSink> Walker<'_, '_, N, S> {
    fn root(&mut self) {
        count!(self.stats.nodes_visited += 1);
        let root = Sphere {
            c: [0; 3],
            xyw: self.tf.root,
            r: ROOT_RADIUS,
        };
        let flags = Flags {
            inside: false,
            facing: !self.tf.backface,
        };
        // The root has no normal: it is never drawn or backface culled, only frustum tested.
        let Some(inside) = self.frustum(&root) else {
            count!(self.stats.culled += 1);
            return;
        };
        let flags = Flags { inside, ..flags };
        let g = self.root;
        match self.nodes.group(g, 1) {
            Some(records) => self.members(records, &root, 1, flags),
            None => self.nodes.absent(g, 1, None),
        }
    }

    fn members(&mut self, mut records: N::Records, parent: &Sphere, level: u8, flags: Flags) {
        let r13 = thirteenth_up(parent.r);
        // `while let` and a counter, not `for` over `enumerate` (or over the records): on
        // thumbv7m the `for` forms cost 4 to 11 instructions more per node (std 1 px: 471.5 with
        // `enumerate`, 464.5 with `for`, 460.2 so).
        let mut i = 0;
        #[allow(clippy::while_let_on_iterator)]
        while let Some((at, node, child)) = records.next() {
            if !self.nodes.skip(level, i) {
                self.node(at, &node, child, parent, r13, level, flags);
                if self.nodes.done() {
                    return;
                }
            }
            i += 1;
        }
    }

    /// `Some(inside)` when the sphere meets the frustum (QSplat's flag: no more tests below a node
    /// wholly inside), `None` when it is wholly outside a plane.
    #[inline]
    fn frustum(&self, s: &Sphere) -> Option<bool> {
        let tf = self.tf;
        let r = s.r.max(0) as u32;
        let e = |k: usize| (tf.ext[k].apply(r) + PLANE_MARGIN) as i64;
        let [x, y, w] = s.xyw.map(i64::from);
        let near = i64::from(self.frame.near_w);
        let (width, height) = (
            i64::from(self.frame.viewport.width),
            i64::from(self.frame.viewport.height),
        );
        let f = [x, y, w - near, width * w - x, height * w - y];
        let mut inside = true;
        for (k, &v) in f.iter().enumerate() {
            let ek = e(k);
            if v + ek < 0 {
                return None;
            }
            inside &= v - ek >= 0;
        }
        Some(inside)
    }

    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn node(
        &mut self,
        at: u32,
        node: &Node,
        child: Option<Group>,
        parent: &Sphere,
        r13: i32,
        level: u8,
        mut flags: Flags,
    ) {
        count!(self.stats.nodes_visited += 1);
        // Validated below 7621; the parent's own sphere otherwise. Packed `s, x, y, z`
        // (QSplat §3.1): the displacement tables are indexed by `s + 2x = a + 13`.
        let p = u32::from(
            SPHERES
                .get(usize::from(node.sphere))
                .copied()
                .unwrap_or(0xD000),
        );
        let s13 = p >> 12;
        let (ia, ib, ic) = (
            (s13 + (p >> 7 & 30)) as usize & 31,
            (s13 + (p >> 3 & 30)) as usize & 31,
            (s13 + (p << 1 & 30)) as usize & 31,
        );
        let (a, b, c) = (ia as i32 - 13, ib as i32 - 13, ic as i32 - 13);
        let t = &self.tf.t;
        let (ta, tb, tc) = (&t[0][ia], &t[1][ib], &t[2][ic]);
        // Wrapping: a valid tree stays far inside i32 (every centre lies within about one root radius
        // of the root's); a hostile one draws garbage but cannot overflow. The table sum fits an
        // i32 whatever the file holds (each entry is at most 12 model integers times a row of at
        // most 4 units each: 3 · 12 · 4 · 2²³ < 2³¹), so one 32 × 32 → 64-bit multiply.
        let step = |k: usize| {
            let sum = ta[k].wrapping_add(tb[k]).wrapping_add(tc[k]);
            ((i64::from(r13) * i64::from(sum) + (1 << (T_BITS - 1))) >> T_BITS) as i32
        };
        let s = Sphere {
            // The model-space centre serves only the cone test: below a node facing the eye
            // nothing tests, so it is not kept up.
            c: if flags.facing {
                parent.c
            } else {
                [
                    parent.c[0].wrapping_add(a.wrapping_mul(r13)),
                    parent.c[1].wrapping_add(b.wrapping_mul(r13)),
                    parent.c[2].wrapping_add(c.wrapping_mul(r13)),
                ]
            },
            xyw: [
                parent.xyw[0].wrapping_add(step(0)),
                parent.xyw[1].wrapping_add(step(1)),
                parent.xyw[2].wrapping_add(step(2)),
            ],
            r: (s13 as i32).wrapping_mul(r13),
        };
        if !flags.inside {
            match self.frustum(&s) {
                None => {
                    count!(self.stats.culled += 1);
                    return;
                }
                Some(inside) => flags.inside = inside,
            }
        }
        if !flags.facing && node.cone < normal::CONE_NEVER {
            match self.backface(&s, node) {
                Cone::Away => {
                    count!(self.stats.backfacing += 1);
                    return;
                }
                Cone::Facing => flags.facing = true,
                Cone::Unknown => {}
            }
        }
        let w = s.xyw[2];
        let near = self.frame.near_w;
        let mut wanted = None;
        if let Some(g) = child {
            if !(w >= near && self.tf.lod.apply(s.r as u32) <= w as u64) {
                match self.nodes.group(g, level + 1) {
                    Some(records) => return self.members(records, &s, level + 1, flags),
                    None => wanted = Some(g),
                }
            }
        }
        if w < near {
            // A leaf (or a node whose children are absent) centred in front of the near plane.
            count!(self.stats.culled += 1);
            return;
        }
        let sample = self.splat(at, &s, node, level);
        if let Some(g) = wanted {
            self.nodes.absent(g, level + 1, Some(&sample));
        }
        match node.color {
            Some(rgb) if self.colored => self.sink.splat_colored(&sample, rgb),
            _ => self.sink.splat(&sample),
        }
    }

    /// The normal-cone test (QSplat §2.1) with `d = (eye − centre)·n` and `D = |eye − centre|`:
    /// away when `d < −r` and `(d + r)² > D²·sin²θ`, facing when `d > r` and `(d − r)² > D²·sin²θ`.
    #[inline]
    fn backface(&self, s: &Sphere, node: &Node) -> Cone {
        let Some(n) = normal_q14(node.normal) else {
            return Cone::Unknown;
        };
        let tf = self.tf;
        let lim = 1i32 << 24;
        // To `[−2²⁴, 2²⁴)`: one `ssat` on ARM (a valid tree's vectors are inside). Each fits an
        // `i32`, and so does `|v|₁`; only the products take 64 bits.
        let v: [i32; 3] = core::array::from_fn(|k| {
            tf.eye[k]
                .wrapping_sub(s.c[k] >> tf.bshift)
                .clamp(-lim, lim - 1)
        });
        let wide = |a: i32, b: i32| i64::from(a) * i64::from(b);
        // |v| ≤ 2²⁴ per axis and |n| ≤ 2¹⁴: `d`, `r` and `d ± r` fit an `i32` (below 2²⁷).
        let d = ((wide(v[0], n[0]) + wide(v[1], n[1]) + wide(v[2], n[2])) >> 14) as i32;
        // Radius in backface units, rounded up, plus the Q14 normal's error (|v|₁ / 2¹³).
        let slack = (v[0].abs() + v[1].abs() + v[2].abs()) >> 13;
        let r = (s.r.max(0) >> tf.bshift).saturating_add(2 + slack).min(lim);
        let e = if d < -r {
            d + r
        } else if d > r {
            d - r
        } else {
            return Cone::Unknown;
        };
        let d2 = wide(v[0], v[0]) + wide(v[1], v[1]) + wide(v[2], v[2]);
        // sin²θ ≤ ((c + 1)/4)⁴ = k/256.
        let k = CONE_K[usize::from(node.cone & 3)];
        if 256 * wide(e, e) > i64::from(k) * d2 {
            if d < 0 {
                Cone::Away
            } else {
                Cone::Facing
            }
        } else {
            Cone::Unknown
        }
    }

    /// The splat of node `node` at `at` with sphere `s`.
    #[inline]
    fn splat(&mut self, at: u32, s: &Sphere, node: &Node, level: u8) -> SampleSplat {
        let f = self.frame;
        let [x, y, w] = s.xyw;
        let (rc, shift) = recip(w as u32);
        let sh = shift - SUBPIXEL_BITS;
        let (x_q8, y_q8) = if sh > 32 {
            // `(p + 2^(sh−1)) >> sh` from the product's high word `h` alone: `h >> t` plus bit
            // `t − 1` of `h` (`t = sh − 32`), the same rounding without 64-bit shifts.
            let t = sh - 32;
            let hi = |v: i32| ((i64::from(v) * i64::from(rc)) >> 32) as i32;
            let round = |h: i32| (h >> t) + (h >> (t - 1) & 1);
            (round(hi(x)), round(hi(y)))
        } else {
            let rc64 = i64::from(rc);
            let half = 1i64 << (sh - 1);
            (
                ((i64::from(x) * rc64 + half) >> sh) as i32,
                ((i64::from(y) * rc64 + half) >> sh) as i32,
            )
        };
        // size · W in Q8, then divided by W through the reciprocal.
        let q = self.tf.size.apply(s.r.max(0) as u32);
        let size_q8 = if q >> 32 == 0 && shift >= 32 {
            // The floor of the high word's floor is the floor.
            let h = ((q * u64::from(rc)) >> 32) as u32 >> (shift - 32);
            h.min(i32::MAX as u32) as i32
        } else {
            let extra = (64 - q.leading_zeros()).saturating_sub(32);
            if shift > extra {
                (((q >> extra) * u64::from(rc)) >> (shift - extra)).min(i32::MAX as u64) as i32
            } else {
                i32::MAX
            }
        };
        let dz = (w - f.depth_w0).max(0) as u64;
        let depth = ((dz * f.depth_scale) >> 32).min(65534) as u16;
        let attr = QS_SHADE_CODE
            .get(usize::from(node.normal))
            .copied()
            .unwrap_or(0);
        count!(self.stats.splats += 1);
        count!(self.stats.max_level = self.stats.max_level.max(level));
        SampleSplat {
            x_q8,
            y_q8,
            size_q8,
            depth,
            attr,
            level,
            index: self.offset + at,
            shadowed: false,
            exact: false,
        }
    }
}

/// Outcome of a cone test.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Cone {
    Away,
    Facing,
    Unknown,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::splat::modulate;

    #[test]
    fn divisions_by_multiply_are_exact() {
        for i in 0..1u32 << 15 {
            assert_eq!(div52(i), (i / 52, i % 52), "{i}");
        }
        for r in (0..1i32 << 29)
            .step_by(997)
            .chain([0, 1, 12, 13, 14, (1 << 28) + 600])
        {
            assert_eq!(thirteenth_up(r), (r + 12) / 13, "{r}");
        }
    }

    #[test]
    #[allow(clippy::float_arithmetic)]
    fn integer_normals_match_the_f64_decoder() {
        for i in 0..16384u16 {
            let f = normal::decode(i);
            match normal_q14(i) {
                Some(q) => {
                    for k in 0..3 {
                        assert!(
                            (f64::from(q[k]) / 16384.0 - f[k]).abs() < 2e-4,
                            "code {i}: {q:?} vs {f:?}"
                        );
                    }
                }
                None => assert!(u32::from(i) < normal::NORMAL_CODES),
            }
            // The shading code is the nearest 13-bit code to the same direction.
            let code = QS_SHADE_CODE[usize::from(i)];
            assert_eq!(code, crate::normal::encode(f));
        }
    }

    #[test]
    fn modulate_by_white_is_identity_and_by_black_is_black() {
        for c in [0u16, 0xFFFF, 0xF800, 0x07E0, 0x001F, 0x1234, 0xBEEF] {
            assert_eq!(modulate(c, 0xFFFF), c);
            assert_eq!(modulate(0xFFFF, c), c);
            assert_eq!(modulate(c, 0), 0);
        }
    }
}

#[cfg(all(test, feature = "bake"))]
mod render_tests {
    #![allow(clippy::float_arithmetic)]
    use super::*;
    use crate::camera::{Camera, Placement, Sphere as BSphere, View, STANDARD_VIEWS};
    use crate::frame::RenderOptions;
    use crate::qs::table::sphere;
    use crate::qs::write::{bake_qs, tests::uv_sphere, QsBakeOptions};
    use crate::splat::NullSink;
    use std::collections::HashMap;
    use std::vec::Vec;

    /// f64 decode of every node: file offset → (centre, radius).
    fn decode_f64(file: &QSplat<'_>) -> HashMap<u32, ([f64; 3], f64)> {
        let mut out = HashMap::new();
        for tree in file.trees() {
            let c = tree.center().map(f64::from);
            let r = f64::from(tree.radius());
            let mut stack = std::vec![(tree.root_group(), c, r)];
            while let Some((g, pc, pr)) = stack.pop() {
                for (at, n, child) in tree.children(g) {
                    let e = sphere(n.sphere).unwrap();
                    let cc = [
                        pc[0] + pr * f64::from(e.a) / 13.0,
                        pc[1] + pr * f64::from(e.b) / 13.0,
                        pc[2] + pr * f64::from(e.c) / 13.0,
                    ];
                    let rr = pr * f64::from(e.s) / 13.0;
                    out.insert(tree.offset() + at, (cc, rr));
                    if let Some(g) = child {
                        stack.push((g, cc, rr));
                    }
                }
            }
        }
        out
    }

    struct Record(Vec<SampleSplat>);
    impl SplatSink for Record {
        fn splat(&mut self, s: &SampleSplat) {
            self.0.push(*s);
        }
    }

    fn render(
        file: &QSplat<'_>,
        view: View,
        cutoff: f32,
        backface: bool,
    ) -> (Vec<SampleSplat>, Stats, Camera) {
        let cam = Camera::orbit(BSphere::from_bounds(file.bounds()), view, 45.0);
        let opts = RenderOptions {
            cutoff_px: cutoff,
            backface_culling: backface,
            ..RenderOptions::default()
        };
        let frame = QsFrame::new(file, &Placement::IDENTITY, &cam, &opts).unwrap();
        let mut rec = Record(Vec::new());
        let stats = render_qs(file, &frame, &mut rec);
        (rec.0, stats, cam)
    }

    #[test]
    fn splats_land_where_the_f64_projection_puts_them() {
        let q = bake_qs(&uv_sphere(40, 80), &QsBakeOptions::default()).unwrap();
        let file = QSplat::open(&q.bytes).unwrap();
        let exact = decode_f64(&file);
        for (name, view) in STANDARD_VIEWS {
            for cutoff in [1.0, 4.0] {
                let (splats, stats, cam) = render(&file, view, cutoff, true);
                assert!(!splats.is_empty(), "{name}");
                assert_eq!(stats.splats as usize, splats.len());
                let mut worst: f64 = 0.0;
                for s in &splats {
                    let (c, r) = exact[&s.index];
                    let p = cam.project(c).expect("drawn in front of the near plane");
                    let err = (f64::from(s.x_q8) / 256.0 - p[0])
                        .abs()
                        .max((f64::from(s.y_q8) / 256.0 - p[1]).abs());
                    worst = worst.max(err);
                    let size = 2.0 * r * cam.focal_px / p[2];
                    let got = f64::from(s.size_q8) / 256.0;
                    assert!(
                        (got - size).abs() <= 0.01 * size + 0.1,
                        "{name}: size {got} vs {size}"
                    );
                    if s.level > 0 && cutoff > 1.0 && splats.len() > 1 {
                        // Interior samples are drawn only at or below the cutoff.
                        assert!(got <= f64::from(cutoff) * 1.01 + 0.1 || s.size_q8 > 0);
                    }
                }
                assert!(worst < 0.5, "{name} cutoff {cutoff}: {worst} px");
            }
        }
    }

    #[test]
    fn culling_and_cutoff_do_what_they_say() {
        let q = bake_qs(&uv_sphere(40, 80), &QsBakeOptions::default()).unwrap();
        let file = QSplat::open(&q.bytes).unwrap();
        let std_view = STANDARD_VIEWS[0].1;
        let (all, s_all, _) = render(&file, std_view, 1.0, false);
        let (culled, s_culled, _) = render(&file, std_view, 1.0, true);
        assert_eq!(s_all.backfacing, 0);
        assert!(s_culled.backfacing > 0, "{s_culled:?}");
        // About half a sphere faces away; the cones find most of it.
        assert!(
            culled.len() * 10 < all.len() * 7,
            "{} vs {}",
            culled.len(),
            all.len()
        );
        // A coarser cutoff draws fewer, larger splats from higher up.
        let (coarse, s_coarse, _) = render(&file, std_view, 48.0, true);
        assert!(coarse.len() * 4 < culled.len());
        assert!(s_coarse.max_level < s_culled.max_level);
        // Close up, the frustum culls.
        let (_, s_close, _) = render(&file, STANDARD_VIEWS[2].1, 1.0, true);
        assert!(s_close.culled > 0, "{s_close:?}");
        // Behind the model looking away: nothing.
        let cam = Camera::orbit(
            BSphere::from_bounds(file.bounds()),
            View::new(0.0, 0.0, 3.0),
            45.0,
        );
        let away = Camera {
            forward: crate::camera::scale(cam.forward, -1.0),
            right: crate::camera::scale(cam.right, -1.0),
            ..cam
        };
        let frame = QsFrame::new(
            &file,
            &Placement::IDENTITY,
            &away,
            &RenderOptions::default(),
        )
        .unwrap();
        let stats = render_qs(&file, &frame, &mut NullSink::default());
        assert_eq!((stats.splats, stats.nodes_visited), (0, 1));
    }
}
