//! `.qs` objects in scenes (issue 8): a pack with a QSplat object draws what the single-model
//! QSplat renderer draws, z-tests against a tri-grid ground, and the pack reader knows kind 2 only.

use std::path::Path;

use pocketsplat_core::camera::{Camera, View};
use pocketsplat_core::crc::crc32;
use pocketsplat_core::qs::write::{bake_qs, QsBakeOptions};
use pocketsplat_core::qs::QSplat;
use pocketsplat_core::scene::{Kind, Pack, PackError, Scene, SceneError, ShadowMode};
use pocketsplat_core::tg::Verify;

use super::bake::bake_path;
use super::render::{render_pack_from, scene_table, PackSettings};
use crate::render::{FrameBuffers, Settings};

/// A small `.qs` of the trefoil knot, without colours (shaded by its material alone).
fn trefoil_qs() -> Vec<u8> {
    let mesh = crate::demo::trefoil(96, 12, 0.35);
    bake_qs(
        &mesh,
        &QsBakeOptions {
            colors: false,
            comment: true,
        },
    )
    .expect("trefoil bakes")
    .bytes
}

fn write_scene(dir: &Path, toml: &str) -> std::path::PathBuf {
    std::fs::write(dir.join("knot.qs"), trefoil_qs()).unwrap();
    let path = dir.join("scene.toml");
    std::fs::write(&path, toml).unwrap();
    path
}

const MATERIALS: &str = r#"
[light]
az = -40.0
el = 60.0

[materials.red]
color = [0.9, 0.2, 0.1]

[materials.green]
color = [0.1, 0.8, 0.2]
"#;

fn render(scene: &Scene<'_>, camera: &Camera, shadows: ShadowMode, out: &mut FrameBuffers) {
    let mut opts = PackSettings::new(View::new(0.0, 0.0, 1.0)).options(scene);
    opts.shadows = shadows;
    let mut table = scene_table();
    render_pack_from(scene, camera, &opts, None, &mut table, out, |_, _| {}).expect("renders");
}

#[test]
fn a_scene_qs_object_draws_what_the_qsplat_renderer_draws() {
    let dir = tempfile::tempdir().unwrap();
    let view = View::new(30.0, 20.0, 2.5);
    let path = write_scene(
        dir.path(),
        &format!(
            "{MATERIALS}\n[[objects]]\nname = \"knot\"\nfile = \"knot.qs\"\nmaterial = \"red\"\n\n\
             [[views]]\nname = \"v\"\naz = 30.0\nel = 20.0\ndist = 2.5\n"
        ),
    );
    let baked = bake_path(&path, &Default::default()).expect("bakes");
    let pack = Pack::open(&baked.bytes).unwrap();
    assert_eq!(pack.object(0).unwrap().kind, Kind::QSplat);
    let scene = Scene::open(pack, Verify::Full).unwrap();
    assert!(scene.grid(0).is_none(), "grid() stays tri-grids only");
    let file = *scene.qsplat(0).expect("a QSplat object");
    let cam = scene.camera(view);
    let mut a = FrameBuffers::new();
    render(&scene, &cam, ShadowMode::Off, &mut a);

    let settings = Settings {
        view,
        fov_deg: pack.fov_deg(),
        cutoff_px: 1.0,
        material: pack.material(0).unwrap().material,
        light_az_el: pack.light_az_el(),
        ..Settings::default()
    };
    assert_eq!(settings.camera(file.bounds()), cam, "the same camera");
    let mut b = FrameBuffers::new();
    let mut table = Box::new(pocketsplat_core::shade::ShadingTable::<1>::new());
    let model = pocketsplat_core::render::Model::QSplat(file);
    crate::render::render_with(&model, &settings, &cam, &mut table, &mut b, |_, _| {}).unwrap();

    let (mut covered, mut mismatch, mut equal) = (0usize, 0usize, 0usize);
    for (&pa, &pb) in a.pixels().iter().zip(b.pixels()) {
        covered += usize::from(pb != 0);
        mismatch += usize::from((pa != 0) != (pb != 0));
        equal += usize::from(pa != 0 && pa == pb);
    }
    assert!(covered > 2000, "the knot covers {covered} pixels");
    let total = a.pixels().len();
    assert!(
        (mismatch as f64) < 0.005 * total as f64,
        "coverage differs at {mismatch} of {total} pixels"
    );
    assert!(
        equal as f64 > 0.95 * covered as f64,
        "only {equal} of {covered} pixels equal"
    );
}

fn ground_and_knot(dir: &Path, with_ground: bool, with_knot: bool, shadows: &str) -> Vec<u8> {
    let mut toml = format!("{MATERIALS}\n[shadows]\nmode = \"{shadows}\"\nmap_size = 256\n");
    if with_ground {
        toml += "\n[[objects]]\nname = \"ground\"\nground = { size = 4.0 }\ndepth = 4\n\
                 material = \"green\"\n";
    }
    if with_knot {
        toml += "\n[[objects]]\nname = \"knot\"\nfile = \"knot.qs\"\nmaterial = \"red\"\n\
                 height = 1.2\nanchor = \"base\"\ntranslate = [0.3, 0.0, -0.2]\n\
                 rotate = { yaw = 35.0, pitch = 20.0, roll = 10.0 }\n";
    }
    let path = write_scene(dir, &toml);
    bake_path(&path, &Default::default()).expect("bakes").bytes
}

