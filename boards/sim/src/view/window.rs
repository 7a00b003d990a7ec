//! The desktop window (minifb, `window` feature): a model ([`Shown`]) in a 240×320 window scaled ×2,
//! driven by the mouse and keys. The bindings are listed in [`KEYS_HELP`]; the state they drive,
//! the refinement and the HUD are its sibling modules in [`crate::view`], which need no display.

use std::time::Instant;

use anyhow::Result;
use minifb::{Key, KeyRepeat, MouseButton, MouseMode, Scale, Window, WindowOptions};
use pocketsplat_core::shade::rgb565_to_rgb888;
use pocketsplat_core::tg::TriGrid;

use super::hud::{draw_hud, HudInfo};
use super::options::ViewOptions;
#[cfg(doc)]
use super::options::KEYS_HELP;
use super::scene::Shown;
use super::state::{Action, Change, ViewState};
use crate::image::write_image_png;
use crate::render::{FrameBuffers, FrameReport, Settings};
use pocketsplat_core::camera::Viewport;

/// Orbit speed of the arrow keys, degrees per second.
const ORBIT_KEY_DEG_PER_S: f64 = 90.0;
/// Orbit per pixel of a left-drag, degrees.
const ORBIT_DRAG_DEG_PER_PX: f64 = 0.5;
/// Pan speed of W A S D, framebuffer pixels per second.
const PAN_KEY_PX_PER_S: f64 = 120.0;
/// Zoom of `+`/`-` held for one second.
const ZOOM_KEY_PER_S: f64 = 2.0;
/// Zoom per wheel notch.
const ZOOM_PER_NOTCH: f64 = 1.15;
/// Light speed of I J K L, degrees per second.
const LIGHT_KEY_DEG_PER_S: f64 = 90.0;
/// Window updates per second at most: input is polled this often, and the loop sleeps when idle.
const UPDATE_HZ: usize = 60;

/// An open window.
pub struct Viewer {
    window: Window,
    argb: Vec<u32>,
    /// Mouse position at the last poll, framebuffer pixels.
    mouse: Option<(f32, f32)>,
    /// The frame's size (`--size`), which the window shows scaled.
    size: Viewport,
}

impl Viewer {
    /// Opens a 240×320 window scaled ×2.
    ///
    /// # Errors
    /// When there is no display (minifb cannot connect to X11).
    pub fn open(title: &str) -> Result<Self, minifb::Error> {
        Self::open_scaled(title, 2, Viewport::DEFAULT)
    }

    /// Opens a 240×320 window scaled by `scale` (1, 2 or 4; anything else is taken as 2).
    ///
    /// # Errors
    /// When there is no display (minifb cannot connect to X11).
    pub fn open_scaled(title: &str, scale: usize, size: Viewport) -> Result<Self, minifb::Error> {
        let scale = match scale {
            1 => Scale::X1,
            4 => Scale::X4,
            _ => Scale::X2,
        };
        let (width, height) = (usize::from(size.width), usize::from(size.height));
        let mut window = Window::new(
            title,
            width,
            height,
            WindowOptions {
                scale,
                ..WindowOptions::default()
            },
        )?;
        window.set_target_fps(UPDATE_HZ);
        Ok(Self {
            window,
            argb: vec![0; width * height],
            size,
            mouse: None,
        })
    }

    /// Shows `grid` with the viewer's defaults and `settings` (its cutoff is the moving cutoff)
    /// until the window is closed or Escape is pressed.
    ///
    /// # Errors
    /// When a frame cannot be set up.
    pub fn run(self, grid: &TriGrid<'_>, settings: Settings) -> Result<()> {
        let opts = ViewOptions {
            settings,
            ..ViewOptions::default()
        };
        self.run_scene(
            &mut Shown::new(pocketsplat_core::Model::TriGrid(*grid)),
            &opts,
        )
    }

    /// Shows `scene` (in frames of the window's size, whatever `opts.settings.size` says) until
    /// the window is closed, Escape is pressed, or `opts.frames` window
    /// updates have passed. Frames are drawn only when something changed or the image is still
    /// being refined; otherwise the loop only polls input, `UPDATE_HZ` times a second.
    ///
    /// # Errors
    /// When a frame cannot be set up, or `opts.screenshot` cannot be written.
    pub fn run_scene(mut self, scene: &mut Shown<'_>, opts: &ViewOptions) -> Result<()> {
        let label = scene.label();
        let mut state = ViewState::new(opts);
        let mut frame = FrameBuffers::sized(self.size);
        let mut updates = 0u64;
        let mut first = true;
        let mut last_poll = Instant::now();
        let mut last_frame: Option<Instant> = None;
        let mut fps = 0.0f32;
        // The settled image has been written to `opts.screenshot`.
        let mut saved = false;
        while self.window.is_open() && !self.window.is_key_down(Key::Escape) {
            if opts.frames.is_some_and(|n| updates >= n) {
                break;
            }
            updates += 1;
            let now = Instant::now();
            let dt = now.duration_since(last_poll).as_secs_f64().min(0.1);
            last_poll = now;

            let mut change = if first { Change::Moved } else { Change::None };
            first = false;
            for action in self.actions(dt) {
                change = change.max(state.apply(action));
            }
            let cutoff = match state.refiner.next_cutoff(change == Change::Moved) {
                Some(c) => Some(c),
                // Only the HUD changed: the same cutoff again.
                None if change == Change::Overlay => Some(state.refiner.cutoff()),
                None => None,
            };
            let Some(cutoff) = cutoff else {
                if !saved {
                    if let Some(path) = &opts.screenshot {
                        write_image_png(path, &frame.image)?;
                    }
                    saved = true;
                }
                // The next frame's rate is measured from when it starts, not across the pause.
                last_frame = None;
                self.window.update();
                continue;
            };

            if let Some(t) = last_frame {
                let inst = 1.0 / now.duration_since(t).as_secs_f32().max(1e-6);
                fps = if fps == 0.0 {
                    inst
                } else {
                    0.8 * fps + 0.2 * inst
                };
            }
            last_frame = Some(now);
            let settings = state.frame_settings(cutoff);
            let report: FrameReport =
                scene.render(&settings, state.pan, &mut frame, &mut |fb, report| {
                    let info = HudInfo {
                        fps,
                        report: *report,
                        cutoff_px: cutoff,
                        state: &state,
                        label: &label,
                    };
                    if let Err(never) = draw_hud(fb, &info) {
                        match never {}
                    }
                })?;
            state
                .refiner
                .frame_time(u32::try_from(report.time.as_micros()).unwrap_or(u32::MAX));
            self.present(&frame)?;
            saved = false;
        }
        if let Some(path) = &opts.screenshot {
            write_image_png(path, &frame.image)?;
        }
        Ok(())
    }

