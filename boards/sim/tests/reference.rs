//! The float reference renderer, the image metrics and PNG input/output, checked against
//! independent computations: point-in-triangle tests, the analytic disc of a sphere, ray casts, and
//! closed-form PSNR values.

use crate::common;
use common::model;

use pocketsplat_core::bake::TriMesh;
use pocketsplat_core::camera::{
    self, standard_view, Camera, Sphere, Vec3, View, Viewport, HEIGHT, WIDTH,
};
use pocketsplat_core::shade::{self, Material, DEFAULT_LIGHT_AZ_EL, DEFAULT_MATERIAL};
use pocketsplat_sim::image::{self, read_rgb8_png, write_rgb565_png, write_rgb8_png};
use pocketsplat_sim::metrics::{compare_frames, coverage_mismatch, psnr_rgb8};
use pocketsplat_sim::reference::{linear_to_rgb8, render_reference, vertex_normals, RefImage};

const N: usize = WIDTH * HEIGHT;

fn light() -> Vec3 {
    camera::direction(DEFAULT_LIGHT_AZ_EL.0, DEFAULT_LIGHT_AZ_EL.1)
}

fn render(mesh: &TriMesh, cam: &Camera) -> RefImage {
    render_reference(mesh, cam, &[DEFAULT_MATERIAL], light())
}

