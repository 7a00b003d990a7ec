//! Linker setup for the bare-metal ARM build, the panel's size, and the baked model the firmware
//! links in.
//!
//! - `POCKETSPLAT_PDA_PANEL=WxH` (default `240x320`) sets the panel the frames are drawn for: the
//!   lib's `WIDTH` and `HEIGHT`, the size of the firmware's colour and depth buffers (the projection
//!   follows them).
//! - `POCKETSPLAT_PDA_BANDS=N` (default 1) draws a scene's frame in `N` horizontal bands
//!   (`BANDS`, `BAND_ROWS`; `N` divides the height), as a board with less RAM than a frame's
//!   colour and depth would.
//! - `-Tlink.x` (cortex-m-rt's script, which includes the workspace's `memory.x`) is passed with
//!   `rustc-link-arg-bins`, and only when the target is bare-metal ARM: host builds of this package and
//!   every other crate of the workspace never see it (docs/ARCHITECTURE.md, Conventions 2).
//! - With the `stream` feature, for the ARM firmware, `POCKETSPLAT_PDA_IMAGE` names the FAT disk image the firmware opens
//!   on the host through semihosting at run time; its absolute path (the image need not exist yet,
//!   and its bytes are not part of the build) is handed on as `POCKETSPLAT_PDA_IMAGE_FILE`.
//! - With the `model` feature, `POCKETSPLAT_PDA_MODEL` names a baked `.tg` or `.qs` file; its absolute
//!   path is handed to the firmware as `POCKETSPLAT_PDA_MODEL_FILE`, which `include_bytes!` links into
//!   `.psram`. The firmware tells the format by the magic at run time; a `.qs` file without the
//!   `qsplat` feature is refused here, where the fix (the feature) can be named. A feature rather than the variable alone, so that the builds with and without a model
//!   are separate artifacts that cargo keeps side by side instead of rebuilding on every switch.

use std::env;
use std::path::PathBuf;

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    panel();
    if env::var_os("CARGO_FEATURE_MODEL").is_some() {
        model();
    }
    let arch = env::var("CARGO_CFG_TARGET_ARCH").unwrap_or_default();
    let os = env::var("CARGO_CFG_TARGET_OS").unwrap_or_default();
    if arch != "arm" || os != "none" {
        return;
    }
    // The board's memory map: memory/an505/memory.x for Armv8-M (QEMU's mps2-an505, Cortex-M33),
    // memory/an385/memory.x otherwise (mps2-an385 and mps2-an386 share a map). Not at the workspace
    // root: rust-lld looks in its working directory (the workspace root) before the search path, so a
    // memory.x there would win for every target. The rerun line relinks when the map changes. Only
    // the mps2 firmware binary links with it.
    if env::var_os("CARGO_FEATURE_MPS2").is_none() {
        return;
    }
    // Only the firmware binary opens the image: the host build of the lib (the tests' twin of the
    // sequence) takes its source as an argument.
    if env::var_os("CARGO_FEATURE_STREAM").is_some() {
        image();
    }
    let target = env::var("TARGET").unwrap_or_default();
    let board = if target.starts_with("thumbv8m") {
        "an505"
    } else {
        "an385"
    };
    let dir = manifest_dir().join("memory").join(board);
    // As a link argument of the binary, not `rustc-link-search`: search paths propagate to the link
    // of every crate that depends on this package's lib, and another board has its own memory.x.
    println!("cargo:rustc-link-arg-bins=-L{}", dir.display());
    println!("cargo:rerun-if-changed={}", dir.join("memory.x").display());
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
}

fn manifest_dir() -> PathBuf {
    PathBuf::from(env::var("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"))
}

