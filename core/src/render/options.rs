//! How to draw a frame ([`RenderOptions`]: one set of options for every format and for scenes)
//! and why a format's frame cannot be set up ([`FrameError`]).

use core::fmt;

use crate::camera::{self, Vec3};
use crate::raster::Kernel;
use crate::shade::{Material, ShadowMode, DEFAULT_LIGHT_AZ_EL, DEFAULT_MATERIAL};

/// How to draw a frame: the level of detail, the splats, the light and the shadows.
///
/// One set of options for every format and for scenes: a format or a build reads what it uses
/// (QSplat files have no shadows; a scene pack brings its own materials, [`Model::options`](super::Model::options) its
/// light).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderOptions {
    /// Stop descending where a cell's projected diameter is at most this many pixels (the LOD
    /// cutoff; 1 px is full detail on screen).
    pub cutoff_px: f32,
    /// Splat shape.
    pub kernel: Kernel,
    /// Skip samples (and, with normal cones, subtrees) whose normals face away from every ray.
    pub backface_culling: bool,
    /// Shadow algorithm (tri-grids and scenes of tri-grids, with the `shadows` feature).
    pub shadows: ShadowMode,
    /// Unit direction towards the light, world frame: the shading's light, and a directional
    /// light's shadows.
    pub light_dir: Vec3,
    /// A point light's position instead, world units: shadows from it are two-pass (Duguet §5.3
    /// needs a directional light for one pass); shading still uses [`RenderOptions::light_dir`].
    pub light_position: Option<Vec3>,
    /// Side of the shadow map, texels.
    pub shadow_map_size: usize,
    /// The material every sample is shaded with (a coloured QSplat file's in white, modulated by
    /// its colours; a scene pack's objects bring their own).
    pub material: Material,
    /// The colour the frame is cleared to, RGB565.
    pub background: u16,
}

/// The shadow map side of [`RenderOptions::default`]: 256² texels (128 KB), about one texel per 3
/// leaf cells of a depth-6 tri-grid.
pub const DEFAULT_SHADOW_MAP_SIZE: usize = 256;

impl Default for RenderOptions {
    /// A 1 px cutoff, square splats, backface culling, no shadows, the default light and
    /// material, a black background.
    fn default() -> Self {
        Self {
            cutoff_px: 1.0,
            kernel: Kernel::Square,
            backface_culling: true,
            shadows: ShadowMode::Off,
            light_dir: camera::direction(DEFAULT_LIGHT_AZ_EL.0, DEFAULT_LIGHT_AZ_EL.1),
            light_position: None,
            shadow_map_size: DEFAULT_SHADOW_MAP_SIZE,
            material: DEFAULT_MATERIAL,
            background: 0,
        }
    }
}

impl RenderOptions {
    /// These options at `cutoff_px`.
    pub fn with_cutoff(self, cutoff_px: f32) -> Self {
        Self { cutoff_px, ..self }
    }
}

/// Why a format's per-frame tables cannot be set up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FrameError {
    /// The tri-grid traversal draws ρ = 2 and 3 only (4 and 5 are for the storage comparison).
    UnsupportedRho(u8),
    /// The camera or placement has non-finite numbers, a focal length or scale that is not
    /// positive, an empty viewport, or a cutoff that is not finite and positive.
    BadCamera,
}

impl core::error::Error for FrameError {}

impl fmt::Display for FrameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FrameError::UnsupportedRho(r) => write!(f, "rendering supports rho 2 and 3, not {r}"),
            FrameError::BadCamera => {
                write!(f, "camera, placement or cutoff is not finite and positive")
            }
        }
    }
}
