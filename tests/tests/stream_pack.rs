//! Scene packs streamed (issue 31, item 2): the pack's metadata read once, each object's file read
//! in blocks through its share of the cache, from a file and from a FAT image through
//! embedded-sdmmc (the HTTP leg is in `stream_http`). Every converged frame must be the frame of
//! the pack opened whole, byte for byte (CRC of the framebuffer), with the pack's shadows
//! (one-pass, two-pass, off), both while the cache holds the frame and in passes through a cache
//! smaller than the frame. Two packs: one generated here with a tri-grid ground, a generated tree and a
//! QSplat knot (always runs), and the Big Scene (`boards/sim/scenes/big.toml`, real scans).
//!
//! `cargo test -p pocketsplat-tests --test all stream_pack:: -- --nocapture` prints the figures.

use std::path::Path;

use pocketsplat_core::camera::View;
use pocketsplat_core::scene::{Pack, Scene, ShadowMode};
use pocketsplat_core::stream::ChunkSource;
use pocketsplat_core::tg::Verify;
use pocketsplat_sim::render::FrameBuffers;
use pocketsplat_sim::scene::render::{render_pack, PackSettings};
use pocketsplat_sim::stream::pack::stream_pack;
use pocketsplat_sim::stream::sd::with_file;
use pocketsplat_sim::stream::{FileSource, StreamOptions, StreamOutcome};
use pocketsplat_tests::arm::baked_big_scene;
use pocketsplat_tests::fat::{have, make_image};

/// A pack of a tri-grid ground, a generated tree (two materials) and a QSplat knot, one-pass
/// shadows in its header.
pub(crate) fn generated_pack(dir: &Path) -> Vec<u8> {
    let knot = pocketsplat_core::qs::write::bake_qs(
        &pocketsplat_sim::demo::trefoil(96, 12, 0.3),
        &pocketsplat_core::qs::write::QsBakeOptions {
            colors: false,
            comment: true,
        },
    )
    .unwrap()
    .bytes;
    std::fs::write(dir.join("knot.qs"), knot).unwrap();
    let toml = r#"
[light]
az = -40.0
el = 55.0

[shadows]
mode = "one-pass"
map_size = 256

[bake]
block_size = 1024

[materials.grass]
color = [0.34, 0.50, 0.24]

[materials.bark]
color = [0.42, 0.30, 0.20]

[materials.leaves]
color = [0.25, 0.55, 0.18]

[materials.red]
color = [0.9, 0.2, 0.1]

[[objects]]
name = "ground"
ground = { size = 3.0 }
material = "grass"
depth = 5
casts_shadows = false
in_bounds = false

[[objects]]
name = "tree"
tree = { seed = 7, levels = 3, branches = 3 }
materials = ["bark", "leaves"]
depth = 5
height = 0.9
translate = [-0.4, 0.0, 0.0]
anchor = "base"

[[objects]]
name = "knot"
file = "knot.qs"
material = "red"
height = 0.5
translate = [0.4, 0.3, 0.0]

[[views]]
name = "v"
az = 30.0
el = 25.0
dist = 2.2
"#;
    let path = dir.join("scene.toml");
    std::fs::write(&path, toml).unwrap();
    pocketsplat_sim::scene::bake::bake_path(&path, &Default::default())
        .unwrap()
        .bytes
}

fn settings(view: View, shadows: ShadowMode, cutoff_px: f32) -> PackSettings {
    let mut s = PackSettings::new(view);
    s.shadows = Some(shadows);
    s.cutoff_px = cutoff_px;
    s
}

/// The CRC of the frame the pack opened whole gives.
fn resident_crc(bytes: &[u8], s: &PackSettings) -> u32 {
    let scene = Scene::open(Pack::open(bytes).unwrap(), Verify::Full).unwrap();
    let mut fb = FrameBuffers::new();
    render_pack(&scene, s, &mut fb).unwrap();
    fb.crc()
}

