//! What a case found ([`Outcome`]) and the bounds it is held to; one row of the report
//! ([`CaseResult`]).

/// Largest allowed distance between a splat's centre and the f64 projection of its cell's centre.
pub const MAX_ERROR_PX: f64 = 0.5;
/// How far a splat's drawn pixels may reach beyond the true projected bounds: half a pixel because
/// whole pixels are drawn whose centres fall inside the splat, and [`MAX_ERROR_PX`] of projection error.
pub const BOUNDS_SLACK_PX: f64 = 0.5 + MAX_ERROR_PX;

/// What a case found.
#[derive(Clone, Debug, Default)]
pub struct Outcome {
    /// The case's worst error, in `unit`.
    pub worst: f64,
    /// Unit of `worst` (e.g. "px").
    pub unit: &'static str,
    /// Bound `worst` is held to.
    pub limit: f64,
    /// Splats checked, drawn pixels, and what else was measured.
    pub notes: String,
    /// Why the case fails; empty when it passes.
    pub failures: Vec<String>,
    /// Set when the case reproduces a documented known failure (and `failures` is then empty).
    pub known: Option<String>,
}

impl Outcome {
    pub(super) fn fail(&mut self, why: impl Into<String>) {
        self.failures.push(why.into());
    }
    /// Turns a measured failure into a known one when it is exactly the documented behaviour, and
    /// into a failure ("known failure changed") otherwise. (No case has a known failure since
    /// issue 18; kept for the next one.)
    #[allow(dead_code)]
    fn expect_known(&mut self, reproduced: bool, reason: &str) {
        if reproduced {
            self.failures.clear();
            self.known = Some(reason.to_string());
        } else {
            self.failures.insert(
                0,
                format!("the known failure no longer reproduces as documented ({reason}); update the suite"),
            );
        }
    }
}

/// One row of the report.
#[derive(Clone, Debug)]
pub struct CaseResult {
    /// Group name (one of [`GROUPS`](super::GROUPS)).
    pub group: &'static str,
    /// Case name, unique within the group.
    pub name: String,
    /// What it found (a panic becomes a failure naming the message and place).
    pub outcome: Outcome,
    /// Wall time, seconds (not in the markdown, which must not change between runs).
    pub seconds: f64,
}

impl CaseResult {
    /// Passed, or reproduced its documented known failure.
    pub fn ok(&self) -> bool {
        self.outcome.failures.is_empty()
    }
    /// "pass", "known failure" or "FAIL".
    pub fn status(&self) -> &'static str {
        match (self.ok(), self.outcome.known.is_some()) {
            (true, false) => "pass",
            (true, true) => "known failure",
            (false, _) => "FAIL",
        }
    }
}
