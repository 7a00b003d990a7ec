//! The handheld's whole viewer loop on the host (issue 17, part 5): the depth-6 bunny (5 MB, far
//! more than the Pico 2's 520 KB of RAM) on a real FAT image, as an SD card holds it (an MBR and a
//! FAT16 partition made by `mkfs.fat`, the model copied in by `mcopy`: the main workspace's test
//! fixture `pocketsplat_fixture::fat::make_image`), read by embedded-sdmmc over a block device on the image's
//! bytes, and drawn by [`Viewer::step`] onto a display that records what the panel would show.
//!
//! - `buttons_move_the_camera_and_idle_frames_refine_to_the_resident_frame`: scripted presses move
//!   the camera with coarse frames; once released, idle frames refine, the 1 px frame in passes
//!   through the 64 KB cache, and the panel's last frame has the CRC of the resident render of the
//!   same file and view at 1 px (the firmware's `render_view`, and `pocketsplat render`'s).
//! - `a_pulled_card_leaves_the_marker_and_the_loop_running`: the card stops answering mid-orbit; the
//!   loop goes on drawing what is resident, shows the read-error marker, and comes to rest.
//! - `a_qsplat_model_on_the_card_refines_to_the_resident_frame`: the same loop over `MODEL.QS`.
//! - `a_scene_pack_on_the_card_refines_to_the_resident_frame`: `SCENE.PAK`, two objects with
//!   one-pass shadows, through the [`PackViewer`](pocketsplat_handheld::PackViewer): coarse frames
//!   band by band while the camera moves, then the 1 px frame in passes, band by band, ending on
//!   the resident pack's frame in the same bands.
//!
//! Needs `mkfs.fat` (dosfstools), `mcopy` (mtools) and the bunny scan: without them this fails
//! under CI and is skipped, with a note, elsewhere.

use std::cell::Cell;
use std::convert::Infallible;
use std::rc::Rc;

use embedded_graphics::pixelcolor::raw::RawU16;
use embedded_graphics::pixelcolor::Rgb565;
use embedded_graphics::prelude::*;
use embedded_graphics::primitives::Rectangle;
use embedded_sdmmc::{Block, BlockCount, BlockDevice, BlockIdx};
use pocketsplat_core::camera::{View, HEIGHT, STANDARD_VIEWS, WIDTH};
use pocketsplat_core::crc::Crc32;
use pocketsplat_core::shade::ShadingTable;
use pocketsplat_core::tg::{TriGrid, Verify};
use pocketsplat_core::Model;
use pocketsplat_fixture::fat::{have, make_image};
use pocketsplat_fixture::scan::bunny_tg;
use pocketsplat_handheld::{
    open_model, open_stream, volumes, Button, Clock, ModelSource, Orbit, StepOutcome, StreamTables,
    StreamTargets, Viewer, CACHE_BYTES,
};
use pocketsplat_qemu::stream::{MARKER_COLOR, MARKER_PX};

/// Steps after the last press within which the loop must come to rest.
const MAX_IDLE_STEPS: usize = 5000;

/// A card read failure (the card was pulled).
#[derive(Debug)]
struct Gone;

impl std::fmt::Display for Gone {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("the card is gone")
    }
}

impl std::error::Error for Gone {}

/// An SD card holding a disk image: 512-byte sectors of the image's bytes; every read fails once
/// `pulled` is set.
struct ImageCard {
    image: Vec<u8>,
    pulled: Rc<Cell<bool>>,
}

impl BlockDevice for ImageCard {
    type Error = Gone;

    fn read(&self, blocks: &mut [Block], start: BlockIdx) -> Result<(), Gone> {
        if self.pulled.get() {
            return Err(Gone);
        }
        let mut at = start.0 as usize * Block::LEN;
        for b in blocks.iter_mut() {
            let sector = self.image.get(at..at + Block::LEN).ok_or(Gone)?;
            b.contents.copy_from_slice(sector);
            at += Block::LEN;
        }
        Ok(())
    }

    fn write(&self, _: &[Block], _: BlockIdx) -> Result<(), Gone> {
        panic!("the viewer writes nothing to the card");
    }

    fn num_blocks(&self) -> Result<BlockCount, Gone> {
        Ok(BlockCount((self.image.len() / Block::LEN) as u32))
    }
}

/// A 240×320 panel that keeps what was drawn on it and counts whole-screen writes (frames).
struct Recorder {
    pixels: Vec<u16>,
    frames: usize,
}

