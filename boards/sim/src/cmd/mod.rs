//! The `pocketsplat` subcommands.

pub mod bake;
pub mod info;
pub mod render;
