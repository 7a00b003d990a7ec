//! The integer traversal's projected positions against an f64 projection of the same cells, over
//! thousands of random cameras including the `close` and `far` extremes, with overflow checks on
//! (the test profile keeps them): every splat within 0.5 px, none wrapped around, no panic.

use pocketsplat_core::bake::{BakeOptions, TriMesh};
use pocketsplat_core::camera::{Camera, Placement, Sphere, View, STANDARD_VIEWS};
use pocketsplat_core::raster::Kernel;
use pocketsplat_core::render::RenderOptions;
use pocketsplat_core::splat::{SampleSplat, SplatSink};
use pocketsplat_core::tg::{render_tg, TgFrame, TriGrid, Verify};
use pocketsplat_sim::report::stability::{cell_centres, child_centroids};
use pocketsplat_tests::model;

struct Check<'a> {
    centres: &'a [Vec<[f64; 3]>],
    centroids: &'a [Vec<Option<[f64; 3]>>],
    camera: Camera,
    worst: f64,
    splats: u64,
}

impl SplatSink for Check<'_> {
    fn splat(&mut self, s: &SampleSplat) {
        let (l, i) = (usize::from(s.level), s.index as usize);
        // At the cell's centre or at its children's centroid: the nearer of the two.
        let err = [Some(self.centres[l][i]), self.centroids[l][i]]
            .into_iter()
            .flatten()
            .map(|c| {
                let p = self
                    .camera
                    .project(c)
                    .expect("a drawn splat is in front of the near plane");
                (f64::from(s.x_q8) / 256.0 - p[0])
                    .abs()
                    .max((f64::from(s.y_q8) / 256.0 - p[1]).abs())
            })
            .fold(f64::INFINITY, f64::min);
        self.worst = self.worst.max(err);
        self.splats += 1;
        assert!(
            s.size_q8 > 0,
            "a splat of size {} is wrapped around",
            s.size_q8
        );
    }
}

/// xorshift, so the cameras are the same on every run.
fn rng(seed: &mut u64) -> f64 {
    *seed ^= *seed << 13;
    *seed ^= *seed >> 7;
    *seed ^= *seed << 17;
    (*seed >> 11) as f64 / (1u64 << 53) as f64
}

fn run(tg: &TriGrid<'_>, cameras: usize) -> (f64, u64) {
    let (centres, _) = cell_centres(tg);
    let centroids = child_centroids(tg, &centres);
    let sphere = Sphere::from_bounds(tg.header().bounds);
    let mut seed = 0x2545_F491_4F6C_DD1Du64;
    let (mut worst, mut splats) = (0.0f64, 0u64);
    let mut views: Vec<(View, f64, f32)> = STANDARD_VIEWS
        .iter()
        .map(|(_, v)| (*v, 45.0, 1.0))
        .collect();
    while views.len() < cameras {
        let v = View::new(
            360.0 * rng(&mut seed) - 180.0,
            180.0 * rng(&mut seed) - 90.0,
            0.5 + 30.0 * rng(&mut seed).powi(3),
        );
        views.push((
            v,
            10.0 + 150.0 * rng(&mut seed),
            (0.5 + 15.0 * rng(&mut seed)) as f32,
        ));
    }
    for (view, fov, cutoff) in views {
        let camera = Camera::orbit(sphere, view, fov);
        let opts = RenderOptions {
            cutoff_px: cutoff,
            kernel: Kernel::Square,
            backface_culling: true,
            ..RenderOptions::default()
        };
        let frame = TgFrame::new(tg.header(), &Placement::IDENTITY, &camera, &opts).expect("frame");
        let mut check = Check {
            centres: &centres,
            centroids: &centroids,
            camera,
            worst: 0.0,
            splats: 0,
        };
        render_tg(tg, &frame, &mut check);
        assert!(
            check.worst <= 0.5,
            "{view:?} fov {fov} cutoff {cutoff}: error {} px",
            check.worst
        );
        worst = worst.max(check.worst);
        splats += check.splats;
    }
    (worst, splats)
}

