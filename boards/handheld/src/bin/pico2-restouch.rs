//! pocketsplat on a Raspberry Pi Pico 2 (RP2350A, Cortex-M33 at 150 MHz, 520 KB SRAM, 4 MB flash)
//! plugged into a Waveshare Pico-ResTouch-LCD-2.8 (ST7789 240×320 IPS panel and a micro-SD slot on
//! SPI1), with six push buttons from GP2–GP7 to ground. Wiring and flashing: `../README.md`.
//!
//! This file only binds pins: the viewer is [`pocketsplat_handheld::run`], which streams `MODEL.TG`,
//! `MODEL.QS` or `SCENE.PAK` from the card for as long as it runs. The panel and the card share SPI1 through
//! `embedded-hal-bus`'s `RefCellDevice`, one chip select each; the touch controller's chip select is
//! held high so it stays off the bus. The card is initialised at 400 kHz, then the bus goes to
//! 25 MHz, the most an SD card takes in SPI mode (the panel, which would take 62.5, shares it).
#![no_std]
#![no_main]

use core::cell::RefCell;

use defmt_rtt as _;
use embedded_hal::digital::OutputPin;
use embedded_hal_bus::spi::RefCellDevice;
use embedded_sdmmc::SdCard;
use hal::clocks::Clock as _;
use hal::fugit::RateExtU32;
use hal::gpio::{FunctionSpi, PinState};
use panic_probe as _;
use pocketsplat_handheld::{halt, init_panel, run, Arena, Buttons, Clock, Panel};
use rp235x_hal as hal;

/// Tells the boot ROM this is a secure Arm executable.
// `link_section` counts as unsafe code: the boot ROM looks for this block in the first 4 KB of flash,
// where memory.x places `.start_block`.
#[allow(unsafe_code)]
#[link_section = ".start_block"]
#[used]
pub static IMAGE_DEF: hal::block::ImageDef = hal::block::ImageDef::secure_exe();

/// The Pico 2's crystal.
const XTAL_FREQ_HZ: u32 = 12_000_000;
/// The shared bus after the card's initialisation, Hz.
const SPI_HZ: u32 = 25_000_000;

/// The model linked into flash at build time (`model` feature), streamed when the card has none.
#[cfg(feature = "model")]
static FLASH_MODEL: &[u8] = include_bytes!(env!("POCKETSPLAT_PDA_MODEL_FILE"));
#[cfg(not(feature = "model"))]
static FLASH_MODEL: &[u8] = &[];

/// The RP2350's 1 MHz timer as the viewer's clock.
struct Timer(hal::Timer<hal::timer::CopyableTimer0>);

impl Clock for Timer {
    fn now_us(&mut self) -> u64 {
        self.0.get_counter().ticks()
    }
}

#[hal::entry]
fn main() -> ! {
    // cortex-m-rt turns these into `&'static mut` in .bss (RAM), not on the stack. The arena is
    // laid out for a model or a scene pack once the card says which (`pocketsplat_handheld::memory`).
    static mut ARENA: Arena<'static> = Arena::Free;
    static mut SPI_BUFFER: [u8; 4096] = [0; 4096];

    let mut pac = hal::pac::Peripherals::take().expect("peripherals taken once");
    let mut watchdog = hal::Watchdog::new(pac.WATCHDOG);
    let Ok(clocks) = hal::clocks::init_clocks_and_plls(
        XTAL_FREQ_HZ,
        pac.XOSC,
        pac.CLOCKS,
        pac.PLL_SYS,
        pac.PLL_USB,
        &mut pac.RESETS,
        &mut watchdog,
    ) else {
        panic!("clock setup failed");
    };
    let timer = hal::Timer::new_timer0(pac.TIMER0, &mut pac.RESETS, &clocks);
    let sio = hal::Sio::new(pac.SIO);
    let pins = hal::gpio::Pins::new(
        pac.IO_BANK0,
        pac.PADS_BANK0,
        sio.gpio_bank0,
        &mut pac.RESETS,
    );

    // SPI1: SCK GP10, MOSI GP11, MISO GP12.
    let sck = pins.gpio10.into_function::<FunctionSpi>();
    let mosi = pins.gpio11.into_function::<FunctionSpi>();
    let miso = pins.gpio12.into_function::<FunctionSpi>();
    let spi = hal::spi::Spi::<_, _, _, 8>::new(pac.SPI1, (mosi, miso, sck)).init(
        &mut pac.RESETS,
        clocks.peripheral_clock.freq(),
        400.kHz(),
        embedded_hal::spi::MODE_0,
    );
    let bus = RefCell::new(spi);
    // Chip selects high before anything talks: panel GP9, SD card GP22, touch controller GP16.
    let lcd_cs = pins.gpio9.into_push_pull_output_in_state(PinState::High);
    let sd_cs = pins.gpio22.into_push_pull_output_in_state(PinState::High);
    let mut touch_cs = pins.gpio16.into_push_pull_output_in_state(PinState::High);
    let _ = touch_cs.set_high();

    // The card initialises (at 400 kHz) on its first use; then the bus speeds up.
    let card = SdCard::new(
        RefCellDevice::new(&bus, sd_cs, timer).expect("chip select"),
        timer,
    );
    match card.num_bytes() {
        Ok(n) => defmt::info!("SD card: {} bytes", n),
        Err(e) => defmt::warn!("SD card: {}", e),
    }
    let baud = bus
        .borrow_mut()
        .set_baudrate(clocks.peripheral_clock.freq(), SPI_HZ.Hz());
    defmt::info!("SPI1 at {} Hz", baud.to_Hz());

    let mut delay = timer;
    let panel = Panel {
        spi: RefCellDevice::new(&bus, lcd_cs, timer).expect("chip select"),
        dc: pins.gpio8.into_push_pull_output(),
        reset: pins.gpio15.into_push_pull_output_in_state(PinState::High),
        backlight: pins.gpio13.into_push_pull_output(),
    };
    let Ok(display) = init_panel(panel, &mut delay, SPI_BUFFER) else {
        halt("panel initialisation failed", &mut delay);
    };
    let buttons = Buttons {
        pins: [
            pins.gpio2.into_pull_up_input().into_dyn_pin(),
            pins.gpio3.into_pull_up_input().into_dyn_pin(),
            pins.gpio4.into_pull_up_input().into_dyn_pin(),
            pins.gpio5.into_pull_up_input().into_dyn_pin(),
            pins.gpio6.into_pull_up_input().into_dyn_pin(),
            pins.gpio7.into_pull_up_input().into_dyn_pin(),
        ],
    };
    run(
        card,
        display,
        buttons,
        delay,
        Timer(timer),
        ARENA,
        FLASH_MODEL,
    )
}

/// Program metadata for `picotool info`.
// `link_section`: picotool finds the entries through the table memory.x's `.bi_entries` bounds.
#[allow(unsafe_code)]
#[link_section = ".bi_entries"]
#[used]
pub static PICOTOOL_ENTRIES: [hal::binary_info::EntryAddr; 3] = [
    hal::binary_info::rp_cargo_bin_name!(),
    hal::binary_info::rp_cargo_version!(),
    hal::binary_info::rp_program_description!(c"pocketsplat viewer (Pico-ResTouch-LCD-2.8)"),
];
