//! The firmware under QEMU: builds `boards/pda-arm` for thumbv7m-none-eabi, boots it on mps2-an385 with
//! the runner of `.cargo/config.toml`, and checks what it reports against the host, which renders the
//! same frame with the same library function (DESIGN.md: same frames, same CRC on ARM and host).
//!
//! Needs `qemu-system-arm`: without it these tests fail under CI and are skipped, with a note, elsewhere.

use std::fs;
use std::path::PathBuf;
use std::process::{Command, Output};
use std::sync::Mutex;

use pocketsplat_pda::{frame_crc, render_test_frame, FRAMEBUFFER_BYTES, PIXELS};
use pocketsplat_tests::{under_ci, workspace_root};

const TARGET: &str = "thumbv7m-none-eabi";
/// RAM of the board, bytes (memory.x).
const BOARD_RAM_BYTES: usize = 4 << 20;
/// Seconds a QEMU run may take before it counts as hung.
const QEMU_TIMEOUT_S: &str = "60";

/// Serialises firmware builds: every variant builds into the same target dir and output path.
static BUILD: Mutex<()> = Mutex::new(());

/// Builds the firmware with `features` and returns a copy of the ELF that later builds do not
/// overwrite.
fn build_firmware(features: &[&str]) -> PathBuf {
    let root = workspace_root();
    // A target dir of its own: the `cargo test` running this holds the lock on target/ itself.
    let target_dir = root.join("target/arm");
    let _guard = BUILD
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner());
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut cmd = Command::new(cargo);
    cmd.current_dir(&root).env("CARGO_TARGET_DIR", &target_dir);
    cmd.args([
        "build",
        "-p",
        "pocketsplat-pda",
        "--target",
        TARGET,
        "--release",
    ]);
    if !features.is_empty() {
        cmd.args(["--features", &features.join(",")]);
    }
    let out = cmd.output().expect("cargo runs");
    assert!(
        out.status.success(),
        "firmware build failed ({cmd:?}):\n{}",
        String::from_utf8_lossy(&out.stderr)
    );

    let built = target_dir.join(TARGET).join("release/pocketsplat-pda");
    let variant = if features.is_empty() {
        "default".to_owned()
    } else {
        features.join("+")
    };
    let elf = target_dir
        .join("qemu-smoke")
        .join(format!("pocketsplat-pda-{variant}.elf"));
    fs::create_dir_all(elf.parent().unwrap()).unwrap();
    fs::copy(&built, &elf)
        .unwrap_or_else(|e| panic!("copy {} to {}: {e}", built.display(), elf.display()));
    elf
}

/// The QEMU command line of the bare-metal ARM runner in `.cargo/config.toml`, so that the tests run
/// the firmware exactly as `cargo run --target thumbv7m-none-eabi` does.
fn runner() -> Vec<String> {
    let path = workspace_root().join(".cargo/config.toml");
    let config = fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let table = r#"[target.'cfg(all(target_arch = "arm", target_os = "none"))']"#;
    let line = config
        .lines()
        .skip_while(|l| l.trim() != table)
        .find_map(|l| l.trim().strip_prefix("runner"))
        .unwrap_or_else(|| panic!("no runner under {table} in {}", path.display()));
    let command = line
        .trim_start()
        .trim_start_matches('=')
        .trim()
        .trim_matches('"');
    command.split_whitespace().map(str::to_owned).collect()
}

/// Whether QEMU can be run here; `false` (after a note) only off CI.
///
/// # Panics
/// Under CI when QEMU is missing: the QEMU tests must never skip there.
fn have_qemu() -> bool {
    let qemu = &runner()[0];
    if Command::new(qemu)
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
    {
        return true;
    }
    assert!(
        !under_ci(),
        "{qemu} is missing and CI=true: install it (.ci/test-all does)"
    );
    eprintln!("note: {qemu} not found; QEMU test skipped (run .ci/test-all, or set CI=true to make this fail)");
    false
}

/// Boots the firmware built with `features` in QEMU, under `timeout`; prints its output.
fn run_firmware(features: &[&str]) -> Option<Output> {
    if !have_qemu() {
        return None;
    }
    let elf = build_firmware(features);
    let runner = runner();
    let out = Command::new("timeout")
        .arg(QEMU_TIMEOUT_S)
        .args(&runner)
        .arg(&elf)
        .output()
        .expect("timeout (coreutils) runs");
    eprintln!(
        "{} {} {}\nstatus: {}\nstdout:\n{}stderr:\n{}",
        QEMU_TIMEOUT_S,
        runner.join(" "),
        elf.display(),
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    Some(out)
}

/// The rest of the first stdout line that starts with `prefix`.
fn field<'a>(stdout: &'a str, prefix: &str) -> Option<&'a str> {
    stdout
        .lines()
        .find_map(|l| l.strip_prefix(prefix))
        .map(str::trim)
}

#[test]
fn firmware_frame_crc_matches_the_host() {
    let Some(out) = run_firmware(&[]) else { return };
    assert_eq!(
        out.status.code(),
        Some(0),
        "the firmware must exit through semihosting with status 0"
    );
    let stdout = String::from_utf8_lossy(&out.stdout);

    let crc = field(&stdout, "frame 0 crc ").expect("a `frame 0 crc 0x…` line");
    let crc =
        u32::from_str_radix(crc.strip_prefix("0x").expect("hex with 0x"), 16).expect("a hex u32");
    let mut fb = vec![0u16; PIXELS];
    render_test_frame(0, fb.as_mut_slice().try_into().unwrap());
    let host = frame_crc(&fb);
    assert_eq!(
        crc, host,
        "ARM frame 0 CRC {crc:#010x} differs from the host's {host:#010x}"
    );

    let ram: usize = field(&stdout, "ram_bytes ")
        .expect("a `ram_bytes N` line")
        .parse()
        .expect("a number");
    assert!(
        (FRAMEBUFFER_BYTES..=BOARD_RAM_BYTES).contains(&ram),
        "ram_bytes {ram}: must hold the {FRAMEBUFFER_BYTES}-byte framebuffer and fit the board's {BOARD_RAM_BYTES}"
    );
}

/// A failure (panic or fault) must end the run with status 1, not hang until the timeout (124).
fn assert_fails_fast(out: &Output, report: &str) {
    assert_eq!(
        out.status.code(),
        Some(1),
        "expected semihosting EXIT_FAILURE (status 1), got {}",
        out.status
    );
    let all = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        all.contains(report),
        "expected a `{report}` report from the firmware"
    );
    assert!(
        !all.contains("frame 0 crc"),
        "the self-test must fail before rendering"
    );
}

#[test]
fn firmware_hardfault_exits_with_failure() {
    let Some(out) = run_firmware(&["selftest-fault"]) else {
        return;
    };
    assert_fails_fast(&out, "hardfault: pc=");
}

#[test]
fn firmware_panic_exits_with_failure() {
    let Some(out) = run_firmware(&["selftest-panic"]) else {
        return;
    };
    assert_fails_fast(&out, "panic: ");
}