impl Recorder {
    fn new() -> Self {
        Recorder {
            pixels: vec![0; WIDTH * HEIGHT],
            frames: 0,
        }
    }

    /// CRC-32 of what the panel shows, as `Framebuffer::crc` computes a frame's.
    fn crc(&self) -> u32 {
        let mut c = Crc32::new();
        c.update_u16_le(&self.pixels);
        c.finish()
    }

    fn at(&self, x: usize, y: usize) -> u16 {
        self.pixels[y * WIDTH + x]
    }
}

impl OriginDimensions for Recorder {
    fn size(&self) -> Size {
        Size::new(WIDTH as u32, HEIGHT as u32)
    }
}

impl DrawTarget for Recorder {
    type Color = Rgb565;
    type Error = Infallible;

    fn draw_iter<I: IntoIterator<Item = Pixel<Rgb565>>>(
        &mut self,
        pixels: I,
    ) -> Result<(), Self::Error> {
        for Pixel(p, c) in pixels {
            if (0..WIDTH as i32).contains(&p.x) && (0..HEIGHT as i32).contains(&p.y) {
                self.pixels[p.y as usize * WIDTH + p.x as usize] = RawU16::from(c).into_inner();
            }
        }
        Ok(())
    }

    fn fill_contiguous<I: IntoIterator<Item = Rgb565>>(
        &mut self,
        area: &Rectangle,
        colors: I,
    ) -> Result<(), Self::Error> {
        if *area == self.bounding_box() {
            self.frames += 1;
        }
        self.draw_iter(area.points().zip(colors).map(|(p, c)| Pixel(p, c)))
    }
}

/// A board timer on which every reading is 300 ms after the last: a slow device, so that frames
/// drawn while a button is held stay coarse.
struct SlowClock(u64);

impl Clock for SlowClock {
    fn now_us(&mut self) -> u64 {
        self.0 += 300_000;
        self.0
    }
}

fn rows() -> Box<[[u16; WIDTH]; HEIGHT]> {
    vec![[0u16; WIDTH]; HEIGHT]
        .into_boxed_slice()
        .try_into()
        .expect("HEIGHT rows")
}

/// The bunny at depth 6 on a FAT image as `MODEL.TG`; `None` (skipped) without the tools or scan.
fn card() -> Option<(Vec<u8>, Vec<u8>)> {
    if !have("mkfs.fat", "dosfstools") | !have("mcopy", "mtools") {
        return None;
    }
    let file = bunny_tg()?;
    let dir = tempfile::tempdir().unwrap();
    let image = std::fs::read(make_image(dir.path(), &file, "MODEL.TG")).unwrap();
    Some((file, image))
}

/// What a run of the loop did.
struct Run {
    outcomes: Vec<StepOutcome>,
    /// Index of the first outcome after the last press.
    released_at: usize,
    view: View,
    /// CRC of what the panel shows at the end.
    panel_crc: u32,
    /// Whole-screen writes to the panel.
    panel_frames: usize,
    /// Whether the panel shows the read-error marker at the end (the whole square red).
    panel_marker: bool,
    /// Bytes the stream read, and the file's size.
    bytes_read: u64,
}

/// Runs the viewer over `image` with `script` (each entry: buttons held for one step), calling
/// `during(step)` before each scripted step, then with nothing held until it comes to rest.
fn run_loop(
    image: Vec<u8>,
    script: &[[bool; 6]],
    pulled: Rc<Cell<bool>>,
    mut during: impl FnMut(usize),
) -> Run {
    let volumes = volumes(ImageCard { image, pulled });
    let mut src = ModelSource::Card(open_model(&volumes).expect("a model on the card"));
    let mut cache = Box::new([0u8; CACHE_BYTES]);
    let mut tables = Box::new(StreamTables::EMPTY);
    let (mut color, mut depth) = (rows(), rows());
    let mut table = Box::new(ShadingTable::<1>::new());
    let stream = open_stream(&mut src, &mut cache, &mut tables).expect("a streamable model");
    let targets = StreamTargets {
        color: &mut color,
        depth: &mut depth,
        table: &mut table,
    };
    let mut viewer = Viewer::new(stream, src, Recorder::new(), SlowClock(0), targets);
    let mut outcomes = Vec::new();
    for (k, &held) in script.iter().enumerate() {
        during(k);
        outcomes.push(viewer.step(held));
    }
    let released_at = outcomes.len();
    for _ in 0..MAX_IDLE_STEPS {
        let o = viewer.step([false; 6]);
        outcomes.push(o);
        if o == StepOutcome::Idle {
            break;
        }
    }
    let panel = viewer.panel();
    let side = MARKER_PX as usize;
    let panel_marker = (2..2 + side)
        .all(|y| (WIDTH - side - 2..WIDTH - 2).all(|x| panel.at(x, y) == MARKER_COLOR));
    Run {
        outcomes,
        released_at,
        view: viewer.view(),
        panel_crc: panel.crc(),
        panel_frames: panel.frames,
        panel_marker,
        bytes_read: viewer.stream().counters().bytes_read,
    }
}

