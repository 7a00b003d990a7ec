//! A model of any format, opened by its magic: what [`super::render`] draws.

use super::formats::Drawable;
use super::{Drawn, Layer, ModelError, Phase, RenderError, RenderOptions, Target};
use crate::camera::{Camera, Sphere, View};
use crate::format::FileFormat;
use crate::raster::DepthTarget;
use crate::shade::{Material, ShadowMode};

/// A validated, memory-resident model of any format this build reads: what [`render`](super::render()) draws.
// Unboxed: there is no heap, and a firmware holds one model (a tri-grid's header and level
// directory are its largest part, about 300 bytes; a scene's opened objects ~2 KB).
///
/// Its variants are the formats the build's features enable: match with a `_` arm.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
#[non_exhaustive]
pub enum Model<'a> {
    /// A tri-grid (`.tg`).
    #[cfg(feature = "trigrid")]
    TriGrid(crate::tg::TriGrid<'a>),
    /// A QSplat 1.0 file (`.qs`).
    #[cfg(feature = "qsplat")]
    QSplat(crate::qs::QSplat<'a>),
    /// A scene pack (`.pack`) with its objects opened.
    #[cfg(feature = "scene")]
    Scene(crate::scene::Scene<'a>),
}

/// Runs `$body` with `$m` bound to the model's reader, whatever its format ([`Drawable`]): the
/// one place that lists the variants.
macro_rules! each_format {
    ($model:expr, $m:ident => $body:expr) => {
        match $model {
            #[cfg(feature = "trigrid")]
            Model::TriGrid($m) => $body,
            #[cfg(feature = "qsplat")]
            Model::QSplat($m) => $body,
            #[cfg(feature = "scene")]
            Model::Scene($m) => $body,
        }
    };
}

impl<'a> Model<'a> {
    /// Opens `bytes` in the format its magic names ([`FileFormat::sniff`]), checking it whole.
    ///
    /// # Errors
    /// [`ModelError`]: an unknown magic, a format this build leaves out, or a damaged file.
    pub fn open(bytes: &'a [u8]) -> Result<Self, ModelError> {
        #[cfg(feature = "trigrid")]
        return Self::open_with(bytes, crate::tg::Verify::Full);
        #[cfg(not(feature = "trigrid"))]
        Self::open_any(bytes)
    }

    /// [`Model::open`] with `verify` saying how much of a tri-grid (or a pack's) to check: a
    /// firmware may trust the flash it was written to ([`Verify::Structure`](crate::tg::Verify::Structure)).
    ///
    /// # Errors
    /// As [`Model::open`].
    #[cfg(feature = "trigrid")]
    pub fn open_with(bytes: &'a [u8], verify: crate::tg::Verify) -> Result<Self, ModelError> {
        match FileFormat::sniff(bytes) {
            Some(FileFormat::TriGrid) => crate::tg::TriGrid::open(bytes, verify)
                .map(Model::TriGrid)
                .map_err(ModelError::TriGrid),
            #[cfg(feature = "scene")]
            Some(FileFormat::Pack) => {
                let pack = crate::scene::Pack::open(bytes).map_err(ModelError::Pack)?;
                crate::scene::Scene::open(pack, verify)
                    .map(Model::Scene)
                    .map_err(ModelError::Scene)
            }
            _ => Self::open_any(bytes),
        }
    }

    /// The formats that need no [`Verify`] (QSplat is always checked whole), and the refusals.
    fn open_any(bytes: &'a [u8]) -> Result<Self, ModelError> {
        match FileFormat::sniff(bytes) {
            #[cfg(feature = "qsplat")]
            Some(FileFormat::QSplat) => crate::qs::QSplat::open(bytes)
                .map(Model::QSplat)
                .map_err(ModelError::QSplat),
            Some(format) => Err(ModelError::NotBuilt(format)),
            None => Err(ModelError::UnknownFormat),
        }
    }

    /// The model's format.
    pub fn format(&self) -> FileFormat {
        each_format!(self, m => m.format())
    }

    /// The sphere the views orbit: around the model's bounding box (a tri-grid's precise box when
    /// it has one), or a scene's.
    pub fn sphere(&self) -> Sphere {
        each_format!(self, m => m.sphere())
    }

    /// The orbit camera of `view` about [`Model::sphere`]: the default 45° field of view (a
    /// scene's own), for the reference 240 × 320 image ([`render`](super::render()) fits it to the target).
    pub fn orbit(&self, view: View) -> Camera {
        each_format!(self, m => m.orbit(view))
    }

    /// The material the shading table gives samples drawn with `base`: `base`, in white for a
    /// coloured QSplat file (whose colours then modulate it; a scene's objects bring their own).
    pub fn material(&self, base: Material) -> Material {
        each_format!(self, m => m.material(base))
    }

    /// The options a model is drawn with by default: [`RenderOptions::default`], or a scene
    /// pack's light, shadows and shadow map size.
    pub fn options(&self) -> RenderOptions {
        each_format!(self, m => m.options())
    }

    /// The shadow modes [`render`](super::render()) draws this model in, in this build: all three for a tri-grid or
    /// a scene with the `shadows` feature, [`ShadowMode::Off`] otherwise (QSplat files have no
    /// shadows).
    pub fn shadow_modes(&self) -> &'static [ShadowMode] {
        each_format!(self, m => m.shadow_modes())
    }

    /// One frame of the model for `camera` (fitted to the target) into `target`: its format's
    /// set-up, then the pipeline.
    pub(super) fn draw<P: DepthTarget, L: Layer, const M: usize>(
        &self,
        camera: &Camera,
        options: &RenderOptions,
        target: &mut Target<'_, P, M>,
        layer: &mut L,
        mark: &mut impl FnMut(Phase),
    ) -> Result<Drawn, RenderError> {
        each_format!(self, m => m.draw(camera, options, target, layer, mark))
    }
}

#[cfg(feature = "trigrid")]
impl<'a> From<crate::tg::TriGrid<'a>> for Model<'a> {
    fn from(grid: crate::tg::TriGrid<'a>) -> Self {
        Model::TriGrid(grid)
    }
}

#[cfg(feature = "qsplat")]
impl<'a> From<crate::qs::QSplat<'a>> for Model<'a> {
    fn from(file: crate::qs::QSplat<'a>) -> Self {
        Model::QSplat(file)
    }
}

#[cfg(feature = "scene")]
impl<'a> From<crate::scene::Scene<'a>> for Model<'a> {
    fn from(scene: crate::scene::Scene<'a>) -> Self {
        Model::Scene(scene)
    }
}