fn sphere_mesh(n: usize) -> TriMesh {
    let mut positions = Vec::new();
    for i in 0..=n {
        let th = std::f64::consts::PI * i as f64 / n as f64;
        for j in 0..2 * n {
            let ph = std::f64::consts::PI * j as f64 / n as f64;
            positions.push([th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin()]);
        }
    }
    let mut triangles = Vec::new();
    let v = |i: usize, j: usize| (i * 2 * n + j % (2 * n)) as u32;
    for i in 0..n {
        for j in 0..2 * n {
            triangles.push([v(i, j), v(i + 1, j), v(i + 1, j + 1)]);
            triangles.push([v(i, j), v(i + 1, j + 1), v(i, j + 1)]);
        }
    }
    TriMesh {
        positions,
        triangles,
        materials: None,
        colors: None,
    }
}

#[test]
fn sphere_projection_within_half_a_pixel_over_2000_cameras() {
    let g =
        pocketsplat_core::bake::bake_grid(&sphere_mesh(64), BakeOptions { rho: 3, depth: 5 }, None)
            .unwrap();
    let bytes = pocketsplat_core::tg::write::write_tg(&g, 12).unwrap();
    let tg = TriGrid::open(&bytes, Verify::Full).unwrap();
    let (worst, splats) = run(&tg, 2000);
    eprintln!("sphere: worst {worst:.4} px over {splats} splats");
}

#[test]
fn bunny_projection_within_half_a_pixel_octree_and_trigrid() {
    let Some(path) = model("bun_zipper.ply.gz") else {
        return;
    };
    let mesh = pocketsplat_sim::ply::load_mesh(&path).unwrap();
    for (rho, depth) in [(3, 6), (2, 9)] {
        let g = pocketsplat_core::bake::bake_grid(&mesh, BakeOptions { rho, depth }, None).unwrap();
        let bytes = pocketsplat_core::tg::write::write_tg(&g, 12).unwrap();
        let tg = TriGrid::open(&bytes, Verify::Full).unwrap();
        let (worst, splats) = run(&tg, 300);
        eprintln!("bunny rho {rho} depth {depth}: worst {worst:.4} px over {splats} splats");
    }
}

/// Every splat of a frame, as the walk handed it over.
struct Collect(Vec<SampleSplat>);

impl SplatSink for Collect {
    fn splat(&mut self, s: &SampleSplat) {
        self.0.push(*s);
    }
}

/// The resident reader that reads whole words (what an M0+ walks when the file lies at a multiple
/// of 4 bytes in memory) exists exactly for aligned bytes, and draws every splat the byte reader
/// draws, in the same order.
#[test]
fn the_word_aligned_reader_draws_what_the_byte_reader_does() {
    use pocketsplat_core::tg::{render_nodes, NoShadows, Resident};
    let g =
        pocketsplat_core::bake::bake_grid(&sphere_mesh(48), BakeOptions { rho: 3, depth: 4 }, None)
            .unwrap();
    // Unbricked, as the firmware links it (a bricked file walks through its own reader).
    let bytes = pocketsplat_core::tg::write::write_tg_as(
        &g,
        12,
        pocketsplat_core::tg::write::Layout::Unbricked,
    )
    .unwrap();
    // A copy at a multiple of 4 bytes in memory, and one a byte past it.
    let mut buf = vec![0u8; bytes.len() + 8];
    let at = buf.as_ptr().align_offset(4);
    buf[at + 1..at + 1 + bytes.len()].copy_from_slice(&bytes);
    let misaligned = TriGrid::open(&buf[at + 1..at + 1 + bytes.len()], Verify::Full).unwrap();
    assert!(Resident::new(&misaligned).aligned().is_none());
    buf[at..at + bytes.len()].copy_from_slice(&bytes);
    let tg = TriGrid::open(&buf[at..at + bytes.len()], Verify::Full).unwrap();
    let aligned = Resident::new(&tg)
        .aligned()
        .expect("an aligned file reads whole words");
    let sphere = Sphere::from_bounds(tg.header().bounds);
    for (name, view) in STANDARD_VIEWS {
        let camera = Camera::orbit(sphere, view, 45.0);
        let frame = TgFrame::new(
            tg.header(),
            &Placement::IDENTITY,
            &camera,
            &RenderOptions::default(),
        )
        .expect("frame");
        let (mut want, mut got) = (Collect(Vec::new()), Collect(Vec::new()));
        render_tg(&tg, &frame, &mut want);
        render_nodes(aligned, &frame, &mut NoShadows, &mut got);
        assert!(!want.0.is_empty(), "{name}: nothing drawn");
        assert_eq!(got.0, want.0, "{name}");
    }
}
