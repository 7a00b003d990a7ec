//! The bunny under QEMU: the firmware, with the bunny baked at paper level 5 (tri-grid depth 6), or
//! baked to QSplat (`.qs`, `pocketsplat bake --format qsplat`'s defaults), linked into PSRAM, renders
//! the four standard views at each cutoff (and, a tri-grid built with shadows, with one-pass and
//! two-pass shadows) and prints one CRC per frame; the host renders the same frames through the same
//! library function (`pocketsplat_qemu::render_standard_view`) and every CRC must be identical, or the
//! test fails naming the first frame that differs. The host function itself is checked against the
//! simulator's renderer (`pocketsplat render`), which the golden images come from, for both formats.
//!
//! Needs `qemu-system-arm`, a C compiler (the instruction counter) and the bunny scan: without them
//! these tests fail under CI and are skipped, with a note, elsewhere.

use std::path::PathBuf;
use std::sync::OnceLock;

use pocketsplat_core::camera::STANDARD_VIEWS;
use pocketsplat_core::format::FileFormat;
use pocketsplat_core::qs::QSplat;
use pocketsplat_core::shadow::ShadowMode;
use pocketsplat_core::tg::{TriGrid, Verify};
use pocketsplat_qemu::{
    frame_specs_for, model_frame_specs, FrameReport, FrameSpec, Model, RenderError, Shadows,
    CUTOFFS_PX, SHADOW_MAP_SIZE,
};
use pocketsplat_sim::qsplat::render_qs_frame;
use pocketsplat_sim::render::{render_tg_frame, FrameBuffers, Settings};
use pocketsplat_tests::arm::{
    baked_bunny_as, check_memory, frame_costs, have_qemu, Counter, Firmware, FrameCost, HostFrames,
    TARGET,
};

/// The bunny baked as a tri-grid, once per test binary.
fn bunny() -> Option<PathBuf> {
    static BUNNY: OnceLock<Option<PathBuf>> = OnceLock::new();
    BUNNY
        .get_or_init(|| baked_bunny_as(FileFormat::TriGrid).unwrap())
        .clone()
}

/// The bunny baked as a QSplat file, once per test binary.
fn qs_bunny() -> Option<PathBuf> {
    static BUNNY: OnceLock<Option<PathBuf>> = OnceLock::new();
    BUNNY
        .get_or_init(|| baked_bunny_as(FileFormat::QSplat).unwrap())
        .clone()
}

/// Builds the firmware with `model` (a baked bunny, `None` when the scan is missing) and
/// `features`, boots it (counting instructions with `counter`), and compares its frames, `modes` of
/// each view at each cutoff, with the host's. Returns the frames with their instruction counts
/// when counted.
fn firmware_matches_host(
    target: &'static str,
    model: impl FnOnce() -> Option<PathBuf>,
    features: &[&str],
    modes: &'static [Shadows],
    counter: Option<&Counter>,
) -> Option<Vec<(FrameReport, Option<FrameCost>)>> {
    if !have_qemu() {
        return None;
    }
    let model = model()?;
    let fw = Firmware {
        target,
        panel: None,
        features,
        model: Some(&model),
        image: None,
    };
    let elf = fw.build().unwrap();
    let run = fw.run(&elf, counter).unwrap();
    eprintln!("{}", run.transcript());
    assert_eq!(
        run.output.status.code(),
        Some(0),
        "the firmware must exit through semihosting with status 0"
    );

    let bytes = std::fs::read(&model).unwrap();
    let host_model = Model::open(&bytes).unwrap();
    let expected: Vec<FrameSpec> = frame_specs_for(modes).collect();
    let mut host = HostFrames::new();
    let reports = pocketsplat_tests::arm::compare_frames(&run.stdout(), &expected, |spec| {
        host.render(&host_model, spec)
    })
    .unwrap_or_else(|e| panic!("{} ({}): {e:#}", fw.name(), elf.display()));

    let (memory, stack) = check_memory(&run, &elf).unwrap();
    eprintln!(
        "{}: flash {} B, RAM {} B + stack {stack} B, PSRAM {} B",
        fw.name(),
        memory.flash,
        memory.ram,
        memory.psram
    );
    assert!(memory.psram >= bytes.len() as u64, "the model is in PSRAM");

    let costs: Vec<Option<FrameCost>> = match &run.marks {
        Some(marks) => frame_costs(marks).unwrap().into_iter().map(Some).collect(),
        None => vec![None; reports.len()],
    };
    assert_eq!(
        costs.len(),
        reports.len(),
        "one counted frame per frame line"
    );
    Some(reports.into_iter().zip(costs).collect())
}

