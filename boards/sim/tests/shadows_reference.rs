//! The reference renderer's exact shadows, against answers worked out independently: the shadow of a
//! box and of a sphere on a plane under a directional light, and of a square under a point light, by
//! ray–box, ray–sphere and ray–plane geometry in this file; the hierarchy of shadow rays against a
//! brute-force test of every triangle; the disagreement metric on hand-made masks; and the `render`
//! command's shadow options.

use crate::common;
use common::pocketsplat;
use std::process::Output;

use pocketsplat_core::bake::TriMesh;
use pocketsplat_core::camera::{self, Camera, Sphere, Vec3, View, HEIGHT, WIDTH};
use pocketsplat_core::shade::{self, DEFAULT_MATERIAL};
use pocketsplat_sim::bvh::Bvh;
use pocketsplat_sim::metrics::shadow_disagreement;
use pocketsplat_sim::reference::{
    render_reference, render_reference_shadowed, RefImage, ShadowLight, ShadowRays,
};
use pocketsplat_sim::shapes::{boxmesh, merge, square, uv_sphere};

// ---- scenes ------------------------------------------------------------------------------------

fn camera_for(mesh: &TriMesh, view: View) -> Camera {
    Camera::orbit(
        Sphere::from_bounds(mesh.bounds_f32()),
        view,
        camera::DEFAULT_FOV_DEG,
    )
}

/// The model point seen at pixel `i` (from the reference's camera-space depth).
fn unproject(cam: &Camera, img: &RefImage, i: usize) -> Vec3 {
    let z = img.depth[i];
    let (px, py) = ((i % WIDTH) as f64 + 0.5, (i / WIDTH) as f64 + 0.5);
    let x = (px - WIDTH as f64 / 2.0) * z / cam.focal_px;
    let y = (HEIGHT as f64 / 2.0 - py) * z / cam.focal_px;
    camera::add(
        camera::add(cam.eye, camera::scale(cam.forward, z)),
        camera::add(camera::scale(cam.right, x), camera::scale(cam.up, y)),
    )
}

/// The answer for one pixel: `Some(unlit)`, or `None` within the margin of a boundary.
type Analytic<'a> = &'a dyn Fn(Vec3) -> Option<bool>;

/// Counts (checked pixels, unlit among them, mismatches) of the reference's mask against an answer.
fn check(cam: &Camera, img: &RefImage, answer: Analytic<'_>) -> (usize, usize, Vec<String>) {
    let (mut checked, mut unlit, mut wrong) = (0, 0, Vec::new());
    for i in 0..WIDTH * HEIGHT {
        if !img.covered[i] {
            continue;
        }
        let p = unproject(cam, img, i);
        if let Some(expected) = answer(p) {
            checked += 1;
            unlit += usize::from(expected);
            if img.shadowed[i] != expected {
                wrong.push(format!(
                    "pixel ({}, {}) at {p:?}: expected {}",
                    i % WIDTH,
                    i / WIDTH,
                    if expected { "unlit" } else { "lit" }
                ));
            }
        }
    }
    (checked, unlit, wrong)
}

/// Entry and exit of the ray `o + t·d` through the box `[lo, hi]` (`t0 > t1` when it misses).
fn ray_box(o: Vec3, d: Vec3, lo: Vec3, hi: Vec3) -> (f64, f64) {
    let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
    for k in 0..3 {
        if d[k] == 0.0 {
            if o[k] < lo[k] || o[k] > hi[k] {
                return (1.0, 0.0);
            }
            continue;
        }
        let (a, b) = ((lo[k] - o[k]) / d[k], (hi[k] - o[k]) / d[k]);
        t0 = t0.max(a.min(b));
        t1 = t1.min(a.max(b));
    }
    (t0, t1)
}

fn ray_hits_box(o: Vec3, d: Vec3, lo: Vec3, hi: Vec3) -> bool {
    let (t0, t1) = ray_box(o, d, lo, hi);
    t1 >= t0.max(0.0)
}

