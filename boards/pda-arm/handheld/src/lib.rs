//! # pocketsplat-handheld
//!
//! pocketsplat on a real handheld: a 240×320 RGB565 SPI panel (ST7789, through mipidsi), an SD card
//! on the same SPI bus (through embedded-sdmmc), six buttons that move an orbit camera, and defmt
//! logging. Everything here is generic over embedded-hal 1.0 (`SpiDevice`, `OutputPin`, `InputPin`,
//! `DelayNs`), so a board is a pin binding: `src/bin/pico2-restouch.rs` binds it to a Raspberry Pi
//! Pico 2 with a Waveshare Pico-ResTouch-LCD-2.8 (wiring in `../README.md`).
//!
//! The frame is the QEMU firmware's ([`pocketsplat_pda::render_view`]: same camera, shading and
//! traversal), drawn into statics and sent to the panel in one window write. While a button is held
//! the cutoff follows a [`FrameRateController`]; when nothing moves it refines step by step down to
//! 1 px (QSplat §4.2), then the loop idles until a button is pressed.
//!
//! The model comes from `MODEL.TG` in the SD card's root, read into a RAM arena when it fits
//! ([`load_model`]), or else from flash (a model linked in at build time); with neither, the screen
//! says what to do.
#![no_std]
#![deny(clippy::float_arithmetic)]

use core::fmt::Write as _;

use embedded_graphics::mono_font::{ascii::FONT_6X10, MonoTextStyle};
use embedded_graphics::pixelcolor::{raw::RawU16, Rgb565};
use embedded_graphics::prelude::*;
use embedded_graphics::text::Text;
use embedded_hal::delay::DelayNs;
use embedded_hal::digital::{InputPin, OutputPin};
use embedded_hal::spi::SpiDevice;
use embedded_sdmmc::{Mode, SdCard, TimeSource, Timestamp, VolumeIdx, VolumeManager};
use mipidsi::interface::SpiInterface;
use mipidsi::models::ST7789;
use mipidsi::options::ColorInversion;
use pocketsplat_core::camera::{View, HEIGHT, STANDARD_VIEWS, WIDTH};
use pocketsplat_core::lod::FrameRateController;
use pocketsplat_core::raster::Framebuffer;
use pocketsplat_core::shade::ShadingTable;
use pocketsplat_core::tg::{TriGrid, Verify};
use pocketsplat_pda::{render_view, Model, Shadows, Targets};

/// Name of the model file in the SD card's root directory (8.3).
pub const MODEL_FILE: &str = "MODEL.TG";
/// Frame time the controller aims at while the camera moves, microseconds (5 fps).
pub const TARGET_FRAME_US: u32 = 200_000;
/// Cutoff of the first frame, pixels.
pub const FIRST_CUTOFF_PX: f32 = 4.0;

/// The camera buttons, in the order [`Buttons::pins`] holds them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum Button {
    /// Orbit left (azimuth −).
    Left,
    /// Orbit right (azimuth +).
    Right,
    /// Orbit up (elevation +).
    Up,
    /// Orbit down (elevation −).
    Down,
    /// Move closer.
    ZoomIn,
    /// Move away.
    ZoomOut,
}

impl Button {
    /// Every button, in pin order.
    pub const ALL: [Button; 6] = [
        Button::Left,
        Button::Right,
        Button::Up,
        Button::Down,
        Button::ZoomIn,
        Button::ZoomOut,
    ];
}

/// Six active-low buttons (to ground, with pull-ups), in [`Button::ALL`] order.
pub struct Buttons<P> {
    /// The input pins.
    pub pins: [P; 6],
}

impl<P: InputPin> Buttons<P> {
    /// Which buttons are held now. A pin that cannot be read counts as released.
    pub fn held(&mut self) -> [bool; 6] {
        let mut held = [false; 6];
        for (h, pin) in held.iter_mut().zip(&mut self.pins) {
            *h = pin.is_low().unwrap_or(false);
        }
        held
    }
}