/// Streams the pack on `src` until it converges: the frame's CRC and what the stream did.
fn streamed<C: ChunkSource + ?Sized>(
    src: &mut C,
    s: &PackSettings,
    cache_bytes: usize,
) -> anyhow::Result<(u32, StreamOutcome)> {
    let opts = StreamOptions {
        cache_bytes,
        max_frames: 100_000,
        ..StreamOptions::default()
    };
    let mut fb = FrameBuffers::new();
    let out = stream_pack(src, |_| Ok(*s), &opts, &mut fb, |_| Ok(()))?;
    Ok((fb.crc(), out))
}

/// The smallest cache the pack streams through, from the error a 4 KB cache gives.
fn needed_cache(src: &mut FileSource, s: &PackSettings) -> usize {
    let err = format!("{:#}", streamed(src, s, 4096).unwrap_err());
    let need = err
        .split("needs --cache ")
        .nth(1)
        .and_then(|t| t.split(' ').next())
        .unwrap_or_else(|| panic!("no cache named: {err}"));
    let (n, unit) = need.split_at(need.len() - 1);
    n.parse::<usize>().unwrap() * if unit == "M" { 1 << 20 } else { 1024 }
}

/// Every shadow mode at the default cache (the frame fits), and without shadows through the
/// smallest cache and twice that (passes): the pack opened whole's frame each time.
fn check_file(name: &str, bytes: &[u8], views: &[View], cutoff_px: f32) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.pack");
    std::fs::write(&path, bytes).unwrap();
    let mut src = FileSource::open(&path).unwrap();
    eprintln!(
        "pack     | view           | shadows  | cache   | frames | passes | bytes read | of pack"
    );
    for &view in views {
        // The views show shadows: a test of them could fail.
        let crc_of = |m| resident_crc(bytes, &settings(view, m, cutoff_px));
        assert_ne!(
            crc_of(ShadowMode::Off),
            crc_of(ShadowMode::OnePass),
            "{name}: no shadows"
        );
        for mode in ShadowMode::ALL {
            let s = settings(view, mode, cutoff_px);
            let want = resident_crc(bytes, &s);
            // Passes through the least cache and twice it: without shadows, with two-pass
            // shadows (the casts in passes first) and with one-pass shadows (each object's walk
            // resumed in light order).
            let need = needed_cache(&mut src, &s);
            for cache in [16 << 20, need, 2 * need] {
                let (crc, out) = streamed(&mut src, &s, cache)
                    .unwrap_or_else(|e| panic!("{name} {view:?} {mode:?} {cache}: {e:#}"));
                assert_eq!(
                    crc, want,
                    "{name} {view:?} {mode:?} --cache {cache}: other pixels"
                );
                eprintln!(
                    "{name:8} | {:4.0} {:4.0} {:4.1} | {:8} | {:6}K | {:6} | {:6} | {:10} | {:5.1} %",
                    view.az_deg,
                    view.el_deg,
                    view.dist,
                    mode.name(),
                    cache / 1024,
                    out.frames,
                    out.passes,
                    out.counters.bytes_read,
                    100.0 * out.counters.bytes_read as f64 / bytes.len() as f64
                );
                if cache == need {
                    assert!(out.passes > 1, "{name} {view:?} {mode:?}: no passes");
                }
            }
        }
    }
}

#[test]
fn a_generated_pack_with_a_qsplat_object_streams_to_the_resident_frame() {
    let dir = tempfile::tempdir().unwrap();
    let bytes = generated_pack(dir.path());
    let pack = Pack::open(&bytes).unwrap();
    assert_eq!(pack.object_count(), 3);
    let views = [pack.view_named("v").unwrap(), View::new(-60.0, 50.0, 1.8)];
    // Every object is in both views.
    let scene = Scene::open(pack, Verify::Full).unwrap();
    for &view in &views {
        let mut fb = FrameBuffers::new();
        let f = render_pack(&scene, &settings(view, ShadowMode::OnePass, 1.0), &mut fb).unwrap();
        for i in 0..3 {
            assert!(
                f.stats.objects[i].splats > 100,
                "{view:?}: object {i} not drawn"
            );
        }
    }
    check_file("knot", &bytes, &views, 1.0);
}