fn grow(lo: Vec3, hi: Vec3, by: f64) -> (Vec3, Vec3) {
    (lo.map(|c| c - by), hi.map(|c| c + by))
}

// ---- shadows with known answers -----------------------------------------------------------------

#[test]
fn a_box_over_a_plane_shadows_exactly_the_ground_the_light_cannot_see() {
    let (lo, hi) = ([-0.25, 0.3, -0.2], [0.2, 0.6, 0.25]);
    let mesh = merge(square(1.0, 0.0), &boxmesh(lo, hi));
    let bvh = Bvh::new(&mesh);
    assert_eq!(bvh.triangle_count(), 14);
    for (light_az_el, view) in [
        ((30.0, 50.0), View::new(200.0, 55.0, 2.5)),
        // Exactly along an axis: the shadow is the box's footprint, seen obliquely beside it.
        ((0.0, 90.0), View::new(200.0, 35.0, 2.2)),
        // Grazing: a long shadow.
        ((-70.0, 12.0), View::new(110.0, 50.0, 2.5)),
    ] {
        let l = camera::direction(light_az_el.0, light_az_el.1);
        let cam = camera_for(&mesh, view);
        let rays = ShadowRays {
            bvh: &bvh,
            light: ShadowLight::Directional(l),
        };
        let img = render_reference_shadowed(&mesh, &cam, &[DEFAULT_MATERIAL], l, Some(&rays));
        let answer = |p: Vec3| -> Option<bool> {
            if p[1].abs() < 1e-9 {
                // The ground: unlit when the ray towards the light passes through the box; within
                // 10⁻³ of the box's outline the answer is left open.
                let (inner, outer) = (grow(lo, hi, -1e-3), grow(lo, hi, 1e-3));
                let sure_in = ray_hits_box(p, l, inner.0, inner.1);
                let sure_out = !ray_hits_box(p, l, outer.0, outer.1);
                (sure_in || sure_out).then_some(sure_in)
            } else {
                // The box: each face is lit exactly when its outward normal faces the light
                // (nothing else is above it); edges are left open.
                let on: Vec<f64> = (0..3)
                    .flat_map(|k| {
                        [
                            ((p[k] - lo[k]).abs() < 1e-9, -l[k]),
                            ((p[k] - hi[k]).abs() < 1e-9, l[k]),
                        ]
                    })
                    .filter(|(on, _)| *on)
                    .map(|(_, c)| c)
                    .collect();
                (on.len() == 1 && on[0].abs() > 1e-9).then(|| on[0] <= 0.0)
            }
        };
        let (checked, unlit, wrong) = check(&cam, &img, &answer);
        eprintln!("{light_az_el:?}: {unlit} of {checked} unlit");
        assert!(
            checked > 20_000,
            "{light_az_el:?}: only {checked} pixels checked"
        );
        assert!(
            unlit > 1000 && checked - unlit > 1000,
            "{light_az_el:?}: {unlit} of {checked} unlit"
        );
        assert!(
            wrong.is_empty(),
            "{light_az_el:?}: {} of {checked} pixels wrong, e.g. {:?}",
            wrong.len(),
            &wrong[..wrong.len().min(5)]
        );
    }
}

