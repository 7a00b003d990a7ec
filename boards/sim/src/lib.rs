//! pocketsplat-sim: the desktop side of pocketsplat. Mesh import, the float reference renderer, PNG
//! output, reports and the `pocketsplat` command line live here; everything that runs on the device
//! lives in `pocketsplat-core`.

pub mod args;
pub mod bake;
pub mod bvh;
pub mod demo;
pub mod fsutil;
pub mod generate;
pub mod image;
pub mod info;
pub mod input;
pub mod levels;
pub mod limits;
pub mod memory;
pub mod metrics;
pub mod migrate;
pub mod ply;
pub mod qsplat;
pub mod reference;
pub mod render;
pub mod report;
pub mod scene;
pub mod shapes;
pub mod snapshot;
pub mod stream;
pub mod view;
