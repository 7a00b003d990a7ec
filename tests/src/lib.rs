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

/// The folder with the Stanford models.
pub fn models_dir() -> PathBuf {
    match std::env::var_os("POCKETSPLAT_MODELS") {
        Some(dir) => PathBuf::from(dir),
        None => workspace_root().join("../shared/models"),
    }
}

/// Whether this run is under CI, where nothing may be skipped.
pub fn under_ci() -> bool {
    std::env::var("CI")
        .map(|v| v == "true" || v == "1")
        .unwrap_or(false)
}

/// Path of a model file in [`models_dir`], or `None` (with a note on stderr) when it is missing on a
/// developer machine.
///
/// # Panics
/// When the model is missing and [`under_ci`] is true: CI must never skip a model test.
pub fn model(name: &str) -> Option<PathBuf> {
    let path = models_dir().join(name);
    if path.is_file() {
        return Some(path);
    }
    assert!(
        !under_ci(),
        "model {} is missing and CI=true: model tests must not skip",
        path.display()
    );
    eprintln!("note: {} not found; test skipped (set POCKETSPLAT_MODELS or run under CI to make this fail)", path.display());
    None
}
