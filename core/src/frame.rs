//! What every frame needs, whatever its format: how to draw it ([`RenderOptions`]), why it cannot
//! be set up ([`FrameError`]), what its shading table holds ([`Shading`]) and the one interface
//! between a format's traversal and the pipeline ([`Walk`]).
//!
//! This is the ground floor of the renderer: the formats (`tg`, `qs`), shadows, streams and
//! scenes build on it, and the facade ([`crate::render`](mod@crate::render)) puts them together. Nothing here
//! imports from a format or from the facade (docs/ARCHITECTURE.md "Layout").

use core::fmt;

use crate::camera::{self, Vec3};
use crate::raster::Kernel;
use crate::shade::{Material, ShadingTable, ShadowMode, DEFAULT_LIGHT_AZ_EL, DEFAULT_MATERIAL};
use crate::splat::{ColorSink, Stats};

/// How to draw a frame: the level of detail, the splats, the light and the shadows.
///
/// One set of options for every format and for scenes: a format or a build reads what it uses
/// (QSplat files have no shadows; a scene pack brings its own materials, [`Model::options`](crate::render::Model::options) its
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

/// A frame set up for a camera and ready to walk: a format's traversal with its per-frame tables
/// (and its shadow hooks, its stream, its scene's objects). The pipeline ([`crate::render()`]) runs
/// every format through this one call, into the shaded raster or a caller's sink in front of it.
pub trait Walk {
    /// Walks the model into `sink`; returns what the walk counted.
    fn walk<S: ColorSink>(&mut self, sink: &mut S) -> Stats;
}

impl<W: Walk + ?Sized> Walk for &mut W {
    #[inline(always)]
    fn walk<S: ColorSink>(&mut self, sink: &mut S) -> Stats {
        (**self).walk(sink)
    }
}

/// What a frame's shading table holds: per slot, the material and the light and view directions
/// in the model frame of the samples that use it (a scene's objects may be rotated).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shading<const M: usize> {
    /// Each slot's material.
    pub materials: [Material; M],
    /// Each slot's (towards the light, towards the viewer), unit vectors in its model frame.
    pub dirs: [(Vec3, Vec3); M],
}

impl<const M: usize> Shading<M> {
    /// `material` in every slot, lit from `light_dir` and seen from `view_dir`.
    pub fn uniform(material: Material, light_dir: Vec3, view_dir: Vec3) -> Self {
        Self {
            materials: [material; M],
            dirs: [(light_dir, view_dir); M],
        }
    }

    /// Makes `table` hold this shading, rebuilding only the slots that changed; returns whether
    /// any did.
    pub fn apply(&self, table: &mut ShadingTable<M>) -> bool {
        table.update_slots(&self.materials, &self.dirs)
    }
}