#[test]
fn a_scene_qs_object_z_tests_against_a_tri_grid_ground() {
    let dir = tempfile::tempdir().unwrap();
    for shadows in ["off", "one-pass", "two-pass"] {
        let both = ground_and_knot(dir.path(), true, true, shadows);
        let ground = ground_and_knot(dir.path(), true, false, shadows);
        let knot = ground_and_knot(dir.path(), false, true, shadows);
        fn open(b: &[u8]) -> Scene<'_> {
            Scene::open(Pack::open(b).unwrap(), Verify::Full).unwrap()
        }
        let (s_both, s_ground, s_knot) = (open(&both), open(&ground), open(&knot));
        let mode = s_both.pack().shadows();
        // One camera for the three: the full scene's.
        let cam = s_both.camera(View::new(20.0, 30.0, 2.2));
        let (mut a, mut g, mut k) = (
            FrameBuffers::new(),
            FrameBuffers::new(),
            FrameBuffers::new(),
        );
        render(&s_both, &cam, mode, &mut a);
        render(&s_ground, &cam, mode, &mut g);
        render(&s_knot, &cam, mode, &mut k);
        let (mut ground_seen, mut knot_seen, mut overlap, mut knot_wins) = (0, 0, 0, 0);
        {
            for ((&pa, &pg), &pk) in a.pixels().iter().zip(g.pixels()).zip(k.pixels()) {
                if pk == 0 && pg != 0 && pa == pg {
                    ground_seen += 1;
                }
                if pk != 0 && pa == pk {
                    knot_seen += 1;
                }
                if pk != 0 && pg != 0 {
                    overlap += 1;
                    knot_wins += usize::from(pa == pk);
                }
            }
        }
        assert!(
            ground_seen > 2000,
            "{shadows}: ground seen at {ground_seen}"
        );
        assert!(knot_seen > 1000, "{shadows}: knot seen at {knot_seen}");
        assert!(
            overlap > 500,
            "{shadows}: the knot is in front of the ground"
        );
        assert!(
            knot_wins as f64 > 0.99 * overlap as f64,
            "{shadows}: the knot occludes the ground behind it at only {knot_wins} of {overlap}"
        );
    }
}

/// Sets object 0's kind byte and makes the CRC match again.
fn with_kind(bytes: &[u8], kind: u8) -> Vec<u8> {
    let mut b = bytes.to_vec();
    b[128 + 16] = kind;
    let meta = u32::from_le_bytes(b[16..20].try_into().unwrap()) as usize;
    let crc = crc32(&b[16..meta]);
    b[12..16].copy_from_slice(&crc.to_le_bytes());
    b
}

#[test]
fn scene_pack_reader_accepts_kind_2_and_rejects_kind_3() {
    let dir = tempfile::tempdir().unwrap();
    let knot = ground_and_knot(dir.path(), false, true, "off");
    assert_eq!(
        Pack::open(&knot).unwrap().object(0).unwrap().kind,
        Kind::QSplat
    );
    assert_eq!(
        Pack::open(&with_kind(&knot, 3)).unwrap_err(),
        PackError::UnknownKind { object: 0, kind: 3 }
    );
    // A .tg object said to be QSplat: the pack is fine, its file is not a .qs file.
    let ground = ground_and_knot(dir.path(), true, false, "off");
    let lying = with_kind(&ground, 2);
    let pack = Pack::open(&lying).unwrap();
    assert!(matches!(
        Scene::open(pack, Verify::Full),
        Err(SceneError::QSplatObject { object: 0, .. })
    ));
    // And a .qs object said to be a tri-grid fails the tri-grid reader.
    let as_tg = with_kind(&knot, 1);
    let pack = Pack::open(&as_tg).unwrap();
    assert!(matches!(
        Scene::open(pack, Verify::Full),
        Err(SceneError::Object { object: 0, .. })
    ));
    assert!(QSplat::open(Pack::open(&knot).unwrap().object(0).unwrap().data).is_ok());
}

#[test]
fn scene_qs_objects_take_one_material_and_no_depth() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_scene(
        dir.path(),
        &format!(
            "{MATERIALS}\n[[objects]]\nname = \"knot\"\nfile = \"knot.qs\"\n\
             materials = [\"red\", \"green\"]\n"
        ),
    );
    let e = format!("{:#}", bake_path(&path, &Default::default()).unwrap_err());
    assert!(
        e.contains("scene.toml") && e.contains("\"knot\"") && e.contains("one material"),
        "{e}"
    );
    let path = write_scene(
        dir.path(),
        &format!("{MATERIALS}\n[[objects]]\nname = \"knot\"\nfile = \"knot.qs\"\nmaterial = \"red\"\ndepth = 3\n"),
    );
    let e = format!("{:#}", bake_path(&path, &Default::default()).unwrap_err());
    assert!(e.contains("\"knot\"") && e.contains(".qs"), "{e}");
}