    /// Shows a frame.
    fn present(&mut self, frame: &FrameBuffers) -> Result<()> {
        for (out, &p) in self.argb.iter_mut().zip(frame.pixels()) {
            let [r, g, b] = rgb565_to_rgb888(p);
            *out = u32::from(r) << 16 | u32::from(g) << 8 | u32::from(b);
        }
        let (w, h) = (usize::from(self.size.width), usize::from(self.size.height));
        self.window.update_with_buffer(&self.argb, w, h)?;
        Ok(())
    }

    /// The user's actions since the last poll; held keys act in proportion to `dt` seconds.
    fn actions(&mut self, dt: f64) -> Vec<Action> {
        let w = &self.window;
        let down = |k: Key| w.is_key_down(k);
        let axis = |neg: Key, pos: Key| f64::from(i8::from(down(pos)) - i8::from(down(neg)));
        let pressed = |k: Key| w.is_key_pressed(k, KeyRepeat::No);
        let repeated = |k: Key| w.is_key_pressed(k, KeyRepeat::Yes);
        let mut out = Vec::new();

        // Keys. Arrows move the camera: left/right in azimuth, up/down in elevation.
        let (ax, ay) = (axis(Key::Left, Key::Right), axis(Key::Down, Key::Up));
        if ax != 0.0 || ay != 0.0 {
            let d = ORBIT_KEY_DEG_PER_S * dt;
            out.push(Action::Orbit {
                az_deg: ax * d,
                el_deg: ay * d,
            });
        }
        // W A S D move the camera too, so the model moves the other way on screen.
        let (px, py) = (axis(Key::A, Key::D), axis(Key::S, Key::W));
        if px != 0.0 || py != 0.0 {
            let d = PAN_KEY_PX_PER_S * dt;
            out.push(Action::Pan {
                dx_px: -px * d,
                dy_px: py * d,
            });
        }
        let zoom = f64::from(
            i8::from(down(Key::Equal) || down(Key::NumPadPlus))
                - i8::from(down(Key::Minus) || down(Key::NumPadMinus)),
        );
        if zoom != 0.0 {
            out.push(Action::Zoom(ZOOM_KEY_PER_S.powf(zoom * dt)));
        }
        let (lx, ly) = (axis(Key::J, Key::L), axis(Key::K, Key::I));
        if lx != 0.0 || ly != 0.0 {
            let d = LIGHT_KEY_DEG_PER_S * dt;
            out.push(Action::Light {
                az_deg: lx * d,
                el_deg: ly * d,
            });
        }
        for (key, action) in [
            (Key::LeftBracket, Action::CutoffFiner),
            (Key::RightBracket, Action::CutoffCoarser),
        ] {
            if repeated(key) {
                out.push(action);
            }
        }
        for (key, action) in [
            (Key::C, Action::ToggleKernel),
            (Key::O, Action::CycleShadows),
            (Key::P, Action::ToggleRefine),
            (Key::H, Action::CycleHud),
            (Key::V, Action::ToggleLevels),
            (Key::R, Action::Reset),
        ] {
            if pressed(key) {
                out.push(action);
            }
        }

        // Mouse: left-drag orbits (the model follows the pointer), right-, middle- or
        // shift-left-drag pans, the wheel zooms.
        let pos = w.get_mouse_pos(MouseMode::Pass);
        let shift = down(Key::LeftShift) || down(Key::RightShift);
        let left = w.get_mouse_down(MouseButton::Left);
        let pan_drag =
            w.get_mouse_down(MouseButton::Right) || w.get_mouse_down(MouseButton::Middle);
        if let (Some((x0, y0)), Some((x, y))) = (self.mouse, pos) {
            let (dx, dy) = (f64::from(x - x0), f64::from(y - y0));
            if dx != 0.0 || dy != 0.0 {
                if pan_drag || (left && shift) {
                    out.push(Action::Pan {
                        dx_px: dx,
                        dy_px: dy,
                    });
                } else if left {
                    out.push(Action::Orbit {
                        az_deg: -dx * ORBIT_DRAG_DEG_PER_PX,
                        el_deg: dy * ORBIT_DRAG_DEG_PER_PX,
                    });
                }
            }
        }
        if let Some((_, notches)) = w.get_scroll_wheel() {
            if notches != 0.0 {
                out.push(Action::Zoom(ZOOM_PER_NOTCH.powf(f64::from(notches))));
            }
        }
        self.mouse = pos;
        out
    }
}
