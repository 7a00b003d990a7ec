//! The run sequences: what the firmware draws and prints, per build. A scene pack's named views, a
//! linked-in model's standard views, a model streamed from a disk image, or frame 0 of the test
//! pattern; then the memory report, which ends the run.

use cortex_m_semihosting::{debug, hprintln};
#[cfg(any(feature = "model", all(feature = "stream", not(feature = "scene"))))]
use pocketsplat_qemu::Targets;
#[cfg(not(any(feature = "model", feature = "stream")))]
use pocketsplat_qemu::{HEIGHT, WIDTH};

#[cfg(feature = "stream")]
use embedded_sdmmc::{Mode, VolumeIdx};
#[cfg(feature = "stream")]
use pocketsplat_core::stream::sdmmc::{NoClock, SdFile};
#[cfg(all(feature = "stream", not(feature = "scene")))]
use pocketsplat_qemu::stream::StreamMemory;

#[cfg(feature = "stream")]
use super::disk::{HostDisk, IMAGE};
use super::marks;
use super::memory;
use super::semihosting::exit;
#[cfg(any(feature = "model", feature = "stream"))]
use super::semihosting::fail;

/// The baked model, in PSRAM (memory.x), loaded by QEMU with the rest of the ELF.
#[cfg(feature = "model")]
pub mod model {
    /// Bytes at a multiple of 16 in memory, as the format aligns its arrays within a file: a
    /// core without unaligned loads (the M0+) then reads the grid's words whole.
    #[repr(C, align(16))]
    pub struct Aligned<T>(pub T);

    /// The `.tg` or `.qs` file named by `POCKETSPLAT_PDA_MODEL` at build time.
    #[link_section = ".psram"]
    pub static MODEL: Aligned<[u8; include_bytes!(env!("POCKETSPLAT_PDA_MODEL_FILE")).len()]> =
        Aligned(*include_bytes!(env!("POCKETSPLAT_PDA_MODEL_FILE")));
}

/// Prints the memory report and ends the run with success.
pub fn report_memory(psram_bytes: usize) -> ! {
    hprintln!("ram_bytes {}", memory::ram_bytes());
    hprintln!("stack_bytes {}", memory::stack_peak_bytes());
    hprintln!("flash_bytes {}", memory::flash_bytes());
    hprintln!("psram_bytes {}", psram_bytes);
    exit(debug::EXIT_SUCCESS)
}

/// The named views of the linked-in scene pack at each cutoff, one line per frame, after a line
/// on the scene and the RAM its frames need.
#[cfg(all(feature = "model", feature = "scene"))]
pub fn render_pack(mut targets: pocketsplat_qemu::scene::SceneTargets<'_>) {
    use pocketsplat_core::scene::{ram_budget, Pack, Scene};
    use pocketsplat_core::tg::Verify;
    use pocketsplat_qemu::scene::{render_scene_view, scene_frame_specs};

    let bytes: &[u8] = core::hint::black_box(&model::MODEL.0[..]);
    let pack = match Pack::open(bytes) {
        Ok(pack) => pack,
        Err(e) => fail(format_args!("pack: {e}")),
    };
    let scene = match Scene::open(pack, Verify::Structure) {
        Ok(scene) => scene,
        Err(e) => fail(format_args!("scene: {e}")),
    };
    let p = scene.pack();
    let shadows = if cfg!(feature = "shadows") {
        p.shadows()
    } else {
        pocketsplat_core::scene::ShadowMode::Off
    };
    hprintln!(
        "pack bytes {} objects {} slots {} views {} map {} budget_bytes {}",
        bytes.len(),
        scene.len(),
        p.slot_count(),
        p.view_count(),
        p.shadow_map_size(),
        ram_budget(p, shadows, p.shadow_map_size(), pocketsplat_qemu::PANEL).total()
    );
    // The materials' power tables, once, before the first frame (no view needs them rebuilt).
    targets
        .table
        .prepare(&scene.materials::<{ pocketsplat_core::scene::MAX_SLOTS }>());
    for spec in scene_frame_specs(&scene) {
        match render_scene_view(&scene, spec, &mut targets, marks::hit) {
            Ok(report) => hprintln!("{}", report),
            Err(e) => fail(format_args!("frame {spec:?}: {e}")),
        }
    }
}

