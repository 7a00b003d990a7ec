//! `pocketsplat migrate`: a `.tg` file written again in another layout, every stored value kept
//! (FORMAT.md "Versions"): a version 2 file becomes version 3 with bricks, which streaming needs.

use std::path::Path;

use anyhow::{Context, Result};
use pocketsplat_core::tg::write::{rewrite_tg, Layout};
use pocketsplat_core::tg::{TriGrid, Verify};

use crate::fsutil;

/// The layout called `name`: `bricked` (the writer's brick level), `bricked:R` (bricks below level
/// `R`), `unbricked` or `v2`.
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

/// Reads `input` (checked whole, as `render` reads it), writes it to `out` in `layout` and says
/// what changed. The frames of the two files are the same pixels.
///
/// # Errors
/// When `input` cannot be read or is not a valid `.tg` file, or `out` cannot be written.
pub fn run(input: &Path, out: &Path, layout: Layout) -> Result<()> {
    let bytes = fsutil::read_file(input)?;
    let grid = TriGrid::open(&bytes, Verify::Full)
        .map_err(|e| anyhow::anyhow!("{}: {e}", input.display()))?;
    let written = rewrite_tg(&grid, layout).with_context(|| format!("{}", input.display()))?;
    fsutil::write_atomic(out, &written)?;
    let h = TriGrid::open(&written, Verify::Full)
        .map(|g| *g.header())
        .context("the migrated file does not open: a bug")?;
    let describe = |h: &pocketsplat_core::tg::Header, len: usize| {
        let bricks = if h.bricked() {
            format!(", {} bricks below level {}", h.bricks, h.brick_level)
        } else {
            String::new()
        };
        format!("version {}{bricks}, {len} bytes", h.version)
    };
    println!(
        "{}: {} -> {}: {}",
        input.display(),
        describe(grid.header(), bytes.len()),
        out.display(),
        describe(&h, written.len())
    );
    Ok(())
}