#[test]
fn a_sphere_shadows_a_disc_on_the_ground_and_its_own_far_side() {
    let (c, r) = ([0.1, 0.55, -0.1], 0.3);
    let mesh = merge(square(1.2, 0.0), &uv_sphere(c, r, 48, 96));
    let bvh = Bvh::new(&mesh);
    let l = camera::direction(-40.0, 60.0);
    let cam = camera_for(&mesh, View::new(30.0, 40.0, 2.3));
    let rays = ShadowRays {
        bvh: &bvh,
        light: ShadowLight::Directional(l),
    };
    let img = render_reference_shadowed(&mesh, &cam, &[DEFAULT_MATERIAL], l, Some(&rays));
    let answer = |p: Vec3| -> Option<bool> {
        let q = camera::sub(c, p);
        if p[1].abs() < 1e-9 {
            // Distance from the centre to the ray p + t·l; the tessellated sphere is up to
            // r·(1 − cos(π/48)) ≈ 0.002·r inside the true one, so 1 % of r is left open.
            let t = camera::dot(q, l);
            let d = camera::sub(q, camera::scale(l, t));
            let dist = camera::dot(d, d).sqrt();
            (t > 0.0 && (dist - r).abs() > 0.01 * r).then_some(dist < r)
        } else {
            // On the sphere: lit exactly when the outward normal faces the light (convex, nothing
            // above it); the terminator band is left open (facets there face away while the
            // interpolated normal does not).
            let cos = -camera::dot(camera::normalize(q), l);
            (cos.abs() > 0.05).then_some(cos < 0.0)
        }
    };
    let (checked, unlit, wrong) = check(&cam, &img, &answer);
    eprintln!("{unlit} of {checked} unlit");
    assert!(
        checked > 20_000 && unlit > 1000,
        "{unlit} of {checked} unlit"
    );
    assert!(
        wrong.is_empty(),
        "{} of {checked} pixels wrong, e.g. {:?}",
        wrong.len(),
        &wrong[..wrong.len().min(5)]
    );
}

#[test]
fn a_point_light_casts_a_magnified_shadow_of_a_square() {
    let (h, y) = (0.3, 0.5);
    let mesh = merge(square(1.0, 0.0), &square(h, y));
    let bvh = Bvh::new(&mesh);
    let light = [0.1, 1.4, -0.2];
    let shade_dir = camera::normalize(light);
    let cam = camera_for(&mesh, View::new(10.0, 70.0, 2.4));
    let rays = ShadowRays {
        bvh: &bvh,
        light: ShadowLight::Point(light),
    };
    let img = render_reference_shadowed(&mesh, &cam, &[DEFAULT_MATERIAL], shade_dir, Some(&rays));
    let answer = |p: Vec3| -> Option<bool> {
        if p[1].abs() > 1e-9 {
            // The square's top faces the light (the shading direction has y > 0).
            return Some(false);
        }
        // Where the segment to the light crosses y = 0.5 (magnified 1.4 / 0.9 on the ground).
        let t = y / light[1];
        let q = camera::add(p, camera::scale(camera::sub(light, p), t));
        let inside = q[0].abs().max(q[2].abs());
        ((inside - h).abs() > 1e-3).then_some(inside < h)
    };
    let (checked, unlit, wrong) = check(&cam, &img, &answer);
    eprintln!("{unlit} of {checked} unlit");
    assert!(
        checked > 20_000 && unlit > 1000,
        "{unlit} of {checked} unlit"
    );
    assert!(
        wrong.is_empty(),
        "{} of {checked} pixels wrong, e.g. {:?}",
        wrong.len(),
        &wrong[..wrong.len().min(5)]
    );
    // The same square under a directional light from the same direction casts a smaller shadow.
    let parallel = ShadowRays {
        bvh: &bvh,
        light: ShadowLight::Directional(shade_dir),
    };
    let img2 =
        render_reference_shadowed(&mesh, &cam, &[DEFAULT_MATERIAL], shade_dir, Some(&parallel));
    assert!(
        img.shadowed_count() as f64 > 1.5 * img2.shadowed_count() as f64,
        "point {} vs directional {}",
        img.shadowed_count(),
        img2.shadowed_count()
    );
}

