//! What the fuzz targets share: small `.tg` files baked in-process, and one function that opens a
//! file every way the program does and renders it every way it can, checking the traversal's bounds.
//!
//! Any panic here is a finding: the readers must answer every input with a value or an error.

use std::cell::RefCell;
use std::sync::OnceLock;

use pocketsplat_core::bake::{BakeOptions, TriMesh};
use pocketsplat_core::camera::{Placement, View};
use pocketsplat_core::raster::Kernel;
use pocketsplat_core::render::Model;
use pocketsplat_core::render::RenderOptions;
use pocketsplat_core::shade::ShadingTable;
use pocketsplat_core::splat::NullSink;
use pocketsplat_core::tg::{render_tg, TgFrame, TriGrid, Verify};
use pocketsplat_sim::render::{render_with, FrameBuffers, Settings, ShadowMode};

/// Smallest block (512 B) keeps the files, and so the fuzzer's inputs, small.
pub const BLOCK_LOG2: u8 = 9;

/// The built-in demo's trefoil knot, coarser, with a material and a colour per vertex when asked.
pub fn trefoil(materials: bool, colors: bool) -> TriMesh {
    let mut mesh = pocketsplat_sim::demo::trefoil(48, 6, 0.45);
    if materials {
        mesh.materials = Some((0..mesh.triangles.len()).map(|t| (t % 3) as u8).collect());
    }
    if colors {
        mesh.colors = Some(
            (0..mesh.positions.len())
                .map(|v| [(v * 37) as u8, (v * 11) as u8, 200])
                .collect(),
        );
    }
    mesh
}

/// Valid `.tg` files to mutate: ρ = 3 and ρ = 2, with and without materials and colours.
pub fn base_files() -> &'static [Vec<u8>] {
    base_files_at(BLOCK_LOG2)
}

/// [`base_files`] with blocks of `2^log2` bytes: 512 B, 4 KB or 64 KB (anything else is 512 B).
pub fn base_files_at(log2: u8) -> &'static [Vec<u8>] {
    static FILES: [OnceLock<Vec<Vec<u8>>>; 3] = [OnceLock::new(), OnceLock::new(), OnceLock::new()];
    let (slot, log2) = match log2 {
        12 => (1, 12),
        16 => (2, 16),
        _ => (0, BLOCK_LOG2),
    };
    FILES[slot].get_or_init(|| {
        [
            (false, false, 3, 3),
            (true, true, 3, 2),
            (false, false, 2, 5),
            (false, true, 2, 3),
        ]
        .into_iter()
        .map(|(materials, colors, rho, depth)| {
            let mesh = trefoil(materials, colors);
            let (_, bytes) =
                pocketsplat_sim::bake::bake_mesh(&mesh, BakeOptions { rho, depth }, log2, false)
                    .expect("the trefoil bakes");
            bytes
        })
        .collect()
    })
}

/// How to look at a grid: everything a user can choose on the command line, as raw `f32` bits so
/// that extremes are reached. A number the command line would refuse falls back to its default.
#[derive(Clone, Copy, Debug, arbitrary::Arbitrary)]
pub struct Look {
    /// Azimuth, degrees (any finite value).
    pub az: u32,
    /// Elevation, degrees (any finite value).
    pub el: u32,
    /// Distance in bounding-sphere radii (finite, > 0).
    pub dist: u32,
    /// Vertical field of view, degrees (0 < fov < 180).
    pub fov: u32,
    /// Cutoff, pixels (finite, > 0).
    pub cutoff: u32,
    /// Light azimuth and elevation, degrees (finite).
    pub light: (u32, u32),
    /// Round kernel.
    pub round: bool,
    /// 0 off, 1 one-pass, 2 two-pass shadows.
    pub shadows: u8,
}

fn number(bits: u32, ok: impl Fn(f64) -> bool, default: f64) -> f64 {
    let v = f64::from(f32::from_bits(bits));
    if v.is_finite() && ok(v) {
        v
    } else {
        default
    }
}

