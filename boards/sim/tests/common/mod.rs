//! Helpers shared by the simulator's tests (`mod common;` in tests/main.rs; each module uses some):
//! where the models are, and `pocketsplat` run as a user runs it, with the checks every hostile
//! input must pass.
#![allow(dead_code, unused_imports)]

use std::path::Path;
use std::process::{Command, Output};

pub use pocketsplat_fixture::models::{model, models_dir, under_ci};

/// The names of the files in `dir`, sorted: what a failed command must leave unchanged.
pub fn files_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// `pocketsplat ARGS` in `cwd` as a user without a display runs it (so `view` and the demo never
/// open a window), with backtraces on (so that a panic cannot pass for an error message).
pub fn command(args: &[&str], cwd: &Path) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_pocketsplat"));
    c.args(args)
        .current_dir(cwd)
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .env("RUST_BACKTRACE", "1");
    c
}

/// Runs [`command`].
pub fn pocketsplat(args: &[&str], cwd: &Path) -> Output {
    command(args, cwd).output().expect("pocketsplat runs")
}

/// Whether a run's stderr shows a panic.
pub fn panicked(stderr: &str) -> bool {
    stderr.contains("panicked")
        || stderr.contains("RUST_BACKTRACE")
        || stderr.contains("stack backtrace")
}

/// Runs `cmd` (a [`command`] for `args`, in `dir`) and checks: failure, no panic, every needle in
/// its message, no new file in `dir`. Returns the message.
pub fn fails_with(cmd: &mut Command, dir: &Path, args: &[&str], needles: &[&str]) -> String {
    let before = files_in(dir);
    let out = cmd.output().expect("pocketsplat runs");
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success(), "{args:?} should fail: {err}");
    assert!(!panicked(&err), "{args:?} panicked: {err}");
    for n in needles {
        assert!(err.contains(n), "{args:?}: {n:?} not in {err:?}");
    }
    assert_eq!(files_in(dir), before, "{args:?} left a file behind");
    err
}

/// [`fails_with`] the plain [`command`].
pub fn fails(dir: &Path, args: &[&str], needles: &[&str]) -> String {
    fails_with(&mut command(args, dir), dir, args, needles)
}

/// Runs `cmd` (a [`command`] for `args`) and checks success without a panic.
pub fn succeeds_with(cmd: &mut Command, args: &[&str]) -> Output {
    let out = cmd.output().expect("pocketsplat runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{args:?}: {err}");
    assert!(!panicked(&err), "{args:?}: {err}");
    out
}

/// [`succeeds_with`] the plain [`command`].
pub fn succeeds(dir: &Path, args: &[&str]) -> Output {
    succeeds_with(&mut command(args, dir), args)
}

/// `m` as an ASCII PLY file's text, positions as `double` (`{:e}`: the shortest text that reads
/// back as the same f64).
pub fn ply_text(m: &pocketsplat_core::bake::TriMesh) -> String {
    use std::fmt::Write as _;
    let mut s = format!(
        "ply\nformat ascii 1.0\nelement vertex {}\nproperty double x\nproperty double y\n\
         property double z\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
        m.positions.len(),
        m.triangles.len()
    );
    for p in &m.positions {
        let _ = writeln!(s, "{:e} {:e} {:e}", p[0], p[1], p[2]);
    }
    for t in &m.triangles {
        let _ = writeln!(s, "3 {} {} {}", t[0], t[1], t[2]);
    }
    s
}

/// [`ply_text`] of `m` written to `path`.
pub fn write_ply(m: &pocketsplat_core::bake::TriMesh, path: &std::path::Path) {
    std::fs::write(path, ply_text(m)).unwrap();
}