fn mesh(positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> TriMesh {
    TriMesh {
        positions,
        triangles,
        ..TriMesh::default()
    }
}

/// A camera at the origin looking down +Z with focal length 1 px: the point `screen_point(x, y)`
/// lands exactly on screen position `(x, y)` (no rounding for dyadic coordinates), so fill-rule
/// ties can be tested exactly.
fn unit_camera() -> Camera {
    Camera {
        eye: [0.0; 3],
        // The orbit camera's handedness: right = forward × up.
        right: [-1.0, 0.0, 0.0],
        up: [0.0, 1.0, 0.0],
        forward: [0.0, 0.0, 1.0],
        focal_px: 1.0,
        near: 1e-3,
        viewport: Viewport::DEFAULT,
    }
}

fn screen_point(x: f64, y: f64) -> Vec3 {
    [WIDTH as f64 / 2.0 - x, HEIGHT as f64 / 2.0 - y, 1.0]
}

fn centre(i: usize) -> [f64; 2] {
    [(i % WIDTH) as f64 + 0.5, (i / WIDTH) as f64 + 0.5]
}

/// Independent point-in-triangle test: barycentric coordinates from a 2×2 solve. `Some(inside)`
/// when the point is clearly in or out, `None` within `eps` pixels of an edge's line.
fn classify(t: [[f64; 2]; 3], p: [f64; 2], eps: f64) -> Option<bool> {
    let [a, b, c] = t;
    let (v0, v1, v2) = (
        [b[0] - a[0], b[1] - a[1]],
        [c[0] - a[0], c[1] - a[1]],
        [p[0] - a[0], p[1] - a[1]],
    );
    let den = v0[0] * v1[1] - v1[0] * v0[1];
    let u = (v2[0] * v1[1] - v1[0] * v2[1]) / den;
    let v = (v0[0] * v2[1] - v2[0] * v0[1]) / den;
    let bary = [1.0 - u - v, u, v];
    // Distance to each edge's line, in pixels: barycentric × height over that edge.
    let heights = [
        den.abs() / dist(b, c),
        den.abs() / dist(c, a),
        den.abs() / dist(a, b),
    ];
    let d: Vec<f64> = (0..3).map(|k| bary[k] * heights[k]).collect();
    if d.iter().all(|&d| d > eps) {
        Some(true)
    } else if d.iter().any(|&d| d < -eps) {
        Some(false)
    } else {
        None
    }
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt()
}

fn project2(cam: &Camera, p: Vec3) -> [f64; 2] {
    let s = cam.project(p).expect("in front of the camera");
    [s[0], s[1]]
}

#[test]
fn single_triangle_covers_exactly_the_pixel_centres_inside_it() {
    let sphere = Sphere {
        center: [0.0; 3],
        radius: 1.0,
    };
    let cam = Camera::orbit(sphere, View::new(23.0, -17.0, 2.7), 45.0);
    let triangles: [[Vec3; 3]; 4] = [
        // Front-facing, well inside the frame.
        [[-0.6, -0.7, 0.1], [0.55, -0.3, -0.2], [-0.1, 0.8, 0.3]],
        // The same, wound the other way (seen from behind).
        [[-0.6, -0.7, 0.1], [-0.1, 0.8, 0.3], [0.55, -0.3, -0.2]],
        // A sliver.
        [[-0.9, 0.0, 0.0], [0.9, 0.05, 0.0], [0.0, 0.02, 0.01]],
        // Partly off screen.
        [[-3.0, -0.5, 0.0], [0.2, -0.1, 0.4], [-0.4, 4.0, -0.3]],
    ];
    for (k, tri) in triangles.iter().enumerate() {
        let m = mesh(tri.to_vec(), vec![[0, 1, 2]]);
        let img = render(&m, &cam);
        let screen = tri.map(|p| project2(&cam, p));
        let (mut inside, mut ambiguous) = (0, 0);
        for i in 0..N {
            match classify(screen, centre(i), 1e-7) {
                Some(want) => {
                    assert_eq!(
                        img.covered[i],
                        want,
                        "triangle {k}, pixel ({}, {})",
                        i % WIDTH,
                        i / WIDTH
                    );
                    inside += usize::from(want);
                }
                None => ambiguous += 1,
            }
        }
        assert!(inside > 10, "triangle {k} covers only {inside} pixels");
        assert!(
            ambiguous < 3,
            "triangle {k}: {ambiguous} pixel centres on an edge"
        );
        // Depth is the camera-space z of the surface: check it against a ray cast at one pixel.
        let i = (0..N).find(|&i| img.covered[i]).unwrap();
        let want = ray_plane_depth(&cam, centre(i), tri);
        assert!(
            (img.depth[i] - want).abs() < 1e-9 * want,
            "{} vs {want}",
            img.depth[i]
        );
        assert!(img
            .covered
            .iter()
            .zip(&img.depth)
            .all(|(&c, d)| c == d.is_finite()));
    }
}

/// Camera-space depth where the ray through screen point `p` meets the plane of `tri`.
fn ray_plane_depth(cam: &Camera, p: [f64; 2], tri: &[Vec3; 3]) -> f64 {
    // Camera-space direction with z = 1.
    let d = [
        (p[0] - WIDTH as f64 / 2.0) / cam.focal_px,
        (HEIGHT as f64 / 2.0 - p[1]) / cam.focal_px,
        1.0,
    ];
    let t = tri.map(|v| cam.to_camera(v));
    let n = camera::cross(camera::sub(t[1], t[0]), camera::sub(t[2], t[0]));
    camera::dot(n, t[0]) / camera::dot(n, d)
}

#[test]
fn fill_rule_ties_follow_the_top_left_rule_exactly() {
    // Vertices on pixel centres: every edge runs through pixel centres.
    let (x0, y0, x1, y1) = (10.5, 10.5, 50.5, 50.5);
    let cam = unit_camera();
    for wind in [[0, 1, 2], [0, 2, 1]] {
        let m = mesh(
            vec![
                screen_point(x0, y0),
                screen_point(x1, y0),
                screen_point(x0, y1),
            ],
            vec![wind],
        );
        let img = render(&m, &cam);
        for i in 0..N {
            let [x, y] = centre(i);
            // Top edge (y = y0) and left edge (x = x0) in, the right-hand diagonal out.
            let want = x >= x0 && y >= y0 && (x - x0) + (y - y0) < x1 - x0;
            assert_eq!(
                img.covered[i], want,
                "winding {wind:?}, pixel centre ({x}, {y})"
            );
        }
    }
}

/// How many times each pixel is covered when each triangle of `m` is rendered on its own.
fn coverage_counts(m: &TriMesh, cam: &Camera) -> Vec<u32> {
    let mut counts = vec![0u32; N];
    for &t in &m.triangles {
        let single = TriMesh {
            positions: m.positions.clone(),
            triangles: vec![t],
            ..TriMesh::default()
        };
        for (c, &cov) in counts.iter_mut().zip(&render(&single, cam).covered) {
            *c += u32::from(cov);
        }
    }
    counts
}

#[test]
fn triangles_sharing_an_edge_cover_their_union_exactly_once() {
    // Exact screen coordinates: a quadrilateral split along a diagonal through pixel centres, in
    // both windings and both diagonals.
    let cam = unit_camera();
    let quad = [(12.5, 20.5), (90.5, 20.5), (90.5, 98.5), (12.5, 98.5)];
    let positions: Vec<Vec3> = quad.iter().map(|&(x, y)| screen_point(x, y)).collect();
    for tris in [
        vec![[0, 1, 2], [0, 2, 3]],
        vec![[0, 2, 1], [0, 3, 2]],
        vec![[0, 1, 3], [1, 2, 3]],
        vec![[0, 1, 3], [1, 3, 2]],
    ] {
        let m = mesh(positions.clone(), tris.clone());
        let counts = coverage_counts(&m, &cam);
        for (i, &n) in counts.iter().enumerate() {
            let [x, y] = centre(i);
            // Top and left edges in, bottom and right out.
            let want = u32::from((12.5..90.5).contains(&x) && (20.5..98.5).contains(&y));
            assert_eq!(n, want, "triangles {tris:?}, pixel centre ({x}, {y})");
        }
        // Drawn together, the union is the same.
        let together = render(&m, &cam);
        assert!(together
            .covered
            .iter()
            .zip(&counts)
            .all(|(&c, &n)| c == (n == 1)));
    }

    // A fan around a vertex on a pixel centre with spokes through other pixel centres, and a
    // jittered grid, both seen by a tilted orbit camera (inexact projection).
    let sphere = Sphere {
        center: [0.0; 3],
        radius: 1.0,
    };
    let cam = Camera::orbit(sphere, View::new(-31.0, 27.0, 2.2), 45.0);
    let mut fan = vec![[0.0, 0.0, 0.0]];
    let spokes = 13;
    for k in 0..spokes {
        let a = k as f64 * std::f64::consts::TAU / spokes as f64;
        fan.push([0.7 * a.cos(), 0.7 * a.sin(), 0.1 * (3.0 * a).sin()]);
    }
    let fan_tris: Vec<[u32; 3]> = (0..spokes)
        .map(|k| [0, 1 + k, 1 + (k + 1) % spokes])
        .collect();
    let grid = jittered_grid(9, 0.12, 0.05);
    for (name, m) in [("fan", mesh(fan, fan_tris)), ("grid", grid)] {
        let counts = coverage_counts(&m, &cam);
        assert!(
            counts.iter().all(|&n| n <= 1),
            "{name}: a pixel is drawn twice"
        );
        // Holes: a pixel centre clearly inside the projected outline must be covered. The outline
        // is the union of the triangles, so test each triangle's clear interior.
        let mut inside = 0;
        for t in &m.triangles {
            let screen = t.map(|i| project2(&cam, m.positions[i as usize]));
            for (i, &n) in counts.iter().enumerate() {
                if classify(screen, centre(i), 1e-7) == Some(true) {
                    assert_eq!(n, 1, "{name}: hole at ({}, {})", i % WIDTH, i / WIDTH);
                    inside += 1;
                }
            }
        }
        assert!(inside > 1000, "{name}: only {inside} pixels inside");
    }
}

#[test]
fn shared_edges_a_rounding_error_away_from_pixel_centres_cover_them_once() {
    // Edges in generic directions through pixel centres: rounding puts each centre a few 1e-14 px
    // to one side or the other, and the two triangles must still agree on which side that is.
    let cam = unit_camera();
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut rnd = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    for case in 0..150 {
        let c = [
            (40.0 + 160.0 * rnd()).floor() + 0.5,
            (40.0 + 240.0 * rnd()).floor() + 0.5,
        ];
        let th = std::f64::consts::TAU * rnd();
        let (d, e) = ([th.cos(), th.sin()], [-th.sin(), th.cos()]);
        let along =
            |t: f64, u: f64| screen_point(c[0] + t * d[0] + u * e[0], c[1] + t * d[1] + u * e[1]);
        let m = mesh(
            vec![
                along(-7.3, 0.0),
                along(5.9, 0.0),
                along(0.3, 6.1),
                along(-0.4, -5.7),
            ],
            vec![[0, 1, 2], [1, 0, 3]],
        );
        let counts = coverage_counts(&m, &cam);
        let i = c[1] as usize * WIDTH + c[0] as usize;
        assert_eq!(counts[i], 1, "case {case}: centre {c:?}, edge at {th} rad");
        assert!(
            counts.iter().all(|&n| n <= 1),
            "case {case}: a pixel is drawn twice"
        );
    }
}

/// A `(n+1)²`-vertex grid on the XY plane in [-0.8, 0.8]², interior vertices jittered by up to
/// `jitter` cells in X and Y and every vertex by up to `z_amp` in Z (a fixed pseudo-random
/// sequence), split into triangles along alternating diagonals.
fn jittered_grid(n: u32, jitter: f64, z_amp: f64) -> TriMesh {
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut rnd = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    let mut positions = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let interior = i > 0 && j > 0 && i < n && j < n;
            let (dx, dy) = if interior {
                (rnd() * jitter, rnd() * jitter)
            } else {
                (0.0, 0.0)
            };
            let s = 1.6 / f64::from(n);
            positions.push([
                -0.8 + f64::from(i) * s + dx * s,
                -0.8 + f64::from(j) * s + dy * s,
                z_amp * rnd(),
            ]);
        }
    }
    let mut triangles = Vec::new();
    let v = |i: u32, j: u32| j * (n + 1) + i;
    for j in 0..n {
        for i in 0..n {
            let (a, b, c, d) = (v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j + 1));
            if (i + j) % 2 == 0 {
                triangles.extend([[a, b, c], [a, c, d]]);
            } else {
                triangles.extend([[a, b, d], [b, c, d]]);
            }
        }
    }
    mesh(positions, triangles)
}

