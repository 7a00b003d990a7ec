//! Frame-rate control and progressive refinement, for every format (QSplat §4.2: "the cutoff is
//! scaled each frame by the ratio of actual to desired frame time; when the user stops, it refines
//! progressively down to 1 pixel").
//!
//! The work of a frame grows about as `1/cutoff²` (splats cover the image), so the controller moves
//! the cutoff by `(actual/desired)^(gain/2)` per frame in the log domain. With `gain < 1` this is a
//! damped step: for the `1/cutoff²` model the log error shrinks by a factor `1 − gain` every frame,
//! never changing sign, so a 100× cost jump settles in a bounded number of frames with no oscillation.
//! The per-frame factor is also clamped so one outlier frame cannot throw the cutoff far.
//! Runs once per frame (setup), so it may use floats.

/// Smallest cutoff, pixels: full detail.
pub const FINEST_CUTOFF_PX: f32 = 1.0;

/// The frame-rate controller.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameRateController {
    target_us: f32,
    cutoff: f32,
    max_cutoff: f32,
    gain: f32,
    max_step: f32,
}

impl FrameRateController {
    /// A controller holding frames at `target_us` microseconds, starting at `cutoff_px`.
    pub fn new(target_us: u32, cutoff_px: f32) -> Self {
        Self {
            target_us: target_us.max(1) as f32,
            cutoff: cutoff_px.max(FINEST_CUTOFF_PX),
            max_cutoff: 64.0,
            gain: 0.6,
            max_step: 8.0,
        }
    }

    /// The cutoff to draw the next frame with, pixels.
    pub fn cutoff(&self) -> f32 {
        self.cutoff
    }

    /// The desired frame time, microseconds.
    pub fn target_us(&self) -> u32 {
        self.target_us as u32
    }

    /// Feeds the measured time of the frame just drawn (while the view moves); returns the next
    /// cutoff.
    pub fn update(&mut self, frame_us: u32) -> f32 {
        let ratio = frame_us.max(1) as f32 / self.target_us;
        let step = libm::powf(ratio, 0.5 * self.gain).clamp(1.0 / self.max_step, self.max_step);
        self.cutoff = (self.cutoff * step).clamp(FINEST_CUTOFF_PX, self.max_cutoff);
        self.cutoff
    }

    /// One step of progressive refinement while nothing moves: the cutoff shrinks by √2 per idle
    /// frame down to 1 px. Returns the cutoff to draw, or `None` when the image is already at full
    /// detail and need not be redrawn.
    pub fn refine_idle(&mut self) -> Option<f32> {
        if self.cutoff <= FINEST_CUTOFF_PX {
            return None;
        }
        self.cutoff = (self.cutoff / core::f32::consts::SQRT_2).max(FINEST_CUTOFF_PX);
        Some(self.cutoff)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Frame time of a model whose cost is `k / cutoff²` µs, plus a fixed part.
    fn frame_us(k: f32, cutoff: f32) -> u32 {
        (500.0 + k / (cutoff * cutoff)) as u32
    }

    #[test]
    fn settles_after_a_100x_cost_jump_without_oscillating() {
        let target = 50_000;
        let mut c = FrameRateController::new(target, 2.0);
        let mut k = 40_000.0;
        let mut log_errors = std::vec::Vec::new();
        for frame in 0..80 {
            if frame == 30 {
                k *= 100.0; // zooming into detail
            }
            let t = frame_us(k, c.cutoff());
            log_errors.push((t as f32 / target as f32).ln());
            c.update(t);
        }
        // After the jump: the error keeps one sign (no oscillation) and is within 10 % after 12 frames.
        let after = &log_errors[30..];
        let sign = after[0].signum();
        assert!(
            after.iter().all(|e| e.signum() == sign || e.abs() < 0.02),
            "oscillates: {after:?}"
        );
        assert!(
            after[12..].iter().all(|e| e.abs() < 0.1),
            "not settled: {after:?}"
        );
        // And back down by 100×.
        let mut c2 = c;
        for _ in 0..20 {
            let t = frame_us(k / 100.0, c2.cutoff());
            c2.update(t);
        }
        assert!(
            ((frame_us(k / 100.0, c2.cutoff()) as f32 / target as f32).ln()).abs() < 0.1
                || c2.cutoff() == 1.0
        );
    }

    #[test]
    fn refines_to_one_pixel_when_idle_then_stops() {
        let mut c = FrameRateController::new(30_000, 11.0);
        let mut steps = 0;
        while let Some(cut) = c.refine_idle() {
            assert!(cut >= 1.0);
            steps += 1;
        }
        assert_eq!(c.cutoff(), 1.0);
        assert_eq!(steps, 7, "log√2(11) rounded up");
        assert_eq!(c.refine_idle(), None);
    }

    #[test]
    fn outliers_and_zero_times_are_clamped() {
        let mut c = FrameRateController::new(10_000, 4.0);
        assert!(c.update(u32::MAX) <= 32.0);
        let mut c = FrameRateController::new(10_000, 4.0);
        assert!(c.update(0) >= 0.5);
    }
}
