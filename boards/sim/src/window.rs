//! The desktop window (minifb, `window` feature): the frame scaled ×2, the camera on the keyboard.

use anyhow::Result;
use minifb::{Key, Scale, Window, WindowOptions};
use pocketsplat_core::shade::{rgb565_to_rgb888, ShadingTable};
use pocketsplat_core::tg::TriGrid;

use crate::render::{render_tg_with, FrameBuffers, Settings, HEIGHT, WIDTH};

/// An open window.
pub struct Viewer {
    window: Window,
}

impl Viewer {
    /// Opens a 240×320 window scaled ×2.
    ///
    /// # Errors
    /// When there is no display (minifb cannot connect to X11).
    pub fn open(title: &str) -> Result<Self, minifb::Error> {
        let window = Window::new(
            title,
            WIDTH,
            HEIGHT,
            WindowOptions {
                scale: Scale::X2,
                ..WindowOptions::default()
            },
        )?;
        Ok(Self { window })
    }

    /// Shows `grid` until the window is closed or Escape is pressed. Arrows orbit, `+`/`-` zoom,
    /// `[`/`]` change the cutoff.
    ///
    /// # Errors
    /// When a frame cannot be set up.
    pub fn run(mut self, grid: &TriGrid<'_>, mut settings: Settings) -> Result<()> {
        self.window.set_target_fps(30);
        let mut frame = FrameBuffers::new();
        let mut table = Box::new(ShadingTable::<1>::new());
        let mut argb = vec![0u32; WIDTH * HEIGHT];
        while self.window.is_open() && !self.window.is_key_down(Key::Escape) {
            let v = &mut settings.view;
            if self.window.is_key_down(Key::Left) {
                v.az_deg -= 3.0;
            }
            if self.window.is_key_down(Key::Right) {
                v.az_deg += 3.0;
            }
            if self.window.is_key_down(Key::Up) {
                v.el_deg = (v.el_deg + 3.0).min(89.0);
            }
            if self.window.is_key_down(Key::Down) {
                v.el_deg = (v.el_deg - 3.0).max(-89.0);
            }
            if self.window.is_key_down(Key::Equal) || self.window.is_key_down(Key::NumPadPlus) {
                v.dist = (v.dist / 1.05).max(0.05);
            }
            if self.window.is_key_down(Key::Minus) || self.window.is_key_down(Key::NumPadMinus) {
                v.dist *= 1.05;
            }
            if self.window.is_key_down(Key::LeftBracket) {
                settings.cutoff_px = (settings.cutoff_px / 1.1).max(0.5);
            }
            if self.window.is_key_down(Key::RightBracket) {
                settings.cutoff_px = (settings.cutoff_px * 1.1).min(32.0);
            }
            render_tg_with(grid, &settings, &mut table, &mut frame, |_, _| {})?;
            for (out, &p) in argb.iter_mut().zip(frame.pixels()) {
                let [r, g, b] = rgb565_to_rgb888(p);
                *out = u32::from(r) << 16 | u32::from(g) << 8 | u32::from(b);
            }
            self.window.update_with_buffer(&argb, WIDTH, HEIGHT)?;
        }
        Ok(())
    }
}
