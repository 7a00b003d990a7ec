//! The sweep: what a subject is ([`Subject`]: views, a reference, [`Method`]s), the frame
//! configurations a method is measured at ([`Sweep`], [`FrameConfig`]), and one measured frame
//! ([`measure`] → [`Row`]).

use std::time::Duration;

use anyhow::{Context, Result};
use cpu_time::ThreadTime;
use pocketsplat_core::camera::View;
use pocketsplat_core::raster::Kernel;
use pocketsplat_core::shade::rgb565_to_rgb888;

use super::arm;
use super::brute::kernel_name;
use crate::metrics::{coverage_mismatch, psnr_rgb8};
use crate::reference::RefImage;
use crate::render::{FrameBuffers, FrameReport, ShadowMode};

/// Cutoffs of the full sweep, pixels.
pub const CUTOFFS_PX: [f32; 6] = [0.5, 1.0, 2.0, 4.0, 8.0, 16.0];

/// Cutoffs of `--quick`, pixels.
pub const QUICK_CUTOFFS_PX: [f32; 2] = [1.0, 4.0];

/// One frame configuration of a method.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameConfig {
    /// LOD cutoff, pixels (ignored by methods without one).
    pub cutoff_px: f32,
    /// Splat kernel.
    pub kernel: Kernel,
    /// Shadow algorithm.
    pub shadows: ShadowMode,
}

/// A way to draw a subject: a format and its renderer.
pub trait Method {
    /// Short name in tables and plots: `trigrid`, `octree`, `qsplat`, `brute`.
    fn name(&self) -> &str;
    /// What was baked, e.g. `ρ=3 depth 6, 1234567 leaves`.
    fn detail(&self) -> String;
    /// Whether the cutoff changes the frame (the brute force draws every leaf whatever it is).
    fn uses_cutoff(&self) -> bool;
    /// Whether it can draw these shadows.
    fn supports(&self, shadows: ShadowMode) -> bool;
    /// CRC-32 of the file it draws, when firmware can draw the same file (the key of its ARM
    /// counts, [`arm`]).
    fn file_crc(&self) -> Option<u32> {
        None
    }
    /// CRC-32 of the same samples in the layout a firmware links into flash, when that is another
    /// file than [`Method::file_crc`]'s (a tri-grid baked with bricks; the firmware's is
    /// unbricked): `arm-bench` names its frames by that file, and they are this method's frames.
    fn flash_crc(&self) -> Option<u32> {
        None
    }
    /// Renders `view` into `out` (cleared first), timing setup, traversal and raster.
    ///
    /// # Errors
    /// When the frame cannot be set up.
    fn render(
        &mut self,
        view: View,
        cfg: &FrameConfig,
        out: &mut FrameBuffers,
    ) -> Result<FrameReport>;
}

/// What a shadowed frame was compared with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RefShadows {
    /// The reference without shadows.
    None,
    /// Exact shadow rays against the mesh.
    RayCast,
}

impl RefShadows {
    fn name(self) -> &'static str {
        match self {
            RefShadows::None => "unshadowed",
            RefShadows::RayCast => "ray-cast",
        }
    }
}

/// A reference frame and how its shadows were made.
pub struct Reference {
    /// The f64 image.
    pub image: RefImage,
    /// Shadows in it.
    pub shadows: RefShadows,
}

/// The reference render function of a subject: `(view, with shadows)` → frame.
pub type ReferenceFn<'a> = Box<dyn Fn(View, bool) -> Result<Reference> + 'a>;

/// What the report sweeps over.
pub struct Subject<'a> {
    /// Name in titles (the file name of the mesh or scene).
    pub name: String,
    /// Named views.
    pub views: Vec<(String, View)>,
    /// The subject's own shadows (a scene's; off for a mesh): the mean plot and the budget table
    /// are also made for them when they are not off.
    pub shadows: ShadowMode,
    /// The ground truth.
    pub reference: ReferenceFn<'a>,
    /// The methods compared.
    pub methods: Vec<Box<dyn Method + 'a>>,
}

/// The sweep's axes other than views and methods.
#[derive(Clone, Debug, PartialEq)]
pub struct Sweep {
    /// Cutoffs, pixels.
    pub cutoffs: Vec<f32>,
    /// Kernels.
    pub kernels: Vec<Kernel>,
    /// Shadow algorithms (each method runs those it supports).
    pub shadows: Vec<ShadowMode>,
    /// Timed repeats per frame; the median is reported.
    pub repeats: usize,
}

impl Sweep {
    /// The full sweep: six cutoffs, both kernels, shadows off / one-pass / two-pass.
    pub fn full(repeats: usize) -> Self {
        Self {
            cutoffs: CUTOFFS_PX.to_vec(),
            kernels: vec![Kernel::Square, Kernel::Round],
            shadows: vec![ShadowMode::Off, ShadowMode::OnePass, ShadowMode::TwoPass],
            repeats,
        }
    }
    /// `--quick`: two cutoffs, everything else as [`Sweep::full`].
    pub fn quick(repeats: usize) -> Self {
        Self {
            cutoffs: QUICK_CUTOFFS_PX.to_vec(),
            ..Self::full(repeats)
        }
    }
}