impl Look {
    /// The render settings this stands for, as `pocketsplat render` would accept them.
    pub fn settings(&self) -> Settings {
        let any = |_: f64| true;
        Settings {
            view: View {
                az_deg: number(self.az, any, 30.0),
                el_deg: number(self.el, any, 20.0),
                dist: number(self.dist, |d| d > 0.0, 2.5),
            },
            fov_deg: number(self.fov, |f| f > 0.0 && f < 180.0, 45.0),
            cutoff_px: number(self.cutoff, |c| c > 0.0, 1.0) as f32,
            kernel: if self.round {
                Kernel::Round
            } else {
                Kernel::Square
            },
            light_az_el: (
                number(self.light.0, any, -40.0),
                number(self.light.1, any, 60.0),
            ),
            shadows: match self.shadows % 3 {
                0 => ShadowMode::Off,
                1 => ShadowMode::OnePass,
                _ => ShadowMode::TwoPass,
            },
            shadow_map_size: 64,
            ..Settings::default()
        }
    }

    /// A look from plain numbers.
    pub fn new(view: View, cutoff_px: f32, shadows: u8) -> Self {
        Look {
            az: (view.az_deg as f32).to_bits(),
            el: (view.el_deg as f32).to_bits(),
            dist: (view.dist as f32).to_bits(),
            fov: 45f32.to_bits(),
            cutoff: cutoff_px.to_bits(),
            light: ((-40f32).to_bits(), 60f32.to_bits()),
            round: false,
            shadows,
        }
    }
}

/// Opens `bytes` as the program does (`Verify::Full` for files, `Verify::Structure` for flash) and
/// renders whatever opens, through the real raster when `raster`. A file that passes `Full` passes
/// `Structure`.
pub fn open_and_render(bytes: &[u8], looks: &[Look], raster: bool) {
    let full = TriGrid::open(bytes, Verify::Full);
    let structure = TriGrid::open(bytes, Verify::Structure);
    if full.is_ok() {
        assert!(structure.is_ok(), "Full accepts what Structure rejects");
    }
    if let Ok(grid) = structure {
        for look in looks {
            render_checked(&grid, look, raster);
        }
    }
}

thread_local! {
    /// Frame buffers and shading table, kept between runs (the table is rebuilt only on change).
    static RASTER: RefCell<(FrameBuffers, Box<ShadingTable<1>>)> =
        RefCell::new((FrameBuffers::new(), Box::new(ShadingTable::new())));
}

/// Renders one frame through the traversal alone (a `NullSink`) and, when `raster`, through the
/// real raster with shadows as asked, and checks the bounds the traversal promises: at most one
/// visit per sample per pass, no level deeper than the file.
pub fn render_checked(grid: &TriGrid<'_>, look: &Look, raster: bool) {
    let settings = look.settings();
    let h = grid.header();
    let total = grid.total_samples();
    let cam = settings.camera(h.bounds);
    let opts = RenderOptions {
        cutoff_px: settings.cutoff_px,
        kernel: settings.kernel,
        ..RenderOptions::default()
    };
    let Ok(frame) = TgFrame::new(h, &Placement::IDENTITY, &cam, &opts) else {
        return;
    };
    let mut sink = NullSink::default();
    let stats = render_tg(grid, &frame, &mut sink);
    assert!(
        u64::from(stats.nodes_visited) <= total,
        "{stats:?} > {total}"
    );
    assert!(stats.max_level <= h.depth);
    assert!(stats.splats <= stats.nodes_visited);
    if !raster {
        return;
    }
    RASTER.with_borrow_mut(|(fb, table)| {
        let model = Model::TriGrid(*grid);
        let cam = settings.camera_for(&model);
        let Ok(report) = render_with(&model, &settings, &cam, table, fb, |_, _| {}) else {
            return;
        };
        let passes = if settings.shadows == ShadowMode::TwoPass {
            2
        } else {
            1
        };
        let s = report.stats;
        assert!(
            u64::from(s.nodes_visited) <= passes * total,
            "{s:?} > {passes} x {total}"
        );
        assert!(s.max_level <= h.depth);
        if settings.shadows == ShadowMode::Off {
            assert_eq!(s, stats, "the raster changes what the traversal visits");
        }
    });
}

/// Recomputes only the header block's CRC (what a file damaged after block 0 looks like).
pub fn seal_header(bytes: &mut [u8]) {
    let Some(&log2) = bytes.get(12) else {
        return;
    };
    if !(9..=16).contains(&log2) || bytes.len() < 1 << log2 {
        return;
    }
    let bs = 1usize << log2;
    let c = pocketsplat_core::crc::crc32(&bytes[..bs - 4]);
    bytes[bs - 4..bs].copy_from_slice(&c.to_le_bytes());
}

