//! A model on a Cortex-M board's display, in the few lines a firmware needs: open the model in
//! flash, orbit a camera, draw into the display through a depth buffer of your own.
//!
//! The display here is a stand-in for your driver (an ST7735 128 × 160 panel, say, behind
//! `mipidsi` or `st7735-lcd`): any embedded-graphics `DrawTarget<Color = Rgb565>` will do. This one
//! is the crate's [`TestPanel`], which counts the pixels it would be sent over SPI and checksums
//! them, so that a run shows what was drawn.
//!
//! Build and run it on QEMU's Cortex-M3 board (the workspace's runner, `.cargo/config.toml`):
//!
//! ```sh
//! cargo run -p pocketsplat-core --example cortex_m --target thumbv7m-none-eabi --release
//! ```
//!
//! Built for the host (`cargo run -p pocketsplat-core --example cortex_m`) the same code runs as a
//! std program and prints the same lines: no float per node, the same pixels on both.
#![cfg_attr(all(target_arch = "arm", target_os = "none"), no_std, no_main)]

use pocketsplat_core::{
    render, DisplayTarget, Model, ModelError, RenderError, RenderOptions, ShadingTable, Target,
    TestPanel, Verify, View,
};

/// The panel's size: a common 1.8" ST7735 TFT, portrait.
const WIDTH: usize = 128;
const HEIGHT: usize = 160;

/// The model, baked on the desktop (`pocketsplat bake mesh.ply -o model.tg`) and linked into
/// flash, where it is read in place.
static MODEL: &[u8] = include_bytes!("data/trefoil.tg");

/// Why the example stops.
#[derive(Debug)]
enum Error {
    Model(ModelError),
    Render(RenderError),
}

impl core::fmt::Display for Error {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Error::Model(e) => write!(f, "the model: {e}"),
            Error::Render(e) => write!(f, "a frame: {e}"),
        }
    }
}

/// Draws the model from four sides; returns the pixels sent to the panel and their checksum.
fn draw(depth: &mut [u16], table: &mut ShadingTable<1>) -> Result<(u32, u32), Error> {
    // Trusted flash: the header and the structure are checked, not every block's CRC.
    let model = Model::open_with(MODEL, Verify::Structure).map_err(Error::Model)?;
    let mut panel = TestPanel::new(WIDTH as u32, HEIGHT as u32);
    // A coarser cutoff than the desktop's 1 px: four times fewer splats, and what a moving camera
    // would use (`lod::CutoffController` adapts it to a frame rate).
    let options = RenderOptions {
        cutoff_px: 2.0,
        ..RenderOptions::default()
    };
    for az in [0.0, 90.0, 180.0, 270.0] {
        let camera = model.orbit(View::new(az, 20.0, 2.5));
        let pixels = DisplayTarget::new(&mut panel, &mut *depth).expect("a depth value per pixel");
        let mut target = Target::new(pixels, &mut *table);
        render(&model, &camera, &options, &mut target).map_err(Error::Render)?;
    }
    Ok((panel.sent(), panel.crc()))
}

#[cfg(all(target_arch = "arm", target_os = "none"))]
mod device {
    use cortex_m_rt::{entry, exception, ExceptionFrame};
    use cortex_m_semihosting::{debug, hprintln};
    use pocketsplat_core::ShadingTable;

    #[entry]
    fn main() -> ! {
        // `static mut` in the entry function: cortex-m-rt hands out `&'static mut`, in RAM, not on
        // the stack. 40 KB of depth and the 18 KB shading table.
        static mut DEPTH: [u16; super::WIDTH * super::HEIGHT] = [0; super::WIDTH * super::HEIGHT];
        static mut TABLE: ShadingTable<1> = ShadingTable::new();
        match super::draw(DEPTH, TABLE) {
            Ok((pixels, crc)) => {
                hprintln!("pixels {} crc {:#010x}", pixels, crc);
                exit(debug::EXIT_SUCCESS)
            }
            Err(e) => {
                hprintln!("error: {}", e);
                exit(debug::EXIT_FAILURE)
            }
        }
    }

    /// Ends the run (QEMU exits with the status); on a board without a debugger, sleeps.
    fn exit(status: debug::ExitStatus) -> ! {
        debug::exit(status);
        loop {
            cortex_m::asm::wfi();
        }
    }

    /// A fault ends the run with a failure instead of looping (cortex-m-rt's default), so that
    /// QEMU never hangs. cortex-m-rt declares the handler `unsafe`; nothing in it is.
    #[allow(unsafe_code)]
    #[exception]
    unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
        hprintln!("hardfault at {:#010x}", frame.pc());
        exit(debug::EXIT_FAILURE)
    }

    #[panic_handler]
    fn panic(info: &core::panic::PanicInfo) -> ! {
        hprintln!("panic: {}", info);
        exit(debug::EXIT_FAILURE)
    }
}

#[cfg(not(all(target_arch = "arm", target_os = "none")))]
fn main() {
    let mut depth = vec![0u16; WIDTH * HEIGHT];
    let mut table = Box::new(ShadingTable::<1>::new());
    match draw(&mut depth, &mut table) {
        Ok((pixels, crc)) => println!("pixels {pixels} crc {crc:#010x}"),
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    }
}
