//! The bunny streamed under QEMU (issue 7): the firmware built with `stream` opens a FAT disk image
//! on the host through semihosting file reads behind an embedded-sdmmc `BlockDevice` (the SD card's
//! code path: MBR, FAT16 volume, root directory, `BUNNY.TG`), and draws the bunny at paper level 5
//! (tri-grid depth 6, 5 MB) through a 64 KB block cache: the std view from a cold cache until it
//! converges, an orbit of 24 steps, and the std view again (`pocketsplat_qemu::stream`).
//!
//! Checked: the firmware's lines equal those of the same sequence run on the host over the same
//! image (so every frame, byte count and missing-block count is the host's), and every converged
//! frame has the CRC of the host's resident render of that view. Printed (`-- --nocapture`):
//! frames to convergence, bytes read per orbit frame, total bytes against the file size, and the
//! firmware's memory.
//!
//! Needs `qemu-system-arm`, `mkfs.fat` (dosfstools), `mcopy` (mtools) and the bunny scan: without
//! them this fails under CI and is skipped, with a note, elsewhere.

use std::path::Path;

use pocketsplat_core::stream::sdmmc::{NoClock, SdFile};
use pocketsplat_core::stream::ChunkSource;
use pocketsplat_qemu::stream::{
    orbit_view, stream_frames, Leg, StreamFrame, StreamTables, StreamTotals, CACHE_BYTES,
    STREAM_CUTOFF_PX,
};
use pocketsplat_qemu::Model;
use pocketsplat_sim::stream::FileBlockDevice;
use pocketsplat_tests::arm::{
    baked_bunny, check_memory, have_qemu, target_dir, Firmware, HostFrames, TARGET,
};
use pocketsplat_tests::fat::{have, make_image};

/// The model's name on the volume (the firmware opens it by this name).
const MODEL_FILE: &str = "BUNNY.TG";

/// The firmware's sequence on the host: the same library call over the same image, through
/// The medium under the file system: what the firmware's `selftest-*` features put there.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Medium {
    /// Every read succeeds.
    Clean,
    /// `selftest-flaky`: core's torture source.
    Flaky,
    /// `selftest-pulled`: the card is pulled during the orbit.
    Pulled,
}

impl Medium {
    fn feature(self) -> Option<&'static str> {
        match self {
            Medium::Clean => None,
            Medium::Flaky => Some("selftest-flaky"),
            Medium::Pulled => Some("selftest-pulled"),
        }
    }
}

/// embedded-sdmmc on a host file, through the same medium as the firmware's.
fn host_sequence(image: &Path, medium: Medium) -> (Vec<StreamFrame>, StreamTotals) {
    let device = FileBlockDevice::open(image).unwrap();
    let volumes: embedded_sdmmc::VolumeManager<_, _, 1, 1, 1> =
        embedded_sdmmc::VolumeManager::new_with_limits(device, NoClock, 0);
    let volume = volumes
        .open_raw_volume(embedded_sdmmc::VolumeIdx(0))
        .unwrap();
    let root = volumes.open_root_dir(volume).unwrap();
    let file = volumes
        .open_file_in_dir(root, MODEL_FILE, embedded_sdmmc::Mode::ReadOnly)
        .unwrap();
    let mut sd = SdFile::new(&volumes, file);
    match medium {
        Medium::Clean => sequence(&mut sd),
        Medium::Flaky => sequence(&mut pocketsplat_qemu::stream::flaky(sd)),
        Medium::Pulled => sequence(&mut pocketsplat_qemu::stream::pulled(sd)),
    }
}

fn sequence<C: ChunkSource>(src: &mut C) -> (Vec<StreamFrame>, StreamTotals) {
    let mut tables = Box::new(StreamTables::EMPTY);
    let mut data = Box::new([0u8; CACHE_BYTES]);
    let mem = tables.with_cache(&mut data);
    let mut frames = HostFrames::new();
    let mut lines = Vec::new();
    let totals = stream_frames(src, mem, &mut frames.targets(), |_| {}, |f| lines.push(*f))
        .unwrap_or_else(|e| panic!("host sequence: {e}"));
    (lines, totals)
}

/// The `stream total …` line, read back.
fn parse_totals(line: &str) -> Option<StreamTotals> {
    let w: Vec<&str> = line.split_whitespace().collect();
    let get = |key: &str| -> Option<u64> {
        let i = w.iter().position(|x| *x == key)?;
        w.get(i + 1)?.parse().ok()
    };
    Some(StreamTotals {
        bytes: get("bytes")?,
        file_bytes: get("file")?,
        frames: get("frames")? as u32,
        read_errors: get("read_errors")? as u32,
        crc_errors: get("crc_errors")? as u32,
        evictions: get("evictions")? as u32,
        cache_blocks: get("cache_blocks")? as u32,
    })
}

