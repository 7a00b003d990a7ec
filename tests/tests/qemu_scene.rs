//! The Big Scene under QEMU (issue 8): `boards/sim/scenes/big.toml` baked into a pack (bunny,
//! dragon, buddha, two generated trees on a ground plane; one-pass shadows in a 512² map) and
//! linked into PSRAM; the firmware built with `scene` and `shadows` renders each of the pack's
//! named views at each cutoff of `SCENE_CUTOFFS_PX` with the pack's light and shadows, and prints
//! one CRC per frame; the host renders the same frames through the same library function
//! (`pocketsplat_qemu::scene::render_scene_view`), and every line must be identical. The host
//! function is itself checked against the simulator's `render_pack` (what `pocketsplat render
//! big.pack` draws).
//!
//! Needs `qemu-system-arm`, a C compiler (the instruction counter) and the scans: without them
//! these tests fail under CI and are skipped, with a note, elsewhere.

use std::path::PathBuf;
use std::sync::OnceLock;

use pocketsplat_core::scene::{Pack, Scene, ShadowMode};
use pocketsplat_core::tg::Verify;
use pocketsplat_qemu::scene::{scene_frame_specs, SCENE_CUTOFFS_PX};
use pocketsplat_qemu::Shadows;
use pocketsplat_sim::render::FrameBuffers;
use pocketsplat_sim::scene::render::{render_pack, PackSettings};
use pocketsplat_tests::arm::{
    baked_big_scene, check_memory, compare_scene_frames, frame_costs, have_qemu, Counter, Firmware,
    HostSceneFrames, TARGET,
};

/// The Big Scene baked, once per test binary.
fn big_pack() -> Option<PathBuf> {
    static PACK: OnceLock<Option<PathBuf>> = OnceLock::new();
    PACK.get_or_init(|| baked_big_scene(3).unwrap()).clone()
}

#[test]
fn big_scene_views_on_arm_match_the_host() {
    if !have_qemu() {
        return;
    }
    let Some(pack_path) = big_pack() else {
        return;
    };
    let counter = Counter::build().unwrap();
    let fw = Firmware {
        target: TARGET,
        panel: None,
        features: &["scene", "shadows"],
        model: Some(&pack_path),
        image: None,
    };
    let elf = fw.build().unwrap();
    let run = fw.run(&elf, Some(&counter)).unwrap();
    eprintln!("{}", run.transcript());
    assert_eq!(
        run.output.status.code(),
        Some(0),
        "the firmware must exit through semihosting with status 0"
    );

    let bytes = std::fs::read(&pack_path).unwrap();
    let scene = Scene::open(Pack::open(&bytes).unwrap(), Verify::Full).unwrap();
    assert_eq!(scene.pack().shadows(), ShadowMode::OnePass);
    let mut host = HostSceneFrames::new();
    let reports = compare_scene_frames(&run.stdout(), &scene, &mut host)
        .unwrap_or_else(|e| panic!("{} ({}): {e:#}", fw.name(), elf.display()));
    assert_eq!(
        reports.len(),
        scene.pack().view_count() * SCENE_CUTOFFS_PX.len()
    );
    for r in &reports {
        assert_eq!(r.shadows, Shadows::OnePass, "{r}");
        assert!(r.stats.splats > 0, "{r}: draws nothing");
    }

    let (memory, stack) = check_memory(&run, &elf).unwrap();
    eprintln!(
        "{}: flash {} B, RAM {} B + stack {stack} B, PSRAM {} B (pack {} B)",
        fw.name(),
        memory.flash,
        memory.ram,
        memory.psram,
        bytes.len()
    );
    assert!(memory.psram >= bytes.len() as u64, "the pack is in PSRAM");

    let costs = frame_costs(run.marks.as_ref().expect("counted")).unwrap();
    assert_eq!(
        costs.len(),
        reports.len(),
        "one counted frame per frame line"
    );
    for (r, c) in reports.iter().zip(&costs) {
        eprintln!(
            "{:5} {} px {}: {:>11} instructions (setup {}, table {}, clear {}, traverse {}), \
             {:>7} splats, {:>7} nodes",
            r.view_name,
            r.spec.cutoff_px,
            r.shadows.name(),
            c.frame(),
            c.setup,
            c.table,
            c.clear,
            c.traverse,
            r.stats.splats,
            r.stats.nodes_visited
        );
    }
}

/// The frames the firmware renders of the pack are the simulator's (`render_pack` with the pack's
/// own light, shadows and field of view at the view and cutoff): same CRC, same counts.
#[test]
fn firmware_scene_frames_are_the_simulators_frames() {
    let Some(pack_path) = big_pack() else {
        return;
    };
    let bytes = std::fs::read(&pack_path).unwrap();
    let scene = Scene::open(Pack::open(&bytes).unwrap(), Verify::Full).unwrap();
    let mut host = HostSceneFrames::new();
    let mut sim = FrameBuffers::new();
    for spec in scene_frame_specs(&scene) {
        let ours = host.render(&scene, spec).unwrap();
        let (_, view) = scene.pack().view(spec.view).unwrap();
        let settings = PackSettings {
            cutoff_px: f32::from(spec.cutoff_px),
            ..PackSettings::new(view)
        };
        let theirs = render_pack(&scene, &settings, &mut sim).unwrap();
        assert_eq!(
            (ours.crc, ours.stats),
            (sim.crc(), theirs.stats.total),
            "{ours}: the firmware's frame differs from the simulator's"
        );
    }
}

