//! `pocketsplat view INPUT`: a point file in a window that follows the mouse and keys.
//!
//! The window itself (minifb) is [`Viewer`] (`window`), behind the `window` feature. What needs no
//! display lives beside it, so it is tested without one: what the command was asked for
//! (`options`: [`ViewOptions`], [`KEYS_HELP`]), the model it shows ([`Shown`], any format the core opens: `scene`), the
//! camera and light driven by [`Action`]s (`state`: [`ViewState`]), progressive refinement
//! (`refine`: [`Refiner`]) and the HUD (`hud`: [`draw_hud`]). The modules depend on each other in
//! that order only: `window` on all the others, `hud` on `state`, `state` on `options` and
//! `refine`.

mod hud;
mod options;
mod refine;
mod scene;
mod state;
#[cfg(feature = "window")]
mod window;

use std::path::Path;

use anyhow::{bail, Result};

pub use hud::{draw_hud, HudInfo};
pub use options::{ViewOptions, KEYS_HELP};
pub use refine::{Refiner, MAX_CUTOFF_PX};
pub use scene::Shown;
pub use state::{panned_camera, Action, Change, HudMode, ViewState, DIST_RANGE, MAX_ELEVATION_DEG};
#[cfg(feature = "window")]
pub use window::Viewer;

/// The `view` command: opens `input`, then the window.
///
/// # Errors
/// When the input cannot be read or is not a point file; when there is no display (the message
/// says to use `pocketsplat render`); when the crate was built without the `window` feature.
pub fn run(input: &Path, opts: &ViewOptions) -> Result<()> {
    if ![1, 2, 4].contains(&opts.scale) {
        bail!("--scale {}: must be 1, 2 or 4", opts.scale);
    }
    if let Some(fps) = opts.target_fps {
        if !(fps > 0.0 && fps.is_finite()) {
            bail!("--target-fps {fps}: must be a positive number");
        }
    }
    let bytes = crate::fsutil::read_file(input)?;
    let mut scene = Shown::open(input, &bytes)?;
    let name = input.file_name().map_or_else(
        || input.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    show(
        &format!("pocketsplat view: {name}"),
        input,
        &mut scene,
        opts,
    )
}

#[cfg(feature = "window")]
fn show(title: &str, input: &Path, scene: &mut Shown<'_>, opts: &ViewOptions) -> Result<()> {
    let viewer = Viewer::open_scaled(title, opts.scale, opts.settings.size).map_err(|e| {
        let why = match std::env::var_os("DISPLAY") {
            None => "DISPLAY is not set".to_string(),
            Some(d) => format!(
                "cannot open a window on DISPLAY={}: {e}",
                d.to_string_lossy()
            ),
        };
        anyhow::anyhow!(
            "no display ({why}): `pocketsplat view` needs an X11 display; for an image without \
             one, use `pocketsplat render {} -o OUT.png`",
            input.display()
        )
    })?;
    viewer.run_scene(scene, opts)
}

#[cfg(not(feature = "window"))]
fn show(_title: &str, input: &Path, _scene: &mut Shown<'_>, _opts: &ViewOptions) -> Result<()> {
    bail!(
        "built without the `window` feature: pocketsplat view needs a window; use `pocketsplat \
         render {} -o OUT.png`",
        input.display()
    )
}
