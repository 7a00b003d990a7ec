//! # pocketsplat-core
//!
//! Everything that runs on the device: the hierarchical point formats (tri-grids and QSplat),
//! their integer-only traversal, the raster and the shading tables. `no_std`, no heap.
//!
//! ## One way in
//!
//! [`Model::open`] a file (by its magic), orbit a [`Camera`] about it, and [`render()`] it into a
//! [`Target`]: any embedded-graphics display with a depth buffer you own ([`DisplayTarget`]) or
//! the crate's [`Framebuffer`], of any size, with a [`ShadingTable`] kept between frames.
//!
//! ```
//! use pocketsplat_core::{render, DisplayTarget, Model, RenderOptions, ShadingTable, Target, View};
//! # use pocketsplat_core::TestPanel;
//! # let mut display = TestPanel::new(128, 160); // your panel's driver
//! let mut depth = [0u16; 128 * 160];
//! let mut table = ShadingTable::<1>::new();
//! let model = Model::open(include_bytes!("../examples/data/trefoil.tg")).unwrap();
//! let camera = model.orbit(View::new(30.0, 20.0, 2.5));
//! let mut target = Target::new(DisplayTarget::new(&mut display, &mut depth).unwrap(), &mut table);
//! render(&model, &camera, &RenderOptions::default(), &mut target).unwrap();
//! # assert!(display.lit() > 1000);
//! ```
//!
//! Everything a firmware names is at the root: the model ([`Model`], [`Verify`]), the camera ([`Camera`],
//! [`View`]), the options ([`RenderOptions`], [`ShadowMode`], [`Kernel`], [`Material`]), the
//! target ([`Target`], [`DisplayTarget`], [`Framebuffer`], [`ShadingTable`], and `LightFrame`
//! for shadows), the errors ([`ModelError`], [`RenderError`], [`FrameError`]), a display for tests
//! ([`TestPanel`]), and the hooks of [`render_marked`] ([`Layer`], [`Walk`], the sinks).
//! [`render`](mod@render) tells the pipeline whole; `examples/cortex_m.rs` is a firmware that uses
//! it, and `render_stream` draws a file read in blocks (feature `stream`).
//!
//! The modules below are the formats' readers and writers (`tg`, `qs`, `scene`), the streaming
//! reader (`stream`), the traversal's parts and the desktop's baker (`bake`, std): what the board
//! crates and the simulator build on. The writers live next to the readers so that each byte layout
//! is defined in one place.
#![cfg_attr(not(test), no_std)]

#[cfg(not(any(feature = "trigrid", feature = "qsplat")))]
compile_error!(
    "pocketsplat-core reads no format: enable the feature `trigrid` (the default) or `qsplat`, \
     or both (`scene`, `shadows` and `stream` enable `trigrid`)"
);

#[cfg(feature = "std")]
extern crate std;

/// Counts into a frame's [`splat::Stats`] with the `stats` feature only: the device build keeps no
/// per-node statistics (without the feature a frame's counts are all 0).
macro_rules! count {
    ($($counting:tt)*) => {
        #[cfg(any(test, feature = "stats"))]
        {
            $($counting)*;
        }
    };
}

// The parts of the pipeline (byte reading, fixed point, the raster, shading, splats, the walk's
// trait): public for the board crates and the desktop tools that build on them, hidden from the
// docs, whose one way in is the re-exports below.
#[doc(hidden)]
pub mod bytes;
pub mod camera;
#[doc(hidden)]
pub mod crc;
#[doc(hidden)]
pub mod fixed;
#[doc(hidden)]
pub mod format;
mod frame;
#[doc(hidden)]
pub mod lod;
#[doc(hidden)]
pub mod normal;
#[cfg(feature = "qsplat")]
pub mod qs;
#[doc(hidden)]
pub mod raster;
pub mod render;
#[cfg(feature = "scene")]
pub mod scene;
#[doc(hidden)]
pub mod shade;
#[cfg(feature = "shadows")]
pub mod shadow;
#[doc(hidden)]
pub mod splat;
#[cfg(feature = "stream")]
pub mod stream;
mod test_panel;
#[cfg(feature = "trigrid")]
pub mod tg;

#[cfg(feature = "bake")]
pub mod bake;

// The one way in, flat at the root: what a firmware author names to open a model and draw it into
// a display (the cortex_m example and every doctest import only these). The formats' modules
// (tg, qs, scene, stream, shadow, bake) stay in the docs for their readers, writers and streams.
pub use camera::{Camera, View, Viewport};
pub use crc::Crc32;
pub use format::FileFormat;
pub use frame::Walk;
pub use raster::{DepthTarget, DisplayTarget, Framebuffer, Kernel};
#[cfg(all(feature = "stream", feature = "qsplat"))]
pub use render::render_qs_stream;
pub use render::{
    render, render_marked, Drawn, FrameError, Layer, Model, ModelError, Phase, RenderError,
    RenderOptions, Target,
};
pub use shade::{Material, ShadingTable, ShadowMode};
#[cfg(feature = "shadows")]
pub use shadow::LightFrame;
pub use splat::{ColorSink, SampleSplat, SplatSink, Stats};
pub use test_panel::TestPanel;
#[cfg(feature = "trigrid")]
pub use tg::Verify;
#[cfg(feature = "stream")]
pub use {
    render::{render_stream, StreamPass},
    stream::{ChunkSource, MemSource},
};

/// Helpers of the unit tests.
#[cfg(test)]
pub(crate) mod testing {
    /// A little LCG (no dependency): uniform in [−1, 1), the same sequence on every machine.
    #[allow(clippy::float_arithmetic)]
    pub fn signed_uniform(mut seed: u64) -> impl FnMut() -> f64 {
        move || {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        }
    }
}