#[test]
fn bunny_views_on_arm_match_the_host() {
    let Some(frames) = firmware_matches_host(TARGET, bunny, &[], &[Shadows::Off], None) else {
        return;
    };
    assert_eq!(frames.len(), STANDARD_VIEWS.len() * CUTOFFS_PX.len());
}

/// The same on a Cortex-M0+ build (thumbv6m): no 64-bit multiply, no `CLZ`, no unaligned loads,
/// so its products come from 16-bit halves and its resident reader loads whole words from the
/// aligned model (`fixed`'s `halves`, `tg::Resident::aligned`): the same bits, frame by frame.
#[test]
fn bunny_views_on_an_m0_plus_match_the_host() {
    let Some(frames) =
        firmware_matches_host("thumbv6m-none-eabi", bunny, &[], &[Shadows::Off], None)
    else {
        return;
    };
    assert_eq!(frames.len(), STANDARD_VIEWS.len() * CUTOFFS_PX.len());
}

/// The QSplat bunny: the firmware built with `qsplat` tells the format by its magic and renders
/// every view at every cutoff, without shadows (tri-grid only), to the host's CRCs.
#[test]
fn qsplat_bunny_views_on_arm_match_the_host() {
    let Some(frames) = firmware_matches_host(TARGET, qs_bunny, &["qsplat"], &[Shadows::Off], None)
    else {
        return;
    };
    assert_eq!(frames.len(), STANDARD_VIEWS.len() * CUTOFFS_PX.len());
    for (r, _) in &frames {
        assert!(r.stats.splats > 0, "{:?} draws nothing", r.spec);
    }
}

/// The panel's size is a build-time choice (`POCKETSPLAT_PDA_PANEL`): a firmware built for a
/// landscape 320 × 240 panel draws every view at every cutoff into buffers of that size, and its
/// frames are the host's frames at that size (the projection follows the buffers).
#[test]
fn a_firmware_for_a_landscape_panel_draws_the_hosts_frames_at_that_size() {
    if !have_qemu() {
        return;
    }
    let Some(model) = bunny() else {
        return;
    };
    let fw = Firmware {
        target: TARGET,
        features: &[],
        panel: Some("320x240"),
        model: Some(&model),
        image: None,
    };
    let elf = fw.build().unwrap();
    let run = fw.run(&elf, None).unwrap();
    assert_eq!(run.output.status.code(), Some(0), "{}", run.transcript());
    let bytes = std::fs::read(&model).unwrap();
    let host_model = Model::open(&bytes).unwrap();
    let expected: Vec<FrameSpec> = frame_specs_for(&[Shadows::Off]).collect();
    let mut host = HostFrames::<320, 240>::sized();
    let reports = pocketsplat_tests::arm::compare_frames(&run.stdout(), &expected, |spec| {
        host.render(&host_model, spec)
    })
    .unwrap_or_else(|e| panic!("{} ({}): {e:#}", fw.name(), elf.display()));
    // Not the portrait frames: the same views framed for another image.
    let mut portrait = HostFrames::new();
    let differ = reports
        .iter()
        .filter(|r| portrait.render(&host_model, r.spec).unwrap().crc != r.crc)
        .count();
    assert_eq!(
        differ,
        reports.len(),
        "every landscape frame differs from the portrait one"
    );
}