fn info(o: &StepOutcome) -> Option<&pocketsplat_handheld::FrameInfo> {
    match o {
        StepOutcome::Frame(i)
        | StepOutcome::Pass(i)
        | StepOutcome::Refined(i)
        | StepOutcome::GaveUp(i) => Some(i),
        StepOutcome::Idle => None,
    }
}

#[test]
fn buttons_move_the_camera_and_idle_frames_refine_to_the_resident_frame() {
    let Some((file, image)) = card() else {
        return;
    };
    // Six steps of orbit right, three up, two closer.
    let mut script = vec![Button::Right.alone(); 6];
    script.extend([Button::Up.alone(); 3]);
    script.extend([Button::ZoomIn.alone(); 2]);
    let run = run_loop(image, &script, Rc::new(Cell::new(false)), |_| {});

    // The camera moved as the presses say.
    let mut orbit = Orbit::default();
    for &held in &script {
        assert!(orbit.step(held), "every scripted press moves the camera");
    }
    assert_eq!(run.view, orbit.view);
    assert_ne!(run.view, STANDARD_VIEWS[0].1);

    // While a button was held: one coarse whole frame per step, on the panel.
    let (held, idle) = run.outcomes.split_at(run.released_at);
    for (k, o) in held.iter().enumerate() {
        let StepOutcome::Frame(f) = o else {
            panic!("step {k} with a button held: {o:?}, not a whole frame");
        };
        assert!(
            f.cutoff_px >= 4.0,
            "step {k}: cutoff {} px while moving",
            f.cutoff_px
        );
    }

    // Idle: refinement, the 1 px frame in passes (it needs more blocks than 64 KB), then rest.
    let n = idle.len();
    assert_eq!(idle[n - 1], StepOutcome::Idle, "the loop comes to rest");
    let StepOutcome::Refined(last) = idle[n - 2] else {
        panic!(
            "the step before rest is {:?}, not the refined frame",
            idle[n - 2]
        );
    };
    assert_eq!((last.cutoff_px, last.missing), (1.0, 0));
    let passes = idle
        .iter()
        .filter(|o| matches!(o, StepOutcome::Pass(_)))
        .count();
    assert!(
        passes > 0,
        "the 1 px frame of the depth-6 bunny is drawn in passes"
    );
    assert!(
        !run.outcomes
            .iter()
            .any(|o| matches!(o, StepOutcome::GaveUp(_))),
        "a clean card never gives up"
    );
    assert!(
        !run.outcomes.iter().filter_map(info).any(|f| f.marker),
        "a clean card never shows the read-error marker"
    );
    // Passes are drawn off screen: the panel got the whole frames and the refined one.
    let shown = run
        .outcomes
        .iter()
        .filter(|o| matches!(o, StepOutcome::Frame(_) | StepOutcome::Refined(_)))
        .count();
    assert_eq!(run.panel_frames, shown);
    let refined_read: u64 = idle
        .iter()
        .filter(|o| matches!(o, StepOutcome::Pass(_) | StepOutcome::Refined(_)))
        .filter_map(info)
        .map(|f| u64::from(f.read))
        .sum();
    assert!(
        refined_read <= file.len() as u64,
        "the refined frame read {refined_read} bytes, more than the file's {}",
        file.len()
    );

    // The panel's last frame is the resident file's at 1 px: the frame the core's root API draws
    // with its default options (the main workspace's QEMU tests check that the firmware's resident
    // frame is this one too).
    let grid = TriGrid::open(&file, Verify::Full).unwrap();
    let want = core_frame_crc(&Model::from(grid), run.view);
    assert_eq!(
        run.panel_crc, want,
        "the panel's last frame is not the resident render"
    );
    eprintln!(
        "handheld loop: {} steps ({} held, {} whole frames, {} passes), {} of {} bytes read in all, \
         {refined_read} for the refined frame; last frame crc {:#010x}",
        run.outcomes.len(),
        held.len(),
        shown,
        passes,
        run.bytes_read,
        file.len(),
        run.panel_crc
    );
}

