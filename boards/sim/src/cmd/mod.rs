//! The `pocketsplat` subcommands.

pub mod bake;
pub mod info;
pub mod migrate;
pub mod render;
pub mod view;
