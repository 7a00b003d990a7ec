//! What a path on the command line holds, and opening it with its name in every error: the format
//! dispatch of `bake`, `info`, `render` and `view`, by the file's first bytes.

use std::path::Path;

use anyhow::{anyhow, Result};
use pocketsplat_core::format::FileFormat;
use pocketsplat_core::scene::{Pack, Scene};
use pocketsplat_core::tg::{TriGrid, Verify};

/// What an input file is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InputKind {
    /// A tri-grid (or any ρ-grid), `.tg`.
    TriGrid,
    /// A QSplat file: magic `QSplat11`, or failing that the name `*.qs` (so that a damaged one is
    /// reported as a bad `.qs` file, not as a bad mesh).
    QSplat,
    /// A scene pack (magic `PSPK`).
    Pack,
    /// None of these: a mesh, or something no reader takes.
    Other,
}

/// What the file at `path` is, by its first bytes.
///
/// # Errors
/// When the file cannot be opened or read (or is not a regular file); the message names it.
pub fn kind(path: &Path) -> Result<InputKind> {
    Ok(match crate::fsutil::sniff(path)? {
        Some(FileFormat::Pack) => InputKind::Pack,
        _ if crate::qsplat::is_qs(path)? => InputKind::QSplat,
        Some(FileFormat::TriGrid) => InputKind::TriGrid,
        _ => InputKind::Other,
    })
}

/// Whether `path` is a scene pack (by its magic). A file that cannot be opened is not one (the
/// caller's own reader then names the problem).
pub fn is_pack(path: &Path) -> bool {
    crate::fsutil::sniff(path).is_ok_and(|f| f == Some(FileFormat::Pack))
}

/// Whether `path` names a scene file (by its `.toml` extension).
pub fn is_scene_file(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("toml"))
}

/// Reads a `.tg` file and checks it whole (every block's CRC), naming it in any error.
///
/// # Errors
/// When the file cannot be read or is not a valid `.tg` file.
pub fn read_tg(path: &Path) -> Result<Vec<u8>> {
    let bytes = crate::fsutil::read_file(path)?;
    TriGrid::open(&bytes, Verify::Full).map_err(|e| anyhow!("{}: {e}", path.display()))?;
    Ok(bytes)
}

/// Opens a pack's bytes as a scene (every object's file checked), naming `path` in errors.
///
/// # Errors
/// When the pack or an object's file is invalid.
pub fn open_pack<'a>(path: &Path, bytes: &'a [u8]) -> Result<Scene<'a>> {
    let pack = Pack::open(bytes).map_err(|e| anyhow!("{}: {e}", path.display()))?;
    Scene::open(pack, Verify::Full).map_err(|e| anyhow!("{}: {e}", path.display()))
}
