//! `pocketsplat info FILE [--json]`: what a point file holds and what it costs, for each format
//! ([`describe`] dispatches by the file's magic): a tri-grid's levels (`tg`), a QSplat file's
//! fragments and nodes (`qs`), a scene pack's objects and the RAM its frames need (`pack`).

mod large;
mod pack;
mod qs;
mod tg;

use std::path::Path;

use anyhow::{anyhow, Result};
use pocketsplat_core::qs::QSplat;
use pocketsplat_core::tg::{TriGrid, Verify};

pub use large::RESIDENT_MAX;
pub use pack::{pack_info, PackInfo, DEVICE_BANDS, DEVICE_MAP_SIZE, DEVICE_QUEUE, PICO2_RAM};
pub use qs::{qs_info, qs_info_of, QsInfo};
pub use tg::{tg_info, tg_info_of, LevelInfo, TgInfo};

use crate::input::{self, InputKind};

/// What `info` says about a file, per format.
#[derive(Clone, Debug)]
pub enum Info {
    /// A tri-grid (or any ρ-grid).
    TriGrid(TgInfo),
    /// A QSplat file.
    QSplat(QsInfo),
    /// A scene pack.
    Pack(PackInfo),
}

impl Info {
    /// One JSON object, as `info --json` prints it.
    ///
    /// # Errors
    /// When it cannot be serialised (it always can).
    pub fn to_json(&self) -> serde_json::Result<String> {
        match self {
            Info::TriGrid(i) => serde_json::to_string(i),
            Info::QSplat(i) => serde_json::to_string(i),
            Info::Pack(i) => Ok(i.to_json().to_string()),
        }
    }

    /// The text `info` prints, headed by `path`.
    pub fn to_text(&self, path: &Path) -> String {
        match self {
            Info::TriGrid(i) => i.to_text(path),
            Info::QSplat(i) => i.to_text(path),
            Info::Pack(i) => i.to_text(path),
        }
    }
}

/// Reads the file at `path` and describes it, by its magic (a `.qs` name counts as QSplat; what
/// is none of the three is read as a `.tg` file, whose reader then says what is wrong). A `.tg`
/// or `.qs` file over [`RESIDENT_MAX`] bytes is read front to back in bounded memory instead of
/// whole (`large.rs`: its blocks' CRCs or its trees' structure checked as it goes).
///
/// # Errors
/// When the file cannot be read or is not a valid point file; the message names it.
pub fn describe(path: &Path) -> Result<Info> {
    let kind = input::kind(path)?;
    let (_, len) = crate::fsutil::open_regular(path)?;
    if len > RESIDENT_MAX {
        match kind {
            InputKind::QSplat => return Ok(Info::QSplat(large::qs(path, len)?)),
            InputKind::TriGrid => return Ok(Info::TriGrid(large::tg(path, len)?)),
            _ => {}
        }
    }
    Ok(match kind {
        InputKind::Pack => {
            let bytes = crate::fsutil::read_file(path)?;
            Info::Pack(pack_info(path, &bytes)?)
        }
        InputKind::QSplat => {
            let bytes = crate::qsplat::read_qs(path)?;
            let q = QSplat::open(&bytes).map_err(|e| anyhow!("{}: {e}", path.display()))?;
            Info::QSplat(qs_info(&q))
        }
        InputKind::TriGrid | InputKind::Other => {
            let bytes = input::read_tg(path)?;
            let tg = TriGrid::open(&bytes, Verify::Structure)
                .map_err(|e| anyhow!("{}: {e}", path.display()))?;
            Info::TriGrid(tg_info(&tg))
        }
    })
}
