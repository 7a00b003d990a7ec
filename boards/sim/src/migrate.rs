//! A `.tg` file written again in another layout, every stored value kept (FORMAT.md "Versions"): a
//! version 2 file becomes version 3 with bricks, which streaming needs (`pocketsplat migrate`).

use std::path::Path;

use anyhow::{Context, Result};
use pocketsplat_core::tg::write::{rewrite_tg, Layout};
use pocketsplat_core::tg::{Header, TriGrid, Verify};

use crate::fsutil;

/// The layout called `name`: `bricked` (the writer's brick level), `bricked:R` (bricks below level
/// `R`), `unbricked` or `v2` (a value parser for `--layout`).
///
/// # Errors
/// A message naming the layouts, for any other name.
pub fn layout(name: &str) -> Result<Layout, String> {
    match name {
        "bricked" => Ok(Layout::Bricked),
        "unbricked" => Ok(Layout::Unbricked),
        "v2" => Ok(Layout::Version2),
        _ => name
            .strip_prefix("bricked:")
            .and_then(|r| r.parse().ok())
            .map(Layout::BrickedBelow)
            .ok_or_else(|| format!("{name}: expected bricked, bricked:LEVEL, unbricked or v2")),
    }
}

/// Reads `input` (checked whole, as `render` reads it), writes it to `out` in `layout`, and says
/// what changed (`IN: version 2, N bytes -> OUT: version 3, B bricks below level R, N bytes`). The
/// frames of the two files are the same pixels.
///
/// # Errors
/// When `input` cannot be read or is not a valid `.tg` file, or `out` cannot be written (nothing is
/// left behind then).
pub fn migrate(input: &Path, out: &Path, layout: Layout) -> Result<String> {
    let bytes = fsutil::read_file(input)?;
    let grid = TriGrid::open(&bytes, Verify::Full)
        .map_err(|e| anyhow::anyhow!("{}: {e}", input.display()))?;
    let written = rewrite_tg(&grid, layout).with_context(|| format!("{}", input.display()))?;
    let h = TriGrid::open(&written, Verify::Full)
        .map(|g| *g.header())
        .context("the migrated file does not open: a bug")?;
    fsutil::write_atomic(out, &written)?;
    let describe = |h: &Header, len: usize| {
        let bricks = if h.bricked() {
            format!(", {} bricks below level {}", h.bricks, h.brick_level)
        } else {
            String::new()
        };
        format!("version {}{bricks}, {len} bytes", h.version)
    };
    Ok(format!(
        "{}: {} -> {}: {}",
        input.display(),
        describe(grid.header(), bytes.len()),
        out.display(),
        describe(&h, written.len())
    ))
}