/// One measured frame: a row of `results.csv`.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Row {
    /// Subject name.
    pub scene: String,
    /// View name.
    pub view: String,
    /// Method name.
    pub method: String,
    /// What was baked.
    pub detail: String,
    /// `square` or `round`.
    pub kernel: String,
    /// `off`, `one-pass` or `two-pass`.
    pub shadows: String,
    /// LOD cutoff, pixels; `None` for methods without one.
    pub cutoff_px: Option<f32>,
    /// PSNR against the reference, dB (8-bit RGB); infinite for an exact match.
    pub psnr_db: f64,
    /// Fraction of pixels covered by one image and not the other.
    pub coverage_mismatch: f64,
    /// Fraction of pixels the reference covers and the frame misses.
    pub holes: f64,
    /// Median host time per frame, ms: CPU time of the rendering thread (wall time where the
    /// thread's CPU clock is not available), so that other processes on the machine do not count.
    pub ms: f64,
    /// Median wall time per frame, ms, as the renderer measures it (setup, traversal, raster).
    pub wall_ms: f64,
    /// Nodes visited (points processed by the brute force).
    pub nodes_visited: u32,
    /// Splats drawn.
    pub splats: u32,
    /// ARM instructions per frame under QEMU, when measured.
    pub arm_instructions: Option<u64>,
    /// What shadowed frames were compared with (`unshadowed` or `ray-cast`); `-` without shadows.
    pub reference: String,
    /// The CRC-32 of the baked file the method drew (not in `results.csv`): what ARM counts of
    /// other targets are matched by (the "same frames on" section of `results.md`).
    #[serde(skip)]
    pub file_crc: Option<u32>,
}

/// Name of a shadow mode in the report.
pub fn shadows_name(s: ShadowMode) -> &'static str {
    match s {
        ShadowMode::Off => "off",
        ShadowMode::OnePass => "one-pass",
        ShadowMode::TwoPass => "two-pass",
    }
}

/// Median of durations (the upper one of an even count).
pub(super) fn median(mut t: Vec<Duration>) -> Duration {
    t.sort();
    t[t.len() / 2]
}

/// Runs the sweep over every view of `subject`; `log` receives one line per view and method.
///
/// # Errors
/// When a reference or a frame cannot be made.
pub fn measure(
    subject: &mut Subject<'_>,
    sweep: &Sweep,
    arm: &arm::ArmCounts,
    mut log: impl FnMut(&str),
) -> Result<Vec<Row>> {
    let mut rows = Vec::new();
    let mut fb = FrameBuffers::new();
    for (view_name, view) in &subject.views {
        let plain = (subject.reference)(*view, false)
            .with_context(|| format!("reference of view {view_name}"))?;
        let mut shadowed: Option<Reference> = None;
        for method in &mut subject.methods {
            log(&format!("{view_name}: {}", method.name()));
            for &kernel in &sweep.kernels {
                for &shadows in &sweep.shadows {
                    if !method.supports(shadows) {
                        continue;
                    }
                    let cutoffs: Vec<Option<f32>> = if method.uses_cutoff() {
                        sweep.cutoffs.iter().copied().map(Some).collect()
                    } else {
                        vec![None]
                    };
                    for cutoff in cutoffs {
                        let cfg = FrameConfig {
                            cutoff_px: cutoff.unwrap_or(1.0),
                            kernel,
                            shadows,
                        };
                        let mut times = Vec::with_capacity(sweep.repeats.max(1));
                        let mut walls = Vec::with_capacity(sweep.repeats.max(1));
                        let mut stats = None;
                        for _ in 0..sweep.repeats.max(1) {
                            let cpu = ThreadTime::try_now().ok();
                            let r = method.render(*view, &cfg, &mut fb).with_context(|| {
                                format!("{} frame of view {view_name}", method.name())
                            })?;
                            times.push(cpu.and_then(|c| c.try_elapsed().ok()).unwrap_or(r.time));
                            walls.push(r.time);
                            stats = Some(r.stats);
                        }
                        let stats = stats.expect("at least one frame");
                        let reference = if shadows == ShadowMode::Off {
                            &plain
                        } else {
                            if shadowed.is_none() {
                                shadowed =
                                    Some((subject.reference)(*view, true).with_context(|| {
                                        format!("shadowed reference of view {view_name}")
                                    })?);
                            }
                            shadowed.as_ref().expect("just made")
                        };
                        let (psnr_db, coverage, holes) = compare(&reference.image, &fb);
                        rows.push(Row {
                            scene: subject.name.clone(),
                            view: view_name.clone(),
                            method: method.name().to_owned(),
                            detail: method.detail(),
                            kernel: kernel_name(kernel).to_owned(),
                            shadows: shadows_name(shadows).to_owned(),
                            cutoff_px: cutoff,
                            psnr_db,
                            coverage_mismatch: coverage,
                            holes,
                            ms: median(times).as_secs_f64() * 1e3,
                            wall_ms: median(walls).as_secs_f64() * 1e3,
                            nodes_visited: stats.nodes_visited,
                            splats: stats.splats,
                            arm_instructions: method.file_crc().and_then(|crc| {
                                arm.get(
                                    crc,
                                    view_name,
                                    cfg.cutoff_px,
                                    shadows_name(shadows),
                                    kernel_name(kernel),
                                )
                            }),
                            reference: if shadows == ShadowMode::Off {
                                "-".to_owned()
                            } else {
                                reference.shadows.name().to_owned()
                            },
                            file_crc: method.file_crc(),
                        });
                    }
                }
            }
        }
    }
    Ok(rows)
}

/// PSNR, coverage mismatch and holes of a frame against the reference.
pub(super) fn compare(reference: &RefImage, frame: &FrameBuffers) -> (f64, f64, f64) {
    let rgb: Vec<[u8; 3]> = frame
        .pixels()
        .iter()
        .map(|&p| rgb565_to_rgb888(p))
        .collect();
    let covered = frame.covered();
    let holes = reference
        .covered
        .iter()
        .zip(&covered)
        .filter(|&(&r, &c)| r && !c)
        .count();
    (
        psnr_rgb8(&reference.to_rgb8(), &rgb),
        coverage_mismatch(&reference.covered, &covered),
        holes as f64 / covered.len() as f64,
    )
}