/// An orbit camera driven by the buttons (per-frame setup: floats allowed).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Orbit {
    /// The current view.
    pub view: View,
}

impl Default for Orbit {
    fn default() -> Self {
        Orbit {
            view: STANDARD_VIEWS[0].1,
        }
    }
}

impl Orbit {
    /// Degrees per frame a held orbit button turns.
    pub const STEP_DEG: f64 = 8.0;
    /// Distance factor per frame a held zoom button applies.
    pub const ZOOM: f64 = 1.12;

    /// Applies the held buttons; returns whether the view changed.
    #[allow(clippy::float_arithmetic)]
    pub fn step(&mut self, held: [bool; 6]) -> bool {
        let before = self.view;
        let v = &mut self.view;
        for (button, _) in Button::ALL.iter().zip(held).filter(|(_, h)| *h) {
            match button {
                Button::Left => v.az_deg -= Self::STEP_DEG,
                Button::Right => v.az_deg += Self::STEP_DEG,
                Button::Up => v.el_deg = (v.el_deg + Self::STEP_DEG).min(85.0),
                Button::Down => v.el_deg = (v.el_deg - Self::STEP_DEG).max(-85.0),
                Button::ZoomIn => v.dist = (v.dist / Self::ZOOM).max(0.6),
                Button::ZoomOut => v.dist = (v.dist * Self::ZOOM).min(40.0),
            }
        }
        if v.az_deg > 180.0 {
            v.az_deg -= 360.0;
        } else if v.az_deg < -180.0 {
            v.az_deg += 360.0;
        }
        self.view != before
    }
}

/// A fixed timestamp for the FAT layer: the app only reads files.
pub struct NoClock;

impl TimeSource for NoClock {
    fn get_timestamp(&self) -> Timestamp {
        Timestamp {
            year_since_1970: 56,
            zero_indexed_month: 0,
            zero_indexed_day: 0,
            hours: 0,
            minutes: 0,
            seconds: 0,
        }
    }
}

/// Why no model could be read from the SD card.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum LoadError {
    /// No card, no FAT volume, no `MODEL.TG`, or a read failed.
    Card,
    /// `MODEL.TG` is larger than the arena (its size, bytes).
    TooLarge(u32),
    /// The file is not a valid tri-grid.
    Invalid,
}

/// Reads [`MODEL_FILE`] from the first FAT volume of the SD card on `spi` into `arena` and checks
/// it (`Verify::Full`: header, structure and every block's CRC). Call it with the bus at ≤ 400 kHz
/// (card initialisation); the bus may be sped up afterwards.
///
/// # Errors
/// [`LoadError`]: no card or file, a file larger than `arena`, a file that is not a tri-grid.
pub fn load_model<S: SpiDevice, D: DelayNs>(
    spi: S,
    delay: D,
    arena: &mut [u8],
) -> Result<&[u8], LoadError> {
    let card = SdCard::new(spi, delay);
    let len = {
        let volumes = VolumeManager::new(card, NoClock);
        let volume = volumes.open_volume(VolumeIdx(0)).map_err(|e| {
            defmt::warn!("SD card: {}", e);
            LoadError::Card
        })?;
        let root = volume.open_root_dir().map_err(|_| LoadError::Card)?;
        let file = root
            .open_file_in_dir(MODEL_FILE, Mode::ReadOnly)
            .map_err(|_| LoadError::Card)?;
        let len = file.length();
        let dest = arena
            .get_mut(..len as usize)
            .ok_or(LoadError::TooLarge(len))?;
        let mut done = 0;
        while done < dest.len() {
            match file.read(&mut dest[done..]) {
                Ok(0) | Err(_) => return Err(LoadError::Card),
                Ok(n) => done += n,
            }
        }
        len as usize
    };
    let bytes = &arena[..len];
    TriGrid::open(bytes, Verify::Full).map_err(|e| {
        defmt::warn!("{}: {}", MODEL_FILE, defmt::Display2Format(&e));
        LoadError::Invalid
    })?;
    Ok(bytes)
}