/// The standard views of the linked-in model, one line per frame.
#[cfg(feature = "model")]
pub fn render_model(mut targets: Targets<'_>) {
    use pocketsplat_core::tg::Verify;
    use pocketsplat_qemu::{model_frame_specs, render_standard_view, Model};

    // Opaque: the bytes are a known constant, and the compiler must not fold any of the parse.
    let bytes: &[u8] = core::hint::black_box(&model::MODEL.0[..]);
    // Of a tri-grid, the header CRC and the structure; the 5 MB data CRC pass is for untrusted
    // sources. A QSplat file is checked whole (its reader has one level).
    let model = match Model::open_with(bytes, Verify::Structure) {
        Ok(model) => model,
        Err(e) => fail(format_args!("model: {e}")),
    };
    match &model {
        Model::TriGrid(grid) => {
            let h = grid.header();
            hprintln!(
                "model bytes {} rho {} depth {} samples {}",
                bytes.len(),
                h.rho,
                h.depth,
                grid.total_samples()
            );
        }
        #[cfg(feature = "qsplat")]
        Model::QSplat(file) => {
            let c = file.counts();
            hprintln!(
                "model bytes {} qsplat trees {} depth {} leaves {} interior {}",
                bytes.len(),
                c.trees,
                c.max_depth,
                c.leaves,
                c.interior
            );
        }
        #[allow(unreachable_patterns)] // a pack is drawn by `render_pack`
        _ => {}
    }
    // The material's power table, once, before the first frame (no view needs it rebuilt).
    targets
        .table
        .prepare(&[model.material(model.options().material)]);
    for spec in model_frame_specs(&model) {
        match render_standard_view(&model, spec, &mut targets, marks::hit) {
            Ok(report) => hprintln!("{}", report),
            Err(e) => fail(format_args!("frame {spec:?}: {e}")),
        }
    }
}

/// Frame 0 of the test pattern (no model linked in).
#[cfg(not(any(feature = "model", feature = "stream")))]
pub fn render_pattern(color: &mut [[u16; WIDTH]; HEIGHT]) {
    use pocketsplat_qemu::{frame_crc, render_test_frame, FrameCrc, Phase, PIXELS};
    // Opaque frame number: under LTO the whole frame is otherwise a constant the compiler may fold.
    let frame = core::hint::black_box(0);
    let fb: &mut [u16; PIXELS] = color
        .as_flattened_mut()
        .try_into()
        .expect("WIDTH × HEIGHT pixels");
    // Every phase is marked, as for a model's frame, so that an instruction counter sees the
    // same markers in every build; only the last one does any work here.
    for phase in Phase::ALL {
        if phase != Phase::End {
            marks::hit(phase);
        }
    }
    render_test_frame(frame, fb);
    marks::hit(Phase::End);
    let crc = frame_crc(fb);
    hprintln!("{}", FrameCrc { frame, crc });
}

/// The model's name in the volume's root directory (8.3): the bunny's tri-grid, or, in a build
/// with `qsplat`, a QSplat file (`pocketsplat_qemu::stream::qs_stream_frames`).
#[cfg(all(
    feature = "stream",
    not(feature = "selftest-hostile"),
    not(feature = "scene"),
    not(feature = "qsplat")
))]
const MODEL_FILE: &str = "BUNNY.TG";
#[cfg(all(
    feature = "stream",
    not(feature = "selftest-hostile"),
    not(feature = "scene"),
    feature = "qsplat"
))]
const MODEL_FILE: &str = "MODEL.QS";