/// One of `files` changed as `data` says: its first byte picks the file, then 5-byte edits
/// (offset u32 LE, xor), at most 32. `None` for an empty input.
pub fn edited(files: &[Vec<u8>], data: &[u8]) -> Option<Vec<u8>> {
    let (&pick, edits) = data.split_first()?;
    let mut bytes = files[usize::from(pick) % files.len()].clone();
    for e in edits.chunks_exact(5).take(32) {
        let at = u32::from_le_bytes([e[0], e[1], e[2], e[3]]) as usize % bytes.len();
        bytes[at] ^= e[4];
    }
    Some(bytes)
}

/// Valid `.qs` files to mutate: the trefoil with and without colours.
pub fn qs_base_files() -> &'static [Vec<u8>] {
    use pocketsplat_core::qs::write::{bake_qs, QsBakeOptions};
    static FILES: OnceLock<Vec<Vec<u8>>> = OnceLock::new();
    FILES.get_or_init(|| {
        [false, true]
            .into_iter()
            .map(|colors| {
                let mesh = pocketsplat_sim::demo::trefoil(24, 5, 0.45);
                let mesh = TriMesh {
                    colors: colors.then(|| vec![[200, 40, 90]; mesh.positions.len()]),
                    ..mesh
                };
                let opts = QsBakeOptions {
                    colors,
                    comment: colors,
                };
                bake_qs(&mesh, &opts).expect("the trefoil bakes").bytes
            })
            .collect()
    })
}

/// Opens `bytes` as a `.qs` file and renders what opens from each look through a `NullSink` and
/// the real raster, checking that no node is visited twice.
pub fn qs_open_and_render(bytes: &[u8], looks: &[Look]) {
    use pocketsplat_core::camera::{Camera, Sphere};
    use pocketsplat_core::qs::{render_qs, QSplat, QsFrame};
    let Ok(file) = QSplat::open(bytes) else {
        return;
    };
    let c = file.counts();
    let nodes = c.leaves + c.interior + u64::from(c.trees);
    for look in looks {
        let s = look.settings();
        let cam = Camera::orbit(Sphere::from_bounds(file.bounds()), s.view, s.fov_deg);
        let opts = RenderOptions {
            cutoff_px: s.cutoff_px,
            kernel: s.kernel,
            ..RenderOptions::default()
        };
        let Ok(frame) = QsFrame::new(&file, &Placement::IDENTITY, &cam, &opts) else {
            continue;
        };
        let stats = render_qs(&file, &frame, &mut NullSink::default());
        assert!(
            u64::from(stats.nodes_visited) <= nodes,
            "{stats:?} > {nodes}"
        );
        assert!(stats.splats <= stats.nodes_visited);
        RASTER.with_borrow_mut(|(fb, table)| {
            // Through the program's pipeline (the core's `render`), colours and all.
            let model = Model::QSplat(file);
            let settings = Settings {
                shadows: ShadowMode::Off,
                ..s
            };
            let Ok(again) = render_with(&model, &settings, &cam, table, fb, |_, _| {}) else {
                return;
            };
            assert_eq!(
                again.stats, stats,
                "the raster changes what the traversal visits"
            );
        });
    }
}

/// Valid scene packs to mutate: two trefoil objects (ρ 3 and ρ 3 with materials and colours), one
/// placed beside the other, with a view, a camera path and each shadow mode.
pub fn pack_base_files() -> &'static [Vec<u8>] {
    use pocketsplat_core::camera::Sphere;
    use pocketsplat_core::scene::write::{write_pack, PackContents, PackObject};
    use pocketsplat_core::scene::{Savings, ShadowMode};
    use pocketsplat_core::shade::DEFAULT_MATERIAL;
    static FILES: OnceLock<Vec<Vec<u8>>> = OnceLock::new();
    FILES.get_or_init(|| {
        let tg = base_files();
        let object = |name: &str, data: &[u8], x: f64, slots: Vec<u8>| PackObject {
            name: name.into(),
            kind: pocketsplat_core::scene::Kind::TriGrid,
            data: data.to_vec(),
            placement: Placement {
                translation: [x, 0.0, 0.0],
                ..Placement::IDENTITY
            },
            slots,
            casts_shadows: true,
            ground: false,
            in_bounds: true,
            depth_asked: 3,
            depth_kept: 3,
            savings: Savings::default(),
        };
        [ShadowMode::Off, ShadowMode::OnePass, ShadowMode::TwoPass]
            .into_iter()
            .map(|shadows| {
                let contents = PackContents {
                    objects: vec![
                        object("plain", &tg[0], -1.2, vec![0]),
                        object("dressed", &tg[1], 1.2, (0..8).map(|s| s % 3).collect()),
                    ],
                    materials: (0..3)
                        .map(|i| (format!("m{i}"), DEFAULT_MATERIAL))
                        .collect(),
                    views: vec![("std".into(), View::new(30.0, 20.0, 2.5))],
                    path: vec![
                        (0.0, View::new(0.0, 10.0, 3.0)),
                        (2.0, View::new(90.0, 30.0, 2.0)),
                    ],
                    light_az_el: (-40.0, 60.0),
                    shadows,
                    shadow_map_size: 64,
                    fov_deg: 45.0,
                    min_cell_px: 0.0,
                    sphere: Sphere {
                        center: [0.0; 3],
                        radius: 2.5,
                    },
                    align_log2: 9,
                };
                write_pack(&contents).expect("the base pack writes")
            })
            .collect()
    })
}

