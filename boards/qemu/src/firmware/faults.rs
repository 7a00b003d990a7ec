//! Faults end the run instead of hanging it: the HardFault and panic handlers report what happened
//! on the host's stderr and exit QEMU with a failure status (docs/ARCHITECTURE.md, Conventions 3);
//! the self-test features fail on purpose to prove it.

use core::panic::PanicInfo;

use cortex_m_rt::{exception, ExceptionFrame};

use super::semihosting::fail;

/// Fails on purpose when a self-test feature asks for it (tests/tests/qemu_smoke.rs checks that
/// QEMU then exits non-zero).
pub fn selftest() {
    // An undefined instruction: UsageFault, escalated to HardFault (UsageFault is disabled at reset).
    #[cfg(feature = "selftest-fault")]
    cortex_m::asm::udf();
    #[cfg(feature = "selftest-panic")]
    panic!("selftest-panic: panicking on purpose");
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
