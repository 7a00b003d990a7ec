//! The splat-by-splat checks: a sink in front of the raster ([`Probe`]) that holds every splat to
//! the f64 projection of its cell, and what it found ([`Checks`]).

use pocketsplat_core::camera::{Vec3, HEIGHT, WIDTH};
use pocketsplat_core::fixed::ONE_PX_Q8;
use pocketsplat_core::raster::{drawn_pixels, MAX_SPLAT_PX};
use pocketsplat_core::shade::ShadingTable;
use pocketsplat_core::splat::{SampleSplat, SplatSink};

use super::outcome::{BOUNDS_SLACK_PX, MAX_ERROR_PX};
use super::shot::{model_to_camera, screen_box, ShadowTruth, Shot};

/// One pixel in the splats' fixed point.
const ONE_PX: f64 = ONE_PX_Q8 as f64;

/// What the splat-by-splat checks of one frame found.
#[derive(Clone, Debug)]
pub struct Checks {
    /// Worst position or diameter error over splats that reach the screen, px.
    pub worst_px: f64,
    /// Worst position or diameter error over every splat, on screen or not, px.
    pub worst_any_px: f64,
    /// Worst reach of a splat's drawn pixels beyond its cell's true projected bounds, px.
    pub cell_excess_px: f64,
    /// Worst reach beyond the model's true projected bounds, px.
    pub model_excess_px: f64,
    /// Splats whose cell centre is nearer than half the near plane (or behind the eye).
    pub near_violations: u32,
    /// Splats with a negative size (wrapped around).
    pub wrapped: u32,
    /// Splats that reach the screen.
    pub on_screen: u32,
    /// Splats whose cell reaches behind the eye (no finite projected bounds to check).
    pub unbounded: u32,
    /// Nearest splat centre, in near-plane distances.
    pub min_z_over_near: f64,
    /// Samples whose shadow state disagrees with the f64 truth, where that changes their colour.
    pub shadow_wrong: u32,
    /// Samples whose shadow state disagrees but whose lit and shadowed colours are the same.
    pub shadow_invisible: u32,
    /// Of those, samples shadowed where the f64 answer is lit (self-shadowing acne).
    pub shadow_acne: u32,
    /// Largest colour change acne makes (lit against shadowed colour), RGB565 steps per channel.
    pub acne_steps: i32,
    /// Samples with a sure f64 shadow state.
    pub shadow_sure: u32,
    /// The first problem, described.
    pub first_problem: Option<String>,
}

impl Default for Checks {
    fn default() -> Self {
        Self {
            worst_px: 0.0,
            worst_any_px: 0.0,
            cell_excess_px: 0.0,
            model_excess_px: 0.0,
            near_violations: 0,
            wrapped: 0,
            on_screen: 0,
            unbounded: 0,
            min_z_over_near: f64::INFINITY,
            shadow_wrong: 0,
            shadow_invisible: 0,
            shadow_acne: 0,
            acne_steps: 0,
            shadow_sure: 0,
            first_problem: None,
        }
    }
}

/// How far the pixel rectangle `[x0, x1) × [y0, y1)` reaches outside `b`.
pub(super) fn excess(r: [i64; 4], b: [f64; 4]) -> f64 {
    let [x0, x1, y0, y1] = r.map(|v| v as f64);
    (b[0] - x0)
        .max(x1 - b[1])
        .max(b[2] - y0)
        .max(y1 - b[3])
        .max(0.0)
}

/// The pixels the raster writes for a splat (before clipping), as `raster.rs` computes them, in i64.
fn drawn_rect(s: &SampleSplat) -> [i64; 4] {
    drawn_pixels(s.x_q8, s.y_q8, s.size_q8, s.exact).map(i64::from)
}

pub(super) fn on_screen(r: [i64; 4]) -> bool {
    r[0] < WIDTH as i64 && r[1] > 0 && r[2] < HEIGHT as i64 && r[3] > 0
}

pub(super) struct Probe<'a, S> {
    /// The frame's set-up.
    pub(super) shot: &'a Shot<'a>,
    /// Per level: the model's box grown by 2 cell sides, placed, as 8 camera-space corners.
    pub(super) model_boxes: Vec<Option<[f64; 4]>>,
    /// The f64 shadow state of samples, when shadows are checked.
    pub(super) truth: Option<ShadowTruth<'a>>,
    /// The frame's shading table (the lit and shadowed colour of a sample).
    pub(super) table: &'a ShadingTable<1>,
    /// A drawn cell's splat over its projected side (`pocketsplat_core::tg::frame::footprint`).
    pub(super) footprint: f64,
    /// The raster behind the probe.
    pub(super) inner: S,
    /// What the checks found so far.
    pub(super) m: Checks,
}