#[test]
fn the_big_scene_streams_from_a_file_to_the_resident_frame() {
    let Some(path) = baked_big_scene(3).unwrap() else {
        return;
    };
    let bytes = std::fs::read(path).unwrap();
    let pack = Pack::open(&bytes).unwrap();
    let views = [
        pack.view_named("std").unwrap(),
        pack.view_named("top").unwrap(),
    ];
    check_file("big", &bytes, &views, 2.0);
}

/// The Big Scene on a FAT16 image as `SCENE.PAK`, read through embedded-sdmmc: with its one-pass
/// shadows through the default cache, and without shadows through 512 KB (passes).
#[test]
fn the_big_scene_streams_from_a_fat_image_through_embedded_sdmmc() {
    if !have("mkfs.fat", "dosfstools") | !have("mcopy", "mtools") {
        return;
    }
    let Some(path) = baked_big_scene(3).unwrap() else {
        return;
    };
    let bytes = std::fs::read(path).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let image = make_image(dir.path(), &bytes, "SCENE.PAK");
    let view = Pack::open(&bytes).unwrap().view_named("std").unwrap();
    for (mode, cache) in [
        (ShadowMode::OnePass, 16 << 20),
        (ShadowMode::Off, 512 << 10),
        (ShadowMode::TwoPass, 512 << 10),
    ] {
        let s = settings(view, mode, 2.0);
        let want = resident_crc(&bytes, &s);
        let (crc, out) = with_file(&image, "SCENE.PAK", |sd| streamed(sd, &s, cache)).unwrap();
        assert_eq!(crc, want, "SD {mode:?}: other pixels");
        eprintln!(
            "SD big std {}: {} frames, {} passes, {} of {} bytes read through embedded-sdmmc",
            mode.name(),
            out.frames,
            out.passes,
            out.counters.bytes_read,
            bytes.len(),
        );
    }
}

/// Hostile packs streamed (issue 31, item 6, packs): each class
/// (`pocketsplat_tests::hostile::pack_cases`) ends in an error that names what is wrong, within a
/// bounded number of frames; never a panic, a hang or a frame of noise. (The same files stream
/// under QEMU in `qemu_pack_stream.rs`.)
#[test]
fn hostile_packs_streamed_end_in_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let good = generated_pack(dir.path());
    let s = settings(
        Pack::open(&good).unwrap().view_named("v").unwrap(),
        ShadowMode::OnePass,
        1.0,
    );
    for case in pocketsplat_tests::hostile::pack_cases(&good) {
        let path = dir.path().join("h.pack");
        std::fs::write(&path, &case.bytes).unwrap();
        let mut src = FileSource::open(&path).unwrap();
        let opts = StreamOptions {
            max_frames: 200,
            ..StreamOptions::default()
        };
        let mut fb = FrameBuffers::new();
        let err = stream_pack(&mut src, |_| Ok(s), &opts, &mut fb, |_| Ok(()))
            .err()
            .unwrap_or_else(|| panic!("{}: streamed without an error", case.name));
        let msg = format!("{err:#}");
        assert!(msg.contains(case.says), "{}: {msg}", case.name);
        eprintln!("{}: {msg}", case.name);
    }
}