#[test]
fn shadow_rays_only_darken_to_the_ambient_term_and_leave_everything_else_alone() {
    let mesh = merge(square(1.0, 0.0), &uv_sphere([0.0, 0.5, 0.0], 0.3, 24, 48));
    let bvh = Bvh::new(&mesh);
    let l = camera::direction(20.0, 45.0);
    let cam = camera_for(&mesh, View::new(-30.0, 35.0, 2.5));
    let plain = render_reference(&mesh, &cam, &[DEFAULT_MATERIAL], l);
    let rays = ShadowRays {
        bvh: &bvh,
        light: ShadowLight::Directional(l),
    };
    let shadowed = render_reference_shadowed(&mesh, &cam, &[DEFAULT_MATERIAL], l, Some(&rays));
    assert_eq!(plain.covered, shadowed.covered);
    assert_eq!(plain.depth, shadowed.depth);
    let m = DEFAULT_MATERIAL;
    let ambient = m.color.map(|c| f64::from(c) * f64::from(m.ambient));
    let mut cast = 0;
    for i in 0..WIDTH * HEIGHT {
        if shadowed.shadowed[i] && !plain.shadowed[i] {
            cast += 1;
            let expected = ambient.map(|c| c.clamp(0.0, 1.0));
            for (got, want) in shadowed.rgb[i].iter().zip(expected) {
                assert!((got - want).abs() < 1e-6, "pixel {i}");
            }
        } else {
            assert_eq!(shadowed.rgb[i], plain.rgb[i], "pixel {i}");
            assert_eq!(shadowed.shadowed[i], plain.shadowed[i]);
        }
        // Without rays, "unlit" is exactly "covered and facing away": such pixels get no diffuse.
        if plain.shadowed[i] {
            assert!(plain.covered[i]);
        }
    }
    eprintln!("cast {cast}, facing away {}", plain.shadowed_count());
    assert!(cast > 1000, "{cast} pixels in cast shadow");
    assert!(plain.shadowed_count() > 100);
    // Phong of a facing-away normal is the ambient term too: shadows are one colour.
    let facing_away = shade::phong(&m, [0.0, -1.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]);
    assert_eq!(facing_away, ambient.map(|c| c.clamp(0.0, 1.0)));
}

// ---- the hierarchy ------------------------------------------------------------------------------

/// Möller–Trumbore, written again here: whether `o + t·d` meets triangle `abc` at `t_min < t < t_max`.
fn brute_hit(mesh: &TriMesh, o: Vec3, d: Vec3, t_min: f64, t_max: f64) -> bool {
    mesh.triangles.iter().any(|t| {
        let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
        let (e1, e2) = (camera::sub(b, a), camera::sub(c, a));
        let p = camera::cross(d, e2);
        let det = camera::dot(e1, p);
        if det.abs() < 1e-300 {
            return false;
        }
        let s = camera::sub(o, a);
        let u = camera::dot(s, p) / det;
        let q = camera::cross(s, e1);
        let v = camera::dot(d, q) / det;
        let t = camera::dot(e2, q) / det;
        u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > t_min && t < t_max
    })
}

/// A small deterministic generator (xorshift64*), uniform in [-1, 1).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let x = self.0.wrapping_mul(0x2545_f491_4f6c_dd1d);
        (x >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
    fn vec(&mut self) -> Vec3 {
        [self.next(), self.next(), self.next()]
    }
}