/// A unit sphere at the origin: an icosahedron subdivided `levels` times, vertices pushed onto the
/// sphere, triangles counter-clockwise seen from outside.
fn icosphere(levels: u32) -> TriMesh {
    let g = (1.0 + 5f64.sqrt()) / 2.0;
    let mut positions: Vec<Vec3> = [
        [-1.0, g, 0.0],
        [1.0, g, 0.0],
        [-1.0, -g, 0.0],
        [1.0, -g, 0.0],
        [0.0, -1.0, g],
        [0.0, 1.0, g],
        [0.0, -1.0, -g],
        [0.0, 1.0, -g],
        [g, 0.0, -1.0],
        [g, 0.0, 1.0],
        [-g, 0.0, -1.0],
        [-g, 0.0, 1.0],
    ]
    .map(camera::normalize)
    .to_vec();
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut mid = std::collections::HashMap::new();
        let mut midpoint = |a: u32, b: u32, positions: &mut Vec<Vec3>| {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                let p = camera::scale(
                    camera::add(positions[a as usize], positions[b as usize]),
                    0.5,
                );
                positions.push(camera::normalize(p));
                (positions.len() - 1) as u32
            })
        };
        let mut next = Vec::with_capacity(triangles.len() * 4);
        for [a, b, c] in triangles {
            let ab = midpoint(a, b, &mut positions);
            let bc = midpoint(b, c, &mut positions);
            let ca = midpoint(c, a, &mut positions);
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        triangles = next;
    }
    mesh(positions, triangles)
}

