//! PNG output and input: frames are written as 8-bit RGB PNGs (RGB565 expanded by bit
//! replication) and golden images are read back as 8-bit RGB.
//!
//! Every write goes through [`write_atomic`], so a failure never leaves a partial file; every error
//! names the file.
//!
//! # Example
//!
//! ```
//! use pocketsplat_core::camera::Viewport;
//! use pocketsplat_sim::image::{read_rgb8_png, write_rgb565_png};
//!
//! let dir = tempfile::tempdir()?;
//! let path = dir.path().join("frame.png");
//! let landscape = Viewport::new(320, 240).unwrap();
//! write_rgb565_png(&path, landscape, &vec![0xF800; 320 * 240])?; // pure red
//! let img = read_rgb8_png(&path)?;
//! assert_eq!((img.width, img.height), (320, 240));
//! assert_eq!(img.pixels[0], [255, 0, 0]);
//! # Ok::<(), anyhow::Error>(())
//! ```

use std::io::Cursor;
use std::path::Path;

use anyhow::{bail, Context, Result};
use pocketsplat_core::camera::{Viewport, HEIGHT, WIDTH};
use pocketsplat_core::shade::rgb565_to_rgb888;

use crate::fsutil::write_atomic;

/// An 8-bit RGB image, row-major.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Rgb8Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width × height` pixels, row by row from the top.
    pub pixels: Vec<[u8; 3]>,
}

/// Writes an RGB565 frame of `viewport`'s size as an 8-bit RGB PNG, each channel expanded by bit
/// replication ([`rgb565_to_rgb888`]).
///
/// # Errors
/// When `pixels` does not hold the viewport's pixels, or the file cannot be written (nothing is
/// left behind then).
pub fn write_rgb565_png(path: &Path, viewport: Viewport, pixels: &[u16]) -> Result<()> {
    let rgb: Vec<[u8; 3]> = pixels.iter().map(|&p| rgb565_to_rgb888(p)).collect();
    write_rgb8_png_sized(path, viewport.width.into(), viewport.height.into(), &rgb)
}

/// Writes a frame ([`crate::render::Image`], any size) as a PNG: [`write_rgb565_png`].
///
/// # Errors
/// When the file cannot be written (nothing is left behind then).
pub fn write_image_png(path: &Path, image: &crate::render::Image) -> Result<()> {
    write_rgb565_png(path, image.viewport(), image.pixels())
}

/// Writes a `WIDTH × HEIGHT` (240 × 320) 8-bit RGB frame as a PNG.
///
/// # Errors
/// When `pixels` is not 240 × 320, or the file cannot be written (nothing is left behind then).
pub fn write_rgb8_png(path: &Path, pixels: &[[u8; 3]]) -> Result<()> {
    write_rgb8_png_sized(path, WIDTH as u32, HEIGHT as u32, pixels)
}

/// Writes an 8-bit RGB image of any size as a PNG.
///
/// # Errors
/// When `pixels` does not hold `width × height` pixels, or the file cannot be written (nothing is
/// left behind then).
pub fn write_rgb8_png_sized(
    path: &Path,
    width: u32,
    height: u32,
    pixels: &[[u8; 3]],
) -> Result<()> {
    let bytes = encode_rgb8_png(width, height, pixels)
        .with_context(|| format!("cannot encode {}", path.display()))?;
    write_atomic(path, &bytes).with_context(|| format!("cannot write PNG {}", path.display()))
}

/// Encodes an 8-bit RGB image as PNG bytes.
///
/// # Errors
/// When `pixels` does not hold `width × height` pixels, or the size is zero.
pub fn encode_rgb8_png(width: u32, height: u32, pixels: &[[u8; 3]]) -> Result<Vec<u8>> {
    let expected = width as usize * height as usize;
    if pixels.len() != expected || expected == 0 {
        bail!(
            "image of {} pixels does not match its size {width} × {height}",
            pixels.len()
        );
    }
    let mut out = Vec::new();
    let mut encoder = png::Encoder::new(&mut out, width, height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header()?;
    writer.write_image_data(pixels.as_flattened())?;
    writer.finish()?;
    Ok(out)
}

/// Reads a PNG as 8-bit RGB. Any PNG colour type and depth is accepted: palettes are expanded,
/// 16-bit channels keep their high byte, grey is replicated to RGB, and alpha is dropped (not
/// composited). For an animated PNG the first frame is read.
///
/// # Errors
/// When the file cannot be read or is not a valid PNG; the message names the file.
pub fn read_rgb8_png(path: &Path) -> Result<Rgb8Image> {
    let bytes = crate::fsutil::read_file(path)?;
    decode_rgb8_png(&bytes).with_context(|| format!("{}: not a readable PNG", path.display()))
}

/// Reads a PNG that must be a `WIDTH × HEIGHT` (240 × 320) frame, as 8-bit RGB (see
/// [`read_rgb8_png`]): what golden-image tests compare with.
///
/// # Errors
/// As [`read_rgb8_png`], and when the image is not 240 × 320.
pub fn read_rgb8_frame(path: &Path) -> Result<Vec<[u8; 3]>> {
    let img = read_rgb8_png(path)?;
    if (img.width, img.height) != (WIDTH as u32, HEIGHT as u32) {
        bail!(
            "{}: image is {} × {}, expected a {WIDTH} × {HEIGHT} frame",
            path.display(),
            img.width,
            img.height
        );
    }
    Ok(img.pixels)
}

/// Decodes PNG bytes as 8-bit RGB (see [`read_rgb8_png`]).
///
/// # Errors
/// When the bytes are not a valid PNG.
pub fn decode_rgb8_png(bytes: &[u8]) -> Result<Rgb8Image> {
    let mut decoder = png::Decoder::new(Cursor::new(bytes));
    decoder.set_transformations(png::Transformations::normalize_to_color8());
    let mut reader = decoder.read_info()?;
    let size = reader
        .output_buffer_size()
        .context("image too large for memory")?;
    let mut buf = vec![0; size];
    let info = reader.next_frame(&mut buf)?;
    if info.bit_depth != png::BitDepth::Eight {
        bail!("unexpected bit depth {:?} after expansion", info.bit_depth);
    }
    let channels = match info.color_type {
        png::ColorType::Grayscale => 1,
        png::ColorType::GrayscaleAlpha => 2,
        png::ColorType::Rgb => 3,
        png::ColorType::Rgba => 4,
        other => bail!("unexpected colour type {other:?} after expansion"),
    };
    let (w, h) = (info.width as usize, info.height as usize);
    let mut pixels = Vec::with_capacity(w * h);
    for row in buf[..info.buffer_size()]
        .chunks_exact(info.line_size)
        .take(h)
    {
        for px in row[..w * channels].chunks_exact(channels) {
            pixels.push(if channels < 3 {
                [px[0]; 3]
            } else {
                [px[0], px[1], px[2]]
            });
        }
    }
    Ok(Rgb8Image {
        width: info.width,
        height: info.height,
        pixels,
    })
}