#[test]
fn the_hierarchy_answers_like_a_test_of_every_triangle() {
    // Spheres, a box, a ground plane and a cloud of random triangles of all sizes.
    let mut mesh = merge(square(1.0, -0.9), &uv_sphere([0.2, 0.1, 0.0], 0.4, 20, 40));
    mesh = merge(mesh, &uv_sphere([-0.5, -0.3, 0.4], 0.2, 12, 24));
    mesh = merge(mesh, &boxmesh([0.3, -0.8, -0.7], [0.7, -0.2, -0.3]));
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let mut soup = TriMesh::default();
    for k in 0..3000u32 {
        let c = rng.vec();
        let size = if k % 100 == 0 { 0.5 } else { 0.03 };
        soup.positions.extend([
            camera::add(c, camera::scale(rng.vec(), size)),
            camera::add(c, camera::scale(rng.vec(), size)),
            camera::add(c, camera::scale(rng.vec(), size)),
        ]);
        soup.triangles.push([3 * k, 3 * k + 1, 3 * k + 2]);
    }
    mesh = merge(mesh, &soup);
    let bvh = Bvh::new(&mesh);
    // The spheres' poles have zero-area triangles, which cannot block a ray.
    let nondegenerate = mesh
        .triangles
        .iter()
        .filter(|t| {
            let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
            let n = camera::cross(camera::sub(b, a), camera::sub(c, a));
            camera::dot(n, n) > 0.0
        })
        .count();
    assert_eq!(bvh.triangle_count(), nondegenerate);
    assert!(bvh.node_count() > 100);
    let (mut hits, mut misses) = (0, 0);
    for k in 0..4000 {
        let o = camera::scale(rng.vec(), 1.5);
        let mut d = rng.vec();
        if k % 10 == 0 {
            d[k / 10 % 3] = 0.0; // rays parallel to a plane of the boxes
        }
        let t_max = if k % 3 == 0 { f64::INFINITY } else { 0.7 };
        let expected = brute_hit(&mesh, o, d, 0.0, t_max);
        assert_eq!(
            bvh.occluded(o, d, 0.0, t_max),
            expected,
            "ray {k}: {o:?} + t·{d:?}, t < {t_max}"
        );
        if expected {
            hits += 1;
        } else {
            misses += 1;
        }
    }
    assert!(hits > 500 && misses > 500, "{hits} hits, {misses} misses");
    // Degenerate and non-finite triangles are left out.
    let mut bad = square(1.0, 0.0);
    bad.positions.push([f64::NAN, 0.0, 0.0]);
    bad.triangles.push([0, 1, 4]);
    bad.triangles.push([0, 0, 1]);
    let b = Bvh::new(&bad);
    assert_eq!(b.triangle_count(), 2);
    assert!(b.occluded([0.1, 1.0, 0.2], [0.0, -1.0, 0.0], 0.0, f64::INFINITY));
    assert!(!Bvh::new(&TriMesh::default()).occluded([0.0; 3], [1.0, 0.0, 0.0], 0.0, 1.0));
}

// ---- the metric ---------------------------------------------------------------------------------

#[test]
fn disagreement_counts_only_pixels_covered_in_both() {
    let (t, f) = (true, false);
    let a_cov = [t, t, t, t, f, t];
    let a_sh = [t, f, t, f, f, t];
    let b_cov = [t, t, t, f, t, t];
    let b_sh = [t, t, f, t, t, t];
    // Covered in both: 0, 1, 2, 5; differing among them: 1, 2.
    assert_eq!(shadow_disagreement(&a_cov, &a_sh, &b_cov, &b_sh), 0.5);
    assert_eq!(shadow_disagreement(&a_cov, &a_sh, &a_cov, &a_sh), 0.0);
    assert_eq!(shadow_disagreement(&[f, f], &[t, t], &[t, t], &[f, f]), 0.0);
}

// ---- the report ---------------------------------------------------------------------------------

