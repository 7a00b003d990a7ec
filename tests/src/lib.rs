//! Shared helpers for pocketsplat's cross-crate tests.
//!
//! Tests read the Stanford scans from `../shared/models` (beside the repository; override with
//! `POCKETSPLAT_MODELS`). When a model is missing they fail under CI (`CI=true`) and are skipped, with a
//! message, only on a developer machine that lacks the models.

use std::path::{Path, PathBuf};

pub mod arm;
pub mod elf;
pub mod hostile;

/// The workspace root (the folder holding the top-level `Cargo.toml`).
pub fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("tests/ has a parent")
        .to_path_buf()
}

/// SD card images made by the real FAT tools.
pub use pocketsplat_fixture::fat;
/// Where the Stanford scans are, and the rule that CI may not skip a missing one (the fixture crate
/// holds them for every crate's tests, the boards' included).
pub use pocketsplat_fixture::models::{model, models_dir, under_ci};
