//! The `pocketsplat` subcommands.

pub mod render;
