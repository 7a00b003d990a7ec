use super::light::{tan_table, TAN_Q8};
use super::*;
use crate::camera::{self, Placement, Vec3};
use crate::normal::NORMALS_Q14;
use crate::tg::read::Header;

#[test]
fn light_facing_table_matches_the_formula_per_code() {
    let mut next = crate::testing::signed_uniform(0x2545_f491_u64);
    let mut light = LightFrame::UNSET;
    for _ in 0..100 {
        let v: [f64; 3] = core::array::from_fn(|_| next());
        let len = libm::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        let l = v.map(|c| libm::round(c / len * 16384.0) as i32);
        light.set_to_light(l);
        for (code, n) in NORMALS_Q14.iter().enumerate() {
            let cos =
                (i32::from(n[0]) * l[0] + i32::from(n[1]) * l[1] + i32::from(n[2]) * l[2]) >> 14;
            let want = if cos <= 0 {
                0
            } else {
                1 + (cos >> 8).min(64) as u8
            };
            assert_eq!(light.derived.facing[code], want, "code {code}, l {l:?}");
        }
    }
}

/// A depth-6 tri-grid header over the cube [-1, 1]³.
fn header() -> Header {
    Header {
        version: 1,
        flags: 0,
        rho: 3,
        depth: 6,
        normal_bits: 13,
        material_bits: 0,
        block_log2: 12,
        origin: [-1.0; 3],
        side: 2.0,
        blocks: 1,
        crc_table_blocks: 1,
        bounds: [[-1.0; 3], [1.0; 3]],
        origin64: [-1.0; 3],
        side64: 2.0,
        bounds64: [[-1.0; 3], [1.0; 3]],
        brick_level: 0,
        bricks: 0,
        brick_table: 0,
    }
}

fn ijk(s: u8) -> [i32; 3] {
    let s = i32::from(s);
    [s % 3, s / 3 % 3, s / 9]
}

#[test]
fn the_written_out_tangents_are_the_formula_s() {
    assert_eq!(TAN_Q8, tan_table());
}

#[test]
fn sub_cells_nearer_the_light_come_first_and_ties_keep_slot_order() {
    let mut lights: Vec<Vec3> = Vec::new();
    for axis in 0..3 {
        for sign in [-1.0, 1.0] {
            let mut d = [0.0; 3];
            d[axis] = sign;
            lights.push(d); // exactly along an axis: layers of 9 tie
        }
    }
    lights.extend([
        [1.0, 1.0, 0.0],  // along a face diagonal: lines of 3 tie
        [1.0, -1.0, 1.0], // along a main diagonal
        [0.3, 0.8, -0.2], // general
        [1.0, 1e-9, 0.0], // grazing, all but tied
        camera::direction(-40.0, 60.0),
    ]);
    for l in lights {
        let frame = LightFrame::new(&header(), &Placement::IDENTITY, camera::normalize(l), 64);
        let order = frame.order();
        let mut seen = [false; 27];
        for &s in &order[..27] {
            assert!(!seen[usize::from(s)], "{l:?}: slot {s} twice");
            seen[usize::from(s)] = true;
        }
        assert!(order[27..]
            .iter()
            .enumerate()
            .all(|(i, &s)| usize::from(s) == 27 + i));
        // Distance from the light grows along the order: −l·ijk never decreases (up to rounding
        // for the general directions), and equal distances (exact when l's components are 0
        // or ±1) keep slot order.
        let key = |s: u8| -> f64 {
            let c = ijk(s);
            -(l[0] * f64::from(c[0]) + l[1] * f64::from(c[1]) + l[2] * f64::from(c[2]))
        };
        let exact = l.iter().all(|c| [-1.0, 0.0, 1.0].contains(c));
        for w in order[..27].windows(2) {
            let (a, b) = (key(w[0]), key(w[1]));
            assert!(a <= b + 1e-9, "{l:?}: slot {} after {}", w[1], w[0]);
            if exact && a == b {
                assert!(w[0] < w[1], "{l:?}: tie out of slot order");
            }
        }
    }
    // Straight down: the top layer (j = 2) first, then j = 1, then j = 0, each in slot order.
    let down = LightFrame::new(&header(), &Placement::IDENTITY, [0.0, 1.0, 0.0], 64);
    let expected: [u8; 27] = core::array::from_fn(|i| {
        let layer = 2 - i / 9;
        let k = i % 9;
        (k % 3 + 3 * layer + 9 * (k / 3)) as u8
    });
    assert_eq!(down.order()[..27], expected);
}