#[test]
fn the_bunny_streams_from_a_fat_image_under_qemu_to_the_host_frames() {
    let Some((totals, marked, _)) = stream_under_qemu(Medium::Clean) else {
        return;
    };
    assert_eq!(totals.read_errors + totals.crc_errors, 0, "a clean medium");
    assert_eq!(marked, 0, "no error marker without errors");
}

/// `selftest-flaky`: a tenth of the reads fail and a tenth arrive damaged. Each bad block stays
/// absent (the frame is drawn coarser, the block read again after a backoff), nothing panics, the
/// frames after a failed read show the error marker, and the converged frames without one are
/// still the resident file's.
#[test]
fn bad_reads_leave_blocks_absent_and_the_stream_still_converges_under_qemu() {
    let Some((totals, marked, _)) = stream_under_qemu(Medium::Flaky) else {
        return;
    };
    assert!(
        totals.read_errors > 0 && totals.crc_errors > 0,
        "the torture source failed and damaged reads: {totals:?}"
    );
    assert!(
        marked > 0,
        "frames after failed reads carry the error marker"
    );
}

/// `selftest-pulled`: the card is pulled during the orbit. The firmware keeps drawing what is
/// resident, every frame after that carries the error marker, and it exits normally (a panic or
/// HardFault would fail the run).
#[test]
fn a_pulled_card_leaves_the_firmware_drawing_the_coarse_model_with_the_marker_under_qemu() {
    let Some((totals, marked, frames)) = stream_under_qemu(Medium::Pulled) else {
        return;
    };
    assert!(
        totals.read_errors > 0,
        "reads failed once the card was gone: {totals:?}"
    );
    let first_failed = frames
        .iter()
        .position(|f| f.failed > 0)
        .expect("a frame after the pull");
    // A pass that resumes where blocks never come draws nothing: only whole frames must draw.
    assert!(
        frames[first_failed..]
            .iter()
            .all(|f| f.marker && (f.splats > 0 || f.leg.passes())),
        "every frame after the pull is drawn, from resident blocks, with the marker"
    );
    assert_eq!(marked, frames.len() - first_failed);
}

