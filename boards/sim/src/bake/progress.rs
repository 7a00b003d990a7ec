//! The progress of a long bake: one bar per phase (reading, partitioning, baking pieces,
//! stitching, writing) with its rate and time left, drawn on stderr when it is a terminal, and
//! the time each phase took, for the summary line.

use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressStyle};

/// The phases of a bake, in order.
pub struct Phases {
    total: usize,
    done: Vec<(&'static str, Duration)>,
    current: Option<(&'static str, Instant, ProgressBar)>,
    start: Instant,
    draw: bool,
}

/// What a phase counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Unit {
    /// Bytes of a file.
    Bytes,
    /// Triangles.
    Triangles,
    /// Points (QSplat leaves).
    Points,
}

impl Phases {
    /// `total` phases to come; bars are drawn when `draw` (and stderr is a terminal).
    pub fn new(total: usize, draw: bool) -> Self {
        Self {
            total,
            done: Vec::new(),
            current: None,
            start: Instant::now(),
            draw,
        }
    }

    /// Ends the phase under way and starts `name`, of `len` units; returns its bar (which is
    /// `Sync`: threads advance it with `inc`).
    pub fn start(&mut self, name: &'static str, len: u64, unit: Unit) -> ProgressBar {
        self.end();
        let bar = if self.draw {
            ProgressBar::new(len)
        } else {
            ProgressBar::hidden()
        };
        let counts = match unit {
            Unit::Bytes => "{bytes}/{total_bytes}",
            Unit::Triangles => "{human_pos}/{human_len} triangles",
            Unit::Points => "{human_pos}/{human_len} points",
        };
        let n = self.done.len() + 1;
        bar.set_style(
            ProgressStyle::with_template(&format!(
                "[{n}/{}] {{prefix:<13}} {{bar:30}} {counts} ({{elapsed}}, {{eta}} left)",
                self.total
            ))
            .expect("static template")
            .progress_chars("=> "),
        );
        bar.set_prefix(name);
        self.current = Some((name, Instant::now(), bar.clone()));
        bar
    }

    /// Ends the phase under way.
    pub fn end(&mut self) {
        if let Some((name, t, bar)) = self.current.take() {
            bar.finish_and_clear();
            self.done.push((name, t.elapsed()));
        }
    }

    /// Ends the last phase; returns the time since the start and each phase's.
    pub fn finish(mut self) -> (Duration, Vec<(&'static str, Duration)>) {
        self.end();
        (self.start.elapsed(), self.done)
    }
}

/// `reading 12.1 s, partitioning 30.2 s, …`.
pub fn phase_times(phases: &[(&'static str, Duration)]) -> String {
    phases
        .iter()
        .map(|(n, d)| format!("{n} {:.1} s", d.as_secs_f64()))
        .collect::<Vec<_>>()
        .join(", ")
}
