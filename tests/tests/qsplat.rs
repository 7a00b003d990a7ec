//! QSplat on the Stanford bunny, baked once for this binary: the file reads back to the baked tree in
//! both byte orders; the integer traversal's splats match an f64 projection of the decoded spheres
//! over the standard views and hundreds of random cameras (overflow checks on); and the frame-rate
//! controller shared with the tri-grid holds QSplat frames through a 100× cost jump.

use std::sync::OnceLock;

use pocketsplat_core::camera::{Camera, Placement, Sphere, View, STANDARD_VIEWS};
use pocketsplat_core::lod::{FrameRateController, FINEST_CUTOFF_PX};
use pocketsplat_core::qs::table::sphere;
use pocketsplat_core::qs::write::{bake_qs, BakedQs, QsBakeOptions};
use pocketsplat_core::qs::{render_qs, ByteOrder, Group, QSplat, QsFrame, Tree};
use pocketsplat_core::render::RenderOptions;
use pocketsplat_core::splat::{NullSink, SampleSplat, SplatSink};
use pocketsplat_tests::model;

/// The bunny's bake, shared by every test of this binary.
fn bunny() -> Option<&'static BakedQs> {
    static BUNNY: OnceLock<Option<BakedQs>> = OnceLock::new();
    BUNNY
        .get_or_init(|| {
            let path = model("bun_zipper.ply.gz")?;
            let mesh = pocketsplat_sim::ply::load_mesh(&path).expect("bunny loads");
            Some(bake_qs(&mesh, &QsBakeOptions::default()).expect("bunny bakes"))
        })
        .as_ref()
}

/// (sphere, children, normal, cone) of every node, breadth-first.
fn breadth_first(tree: &Tree<'_>) -> Vec<(u16, u8, u16, u8)> {
    let mut out = Vec::new();
    let mut queue: Vec<Group> = vec![tree.root_group()];
    let mut k = 0;
    while k < queue.len() {
        for (_, n, g) in tree.children(queue[k]) {
            out.push((n.sphere, n.children, n.normal, n.cone));
            queue.extend(g);
        }
        k += 1;
    }
    out
}

/// The same file little-endian, as a QSplat 1.0 build that did not swap bytes would lay it out: the
/// header fields and the group pointers swapped, the node records as they are (always big-endian:
/// the original wrote them byte by byte).
fn to_little_endian(q: &QSplat<'_>) -> Vec<u8> {
    let mut out = q.bytes().to_vec();
    let swap = |out: &mut Vec<u8>, at: usize, n: usize| out[at..at + n].reverse();
    let mut at = 0usize;
    for f in q.fragments() {
        let len = match f {
            pocketsplat_core::qs::Fragment::Comment(text) => text.len() + 20,
            pocketsplat_core::qs::Fragment::Tree(t) => t.bytes().len(),
        };
        for k in 0..(if matches!(f, pocketsplat_core::qs::Fragment::Comment(_)) {
            3
        } else {
            8
        }) {
            swap(&mut out, at + 8 + 4 * k, 4);
        }
        if let pocketsplat_core::qs::Fragment::Tree(t) = f {
            let mut queue = vec![t.root_group()];
            let mut k = 0;
            while k < queue.len() {
                let g = queue[k];
                if let Some(p) = g.pointer {
                    swap(&mut out, at + p as usize, 4);
                }
                for (_, _, child) in t.children(g) {
                    queue.extend(child);
                }
                k += 1;
            }
        }
        at += len;
    }
    out
}

#[test]
fn the_bunny_reads_back_to_the_baked_tree_in_both_byte_orders() {
    let Some(q) = bunny() else {
        return;
    };
    let file = QSplat::open(&q.bytes).unwrap();
    assert_eq!(file.byte_order(), ByteOrder::Big);
    let mut want = Vec::new();
    let mut queue = vec![q.root];
    let mut k = 0;
    while k < queue.len() {
        for &c in &q.nodes[queue[k] as usize].children {
            let n = &q.nodes[c as usize];
            want.push((n.sphere, n.children.len() as u8, n.normal, n.cone));
            if !n.children.is_empty() {
                queue.push(c);
            }
        }
        k += 1;
    }
    let tree = file.trees().next().unwrap();
    assert_eq!(breadth_first(&tree), want);
    assert_eq!(file.counts().leaves, q.stats.leaves);

    let le = to_little_endian(&file);
    assert_ne!(le, q.bytes);
    let file_le = QSplat::open(&le).unwrap();
    assert_eq!(file_le.byte_order(), ByteOrder::Little);
    assert_eq!(file_le.counts(), file.counts());
    assert_eq!(file_le.bounds(), file.bounds());
    assert_eq!(breadth_first(&file_le.trees().next().unwrap()), want);
}

