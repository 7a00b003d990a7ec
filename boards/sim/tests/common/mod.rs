//! Helpers shared by the simulator's tests (`mod common;` in each test file; each file uses some).
#![allow(dead_code)]

use std::path::{Path, PathBuf};

/// The folder of the Stanford scans: `$POCKETSPLAT_MODELS`, or `../shared/models` beside the
/// repository.
pub fn models_dir() -> PathBuf {
    std::env::var_os("POCKETSPLAT_MODELS")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/models"))
}

/// The model's path, or `None` (with a note) when it is missing outside CI; in CI (`CI=true`) a
/// missing model fails the test instead of skipping it.
pub fn model(name: &str) -> Option<PathBuf> {
    let path = models_dir().join(name);
    if path.is_file() {
        return Some(path);
    }
    assert!(
        std::env::var("CI").as_deref() != Ok("true"),
        "model {} is missing and CI=true: model tests must not skip (set POCKETSPLAT_MODELS)",
        path.display()
    );
    eprintln!(
        "note: model {} is missing; skipping (set POCKETSPLAT_MODELS)",
        path.display()
    );
    None
}

/// The names of the files in `dir`, sorted: what a failed command must leave unchanged.
pub fn files_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}
