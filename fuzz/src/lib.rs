//! What the fuzz targets share: small `.tg` files baked in-process, and one function that opens a
//! file every way the program does and renders it every way it can, checking the traversal's bounds.
//!
//! Any panic here is a finding: the readers must answer every input with a value or an error.

use std::cell::RefCell;
use std::sync::OnceLock;

use pocketsplat_core::bake::{BakeOptions, TriMesh};
use pocketsplat_core::camera::{Placement, View};
use pocketsplat_core::raster::Kernel;
use pocketsplat_core::shade::ShadingTable;
use pocketsplat_core::splat::NullSink;
use pocketsplat_core::tg::{render_tg, RenderOptions, TgFrame, TriGrid, Verify};
use pocketsplat_sim::render::{render_tg_with, FrameBuffers, Settings, ShadowMode};

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
    static FILES: OnceLock<Vec<Vec<u8>>> = OnceLock::new();
    FILES.get_or_init(|| {
        [
            (false, false, 3, 3),
            (true, true, 3, 2),
            (false, false, 2, 5),
            (false, true, 2, 3),
        ]
        .into_iter()
        .map(|(materials, colors, rho, depth)| {
            let mesh = trefoil(materials, colors);
            let (_, bytes) = pocketsplat_sim::cmd::bake::bake_mesh(
                &mesh,
                BakeOptions { rho, depth },
                BLOCK_LOG2,
                false,
            )
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
        let Ok(report) = render_tg_with(grid, &settings, table, fb, |_, _| {}) else {
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
    use pocketsplat_core::qs::{render_qs, QSplat, QsFrame, QsRenderOptions};
    use pocketsplat_core::raster::Framebuffer;
    use pocketsplat_core::splat::ShadedRaster;
    let Ok(file) = QSplat::open(bytes) else {
        return;
    };
    let c = file.counts();
    let nodes = c.leaves + c.interior + u64::from(c.trees);
    for look in looks {
        let s = look.settings();
        let cam = Camera::orbit(Sphere::from_bounds(file.bounds()), s.view, s.fov_deg);
        let opts = QsRenderOptions {
            cutoff_px: s.cutoff_px,
            kernel: s.kernel,
            ..QsRenderOptions::default()
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
            table.update(&[s.material], s.light_dir(), [0.0, 0.0, 1.0]);
            let mut fbuf = Framebuffer::new(&mut fb.color, &mut fb.depth);
            fbuf.clear(0);
            let mut sink = ShadedRaster {
                fb: &mut fbuf,
                table,
                kernel: s.kernel,
            };
            let again = render_qs(&file, &frame, &mut sink);
            assert_eq!(again, stats, "the raster changes what the traversal visits");
        });
    }
}