/// Opens `bytes` as a scene pack and each object's file (`Verify::Full` and `Structure`), and
/// renders what opens from its first view and its path's middle, without shadows and with the
/// pack's, checking the traversal's bounds per object.
pub fn pack_open_and_render(bytes: &[u8]) {
    use pocketsplat_core::scene::{render_scene, Pack, Scene, ShadowMode};
    let Ok(pack) = Pack::open(bytes) else {
        return;
    };
    for verify in [Verify::Full, Verify::Structure] {
        let Ok(scene) = Scene::open(pack, verify) else {
            continue;
        };
        let total: u64 = (0..scene.len())
            .filter_map(|i| scene.grid(i))
            .map(|g| g.total_samples())
            .sum();
        let views = pack
            .view(0)
            .map(|(_, v)| v)
            .into_iter()
            .chain(pack.path_view(pack.path_duration() / 2.0));
        for view in views {
            let camera = scene.camera(view);
            let of = scene.options();
            for shadows in [ShadowMode::Off, of.shadows] {
                let opts = RenderOptions {
                    shadows,
                    shadow_map_size: of.shadow_map_size.min(256),
                    ..of
                };
                let mut map = vec![0u16; opts.shadow_map_size * opts.shadow_map_size];
                let Ok(stats) =
                    render_scene(&scene, &camera, &opts, &mut map, &mut NullSink::default())
                else {
                    continue;
                };
                let passes = if stats.shadows == ShadowMode::TwoPass {
                    2
                } else {
                    1
                };
                // `total` counts the light pass's nodes too.
                let visited = u64::from(stats.total.nodes_visited);
                assert!(visited <= passes * total, "{stats:?} > {passes} x {total}");
                assert!(u64::from(stats.shadow_fill_nodes) <= total, "{stats:?}");
                assert!(stats.total.splats <= stats.total.nodes_visited);
            }
        }
    }
}

/// A `.tg` file read through a medium that fails, corrupts or truncates reads as the input says:
/// the streaming traversal must treat every such block as absent.
pub struct FlakySource<'a> {
    /// The file.
    pub bytes: &'a [u8],
    /// One byte per read, cycled: low 2 bits 0 = good read, 1 = error, 2 = one byte flipped,
    /// 3 = the read comes back short (an error); the rest picks the byte.
    pub script: &'a [u8],
    /// Reads so far.
    pub reads: usize,
}

impl pocketsplat_core::stream::ChunkSource for FlakySource<'_> {
    type Error = ();
    fn read_at(&mut self, offset: u64, buf: &mut [u8]) -> Result<(), ()> {
        let op = if self.script.is_empty() {
            0
        } else {
            self.script[self.reads % self.script.len()]
        };
        self.reads += 1;
        let start = usize::try_from(offset).map_err(|_| ())?;
        let end = start.checked_add(buf.len()).ok_or(())?;
        let src = self.bytes.get(start..end).ok_or(())?;
        match op & 3 {
            1 | 3 => Err(()),
            2 => {
                buf.copy_from_slice(src);
                if !buf.is_empty() {
                    let at = usize::from(op >> 2) * 7 % buf.len();
                    buf[at] ^= 1 << (op >> 5);
                }
                Ok(())
            }
            _ => {
                buf.copy_from_slice(src);
                Ok(())
            }
        }
    }
    fn byte_len(&self) -> Option<u64> {
        Some(self.bytes.len() as u64)
    }
}