/// With `selftest-hostile`: streams `H000.TG`, `H001.TG`, … of the image's first volume in turn
/// until one is missing, one line each (`pocketsplat_qemu::hostile`), then `hostile done N`.
#[cfg(all(feature = "selftest-hostile", not(feature = "scene")))]
pub fn render_stream(mut targets: Targets<'_>, mut mem: StreamMemory<'_>) {
    use pocketsplat_qemu::hostile::{file_name, hostile_run};
    each_hostile_file(file_name, |index, sd| {
        let line = hostile_run(index, sd, mem.reborrow(), &mut targets, marks::hit);
        hprintln!("{}", line);
    });
}

/// Hands the image's hostile files `name(0)`, `name(1)`, … (8.3 names in the first volume's root)
/// to `run` in turn until one is missing, then prints `hostile done N`.
#[cfg(feature = "selftest-hostile")]
fn each_hostile_file<const L: usize>(
    name: impl Fn(u32) -> [u8; L],
    mut run: impl FnMut(u32, &mut SdFile<'_, HostDisk, NoClock, 1, 1, 1>),
) {
    let disk = match HostDisk::open(IMAGE) {
        Ok(d) => d,
        Err(e) => fail(format_args!("image: {e}")),
    };
    let volumes: embedded_sdmmc::VolumeManager<_, _, 1, 1, 1> =
        embedded_sdmmc::VolumeManager::new_with_limits(disk, NoClock, 0);
    let root = match volumes
        .open_raw_volume(VolumeIdx(0))
        .and_then(|v| volumes.open_root_dir(v))
    {
        Ok(r) => r,
        Err(e) => fail(format_args!("volume: {e:?}")),
    };
    let mut index = 0;
    loop {
        let bytes = name(index);
        let Ok(name) = core::str::from_utf8(&bytes) else {
            break;
        };
        let Ok(file) = volumes.open_file_in_dir(root, name, Mode::ReadOnly) else {
            break;
        };
        run(index, &mut SdFile::new(&volumes, file));
        if let Err(e) = volumes.close_file(file) {
            fail(format_args!("{name}: {e:?}"));
        }
        index += 1;
    }
    hprintln!("hostile done {}", index);
}

/// With `selftest-hostile` and `scene`: streams `H000.PAK`, `H001.PAK`, … of the image's first
/// volume in turn until one is missing, one line each
/// (`pocketsplat_qemu::pack_stream::hostile_pack_run`), then `hostile done N`. Each run's object
/// streams are on the stack (a static holds one run's).
#[cfg(all(feature = "selftest-hostile", feature = "scene"))]
pub fn render_hostile_packs(
    buffers: &mut pocketsplat_qemu::pack_stream::PackBuffers,
    tables: &mut pocketsplat_qemu::pack_stream::PackTables,
    #[cfg(feature = "shadows")] light: &mut pocketsplat_core::shadow::LightFrame,
) {
    use pocketsplat_qemu::pack_stream::{
        hostile_pack_name, hostile_pack_run, pack_memory, PackObjects,
    };
    each_hostile_file(hostile_pack_name, |index, sd| {
        // Not dropped: the streams borrow the memory they sit beside for as long as they live
        // (and own nothing that needs dropping).
        let mut objects = core::mem::ManuallyDrop::new(PackObjects::new());
        let (mut targets, mem) = pack_memory(
            &mut *buffers,
            &mut *tables,
            &mut objects,
            #[cfg(feature = "shadows")]
            &mut *light,
        );
        hprintln!(
            "{}",
            hostile_pack_run(index, sd, mem, &mut targets, marks::hit)
        );
    });
}

/// Opens the image, its first FAT volume and `name` in its root, printing `image blocks N` and
/// `<what> file NAME bytes N`, hands the file to `run`, then prints `sectors_read N`; any failure to
/// get as far as `run` ends the run with a message.
#[cfg(all(feature = "stream", not(feature = "selftest-hostile")))]
fn with_image_file(
    what: &str,
    name: &str,
    run: impl FnOnce(SdFile<'_, HostDisk, NoClock, 1, 1, 1>),
) {
    let disk = match HostDisk::open(IMAGE) {
        Ok(d) => d,
        Err(e) => fail(format_args!("image: {e}")),
    };
    hprintln!("image blocks {}", disk.blocks);
    let volumes: embedded_sdmmc::VolumeManager<_, _, 1, 1, 1> =
        embedded_sdmmc::VolumeManager::new_with_limits(disk, NoClock, 0);
    let file = volumes
        .open_raw_volume(VolumeIdx(0))
        .and_then(|v| volumes.open_root_dir(v))
        .and_then(|root| volumes.open_file_in_dir(root, name, Mode::ReadOnly));
    let file = match file {
        Ok(f) => f,
        Err(e) => fail(format_args!("{name}: {e:?}")),
    };
    let sd = SdFile::new(&volumes, file);
    match sd.len() {
        Ok(n) => hprintln!("{} file {} bytes {}", what, name, n),
        Err(e) => fail(format_args!("{name}: {e:?}")),
    }
    run(sd);
    hprintln!("sectors_read {}", volumes.device(|d| d.reads.get()));
}

/// Opens the image, its first FAT volume and `SCENE.PAK`, and draws the pack's first view refined
/// in passes band by band, one line per pass (`pocketsplat_qemu::pack_stream`); any failure to
/// get that far ends the run with a message.
#[cfg(all(
    feature = "stream",
    feature = "scene",
    not(feature = "selftest-hostile")
))]
pub fn render_pack_stream(
    mut targets: pocketsplat_qemu::scene::SceneTargets<
        '_,
        { pocketsplat_qemu::pack_stream::PACK_BAND_ROWS },
    >,
    mem: pocketsplat_qemu::pack_stream::PackMemory<'_>,
) {
    use pocketsplat_qemu::pack_stream::{pack_stream_frames, PACK_FILE};
    with_image_file("pack", PACK_FILE, |mut sd| {
        let report = |f: &pocketsplat_qemu::stream::StreamFrame| hprintln!("{}", f);
        match pack_stream_frames(&mut sd, mem, &mut targets, marks::hit, report) {
            Ok(totals) => hprintln!("{}", totals),
            Err(e) => fail(format_args!("stream: {e}")),
        }
    });
}