/// The frame's buffers (statics on the board).
pub struct Buffers<'a> {
    /// RGB565 rows.
    pub color: &'a mut [[u16; WIDTH]; HEIGHT],
    /// Depth rows.
    pub depth: &'a mut [[u16; WIDTH]; HEIGHT],
    /// The shading table.
    pub table: &'a mut ShadingTable<1>,
}

/// The panel and its pins.
pub struct Panel<S, DC, RST, BL> {
    /// The panel's SPI device (its chip select).
    pub spi: S,
    /// Data/command select.
    pub dc: DC,
    /// Reset, active low.
    pub reset: RST,
    /// Backlight enable.
    pub backlight: BL,
}

/// A monotonic clock in microseconds (the board's timer).
pub trait Clock {
    /// Microseconds since some fixed point.
    fn now_us(&mut self) -> u64;
}

/// Runs the viewer forever: initialises the panel, then draws `model` (or, when it is `None`, a
/// screen saying how to provide one), moving the camera with `buttons`.
///
/// `spi_buffer` batches pixels for the panel (a few KB: larger is faster).
pub fn run<S, DC, RST, BL, P, D, C>(
    panel: Panel<S, DC, RST, BL>,
    mut buttons: Buttons<P>,
    mut delay: D,
    mut clock: C,
    spi_buffer: &mut [u8],
    buffers: Buffers<'_>,
    model: Result<&[u8], LoadError>,
) -> !
where
    S: SpiDevice,
    DC: OutputPin,
    RST: OutputPin,
    BL: OutputPin,
    P: InputPin,
    D: DelayNs,
    C: Clock,
{
    let Panel {
        spi,
        dc,
        reset,
        mut backlight,
    } = panel;
    let interface = SpiInterface::new(spi, dc, spi_buffer);
    // The 2.8" IPS panel shows true colours with inversion on.
    let mut display = match mipidsi::Builder::new(ST7789, interface)
        .display_size(WIDTH as u16, HEIGHT as u16)
        .invert_colors(ColorInversion::Inverted)
        .reset_pin(reset)
        .init(&mut delay)
    {
        Ok(d) => d,
        Err(_) => halt("panel initialisation failed", &mut delay),
    };
    let _ = backlight.set_high();

    let Buffers {
        color,
        depth,
        table,
    } = buffers;
    let model_bytes = model.map_or(0, <[u8]>::len);
    let grid = match model.map(|bytes| TriGrid::open(bytes, Verify::Structure)) {
        Ok(Ok(grid)) => grid,
        failed => {
            let mut fb = Framebuffer::new(color, depth);
            fb.clear(0);
            let mut text = heapless_line();
            let _ = match failed {
                Err(LoadError::TooLarge(n)) => write!(
                    text,
                    "{MODEL_FILE}: {n} bytes,\ntoo large for RAM.\nBake with --depth 4."
                ),
                Err(LoadError::Invalid) | Ok(Err(_)) => {
                    write!(text, "{MODEL_FILE} is not a\nvalid tri-grid.")
                }
                Err(LoadError::Card) | Ok(Ok(_)) => write!(
                    text,
                    "No {MODEL_FILE} on the SD card\nand no model in flash.\nSee README."
                ),
            };
            draw_text(&mut fb, &text, Point::new(8, 20));
            let _ = blit(&mut display, fb.rows());
            halt("no model", &mut delay);
        }
    };
    let h = grid.header();
    defmt::info!(
        "model: {} bytes, rho {}, depth {}, {} samples",
        model_bytes,
        h.rho,
        h.depth,
        grid.total_samples()
    );

    let model = Model::from(grid);

    let mut orbit = Orbit::default();
    let mut lod = FrameRateController::new(TARGET_FRAME_US, FIRST_CUTOFF_PX);
    let mut cutoff = Some(lod.cutoff());
    let mut targets = Targets {
        color,
        depth,
        table,
    };
    loop {
        let held = buttons.held();
        let moved = orbit.step(held);
        if moved {
            cutoff = Some(lod.cutoff());
        }
        let Some(cutoff_px) = cutoff else {
            // Full detail is on screen and nothing moves: poll the buttons at 50 Hz.
            delay.delay_ms(20);
            continue;
        };
        let t0 = clock.now_us();
        let drawn = match render_view(
            &model,
            orbit.view,
            cutoff_px,
            Shadows::Off,
            &mut targets,
            |_| {},
        ) {
            Ok(d) => d,
            Err(e) => {
                defmt::error!("frame: {}", defmt::Display2Format(&e));
                cutoff = None;
                continue;
            }
        };
        let t1 = clock.now_us();
        let render_us = u32::try_from(t1 - t0).unwrap_or(u32::MAX);
        let mut fb = Framebuffer::new(targets.color, targets.depth);
        let mut hud = heapless_line();
        let _ = write!(
            hud,
            "{} splats  cutoff {} px  {} ms",
            drawn.stats.splats,
            cutoff_px as u32,
            render_us / 1000
        );
        draw_text(&mut fb, &hud, Point::new(2, HEIGHT as i32 - 4));
        let _ = blit(&mut display, fb.rows());
        let blit_us = u32::try_from(clock.now_us() - t1).unwrap_or(u32::MAX);
        defmt::info!(
            "frame: cutoff {} px, {} splats, {} nodes, render {} us, blit {} us",
            cutoff_px,
            drawn.stats.splats,
            drawn.stats.nodes_visited,
            render_us,
            blit_us
        );
        cutoff = if moved || held.contains(&true) {
            Some(lod.update(render_us))
        } else {
            lod.refine_idle()
        };
    }
}

