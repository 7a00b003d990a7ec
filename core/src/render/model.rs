//! A model of any format, opened by its magic: what [`super::render`] draws.

use core::fmt;

use super::RenderOptions;
use crate::camera::{Camera, Sphere, View, DEFAULT_FOV_DEG};
use crate::format::FileFormat;
use crate::shade::{Material, ShadowMode};

#[cfg(feature = "qsplat")]
use crate::qs::{shading_material, QSplat, QsError};
#[cfg(feature = "scene")]
use crate::scene::{Pack, PackError, Scene, SceneError};
#[cfg(feature = "trigrid")]
use crate::tg::{TgError, TriGrid, Verify};

/// A validated, memory-resident model of any format this build reads: what [`render`](super::render()) draws.
// Unboxed: there is no heap, and a firmware holds one model (a tri-grid's header and level
// directory are its largest part, about 300 bytes; a scene's opened objects ~2 KB).
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
pub enum Model<'a> {
    /// A tri-grid (`.tg`).
    #[cfg(feature = "trigrid")]
    TriGrid(TriGrid<'a>),
    /// A QSplat 1.0 file (`.qs`).
    #[cfg(feature = "qsplat")]
    QSplat(QSplat<'a>),
    /// A scene pack (`.pack`) with its objects opened.
    #[cfg(feature = "scene")]
    Scene(Scene<'a>),
    /// No format at all: a build with none of the format features (never constructed).
    #[doc(hidden)]
    #[cfg(not(any(feature = "trigrid", feature = "qsplat")))]
    None(core::marker::PhantomData<&'a ()>, core::convert::Infallible),
}

/// Why a file cannot be opened as a [`Model`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ModelError {
    /// The first bytes are no format's magic.
    UnknownFormat,
    /// A format this build leaves out (its cargo feature is off).
    NotBuilt(FileFormat),
    /// Not a valid tri-grid.
    #[cfg(feature = "trigrid")]
    TriGrid(TgError),
    /// Not a valid QSplat file.
    #[cfg(feature = "qsplat")]
    QSplat(QsError),
    /// Not a valid scene pack.
    #[cfg(feature = "scene")]
    Pack(PackError),
    /// A scene pack one of whose objects is not valid or cannot be drawn.
    #[cfg(feature = "scene")]
    Scene(SceneError),
}

impl core::error::Error for ModelError {}

impl fmt::Display for ModelError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ModelError::UnknownFormat => {
                write!(
                    f,
                    "not a tri-grid, QSplat file or scene pack (unknown magic)"
                )
            }
            ModelError::NotBuilt(format) => write!(
                f,
                "a {} file: this build leaves its format out (cargo feature `{}`)",
                format.name(),
                format.feature()
            ),
            #[cfg(feature = "trigrid")]
            ModelError::TriGrid(e) => write!(f, "tri-grid: {e}"),
            #[cfg(feature = "qsplat")]
            ModelError::QSplat(e) => write!(f, "QSplat: {e}"),
            #[cfg(feature = "scene")]
            ModelError::Pack(e) => write!(f, "scene pack: {e}"),
            #[cfg(feature = "scene")]
            ModelError::Scene(e) => write!(f, "scene pack: {e}"),
        }
    }
}

impl<'a> Model<'a> {
    /// Opens `bytes` in the format its magic names ([`FileFormat::sniff`]), checking it whole.
    ///
    /// # Errors
    /// [`ModelError`]: an unknown magic, a format this build leaves out, or a damaged file.
    pub fn open(bytes: &'a [u8]) -> Result<Self, ModelError> {
        #[cfg(feature = "trigrid")]
        return Self::open_with(bytes, Verify::Full);
        #[cfg(not(feature = "trigrid"))]
        Self::open_any(bytes)
    }