/// Streams `bytes` through `script`'s flaky medium for up to `frames` frames with `budget` bytes of
/// reads per frame and a `cache_bytes` cache. Checks the traversal's bounds each frame and, when the
/// file opens resident with `Verify::Full` and the stream converged, that the last frame is the
/// resident one. `clean`: the file `bytes` was made from by structural damage only (masks, group
/// pointers, counts, all sealed): when the resident reader rejects `bytes` and the stream still
/// converged, the damage was never read, so the frame must be `clean`'s resident frame (issue 17:
/// valid data only, never noise).
pub fn stream_checked(
    bytes: &[u8],
    script: &[u8],
    look: &Look,
    frames: u32,
    budget: u32,
    cache_bytes: usize,
    clean: Option<&[u8]>,
) {
    use pocketsplat_sim::render::FrameBuffers;
    use pocketsplat_sim::stream::run::{camera_for, stream_frame};
    use pocketsplat_sim::stream::OwnedStream;
    let mut settings = look.settings();
    settings.shadows = ShadowMode::Off;
    let mut src = FlakySource {
        bytes,
        script,
        reads: 0,
    };
    let Ok(mut mem) = OwnedStream::new(&mut src, cache_bytes) else {
        return;
    };
    let Ok(mut stream) = mem.open(&mut src) else {
        return;
    };
    let h = *stream.header();
    // At most one visit per sample the stored file's directory counts (the medium may lie, the
    // bound may not), or one per two bytes when the stored header does not parse.
    let total = match pocketsplat_core::tg::read::parse_header(bytes) {
        Ok((_, dirs)) => dirs.iter().map(|d| u64::from(d.count)).sum(),
        Err(_) => bytes.len() as u64 / 2,
    };
    let cam = camera_for(&stream, &settings);
    RASTER.with_borrow_mut(|(fb, table)| {
        let mut last = None;
        for _ in 0..frames {
            let Ok(stats) = stream_frame(&mut stream, &cam, &settings, table, fb) else {
                return;
            };
            assert!(
                u64::from(stats.nodes_visited) <= total,
                "{stats:?} > {total}"
            );
            assert!(stats.max_level <= h.depth);
            last = Some(stats);
            if stream.converged() {
                break;
            }
            stream.serve(&mut src, budget);
        }
        let (Some(_), true) = (last, stream.converged()) else {
            return;
        };
        let (grid, what) = match (TriGrid::open(bytes, Verify::Full), clean) {
            (Ok(g), _) => (g, "the resident frame"),
            (Err(_), Some(c)) => match TriGrid::open(c, Verify::Full) {
                Ok(g) => (g, "the undamaged file's frame"),
                Err(_) => return,
            },
            (Err(_), None) => return,
        };
        let streamed = fb.pixels().to_vec();
        let mut resident = FrameBuffers::new();
        let model = Model::TriGrid(grid);
        let cam = settings.camera_for(&model);
        if render_with(&model, &settings, &cam, table, &mut resident, |_, _| {}).is_ok() {
            assert!(
                streamed == resident.pixels(),
                "converged stream differs from {what}"
            );
        }
    });
}

