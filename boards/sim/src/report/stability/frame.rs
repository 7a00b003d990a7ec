//! One checked frame: a [`Shot`] rendered through the real raster with the [`Probe`] in front of
//! it ([`shoot`]), and judged against the suite's bounds ([`Measured::outcome`]).

use std::fmt::Write as _;

use pocketsplat_core::camera::{self, Vec3, HEIGHT, WIDTH};
use pocketsplat_core::shade::{ShadingTable, DEFAULT_MATERIAL};
use pocketsplat_core::shadow::{render_tg_shadowed, LightFrame, ShadowMap, ShadowMode};
use pocketsplat_core::splat::{ShadedRaster, Stats};
use pocketsplat_core::tg::frame::footprint;
use pocketsplat_core::tg::{render_tg, TgFrame};

use super::outcome::{Outcome, BOUNDS_SLACK_PX, MAX_ERROR_PX};
use super::probe::{Checks, Probe};
use super::shot::{model_to_camera, screen_box, ShadowTruth, Shot};
use crate::render::FrameBuffers;

/// What a checked frame measured.
pub struct Measured {
    /// The traversal's counts.
    pub stats: Stats,
    /// The frame.
    pub fb: FrameBuffers,
    /// What the splat-by-splat checks found.
    pub checks: Checks,
    /// The frame's near plane, world units: the camera's, or the frame's precision plane when that
    /// is farther (`TgFrame::near_depth`).
    pub near_depth: f64,
    /// A drawn cell's splat over its projected side (`pocketsplat_core::tg::frame::footprint`).
    pub footprint: f64,
}

impl Measured {
    /// Pixels written.
    pub fn covered(&self) -> usize {
        self.fb.covered().iter().filter(|&&c| c).count()
    }

    /// Judges the frame against the suite's bounds.
    pub fn outcome(&self) -> Outcome {
        let c = &self.checks;
        let mut o = Outcome {
            worst: c.worst_px,
            unit: "px",
            limit: MAX_ERROR_PX,
            notes: format!(
                "{} splats ({} on screen), {} px covered; bounds excess {:.3} px",
                self.stats.splats,
                c.on_screen,
                self.covered(),
                c.cell_excess_px.max(c.model_excess_px)
            ),
            ..Outcome::default()
        };
        if c.worst_px > MAX_ERROR_PX {
            o.fail(format!(
                "projected error {:.3} px > {MAX_ERROR_PX} px",
                c.worst_px
            ));
        }
        if c.cell_excess_px > BOUNDS_SLACK_PX {
            o.fail(format!(
                "a splat reaches {:.2} px outside its cell's projected bounds",
                c.cell_excess_px
            ));
        }
        if c.model_excess_px > BOUNDS_SLACK_PX {
            o.fail(format!(
                "a splat reaches {:.2} px outside the model's projected bounds",
                c.model_excess_px
            ));
        }
        if c.near_violations > 0 {
            o.fail(format!(
                "{} splats from in front of the near plane (nearest at {:.3} × near)",
                c.near_violations, c.min_z_over_near
            ));
        }
        if c.wrapped > 0 {
            o.fail(format!("{} splats with a wrapped size", c.wrapped));
        }
        if c.shadow_wrong > 0 {
            o.fail(format!(
                "{} of {} samples with a sure answer have the wrong shadow state",
                c.shadow_wrong, c.shadow_sure
            ));
        }
        if !o.failures.is_empty() {
            if let Some(p) = &c.first_problem {
                o.fail(format!("first: {p}"));
            }
        }
        if c.unbounded > 0 {
            let _ = write!(
                o.notes,
                "; {} splats of cells reaching behind the eye (bounds unchecked)",
                c.unbounded
            );
        }
        if c.worst_any_px > c.worst_px {
            let _ = write!(o.notes, "; off screen up to {:.3} px", c.worst_any_px);
        }
        if c.shadow_sure > 0 {
            let _ = write!(o.notes, "; {} sure shadow states checked", c.shadow_sure);
            if c.shadow_invisible > 0 {
                let _ = write!(
                    o.notes,
                    " ({} differ where lit and shadowed colours are equal)",
                    c.shadow_invisible
                );
            }
        }
        o
    }
}

/// Renders a shot through the real raster, checking every splat on the way.
pub fn shoot(shot: &Shot<'_>) -> Measured {
    shoot_with(shot, None)
}