/// With shadows on, every frame still matches (issue 5: "QEMU CRC equality holds with shadows on"),
/// and each shadow algorithm costs instructions over the unshadowed frame.
///
/// Not asserted, because it does not hold today: one-pass cheaper than two-pass at every frame. It is
/// at coarse cutoffs and far views (std 8 px: 19 M against 62 M instructions), where the two-pass
/// light pass walks far more nodes than the view does; at 1 px one-pass fills the map once per drawn
/// splat and costs more (std: 889 M against 645 M). `arm-bench` prints the figures.
#[test]
fn shadowed_bunny_views_on_arm_match_the_host() {
    if !have_qemu() {
        return;
    }
    let counter = Counter::build().unwrap();
    let Some(frames) =
        firmware_matches_host(TARGET, bunny, &["shadows"], &Shadows::ALL, Some(&counter))
    else {
        return;
    };
    let cost = |spec: FrameSpec| -> u64 {
        frames
            .iter()
            .find(|(r, _)| r.spec == spec)
            .and_then(|(_, c)| *c)
            .unwrap_or_else(|| panic!("no counted frame {spec:?}"))
            .frame()
    };
    for (r, c) in &frames {
        let c = c.expect("counted");
        eprintln!(
            "{:5} {} px {:8}: {:>11} instructions, {:>8} splats, {:>8} nodes",
            r.spec.view_name(),
            r.spec.cutoff_px,
            r.spec.shadows.name(),
            c.frame(),
            r.stats.splats,
            r.stats.nodes_visited
        );
    }
    for (view, (view_name, _)) in STANDARD_VIEWS.iter().enumerate() {
        for cutoff_px in CUTOFFS_PX {
            let at = |shadows| {
                cost(FrameSpec {
                    view,
                    cutoff_px,
                    shadows,
                })
            };
            let (off, one, two) = (at(Shadows::Off), at(Shadows::OnePass), at(Shadows::TwoPass));
            assert!(
                off < one && off < two,
                "{view_name} at {cutoff_px} px: off {off}, one-pass {one}, two-pass {two} instructions"
            );
        }
    }
}

/// The frames the firmware renders are the simulator's (`pocketsplat render` with default settings,
/// the golden images' renderer): same CRC, same counts, every view, cutoff and shadow mode.
#[test]
fn firmware_frames_are_the_simulators_frames() {
    let Some(model) = bunny() else {
        return;
    };
    let bytes = std::fs::read(&model).unwrap();
    let grid = TriGrid::open(&bytes, Verify::Full).unwrap();
    let mut host = HostFrames::new();
    let mut sim = FrameBuffers::new();
    for spec in frame_specs_for(&Shadows::ALL) {
        let ours = host
            .render(&pocketsplat_core::Model::TriGrid(grid), spec)
            .unwrap();
        let settings = Settings {
            view: STANDARD_VIEWS[spec.view].1,
            cutoff_px: f32::from(spec.cutoff_px),
            shadows: match spec.shadows {
                Shadows::Off => ShadowMode::Off,
                Shadows::OnePass => ShadowMode::OnePass,
                Shadows::TwoPass => ShadowMode::TwoPass,
            },
            shadow_map_size: SHADOW_MAP_SIZE,
            ..Settings::default()
        };
        let theirs = render_tg_frame(&grid, &settings, &mut sim).unwrap();
        assert_eq!(
            (ours.crc, ours.stats),
            (sim.crc(), theirs.stats),
            "{spec:?}: the firmware's frame differs from the simulator's"
        );
    }
}

/// The QSplat frames the firmware renders are `pocketsplat render`'s of the `.qs` file: same CRC,
/// same counts, every view and cutoff; asked for shadows, the frame is refused, not drawn.
#[test]
fn firmware_qsplat_frames_are_the_simulators_frames() {
    let Some(model) = qs_bunny() else {
        return;
    };
    let bytes = std::fs::read(&model).unwrap();
    let file = QSplat::open(&bytes).unwrap();
    let ours_model = Model::open(&bytes).unwrap();
    assert_eq!(ours_model.format(), FileFormat::QSplat);
    assert_eq!(ours_model.shadow_modes(), &[Shadows::Off]);
    let mut host = HostFrames::new();
    let mut sim = FrameBuffers::new();
    for spec in model_frame_specs(&ours_model) {
        let ours = host.render(&ours_model, spec).unwrap();
        let settings = Settings {
            view: STANDARD_VIEWS[spec.view].1,
            cutoff_px: f32::from(spec.cutoff_px),
            ..Settings::default()
        };
        let theirs = render_qs_frame(&file, &settings, &mut sim).unwrap();
        assert_eq!(
            (ours.crc, ours.stats),
            (sim.crc(), theirs.stats),
            "{spec:?}: the firmware's QSplat frame differs from the simulator's"
        );
    }
    let shadowed = FrameSpec {
        view: 0,
        cutoff_px: 1,
        shadows: Shadows::OnePass,
    };
    let err = host.render(&ours_model, shadowed).unwrap_err();
    assert_eq!(
        err.downcast_ref::<RenderError>(),
        Some(&RenderError::NoShadows(
            FileFormat::QSplat,
            Shadows::OnePass
        ))
    );
}
