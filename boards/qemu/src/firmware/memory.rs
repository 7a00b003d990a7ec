//! Memory use from the linker's symbols, and the stack's high-water mark. The firmware's only
//! `unsafe` blocks (besides the HardFault handler's signature) are here.

use cortex_m_rt::heap_start;

extern "C" {
    /// Start of RAM (cortex-m-rt's link.x: `ORIGIN(RAM)` of memory.x).
    static _ram_start: u8;
    /// Initial stack pointer: the top of RAM.
    static _stack_start: u8;
    /// Start of the vector table: `ORIGIN(FLASH)`.
    static __vector_table: u8;
    /// `.data` in RAM, and where its initial values are stored in flash.
    static __sdata: u8;
    static __edata: u8;
    static __sidata: u8;
    /// Bounds of the `.psram` output section (memory.x).
    static __spsram: u8;
    static __epsram: u8;
}

/// What an untouched stack word holds.
const PAINT: u32 = 0x5EA7_C0DE;
/// Bytes below the current stack pointer left unpainted (this function's own frame).
const PAINT_MARGIN: usize = 256;

/// Statics in RAM (.data + .bss + .uninit), bytes; the stack comes on top of this.
pub fn ram_bytes() -> usize {
    heap_start() as usize - (&raw const _ram_start) as usize
}

/// Code, read-only data and `.data`'s initial values, bytes (the image a board's flash holds;
/// the model lives in `.psram` and is counted there).
pub fn flash_bytes() -> usize {
    let data = (&raw const __edata) as usize - (&raw const __sdata) as usize;
    (&raw const __sidata) as usize + data - (&raw const __vector_table) as usize
}

/// Fills the free RAM between the statics and the stack with [`PAINT`].
pub fn paint_stack() {
    let lo = heap_start() as usize;
    let sp = cortex_m::register::msp::read() as usize - PAINT_MARGIN;
    for addr in (lo..sp).step_by(4) {
        // SAFETY: [heap_start, sp − margin) is RAM above every static and below the live
        // stack (no heap exists), word-aligned (link.x aligns __sheap to 4), owned by no one.
        unsafe { core::ptr::write_volatile(addr as *mut u32, PAINT) };
    }
}

/// The most stack used since [`paint_stack`], bytes: from the top of RAM down to the lowest
/// word no longer holding [`PAINT`].
pub fn stack_peak_bytes() -> usize {
    let top = (&raw const _stack_start) as usize;
    let mut addr = heap_start() as usize;
    // SAFETY: reads of word-aligned RAM between the statics and the top of the stack.
    while addr < top && unsafe { core::ptr::read_volatile(addr as *const u32) } == PAINT {
        addr += 4;
    }
    top - addr
}

/// Proves the memory map: QEMU must load memory.x's `.psram` section (where baked models are
/// linked) before reset, and the firmware must read it back. Returns the size of `.psram`.
pub fn check_psram() -> usize {
    /// A known pattern in `.psram`.
    #[link_section = ".psram"]
    static PSRAM_PROBE: [u8; 16] = *b"pocketsplat-psrm";

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
        // SAFETY: `probe + i` is inside the 16-byte static PSRAM_PROBE. Volatile, to read what
        // QEMU loaded into memory rather than the value the compiler knows.
        let got = unsafe { core::ptr::read_volatile(probe.add(i)) };
        assert_eq!(got, want, "PSRAM byte {i} at {probe:p} was not loaded");
    }
    end - start
}
