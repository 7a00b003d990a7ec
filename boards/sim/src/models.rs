//! Where the Stanford scans are (`../shared/models` beside the repository, never copied into it),
//! for the tests and benchmarks of every crate: one place for the folder and for the rule that a
//! test under CI may not skip a missing scan.

use std::path::{Path, PathBuf};

/// The folder of the Stanford scans: `$POCKETSPLAT_MODELS`, or `../shared/models` beside the
/// repository.
pub fn models_dir() -> PathBuf {
    std::env::var_os("POCKETSPLAT_MODELS")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/models"))
}

/// Whether this run is under CI (`CI=true` or `CI=1`), where nothing may be skipped.
pub fn under_ci() -> bool {
    std::env::var("CI").is_ok_and(|v| v == "true" || v == "1")
}

/// The path of scan `name` in [`models_dir`], or `None` (with a note on stderr) when it is missing
/// on a developer's machine.
///
/// # Panics
/// When the scan is missing under CI ([`under_ci`]): a test there must fail, not skip.
pub fn model(name: &str) -> Option<PathBuf> {
    let path = models_dir().join(name);
    if path.is_file() {
        return Some(path);
    }
    assert!(
        !under_ci(),
        "model {} is missing and CI=true: model tests must not skip (set POCKETSPLAT_MODELS)",
        path.display()
    );
    eprintln!(
        "note: model {} is missing; skipping (set POCKETSPLAT_MODELS, or run under CI to make this \
         fail)",
        path.display()
    );
    None
}
