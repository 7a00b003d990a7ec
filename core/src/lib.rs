//! # pocketsplat-core
//!
//! Everything that runs on the device: the hierarchical point formats (tri-grids and QSplat),
//! their integer-only traversal, the raster and the shading tables. `no_std`, no heap.
//!
//! **One way in**: [`Model::open`] a file (by its magic), orbit a [`Camera`] about it, and
//! [`render()`] it into a [`Target`]: any embedded-graphics display with a depth buffer you own
//! ([`raster::DisplayTarget`]) or the crate's [`raster::Framebuffer`], of any size. The [`render`
//! module](mod@render) shows it whole; `examples/cortex_m.rs` is a firmware that does it.
//!
//! The writers live next to the readers so that each byte layout is defined in one place; they and the
//! mesh baker sit behind the `bake` feature (std).
//!
//! ```
//! use pocketsplat_core::normal;
//! // 13-bit normal codes: 8192 directions (Duguet & Drettakis Table 3, level 5).
//! assert_eq!(normal::NORMAL_COUNT, 8192);
//! ```
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

pub mod bytes;
pub mod camera;
pub mod crc;
pub mod fixed;
pub mod format;
pub mod frame;
pub mod lod;
pub mod normal;
#[cfg(feature = "qsplat")]
pub mod qs;
pub mod raster;
pub mod render;
#[cfg(feature = "scene")]
pub mod scene;
pub mod shade;
#[cfg(feature = "shadows")]
pub mod shadow;
pub mod splat;
#[cfg(feature = "stream")]
pub mod stream;
#[cfg(feature = "trigrid")]
pub mod tg;

#[cfg(feature = "bake")]
pub mod bake;

pub use camera::{Camera, View, Viewport};
pub use render::{render, Model, RenderOptions, Target};

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