#[test]
fn icosphere_faces_point_outwards() {
    // The test mesh itself: counter-clockwise from outside, so the vertex normals point outwards.
    let m = icosphere(2);
    for (p, n) in m.positions.iter().zip(vertex_normals(&m)) {
        assert!(camera::dot(*p, camera::normalize(n)) > 0.99);
    }
}

#[test]
fn sphere_from_the_front_is_the_analytic_disc_with_phong_at_the_centre() {
    let m = icosphere(4);
    let sphere = Sphere::from_bounds(m.bounds_f32());
    let cam = Camera::orbit(sphere, standard_view("front").unwrap(), 45.0);
    let img = render(&m, &cam);

    // The silhouette of a sphere of radius r seen from distance d is a cone of half-angle
    // asin(r / d) around the view axis: a disc of radius f·tan(asin(r / d)) around the frame centre.
    let d = camera::dot(
        camera::sub(cam.eye, [0.0; 3]),
        camera::scale(cam.forward, -1.0),
    );
    let alpha = (1.0 / d).asin();
    let radius_px = cam.focal_px * alpha.tan();
    let (mut band, mut inside) = (0, 0);
    for i in 0..N {
        let [x, y] = centre(i);
        let rho = dist([x, y], [WIDTH as f64 / 2.0, HEIGHT as f64 / 2.0]);
        if rho < radius_px - 1.0 {
            assert!(
                img.covered[i],
                "hole at ({x}, {y}), {rho:.2} px from the centre"
            );
            inside += 1;
        } else if rho > radius_px + 1.0 {
            assert!(
                !img.covered[i],
                "stray pixel at ({x}, {y}), {rho:.2} px from the centre"
            );
        } else {
            band += 1;
        }
    }
    assert!(
        inside > 10_000 && band < 1200,
        "inside {inside}, band {band}"
    );
    assert!(
        (img.covered_count() as f64 / (std::f64::consts::PI * radius_px * radius_px) - 1.0).abs()
            < 0.02
    );

    // The centre pixel faces the camera: its colour is Phong of the sphere's normal there, which
    // is the normal towards the eye tilted by the half-pixel offset of the pixel centre from the
    // view axis (about 0.011 rad here, 0.005 in colour: more than 1/255, so it is not ignored).
    let i = HEIGHT / 2 * WIDTH + WIDTH / 2;
    let want = shade::phong(
        &DEFAULT_MATERIAL,
        sphere_normal(&cam, centre(i)).unwrap(),
        light(),
        v(&cam),
    );
    for c in 0..3 {
        assert!(
            (img.rgb[i][c] - want[c]).abs() <= 1.0 / 255.0,
            "centre {:?} vs {want:?}",
            img.rgb[i]
        );
    }
    // Everywhere but the rim, the interpolated normals of the polyhedron shade like the sphere's
    // (flat faces would be several steps off).
    let mut checked = 0;
    for i in (0..N).filter(|&i| img.covered[i]) {
        if dist(centre(i), [WIDTH as f64 / 2.0, HEIGHT as f64 / 2.0]) > 0.9 * radius_px {
            continue;
        }
        let want = shade::phong(
            &DEFAULT_MATERIAL,
            sphere_normal(&cam, centre(i)).unwrap(),
            light(),
            v(&cam),
        );
        for c in 0..3 {
            assert!(
                (img.rgb[i][c] - want[c]).abs() <= 1.5 / 255.0,
                "pixel {:?}: {:?} vs {want:?}",
                centre(i),
                img.rgb[i]
            );
        }
        checked += 1;
    }
    assert!(checked > 10_000);
    // And its depth is the distance to the front of the sphere.
    assert!(
        (img.depth[i] - (d - 1.0)).abs() < 2e-3,
        "depth {}",
        img.depth[i]
    );
    // Uncovered pixels are black.
    assert!(img
        .rgb
        .iter()
        .zip(&img.covered)
        .all(|(c, &cov)| cov || *c == [0.0; 3]));
}

