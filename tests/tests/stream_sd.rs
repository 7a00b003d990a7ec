//! Streaming from a real FAT volume through embedded-sdmmc (issue 7, item 1): the test makes a disk
//! image the way one prepares an SD card, an MBR and a FAT16 partition made by `mkfs.fat` holding
//! the bunny copied in by `mcopy` (apt packages dosfstools and mtools), then reads it with
//! embedded-sdmmc's `VolumeManager` over a `BlockDevice` on the image file: the code path of an SD
//! card on SPI. The streamed frame must equal the resident one. Under CI a missing tool fails.

use pocketsplat_core::bake::BakeOptions;
use pocketsplat_core::camera::STANDARD_VIEWS;
use pocketsplat_core::stream::sdmmc::SdFile;
use pocketsplat_core::tg::{TriGrid, Verify};
use pocketsplat_sim::render::{render_tg_frame, FrameBuffers, Settings};
use pocketsplat_sim::stream::sd::NoClock;
use pocketsplat_sim::stream::{stream_render, FileBlockDevice, StreamOptions};
use pocketsplat_tests::fat::{have, make_image};
use pocketsplat_tests::model;

#[test]
fn the_bunny_streams_from_a_fat_image_through_embedded_sdmmc() {
    if !have("mkfs.fat", "dosfstools") | !have("mcopy", "mtools") {
        return;
    }
    let Some(path) = model("bun_zipper.ply.gz") else {
        return;
    };
    let mesh = pocketsplat_sim::ply::load_mesh(&path).unwrap();
    let (_, file) =
        pocketsplat_sim::bake::bake_mesh(&mesh, BakeOptions { rho: 3, depth: 6 }, 12, false)
            .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let image = make_image(dir.path(), &file, "BUNNY.TG");

    let device = FileBlockDevice::open(&image).unwrap();
    let volumes: embedded_sdmmc::VolumeManager<_, _, 4, 4, 1> =
        embedded_sdmmc::VolumeManager::new_with_limits(device, NoClock, 0);
    let volume = volumes
        .open_raw_volume(embedded_sdmmc::VolumeIdx(0))
        .unwrap();
    let root = volumes.open_root_dir(volume).unwrap();
    let handle = volumes
        .open_file_in_dir(root, "BUNNY.TG", embedded_sdmmc::Mode::ReadOnly)
        .unwrap();
    let mut sd = SdFile::new(&volumes, handle);
    assert_eq!(sd.len().unwrap() as usize, file.len());

    let grid = TriGrid::open(&file, Verify::Full).unwrap();
    // A cache of half the file: the model does not fit. At 1 px the std and front views need
    // nearly every block at once, which no smaller cache can hold, so the views are drawn at the
    // 2 px a handheld uses while the camera moves.
    let opts = StreamOptions {
        io_budget: 128 * 1024,
        cache_bytes: file.len() / 2,
        max_frames: 500,
        ..StreamOptions::default()
    };
    for (name, view) in STANDARD_VIEWS {
        let settings = Settings {
            view,
            cutoff_px: 2.0,
            ..Settings::default()
        };
        let mut want = FrameBuffers::new();
        render_tg_frame(&grid, &settings, &mut want).unwrap();
        let mut fb = FrameBuffers::new();
        let before = volumes.device(|d| d.reads.get());
        let out = stream_render(&mut sd, &settings, &opts, &mut fb).unwrap();
        let sectors = volumes.device(|d| d.reads.get()) - before;
        assert_eq!(fb.crc(), want.crc(), "{name}: streamed frame differs");
        eprintln!(
            "SD {name:5}: {} frames, {} of {} bytes read ({} sectors through embedded-sdmmc), cache {} blocks",
            out.frames,
            out.counters.bytes_read,
            file.len(),
            sectors,
            out.cache_blocks
        );
    }
    volumes.close_file(handle).unwrap();
    volumes.close_dir(root).unwrap();
    volumes.close_volume(volume).unwrap();
}

/// Streaming QSplat from a real FAT volume (issue 31): the dragon baked to `.qs`, copied onto the
/// image as `MODEL.QS` by `mcopy`, read through embedded-sdmmc with a 64 KB cache of 512-byte
/// blocks at a 1 px cutoff: every standard view converges to the resident frame.
#[test]
fn the_qsplat_dragon_streams_from_a_fat_image_through_embedded_sdmmc() {
    if !have("mkfs.fat", "dosfstools") | !have("mcopy", "mtools") {
        return;
    }
    let Some(path) = model("dragon_vrip.ply.gz") else {
        return;
    };
    let mesh = pocketsplat_sim::ply::load_mesh(&path).unwrap();
    let file = pocketsplat_core::qs::write::bake_qs(&mesh, &Default::default())
        .unwrap()
        .bytes;
    let dir = tempfile::tempdir().unwrap();
    let image = make_image(dir.path(), &file, "MODEL.QS");
    let device = FileBlockDevice::open(&image).unwrap();
    let volumes: embedded_sdmmc::VolumeManager<_, _, 4, 4, 1> =
        embedded_sdmmc::VolumeManager::new_with_limits(device, NoClock, 0);
    let volume = volumes
        .open_raw_volume(embedded_sdmmc::VolumeIdx(0))
        .unwrap();
    let root = volumes.open_root_dir(volume).unwrap();
    let handle = volumes
        .open_file_in_dir(root, "MODEL.QS", embedded_sdmmc::Mode::ReadOnly)
        .unwrap();
    let mut sd = SdFile::new(&volumes, handle);
    let qs = pocketsplat_core::qs::QSplat::open(&file).unwrap();
    let opts = StreamOptions {
        cache_bytes: 64 * 1024,
        max_frames: 100_000,
        ..StreamOptions::default()
    };
    for (name, view) in STANDARD_VIEWS {
        let settings = Settings {
            view,
            cutoff_px: 1.0,
            ..Settings::default()
        };
        let mut want = FrameBuffers::new();
        pocketsplat_sim::qsplat::render_qs_frame(&qs, &settings, &mut want).unwrap();
        let mut fb = FrameBuffers::new();
        let before = volumes.device(|d| d.reads.get());
        let out = stream_render(&mut sd, &settings, &opts, &mut fb).unwrap();
        let sectors = volumes.device(|d| d.reads.get()) - before;
        assert_eq!(fb.crc(), want.crc(), "{name}: streamed frame differs");
        // The refined frame's reads at an SD card's sustained rates (MB = 10^6 bytes).
        let ms = |mb_s: f64| out.refined_bytes as f64 / (mb_s * 1e3);
        eprintln!(
            "SD .qs {name:5}: {} frames, {} passes, {} blocks / {} bytes read for the refined frame \
             ({:.0} / {:.0} / {:.0} ms at 2 / 10 / 20 MB/s), {} sectors through embedded-sdmmc",
            out.frames,
            out.passes,
            out.refined_reads,
            out.refined_bytes,
            ms(2.0),
            ms(10.0),
            ms(20.0),
            sectors
        );
    }
    volumes.close_file(handle).unwrap();
    volumes.close_dir(root).unwrap();
    volumes.close_volume(volume).unwrap();
}
