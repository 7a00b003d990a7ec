//! # pocketsplat-qemu
//!
//! The board-independent half of the Cortex-M firmware: what it draws and how a frame is checksummed.
//! It is `no_std` and builds for the host too, so the host tests compute the CRCs the firmware must
//! print under QEMU by calling the very same functions (docs/ARCHITECTURE.md: the ARM build and the host build
//! render the same frames to the same CRC).
//!
//! - [`views`]: the four standard views of a resident [`Model`] (a tri-grid or, with the `qsplat`
//!   feature, a QSplat file, told apart by its magic) at several cutoffs (and, for a tri-grid with
//!   the `shadows` feature, with one-pass and two-pass shadows), the frames the firmware renders when
//!   a baked model is linked in, and the line it prints per frame.
//! - [`stream`] (`stream` feature): the bunny streamed from a FAT image through a 64 KB block cache,
//!   the frames drawn by the same code as a resident model's ([`render_stream_view`]).
//! - `scene` (feature `scene`): the named views of a resident scene pack (`.pack`, told apart by
//!   its magic) with the pack's light and shadows at each cutoff of `scene::SCENE_CUTOFFS_PX`
//!   (1, 2, 3, 4, 6 and 8 px), as the simulator draws them.
//! - [`render_test_frame`]: a test pattern (an integer-shaded sphere over a gradient-and-xor
//!   background), drawn when the firmware is built without a model.
//!
//! ```
//! use pocketsplat_qemu::{frame_crc, render_test_frame, PIXELS};
//! let mut fb = [0u16; PIXELS];
//! render_test_frame(0, &mut fb);
//! // Deterministic: the same frame always gives the same CRC.
//! let again = { let mut b = [0u16; PIXELS]; render_test_frame(0, &mut b); frame_crc(&b) };
//! assert_eq!(frame_crc(&fb), again);
//! ```
#![cfg_attr(not(test), no_std)]
// Per-pixel work is integer only, as on the FPU-less device (docs/ARCHITECTURE.md, Numbers).
#![deny(clippy::float_arithmetic)]

#[cfg(feature = "stream")]
pub mod hostile;
#[cfg(all(feature = "stream", feature = "scene"))]
pub mod pack_stream;
#[cfg(feature = "scene")]
pub mod scene;
#[cfg(feature = "stream")]
pub mod stream;
pub mod views;

#[cfg(feature = "stream")]
pub use pocketsplat_core::render::StreamPass;
#[cfg(all(feature = "stream", feature = "qsplat"))]
pub use views::render_qs_stream_pass;
pub use views::{
    frame_specs, frame_specs_for, model_frame_specs, render_standard_view, render_view, Drawn,
    FrameLine, FrameReport, FrameSpec, Model, ModelError, Phase, RenderError, Shadows, Targets,
    CUTOFFS_PX, SHADOW_MAP_SIZE, SHADOW_MODES,
};
#[cfg(feature = "stream")]
pub use views::{
    render_model_stream, render_stream_pass, render_stream_view, ModelStream, StreamTargets,
};

use pocketsplat_core::crc::Crc32;

// The panel's size, a build-time choice (build.rs: `POCKETSPLAT_PDA_PANEL=WxH`, 240x320 by
// default): `WIDTH` and `HEIGHT`, pixels.
include!(concat!(env!("OUT_DIR"), "/panel.rs"));
/// The panel as the core's viewport.
pub const PANEL: pocketsplat_core::camera::Viewport = pocketsplat_core::camera::Viewport {
    width: WIDTH as u16,
    height: HEIGHT as u16,
};
/// Pixels in a frame.
pub const PIXELS: usize = WIDTH * HEIGHT;
/// Size of one RGB565 framebuffer, bytes.
pub const FRAMEBUFFER_BYTES: usize = PIXELS * core::mem::size_of::<u16>();

/// The line the firmware prints for each frame it renders, `frame N crc 0xXXXXXXXX` (the host twin of
/// the binary prints the same; tests read it).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameCrc {
    /// Frame number.
    pub frame: u32,
    /// [`frame_crc`] of the frame.
    pub crc: u32,
}

impl core::fmt::Display for FrameCrc {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "frame {} crc {:#010x}", self.frame, self.crc)
    }
}

/// Packs 8-bit channels into RGB565 (the core's one packer for them).
pub use pocketsplat_core::shade::rgb888_to_rgb565 as rgb565;

/// Floor of the square root of `n` (digit by digit, no division, no float).
pub const fn isqrt(n: u32) -> u32 {
    let mut rem = n;
    let mut root = 0u32;
    let mut bit = 1u32 << 30;
    while bit > n {
        bit >>= 2;
    }
    while bit != 0 {
        if rem >= root + bit {
            rem -= root + bit;
            root = (root >> 1) + bit;
        } else {
            root >>= 1;
        }
        bit >>= 2;
    }
    root
}

/// Sphere centre and radius, pixels.
const SPHERE_X: i32 = 120;
const SPHERE_Y: i32 = 150;
const SPHERE_R: i32 = 100;

/// Light directions (x, y), Q8 unit vectors with z = 181 (so |L| ≈ 256): eight steps of 45° around the
/// view axis. Frame 0 takes index 5, light from the upper left.
const LIGHTS: [(i32, i32); 8] = [
    (181, 0),
    (128, 128),
    (0, 181),
    (-128, 128),
    (-181, 0),
    (-128, -128),
    (0, -181),
    (128, -128),
];
const LIGHT_Z: i32 = 181;