impl<S: SplatSink> SplatSink for Probe<'_, S> {
    fn splat(&mut self, s: &SampleSplat) {
        let shot = self.shot;
        let cam = &shot.camera;
        let l = usize::from(s.level);
        let centre_model = shot.baked.centres[l][s.index as usize];
        let centre = model_to_camera(cam, &shot.placement, centre_model);
        let [x, y, z] = centre;
        // The walk draws a cell at its centre or at its children's centroid (Duguet §4.1: where
        // in the cell the surface is): the splat's position is held to the nearer of the two.
        let centroid = shot.baked.centroids[l][s.index as usize]
            .map(|c| model_to_camera(cam, &shot.placement, c));
        // The splat stands for the cell's bounding sphere; its projected square lies inside the
        // projection of the sphere's camera-aligned bounding cube (exactly: the square's half-width
        // is radius · f / z at the projected centre).
        let radius = 0.5 * 3f64.sqrt() * shot.baked.side[l] * shot.placement.scale;
        let rect = drawn_rect(s);
        let m = &mut self.m;
        m.min_z_over_near = m.min_z_over_near.min(z / cam.near);
        if z < 0.5 * cam.near {
            m.near_violations += 1;
            m.first_problem.get_or_insert_with(|| {
                format!(
                    "level {l} cell {} at depth {z:.3e} (near {:.3e})",
                    s.index, cam.near
                )
            });
            self.inner.splat(s);
            return;
        }
        if s.size_q8 < 0 {
            m.wrapped += 1;
        }
        let p = cam.screen(x, y, z);
        let off = |p: Vec3| {
            (f64::from(s.x_q8) / ONE_PX - p[0])
                .abs()
                .max((f64::from(s.y_q8) / ONE_PX - p[1]).abs())
        };
        let pos_err = match centroid {
            Some([cx, cy, cz]) if cz > 0.0 => off(p).min(off(cam.screen(cx, cy, cz))),
            _ => off(p),
        };
        // The footprint (`pocketsplat_core::tg::frame::footprint`) × the projected side of an
        // exact splat; the bounding sphere's diameter otherwise.
        let size_true = if s.exact {
            self.footprint * shot.baked.side[l] * shot.placement.scale * cam.focal_px / z
        } else {
            2.0 * radius * cam.focal_px / z
        };
        // The diameter too, where the raster draws it unclamped.
        let size_err = if size_true < f64::from(MAX_SPLAT_PX) {
            (f64::from(s.size_q8) / ONE_PX - size_true).abs()
        } else {
            0.0
        };
        let err = pos_err.max(size_err);
        let half_true = 0.5 * size_true.min(f64::from(MAX_SPLAT_PX));
        let true_rect = [
            (p[0] - half_true).floor() as i64,
            (p[0] + half_true).ceil() as i64,
            (p[1] - half_true).floor() as i64,
            (p[1] + half_true).ceil() as i64,
        ];
        m.worst_any_px = m.worst_any_px.max(err);
        let visible = on_screen(rect) || on_screen(true_rect);
        if visible {
            m.on_screen += 1;
            if err > m.worst_px {
                m.worst_px = err;
                if err > MAX_ERROR_PX {
                    m.first_problem = Some(format!(
                        "level {l} cell {} drawn at ({:.2}, {:.2}) size {:.2}, f64 ({:.2}, {:.2}) \
                         size {:.2}, depth {:.3e}",
                        s.index,
                        f64::from(s.x_q8) / ONE_PX,
                        f64::from(s.y_q8) / ONE_PX,
                        f64::from(s.size_q8) / ONE_PX,
                        p[0],
                        p[1],
                        size_true,
                        z
                    ));
                }
            }
        }
        // Bounds, for what the raster actually writes (clipped to the screen).
        let clip = [
            rect[0].max(0),
            rect[1].min(WIDTH as i64),
            rect[2].max(0),
            rect[3].min(HEIGHT as i64),
        ];
        if clip[0] < clip[1] && clip[2] < clip[3] {
            let cube = (0..8).map(|k| {
                let d = |bit: u32| if k >> bit & 1 == 1 { radius } else { -radius };
                [x + d(0), y + d(1), z + d(2)]
            });
            match screen_box(cam, cube) {
                Some(b) => {
                    let e = excess(clip, b);
                    if e > m.cell_excess_px {
                        m.cell_excess_px = e;
                        if e > BOUNDS_SLACK_PX {
                            m.first_problem = Some(format!(
                                "level {l} cell {} draws {clip:?}, its bounds are {b:.2?}",
                                s.index
                            ));
                        }
                    }
                }
                None => m.unbounded += 1,
            }
            if let Some(b) = self.model_boxes[l] {
                m.model_excess_px = m.model_excess_px.max(excess(clip, b));
            }
        }
        if let Some(truth) = self.truth {
            if let Some(shadowed) = truth(l, centre_model) {
                m.shadow_sure += 1;
                // Lit and shadowed colours of this sample: a wrong answer that changes no colour
                // (a surface lit at a grazing angle) is not an error anyone can see.
                let (lit, dark) = (self.table.color(s.attr), self.table.shadowed(s.attr));
                let steps = [(11, 31), (5, 63), (0, 31)]
                    .iter()
                    .map(|&(shift, mask)| {
                        (i32::from(lit >> shift & mask) - i32::from(dark >> shift & mask)).abs()
                    })
                    .max()
                    .unwrap_or(0);
                if shadowed != s.shadowed && steps == 0 {
                    m.shadow_invisible += 1;
                } else if shadowed != s.shadowed {
                    m.shadow_wrong += 1;
                    if s.shadowed {
                        m.shadow_acne += 1;
                        m.acne_steps = m.acne_steps.max(steps);
                    }
                    m.first_problem.get_or_insert_with(|| {
                        format!(
                            "level {l} sample at {centre_model:.3?}: shadowed {} (f64: {shadowed})",
                            s.shadowed
                        )
                    });
                }
            }
        }
        self.inner.splat(s);
    }
}
