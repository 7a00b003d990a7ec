//! Running cases: a panic (an overflow, with overflow checks on) is caught and reported as the
//! case's failure with its message and place, instead of ending the suite.

use std::cell::{Cell, RefCell};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::time::Instant;

use super::outcome::{CaseResult, Outcome, MAX_ERROR_PX};

thread_local! {
    static IN_CASE: Cell<bool> = const { Cell::new(false) };
    static PANIC: RefCell<Option<String>> = const { RefCell::new(None) };
}

fn install_panic_hook() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if IN_CASE.with(Cell::get) {
                let msg = payload_message(info.payload());
                let at = info
                    .location()
                    .map(|l| format!(" at {}:{}", l.file(), l.line()))
                    .unwrap_or_default();
                PANIC.with(|p| *p.borrow_mut() = Some(format!("{msg}{at}")));
            } else {
                previous(info);
            }
        }));
    });
}

fn payload_message(p: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = p.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = p.downcast_ref::<String>() {
        s.clone()
    } else {
        "panic".to_string()
    }
}

/// Runs `f` with panics caught: `Err(message at file:line)` when it panicked.
fn guarded<T>(f: impl FnOnce() -> T) -> Result<T, String> {
    install_panic_hook();
    IN_CASE.with(|c| c.set(true));
    PANIC.with(|p| p.borrow_mut().take());
    let r = catch_unwind(AssertUnwindSafe(f));
    IN_CASE.with(|c| c.set(false));
    r.map_err(|payload| {
        PANIC
            .with(|p| p.borrow_mut().take())
            .unwrap_or_else(|| payload_message(payload.as_ref()))
    })
}

/// Whether this build checks integer overflow (the dev and test profiles do; release does not).
pub fn overflow_checks_on() -> bool {
    guarded(|| std::hint::black_box(i32::MAX) + std::hint::black_box(1)).is_err()
}

pub(super) struct Runner {
    /// The group whose cases run.
    pub(super) group: &'static str,
    /// Their results so far.
    pub(super) results: Vec<CaseResult>,
}

impl Runner {
    pub(super) fn case(&mut self, name: impl Into<String>, f: impl FnOnce() -> Outcome) {
        let t = Instant::now();
        let outcome = guarded(f).unwrap_or_else(|msg| Outcome {
            unit: "px",
            limit: MAX_ERROR_PX,
            failures: vec![format!("panicked: {msg}")],
            ..Outcome::default()
        });
        self.results.push(CaseResult {
            group: self.group,
            name: name.into(),
            outcome,
            seconds: t.elapsed().as_secs_f64(),
        });
    }

    /// Shared set-up (a bake): on a panic, a failing case named after it and `None`.
    pub(super) fn setup<T>(&mut self, name: &str, f: impl FnOnce() -> T) -> Option<T> {
        let t = Instant::now();
        match guarded(f) {
            Ok(v) => Some(v),
            Err(msg) => {
                self.results.push(CaseResult {
                    group: self.group,
                    name: format!("set-up: {name}"),
                    outcome: Outcome {
                        failures: vec![format!("panicked: {msg}")],
                        ..Outcome::default()
                    },
                    seconds: t.elapsed().as_secs_f64(),
                });
                None
            }
        }
    }
}