/// The bunny baked to `.qs` on a FAT image as `MODEL.QS` (and no `MODEL.TG`): the same loop, same
/// script, comes to rest on the resident file's 1 px frame (issue 31).
#[test]
fn a_qsplat_model_on_the_card_refines_to_the_resident_frame() {
    if !have("mkfs.fat", "dosfstools") | !have("mcopy", "mtools") {
        return;
    }
    let Some(path) = pocketsplat_fixture::models::model("bun_zipper.ply.gz") else {
        return;
    };
    let mesh = pocketsplat_fixture::scan::read_ascii_ply(&path);
    let file = pocketsplat_core::qs::write::bake_qs(&mesh, &Default::default())
        .unwrap()
        .bytes;
    let dir = tempfile::tempdir().unwrap();
    let image = std::fs::read(make_image(dir.path(), &file, "MODEL.QS")).unwrap();
    let mut script = vec![Button::Right.alone(); 3];
    script.extend([Button::ZoomIn.alone(); 2]);
    let run = run_loop(image, &script, Rc::new(Cell::new(false)), |_| {});
    let n = run.outcomes.len();
    assert_eq!(
        run.outcomes[n - 1],
        StepOutcome::Idle,
        "the loop comes to rest"
    );
    let StepOutcome::Refined(last) = run.outcomes[n - 2] else {
        panic!("the step before rest is {:?}", run.outcomes[n - 2]);
    };
    assert_eq!((last.cutoff_px, last.missing), (1.0, 0));
    assert!(
        !run.outcomes.iter().filter_map(info).any(|f| f.marker),
        "a clean card never shows the read-error marker"
    );
    let qs = pocketsplat_core::qs::QSplat::open(&file).unwrap();
    let want = core_frame_crc(&Model::from(qs), run.view);
    assert_eq!(
        run.panel_crc, want,
        "the panel's last frame is not the resident render"
    );
    let passes = run
        .outcomes
        .iter()
        .filter(|o| matches!(o, StepOutcome::Pass(_)))
        .count();
    eprintln!(
        "handheld loop, MODEL.QS ({} bytes): {} steps, {passes} passes, {} bytes read in all; \
         last frame crc {:#010x}",
        file.len(),
        run.outcomes.len(),
        run.bytes_read,
        run.panel_crc
    );
}

#[test]
fn a_pulled_card_leaves_the_marker_and_the_loop_running() {
    let Some((_, image)) = card() else {
        return;
    };
    let script = vec![Button::Left.alone(); 8];
    let pulled = Rc::new(Cell::new(false));
    let pull = pulled.clone();
    // Pulled after four frames of the orbit.
    let run = run_loop(image, &script, pulled, |k| pull.set(k >= 4));
    let n = run.outcomes.len();
    assert!(n < script.len() + MAX_IDLE_STEPS, "the loop comes to rest");
    assert_eq!(run.outcomes[n - 1], StepOutcome::Idle);
    assert!(
        matches!(run.outcomes[n - 2], StepOutcome::GaveUp(_)),
        "refinement gives up: {:?}",
        run.outcomes[n - 2]
    );
    let marked = run
        .outcomes
        .iter()
        .filter_map(info)
        .filter(|f| f.marker)
        .count();
    assert!(marked > 0, "frames after the pull carry the marker");
    assert!(run.panel_marker, "the panel shows the marker at rest");
    eprintln!(
        "pulled card: {n} steps, {marked} marked, {} bytes read",
        run.bytes_read
    );
}

