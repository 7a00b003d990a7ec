//! Light cases: shadows under lights along each axis and at grazing angles, against f64 shadow
//! rays.

use std::fmt::Write as _;

use pocketsplat_core::bake::TriMesh;
use pocketsplat_core::camera::{self, Vec3};
use pocketsplat_core::normal::{self, NORMAL_COUNT};
use pocketsplat_core::shade::{phong, to_rgb565, ShadingTable, DEFAULT_MATERIAL};
use pocketsplat_core::shadow::ShadowMode;

use crate::report::stability::baked::Baked;
use crate::report::stability::frame::shoot_with;
use crate::report::stability::meshes::mesh;
use crate::report::stability::outcome::Outcome;
use crate::report::stability::runner::Runner;
use crate::report::stability::shot::{view_from, Shot};

/// The light test scene: a 2×2 ground square across axis `a` facing `σ·e_a`, and a 0.6×0.6 occluder
/// 0.5 above it (towards `σ·e_a`), both facing the same way.
fn shadow_scene(a: usize, sigma: f64, height: f64) -> TriMesh {
    let (u, v) = ((a + 1) % 3, (a + 2) % 3);
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for (half, off) in [(1.0, 0.0), (0.3, height)] {
        let base = positions.len() as u32;
        for (s, t) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            let mut p = [0.0; 3];
            p[u] = s * half;
            p[v] = t * half;
            p[a] = sigma * off;
            positions.push(p);
        }
        // e_u × e_v = e_a: counter-clockwise in (u, v) faces +e_a.
        if sigma > 0.0 {
            triangles.extend([[base, base + 1, base + 2], [base, base + 2, base + 3]]);
        } else {
            triangles.extend([[base, base + 2, base + 1], [base, base + 3, base + 2]]);
        }
    }
    mesh(positions, triangles)
}