#[test]
fn the_acne_bias_grows_with_grazing_light_and_coarse_cells_and_stops_at_one_texel() {
    for map in [64, 256, 1024] {
        let f = LightFrame::new(&header(), &Placement::IDENTITY, [0.6, 0.8, 0.0], map);
        let stop = f.stop_level();
        assert!(stop > 0 && stop <= 6, "map {map}: stop level {stop}");
        let slope = |level: usize, cos: i32| f.bias(level, 0, cos) - f.bias[level];
        for level in 0..=6 {
            // The slope term grows as the light grazes (cos → 0) and is 0 head-on.
            assert_eq!(slope(level, 16384), 0);
            assert!(slope(level, 16384 / 16) > slope(level, 16384 / 2));
            assert!(slope(level, 16384 / 2) > 0, "map {map} level {level}");
            if level >= stop {
                // At and below one texel: a one-texel cell's bias (1.5 texels of reach).
                assert_eq!(f.bias[level], f.bias[stop]);
                assert_eq!(slope(level, 4000), slope(stop, 4000));
            } else {
                // Coarser samples (multi-level rendering) get more of both terms.
                assert!(f.bias[level] > f.bias[level + 1]);
                assert!(slope(level, 4000) > slope(level + 1, 4000));
            }
        }
        // Finer maps stop deeper.
        if map == 1024 {
            let coarse = LightFrame::new(&header(), &Placement::IDENTITY, [0.6, 0.8, 0.0], 64);
            assert!(f.stop_level() > coarse.stop_level());
        }
    }
    // A point light's texels widen with distance, and so does the fine levels' slope bias.
    let p = LightFrame::point(&header(), &Placement::IDENTITY, [0.0, 6.0, 0.0], 256).unwrap();
    let w = p.root[2];
    assert!(p.bias(6, 2 * w, 4000) > p.bias(6, w, 4000));
    assert!(p.bias(1, w, 4000) > p.bias(6, w, 4000));
}

#[test]
fn a_point_light_maps_the_cube_into_the_shadow_map() {
    let h = header();
    for at in [[0.0, 6.0, 0.0], [4.0, 3.0, -2.5], [0.0, 0.0, -1.8]] {
        let f = LightFrame::point(&h, &Placement::IDENTITY, at, 256).unwrap();
        assert!(f.is_point());
        // The root's centre is on the light's axis: the middle of the map.
        let (u, v, _) = LightFrame::texel::<true>(f.root);
        assert!(
            (u - 128 * 256).abs() <= 2 && (v - 128 * 256).abs() <= 2,
            "{at:?}: {u} {v}"
        );
        // Every corner cell of the finest level lands inside the map, with W > 0.
        let mut p = f.root;
        for level in 1..=6 {
            p = f.step(p, level, 26);
        }
        let (u, v, _) = LightFrame::texel::<true>(p);
        assert!(p[2] > 0 && (0..256 * 256).contains(&u) && (0..256 * 256).contains(&v));
        // Depth grows away from the light.
        let near = f.depth16::<true>(f.root[2] - f.ext[0][2]);
        let far = f.depth16::<true>(f.root[2] + f.ext[0][2]);
        assert!(near < 1000 && far > 64000, "{near} {far}");
    }
    assert_eq!(
        LightFrame::point(&h, &Placement::IDENTITY, [0.0, 1.5, 0.0], 256).unwrap_err(),
        LightError::PointInsideGrid
    );
    assert_eq!(
        LightFrame::point(&h, &Placement::IDENTITY, [0.0, 5.0, 0.0], 0).unwrap_err(),
        LightError::MapSize(0)
    );
    assert_eq!(
        LightFrame::point(&h, &Placement::IDENTITY, [f64::NAN, 5.0, 0.0], 64).unwrap_err(),
        LightError::NotFinite
    );
}

#[test]
fn unlit_bounds_are_minus_the_sine_of_each_cone_angle_and_its_margin() {
    use crate::tg::frame::CONE_ANGLES_DEG;
    for (class, deg) in CONE_ANGLES_DEG.iter().enumerate().take(7).skip(1) {
        let t = (deg + 0.5).to_radians();
        let want = -libm::sin(t) * 268_435_456.0;
        let got = f64::from(super::hooks::UNLIT_Q28[class]);
        assert!(
            (got - want).abs() <= 1.0,
            "class {class}: {got} against {want}"
        );
    }
    assert_eq!(super::hooks::UNLIT_Q28[0], i32::MIN);
    assert_eq!(super::hooks::UNLIT_Q28[7], i32::MIN);
}

#[test]
fn every_stop_level_cell_lies_within_stop_side_and_the_map_holds_them() {
    // Lights from many directions (the axes and their diagonals among them), depth-6 grids
    // and three map sides: every cell at the stop level, reached as the walk reaches it (the
    // root plus one displacement per level), lies in texels 0..stop_side, and stop_side is
    // within the map, so the one-pass stop-level loops skip their bounds tests.
    let mut next = crate::testing::signed_uniform(0x9e37_79b9_u64);
    let mut dirs: Vec<Vec3> = vec![
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 0.0],
        [0.0, -1.0, 0.0],
        [1.0, 1.0, 1.0],
        [-1.0, 1.0, 0.0],
    ];
    dirs.extend((0..20).map(|_| [next(), next(), next()]));
    for dir in dirs {
        let dir = camera::normalize(dir);
        for map in [64, 128, 256] {
            let light = LightFrame::new(&header(), &Placement::IDENTITY, dir, map);
            let stop = light.stop_level;
            assert!(
                light.stop_side <= map,
                "{dir:?}, map {map}: {}",
                light.stop_side
            );
            let mut level_cells = vec![light.root];
            for level in 1..=stop {
                level_cells = level_cells
                    .iter()
                    .flat_map(|p| (0..27).map(move |s| (p, s)))
                    .map(|(p, s)| light.step(*p, level, s))
                    .collect();
            }
            for p in level_cells {
                let (u, v) = (p[0] >> LIGHT_FRAC, p[1] >> LIGHT_FRAC);
                assert!(
                    (0..light.stop_side as i32).contains(&u)
                        && (0..light.stop_side as i32).contains(&v),
                    "{dir:?}, map {map}: texel ({u}, {v}) outside {}",
                    light.stop_side
                );
            }
        }
    }
}
