//! The measured frames summed up: per method the Pareto-optimal points over the views' mean, the
//! curves the plots draw, and the table of the best PSNR within each time budget
//! ([`BUDGETS_MS`]).

use std::collections::BTreeMap;
use std::fmt::Write as _;

use super::plot;
use super::sweep::{shadows_name, Row, Subject};
use crate::render::ShadowMode;

/// Time budgets of the headline table, ms.
pub const BUDGETS_MS: [f64; 9] = [0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0];

/// The PSNR-against-ARM-instructions plot's file name.
pub const ARM_PLOT: &str = "psnr-vs-arm.png";

/// ARM instructions of a row, millions.
pub(super) fn arm_millions(r: &Row) -> Option<f64> {
    r.arm_instructions.map(|n| n as f64 / 1e6)
}

/// The shadow modes the mean plot and the budget table are made for: off, and the subject's own.
pub(super) fn modes_plotted(subject: &Subject<'_>) -> Vec<&'static str> {
    let mut m = vec!["off"];
    if subject.shadows != ShadowMode::Off {
        m.push(shadows_name(subject.shadows));
    }
    m
}

/// `psnr-vs-ms.png` (shadows off), `psnr-vs-ms-one-pass.png`, …
pub(super) fn mean_plot_name(subject: &Subject<'_>, shadows: &str) -> String {
    if shadows == "off" || subject.shadows == ShadowMode::Off {
        "psnr-vs-ms.png".to_owned()
    } else {
        format!("psnr-vs-ms-{shadows}.png")
    }
}

/// A frame configuration on a plot: method, kernel, cutoff, time and PSNR.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Point {
    method: String,
    kernel: String,
    cutoff_px: Option<f32>,
    ms: f64,
    psnr_db: f64,
}

impl Point {
    /// The frame `r` at `x` on the plot's axis (time, ms, or ARM instructions).
    pub(super) fn of(r: &Row, x: f64) -> Self {
        Self {
            method: r.method.clone(),
            kernel: r.kernel.clone(),
            cutoff_px: r.cutoff_px,
            ms: x,
            psnr_db: r.psnr_db,
        }
    }
    fn label(&self) -> String {
        match self.cutoff_px {
            Some(c) => format!("{c} px, {}", self.kernel),
            None => self.kernel.clone(),
        }
    }
}

/// The configurations with `shadows` averaged over the views that have them all, with an `x` for
/// each: mean `x` (host time, ARM instructions, …), mean PSNR. Rows without an `x` are left out.
pub(super) fn mean_points(
    rows: &[Row],
    shadows: &str,
    x: impl Fn(&Row) -> Option<f64>,
) -> Vec<Point> {
    let views: std::collections::BTreeSet<&str> = rows.iter().map(|r| r.view.as_str()).collect();
    // (method, kernel, cutoff) → the rows of each view with their x.
    type Group<'r> = Vec<(&'r Row, f64)>;
    let mut groups: BTreeMap<(String, String, String), Group<'_>> = BTreeMap::new();
    for r in rows.iter().filter(|r| r.shadows == shadows) {
        let Some(v) = x(r) else { continue };
        let cutoff = r.cutoff_px.map(|c| c.to_string()).unwrap_or_default();
        groups
            .entry((r.method.clone(), r.kernel.clone(), cutoff))
            .or_default()
            .push((r, v));
    }
    let mut out: Vec<Point> = groups
        .into_values()
        .filter(|g| g.len() == views.len())
        .map(|g| {
            let n = g.len() as f64;
            Point {
                ms: g.iter().map(|(_, v)| v).sum::<f64>() / n,
                psnr_db: g.iter().map(|(r, _)| r.psnr_db).sum::<f64>() / n,
                ..Point::of(g[0].0, 0.0)
            }
        })
        .collect();
    out.sort_by(|a, b| a.method.cmp(&b.method).then(a.ms.total_cmp(&b.ms)));
    out
}

/// Method names in a fixed order (the plots' colours), then any others.
pub(super) const METHOD_ORDER: [&str; 4] = ["trigrid", "octree", "qsplat", "brute"];

pub(super) fn method_order(points: &[Point]) -> Vec<String> {
    let mut names: Vec<String> = METHOD_ORDER
        .iter()
        .filter(|m| points.iter().any(|p| p.method == **m))
        .map(|m| (*m).to_owned())
        .collect();
    for p in points {
        if !names.contains(&p.method) {
            names.push(p.method.clone());
        }
    }
    names
}

pub(super) fn curves(points: &[Point]) -> Vec<plot::Curve> {
    method_order(points)
        .into_iter()
        .map(|m| plot::Curve {
            points: points
                .iter()
                .filter(|p| p.method == m && p.psnr_db.is_finite() && p.ms > 0.0)
                .map(|p| (p.ms, p.psnr_db))
                .collect(),
            label: m,
        })
        .collect()
}

/// The best point of each method within each budget.
pub(super) fn budget_table(points: &[Point]) -> String {
    let mut out = String::from("| method |");
    for b in BUDGETS_MS {
        let _ = write!(out, " ≤ {b} ms |");
    }
    out.push_str("\n|---|");
    out.push_str(&"---|".repeat(BUDGETS_MS.len()));
    out.push('\n');
    for m in method_order(points) {
        let _ = write!(out, "| {m} |");
        let mut previous = None;
        for b in BUDGETS_MS {
            let best = points
                .iter()
                .filter(|p| p.method == m && p.ms <= b)
                // The best PSNR; of equals, the fastest.
                .max_by(|a, b| a.psnr_db.total_cmp(&b.psnr_db).then(b.ms.total_cmp(&a.ms)));
            match best {
                // The same frame as in the budget before: say so briefly.
                Some(p) if previous == Some(p) => out.push_str(" 〃 |"),
                Some(p) => {
                    let _ = write!(
                        out,
                        " **{:.2}** dB ({}, {:.2} ms) |",
                        p.psnr_db,
                        p.label(),
                        p.ms
                    );
                }
                None => out.push_str(" — |"),
            }
            previous = best;
        }
        out.push('\n');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(method: &str, ms: f64, psnr_db: f64) -> Point {
        Point {
            method: method.into(),
            kernel: "square".into(),
            cutoff_px: Some(1.0),
            ms,
            psnr_db,
        }
    }

    #[test]
    fn a_budget_takes_the_best_frame_that_fits() {
        let pts = [
            point("trigrid", 0.8, 20.0),
            point("trigrid", 3.0, 25.0),
            point("trigrid", 4.0, 24.0),
            point("brute", 30.0, 26.0),
            point("brute", 60.0, 26.0),
        ];
        let t = budget_table(&pts);
        let line = |m: &str| {
            t.lines()
                .find(|l| l.starts_with(&format!("| {m} |")))
                .unwrap()
                .to_owned()
        };
        let tg_line = line("trigrid");
        let tg: Vec<&str> = tg_line.split('|').map(str::trim).collect();
        // Columns: "", method, ≤0.5, ≤1, ≤2, ≤5, ...
        assert_eq!(tg[2], "—");
        assert!(tg[3].starts_with("**20.00** dB"), "{tg:?}");
        assert!(tg[5].starts_with("**25.00** dB"), "{tg:?}");
        assert_eq!(tg[6], "〃", "{tg:?}");
        let brute_line = line("brute");
        let brute: Vec<&str> = brute_line.split('|').map(str::trim).collect();
        assert_eq!(brute[6], "—");
        assert!(brute[8].starts_with("**26.00** dB"), "{brute:?}");
        // An equal PSNR later is not better.
        assert_eq!(brute[10], "〃", "{brute:?}");
    }
}