#[test]
fn the_shadow_report_ranks_no_shadows_below_both_algorithms() {
    use pocketsplat_sim::render::Settings;
    use pocketsplat_sim::report::shadows::{markdown, measure};
    let mesh = merge(
        square(1.0, 0.0),
        &boxmesh([-0.25, 0.3, -0.2], [0.2, 0.6, 0.25]),
    );
    let settings = Settings {
        light_az_el: (30.0, 50.0),
        ..Settings::default()
    };
    let rows = measure("box", &mesh, 5, &settings, 1).unwrap();
    assert_eq!(rows.len(), 4);
    for r in &rows {
        let modes: Vec<&str> = r.cells.iter().map(|c| c.mode).collect();
        assert_eq!(modes, ["off", "two-pass", "one-pass"]);
        assert!(r.reference_unlit > 0.0 && r.reference_unlit < 1.0);
        for c in &r.cells {
            assert!((0.0..=1.0).contains(&c.disagreement) && c.psnr_db > 15.0 && c.ms > 0.0);
        }
    }
    // The std view sees the box's shadow: off misses it, both algorithms find it.
    let std = &rows[0];
    assert_eq!(std.view, "std");
    let (off, two, one) = (&std.cells[0], &std.cells[1], &std.cells[2]);
    assert!(off.disagreement > 2.0 * two.disagreement.max(one.disagreement));
    assert!(two.psnr_db > off.psnr_db && one.psnr_db > off.psnr_db);
    let table = markdown(&rows, 1);
    assert_eq!(table.lines().count(), 2 + 4);
    assert!(table.contains("| box (5) | std |"), "{table}");
}

// ---- the command line ---------------------------------------------------------------------------

/// The box over the plane as ASCII PLY.
fn scene_ply() -> String {
    crate::common::ply_text(&merge(
        square(1.0, 0.0),
        &boxmesh([-0.25, 0.3, -0.2], [0.2, 0.6, 0.25]),
    ))
}

fn json(out: &Output) -> serde_json::Value {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn render_casts_shadow_rays_for_a_mesh_and_takes_point_lights() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("scene.ply"), scene_ply()).unwrap();
    let render = |extra: &[&str]| {
        let mut args = vec![
            "render",
            "scene.ply",
            "-o",
            "out.png",
            "--view",
            "200,55,2.5",
            "--light",
            "30,50",
            "--stats-json",
        ];
        args.extend(extra);
        json(&pocketsplat(&args, dir.path()))
    };
    let off = render(&[]);
    assert_eq!(off["shadows"], "off");
    let on = render(&["--shadows", "two-pass"]);
    assert_eq!(on["shadows"], "ray-cast");
    assert_eq!(on["covered_pixels"], off["covered_pixels"]);
    let (n_off, n_on) = (
        off["shadowed_pixels"].as_u64().unwrap(),
        on["shadowed_pixels"].as_u64().unwrap(),
    );
    eprintln!("{n_off} → {n_on}");
    assert!(n_on > n_off + 1000, "{n_off} → {n_on}");
    // A point light straight above the box, in bounding radii.
    let point = render(&["--shadows", "two-pass", "--light-pos", "0,2.5,0"]);
    assert!(point["shadowed_pixels"].as_u64().unwrap() > n_off + 500);

    // A grid: the point light works two-pass, and is refused one-pass or inside the model, with
    // no output left behind.
    let out = pocketsplat(
        &["bake", "scene.ply", "-o", "scene.tg", "--depth", "4"],
        dir.path(),
    );
    assert!(out.status.success());
    let tg = |extra: &[&str]| {
        let mut args = vec!["render", "scene.tg", "-o", "tg.png", "--stats-json"];
        args.extend(extra);
        pocketsplat(&args, dir.path())
    };
    let two = json(&tg(&[
        "--shadows",
        "two-pass",
        "--light-pos",
        "0.5,2.5,-0.3",
    ]));
    assert!(two["shadowed"].as_u64().unwrap() > 0);
    std::fs::remove_file(dir.path().join("tg.png")).unwrap();
    for (args, message) in [
        (
            &["--shadows", "one-pass", "--light-pos", "0,2.5,0"][..],
            "one-pass shadows need a directional light",
        ),
        (
            &["--shadows", "two-pass", "--light-pos", "0,0.5,0"][..],
            "must be outside",
        ),
        (
            &["--shadows", "two-pass", "--light-pos", "0,0,0"][..],
            "centre",
        ),
        (&["--light-pos", "1,2"][..], "expected 3"),
    ] {
        let out = tg(args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?}");
        assert!(err.contains(message), "{args:?}: {err}");
        assert!(!dir.path().join("tg.png").exists(), "{args:?}");
    }
}
