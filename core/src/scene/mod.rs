//! Scenes: several point files placed in one world with their materials, a light, shadows and named
//! views, packed into one file (`.pack`) and drawn into one framebuffer (docs/ARCHITECTURE.md "Formats").
//!
//! The byte layout is specified in `PACK.md` beside this file, included below. [`pack`] reads it
//! (no_std; validate once, then no accessor can panic), `write` produces it (`bake` feature), and
//! [`render_scene`] draws a scene: every object through its own tri-grid frame, all of them into one
//! z-buffer over a depth range they share ([`crate::tg::frame::TgFrame::share_depth_range`]), with
//! one shadow map they all fill ([`crate::shadow::LightSpace`], feature `shadows`) and one shading
//! table whose slots are the objects' materials. An object may also be a QSplat file (`.qs`, kind
//! 2, feature `qsplat`): it is drawn through its own QSplat frame over the same shared depth range,
//! but QSplat has no shadow code, so in a shadowed scene it is drawn unshadowed and casts nothing.
//!
//! ```
//! use pocketsplat_core::{Model, ModelError};
//! // A pack opens through the one way in, by its magic; a cut one is refused by name.
//! let err = Model::open(b"PSPK\x01\x00").unwrap_err();
//! assert!(matches!(err, ModelError::Pack(_)), "{err}");
//! ```
#![doc = include_str!("PACK.md")]

mod budget;
pub(crate) mod draw;
mod open;
pub mod pack;
#[cfg(feature = "bake")]
pub mod write;

pub use budget::{ram_budget, shading_table_bytes, RamBudget};
#[cfg(feature = "shadows")]
pub use draw::render_scene_in;
pub use draw::{render_scene, slot_attr, slot_bits, SceneWalk};
pub use open::{ObjectFile, Scene, SceneError, SceneStats};
pub use pack::{Pack, PackError};

use crate::camera::Placement;
use crate::shade::Material;

/// File magic.
pub const MAGIC: [u8; 4] = crate::format::PACK_MAGIC;
/// Current format version.
pub const VERSION: u16 = 1;
/// Most objects in a pack.
pub const MAX_OBJECTS: usize = 16;
/// Most material slots: the 3 material bits of a splat's attribute ([`crate::shade::MAX_MATERIALS`]).
pub const MAX_SLOTS: usize = crate::shade::MAX_MATERIALS;
/// Most named views.
pub const MAX_VIEWS: usize = 32;
/// Most camera path keyframes.
pub const MAX_PATH_KEYS: usize = 256;
/// Smallest and largest shadow map side (texels) a pack may ask for.
pub const MIN_MAP_SIZE: usize = 16;
/// See [`MIN_MAP_SIZE`].
pub const MAX_MAP_SIZE: usize = 4096;
/// The longest metadata a valid pack has (header and the four tables at their largest): what a
/// stream reads before the objects ([`Pack::open_meta`]).
pub const MAX_META_BYTES: usize = HEADER_BYTES
    + MAX_OBJECTS * OBJECT_BYTES
    + MAX_SLOTS * MATERIAL_BYTES
    + MAX_VIEWS * VIEW_BYTES
    + MAX_PATH_KEYS * PATH_BYTES;
/// Bytes of a name field.
pub const NAME_BYTES: usize = 16;
/// Bytes of the header.
pub const HEADER_BYTES: usize = 128;
/// Bytes of an object record.
pub const OBJECT_BYTES: usize = 160;
/// Bytes of a material record.
pub const MATERIAL_BYTES: usize = 48;
/// Bytes of a view record.
pub const VIEW_BYTES: usize = 48;
/// Bytes of a camera path keyframe.
pub const PATH_BYTES: usize = 32;
/// Allowed `align_log2` (objects' files start at multiples of `2^align_log2`).
pub const ALIGN_LOG2_RANGE: core::ops::RangeInclusive<u8> = 9..=16;
/// Object flag: casts shadows.
pub const FLAG_CASTS: u8 = 1;
/// Object flag: the ground, drawn after every other object in one-pass shadows.
pub const FLAG_GROUND: u8 = 2;
/// Object flag: counts towards the sphere the views orbit.
pub const FLAG_IN_BOUNDS: u8 = 4;

/// What an object's file is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Kind {
    /// A `.tg` file (tri-grid or octree).
    TriGrid = 1,
    /// A `.qs` file (QSplat bounding-sphere tree). Drawn only by builds with the `qsplat` feature;
    /// never shadowed and casts nothing ([`render`](crate::render::render())).
    QSplat = 2,
}

impl Kind {
    /// The kind of a record's byte, `None` when unknown.
    pub fn from_byte(b: u8) -> Option<Self> {
        match b {
            1 => Some(Kind::TriGrid),
            2 => Some(Kind::QSplat),
            _ => None,
        }
    }
}

pub use crate::shade::ShadowMode;

/// Bytes a bake left out of one object because the scene does not need them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Savings {
    /// Levels finer than any view of the scene can resolve.
    pub levels: u32,
    /// A colour channel nothing draws (tri-grid samples are shaded by material).
    pub color: u32,
    /// Material bits (0 in this format: they share the `u16` attribute with the normal code).
    pub material_bits: u32,
}

/// One object of a validated pack.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObjectRecord<'a> {
    /// Its name.
    pub name: &'a str,
    /// What its file is.
    pub kind: Kind,
    /// Whether it casts shadows.
    pub casts_shadows: bool,
    /// Whether it is the ground (drawn last in one-pass shadows).
    pub ground: bool,
    /// Whether it counts towards the views' sphere.
    pub in_bounds: bool,
    /// Material indices its file can carry (1..=8).
    pub materials: u8,
    /// Slot of each file material index; entries at or beyond `materials` are `0xFF`.
    pub slots: [u8; MAX_SLOTS],
    /// Its file's bytes (empty when the pack was opened from its metadata alone,
    /// [`Pack::open_meta`]: a stream reads them from `data_offset`).
    pub data: &'a [u8],
    /// Where they start in the pack.
    pub data_offset: u32,
    /// How many there are.
    pub data_len: u32,
    /// Where it sits in the world.
    pub placement: Placement,
    /// Depth the scene asked for.
    pub depth_asked: u8,
    /// Depth kept: the levels the scene's views can resolve.
    pub depth_kept: u8,
    /// What the bake left out.
    pub savings: Savings,
}

/// One material slot of a validated pack.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MaterialRecord<'a> {
    /// The scene's name for it.
    pub name: &'a str,
    /// The material.
    pub material: Material,
}
