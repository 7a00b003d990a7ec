//! Frames drawn in horizontal bands (issue 31, item 4: a device with less RAM than a frame's colour
//! and depth draws the panel a band at a time, `raster::Band`): the bands put together must be the
//! whole frame, bit for bit, in every shadow mode, for a single tri-grid and for a scene pack with
//! a QSplat object, whatever the number of bands (one that does not divide the height leaves a
//! shorter last band). One-pass shadows are the case that could fail: their map is filled as the
//! walk goes, so a band whose walk skipped what lies outside it would shade differently.

use pocketsplat_core::bake::{bake_grid, BakeOptions};
use pocketsplat_core::camera::View;
use pocketsplat_core::scene::{Pack, Scene};
use pocketsplat_core::tg::write::write_tg;
use pocketsplat_core::tg::{TriGrid, Verify};
use pocketsplat_sim::render::{render_tg_frame, FrameBuffers, Settings, ShadowMode};
use pocketsplat_sim::scene::render::{render_pack, PackSettings};

const BANDS: [u16; 3] = [2, 7, 40];

#[test]
fn a_tri_grid_drawn_in_bands_is_the_whole_frame() {
    let mesh = pocketsplat_sim::demo::trefoil(160, 16, 0.3);
    let grid = bake_grid(&mesh, BakeOptions { rho: 3, depth: 5 }, None).unwrap();
    let bytes = write_tg(&grid, 12).unwrap();
    let grid = TriGrid::open(&bytes, Verify::Full).unwrap();
    for mode in [ShadowMode::Off, ShadowMode::OnePass, ShadowMode::TwoPass] {
        for (view, cutoff_px) in [
            (View::new(30.0, 20.0, 1.6), 1.0),
            (View::new(-70.0, 50.0, 1.1), 3.0),
        ] {
            let settings = Settings {
                view,
                shadows: mode,
                cutoff_px,
                ..Settings::default()
            };
            let mut whole = FrameBuffers::new();
            let w = render_tg_frame(&grid, &settings, &mut whole).unwrap();
            assert!(w.stats.splats > 1000, "{mode:?}: the model is not in view");
            for bands in BANDS {
                let mut fb = FrameBuffers::new().in_bands(bands);
                let b = render_tg_frame(&grid, &settings, &mut fb).unwrap();
                assert_eq!(fb.crc(), whole.crc(), "{mode:?} {view:?} in {bands} bands");
                assert_eq!(
                    fb.depths(),
                    whole.depths(),
                    "{mode:?} {view:?} depth, {bands} bands"
                );
                assert_eq!(
                    b.stats.splats, w.stats.splats,
                    "{mode:?}: each band's walk is the frame's"
                );
            }
        }
    }
}

#[test]
fn a_scene_pack_drawn_in_bands_is_the_whole_frame() {
    let dir = tempfile::tempdir().unwrap();
    let bytes = crate::stream_pack::generated_pack(dir.path());
    let pack = Pack::open(&bytes).unwrap();
    let scene = Scene::open(pack, Verify::Full).unwrap();
    let view = pack.view_named("v").unwrap();
    let mut shaded = Vec::new();
    for mode in [ShadowMode::Off, ShadowMode::OnePass, ShadowMode::TwoPass] {
        let mut s = PackSettings::new(view);
        s.shadows = Some(mode);
        let mut whole = FrameBuffers::new();
        render_pack(&scene, &s, &mut whole).unwrap();
        shaded.push(whole.crc());
        for bands in BANDS {
            let mut fb = FrameBuffers::new().in_bands(bands);
            render_pack(&scene, &s, &mut fb).unwrap();
            assert_eq!(fb.crc(), whole.crc(), "{mode:?} in {bands} bands");
        }
    }
    // The shadows show: a test of them could fail.
    assert_ne!(shaded[0], shaded[1], "no shadows in the view");
}
