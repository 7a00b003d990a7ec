//! QSplat (`.qs`) files on the desktop: reading them with a file name in every error, and rendering
//! them through the same camera, light, shading table and raster as the tri-grid.

use std::path::Path;
use std::time::Instant;

use anyhow::{bail, Result};
use pocketsplat_core::camera::{self, Camera, Placement};
use pocketsplat_core::format::FileFormat;
use pocketsplat_core::qs::{render_qs_colored, shading_material, QSplat, QsFrame};
use pocketsplat_core::raster::Framebuffer;
use pocketsplat_core::render::RenderOptions;
use pocketsplat_core::shade::{Material, ShadingTable};
use pocketsplat_core::splat::{LevelTint, SampleSplat, ShadedRaster, Stats};

use crate::levels::Levels;
use crate::render::{FrameBuffers, FrameReport, Settings, ShadowMode};

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

/// The material a file is shaded with: the settings' own, or, when its samples carry colours, the
/// same material in white, which the colours then tint.
pub fn qs_material(file: &QSplat<'_>, settings: &Settings) -> Material {
    shading_material(file, settings.material)
}

/// Renders one frame of a `.qs` file into `out` (cleared first).
///
/// # Errors
/// When the frame cannot be set up or shadows are asked for (not implemented for `.qs`).
pub fn render_qs_frame(
    file: &QSplat<'_>,
    settings: &Settings,
    out: &mut FrameBuffers,
) -> Result<FrameReport> {
    let mut table = Box::new(ShadingTable::<1>::new());
    render_qs_with(file, settings, &mut table, out, |_, _| {})
}

/// Renders with a caller-owned shading table and a hook that may draw over the frame.
///
/// # Errors
/// When the frame cannot be set up or shadows are asked for.
pub fn render_qs_with(
    file: &QSplat<'_>,
    settings: &Settings,
    table: &mut ShadingTable<1>,
    out: &mut FrameBuffers,
    overlay: impl FnOnce(&mut Framebuffer<'_>, &Stats),
) -> Result<FrameReport> {
    let cam = settings.camera(file.bounds());
    render_qs_from(file, settings, &cam, table, out, |fb, report| {
        overlay(fb, &report.stats)
    })
}

/// As [`render_qs_with`], from `cam` instead of the orbit camera of `settings.view` (the viewer
/// pans the orbit centre); the hook also sees the frame's time.
///
/// # Errors
/// When the frame cannot be set up or shadows are asked for.
pub fn render_qs_from(
    file: &QSplat<'_>,
    settings: &Settings,
    cam: &Camera,
    table: &mut ShadingTable<1>,
    out: &mut FrameBuffers,
    overlay: impl FnOnce(&mut Framebuffer<'_>, &FrameReport),
) -> Result<FrameReport> {
    if settings.shadows != ShadowMode::Off {
        bail!("shadows are implemented for .tg files only; render .qs files with --shadows off");
    }
    let opts = RenderOptions {
        cutoff_px: settings.cutoff_px,
        kernel: settings.kernel,
        ..RenderOptions::default()
    };
    let t = Instant::now();
    let frame = QsFrame::new(file, &Placement::IDENTITY, cam, &opts)?;
    table.update(
        &[qs_material(file, settings)],
        settings.light_dir(),
        camera::scale(cam.forward, -1.0),
    );
    let mut fb = Framebuffer::new(&mut out.color, &mut out.depth);
    fb.clear(0);
    let mut sink = ShadedRaster {
        fb: &mut fb,
        table,
        kernel: settings.kernel,
    };
    let stats = if settings.color_by_level {
        let levels = Levels::of_qsplat(file);
        let mut tinted = LevelTint {
            sink: &mut sink,
            levels: |object, s: &SampleSplat| levels.of(object, s),
            object: 0,
        };
        render_qs_colored(file, &frame, &mut tinted)
    } else {
        render_qs_colored(file, &frame, &mut sink)
    };
    let report = FrameReport {
        stats,
        time: t.elapsed(),
    };
    overlay(&mut fb, &report);
    Ok(report)
}
