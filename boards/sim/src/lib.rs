//! pocketsplat-sim: the desktop side of pocketsplat. Mesh import, the float reference renderer, PNG
//! output, reports and the `pocketsplat` command line live here; everything that runs on the device
//! lives in `pocketsplat-core`.

pub mod ply;
pub mod metrics;
pub mod reference;
pub mod image;