#[cfg(all(
    feature = "stream",
    not(feature = "selftest-hostile"),
    not(feature = "scene")
))]
/// Opens the image, its first FAT volume and [`MODEL_FILE`], and draws the streamed
/// sequence, one line per frame; any failure to get that far ends the run with a message.
pub fn render_stream(mut targets: Targets<'_>, mem: StreamMemory<'_>) {
    with_image_file("model", MODEL_FILE, |sd| {
        // With `selftest-flaky`, reads fail or arrive damaged at random (repeatably); with
        // `selftest-pulled`, the card is pulled during the orbit.
        #[cfg(feature = "selftest-flaky")]
        let mut src = pocketsplat_qemu::stream::flaky(sd);
        #[cfg(all(feature = "selftest-pulled", not(feature = "selftest-flaky")))]
        let mut src = pocketsplat_qemu::stream::pulled(sd);
        #[cfg(not(any(feature = "selftest-flaky", feature = "selftest-pulled")))]
        let mut src = sd;
        let report = |f: &pocketsplat_qemu::stream::StreamFrame| hprintln!("{}", f);
        #[cfg(not(feature = "qsplat"))]
        let run = pocketsplat_qemu::stream::stream_frames(
            &mut src,
            mem,
            &mut targets,
            marks::hit,
            report,
        );
        #[cfg(feature = "qsplat")]
        let run = pocketsplat_qemu::stream::qs_stream_frames(
            &mut src,
            mem,
            &mut targets,
            marks::hit,
            report,
        );
        match run {
            Ok(totals) => hprintln!("{}", totals),
            Err(e) => fail(format_args!("stream: {e}")),
        }
    });
}