/// What coarser cutoffs cost in image quality at the `std` view, one-pass shadows: PSNR of the
/// firmware's frames at each coarser cutoff of `SCENE_CUTOFFS_PX` (2, 3, 4, 6 and 8 px) against
/// its 1 px frame (the scene has no float reference render yet, so the 1 px frame stands in for
/// it). Printed for the issue's figures; asserted only to fall as the cutoff grows.
#[test]
fn coarser_cutoffs_lose_psnr_against_1_px_at_std() {
    use pocketsplat_core::shade::rgb565_to_rgb888;
    use pocketsplat_qemu::scene::SceneFrameSpec;
    use pocketsplat_sim::metrics::psnr_rgb8;

    let Some(pack_path) = big_pack() else {
        return;
    };
    let bytes = std::fs::read(&pack_path).unwrap();
    let scene = Scene::open(Pack::open(&bytes).unwrap(), Verify::Full).unwrap();
    let std_view = (0..scene.pack().view_count())
        .find(|&v| scene.pack().view(v).is_some_and(|(n, _)| n == "std"))
        .expect("the Big Scene has a `std` view");
    let mut host = HostSceneFrames::new();
    let mut frame = |cutoff_px| -> Vec<[u8; 3]> {
        host.render(
            &scene,
            SceneFrameSpec {
                view: std_view,
                cutoff_px,
            },
        )
        .unwrap();
        host.color()
            .as_flattened()
            .iter()
            .map(|&p| rgb565_to_rgb888(p))
            .collect()
    };
    let fine = frame(1);
    let psnr: Vec<(u8, f64)> = SCENE_CUTOFFS_PX[1..]
        .iter()
        .map(|&c| (c, psnr_rgb8(&fine, &frame(c))))
        .collect();
    for (c, p) in &psnr {
        eprintln!("std {c} px one-pass: PSNR {p:.2} dB against 1 px");
    }
    for w in psnr.windows(2) {
        assert!(w[0].1 > w[1].1, "PSNR against 1 px: {psnr:?}");
    }
}

/// A pack with a QSplat object (a rotated trefoil `.qs` on a tri-grid ground, one-pass shadows):
/// the firmware built with `scene,shadows,qsplat` draws every view as the host does.
#[test]
fn a_pack_with_a_qsplat_object_on_arm_matches_the_host() {
    if !have_qemu() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let mesh = pocketsplat_sim::demo::trefoil(96, 12, 0.35);
    let qs = pocketsplat_core::qs::write::bake_qs(&mesh, &Default::default()).unwrap();
    std::fs::write(dir.path().join("knot.qs"), &qs.bytes).unwrap();
    let toml = r#"
[shadows]
mode = "one-pass"
map_size = 256

[materials.red]
color = [0.9, 0.2, 0.1]

[materials.green]
color = [0.1, 0.8, 0.2]

[[objects]]
name = "ground"
ground = { size = 4.0 }
depth = 4
material = "green"

[[objects]]
name = "knot"
file = "knot.qs"
material = "red"
height = 1.2
anchor = "base"
rotate = { yaw = 35.0, pitch = 20.0 }

[[views]]
name = "v"
az = 20.0
el = 30.0
dist = 2.2
"#;
    let scene_path = dir.path().join("qs.toml");
    std::fs::write(&scene_path, toml).unwrap();
    let baked = pocketsplat_sim::scene::bake::bake_path(&scene_path, &Default::default()).unwrap();
    let pack_path = dir.path().join("qs.pack");
    std::fs::write(&pack_path, &baked.bytes).unwrap();

    let fw = Firmware {
        target: TARGET,
        panel: None,
        features: &["scene", "shadows", "qsplat"],
        model: Some(&pack_path),
        image: None,
    };
    let elf = fw.build().unwrap();
    let run = fw.run(&elf, None).unwrap();
    eprintln!("{}", run.transcript());
    assert_eq!(run.output.status.code(), Some(0));
    let scene = Scene::open(Pack::open(&baked.bytes).unwrap(), Verify::Full).unwrap();
    assert!(scene.qsplat(1).is_some());
    let mut host = HostSceneFrames::new();
    let reports = compare_scene_frames(&run.stdout(), &scene, &mut host)
        .unwrap_or_else(|e| panic!("{} ({}): {e:#}", fw.name(), elf.display()));
    assert_eq!(reports.len(), SCENE_CUTOFFS_PX.len());
    for r in &reports {
        assert!(r.stats.splats > 0, "{r}: draws nothing");
    }
}