pub(super) fn shoot_with(shot: &Shot<'_>, truth: Option<ShadowTruth<'_>>) -> Measured {
    let tg = shot.baked.tg();
    let h = tg.header();
    let frame = TgFrame::new(h, &shot.placement, &shot.camera, &shot.opts).expect("frame set-up");
    let bounds = h.bounds64;
    let model_boxes = shot
        .baked
        .side
        .iter()
        .map(|&side| {
            let corners = (0..8).map(|k| {
                let p: Vec3 = std::array::from_fn(|a| {
                    if k >> a & 1 == 1 {
                        bounds[1][a] + 2.0 * side
                    } else {
                        bounds[0][a] - 2.0 * side
                    }
                });
                model_to_camera(&shot.camera, &shot.placement, p)
            });
            screen_box(&shot.camera, corners)
        })
        .collect();
    let mut fb = FrameBuffers::new();
    let mut table = Box::new(ShadingTable::<1>::new());
    let (mode, light_world) = shot.light;
    let to_model = |d: Vec3| camera::normalize(shot.placement.to_model_dir(d));
    table.update(
        &[DEFAULT_MATERIAL],
        to_model(light_world),
        to_model(camera::scale(shot.camera.forward, -1.0)),
    );
    let mut shadow = Vec::new();
    let footprint = footprint(h, &shot.placement, &shot.camera, shot.opts.kernel);
    let stats;
    let measured;
    {
        let mut framebuffer = fb.display();
        pocketsplat_core::raster::DepthTarget::clear(&mut framebuffer, 0);
        let mut probe = Probe {
            shot,
            model_boxes,
            truth,
            table: &table,
            footprint,
            inner: ShadedRaster {
                fb: &mut framebuffer,
                table: &table,
                kernel: shot.opts.kernel,
            },
            m: Checks::default(),
        };
        stats = if mode == ShadowMode::Off {
            render_tg(&tg, &frame, &mut probe)
        } else {
            let n = crate::render::DEFAULT_SHADOW_MAP_SIZE;
            shadow.resize(n * n, u16::MAX);
            let light = LightFrame::new(h, &shot.placement, light_world, n);
            let mut map = ShadowMap::new(&mut shadow, n);
            render_tg_shadowed(&tg, &frame, &light, &mut map, mode, &mut probe)
        };
        measured = probe.m;
    }
    Measured {
        stats,
        fb,
        checks: measured,
        near_depth: frame.near_depth(),
        footprint,
    }
}

/// A checked frame as a case outcome.
pub(super) fn check(shot: &Shot<'_>) -> Outcome {
    shoot(shot).outcome()
}

/// Requires that something was drawn (a vacuous pass proves nothing) where, in f64, some leaf's
/// footprint covers a pixel centre beyond the frame's near plane (the camera's, or the frame's
/// precision plane, `TgFrame::near_depth`). A model smaller than that draws nothing: its splats,
/// exact footprints, cover no pixel centre, as the surface itself covers none.
pub(super) fn check_drawn(shot: &Shot<'_>) -> Outcome {
    let m = shoot(shot);
    let mut o = m.outcome();
    let b = shot.baked;
    let leaf = b.side.len() - 1;
    let half = 0.5 * m.footprint * b.side[leaf] * shot.placement.scale;
    let cam = &shot.camera;
    // A leaf straddling the plane may be drawn or not (its centre decides): only leaves wholly
    // beyond it must be.
    let near = cam.near.max(m.near_depth) + half * 3f64.sqrt();
    let over_a_centre = b.centres[leaf].iter().any(|&c| {
        let [x, y, z] = model_to_camera(cam, &shot.placement, c);
        if z <= near {
            return false;
        }
        let p = cam.screen(x, y, z);
        let h = half * cam.focal_px / z;
        // A pixel centre i + ½ in [p − h, p + h) on both axes, on the screen.
        let centre_in = |a: f64, b: f64, n: f64| {
            let (first, end) = ((a - 0.5).ceil().max(0.0), (b - 0.5).ceil().min(n));
            first < end
        };
        centre_in(p[0] - h, p[0] + h, WIDTH as f64) && centre_in(p[1] - h, p[1] + h, HEIGHT as f64)
    });
    if over_a_centre && (m.stats.splats == 0 || m.covered() == 0) {
        o.fail("nothing drawn where the model is in view");
    }
    if !over_a_centre {
        o.notes
            .push_str("; no leaf covers a pixel centre: nothing to draw");
    }
    if m.near_depth > cam.near {
        let _ = write!(
            o.notes,
            "; the frame's precision plane clips at {:.1} × the camera's near plane",
            m.near_depth / cam.near
        );
    }
    o
}