/// The panel's size, a build-time choice: `POCKETSPLAT_PDA_PANEL=WxH` (default `240x320`, the
/// reference frame), written as the `WIDTH` and `HEIGHT` constants the lib includes. A size the
/// core's viewport cannot take stops the build with what to write instead.
fn panel() {
    const VAR: &str = "POCKETSPLAT_PDA_PANEL";
    println!("cargo:rerun-if-env-changed={VAR}");
    let text = env::var(VAR).unwrap_or_else(|_| "240x320".to_owned());
    let size = text
        .split_once(['x', 'X'])
        .and_then(|(w, h)| Some((w.trim().parse::<u32>().ok()?, h.trim().parse::<u32>().ok()?)))
        .filter(|&(w, h)| (16..=1024).contains(&w) && (16..=1024).contains(&h));
    let Some((width, height)) = size else {
        panic!(
            "{VAR}={text}: want WIDTHxHEIGHT with each side from 16 to 1024 pixels, e.g. 320x240"
        );
    };
    const BANDS: &str = "POCKETSPLAT_PDA_BANDS";
    println!("cargo:rerun-if-env-changed={BANDS}");
    let text = env::var(BANDS).unwrap_or_else(|_| "1".to_owned());
    let bands = text
        .trim()
        .parse::<u32>()
        .ok()
        .filter(|&n| n >= 1 && height % n == 0);
    let Some(bands) = bands else {
        panic!("{BANDS}={text}: want a number of bands that divides the panel's {height} rows");
    };
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR")).join("panel.rs");
    let rows = height / bands;
    let src = format!(
        "/// Panel width, pixels (`{VAR}` at build time; 240 by default).\n\
         pub const WIDTH: usize = {width};\n\
         /// Panel height, pixels (`{VAR}` at build time; 320 by default).\n\
         pub const HEIGHT: usize = {height};\n\
         /// Bands a scene's frame is drawn in (`{BANDS}` at build time; 1 by default).\n\
         pub const BANDS: usize = {bands};\n\
         /// Rows of a band: the height of a scene's colour and depth buffers.\n\
         pub const BAND_ROWS: usize = {rows};\n"
    );
    std::fs::write(&out, src).unwrap_or_else(|e| panic!("{}: {e}", out.display()));
}

/// Resolves `POCKETSPLAT_PDA_MODEL` (relative paths from the workspace root, where the README's
/// commands run) and passes it on; a missing variable or file is an error that says what to do.
fn model() {
    const VAR: &str = "POCKETSPLAT_PDA_MODEL";
    let path = path_from_env(
        VAR,
        "the `model` feature needs it to name a baked .tg or .qs file \
         (e.g. `pocketsplat bake ../shared/models/bun_zipper.ply.gz -o bunny.tg`)",
    );
    let path = path
        .canonicalize()
        .unwrap_or_else(|e| panic!("{VAR}={}: {e}", path.display()));
    println!("cargo:rerun-if-changed={}", path.display());
    if is_qsplat(&path) && env::var_os("CARGO_FEATURE_QSPLAT").is_none() {
        panic!(
            "{VAR}={} is a QSplat file: build with `--features model,qsplat`",
            path.display()
        );
    }
    if starts_with(&path, b"PSPK") && env::var_os("CARGO_FEATURE_SCENE").is_none() {
        panic!(
            "{VAR}={} is a scene pack: build with `--features model,scene,shadows`",
            path.display()
        );
    }
    println!(
        "cargo:rustc-env=POCKETSPLAT_PDA_MODEL_FILE={}",
        path.display()
    );
}

/// Whether the file at `path` starts like a QSplat file (`QSplat`, as
/// `pocketsplat_qemu::QSPLAT_MAGIC_PREFIX`); an unreadable file is left for `include_bytes!` to report.
fn is_qsplat(path: &std::path::Path) -> bool {
    starts_with(path, b"QSplat")
}

/// Whether the file at `path` starts with `magic` (`PSPK` for a scene pack, as
/// `pocketsplat_core::scene::MAGIC`).
fn starts_with(path: &std::path::Path, magic: &[u8]) -> bool {
    use std::io::Read;
    let mut head = vec![0u8; magic.len()];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut head))
        .is_ok_and(|()| head == magic)
}

/// Resolves `POCKETSPLAT_PDA_IMAGE` (relative paths from the workspace root) into the absolute path
/// the firmware asks the semihosting host to open.
fn image() {
    const VAR: &str = "POCKETSPLAT_PDA_IMAGE";
    let path = path_from_env(
        VAR,
        "the `stream` firmware needs it to name a FAT disk image holding BUNNY.TG \
         (tests/tests/qemu_stream.rs makes one with mkfs.fat and mcopy)",
    );
    let text = path
        .to_str()
        .unwrap_or_else(|| panic!("{VAR}={}: not UTF-8", path.display()));
    assert!(!text.contains('\0'), "{VAR}: a path cannot hold NUL");
    println!("cargo:rustc-env=POCKETSPLAT_PDA_IMAGE_FILE={text}");
}

/// The path in the environment variable `var` (watched for changes), relative paths taken from the
/// workspace root, where the README's commands run; a missing variable panics with `missing`.
fn path_from_env(var: &str, missing: &str) -> PathBuf {
    println!("cargo:rerun-if-env-changed={var}");
    let Some(path) = env::var_os(var) else {
        panic!("{var} is not set: {missing}");
    };
    let path = PathBuf::from(path);
    if path.is_absolute() {
        path
    } else {
        manifest_dir().join("../..").join(path)
    }
}