    /// [`Model::open`] with `verify` saying how much of a tri-grid (or a pack's) to check: a
    /// firmware may trust the flash it was written to ([`Verify::Structure`]).
    ///
    /// # Errors
    /// As [`Model::open`].
    #[cfg(feature = "trigrid")]
    pub fn open_with(bytes: &'a [u8], verify: Verify) -> Result<Self, ModelError> {
        match FileFormat::sniff(bytes) {
            Some(FileFormat::TriGrid) => TriGrid::open(bytes, verify)
                .map(Model::TriGrid)
                .map_err(ModelError::TriGrid),
            #[cfg(feature = "scene")]
            Some(FileFormat::Pack) => {
                let pack = Pack::open(bytes).map_err(ModelError::Pack)?;
                Scene::open(pack, verify)
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
            Some(FileFormat::QSplat) => QSplat::open(bytes)
                .map(Model::QSplat)
                .map_err(ModelError::QSplat),
            Some(format) => Err(ModelError::NotBuilt(format)),
            None => Err(ModelError::UnknownFormat),
        }
    }

    /// The model's format.
    pub fn format(&self) -> FileFormat {
        match self {
            #[cfg(feature = "trigrid")]
            Model::TriGrid(_) => FileFormat::TriGrid,
            #[cfg(feature = "qsplat")]
            Model::QSplat(_) => FileFormat::QSplat,
            #[cfg(feature = "scene")]
            Model::Scene(_) => FileFormat::Pack,
            #[cfg(not(any(feature = "trigrid", feature = "qsplat")))]
            Model::None(_, never) => match *never {},
        }
    }

    /// The sphere the views orbit: around the model's bounding box (a tri-grid's precise box when
    /// it has one), or a scene's.
    pub fn sphere(&self) -> Sphere {
        match self {
            #[cfg(feature = "trigrid")]
            Model::TriGrid(grid) => Sphere::from_bounds_f64(grid.header().bounds64),
            #[cfg(feature = "qsplat")]
            Model::QSplat(file) => Sphere::from_bounds(file.bounds()),
            #[cfg(feature = "scene")]
            Model::Scene(scene) => scene.sphere(),
            #[cfg(not(any(feature = "trigrid", feature = "qsplat")))]
            Model::None(_, never) => match *never {},
        }
    }

    /// The orbit camera of `view` about [`Model::sphere`]: the default 45° field of view (a
    /// scene's own), for the reference 240 × 320 image ([`render`](super::render()) fits it to the target).
    pub fn orbit(&self, view: View) -> Camera {
        #[cfg(feature = "scene")]
        if let Model::Scene(scene) = self {
            return scene.camera(view);
        }
        Camera::orbit(self.sphere(), view, DEFAULT_FOV_DEG)
    }

    /// The material the shading table gives samples drawn with `base`: `base`, in white for a
    /// coloured QSplat file (whose colours then modulate it; a scene's objects bring their own).
    pub fn material(&self, base: Material) -> Material {
        match self {
            #[cfg(feature = "qsplat")]
            Model::QSplat(file) => shading_material(file, base),
            #[allow(unreachable_patterns)] // a build with no format has no model
            _ => base,
        }
    }

    /// The options a model is drawn with by default: [`RenderOptions::default`], or a scene
    /// pack's light, shadows and shadow map size.
    pub fn options(&self) -> RenderOptions {
        #[cfg(feature = "scene")]
        if let Model::Scene(scene) = self {
            return scene.options();
        }
        RenderOptions::default()
    }

    /// The shadow modes [`render`](super::render()) draws this model in, in this build: all three for a tri-grid or
    /// a scene with the `shadows` feature, [`ShadowMode::Off`] otherwise (QSplat files have no
    /// shadows).
    pub fn shadow_modes(&self) -> &'static [ShadowMode] {
        let shadowed = matches!(self.format(), FileFormat::TriGrid | FileFormat::Pack);
        if shadowed && cfg!(feature = "shadows") {
            &ShadowMode::ALL
        } else {
            &[ShadowMode::Off]
        }
    }
}

#[cfg(feature = "trigrid")]
impl<'a> From<TriGrid<'a>> for Model<'a> {
    fn from(grid: TriGrid<'a>) -> Self {
        Model::TriGrid(grid)
    }
}

#[cfg(feature = "qsplat")]
impl<'a> From<QSplat<'a>> for Model<'a> {
    fn from(file: QSplat<'a>) -> Self {
        Model::QSplat(file)
    }
}

#[cfg(feature = "scene")]
impl<'a> From<Scene<'a>> for Model<'a> {
    fn from(scene: Scene<'a>) -> Self {
        Model::Scene(scene)
    }
}