/// The viewer direction of a camera.
fn v(cam: &Camera) -> Vec3 {
    camera::scale(cam.forward, -1.0)
}

/// The normal of the unit sphere at the origin where the ray through screen point `p` first meets
/// it, or `None` when it misses.
fn sphere_normal(cam: &Camera, p: [f64; 2]) -> Option<Vec3> {
    let d = camera::normalize(camera::add(
        cam.forward,
        camera::add(
            camera::scale(cam.right, (p[0] - WIDTH as f64 / 2.0) / cam.focal_px),
            camera::scale(cam.up, (HEIGHT as f64 / 2.0 - p[1]) / cam.focal_px),
        ),
    ));
    // |e + t d|² = 1 with |d| = 1.
    let b = camera::dot(cam.eye, d);
    let disc = b * b - (camera::dot(cam.eye, cam.eye) - 1.0);
    (disc >= 0.0).then(|| camera::add(cam.eye, camera::scale(d, -b - disc.sqrt())))
}

#[test]
fn camera_inside_a_sphere_sees_it_everywhere() {
    let m = icosphere(3);
    let sphere = Sphere::from_bounds(m.bounds_f32());
    // Inside the unit sphere (the bounding sphere of its box is √3 times larger).
    let view = View::new(60.0, 10.0, 0.3);
    let cam = Camera::orbit(sphere, view, 45.0);
    let img = render(&m, &cam);
    assert_eq!(
        img.covered_count(),
        N,
        "the inside of a closed sphere covers every pixel"
    );
    assert!(img.depth.iter().all(|&z| z.is_finite() && z >= cam.near));
    // Looking at the centre from 0.3 · √3 away: the far side is 1 + 0.3 · √3 away.
    let i = HEIGHT / 2 * WIDTH + WIDTH / 2;
    let want = 1.0 + view.dist * sphere.radius;
    assert!(
        (img.depth[i] - want).abs() < 1e-2,
        "{} vs {want}",
        img.depth[i]
    );
}

#[test]
fn near_plane_clips_triangles_where_the_analytic_surface_says() {
    // From the centre of a unit sphere every surface point is 1 away, so its camera depth is
    // cos θ (θ from the view axis): with near = 0.92, what lies beyond θ = acos 0.92 (the frame's
    // corners) is clipped away, and the triangles crossing the plane are cut, not dropped.
    let m = icosphere(4);
    let sphere = Sphere {
        center: [0.0; 3],
        radius: 1.0,
    };
    let mut cam = Camera::orbit(sphere, View::new(10.0, 5.0, 0.0), 45.0);
    cam.near = 0.92;
    let img = render(&m, &cam);
    let boundary_px = cam.focal_px * cam.near.acos().tan();
    let (mut clipped, mut kept) = (0, 0);
    for i in 0..N {
        let [x, y] = centre(i);
        let rho = dist([x, y], [WIDTH as f64 / 2.0, HEIGHT as f64 / 2.0]);
        if rho < boundary_px - 1.5 {
            assert!(img.covered[i], "clipped too much at ({x}, {y})");
            kept += 1;
        } else if rho > boundary_px + 1.5 {
            assert!(!img.covered[i], "not clipped at ({x}, {y})");
            clipped += 1;
        }
        if img.covered[i] {
            assert!(
                img.depth[i] >= cam.near * (1.0 - 1e-12),
                "depth {}",
                img.depth[i]
            );
        }
    }
    assert!(
        clipped > 2000 && kept > 50_000,
        "clipped {clipped}, kept {kept}"
    );
}

#[test]
fn clipped_neighbours_stay_watertight() {
    // A flat jittered grid on the XZ plane, the eye 0.03 above it looking 30° down, and the near
    // plane pushed out to 0.05: the bottom third of the frame sees the plane closer than that, so
    // the triangles there are cut by the near plane, and the cut pieces must still fit together.
    let mut grid = jittered_grid(8, 0.2, 0.0);
    for p in &mut grid.positions {
        *p = [p[0], 0.0, p[1]];
    }
    let sphere = Sphere {
        center: [0.0; 3],
        radius: 1.0,
    };
    let mut cam = Camera::orbit(sphere, View::new(0.0, 30.0, 0.06), 45.0);
    cam.near = 0.05;
    let counts = coverage_counts(&grid, &cam);
    assert!(counts.iter().all(|&n| n <= 1), "a pixel is drawn twice");
    let whole = render(&grid, &cam);
    assert!(whole
        .covered
        .iter()
        .zip(&counts)
        .all(|(&c, &n)| c == (n == 1)));
    // Ray cast: camera depth of the plane y = 0 through each pixel centre.
    let (mut kept, mut clipped) = (0, 0);
    for (i, &count) in counts.iter().enumerate() {
        let [x, y] = centre(i);
        let (dx, dy) = (
            (x - WIDTH as f64 / 2.0) / cam.focal_px,
            (HEIGHT as f64 / 2.0 - y) / cam.focal_px,
        );
        let dir = camera::add(
            cam.forward,
            camera::add(camera::scale(cam.right, dx), camera::scale(cam.up, dy)),
        );
        let depth = -cam.eye[1] / dir[1];
        let hit = camera::add(cam.eye, camera::scale(dir, depth));
        assert!(
            depth > 0.0 && hit[0].abs() < 0.7 && hit[2].abs() < 0.7,
            "ray leaves the grid"
        );
        if depth > cam.near * (1.0 + 1e-6) {
            assert_eq!(count, 1, "hole at ({x}, {y})");
            kept += 1;
        } else if depth < cam.near * (1.0 - 1e-6) {
            assert_eq!(count, 0, "not clipped at ({x}, {y})");
            clipped += 1;
        }
    }
    assert!(
        kept > N / 2 && clipped > N / 5,
        "kept {kept}, clipped {clipped}"
    );
}

