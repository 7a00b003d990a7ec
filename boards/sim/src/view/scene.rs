//! What the viewer draws: any model the core opens by its magic (a tri-grid, a QSplat file, a
//! scene pack), through the core's one pipeline ([`crate::render::render_from`]).

use std::path::Path;

use anyhow::{bail, Result};
use pocketsplat_core::format::FileFormat;
use pocketsplat_core::render::Model;
use pocketsplat_core::shade::ShadingTable;
use pocketsplat_core::tg::Verify;

use super::state::panned_camera;
use crate::render::{render_with, FrameBuffers, FrameReport, Image, Settings, ShadowMode};
use crate::scene::render::{scene_table, SceneTable};

/// A model in the viewer: the core's [`Model`] and its shading table (kept between frames, so that
/// it is rebuilt only when the view turns).
pub struct Shown<'a> {
    model: Model<'a>,
    table: Table,
}

/// A model's table: one material, or a slot per material of a scene.
enum Table {
    One(Box<ShadingTable<1>>),
    Scene(Box<SceneTable>),
}

impl<'a> Shown<'a> {
    /// A model to show.
    pub fn new(model: Model<'a>) -> Self {
        let table = match model {
            Model::Scene(_) => Table::Scene(scene_table()),
            _ => Table::One(Box::new(ShadingTable::new())),
        };
        Self { model, table }
    }

    /// Opens the bytes of a point file, by its magic.
    ///
    /// # Errors
    /// When the bytes are not a format the viewer knows, or the file is damaged; the message names
    /// `path`.
    pub fn open(path: &Path, bytes: &'a [u8]) -> Result<Self> {
        let model = match FileFormat::sniff(bytes) {
            Some(FileFormat::Pack) => Model::Scene(crate::input::open_pack(path, bytes)?),
            Some(_) => Model::open_with(bytes, Verify::Full)
                .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?,
            None => bail!(
                "{}: not a point file `pocketsplat view` can show (expected a .tg, .qs or .pack \
                 file; bake a mesh first with `pocketsplat bake MESH -o FILE.tg`)",
                path.display()
            ),
        };
        Ok(Self::new(model))
    }

    /// The model.
    pub fn model(&self) -> &Model<'a> {
        &self.model
    }

    /// A short description for the HUD, ASCII (the HUD font has no other glyphs).
    pub fn label(&self) -> String {
        match &self.model {
            Model::TriGrid(grid) => {
                let h = grid.header();
                let kind = match h.rho {
                    2 => "octree".to_string(),
                    3 => "tri-grid".to_string(),
                    r => format!("rho {r} grid"),
                };
                format!("{kind} d{}", h.depth)
            }
            Model::QSplat(file) => format!("QSplat {} points", file.counts().leaves),
            Model::Scene(scene) => format!("scene, {} objects", scene.len()),
            other => other.format().name().to_string(),
        }
    }

    /// Draws one frame into `out` (cleared first) with the orbit centre moved by `pan` (units of
    /// the model's bounding-sphere radius), then calls `overlay` on the image. A QSplat file is
    /// drawn without shadows (it has none), whatever the settings.
    ///
    /// # Errors
    /// When the frame cannot be set up.
    pub fn render(
        &mut self,
        settings: &Settings,
        pan: [f64; 3],
        out: &mut FrameBuffers,
        overlay: &mut dyn FnMut(&mut Image, &FrameReport),
    ) -> Result<FrameReport> {
        let mut settings = *settings;
        if matches!(self.model, Model::QSplat(_)) {
            settings.shadows = ShadowMode::Off;
        }
        let cam = panned_camera(&settings, self.model.sphere(), pan);
        match &mut self.table {
            Table::One(t) => render_with(&self.model, &settings, &cam, t, out, overlay),
            Table::Scene(t) => render_with(&self.model, &settings, &cam, t, out, overlay),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_files_are_refused_with_a_hint() {
        let e = Shown::open(Path::new("x.bin"), b"not a point file")
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("x.bin") && e.contains("pocketsplat bake"), "{e}");
    }
}
