//! The firmware under QEMU, without a model: builds `boards/qemu` for thumbv7m-none-eabi, boots it
//! on mps2-an385 with the runner of `.cargo/config.toml`, and checks what it reports against the host,
//! which renders the same test-pattern frame with the same library function (docs/ARCHITECTURE.md: same frames,
//! same CRC on ARM and host); that faults and panics end the run with a failure status instead of a
//! hang; and that the instruction counter (`tests/qemu-plugin/icount.c`) counts exactly.
//!
//! Needs `qemu-system-arm` (and a C compiler for the counter): without QEMU these tests fail under CI
//! and are skipped, with a note, elsewhere.

use pocketsplat_qemu::{frame_crc, render_test_frame, FRAMEBUFFER_BYTES, PIXELS};
use pocketsplat_tests::arm::{
    check_memory, frame_costs, have_qemu, Counter, Firmware, Run, BOARD_RAM_BYTES,
};

/// Builds the plain firmware with `features` and boots it, counting instructions with `counter`.
fn run_firmware(features: &[&str], counter: Option<&Counter>) -> Option<(Run, std::path::PathBuf)> {
    if !have_qemu() {
        return None;
    }
    let fw = Firmware::plain(features);
    let elf = fw.build().unwrap();
    let run = fw.run(&elf, counter).unwrap();
    eprintln!("{}", run.transcript());
    Some((run, elf))
}

#[test]
fn firmware_frame_crc_matches_the_host() {
    let Some((run, elf)) = run_firmware(&[], None) else {
        return;
    };
    assert_eq!(
        run.output.status.code(),
        Some(0),
        "the firmware must exit through semihosting with status 0"
    );
    let crc = run.field("frame 0 crc ").expect("a `frame 0 crc 0x…` line");
    let crc =
        u32::from_str_radix(crc.strip_prefix("0x").expect("hex with 0x"), 16).expect("a hex u32");
    let mut fb = vec![0u16; PIXELS];
    render_test_frame(0, fb.as_mut_slice().try_into().unwrap());
    let host = frame_crc(&fb);
    assert_eq!(
        crc, host,
        "ARM frame 0 CRC {crc:#010x} differs from the host's {host:#010x}"
    );

    let (memory, _) = check_memory(&run, &elf).unwrap();
    assert!(
        (FRAMEBUFFER_BYTES as u64..=BOARD_RAM_BYTES).contains(&memory.ram),
        "RAM {} bytes: must hold the {FRAMEBUFFER_BYTES}-byte framebuffer",
        memory.ram
    );
}

/// A failure (panic or fault) must end the run with status 1, not hang until the timeout (124).
fn assert_fails_fast(run: &Run, report: &str) {
    assert_eq!(
        run.output.status.code(),
        Some(1),
        "expected semihosting EXIT_FAILURE (status 1), got {}",
        run.output.status
    );
    let all = format!(
        "{}{}",
        run.stdout(),
        String::from_utf8_lossy(&run.output.stderr)
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
    let Some((run, _)) = run_firmware(&["selftest-fault"], None) else {
        return;
    };
    assert_fails_fast(&run, "hardfault: pc=");
}

#[test]
fn firmware_panic_exits_with_failure() {
    let Some((run, _)) = run_firmware(&["selftest-panic"], None) else {
        return;
    };
    assert_fails_fast(&run, "panic: ");
}

/// The counter sees the test pattern's frame between its markers, the same number of instructions
/// on every run (QEMU's TCG is deterministic for a single-core guest without I/O timing), and a
/// plausible number: every one of the 76 800 pixels costs some instructions, none costs thousands.
#[test]
fn instruction_counts_are_exact_and_repeatable() {
    if !have_qemu() {
        return;
    }
    let counter = Counter::build().unwrap();
    let counts: Vec<_> = (0..2)
        .map(|_| {
            let (run, _) = run_firmware(&[], Some(&counter)).unwrap();
            assert_eq!(run.output.status.code(), Some(0));
            run.marks.expect("the counter's marks")
        })
        .collect();
    assert_eq!(counts[0], counts[1], "two runs counted differently");
    // One frame, all its phases marked; all the work is in the traverse phase.
    let costs = frame_costs(&counts[0]).unwrap();
    assert_eq!(costs.len(), 1, "marker hits {:?}", counts[0].hits);
    let frame = costs[0].traverse;
    eprintln!(
        "test pattern frame: {frame} instructions, whole run {}",
        counts[0].total
    );
    assert!(
        (10 * PIXELS as u64..1000 * PIXELS as u64).contains(&frame),
        "{frame} instructions for {PIXELS} pixels"
    );
    assert!(costs[0].frame() - frame < 100, "{:?}", costs[0]);
}
