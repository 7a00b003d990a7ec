//! What `pocketsplat view` is asked for ([`ViewOptions`]) and the mouse and keys it answers to
//! ([`KEYS_HELP`]).

use std::path::PathBuf;

use crate::render::Settings;

/// The mouse and keys, as `pocketsplat view --help` and the HUD list them.
pub const KEYS_HELP: &str = "\
Mouse and keys:
  left-drag, arrows      orbit (left/right: azimuth, up/down: elevation)
  right-drag, shift-drag, middle-drag, W A S D
                         pan (move the orbit centre across the view)
  wheel, + -             zoom
  J L, I K               light azimuth, light elevation
  [ ]                    cutoff finer, coarser (the cutoff used while moving)
  C                      kernel: square / round
  O                      shadows: off / one-pass / two-pass
  P                      progressive refinement on / off
  R                      back to the starting view
  V                      colour by resolution: tint splats by their levels above full detail
  H                      HUD: stats and help / stats / off
  Esc                    quit

While anything moves, frames are drawn at the moving cutoff; once nothing has moved for a frame,
the cutoff is divided by √2 per frame down to 1 px (QSplat §4.2), then nothing is redrawn.";

/// What `pocketsplat view` was asked for.
#[derive(Clone, Debug)]
pub struct ViewOptions {
    /// Starting view, light, kernel and shadows; `cutoff_px` is the cutoff used while moving.
    pub settings: Settings,
    /// Window pixels per framebuffer pixel: 1, 2 or 4.
    pub scale: usize,
    /// Progressive refinement when idle.
    pub refine: bool,
    /// Hold frames at this rate while moving by adapting the cutoff (QSplat's frame-rate control),
    /// instead of a fixed moving cutoff.
    pub target_fps: Option<f32>,
    /// Quit after this many window updates (for tests and scripted screenshots).
    pub frames: Option<u64>,
    /// Write the frame on screen as a PNG whenever it is fully refined, and at exit.
    pub screenshot: Option<PathBuf>,
}

impl Default for ViewOptions {
    fn default() -> Self {
        Self {
            settings: Settings {
                cutoff_px: 2.0,
                ..Settings::default()
            },
            scale: 2,
            refine: true,
            target_fps: None,
            frames: None,
            screenshot: None,
        }
    }
}
