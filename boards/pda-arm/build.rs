//! Linker setup for the bare-metal ARM build only.
//!
//! `-Tlink.x` (cortex-m-rt's script, which includes the workspace's `memory.x`) is passed with
//! `rustc-link-arg-bins`, and only when the target is bare-metal ARM: host builds of this package and
//! every other crate of the workspace never see it (STYLE.md 2).

use std::env;
use std::path::PathBuf;

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    let arch = env::var("CARGO_CFG_TARGET_ARCH").unwrap_or_default();
    let os = env::var("CARGO_CFG_TARGET_OS").unwrap_or_default();
    if arch != "arm" || os != "none" {
        return;
    }
    // memory.x lives at the workspace root (one memory map for the reference board). rust-lld finds it
    // in its working directory, which cargo sets to the workspace root; the search path makes that not
    // depend on where rustc happens to run, and the rerun line relinks when the map changes.
    let root =
        PathBuf::from(env::var("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"))
            .join("../..");
    let root = root.canonicalize().unwrap_or(root);
    println!("cargo:rustc-link-search={}", root.display());
    println!("cargo:rerun-if-changed={}", root.join("memory.x").display());
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
}
