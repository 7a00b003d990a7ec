//! `pocketsplat report stability`: a named suite of extreme and stiff cases for the integer renderer,
//! each judged against an f64 projection of the same cells (docs/ARCHITECTURE.md "Numbers": overflow is a bug).
//!
//! A case passes only when it does not panic (overflow checks on: the dev profile has them), every
//! splat that reaches the screen lies within [`MAX_ERROR_PX`] of the f64 projection of its cell's
//! centre (and has the f64 diameter within as much, where the raster draws it unclamped), no splat
//! draws outside the true projected bounds of its cell's bounding sphere (and of the model) by more
//! than [`BOUNDS_SLACK_PX`], and no splat comes from in front of the near plane; cases with more to
//! check (images that must match, α, the frame-rate controller, shadows) say so in their notes. A
//! case the core cannot pass yet is a *known failure*: it checks that the failure is still the one
//! documented, so it fails as soon as the behaviour changes (fixed or worse).
//!
//! The groups are the rows of issue 8 §3; `boards/sim/tests/stability.rs` runs each as one test.
//! Meshes are generated here, so the suite needs no model files.
//!
//! One job per module, each using only those before it: `outcome` (what a case found, the bounds),
//! `runner` (cases run with panics caught), `meshes` and `baked` (the models and the f64 geometry of
//! their cells), `shot`, `probe` and `frame` (one frame checked splat by splat), `cases` (the
//! groups), `page` (the markdown table and `docs/stability.md`); this module runs them
//! ([`run_group`], [`command`]).

mod baked;
mod cases;
mod frame;
mod meshes;
mod outcome;
mod page;
mod probe;
mod runner;
mod shot;

use std::time::Instant;

pub use baked::{cell_centres, child_centroids, world_sphere, Baked};
pub use frame::{shoot, Measured};
pub use meshes::{blob, cluster_with_outliers, flat_plane, needle, single_triangle, wire};
pub use outcome::{CaseResult, Outcome, BOUNDS_SLACK_PX, MAX_ERROR_PX};
pub use page::{document, markdown, DOC_COMMAND};
pub use probe::Checks;
pub use runner::overflow_checks_on;
pub use shot::Shot;

use runner::Runner;

/// The groups, in report order.
pub const GROUPS: [&str; 9] = [
    "distance", "inside", "fov", "axes", "scale", "depth", "shapes", "lights", "lod",
];

/// Runs one group by name.
///
/// # Panics
/// When `group` is not one of [`GROUPS`].
pub fn run_group(group: &str) -> Vec<CaseResult> {
    let group = *GROUPS
        .iter()
        .find(|g| **g == group)
        .unwrap_or_else(|| panic!("no stability group {group:?}; groups: {GROUPS:?}"));
    let mut r = Runner {
        group,
        results: Vec::new(),
    };
    cases::run(group, &mut r);
    r.results
}

/// Runs every group.
pub fn run_all() -> Vec<CaseResult> {
    GROUPS.iter().flat_map(|g| run_group(g)).collect()
}

/// `pocketsplat report stability`: runs `groups` (all when empty), prints the table, writes the page
/// to `out` when given, and fails when a case fails.
///
/// # Errors
/// When overflow checks are off (a release build cannot see overflow), a group name is unknown, the
/// page cannot be written, or a case fails.
pub fn command(out: Option<&std::path::Path>, groups: &[String]) -> anyhow::Result<()> {
    if !overflow_checks_on() {
        anyhow::bail!(
            "this build does not check integer overflow, which the suite tests: run it in the dev \
             profile (`cargo run -p pocketsplat-sim -- report stability`, without --release)"
        );
    }
    if let Some(g) = groups.iter().find(|g| !GROUPS.contains(&g.as_str())) {
        anyhow::bail!(
            "no stability group {g:?}; the groups are {}",
            GROUPS.join(", ")
        );
    }
    let mut results = Vec::new();
    for g in GROUPS {
        if groups.is_empty() || groups.iter().any(|x| x == g) {
            let t = Instant::now();
            let r = run_group(g);
            eprintln!(
                "{g}: {} cases in {:.1} s",
                r.len(),
                t.elapsed().as_secs_f64()
            );
            results.extend(r);
        }
    }
    print!("{}", markdown(&results));
    if let Some(path) = out {
        crate::fsutil::write_atomic(path, document(&results).as_bytes())?;
    }
    let failed: Vec<String> = results
        .iter()
        .filter(|c| !c.ok())
        .map(|c| format!("{} / {}", c.group, c.name))
        .collect();
    if !failed.is_empty() {
        anyhow::bail!(
            "{} stability cases fail: {}",
            failed.len(),
            failed.join(", ")
        );
    }
    Ok(())
}
