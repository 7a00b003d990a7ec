//! pocketsplat firmware for QEMU's mps2-an385 (Cortex-M3, no FPU), the reference ARM board in CI.
//!
//! Renders frame 0 of the test pattern into a static 240×320 RGB565 framebuffer, prints its CRC and the
//! RAM its statics take over semihosting, and exits QEMU with status 0. A panic or a HardFault prints
//! what happened and exits with a failure status, so a QEMU run never hangs (STYLE.md 3).
//!
//! Why the `cfg`s: the firmware only means something on bare-metal ARM. Built for the host (by
//! `cargo build -p pocketsplat-pda`, `cargo build --workspace`, rust-analyzer, …) this file is a small
//! std program, the host twin, that prints the line the firmware must print. So host builds of the
//! workspace never break, no `required-features` switch is needed to build the firmware, and the
//! runtime crates are target-gated dependencies that the host never compiles.
#![cfg_attr(all(target_arch = "arm", target_os = "none"), no_std, no_main)]

#[cfg(all(target_arch = "arm", target_os = "none"))]
mod firmware {
    use core::fmt::Write as _;
    use core::panic::PanicInfo;

    use cortex_m_rt::{entry, exception, heap_start, ExceptionFrame};
    use cortex_m_semihosting::{debug, hio, hprintln};
    use pocketsplat_pda::{frame_crc, render_test_frame, FrameCrc, PIXELS};

    #[cfg(all(feature = "selftest-fault", feature = "selftest-panic"))]
    compile_error!("the features `selftest-fault` and `selftest-panic` exclude each other");

    /// Proves the memory map: QEMU must load memory.x's `.psram` section (where baked models will be
    /// linked) before reset, and the firmware must read it back.
    #[link_section = ".psram"]
    static PSRAM_PROBE: [u8; 16] = *b"pocketsplat-psrm";

    extern "C" {
        /// Start of RAM (cortex-m-rt's link.x: `ORIGIN(RAM)` of memory.x).
        static _ram_start: u8;
        /// Bounds of the `.psram` output section (memory.x).
        static __spsram: u8;
        static __epsram: u8;
    }

    #[entry]
    fn main() -> ! {
        // cortex-m-rt turns a `static mut` declared in the entry function into a `&'static mut`:
        // the framebuffer sits in .bss (RAM), not on the stack, with no `unsafe`.
        static mut FRAMEBUFFER: [u16; PIXELS] = [0; PIXELS];

        selftest();
        let psram_bytes = check_psram();

        // Opaque frame number: under LTO the whole frame is otherwise a constant the compiler may fold.
        let frame = core::hint::black_box(0);
        render_test_frame(frame, FRAMEBUFFER);
        let crc = frame_crc(FRAMEBUFFER);
        hprintln!("{}", FrameCrc { frame, crc });

        // Statics in RAM (.data + .bss + .uninit); the stack comes on top of this.
        let ram_bytes = heap_start() as usize - (&raw const _ram_start) as usize;
        hprintln!("ram_bytes {}", ram_bytes);
        hprintln!("psram_bytes {}", psram_bytes);
        exit(debug::EXIT_SUCCESS)
    }

    /// Fails on purpose when a self-test feature asks for it (tests/tests/qemu_smoke.rs checks that
    /// QEMU then exits non-zero).
    fn selftest() {
        // An undefined instruction: UsageFault, escalated to HardFault (UsageFault is disabled at reset).
        #[cfg(feature = "selftest-fault")]
        cortex_m::asm::udf();
        #[cfg(feature = "selftest-panic")]
        panic!("selftest-panic: panicking on purpose");
    }

    /// Checks that the `.psram` probe reads back as linked; returns the size of `.psram`, bytes.
    fn check_psram() -> usize {
        let (start, end) = (
            (&raw const __spsram) as usize,
            (&raw const __epsram) as usize,
        );
        let probe = PSRAM_PROBE.as_ptr();
        assert!(
            (start..end).contains(&(probe as usize)),
            "PSRAM probe at {probe:p} is outside .psram"
        );
        let expected = *b"pocketsplat-psrm";
        for (i, want) in expected.into_iter().enumerate() {
            // SAFETY: `probe + i` is inside the 16-byte static PSRAM_PROBE. Volatile, to read what QEMU
            // loaded into memory rather than the value the compiler knows.
            let got = unsafe { core::ptr::read_volatile(probe.add(i)) };
            assert_eq!(got, want, "PSRAM byte {i} at {probe:p} was not loaded");
        }
        end - start
    }

    /// Ends the QEMU run with `status` (semihosting SYS_EXIT).
    fn exit(status: debug::ExitStatus) -> ! {
        debug::exit(status);
        // Only reached when no semihosting host ends the run (a debugger that resumes): idle.
        loop {
            cortex_m::asm::wfi();
        }
    }

    /// Reports a failure on the host's stderr and exits with a failure status.
    fn fail(what: core::fmt::Arguments) -> ! {
        // A fresh host stream, not `hprintln!`: the failure may have struck inside `hprintln!`, whose
        // shared stream is then still borrowed, and borrowing it again would panic in the panic handler.
        if let Ok(mut stderr) = hio::hstderr() {
            let _ = writeln!(stderr, "{what}");
        }
        exit(debug::EXIT_FAILURE)
    }

    #[exception]
    unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
        fail(format_args!(
            "hardfault: pc={:#010x} lr={:#010x} xpsr={:#010x}",
            frame.pc(),
            frame.lr(),
            frame.xpsr()
        ))
    }

    #[panic_handler]
    fn panic(info: &PanicInfo) -> ! {
        fail(format_args!("panic: {info}"))
    }
}

/// Host twin: prints the line the firmware prints for frame 0.
#[cfg(not(all(target_arch = "arm", target_os = "none")))]
fn main() {
    use pocketsplat_pda::{frame_crc, render_test_frame, FrameCrc, PIXELS};
    let mut fb: Box<[u16; PIXELS]> = vec![0; PIXELS]
        .into_boxed_slice()
        .try_into()
        .expect("PIXELS long");
    render_test_frame(0, &mut fb);
    println!(
        "{}",
        FrameCrc {
            frame: 0,
            crc: frame_crc(&fb[..])
        }
    );
}