/// Streams `bytes` as a `.qs` file through `script`'s flaky medium (a read that would come back
/// with a flipped bit fails instead: the format has no CRCs to catch it, FORMAT.md "Streaming"),
/// drawing whole frames and then, once the cache evicts, a refined frame in passes, for up to
/// `frames` frames with `budget` bytes per frame and a `cache_bytes` cache. Each frame or pass
/// visits at most one node per 4 bytes of the file; a refined frame that completes on a file that
/// opens resident ends on exactly the resident frame.
pub fn qs_stream_checked(
    bytes: &[u8],
    script: &[u8],
    look: &Look,
    frames: u32,
    budget: u32,
    cache_bytes: usize,
) {
    use pocketsplat_core::qs::QSplat;
    use pocketsplat_sim::stream::run::{stream_frame, stream_pass, OwnedQsStream, Streamed};
    let mut settings = look.settings();
    settings.shadows = ShadowMode::Off;
    let script = damage_fails(script);
    let mut src = FlakySource {
        bytes,
        script: &script,
        reads: 0,
    };
    let Ok(mut mem) = OwnedQsStream::new(&mut src, cache_bytes) else {
        return;
    };
    let Ok(mut stream) = mem.open(&mut src) else {
        return;
    };
    let bound = bytes.len() as u64 / 4 + stream.trees().len() as u64;
    let cam = stream.camera(&settings);
    RASTER.with_borrow_mut(|(fb, table)| {
        let mut refining = false;
        let mut first = true;
        let mut done = false;
        for _ in 0..frames {
            let stats = if refining {
                let s = stream_pass(&mut stream, &cam, &settings, table, fb, first);
                first = false;
                s
            } else {
                stream_frame(&mut stream, &cam, &settings, table, fb)
            };
            let Ok(stats) = stats else {
                return;
            };
            assert!(
                u64::from(stats.nodes_visited) <= bound,
                "{stats:?} > {bound}"
            );
            if refining && stream.refined_done() {
                done = stream.converged();
                break;
            }
            if !refining && stream.stream_counters().evictions > 0 {
                refining = true;
                continue;
            }
            if !refining && stream.converged() {
                done = true;
                break;
            }
            Streamed::serve(&mut stream, &mut src, budget);
        }
        if !done {
            return;
        }
        let Ok(file) = QSplat::open(bytes) else {
            return;
        };
        let streamed = fb.pixels().to_vec();
        let mut resident = FrameBuffers::new();
        let model = Model::QSplat(file);
        let cam = settings.camera_for(&model);
        if render_with(&model, &settings, &cam, table, &mut resident, |_, _| {}).is_ok() {
            assert!(
                streamed == resident.pixels(),
                "converged stream differs from the resident frame"
            );
        }
    });
}

/// `script` with its damaged reads (op 2) made failed reads (op 3): for media whose files have no
/// CRCs (QSplat), where a damaged byte that still reads as valid data is not an error to find.
fn damage_fails(script: &[u8]) -> Vec<u8> {
    script
        .iter()
        .map(|&op| if op & 3 == 2 { op | 1 } else { op })
        .collect()
}

/// Streams the pack `bytes` through `script`'s flaky medium (damaged reads made failed reads, as
/// for `.qs`: a pack's QSplat objects have no CRCs) with a `cache_bytes` cache and `budget` bytes of
/// reads per frame, for up to `frames` frames, from the pack's first view with `shadows` (0 off,
/// 1 one-pass, 2 two-pass). Nothing may panic; when the stream converges and the pack opens whole,
/// the frame must be the pack's resident frame.
pub fn pack_stream_checked(
    bytes: &[u8],
    script: &[u8],
    shadows: u8,
    frames: u32,
    budget: u32,
    cache_bytes: usize,
) {
    use pocketsplat_core::scene::{Pack, Scene};
    use pocketsplat_sim::scene::render::{render_pack, PackSettings};
    use pocketsplat_sim::stream::pack::stream_pack;
    use pocketsplat_sim::stream::StreamOptions;
    let script = damage_fails(script);
    let mut src = FlakySource {
        bytes,
        script: &script,
        reads: 0,
    };
    let mode =
        [ShadowMode::Off, ShadowMode::OnePass, ShadowMode::TwoPass][usize::from(shadows % 3)];
    let settings = |pack: &Pack<'_>| {
        let view = pack.view(0).map_or(View::new(30.0, 20.0, 2.5), |(_, v)| v);
        let mut s = PackSettings::new(view);
        s.shadows = Some(mode);
        s
    };
    let opts = StreamOptions {
        io_budget: budget.max(512),
        cache_bytes,
        max_frames: frames,
        ..StreamOptions::default()
    };
    let mut fb = FrameBuffers::new();
    let mut chosen = None;
    let streamed = stream_pack(
        &mut src,
        |p| {
            let s = settings(p);
            chosen = Some(s);
            Ok(s)
        },
        &opts,
        &mut fb,
        |_| Ok(()),
    );
    let (Ok(_), Some(s)) = (streamed, chosen) else {
        return;
    };
    let Ok(pack) = Pack::open(bytes) else {
        return;
    };
    let Ok(scene) = Scene::open(pack, Verify::Full) else {
        return;
    };
    let mut resident = FrameBuffers::new();
    if render_pack(&scene, &s, &mut resident).is_ok() {
        assert!(
            fb.pixels() == resident.pixels(),
            "converged stream differs from the resident frame"
        );
    }
}