/// f64 centre and radius of every node, by file offset.
fn decode_f64(file: &QSplat<'_>) -> std::collections::HashMap<u32, ([f64; 3], f64)> {
    let mut out = std::collections::HashMap::new();
    for tree in file.trees() {
        let mut stack = vec![(
            tree.root_group(),
            tree.center().map(f64::from),
            f64::from(tree.radius()),
        )];
        while let Some((g, pc, pr)) = stack.pop() {
            for (at, n, child) in tree.children(g) {
                let e = sphere(n.sphere).unwrap();
                let c = [
                    pc[0] + pr * f64::from(e.a) / 13.0,
                    pc[1] + pr * f64::from(e.b) / 13.0,
                    pc[2] + pr * f64::from(e.c) / 13.0,
                ];
                let r = pr * f64::from(e.s) / 13.0;
                out.insert(tree.offset() + at, (c, r));
                if let Some(g) = child {
                    stack.push((g, c, r));
                }
            }
        }
    }
    out
}

struct Check<'a> {
    exact: &'a std::collections::HashMap<u32, ([f64; 3], f64)>,
    camera: Camera,
    worst_px: f64,
    worst_size: f64,
    splats: u64,
    worst: String,
}

impl SplatSink for Check<'_> {
    fn splat(&mut self, s: &SampleSplat) {
        let (c, r) = self.exact[&s.index];
        let p = self
            .camera
            .project(c)
            .expect("a drawn splat is in front of the near plane");
        let err = (f64::from(s.x_q8) / 256.0 - p[0])
            .abs()
            .max((f64::from(s.y_q8) / 256.0 - p[1]).abs());
        // Off screen (a large splat whose sphere reaches into the frustum) the error grows with the
        // distance from the image: W is a few thousand units a hair beyond the near plane, and its
        // rounding scales X/W. Measured relative to that distance there.
        let off = (p[0] - 120.0).abs().max((p[1] - 160.0).abs()) - 192.0;
        let err = if off > 0.0 {
            err * 192.0 / (192.0 + off)
        } else {
            err
        };
        if err > self.worst_px {
            self.worst = format!("{s:?} vs {p:?} (r {r})");
        }
        self.worst_px = self.worst_px.max(err);
        let size = 2.0 * r * self.camera.focal_px / p[2];
        assert!(s.size_q8 > 0, "size {} wrapped around", s.size_q8);
        if size < 1e5 {
            // Q8 sizes are rounded down: 1/256 px of slack, then relative.
            let rel = ((f64::from(s.size_q8) / 256.0 - size).abs() - 1.0 / 256.0).max(0.0) / size;
            self.worst_size = self.worst_size.max(rel);
        }
        self.splats += 1;
    }
}

#[test]
fn splats_match_an_f64_projection_over_random_cameras() {
    let Some(q) = bunny() else {
        return;
    };
    let file = QSplat::open(&q.bytes).unwrap();
    let exact = decode_f64(&file);
    let bsphere = Sphere::from_bounds(file.bounds());
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut cases: Vec<(View, f64, f32)> = STANDARD_VIEWS
        .iter()
        .flat_map(|&(_, v)| [(v, 45.0, 1.0), (v, 45.0, 4.0)])
        .collect();
    for _ in 0..300 {
        let view = View::new(
            360.0 * next() - 180.0,
            180.0 * next() - 90.0,
            // 0.05 to 50 radii, log-uniform: from deep inside to far away.
            0.05 * 1000f64.powf(next()),
        );
        let fov = 10.0 + 100.0 * next();
        let cutoff = [1.0, 1.5, 3.0, 10.0][(next() * 4.0) as usize % 4];
        cases.push((view, fov, cutoff));
    }
    let (mut worst_px, mut worst_size, mut splats) = (0.0f64, 0.0f64, 0u64);
    for (view, fov, cutoff) in cases {
        let camera = Camera::orbit(bsphere, view, fov);
        let opts = RenderOptions {
            cutoff_px: cutoff,
            ..RenderOptions::default()
        };
        let frame = QsFrame::new(&file, &Placement::IDENTITY, &camera, &opts).unwrap();
        let mut check = Check {
            exact: &exact,
            camera,
            worst_px: 0.0,
            worst_size: 0.0,
            splats: 0,
            worst: String::new(),
        };
        render_qs(&file, &frame, &mut check);
        assert!(
            check.worst_px < 0.5,
            "{view:?} fov {fov}: splat {} px from the f64 projection: {}",
            check.worst_px,
            check.worst
        );
        worst_px = worst_px.max(check.worst_px);
        worst_size = worst_size.max(check.worst_size);
        splats += check.splats;
    }
    eprintln!(
        "{splats} splats: worst position error {worst_px:.4} px, worst size error {:.3} %",
        100.0 * worst_size
    );
    assert!(splats > 100_000, "{splats}");
    assert!(worst_size < 0.01, "size error {worst_size}");
}