/// Base colours of the sphere's latitude bands (a stand-in for materials).
const LATITUDES: [(i32, i32, i32); 6] = [
    (230, 80, 60),
    (240, 180, 60),
    (90, 200, 90),
    (60, 160, 230),
    (150, 90, 220),
    (220, 220, 220),
];

/// Draws frame `frame` of the test pattern into `fb` (row-major, `WIDTH` × `HEIGHT`).
///
/// Every pixel is written. The light turns by 45° per frame and the background pattern scrolls, so
/// consecutive frames differ.
pub fn render_test_frame(frame: u32, fb: &mut [u16; PIXELS]) {
    let (lx, ly) = LIGHTS[(frame as usize % LIGHTS.len() + 5) % LIGHTS.len()];
    // The xor texture repeats every 64 pixels, so scrolling modulo 64 is the same and cannot overflow.
    let scroll = (frame % 64) as usize;
    for (y, row) in fb.chunks_exact_mut(WIDTH).enumerate() {
        for (x, px) in row.iter_mut().enumerate() {
            *px = sphere_pixel(x as i32, y as i32, lx, ly)
                .unwrap_or_else(|| background_pixel(x, y, scroll));
        }
    }
}

/// The sphere's colour at (x, y), or `None` outside it.
fn sphere_pixel(x: i32, y: i32, lx: i32, ly: i32) -> Option<u16> {
    let (dx, dy) = (x - SPHERE_X, y - SPHERE_Y);
    let r2 = dx * dx + dy * dy;
    if r2 > SPHERE_R * SPHERE_R {
        return None;
    }
    let dz = isqrt((SPHERE_R * SPHERE_R - r2) as u32) as i32;
    // N·L with N = (dx, dy, dz) / R: Q8, in [-256, 256].
    let diffuse = ((dx * lx + dy * ly + dz * LIGHT_Z) / SPHERE_R).max(0);
    // Ambient 40 plus diffuse, Q8 intensity in [40, 256].
    let intensity = 40 + diffuse * (256 - 40) / 256;
    // A tight highlight: diffuse^16 in Q8, by squaring four times.
    let mut spec = diffuse;
    for _ in 0..4 {
        spec = spec * spec / 256;
    }
    let band = ((dy + SPHERE_R) * LATITUDES.len() as i32 / (2 * SPHERE_R + 1)) as usize;
    let (r, g, b) = LATITUDES[band];
    let shade = |c: i32| (c * intensity / 256 + spec).clamp(0, 255) as u8;
    Some(rgb565(shade(r), shade(g), shade(b)))
}

/// Background: vertical and horizontal gradients with an xor texture, scrolled by `scroll` pixels.
fn background_pixel(x: usize, y: usize, scroll: usize) -> u16 {
    let xor = ((x + scroll) ^ y) & 0x3F;
    let r = (y * 255 / (HEIGHT - 1)) as u8;
    let g = (xor * 3) as u8;
    let b = (x * 255 / (WIDTH - 1)) as u8;
    rgb565(r / 2, g, b)
}

/// CRC-32 of a frame, its pixels fed as little-endian 16-bit words (the frame checksum the firmware
/// prints; [`pocketsplat_core::crc::Crc32::update_u16_le`]).
pub fn frame_crc(fb: &[u16]) -> u32 {
    let mut crc = Crc32::new();
    crc.update_u16_le(fb);
    crc.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn isqrt_is_the_floor_root() {
        for n in (0..70_000u32).chain([u32::MAX - 1, u32::MAX]) {
            let r = isqrt(n) as u64;
            assert!(
                r * r <= n as u64 && (r + 1) * (r + 1) > n as u64,
                "isqrt({n}) = {r}"
            );
        }
    }

    #[test]
    fn rgb565_packs_channels() {
        assert_eq!(rgb565(255, 255, 255), 0xFFFF);
        assert_eq!(rgb565(255, 0, 0), 0xF800);
        assert_eq!(rgb565(0, 255, 0), 0x07E0);
        assert_eq!(rgb565(0, 0, 255), 0x001F);
    }

    #[test]
    fn frames_differ_and_the_sphere_is_lit_from_the_upper_left() {
        let mut f0 = vec![0u16; PIXELS];
        let f0: &mut [u16; PIXELS] = f0.as_mut_slice().try_into().unwrap();
        render_test_frame(0, f0);
        let mut f1 = vec![0u16; PIXELS];
        let f1: &mut [u16; PIXELS] = f1.as_mut_slice().try_into().unwrap();
        render_test_frame(1, f1);
        assert_ne!(frame_crc(f0), frame_crc(f1));

        let at = |fb: &[u16; PIXELS], x: i32, y: i32| fb[y as usize * WIDTH + x as usize];
        let green = |p: u16| (p >> 5) & 0x3F;
        // Same band (same base colour), mirrored about the centre: the upper-left side is brighter.
        let (lit, dark) = (
            at(f0, SPHERE_X - 40, SPHERE_Y - 5),
            at(f0, SPHERE_X + 40, SPHERE_Y - 5),
        );
        assert!(green(lit) > green(dark), "lit {lit:#06x} dark {dark:#06x}");
    }
}
