//! Ending the QEMU run through the semihosting host: with a status ([`exit`]), or with a message on
//! the host's stderr and a failure status ([`fail`]). (Printing is `hprintln!`; the streamed disk
//! image is `super::disk`.)

use core::fmt::Write as _;

use cortex_m_semihosting::{debug, hio};

/// Ends the QEMU run with `status` (semihosting SYS_EXIT).
pub fn exit(status: debug::ExitStatus) -> ! {
    debug::exit(status);
    // Only reached when no semihosting host ends the run (a debugger that resumes): idle.
    loop {
        cortex_m::asm::wfi();
    }
}

/// Reports a failure on the host's stderr and exits with a failure status.
pub fn fail(what: core::fmt::Arguments) -> ! {
    // A fresh host stream, not `hprintln!`: the failure may have struck inside `hprintln!`, whose
    // shared stream is then still borrowed, and borrowing it again would panic in the panic handler.
    if let Ok(mut stderr) = hio::hstderr() {
        let _ = writeln!(stderr, "{what}");
    }
    exit(debug::EXIT_FAILURE)
}