/// Lights along each axis and grazing; the shading table and the shadow map.
pub(super) fn lights(r: &mut Runner) {
    // The shading table against f64 Phong for every normal code, lights along the axes and grazing.
    let lights: [(&str, Vec3); 9] = [
        ("+X", [1.0, 0.0, 0.0]),
        ("-X", [-1.0, 0.0, 0.0]),
        ("+Y", [0.0, 1.0, 0.0]),
        ("-Y", [0.0, -1.0, 0.0]),
        ("+Z", [0.0, 0.0, 1.0]),
        ("-Z", [0.0, 0.0, -1.0]),
        ("grazing the view (light ⟂ view)", [1.0, 0.0, 0.0]),
        ("behind the model (light = -view)", [0.0, 0.0, -1.0]),
        ("along the view", [0.0, 0.0, 1.0]),
    ];
    r.case(
        "shading table vs f64 Phong, lights along the axes and grazing",
        || {
            let mut table = Box::new(ShadingTable::<1>::new());
            let mut worst = 0i32;
            let views = [
                [0.0, 0.0, 1.0],
                camera::direction(30.0, 20.0),
                [0.0, 1.0, 0.0],
            ];
            for (_, l) in &lights {
                for v in views {
                    table.update(&[DEFAULT_MATERIAL], *l, v);
                    for code in 0..NORMAL_COUNT as u16 {
                        let n = normal::decode(code).map(f64::from);
                        let want = to_rgb565(phong(&DEFAULT_MATERIAL, n, *l, v));
                        let got = table.color(code);
                        for (shift, mask) in [(11, 31), (5, 63), (0, 31)] {
                            let d =
                                i32::from(want >> shift & mask) - i32::from(got >> shift & mask);
                            worst = worst.max(d.abs());
                        }
                    }
                }
            }
            let mut o = Outcome {
                worst: f64::from(worst),
                unit: "LSB",
                limit: 1.0,
                notes: format!("{} lights × 3 views × {NORMAL_COUNT} normals", lights.len()),
                ..Outcome::default()
            };
            if worst > 1 {
                o.fail(format!("a table entry is {worst} steps from Phong"));
            }
            o
        },
    );

    // Shadows from a light along each axis, and grazing: every sample whose f64 answer is sure (not
    // within a texel and a cell of the shadow's edge) must be shadowed exactly when the occluder hides
    // it from the light.
    // The map spans the root cube (side 2) across the light: at most 2√3 wide.
    let map_texel = 2.0 * 3f64.sqrt() / crate::render::DEFAULT_SHADOW_MAP_SIZE as f64;
    let mut scenes: Vec<(String, usize, f64, Vec3, f64)> = Vec::new();
    for a in 0..3 {
        for sigma in [1.0, -1.0] {
            let mut l = [0.0; 3];
            l[a] = sigma;
            let axis = ["X", "Y", "Z"][a];
            scenes.push((
                format!("light along {}{axis}", if sigma > 0.0 { "+" } else { "-" }),
                a,
                sigma,
                l,
                0.5,
            ));
        }
    }
    // Grazing: the occluder's shadow falls off the ground below ~8°, so every ground sample is lit
    // (or, at 0°, facing away: in shadow by definition). Below 7.1° the slope bias needs tangents
    // above 8 (the ground's baked normal at EL 2° is 2.8° from the light: tangent 20), which a clamp
    // at 8 left to acne on 24 416 samples until issue 18.
    for el in [10.0, 5.0, 2.0, 0.0] {
        let l = camera::direction(25.0, el);
        scenes.push((format!("grazing light, EL {el}°"), 1, 1.0, l, 0.1));
    }
    for (name, a, sigma, l, height) in scenes {
        let Some(b) = r.setup(&name, || Baked::new(&shadow_scene(a, sigma, height), 3, 5)) else {
            continue;
        };
        for mode in [ShadowMode::OnePass, ShadowMode::TwoPass] {
            let (b, name) = (&b, &name);
            r.case(format!("{name}, {mode:?}"), move || {
                let (u, v) = ((a + 1) % 3, (a + 2) % 3);
                let mut eye = [0.0; 3];
                eye[a] = sigma;
                eye[u] = 0.45;
                eye[v] = 0.3;
                let mut shot = Shot::orbit(b, view_from(eye, 2.2), 45.0);
                shot.light = (mode, l);
                let l_a = l[a] * sigma; // cosine of the light to the surfaces' normal
                                        // Facing the light or not is decided on the baked (13-bit) normal, as the reference
                                        // renderer would with that normal: near grazing, quantisation decides, not geometry.
                let mut n = [0.0; 3];
                n[a] = sigma;
                let n_q = normal::decode(normal::encode(n)).map(f64::from);
                let facing = camera::dot(n_q, l);
                let truth = move |level: usize, c: Vec3| -> Option<bool> {
                    let side = b.side[level];
                    if facing <= 0.0 {
                        return Some(true); // facing away from the light
                    }
                    if l_a <= 0.0 {
                        return Some(false); // the occluder's shadow is at infinity
                    }
                    // A cell's footprint and three texels across the light, stretched on the ground by
                    // 1 / cos of the light's angle to the normal.
                    let tol = (2.0 * side + 3.0 * map_texel) / l_a;
                    let h = c[a] * sigma;
                    if h > 0.5 * height {
                        return Some(false); // on the occluder: nothing above it
                    }
                    // Along the light to the occluder's plane.
                    let t = (height - h) / l_a;
                    let hit = [c[u] + t * l[u], c[v] + t * l[v]];
                    let m = hit[0].abs().max(hit[1].abs());
                    if m < 0.3 - tol {
                        Some(true)
                    } else if m > 0.3 + tol {
                        Some(false)
                    } else {
                        None
                    }
                };
                let m = shoot_with(&shot, Some(&truth));
                let mut o = m.outcome();
                if m.stats.splats == 0 {
                    o.fail("nothing drawn");
                }
                let _ = write!(
                    o.notes,
                    "; {} shadowed; baked normal·light {facing:.4}",
                    m.stats.shadowed
                );
                if m.checks.shadow_acne > 0 {
                    let _ = write!(
                        o.notes,
                        "; acne on {} samples changes their colour by up to {} RGB565 steps",
                        m.checks.shadow_acne, m.checks.acne_steps
                    );
                }
                o
            });
        }
    }
}
