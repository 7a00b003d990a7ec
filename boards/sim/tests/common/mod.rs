//! Helpers shared by the command-line tests (`mod common;` in each test file).

use std::path::Path;

/// The names of the files in `dir`, sorted: what a failed command must leave unchanged.
pub fn files_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}
