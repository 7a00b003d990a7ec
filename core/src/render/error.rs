//! Why a file cannot be opened as a [`Model`](super::Model) ([`ModelError`]) and why a frame
//! cannot be drawn ([`RenderError`]).

use core::fmt;

use crate::format::FileFormat;
use crate::frame::FrameError;
use crate::shade::ShadowMode;

/// Why a file cannot be opened as a [`Model`](super::Model). Some variants come with the format
/// features: match with a `_` arm.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum ModelError {
    /// The first bytes are no format's magic.
    UnknownFormat,
    /// A format this build leaves out (its cargo feature is off).
    NotBuilt(FileFormat),
    /// Not a valid tri-grid.
    #[cfg(feature = "trigrid")]
    TriGrid(crate::tg::TgError),
    /// Not a valid QSplat file.
    #[cfg(feature = "qsplat")]
    QSplat(crate::qs::QsError),
    /// Not a valid scene pack.
    #[cfg(feature = "scene")]
    Pack(crate::scene::PackError),
    /// A scene pack one of whose objects is not valid or cannot be drawn.
    #[cfg(feature = "scene")]
    Scene(crate::scene::SceneError),
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

/// Why [`render`](super::render()) cannot draw a frame. Some variants come with the format
/// features: match with a `_` arm.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum RenderError {
    /// The format's per-frame tables ([`FrameError`]: a bad camera or cutoff, ρ above 3).
    Frame(FrameError),
    /// Shadows asked of a model that has none (QSplat), of a build without the `shadows` feature,
    /// or of a target without a shadow map ([`Target::with_shadows`](super::Target::with_shadows)).
    NoShadows(FileFormat, ShadowMode),
    /// A shadow map smaller than the options' side² (`need` depths, `given`), or a side the light
    /// cannot use.
    ShadowMap {
        /// Depths the map needs.
        need: u32,
        /// Depths the target has.
        given: u32,
    },
    /// The light cannot be set up (a point light inside the model's cube, a map side it cannot
    /// use, a position that is not finite).
    #[cfg(feature = "shadows")]
    Light(crate::shadow::LightError),
    /// A scene could not be drawn (its frames, its slots, its shadow map).
    #[cfg(feature = "scene")]
    Scene(crate::scene::SceneError),
}

impl core::error::Error for RenderError {}

impl fmt::Display for RenderError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RenderError::Frame(e) => write!(f, "{e}"),
            RenderError::NoShadows(format, mode) => write!(
                f,
                "shadows {} of a {} model: shadows need a tri-grid (or a scene), the `shadows` \
                 feature and a target with a shadow map",
                mode.name(),
                format.name()
            ),
            RenderError::ShadowMap { need, given } => write!(
                f,
                "the shadow map needs {need} depths, the target has {given}"
            ),
            #[cfg(feature = "shadows")]
            RenderError::Light(e) => write!(f, "{e}"),
            #[cfg(feature = "scene")]
            RenderError::Scene(e) => write!(f, "{e}"),
        }
    }
}

impl From<FrameError> for RenderError {
    fn from(e: FrameError) -> Self {
        RenderError::Frame(e)
    }
}