/// The Big Scene at the paper's scale (issue 31, item 3): `boards/sim/scenes/paper.toml` baked
/// here (more than the paper's 11.0 M samples), on a FAT image as `SCENE.PAK`, streamed through
/// embedded-sdmmc: the std view with one-pass shadows through 64 MB, and in every shadow mode
/// through 2 MB (passes), each the resident frame. `scripts/paper-scene` does the same for every view
/// through the command line.
#[test]
fn the_paper_scale_big_scene_streams_from_a_fat_image() {
    if !have("mkfs.fat", "dosfstools") | !have("mcopy", "mtools") {
        return;
    }
    for scan in pocketsplat_tests::arm::BIG_SCENE_SCANS {
        if pocketsplat_tests::model(scan).is_none() {
            return;
        }
    }
    let toml = pocketsplat_tests::workspace_root().join("boards/sim/scenes/paper.toml");
    let bytes = pocketsplat_sim::scene::bake::bake_path(&toml, &Default::default())
        .unwrap()
        .bytes;
    let pack = Pack::open(&bytes).unwrap();
    let scene = Scene::open(pack, Verify::Full).unwrap();
    let samples: u64 = (0..scene.len())
        .filter_map(|i| scene.grid(i))
        .map(|g| g.total_samples())
        .sum();
    assert!(
        samples >= 11_000_000,
        "{samples} samples: fewer than the paper's 11.0 M"
    );
    let dir = tempfile::tempdir().unwrap();
    let image = make_image(dir.path(), &bytes, "SCENE.PAK");
    let view = pack.view_named("std").unwrap();
    for (mode, cache) in [
        (ShadowMode::OnePass, 64 << 20),
        (ShadowMode::Off, 2 << 20),
        (ShadowMode::TwoPass, 2 << 20),
        (ShadowMode::OnePass, 2 << 20),
    ] {
        let s = settings(view, mode, 1.0);
        let mut want = FrameBuffers::new();
        render_pack(&scene, &s, &mut want).unwrap();
        let (crc, out) = with_file(&image, "SCENE.PAK", |sd| streamed(sd, &s, cache)).unwrap();
        assert_eq!(crc, want.crc(), "{mode:?} --cache {cache}: other pixels");
        eprintln!(
            "paper scale, {samples} samples, {} bytes: std {} through {} KB: {} frames, {} passes, \
             {} bytes read ({} in the refined frame)",
            bytes.len(),
            mode.name(),
            cache >> 10,
            out.frames,
            out.passes,
            out.counters.bytes_read,
            out.refined_bytes
        );
    }
}

/// What a frame casts counts towards its convergence (issue 31's trust item): one-pass shadows
/// cast from subtrees culled or facing away, and two-pass casts the whole light view; where their
/// blocks are absent they cast coarser, and the frame must not count as converged until those
/// blocks are read. Close views with a 2048² map (casts stop at cells of one texel, deep in the
/// files) and one block read per frame, so that the first frames lack what unseen casters need:
/// every converged frame must be the resident one; and both through the least cache, where
/// two-pass's light pass is itself cast in passes (a later pass adding to what the earlier ones
/// cast) and one-pass's light-ordered walks resume where each pass stopped.
#[test]
fn a_frame_converges_only_once_what_it_casts_is_read() {
    let dir = tempfile::tempdir().unwrap();
    let bytes = generated_pack(dir.path());
    let path = dir.path().join("s.pack");
    std::fs::write(&path, &bytes).unwrap();
    let mut src = FileSource::open(&path).unwrap();
    let opts = StreamOptions {
        io_budget: 512,
        max_frames: 100_000,
        ..StreamOptions::default()
    };
    let mut checked = 0;
    for (az, el, dist) in [
        (30.0, 25.0, 0.9),
        (120.0, 10.0, 0.8),
        (200.0, 40.0, 0.7),
        (-80.0, 15.0, 0.8),
    ] {
        for mode in [ShadowMode::OnePass, ShadowMode::TwoPass] {
            let mut s = settings(View::new(az, el, dist), mode, 1.0);
            s.shadow_map_size = Some(2048);
            let want = resident_crc(&bytes, &s);
            let mut fb = FrameBuffers::new();
            let out = stream_pack(&mut src, |_| Ok(s), &opts, &mut fb, |_| Ok(())).unwrap();
            assert_eq!(
                fb.crc(),
                want,
                "{az} {el} {dist} {mode:?}: converged on other pixels"
            );
            checked += out.frames;
            {
                // Through the least cache: two-pass's light pass is itself cast in passes, and
                // one-pass's walks resume in light order.
                let need = needed_cache(&mut src, &s);
                let (crc, out) = streamed(&mut src, &s, need).unwrap();
                assert_eq!(
                    crc, want,
                    "{az} {el} {dist} {mode:?} in passes: other pixels"
                );
                assert!(
                    out.passes > 1,
                    "{az} {el} {dist}: drawn whole through the least cache"
                );
                checked += out.frames;
            }
        }
    }
    eprintln!("{checked} frames streamed, each run ending on the resident frame");
}