/// Builds the image and the firmware (with the medium's `selftest-*` feature), runs it, checks its lines
/// against the host's and its converged frames against the resident render, prints the figures and
/// returns the totals, the number of frames drawn with the error marker and the frames; `None`
/// when a tool or the scan is missing off CI.
fn stream_under_qemu(medium: Medium) -> Option<(StreamTotals, usize, Vec<StreamFrame>)> {
    if !have_qemu() || !have("mkfs.fat", "dosfstools") | !have("mcopy", "mtools") {
        return None;
    }
    let model = baked_bunny().unwrap()?;
    let bytes = std::fs::read(&model).unwrap();
    assert!(
        bytes.len() > 8 * CACHE_BYTES,
        "the model must be far larger than the cache"
    );
    // A fixed path per variant: the firmware is built with it, and rebuilding for each run would be
    // waste (the two tests run in parallel, so each has its own).
    let dir = target_dir().join(match medium {
        Medium::Clean => "models/sd-bunny",
        Medium::Flaky => "models/sd-bunny-flaky",
        Medium::Pulled => "models/sd-bunny-pulled",
    });
    std::fs::create_dir_all(&dir).unwrap();
    let image = make_image(&dir, &bytes, MODEL_FILE);
    let feature = medium.feature();
    let features: &[&str] = feature.as_slice();

    let fw = Firmware {
        target: TARGET,
        panel: None,
        features,
        model: None,
        image: Some(&image),
    };
    let elf = fw.build().unwrap();
    let run = fw.run(&elf, None).unwrap();
    assert_eq!(
        run.output.status.code(),
        Some(0),
        "the firmware must exit through semihosting with status 0:\n{}",
        run.transcript()
    );
    let stdout = run.stdout();
    let arm: Vec<StreamFrame> = stdout.lines().filter_map(StreamFrame::parse).collect();
    let arm_totals = run
        .field("stream total")
        .and_then(|t| parse_totals(&format!("stream total {t}")))
        .unwrap_or_else(|| panic!("no `stream total` line:\n{}", run.transcript()));

    // The same sequence on the host: same frames, same reads, same misses.
    let (host, host_totals) = host_sequence(&image, medium);
    for (i, (a, h)) in arm.iter().zip(&host).enumerate() {
        assert_eq!(a, h, "streamed frame {i} differs between ARM and host");
    }
    assert_eq!(arm.len(), host.len(), "frame count");
    assert_eq!(arm_totals, host_totals);

    // A converged frame is the resident file's frame.
    let resident = Model::open(&bytes).unwrap();
    let mut frames = HostFrames::new();
    let mut checked = 0;
    // A frame after a failed read carries the error marker over it (same code on both sides, so
    // the ARM and host CRCs above cover it); the others must be exactly the resident render. A
    // refined leg's last pass completes its frame (the marker is never painted into a frame drawn
    // in passes): its CRC is the resident render's (its counts are the last pass's own).
    let marked = arm.iter().filter(|f| f.marker).count();
    for f in arm
        .iter()
        .filter(|f| f.converged() && (!f.marker || f.leg.passes()))
    {
        let cutoff = f32::from(f.leg.cutoff_px());
        let (crc, stats) = frames
            .render_view(&resident, orbit_view(f.az_deg), cutoff)
            .unwrap();
        if f.leg.passes() {
            assert_eq!(
                f.crc, crc,
                "refined frame `{f}` differs from the resident render (crc {crc:#010x})"
            );
        } else {
            assert_eq!(
                (f.crc, f.splats, f.nodes),
                (crc, stats.splats, stats.nodes_visited),
                "converged frame `{f}` differs from the resident render (crc {crc:#010x})"
            );
        }
        checked += 1;
    }
    // A pulled card cannot bring back what was evicted: its return leg need not converge.
    let legs: &[Leg] = if medium == Medium::Pulled {
        &[Leg::Std]
    } else {
        &[Leg::Std, Leg::Return, Leg::Px2, Leg::Px1]
    };
    for &leg in legs {
        let last = arm.iter().rfind(|f| f.leg == leg).expect("the leg ran");
        assert!(last.converged(), "leg {} ends converged", leg.name());
    }

    let (memory, stack) = check_memory(&run, &elf).unwrap();
    let frames_of = |leg: Leg| arm.iter().filter(|f| f.leg == leg).count();
    let orbit: Vec<String> = arm
        .iter()
        .filter(|f| f.leg == Leg::Orbit)
        .map(|f| format!("{}{}", f.read, if f.converged() { "" } else { "*" }))
        .collect();
    eprintln!(
        "QEMU stream{}, cutoff {STREAM_CUTOFF_PX} px, cache {} blocks of {} KB ({CACHE_BYTES} B), \
         image {} KB through embedded-sdmmc over semihosting",
        feature.map(|f| format!(" ({f})")).unwrap_or_default(),
        arm_totals.cache_blocks,
        CACHE_BYTES as u32 / arm_totals.cache_blocks.max(1) / 1024,
        std::fs::metadata(&image).unwrap().len() / 1024
    );
    eprintln!(
        "  std from cold: converged after {} frames; back at std after the orbit: {} frames",
        frames_of(Leg::Std),
        frames_of(Leg::Return)
    );
    eprintln!(
        "  orbit bytes read per frame (* = frame not converged): {}",
        orbit.join(" ")
    );
    eprintln!(
        "  total {} bytes read of a {}-byte file in {} frames ({} evictions, {} failed reads, {} damaged blocks); \
         {checked} converged frames checked against the resident render",
        arm_totals.bytes,
        arm_totals.file_bytes,
        arm_totals.frames,
        arm_totals.evictions,
        arm_totals.read_errors,
        arm_totals.crc_errors
    );
    eprintln!(
        "  {}: flash {} B, RAM {} B + stack {stack} B; {} sectors read through embedded-sdmmc",
        fw.name(),
        memory.flash,
        memory.ram,
        run.field("sectors_read").unwrap_or_default()
    );
    eprintln!("  {marked} frames drawn with the read-error marker");
    for leg in [Leg::Px2, Leg::Px1] {
        let passes: Vec<&StreamFrame> = arm.iter().filter(|f| f.leg == leg).collect();
        // The bytes read for the refined frame: after every pass but the last (which read nothing
        // it needed), the first pass's reads included.
        let bytes: u64 = passes.iter().map(|f| u64::from(f.read)).sum();
        let ms = |mb_s: u64| bytes as f64 / (mb_s as f64 * 1e3);
        eprintln!(
            "  std at {} px refined in {} passes{}: {bytes} bytes read ({} blocks of 4 KB; {:.0} / \
             {:.0} / {:.0} ms of SD reading at 2 / 10 / 20 MB/s)",
            leg.cutoff_px(),
            passes.len(),
            if passes.last().is_some_and(|f| f.converged()) {
                ""
            } else {
                " (not complete)"
            },
            bytes / 4096,
            ms(2),
            ms(10),
            ms(20)
        );
    }
    Some((arm_totals, marked, arm))
}

