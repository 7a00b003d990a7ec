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
    // Rewriting unpacks every sample (a mask takes 16 bytes in memory, 1 to 16 in the file) and
    // holds the file twice more: bounded by the `bake` limit before anything is unpacked.
    crate::limits::current()
        .check(
            "bake",
            "the memory migrating it is estimated to need, bytes",
            migrate_memory(&grid),
        )
        .with_context(|| format!("cannot migrate {}", input.display()))?;
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

/// Bytes of memory [`migrate`] needs for `grid`, about: the file read, the file written and the
/// level arrays laid out for it (each about the file's size), and the samples unpacked (attribute,
/// colour, cone class, and a 16-byte mask per interior cell).
pub fn migrate_memory(grid: &TriGrid<'_>) -> u64 {
    let h = grid.header();
    let file = grid.bytes().len() as u64;
    let samples = grid.total_samples();
    let interior = samples - u64::from(grid.leaf_samples());
    let per_sample = 2 + 1 + if h.has_color() { 2 } else { 0 };
    3 * file + samples * per_sample + 16 * interior
}