/// The RAM budget of the Big Scene streamed as a 520 KB device would draw it (issue 31, item 4):
/// eight bands, a 128² map, the least caches. As baked for benchmarks (4 KB blocks) its caches
/// alone are 228 KB and it does not fit; baked with 1 KB blocks (the least cache falls to 78 KB;
/// the block tables follow the caches, not the files) it must, before the stack, with room for
/// one.
#[test]
fn the_big_scene_in_1k_blocks_fits_a_520_kb_device_before_its_stack() {
    let Some(bytes) = pocketsplat_tests::arm::big_scene_in_1k_blocks().unwrap() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let toml = dir.path().join("big1k.pack");
    let info = pocketsplat_sim::info::pack_info(&toml, &bytes).unwrap();
    let ram = info.device_ram;
    eprintln!(
        "Big Scene, 1 KB blocks, {} bands, map {}²: {} bytes before the stack ({} of caches, {} \
         of stream tables)",
        pocketsplat_sim::info::DEVICE_BANDS,
        pocketsplat_sim::info::DEVICE_MAP_SIZE,
        ram.total(),
        ram.cache - info.stream_tables,
        info.stream_tables
    );
    // The resident scene firmware's stack under QEMU is 52,028 bytes, the frame setup (counted
    // above) 26,768 of them: keep 32 KB for the rest.
    assert!(
        ram.total() + (32 << 10) <= pocketsplat_sim::info::PICO2_RAM,
        "{} bytes before the stack: no room for one in 520 KB",
        ram.total()
    );
}

/// A streamed pack drawn in bands (what a 520 KB device draws, `--bands`): frames from what is
/// resident band by band, and refined frames one band after another, each band's in its own
/// passes through the least cache. Every mode must end on the whole frame the pack opened
/// whole gives.
#[test]
fn a_streamed_pack_drawn_in_bands_ends_on_the_whole_frame() {
    let dir = tempfile::tempdir().unwrap();
    let bytes = generated_pack(dir.path());
    let path = dir.path().join("s.pack");
    std::fs::write(&path, &bytes).unwrap();
    let mut src = FileSource::open(&path).unwrap();
    let view = Pack::open(&bytes).unwrap().view_named("v").unwrap();
    for mode in ShadowMode::ALL {
        let s = settings(view, mode, 1.0);
        let want = resident_crc(&bytes, &s);
        let need = needed_cache(&mut src, &s);
        for (bands, cache) in [(2, 16 << 20), (2, need), (3, need)] {
            let opts = StreamOptions {
                cache_bytes: cache,
                max_frames: 100_000,
                ..StreamOptions::default()
            };
            let mut fb = FrameBuffers::new().in_bands(bands);
            let out = stream_pack(&mut src, |_| Ok(s), &opts, &mut fb, |_| Ok(())).unwrap();
            assert_eq!(
                fb.crc(),
                want,
                "{mode:?} in {bands} bands through {cache} B"
            );
            if cache == need {
                assert!(out.passes > 1, "{mode:?} {bands} bands: no passes");
            }
            eprintln!(
                "{} in {bands} bands through {}K: {} frames, {} passes, {} bytes read",
                mode.name(),
                cache >> 10,
                out.frames,
                out.passes,
                out.counters.bytes_read
            );
        }
    }
}