/// A version 2 `MODEL.TG` (as baked before version 3) cannot be streamed: opening it says which
/// version it is, for the panel's message to say how to convert it.
#[test]
fn a_version_2_model_is_refused_with_its_version() {
    use pocketsplat_core::tg::write::{rewrite_tg, Layout};
    use pocketsplat_handheld::LoadError;
    // The core's example model, written again in both versions.
    let example = include_bytes!("../../../core/examples/data/trefoil.tg");
    let grid = TriGrid::open(example, Verify::Full).unwrap();
    let v2 = rewrite_tg(&grid, Layout::Version2).unwrap();
    let v3 = rewrite_tg(&grid, Layout::Bricked).unwrap();
    let mut tables = Box::new(StreamTables::EMPTY);
    let mut cache = Box::new([0u8; CACHE_BYTES]);
    let mut src = pocketsplat_core::stream::MemSource::new(&v2);
    let err = open_stream(&mut src, &mut cache, &mut tables).err();
    assert_eq!(err, Some(LoadError::OldVersion(2)));
    assert!(err.unwrap().to_string().contains("pocketsplat migrate"));
    let mut src = pocketsplat_core::stream::MemSource::new(&v3);
    assert!(open_stream(&mut src, &mut cache, &mut tables).is_ok());
}

/// CRC of `model` seen from `view` at 1 px, drawn by the core's root API alone (`render` with
/// `RenderOptions::default()` into a `Framebuffer`): the reference the firmware's frame must equal.
fn core_frame_crc(model: &Model<'_>, view: View) -> u32 {
    use pocketsplat_core::{render, Framebuffer, RenderOptions, Target};
    let mut color = Box::new([[0u16; WIDTH]; HEIGHT]);
    let mut depth = Box::new([[0u16; WIDTH]; HEIGHT]);
    let mut table = Box::new(ShadingTable::<1>::new());
    let camera = model.orbit(view);
    let options = RenderOptions {
        cutoff_px: 1.0,
        ..model.options()
    };
    {
        let mut target = Target::new(Framebuffer::new(&mut color, &mut depth), &mut table);
        render(model, &camera, &options, &mut target).unwrap();
    }
    Framebuffer::new(&mut color, &mut depth).crc()
}

/// A scene pack on the card as `SCENE.PAK` (and no model): two objects, the depth-6 bunny as a
/// tri-grid (5 MB in 4 KB blocks) and the coarse bunny scan as a QSplat file beside it, with one-pass shadows. The
/// same script moves the camera with coarse frames from what is resident; once released the loop
/// refines the 1 px frame band by band through the pack's 80 KB cache, and the panel's last frame
/// has the CRC of the pack opened whole, drawn by the core's root API in the same four bands with
/// the same 128² map (issue 31).
#[test]
fn a_scene_pack_on_the_card_refines_to_the_resident_frame() {
    use pocketsplat_core::camera::{Placement, Sphere};
    use pocketsplat_core::scene::write::{write_pack, PackContents, PackObject};
    use pocketsplat_core::scene::{Kind, Pack, Scene};
    use pocketsplat_core::shade::{ShadowMode, DEFAULT_MATERIAL};
    use pocketsplat_handheld::{open_scene, Arena, PackViewer};
    if !have("mkfs.fat", "dosfstools") | !have("mcopy", "mtools") {
        return;
    }
    let Some(tg) = bunny_tg() else {
        return;
    };
    // The coarser scan for the QSplat object: a QSplat stream's least cache is 68 blocks of 2 KB
    // or its whole file, and the 80 KB the pack's objects share must hold the grid's too.
    let Some(coarse) = pocketsplat_fixture::models::model("bun_zipper_res3.ply") else {
        return;
    };
    let coarse = pocketsplat_fixture::scan::read_ascii_ply(&coarse);
    let qs = pocketsplat_core::qs::write::bake_qs(&coarse, &Default::default())
        .unwrap()
        .bytes;
    let object = |name: &str, kind, data: &[u8], x: f64| PackObject {
        name: name.into(),
        kind,
        data: data.to_vec(),
        // The scans are 0.15 m tall: six times that, side by side.
        placement: Placement {
            scale: 6.0,
            translation: [x, -0.66, 0.0],
            ..Placement::IDENTITY
        },
        slots: vec![0],
        casts_shadows: true,
        ground: false,
        in_bounds: true,
        depth_asked: 6,
        depth_kept: 6,
        savings: Default::default(),
    };
    let file = write_pack(&PackContents {
        objects: vec![
            object("grid", Kind::TriGrid, &tg, -0.45),
            object("splats", Kind::QSplat, &qs, 0.55),
        ],
        materials: vec![("clay".into(), DEFAULT_MATERIAL)],
        views: vec![("std".into(), View::new(20.0, 25.0, 2.2))],
        path: vec![],
        light_az_el: (-40.0, 55.0),
        shadows: ShadowMode::OnePass,
        shadow_map_size: 256,
        fov_deg: 45.0,
        min_cell_px: 0.0,
        sphere: Sphere {
            center: [0.0; 3],
            radius: 1.2,
        },
        align_log2: 10,
    })
    .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let image = std::fs::read(make_image(dir.path(), &file, "SCENE.PAK")).unwrap();

    let volumes = volumes(ImageCard {
        image,
        pulled: Rc::new(Cell::new(false)),
    });
    let mut src = ModelSource::Card(open_model(&volumes).expect("the pack on the card"));
    let arena: &'static mut Arena<'static> = Box::leak(Box::new(Arena::Free));
    let (stream, targets) = open_scene(&mut src, arena.pack()).expect("a streamable pack");
    let mut viewer = PackViewer::new(stream, src, Recorder::new(), SlowClock(0), targets);
    let mut outcomes = Vec::new();
    for held in [
        Button::Right.alone(),
        Button::Right.alone(),
        Button::ZoomIn.alone(),
    ] {
        outcomes.push(viewer.step(held));
    }
    let max_steps = 2 * pocketsplat_qemu::pack_stream::PACK_MAX_PASSES as usize;
    for _ in 0..max_steps {
        let o = viewer.step([false; 6]);
        outcomes.push(o);
        if o == StepOutcome::Idle {
            break;
        }
    }
    let n = outcomes.len();
    assert_eq!(outcomes[n - 1], StepOutcome::Idle, "the loop comes to rest");
    let StepOutcome::Refined(last) = outcomes[n - 2] else {
        panic!("the step before rest is {:?}", outcomes[n - 2]);
    };
    assert_eq!((last.cutoff_px, last.missing), (1.0, 0));
    assert!(matches!(outcomes[0], StepOutcome::Frame(f) if f.cutoff_px == 4.0));
    assert!(
        !outcomes.iter().filter_map(info).any(|f| f.marker),
        "a clean card never shows the read-error marker"
    );
    let passes = outcomes
        .iter()
        .filter(|o| matches!(o, StepOutcome::Pass(_)))
        .count();

    // The pack opened whole, drawn band by band as the viewer draws it.
    let scene = Scene::open(Pack::open(&file).unwrap(), Verify::Full).unwrap();
    let want = resident_pack_crc(scene, viewer.view());
    assert_eq!(
        viewer.panel().crc(),
        want,
        "the panel's last frame is not the resident render"
    );
    eprintln!(
        "handheld loop, SCENE.PAK ({} bytes, 2 objects, one-pass shadows): {n} steps, {passes} \
         passes, {} bytes read in all; last frame crc {want:#010x}",
        file.len(),
        viewer.stream().counters().bytes_read,
    );
}

