//! A display for tests and examples, as embedded-graphics' `MockDisplay` is for its drawables: it
//! keeps no pixels (no heap, any size), it counts what it is sent and checksums it, so that a test
//! on the host or a run under QEMU can say what a frame drew and compare two frames exactly.

use core::convert::Infallible;

use embedded_graphics_core::pixelcolor::raw::RawU16;
use embedded_graphics_core::pixelcolor::Rgb565;
use embedded_graphics_core::prelude::*;

use crate::crc::Crc32;

/// A `width` × `height` display that counts and checksums the pixels drawn into it.
///
/// ```
/// use pocketsplat_core::{render, DisplayTarget, Model, RenderOptions, ShadingTable, Target};
/// use pocketsplat_core::{TestPanel, View};
///
/// let mut panel = TestPanel::new(128, 160);
/// let mut depth = [0u16; 128 * 160];
/// let mut table = ShadingTable::<1>::new();
/// let model = Model::open(include_bytes!("../examples/data/trefoil.tg")).unwrap();
/// let camera = model.orbit(View::new(30.0, 20.0, 2.5));
/// let mut target = Target::new(DisplayTarget::new(&mut panel, &mut depth).unwrap(), &mut table);
/// render(&model, &camera, &RenderOptions::default(), &mut target).unwrap();
/// assert!(panel.lit() > 1000);
/// assert_eq!(panel.outside(), 0);
/// ```
#[derive(Clone)]
pub struct TestPanel {
    size: Size,
    sent: u32,
    lit: u32,
    outside: u32,
    crc: Crc32,
}

impl TestPanel {
    /// A panel of `width` × `height` pixels that has been sent nothing.
    pub fn new(width: u32, height: u32) -> Self {
        TestPanel {
            size: Size::new(width, height),
            sent: 0,
            lit: 0,
            outside: 0,
            crc: Crc32::new(),
        }
    }

    /// Pixels sent, every colour counted (a clear sends every pixel once).
    pub fn sent(&self) -> u32 {
        self.sent
    }

    /// Pixels sent that were not black.
    pub fn lit(&self) -> u32 {
        self.lit
    }

    /// Pixels sent outside the panel (a renderer's bug: always 0 from this crate).
    pub fn outside(&self) -> u32 {
        self.outside
    }

    /// The CRC-32 of everything sent, in order: each pixel's x, y and RGB565 value as 16-bit
    /// little-endian words (what an SPI driver would send: the window, then the colour).
    pub fn crc(&self) -> u32 {
        self.crc.clone().finish()
    }
}

impl core::fmt::Debug for TestPanel {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("TestPanel")
            .field("size", &self.size)
            .field("sent", &self.sent)
            .field("lit", &self.lit)
            .field("outside", &self.outside)
            .field("crc", &format_args!("{:#010x}", self.crc()))
            .finish()
    }
}

impl OriginDimensions for TestPanel {
    fn size(&self) -> Size {
        self.size
    }
}

impl DrawTarget for TestPanel {
    type Color = Rgb565;
    type Error = Infallible;

    fn draw_iter<I: IntoIterator<Item = Pixel<Rgb565>>>(
        &mut self,
        pixels: I,
    ) -> Result<(), Infallible> {
        for Pixel(at, color) in pixels {
            let inside = at.x >= 0
                && at.y >= 0
                && (at.x as u32) < self.size.width
                && (at.y as u32) < self.size.height;
            if !inside {
                self.outside += 1;
                continue;
            }
            self.sent += 1;
            let raw = RawU16::from(color).into_inner();
            if raw != 0 {
                self.lit += 1;
            }
            self.crc.update_u16_le(&[at.x as u16, at.y as u16, raw]);
        }
        Ok(())
    }
}