#[test]
fn depth_test_keeps_the_nearest_surface_whatever_the_order() {
    let cam = unit_camera();
    let near_tri = [(20.0, 20.0), (200.0, 30.0), (40.0, 300.0)];
    let far_tri = [(10.0, 10.0), (230.0, 15.0), (100.0, 310.0)];
    let at = |(x, y): (f64, f64), z: f64| camera::scale(screen_point(x, y), z);
    let positions: Vec<Vec3> = near_tri
        .iter()
        .map(|&p| at(p, 2.0))
        .chain(far_tri.iter().map(|&p| at(p, 3.0)))
        .collect();
    let materials = [
        Material {
            color: [1.0, 0.0, 0.0],
            specular: 0.0,
            ..DEFAULT_MATERIAL
        },
        Material {
            color: [0.0, 0.0, 1.0],
            specular: 0.0,
            ..DEFAULT_MATERIAL
        },
    ];
    for tris in [vec![[0, 1, 2], [3, 4, 5]], vec![[3, 4, 5], [0, 1, 2]]] {
        let far_first = tris[0] == [3, 4, 5];
        let m = TriMesh {
            positions: positions.clone(),
            triangles: tris,
            materials: Some(if far_first { vec![1, 0] } else { vec![0, 1] }),
            colors: None,
        };
        let img = render_reference(&m, &cam, &materials, [0.0, 0.0, -1.0]);
        let near_screen = near_tri.map(|(x, y)| [x, y]);
        for i in 0..N {
            if classify(near_screen, centre(i), 1e-6) == Some(true) {
                assert!((img.depth[i] - 2.0).abs() < 1e-12);
                assert!(
                    img.rgb[i][0] > 0.0 && img.rgb[i][2] == 0.0,
                    "far surface shows"
                );
            }
        }
    }
}

#[test]
fn interpolation_is_perspective_correct() {
    // A plane receding from the camera with vertex colours: the red channel equals the model x
    // coordinate mapped to 0..1. With a purely ambient material the pixel colour is the colour, and
    // it must match the ray-plane intersection (affine screen interpolation would not).
    let flat = Material {
        color: [0.0; 3],
        ambient: 1.0,
        diffuse: 0.0,
        specular: 0.0,
        shininess: 1.0,
    };
    let positions = vec![
        [-2.0, -2.0, 1.5],
        [2.0, -2.0, 1.5],
        [2.0, 2.0, 12.0],
        [-2.0, 2.0, 12.0],
    ];
    let colors = Some(vec![[0, 0, 0], [255, 0, 0], [255, 255, 0], [0, 255, 0]]);
    let m = TriMesh {
        positions: positions.clone(),
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        materials: None,
        colors,
    };
    let cam = Camera {
        focal_px: 100.0,
        ..unit_camera()
    };
    let img = render_reference(&m, &cam, &[flat], [0.0, 0.0, -1.0]);
    let tri = [positions[0], positions[1], positions[2]];
    let mut checked = 0;
    for i in (0..N).filter(|&i| img.covered[i]) {
        let z = ray_plane_depth(&cam, centre(i), &tri);
        let [x, y] = centre(i);
        // Camera space → model: x_model = −x_cam (right is −X).
        let x_model = -(x - WIDTH as f64 / 2.0) / cam.focal_px * z;
        let y_model = (HEIGHT as f64 / 2.0 - y) / cam.focal_px * z;
        let want = [(x_model + 2.0) / 4.0, (y_model + 2.0) / 4.0];
        assert!((img.depth[i] - z).abs() < 1e-9 * z);
        for c in 0..2 {
            // Colours pass through f32 in the material.
            assert!(
                (img.rgb[i][c] - want[c]).abs() < 1e-6,
                "pixel ({x}, {y}): {:?} vs {want:?}",
                img.rgb[i]
            );
        }
        checked += 1;
    }
    assert!(checked > 5000, "{checked}");
}

