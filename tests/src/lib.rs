//! Shared helpers for pocketsplat's cross-crate tests.
//!
//! Tests read the Stanford scans from `../shared/models` (beside the repository; override with
//! `POCKETSPLAT_MODELS`). When a model is missing they fail under CI (`CI=true`) and are skipped, with a
//! message, only on a developer machine that lacks the models.

use std::path::{Path, PathBuf};

pub mod arm;
pub mod elf;
pub mod fat;
pub mod hostile;

/// The workspace root (the folder holding the top-level `Cargo.toml`).
pub fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("tests/ has a parent")
        .to_path_buf()
}

/// Where the Stanford scans are, and the rule that CI may not skip a missing one (the simulator's
/// library holds them for every crate's tests).
pub use pocketsplat_sim::models::{model, models_dir, under_ci};
