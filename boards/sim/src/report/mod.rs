//! `pocketsplat report …`: the paper's tables reproduced live, and (later) error against run time.

pub mod bake_scale;
pub mod error_vs_time;
pub mod paper;
pub mod shadows;
pub mod stability;
pub mod views;
