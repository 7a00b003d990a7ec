//! QSplat (`.qs`) files on the desktop: reading them with a file name in every error, and rendering
//! them through the same camera, light, shading table and raster as the tri-grid.

use anyhow::{bail, Result};
use pocketsplat_core::camera::Camera;
use pocketsplat_core::format::FileFormat;
use pocketsplat_core::qs::QSplat;
use pocketsplat_core::render::Model;
use pocketsplat_core::shade::ShadingTable;
use std::path::Path;

use crate::render::{
    render_frame, render_with, FrameBuffers, FrameReport, Image, Settings, ShadowMode,
};

/// Whether `path` is a `.qs` file: its first bytes are `QSplat11`, or failing that its extension is
/// `.qs` (so that a damaged one is reported as a bad `.qs` file, not as a bad mesh).
///
/// # Errors
/// When the file cannot be opened.
pub fn is_qs(path: &Path) -> Result<bool> {
    Ok(crate::fsutil::sniff(path)? == Some(FileFormat::QSplat)
        || path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("qs")))
}

/// Reads a `.qs` file and validates it, naming the file in any error.
///
/// # Errors
/// When the file cannot be read or is not a valid `.qs` file.
pub fn read_qs(path: &Path) -> Result<Vec<u8>> {
    let bytes = crate::fsutil::read_file(path)?;
    QSplat::open(&bytes).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    Ok(bytes)
}

/// Renders one frame of a `.qs` file into `out` (cleared first), as [`render_frame`].
///
/// # Errors
/// When the frame cannot be set up or shadows are asked for (a QSplat file has none).
pub fn render_qs_frame(
    file: &QSplat<'_>,
    settings: &Settings,
    out: &mut FrameBuffers,
) -> Result<FrameReport> {
    no_shadows(settings)?;
    render_frame(&Model::QSplat(*file), settings, out)
}

/// Renders with a caller-owned shading table, from `cam` (the viewer pans the orbit centre); the
/// hook may draw over the frame.
///
/// # Errors
/// When the frame cannot be set up or shadows are asked for.
pub fn render_qs_from(
    file: &QSplat<'_>,
    settings: &Settings,
    cam: &Camera,
    table: &mut ShadingTable<1>,
    out: &mut FrameBuffers,
    overlay: impl FnOnce(&mut Image, &FrameReport),
) -> Result<FrameReport> {
    no_shadows(settings)?;
    render_with(&Model::QSplat(*file), settings, cam, table, out, overlay)
}

/// QSplat has no shadow code: a frame that asks for shadows is refused with what to do.
fn no_shadows(settings: &Settings) -> Result<()> {
    if settings.shadows != ShadowMode::Off {
        bail!("shadows are implemented for .tg files only; render .qs files with --shadows off");
    }
    Ok(())
}