#[test]
fn both_sides_are_shaded_with_the_interpolated_normal_as_is() {
    // One triangle facing +Z, seen from behind: drawn, and shaded with its +Z normal (no flip), so a
    // light from −Z leaves it at ambient.
    let m = mesh(
        vec![[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [0.0, 1.0, 0.0]],
        vec![[0, 1, 2]],
    );
    let sphere = Sphere::from_bounds(m.bounds_f32());
    let back = Camera::orbit(sphere, View::new(180.0, 0.0, 3.0), 45.0);
    let img = render_reference(&m, &back, &[DEFAULT_MATERIAL], [0.0, 0.0, -1.0]);
    let i = HEIGHT / 2 * WIDTH + WIDTH / 2;
    assert!(img.covered[i]);
    let ambient = f64::from(DEFAULT_MATERIAL.color[0] * DEFAULT_MATERIAL.ambient);
    assert!((img.rgb[i][0] - ambient).abs() < 1e-6, "{:?}", img.rgb[i]);
}

#[test]
fn degenerate_and_invisible_triangles_draw_nothing() {
    let cam = unit_camera();
    let m = mesh(
        vec![
            // Zero area (collinear).
            screen_point(10.0, 10.0),
            screen_point(100.0, 100.0),
            screen_point(50.0, 50.0),
            // Behind the camera.
            [0.0, 0.0, -1.0],
            [5.0, 0.0, -1.0],
            [0.0, 5.0, -2.0],
            // Edge-on (all on one screen line).
            [0.0, 0.0, 1.0],
            [0.0, 0.0, 5.0],
            [0.0, 0.1, 3.0],
        ],
        vec![[0, 1, 2], [3, 4, 5], [6, 7, 8]],
    );
    let img = render(&m, &cam);
    assert_eq!(img.covered_count(), 0);
    // An empty mesh renders an empty frame.
    assert_eq!(
        render(&TriMesh::default(), &cam),
        RefImage::empty(Viewport::DEFAULT)
    );
}

#[test]
fn rgb8_conversion_rounds() {
    assert_eq!(linear_to_rgb8([0.0, 1.0, 0.5]), [0, 255, 128]);
    assert_eq!(linear_to_rgb8([-0.1, 1.1, 127.4 / 255.0]), [0, 255, 127]);
}

#[test]
fn psnr_of_identical_and_known_differences() {
    let a: Vec<[u8; 3]> = (0..N)
        .map(|i| [(i % 251) as u8, (i % 7) as u8, 200])
        .collect();
    assert_eq!(psnr_rgb8(&a, &a), f64::INFINITY);
    // Every channel off by one: mse = 1.
    let b: Vec<[u8; 3]> = a.iter().map(|p| p.map(|c| c ^ 1)).collect();
    let want = 20.0 * 255f64.log10();
    assert!((psnr_rgb8(&a, &b) - want).abs() < 1e-12);
    // One channel of one pixel off by 10: mse = 100 / (3 N).
    let mut c = a.clone();
    c[1234][2] -= 10;
    let want = 10.0 * (255.0f64 * 255.0 * 3.0 * N as f64 / 100.0).log10();
    assert!((psnr_rgb8(&a, &c) - want).abs() < 1e-9);
    assert!((psnr_rgb8(&c, &a) - want).abs() < 1e-9, "symmetric");
    // Black against white: 0 dB.
    assert_eq!(psnr_rgb8(&[[0; 3]], &[[255; 3]]), 0.0);
}

#[test]
fn coverage_mismatch_counts_pixels_that_differ() {
    let a = vec![false; N];
    assert_eq!(coverage_mismatch(&a, &a), 0.0);
    let mut b = a.clone();
    for i in (0..N).step_by(4) {
        b[i] = true;
    }
    assert_eq!(coverage_mismatch(&a, &b), 0.25);
    assert_eq!(coverage_mismatch(&b, &a), 0.25);
    assert_eq!(coverage_mismatch(&[], &[]), 0.0);
}

#[test]
fn compare_frames_reports_the_first_differing_pixel_in_row_order() {
    let a = vec![0x1234u16; N];
    assert_eq!(compare_frames(&a, &a), None);
    let mut b = a.clone();
    b[200 * WIDTH + 3] = 1;
    b[5 * WIDTH + 17] = 2;
    b[5 * WIDTH + 239] = 3;
    let d = compare_frames(&a, &b).unwrap();
    assert_eq!(
        (d.x, d.y, d.expected, d.actual, d.count),
        (17, 5, 0x1234, 2, 3)
    );
    let msg = d.to_string();
    assert!(
        msg.contains("3 pixels differ") && msg.contains("(x 17, y 5)"),
        "{msg}"
    );
    // The last pixel alone.
    let mut c = a.clone();
    c[N - 1] = 0;
    let d = compare_frames(&a, &c).unwrap();
    assert_eq!((d.x, d.y, d.count), (WIDTH - 1, HEIGHT - 1, 1));
}

#[test]
#[should_panic(expected = "different sizes")]
fn compare_frames_rejects_frames_of_different_sizes() {
    compare_frames(&[0u16; 3], &[0u16; 4]);
}

#[test]
fn png_round_trip_and_errors_name_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let fb: Vec<u16> = (0..N).map(|i| (i * 2654435761 % 65536) as u16).collect();
    let path = dir.path().join("frame.png");
    write_rgb565_png(&path, Viewport::DEFAULT, &fb).unwrap();
    let img = read_rgb8_png(&path).unwrap();
    assert_eq!((img.width, img.height), (WIDTH as u32, HEIGHT as u32));
    let want: Vec<[u8; 3]> = fb.iter().map(|&p| shade::rgb565_to_rgb888(p)).collect();
    assert_eq!(compare_frames(&want, &img.pixels), None);
    assert_eq!(image::read_rgb8_frame(&path).unwrap(), want);

    let rgb: Vec<[u8; 3]> = (0..N)
        .map(|i| [(i % 256) as u8, (i / 256 % 256) as u8, 7])
        .collect();
    let path8 = dir.path().join("rgb8.png");
    write_rgb8_png(&path8, &rgb).unwrap();
    assert_eq!(read_rgb8_png(&path8).unwrap().pixels, rgb);

    // Wrong size: an error, and no file (not even a temporary one) left behind.
    let bad = dir.path().join("bad.png");
    let err = write_rgb8_png(&bad, &rgb[1..]).unwrap_err();
    assert!(format!("{err:#}").contains("bad.png"), "{err:#}");
    assert!(!bad.exists());
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);

    // A folder that does not exist.
    let missing = dir.path().join("no/such/dir/out.png");
    let err = write_rgb565_png(&missing, Viewport::DEFAULT, &fb).unwrap_err();
    assert!(format!("{err:#}").contains("out.png"), "{err:#}");

    // Not a PNG, and a PNG of the wrong size for a frame.
    let junk = dir.path().join("junk.png");
    std::fs::write(&junk, b"not a png").unwrap();
    let err = read_rgb8_png(&junk).unwrap_err();
    assert!(format!("{err:#}").contains("junk.png"), "{err:#}");
    let small = dir.path().join("small.png");
    image::write_rgb8_png_sized(&small, 2, 1, &[[1, 2, 3], [4, 5, 6]]).unwrap();
    assert_eq!(
        read_rgb8_png(&small).unwrap().pixels,
        vec![[1, 2, 3], [4, 5, 6]]
    );
    let err = image::read_rgb8_frame(&small).unwrap_err();
    assert!(format!("{err:#}").contains("small.png"), "{err:#}");
}

