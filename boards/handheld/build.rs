//! Linker setup for the board binary, and the baked model it may link in.
//!
//! - On bare-metal ARM with the `pico2` feature: cortex-m-rt's `link.x` (which includes this folder's
//!   `memory.x`, found in the working directory: this package is its own workspace root), defmt's
//!   `defmt.x`, and `--nmagic` (no page alignment of sections in flash), for the binaries only.
//! - With the `model` feature, `POCKETSPLAT_PDA_MODEL` names a baked `.tg` file (relative paths from
//!   this folder), passed on as `POCKETSPLAT_PDA_MODEL_FILE` for `include_bytes!`.

use std::env;
use std::path::PathBuf;

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    let dir = PathBuf::from(env::var("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"));
    if env::var_os("CARGO_FEATURE_MODEL").is_some() {
        const VAR: &str = "POCKETSPLAT_PDA_MODEL";
        println!("cargo:rerun-if-env-changed={VAR}");
        let Some(path) = env::var_os(VAR) else {
            panic!(
                "the `model` feature needs {VAR}=<baked .tg file> (`pocketsplat bake … --depth 5`)"
            );
        };
        let path = dir.join(path);
        let path = path
            .canonicalize()
            .unwrap_or_else(|e| panic!("{VAR}={}: {e}", path.display()));
        println!("cargo:rerun-if-changed={}", path.display());
        println!(
            "cargo:rustc-env=POCKETSPLAT_PDA_MODEL_FILE={}",
            path.display()
        );
    }
    let arm = env::var("CARGO_CFG_TARGET_ARCH").is_ok_and(|a| a == "arm")
        && env::var("CARGO_CFG_TARGET_OS").is_ok_and(|o| o == "none");
    if !arm || env::var_os("CARGO_FEATURE_PICO2").is_none() {
        return;
    }
    println!("cargo:rerun-if-changed={}", dir.join("memory.x").display());
    println!("cargo:rustc-link-arg-bins=-L{}", dir.display());
    println!("cargo:rustc-link-arg-bins=--nmagic");
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
}