#[test]
fn frame_rate_control_holds_qsplat_frames_through_a_100x_cost_jump() {
    let Some(q) = bunny() else {
        return;
    };
    let file = QSplat::open(&q.bytes).unwrap();
    let camera = Camera::orbit(
        Sphere::from_bounds(file.bounds()),
        STANDARD_VIEWS[0].1,
        45.0,
    );
    let nodes = |cutoff: f32| {
        let opts = RenderOptions {
            cutoff_px: cutoff,
            ..RenderOptions::default()
        };
        let frame = QsFrame::new(&file, &Placement::IDENTITY, &camera, &opts).unwrap();
        render_qs(&file, &frame, &mut NullSink::default()).nodes_visited
    };
    // The cost of a frame: µs per node visited, a deterministic stand-in for the clock. At 4 px the
    // bunny's std view visits 30,633 nodes, at 64 px 333: just over 90× apart, so a 100× dearer
    // node can be met at the top of the cutoff range.
    let target = nodes(4.0);
    let mut c = FrameRateController::new(target, 4.0);
    let run = |c: &mut FrameRateController, us_per_node: f64, frames: usize| {
        let mut out = Vec::new();
        for _ in 0..frames {
            let t = (us_per_node * f64::from(nodes(c.cutoff()))) as u32;
            out.push(((f64::from(t) / f64::from(target)).ln(), c.cutoff()));
            c.update(t);
        }
        out
    };
    let settle = run(&mut c, 1.0, 25);
    assert!(settle[24].0.abs() < 0.25, "{settle:?}");
    // 100× the cost per node (a slower device, or 100× the detail), then back.
    for (us, what) in [(100.0, "up"), (1.0, "down")] {
        let frames = run(&mut c, us, 25);
        let ok = |(e, cut): (f64, f32)| {
            e.abs() <= 0.25 || (cut <= FINEST_CUTOFF_PX && e < 0.0) || (cut >= 64.0 && e > 0.0)
        };
        let settled = frames.iter().position(|&f| ok(f));
        assert!(
            settled.is_some_and(|k| k <= 12 && frames[k..].iter().all(|&f| ok(f))),
            "{what}: did not settle within 12 frames and stay: {frames:?}"
        );
        // No oscillation: the error does not change sign before it is within the band.
        let sign = frames[0].0.signum();
        let k = settled.unwrap();
        assert!(
            frames[..k].iter().all(|&(e, _)| e.signum() == sign),
            "{what}: oscillates: {frames:?}"
        );
        eprintln!(
            "{what}: settled in {k} frames, cutoff {:.2} → {:.2} px",
            frames[0].1, frames[24].1
        );
    }
}

/// The pixel box `[x0, y0, x1, y1]` of the splat centres of a std-view frame of `file`, framed by
/// its own bounds as every caller frames a `.qs`.
fn drawn_box(file: &QSplat<'_>) -> [f64; 4] {
    struct Extent([f64; 4]);
    impl SplatSink for Extent {
        fn splat(&mut self, s: &SampleSplat) {
            let (x, y) = (f64::from(s.x_q8) / 256.0, f64::from(s.y_q8) / 256.0);
            if (0.0..240.0).contains(&x) && (0.0..320.0).contains(&y) {
                let b = &mut self.0;
                *b = [b[0].min(x), b[1].min(y), b[2].max(x), b[3].max(y)];
            }
        }
    }
    let camera = Camera::orbit(
        Sphere::from_bounds(file.bounds()),
        STANDARD_VIEWS[0].1,
        45.0,
    );
    let frame = QsFrame::new(
        file,
        &Placement::IDENTITY,
        &camera,
        &RenderOptions::default(),
    )
    .unwrap();
    let mut e = Extent([f64::MAX, f64::MAX, f64::MIN, f64::MIN]);
    render_qs(file, &frame, &mut e);
    e.0
}

#[test]
fn a_file_without_the_bounds_comment_is_framed_like_one_with_it() {
    let Some(q) = bunny() else {
        return;
    };
    let with = QSplat::open(&q.bytes).unwrap();
    assert!(
        with.comments().count() == 1,
        "the writer puts one comment first"
    );
    // The same file as QSplat 1.0's maker writes it: no comment fragment (the first one).
    let comment_len = u32::from_be_bytes(q.bytes[8..12].try_into().unwrap()) as usize;
    let bare = &q.bytes[comment_len..];
    let without = QSplat::open(bare).unwrap();
    assert_eq!(without.comments().count(), 0);
    assert_eq!(without.counts().leaves, with.counts().leaves);
    let (a, b) = (drawn_box(&with), drawn_box(&without));
    let (wa, ha) = (a[2] - a[0], a[3] - a[1]);
    let (wb, hb) = (b[2] - b[0], b[3] - b[1]);
    eprintln!("drawn box with the comment {wa:.1} × {ha:.1} px, without {wb:.1} × {hb:.1} px");
    for (x, y, what) in [(wa, wb, "width"), (ha, hb, "height")] {
        assert!(
            (y / x - 1.0).abs() < 0.10,
            "drawn {what}: {y:.1} px without the comment against {x:.1} px with it ({a:?}, {b:?})"
        );
    }
    // The root sphere alone frames it at about half size: the old behaviour, which the test catches.
    let root = without.tree_bounds(0);
    let d = |b: [[f32; 3]; 2]| {
        (0..3)
            .map(|k| f64::from(b[1][k] - b[0][k]).powi(2))
            .sum::<f64>()
    };
    assert!(
        d(root) > 2.0 * d(with.bounds()),
        "root box {root:?}, mesh box {:?}",
        with.bounds()
    );
}
