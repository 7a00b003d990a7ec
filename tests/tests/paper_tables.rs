//! Issue 2's figures as assertions: the tri-grid paper's Table 4 (samples, α, file size at levels 3–5)
//! for the bunny and the dragon, and Table 3 (normal quantization error), measured on the real scans;
//! and issue 6's QSplat figures (storage, quantization errors, cone culling) on the same scans.

use pocketsplat_core::normal;
use pocketsplat_sim::report::paper::{measure, measure_qs, model_file, qsplat_paper, PAPER_TABLE4};
use pocketsplat_tests::model;

fn check_model(name: &str) {
    let Some(path) = model(model_file(name)) else {
        return;
    };
    let mesh = pocketsplat_sim::ply::load_mesh(&path).expect("model loads");
    let paper = PAPER_TABLE4
        .iter()
        .find(|p| p.model == name)
        .expect("paper row");
    for (k, level) in (3u8..=5).enumerate() {
        let m = measure(name, &mesh, 3, level + 1).expect("bake");
        let ratio = m.samples as f64 / paper.samples[k];
        eprintln!(
            "{name} level {level}: {} samples ({} leaves) vs {} ({ratio:.3}), alpha {:.3}, {} bytes vs {}",
            m.samples, m.leaves, paper.samples[k], m.alpha, m.file_bytes, paper.file_bytes[k]
        );
        assert!(
            (0.8..=1.2).contains(&ratio),
            "{name} level {level}: {} samples vs paper {}",
            m.samples,
            paper.samples[k]
        );
        if level == 5 {
            assert!(
                (8.5..=9.5).contains(&m.alpha),
                "{name} level 5: alpha {}",
                m.alpha
            );
            assert!(
                m.file_bytes as f64 <= paper.file_bytes[k],
                "{name} level 5: {} bytes > {}",
                m.file_bytes,
                paper.file_bytes[k]
            );
        }
    }
}

#[test]
fn table4_bunny() {
    check_model("bunny");
}

#[test]
fn table4_dragon() {
    check_model("dragon");
}

#[test]
fn table3_level5_error_at_most_0_001() {
    let (mean, max) = normal::quantization_error(5, 200_000);
    assert!(mean <= 0.001, "mean {mean}");
    eprintln!("Table 3 level 5: mean {mean:.2e}, max {max:.2e}");
}

/// The QSplat paper's figures (§3.1, §3.2), with the margins our measurements justify.
fn check_qsplat(name: &str) {
    let Some(path) = model(model_file(name)) else {
        return;
    };
    let mesh = pocketsplat_sim::ply::load_mesh(&path).expect("model loads");
    let m = measure_qs(name, &mesh).expect("bake");
    eprintln!("{name} QSplat: {m:?}");
    // Leaves are the usable vertices: the bunny has 35,947, minus unreferenced ones.
    assert!(
        m.leaves as usize <= mesh.positions.len()
            && m.leaves as usize * 100 > mesh.positions.len() * 95
    );
    // 6 bytes per leaf without colour (§3.2; Figure 6's David 2 mm works out at 6.7).
    assert!(
        (5.5..=7.0).contains(&m.bytes_per_leaf),
        "{name}: {} bytes per leaf",
        m.bytes_per_leaf
    );
    // Pointers: "approximately 8 to 10 percent" (§3.2); Figure 6's St. Matthew has 11 %, and the
    // dragon, deeper than the bunny, measures 12 %.
    let (lo, hi) = qsplat_paper::POINTER_SHARE;
    assert!(
        (lo - 0.01..=hi + 0.03).contains(&m.pointer_share),
        "{name}: pointer share {}",
        m.pointer_share
    );
    // Quantization (§3.1): 0.04 per axis and 0.15 in the radius, in parent radii; our encoder picks
    // the smallest enclosing sphere, so both come out at or below the paper's.
    assert!(
        m.position_error > 0.01 && m.position_error <= qsplat_paper::POSITION_ERROR * 1.25,
        "{name}: position error {}",
        m.position_error
    );
    assert!(
        m.radius_error > 0.02 && m.radius_error <= qsplat_paper::RADIUS_ERROR * 1.25,
        "{name}: radius error {}",
        m.radius_error
    );
    // Normals: the format's codec gives 0.015 rad on uniform directions (the paper says ≈ 0.01).
    assert!(
        (0.005..=0.02).contains(&m.normal_error),
        "{name}: normal error {}",
        m.normal_error
    );
    // Cones: the 2-bit codes cull over 90 % of what exact cones cull (§3.1).
    assert!(m.cone_culled_exact > 1000, "{name}: {m:?}");
    assert!(
        m.cone_culling > qsplat_paper::CONE_CULLING,
        "{name}: cone culling {}",
        m.cone_culling
    );
}

#[test]
fn qsplat_bunny() {
    check_qsplat("bunny");
}

#[test]
fn qsplat_dragon() {
    check_qsplat("dragon");
}
