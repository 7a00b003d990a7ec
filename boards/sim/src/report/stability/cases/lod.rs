//! The frame-rate controller under a 100× jump in frame cost.

use std::fmt::Write as _;

use pocketsplat_core::camera::{Camera, Placement};
use pocketsplat_core::lod::{FrameRateController, FINEST_CUTOFF_PX};
use pocketsplat_core::render::RenderOptions;
use pocketsplat_core::tg::{render_tg, TgFrame};

use crate::report::stability::baked::{world_sphere, Baked};
use crate::report::stability::meshes::blob;
use crate::report::stability::outcome::Outcome;
use crate::report::stability::runner::Runner;
use crate::report::stability::shot::STD;

/// The frame-rate controller under a 100× cost jump and back, with a model of the cost and with the
/// real traversal's node count as the cost.
pub(super) fn lod(r: &mut Runner) {
    /// Runs `frames` frames of cost `cost(frame, cutoff)` µs; returns the log errors and cutoffs.
    fn run(
        c: &mut FrameRateController,
        frames: usize,
        mut cost: impl FnMut(usize, f32) -> u32,
    ) -> (Vec<f64>, Vec<f32>) {
        let (mut errs, mut cuts) = (Vec::new(), Vec::new());
        for f in 0..frames {
            let t = cost(f, c.cutoff());
            errs.push((f64::from(t) / f64::from(c.target_us())).ln());
            cuts.push(c.cutoff());
            c.update(t);
        }
        (errs, cuts)
    }
    /// Judges the frames after a jump: cutoff in range, settled within `settle` frames to within `tol`
    /// in log (or pinned at the cutoff limit on the side the error pushes to), no overshoot past the
    /// band, and never leaving it again.
    fn judge(o: &mut Outcome, what: &str, errs: &[f64], cuts: &[f32], settle: usize, tol: f64) {
        if cuts.iter().any(|c| !(FINEST_CUTOFF_PX..=64.0).contains(c)) {
            o.fail(format!("{what}: cutoff left [1, 64]: {cuts:?}"));
        }
        let ok = |e: f64, c: f32| {
            e.abs() <= tol || (c <= FINEST_CUTOFF_PX && e < 0.0) || (c >= 64.0 && e > 0.0)
        };
        match errs.iter().zip(cuts).position(|(&e, &c)| ok(e, c)) {
            Some(k) if k <= settle => {
                let _ = write!(
                    o.notes,
                    "{what}: from {:.2} settled in {k} frames (cutoff {:.2} → {:.2} px); ",
                    errs[0],
                    cuts[0],
                    cuts[cuts.len() - 1]
                );
                // Worst error once settled, leaving out frames pinned at a cutoff limit.
                let pinned = |e: f64, c: f32| ok(e, c) && e.abs() > tol;
                let worst = errs[k..]
                    .iter()
                    .zip(&cuts[k..])
                    .filter(|&(&e, &c)| !pinned(e, c))
                    .fold(0.0f64, |w, (e, _)| w.max(e.abs()));
                o.worst = o.worst.max(worst);
                if worst > tol {
                    o.fail(format!("{what}: leaves the band again ({worst:.3})"));
                }
            }
            _ => o.fail(format!(
                "{what}: not settled in {settle} frames: {errs:.3?}"
            )),
        }
        // Overshoot: the error changes sign by more than the band.
        let first = errs[0].signum();
        if errs.iter().any(|e| e.signum() != first && e.abs() > tol) {
            o.fail(format!("{what}: overshoots: {errs:.3?}"));
        }
    }

    r.case("cost model k/cutoff², 100× jump up and down", || {
        let target = 40_000u32;
        let mut c = FrameRateController::new(target, 2.0);
        let mut k = 4.0 * 40_000.0f64;
        let cost = |k: f64, cut: f32| (500.0 + k / f64::from(cut * cut)) as u32;
        let _ = run(&mut c, 30, |_, cut| cost(k, cut));
        let mut o = Outcome {
            unit: "log",
            limit: 0.1,
            ..Outcome::default()
        };
        k *= 100.0;
        let (errs, cuts) = run(&mut c, 40, |_, cut| cost(k, cut));
        judge(&mut o, "up", &errs, &cuts, 12, 0.1);
        k /= 100.0;
        let (errs, cuts) = run(&mut c, 40, |_, cut| cost(k, cut));
        judge(&mut o, "down", &errs, &cuts, 12, 0.1);
        o
    });
    r.case("clamps: frame times 0 and u32::MAX, target 0", || {
        let mut o = Outcome {
            unit: "",
            ..Outcome::default()
        };
        let mut c = FrameRateController::new(0, 4.0);
        for t in [0, u32::MAX, 0, 1, u32::MAX, u32::MAX] {
            let cut = c.update(t);
            if !(FINEST_CUTOFF_PX..=64.0).contains(&cut) || !cut.is_finite() {
                o.fail(format!("cutoff {cut} after a frame of {t} µs"));
            }
        }
        let mut steps = 0;
        while c.refine_idle().is_some() {
            steps += 1;
            if steps > 64 {
                o.fail("idle refinement does not stop");
                break;
            }
        }
        o.notes = format!("idle refinement stops after {steps} steps");
        o
    });
    let Some(b) = r.setup("blob, tri-grid depth 5", || Baked::new(&blob(40), 3, 5)) else {
        return;
    };
    r.case(
        "real traversal cost (nodes visited), 100× jump up and down",
        || {
            let tg = b.tg();
            let camera = Camera::orbit(world_sphere(b.bounds(), &Placement::IDENTITY), STD, 45.0);
            let nodes = |cut: f32| {
                let opts = RenderOptions {
                    cutoff_px: cut,
                    ..RenderOptions::default()
                };
                let frame = TgFrame::new(tg.header(), &Placement::IDENTITY, &camera, &opts)
                    .expect("frame set-up");
                let mut sink = pocketsplat_core::splat::NullSink::default();
                render_tg(&tg, &frame, &mut sink).nodes_visited
            };
            // 1 µs per node, then 100 µs per node (a slower device, or 100× the detail), then back.
            let target = nodes(2.0);
            let mut c = FrameRateController::new(target, 1.0);
            let mut ns = 1.0f64;
            let mut cost = |_: usize, cut: f32| (ns * f64::from(nodes(cut))) as u32;
            let _ = run(&mut c, 25, &mut cost);
            let mut o = Outcome {
                unit: "log",
                limit: 0.25,
                ..Outcome::default()
            };
            ns = 100.0;
            let mut cost = |_: usize, cut: f32| (ns * f64::from(nodes(cut))) as u32;
            let (errs, cuts) = run(&mut c, 25, &mut cost);
            // The node count is a step function of the cutoff and not 1/cutoff², so the band is wider.
            judge(&mut o, "up", &errs, &cuts, 12, 0.25);
            ns = 1.0;
            let mut cost = |_: usize, cut: f32| (ns * f64::from(nodes(cut))) as u32;
            let (errs, cuts) = run(&mut c, 25, &mut cost);
            judge(&mut o, "down", &errs, &cuts, 12, 0.25);
            o
        },
    );
}