/// CRC of `scene` seen from `view` at 1 px with its shadows in a map of at most
/// `PACK_MAP_SIZE`², drawn by the core's root API in the streamed pack's bands.
fn resident_pack_crc(scene: pocketsplat_core::scene::Scene<'_>, view: View) -> u32 {
    use pocketsplat_core::raster::Band;
    use pocketsplat_core::shadow::LightFrame;
    use pocketsplat_core::{render, Framebuffer, Model, Target};
    use pocketsplat_qemu::pack_stream::{PACK_BANDS, PACK_BAND_ROWS, PACK_MAP_SIZE};
    let mut color = Box::new([[0u16; WIDTH]; PACK_BAND_ROWS]);
    let mut depth = Box::new([[0u16; WIDTH]; PACK_BAND_ROWS]);
    let mut table = Box::new(pocketsplat_qemu::scene::SceneTable::new());
    let mut map = vec![0u16; PACK_MAP_SIZE * PACK_MAP_SIZE];
    let mut light = Box::new(LightFrame::UNSET);
    let camera = scene.camera(view);
    let mut options = scene.options().with_cutoff(1.0);
    let model = Model::Scene(scene);
    options.shadow_map_size = options.shadow_map_size.min(PACK_MAP_SIZE);
    let mut crc = Crc32::new();
    for band in 0..PACK_BANDS {
        let top = (band * PACK_BAND_ROWS) as u16;
        let target = Target::new(Framebuffer::new(&mut color, &mut depth), &mut table)
            .with_shadows(&mut map, &mut light);
        let mut target = target.map_pixels(|f| Band::new(f, top, pocketsplat_qemu::PANEL).unwrap());
        render(&model, &camera, &options, &mut target).unwrap();
        crc.update_u16_le(color.as_flattened());
    }
    crc.finish()
}
