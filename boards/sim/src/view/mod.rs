//! `pocketsplat view INPUT`: a point file in a window that follows the mouse and keys.
//!
//! The window itself (minifb) is in `window`, behind the `window` feature. What needs no
//! display lives here, so it is tested without one: the [`Scene`] a format plugs in as (this
//! module), the camera and light driven by [`Action`]s (`state`: [`ViewState`]), progressive
//! refinement (`refine`: [`Refiner`]) and the HUD (`hud`: [`draw_hud`]).

mod hud;
mod refine;
mod state;
#[cfg(feature = "window")]
pub mod window;

use std::path::{Path, PathBuf};

use anyhow::{bail, Result};
use pocketsplat_core::format::FileFormat;
use pocketsplat_core::qs::QSplat;
use pocketsplat_core::raster::Framebuffer;
use pocketsplat_core::shade::ShadingTable;
use pocketsplat_core::tg::{TriGrid, Verify};

pub use hud::{draw_hud, HudInfo, HudMode};
pub use refine::{Refiner, MAX_CUTOFF_PX};
pub use state::{panned_camera, Action, Change, ViewState, DIST_RANGE, MAX_ELEVATION_DEG};

use crate::qsplat::render_qs_from;
use crate::render::{render_tg_from, FrameBuffers, FrameReport, Settings, ShadowMode};

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

/// Something the viewer can draw: a model in one of the point formats. A new format plugs in by
/// implementing this and adding a case to [`open_scene`].
pub trait Scene {
    /// A short description for the HUD, ASCII (the HUD font has no other glyphs).
    fn label(&self) -> String;

    /// Draws one frame into `out` (cleared first) with the orbit centre moved by `pan` (world
    /// units of the model's bounding-sphere radius), then calls `overlay` on the framebuffer.
    ///
    /// # Errors
    /// When the frame cannot be set up.
    fn render(
        &mut self,
        settings: &Settings,
        pan: [f64; 3],
        out: &mut FrameBuffers,
        overlay: &mut dyn FnMut(&mut Framebuffer<'_>, &FrameReport),
    ) -> Result<FrameReport>;
}

/// A tri-grid (or octree) `.tg` file as a [`Scene`].
pub struct TgScene<'a> {
    grid: TriGrid<'a>,
    table: Box<ShadingTable<1>>,
}

impl<'a> TgScene<'a> {
    /// Wraps an opened grid.
    pub fn new(grid: TriGrid<'a>) -> Self {
        Self {
            grid,
            table: Box::new(ShadingTable::<1>::new()),
        }
    }
}

impl Scene for TgScene<'_> {
    fn label(&self) -> String {
        let h = self.grid.header();
        let kind = match h.rho {
            2 => "octree".to_string(),
            3 => "tri-grid".to_string(),
            r => format!("rho {r} grid"),
        };
        format!("{kind} d{}", h.depth)
    }

    fn render(
        &mut self,
        settings: &Settings,
        pan: [f64; 3],
        out: &mut FrameBuffers,
        overlay: &mut dyn FnMut(&mut Framebuffer<'_>, &FrameReport),
    ) -> Result<FrameReport> {
        let cam = panned_camera(settings, self.grid.header().bounds64, pan);
        render_tg_from(&self.grid, settings, &cam, &mut self.table, out, overlay)
    }
}

/// A QSplat `.qs` file as a [`Scene`] (no shadows: the QSplat renderer has none).
pub struct QsScene<'a> {
    file: QSplat<'a>,
    table: Box<ShadingTable<1>>,
}

impl Scene for QsScene<'_> {
    fn label(&self) -> String {
        format!("QSplat {} points", self.file.counts().leaves)
    }

    fn render(
        &mut self,
        settings: &Settings,
        pan: [f64; 3],
        out: &mut FrameBuffers,
        overlay: &mut dyn FnMut(&mut Framebuffer<'_>, &FrameReport),
    ) -> Result<FrameReport> {
        let cam = panned_camera(settings, self.file.bounds(), pan);
        let settings = Settings {
            shadows: ShadowMode::Off,
            ..*settings
        };
        render_qs_from(&self.file, &settings, &cam, &mut self.table, out, overlay)
    }
}

/// Opens the bytes of a point file as a [`Scene`], by the file's magic.
///
/// # Errors
/// When the bytes are not a format the viewer knows, or the file is damaged; the message names
/// `path`.
pub fn open_scene<'a>(path: &Path, bytes: &'a [u8]) -> Result<Box<dyn Scene + 'a>> {
    match FileFormat::sniff(bytes) {
        Some(FileFormat::TriGrid) => {
            let grid = TriGrid::open(bytes, Verify::Full)
                .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
            return Ok(Box::new(TgScene::new(grid)));
        }
        Some(FileFormat::Pack) => return crate::scene::cmd::open_view_scene(path, bytes),
        Some(FileFormat::QSplat) => {
            let file =
                QSplat::open(bytes).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
            return Ok(Box::new(QsScene {
                file,
                table: Box::new(ShadingTable::<1>::new()),
            }));
        }
        None => {}
    }
    bail!(
        "{}: not a point file `pocketsplat view` can show (expected a .tg, .qs or .pack file; bake \
         a mesh first with `pocketsplat bake MESH -o FILE.tg`)",
        path.display()
    )
}

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
    let mut scene = open_scene(input, &bytes)?;
    let name = input.file_name().map_or_else(
        || input.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    show(
        &format!("pocketsplat view: {name}"),
        input,
        scene.as_mut(),
        opts,
    )
}

#[cfg(feature = "window")]
fn show(title: &str, input: &Path, scene: &mut dyn Scene, opts: &ViewOptions) -> Result<()> {
    let viewer = window::Viewer::open_scaled(title, opts.scale).map_err(|e| {
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
fn show(_title: &str, input: &Path, _scene: &mut dyn Scene, _opts: &ViewOptions) -> Result<()> {
    bail!(
        "built without the `window` feature: pocketsplat view needs a window; use `pocketsplat \
         render {} -o OUT.png`",
        input.display()
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_files_are_refused_with_a_hint() {
        let e = open_scene(Path::new("x.bin"), b"not a point file")
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("x.bin") && e.contains("pocketsplat bake"), "{e}");
    }
}