/// Streaming QSplat under QEMU (issue 31, item 5 in part): the firmware built with `stream` and
/// `qsplat` opens `MODEL.QS` on a FAT image (the dragon baked to `.qs`, 2.8 MB) through
/// embedded-sdmmc and draws its std view at 1 px through the 64 KB cache in passes, from the first
/// (`pocketsplat_qemu::stream::qs_stream_frames`, 2 KB blocks). Its lines are the host's over the
/// same image, and its last pass completes the resident file's frame (the host's resident render's
/// CRC). Prints passes, bytes read for the refined frame and SD time at 2 / 10 / 20 MB/s.
#[test]
fn the_qsplat_dragon_streams_from_a_fat_image_under_qemu_to_the_resident_frame() {
    use pocketsplat_qemu::stream::{qs_stream_frames, QS_BLOCK_LOG2};
    if !have_qemu() || !have("mkfs.fat", "dosfstools") | !have("mcopy", "mtools") {
        return;
    }
    let Some(path) = pocketsplat_tests::model("dragon_vrip.ply.gz") else {
        return;
    };
    let mesh = pocketsplat_sim::ply::load_mesh(&path).unwrap();
    let bytes = pocketsplat_core::qs::write::bake_qs(&mesh, &Default::default())
        .unwrap()
        .bytes;
    let dir = target_dir().join("models/sd-dragon-qs");
    std::fs::create_dir_all(&dir).unwrap();
    let image = make_image(&dir, &bytes, "MODEL.QS");
    let fw = Firmware::streaming(&["qsplat"], &image);
    let (elf, run) = fw.build_and_run().unwrap();
    let arm: Vec<StreamFrame> = run
        .stdout()
        .lines()
        .filter_map(StreamFrame::parse)
        .collect();
    let arm_totals = run
        .field("stream total")
        .and_then(|t| parse_totals(&format!("stream total {t}")))
        .unwrap_or_else(|| panic!("no `stream total` line:\n{}", run.transcript()));

    // The same call on the host over the same image.
    let device = FileBlockDevice::open(&image).unwrap();
    let volumes: embedded_sdmmc::VolumeManager<_, _, 1, 1, 1> =
        embedded_sdmmc::VolumeManager::new_with_limits(device, NoClock, 0);
    let volume = volumes
        .open_raw_volume(embedded_sdmmc::VolumeIdx(0))
        .unwrap();
    let root = volumes.open_root_dir(volume).unwrap();
    let file = volumes
        .open_file_in_dir(root, "MODEL.QS", embedded_sdmmc::Mode::ReadOnly)
        .unwrap();
    let mut sd = SdFile::new(&volumes, file);
    let mut tables = Box::new(StreamTables::EMPTY);
    let mut data = Box::new([0u8; CACHE_BYTES]);
    let mut frames = HostFrames::new();
    let mut host = Vec::new();
    let host_totals = qs_stream_frames(
        &mut sd,
        tables.with_cache(&mut data),
        &mut frames.targets(),
        |_| {},
        |f| host.push(*f),
    )
    .unwrap_or_else(|e| panic!("host sequence: {e}"));
    assert_eq!(arm, host, "the passes differ between ARM and host");
    assert_eq!(arm_totals, host_totals);

    let last = arm.last().expect("a pass");
    assert!(last.converged(), "the refined frame completes: {last}");
    let resident = Model::open(&bytes).unwrap();
    let (crc, _) = frames.render_view(&resident, orbit_view(0), 1.0).unwrap();
    assert_eq!(last.crc, crc, "the refined frame is the resident render");

    let (memory, stack) = check_memory(&run, &elf).unwrap();
    // The RP2350's SRAM (issue 31): this build, everything included (panel-sized colour and
    // depth, shading table, cache, tables, measured stack), must fit it.
    assert!(
        memory.ram + stack <= 520 * 1024,
        "RAM {} B + stack {stack} B is over the Pico 2's 520 KB",
        memory.ram
    );
    let read: u64 = arm.iter().map(|f| u64::from(f.read)).sum();
    let ms = |mb_s: f64| arm_totals.bytes as f64 / (mb_s * 1e3);
    eprintln!(
        "QEMU QSplat stream: dragon.qs {} B, std at 1 px in {} passes through {} blocks of {} B: \
         {} bytes read ({} blocks; {:.0} / {:.0} / {:.0} ms of SD reading at 2 / 10 / 20 MB/s); \
         {}: flash {} B, RAM {} B + stack {stack} B",
        bytes.len(),
        arm.len(),
        arm_totals.cache_blocks,
        1 << QS_BLOCK_LOG2,
        arm_totals.bytes,
        read >> QS_BLOCK_LOG2,
        ms(2.0),
        ms(10.0),
        ms(20.0),
        fw.name(),
        memory.flash,
        memory.ram
    );
}
