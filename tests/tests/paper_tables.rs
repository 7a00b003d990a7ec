//! Issue 2's figures as assertions: the tri-grid paper's Table 4 (samples, α, file size at levels 3–5)
//! for the bunny and the dragon, and Table 3 (normal quantization error), measured on the real scans.

use pocketsplat_core::normal;
use pocketsplat_sim::report::paper::{measure, model_file, PAPER_TABLE4};
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