/// Sends the frame to the panel in one window write.
fn blit<DI, M, RST>(
    display: &mut mipidsi::Display<DI, M, RST>,
    rows: &[[u16; WIDTH]; HEIGHT],
) -> Result<(), DI::Error>
where
    DI: mipidsi::interface::Interface,
    M: mipidsi::models::Model<ColorFormat = Rgb565>,
    Rgb565: mipidsi::interface::InterfacePixelFormat<DI::Word>,
    RST: OutputPin,
{
    let pixels = rows.iter().flatten().map(|&p| Rgb565::from(RawU16::new(p)));
    display.set_pixels(0, 0, WIDTH as u16 - 1, HEIGHT as u16 - 1, pixels)
}

/// A short text buffer (no heap).
fn heapless_line() -> Line {
    Line {
        buf: [0; 96],
        len: 0,
    }
}

/// Up to 96 bytes of text; longer writes are cut.
struct Line {
    buf: [u8; 96],
    len: usize,
}

impl Line {
    fn as_str(&self) -> &str {
        core::str::from_utf8(&self.buf[..self.len]).unwrap_or("")
    }
}

impl core::fmt::Write for Line {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        let n = s.len().min(self.buf.len() - self.len);
        let n = (0..=n).rev().find(|&k| s.is_char_boundary(k)).unwrap_or(0);
        self.buf[self.len..self.len + n].copy_from_slice(&s.as_bytes()[..n]);
        self.len += n;
        Ok(())
    }
}

fn draw_text(fb: &mut Framebuffer<'_>, text: &Line, at: Point) {
    let style = MonoTextStyle::new(&FONT_6X10, Rgb565::WHITE);
    let _ = Text::new(text.as_str(), at, style).draw(fb);
}

/// Logs `why` and idles (the panel keeps its last image).
fn halt(why: &str, delay: &mut impl DelayNs) -> ! {
    defmt::error!("halted: {}", why);
    loop {
        delay.delay_ms(1000);
    }
}