#[test]
fn reading_grey_and_alpha_pngs_gives_rgb() {
    for (color, data, want) in [
        (
            png::ColorType::Grayscale,
            vec![10u8, 20],
            vec![[10u8; 3], [20; 3]],
        ),
        (
            png::ColorType::Rgba,
            vec![1, 2, 3, 99, 4, 5, 6, 0],
            vec![[1, 2, 3], [4, 5, 6]],
        ),
    ] {
        let mut bytes = Vec::new();
        let mut enc = png::Encoder::new(&mut bytes, 2, 1);
        enc.set_color(color);
        enc.set_depth(png::BitDepth::Eight);
        let mut w = enc.write_header().unwrap();
        w.write_image_data(&data).unwrap();
        w.finish().unwrap();
        let img = image::decode_rgb8_png(&bytes).unwrap();
        assert_eq!(img.pixels, want, "{color:?}");
    }
}

#[test]
fn bunny_from_the_std_view() {
    let Some(path) = model("bun_zipper.ply.gz") else {
        return;
    };
    let m = pocketsplat_sim::ply::load_mesh(&path).unwrap();
    let cam = Camera::orbit(
        Sphere::from_bounds(m.bounds_f32()),
        standard_view("std").unwrap(),
        camera::DEFAULT_FOV_DEG,
    );
    let t = std::time::Instant::now();
    let img = render(&m, &cam);
    let elapsed = t.elapsed();
    let fraction = img.covered_count() as f64 / N as f64;
    eprintln!(
        "bunny, std view: {} triangles in {elapsed:?}, {:.1}% covered",
        m.triangles.len(),
        100.0 * fraction
    );
    assert!((0.05..=0.60).contains(&fraction), "coverage {fraction}");
    // Deterministic whatever the thread schedule.
    assert_eq!(render(&m, &cam), img);
    // Lit: most covered pixels are brighter than ambient alone.
    let rgb8 = img.to_rgb8();
    let lit = (0..N)
        .filter(|&i| img.covered[i] && rgb8[i][0] > 40)
        .count();
    assert!(lit * 2 > img.covered_count(), "{lit} lit pixels");
}
