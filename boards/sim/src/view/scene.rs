//! What the viewer draws: a [`Scene`], one per point format (a tri-grid, a QSplat file, a scene
//! pack), opened by the file's magic ([`open_scene`]).

use std::path::Path;

use anyhow::{bail, Result};
use pocketsplat_core::format::FileFormat;
use pocketsplat_core::qs::QSplat;
use pocketsplat_core::raster::Framebuffer;
use pocketsplat_core::shade::ShadingTable;
use pocketsplat_core::tg::{TriGrid, Verify};

use super::state::panned_camera;
use crate::levels::Levels;
use crate::qsplat::render_qs_from;
use crate::render::{render_tg_from, FrameBuffers, FrameReport, Settings, ShadowMode};
use crate::scene::render::{render_pack_from, scene_table, PackSettings, SceneTable};

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

/// A pack as a scene of `pocketsplat view`: the viewer's settings (view, light, cutoff, kernel,
/// shadows) drive the frame; pans move the orbit centre in units of the scene sphere's radius.
pub struct PackScene<'a> {
    scene: pocketsplat_core::scene::Scene<'a>,
    table: Box<SceneTable>,
}

impl<'a> PackScene<'a> {
    /// Wraps an opened scene.
    pub fn new(scene: pocketsplat_core::scene::Scene<'a>) -> Self {
        Self {
            scene,
            table: scene_table(),
        }
    }
}

impl Scene for PackScene<'_> {
    fn label(&self) -> String {
        format!("scene, {} objects", self.scene.len())
    }

    fn render(
        &mut self,
        settings: &Settings,
        pan: [f64; 3],
        out: &mut FrameBuffers,
        overlay: &mut dyn FnMut(&mut Framebuffer<'_>, &FrameReport),
    ) -> Result<FrameReport> {
        let s = PackSettings::from_settings(settings)?;
        let cam = s.camera(&self.scene, pan);
        let levels = settings
            .color_by_level
            .then(|| Levels::of_scene(&self.scene));
        let frame = render_pack_from(
            &self.scene,
            &cam,
            &s.options(&self.scene),
            levels.as_ref(),
            &mut self.table,
            out,
            |fb, f| overlay(fb, &f.report()),
        )?;
        Ok(frame.report())
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
        Some(FileFormat::Pack) => {
            let scene = crate::input::open_pack(path, bytes)?;
            return Ok(Box::new(PackScene::new(scene)));
        }
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
