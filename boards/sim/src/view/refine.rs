//! Progressive refinement and frame-rate control of the viewer: the cutoff of each frame.

use pocketsplat_core::lod::{FrameRateController, FINEST_CUTOFF_PX};

/// Coarsest cutoff the user can ask for, pixels.
pub const MAX_CUTOFF_PX: f32 = 64.0;

/// Turns the moving cutoff into the cutoff of each frame: the moving cutoff (fixed, or adapted to
/// a frame rate) while the view changes, then finer by √2 per idle frame down to 1 px, then no
/// frame at all (QSplat §4.2: "when the user stops, it refines progressively down to 1 pixel").
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Refiner {
    /// Cutoff while moving, pixels (without a controller).
    moving_px: f32,
    /// The frame last asked for: its cutoff, and the idle refinement steps from it (its frame
    /// time target is unused).
    shown: FrameRateController,
    refine: bool,
    controller: Option<FrameRateController>,
    /// The frame last asked for was a moving one (its time feeds the controller).
    last_moving: bool,
}

impl Refiner {
    /// A refiner that draws moving frames at `moving_px` (clamped to 1..=64 px).
    pub fn new(moving_px: f32) -> Self {
        let m = clamp_cutoff(moving_px);
        Self {
            moving_px: m,
            shown: FrameRateController::new(1, m),
            refine: true,
            controller: None,
            last_moving: false,
        }
    }

    /// Moving frames adapt their cutoff to hold `fps` frames per second instead
    /// ([`FrameRateController`]), starting from the moving cutoff.
    pub fn with_target_fps(mut self, fps: f32) -> Self {
        let target_us = (1e6 / fps.max(0.1)) as u32;
        self.controller = Some(FrameRateController::new(target_us, self.moving_px));
        self
    }

    /// The cutoff moving frames are drawn at, pixels.
    pub fn moving_cutoff(&self) -> f32 {
        self.controller.map_or(self.moving_px, |c| c.cutoff())
    }

    /// Whether moving frames follow a frame rate.
    pub fn is_adaptive(&self) -> bool {
        self.controller.is_some()
    }

    /// The cutoff of the frame last asked for, pixels.
    pub fn cutoff(&self) -> f32 {
        self.shown.cutoff()
    }

    /// Sets the moving cutoff (clamped to 1..=64 px); an adaptive refiner restarts from it.
    pub fn set_moving_cutoff(&mut self, px: f32) {
        self.moving_px = clamp_cutoff(px);
        if let Some(c) = &mut self.controller {
            *c = FrameRateController::new(c.target_us(), self.moving_px);
        }
    }

    /// Whether idle frames refine.
    pub fn is_refining(&self) -> bool {
        self.refine
    }

    /// Turns progressive refinement on or off.
    pub fn set_refining(&mut self, on: bool) {
        self.refine = on;
    }

    /// Whether the frame last asked for is final: nothing more will be drawn until something moves.
    pub fn is_settled(&self) -> bool {
        !self.refine || self.cutoff() <= FINEST_CUTOFF_PX
    }

    /// Records how long the frame last asked for took, microseconds. Only moving frames count:
    /// refinement frames are slower on purpose.
    pub fn frame_time(&mut self, us: u32) {
        if self.last_moving {
            if let Some(c) = &mut self.controller {
                c.update(us);
            }
        }
    }

    /// The cutoff of the next frame: the moving cutoff if the view changed, else one refinement
    /// step, else `None` (the image on screen is final; draw nothing).
    pub fn next_cutoff(&mut self, moved: bool) -> Option<f32> {
        self.last_moving = moved;
        if moved {
            self.shown = FrameRateController::new(1, self.moving_cutoff());
            return Some(self.cutoff());
        }
        if self.refine {
            // QSplat's idle step: ÷ √2 per frame down to 1 px.
            return self.shown.refine_idle();
        }
        None
    }
}

fn clamp_cutoff(px: f32) -> f32 {
    if px.is_finite() {
        px.clamp(FINEST_CUTOFF_PX, MAX_CUTOFF_PX)
    } else {
        FINEST_CUTOFF_PX
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refines_by_sqrt2_to_one_pixel_then_stops() {
        let mut r = Refiner::new(4.0);
        assert_eq!(r.next_cutoff(true), Some(4.0));
        let mut seen = vec![];
        while let Some(c) = r.next_cutoff(false) {
            seen.push(c);
        }
        // 4 → 2.83 → 2 → 1.41 → 1.
        assert_eq!(seen.len(), 4, "{seen:?}");
        assert!((seen[1] - 2.0).abs() < 1e-5);
        assert_eq!(*seen.last().unwrap(), 1.0);
        assert!(r.is_settled());
        assert_eq!(r.next_cutoff(false), None, "idle: no more frames");
        // Moving again starts from the moving cutoff.
        assert_eq!(r.next_cutoff(true), Some(4.0));
        assert!(!r.is_settled());
    }

    #[test]
    fn without_refinement_only_moving_frames_are_drawn() {
        let mut r = Refiner::new(3.0);
        r.set_refining(false);
        assert_eq!(r.next_cutoff(true), Some(3.0));
        assert!(r.is_settled());
        assert_eq!(r.next_cutoff(false), None);
        // Turned back on, it continues from where it is.
        r.set_refining(true);
        assert!((r.next_cutoff(false).unwrap() - 3.0 / 2f32.sqrt()).abs() < 1e-5);
    }

    #[test]
    fn a_one_pixel_moving_cutoff_never_refines() {
        let mut r = Refiner::new(0.25);
        assert_eq!(r.moving_cutoff(), 1.0, "clamped to the finest cutoff");
        assert_eq!(r.next_cutoff(true), Some(1.0));
        assert_eq!(r.next_cutoff(false), None);
        r.set_moving_cutoff(f32::NAN);
        assert_eq!(r.moving_cutoff(), 1.0);
        r.set_moving_cutoff(1000.0);
        assert_eq!(r.moving_cutoff(), MAX_CUTOFF_PX);
    }

    #[test]
    fn adaptive_moving_cutoff_follows_frame_time_of_moving_frames_only() {
        let mut r = Refiner::new(2.0).with_target_fps(50.0); // 20 ms
        assert_eq!(r.next_cutoff(true), Some(2.0));
        r.frame_time(80_000); // 4× too slow: coarser
        let after_slow = r.moving_cutoff();
        assert!(after_slow > 2.0, "{after_slow}");
        // Refinement frames are slow on purpose and must not move the controller.
        r.next_cutoff(false);
        r.frame_time(1_000_000);
        assert_eq!(r.moving_cutoff(), after_slow);
        assert_eq!(r.next_cutoff(true), Some(after_slow));
    }
}
