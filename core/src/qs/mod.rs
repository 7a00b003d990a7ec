//! QSplat (`.qs`) files: bounding-sphere hierarchies with quantized positions, normals and normal
//! cones (Rusinkiewicz & Levoy 2000), in the QSplat 1.0 file format (version 11).
//!
//! [`read`] validates a file once and reads it in place (no_std, no heap); [`traverse`] draws it with
//! integer arithmetic per node, through the same [`crate::splat::SplatSink`] and shading tables as the
//! tri-grid; `write` bakes a mesh into a file (`bake` feature). The byte layout is below.
#![doc = include_str!("FORMAT.md")]

#[cfg(feature = "bake")]
mod build;
#[doc(hidden)]
pub mod frame;
#[doc(hidden)]
pub mod normal;
#[cfg(feature = "bake")]
pub mod pieces;
pub mod read;
#[doc(hidden)]
pub mod table;
#[doc(hidden)]
pub mod traverse;
#[cfg(feature = "bake")]
pub mod write;

pub use frame::{material_for_colors, shading_material, QsFrame};
pub use read::{
    ByteOrder, Children, Fragment, Group, Node, QSplat, QsCounts, QsError, Tree, TreeHead,
};
pub use traverse::{render_qs, render_qs_colored, ColorSink, QsWalk};
// The streamed scene draws QSplat objects without their colours, as the resident scene does.
#[cfg_attr(not(all(feature = "scene", feature = "stream")), allow(unused_imports))]
pub(crate) use traverse::NoColor;

/// The magic of every fragment.
pub const MAGIC: [u8; 8] = crate::format::QS_MAGIC;
/// Bytes of a tree fragment's header.
pub const HEADER_BYTES: usize = 40;
/// Bytes of a comment fragment's header.
pub const COMMENT_HEADER_BYTES: usize = 20;
/// Bytes of a group pointer.
pub const POINTER_BYTES: u32 = 4;
/// Option bit: nodes carry RGB565 colours.
pub const OPT_COLOR: u32 = 1;
/// Option bit: a comment fragment.
pub const OPT_COMMENT: u32 = 2;
/// Deepest tree the reader accepts (levels below the root): bounds the traversal's recursion.
pub const MAX_DEPTH: usize = 48;
/// How pocketsplat's comment fragment starts; it carries the mesh's bounding box.
pub const BOUNDS_COMMENT_PREFIX: &str = "pocketsplat";

mod tables {
    include!(concat!(env!("OUT_DIR"), "/qs_tables.rs"));
}
pub use tables::{QS_MAJOR_Q14, QS_SHADE_CODE, QS_TAN_Q14};
