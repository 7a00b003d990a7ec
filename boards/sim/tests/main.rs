//! The simulator's tests (the command line, the readers, the reports), one module per subject, in one
//! test binary (`cargo test -p pocketsplat-sim --test all`; one module: `… --test all stability::`):
//! one binary links the core's renderer once, not once per file.

mod common;

mod cli;
mod error_vs_time;
mod hostile_cli;
mod large_mesh;
mod limits;
mod out_of_core;
mod ply;
mod reference;
mod shadows_reference;
mod sizes;
mod stability;
mod stream;
mod view;
mod winding;
