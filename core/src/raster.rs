//! The raster: RGB565 pixels with a 16-bit depth buffer ([`DepthTarget`]: the project's
//! [`Framebuffer`], 240 × 320 by default, or any display as a [`DisplayTarget`]), splat kernels
//! with a depth test, and the framebuffer as an embedded-graphics [`DrawTarget`] so text and HUD
//! overlays use the ecosystem.
//!
//! The buffers are borrowed (`&mut [[u16; W]; H]`, or a display and a depth slice) so that firmware
//! can place them in statics and the desktop on the heap; nothing here allocates.
#![deny(clippy::float_arithmetic)]

use core::convert::Infallible;

use embedded_graphics_core::draw_target::DrawTarget;
use embedded_graphics_core::geometry::{Dimensions, OriginDimensions, Point, Size};
use embedded_graphics_core::image::ImageDrawable;
use embedded_graphics_core::pixelcolor::raw::RawU16;
use embedded_graphics_core::pixelcolor::Rgb565;
use embedded_graphics_core::prelude::{PixelColor, RawData};
use embedded_graphics_core::primitives::Rectangle;
use embedded_graphics_core::Pixel;

use crate::camera::Viewport;
use crate::fixed::{ONE_PX_Q8, SUBPIXEL_BITS};

/// Farthest depth: the value the depth buffer is cleared to.
pub const DEPTH_FAR: u16 = u16::MAX;
/// Largest splat diameter drawn, pixels (larger ones are clamped and counted).
pub const MAX_SPLAT_PX: i32 = 64;

/// Splat shape (QSplat §3.2: squares are fastest, circles look better).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Kernel {
    /// An axis-aligned square.
    #[default]
    Square,
    /// A disc.
    Round,
}

/// One splat for the raster: position and diameter in Q8 pixels, depth, colour.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Splat {
    /// Centre x, Q8 pixels.
    pub x_q8: i32,
    /// Centre y, Q8 pixels (down).
    pub y_q8: i32,
    /// Diameter, Q8 pixels.
    pub size_q8: i32,
    /// Depth, 0 = nearest.
    pub depth: u16,
    /// RGB565 colour.
    pub color: u16,
}

/// Pixels with a 16-bit depth buffer: what a splat is drawn into.
///
/// Implemented by [`Framebuffer`] (the project's own buffers, their size known at compile time: the
/// device's fast path) and [`DisplayTarget`] (any embedded-graphics display with a depth buffer the
/// caller owns). Splats are rasterised once, by [`draw_splat`] and [`draw_pixel`], for every
/// implementation: only where a pixel lands differs.
pub trait DepthTarget {
    /// The size of the image.
    fn viewport(&self) -> Viewport;

    /// Clears colour to `background` and depth to [`DEPTH_FAR`].
    fn clear(&mut self, background: u16);

    /// Writes `color()` to pixel `(x, y)` when `depth` is nearer than the depth there (and `depth`
    /// there); returns 1 if written. `color` is asked for only then. `(x, y)` is inside the
    /// viewport (the caller clipped it).
    fn put(&mut self, x: usize, y: usize, depth: u16, color: impl FnOnce() -> u16) -> u32;

    /// [`DepthTarget::put`] of `color` to pixels `x0..x1` of row `y` (inside the viewport,
    /// `x0 < x1`); returns how many were written.
    #[inline(always)]
    fn put_span(&mut self, y: usize, x0: usize, x1: usize, depth: u16, color: u16) -> u32 {
        (x0..x1).map(|x| self.put(x, y, depth, || color)).sum()
    }
}

/// Draws a splat with a depth test into `target`; returns the number of pixels written. Pixels are
/// those whose centres fall inside the kernel (a square of side `size_q8`, or a disc of that
/// diameter); unless `exact`, a splat that contains no pixel centre writes the pixel under its
/// centre.
///
/// A square splat of at most two pixels (nearly all of a frame at a 1 px cutoff) is drawn inline
/// here; larger and round ones by a loop out of line.
#[inline(always)]
pub fn draw_splat<T: DepthTarget + ?Sized>(
    target: &mut T,
    s: &Splat,
    kernel: Kernel,
    exact: bool,
) -> u32 {
    let size = s.size_q8.clamp(1, MAX_SPLAT_PX * ONE_PX_Q8);
    let round = kernel == Kernel::Round && (exact || size > ONE_PX_Q8);
    if size > 2 * ONE_PX_Q8 || round {
        return splat_area(target, *s, size, kernel, exact);
    }
    // At most two pixel centres per axis, and usually one pixel.
    let (x0, x1, y0, y1) = footprint(s, size, exact);
    let (x, y) = if x1 == x0 + 1 && y1 == y0 + 1 {
        (x0, y0)
    } else if x1 > x0 && y1 > y0 {
        return splat_area(target, *s, size, kernel, exact);
    } else if exact {
        return 0;
    } else {
        (s.x_q8 >> SUBPIXEL_BITS, s.y_q8 >> SUBPIXEL_BITS)
    };
    draw_pixel(target, x, y, s.depth, || s.color)
}

/// Writes pixel `(x, y)` (nothing off the image) with a depth test; returns 1 if written. `color`
/// is asked for only when the pixel passes the depth test, so that a traversal which has already
/// found a splat's one pixel ([`exact_footprint`]) shades only what shows.
#[inline(always)]
pub fn draw_pixel<T: DepthTarget + ?Sized>(
    target: &mut T,
    x: i32,
    y: i32,
    depth: u16,
    color: impl FnOnce() -> u16,
) -> u32 {
    let v = target.viewport();
    // One unsigned comparison per axis also rejects negative coordinates.
    if x as u32 >= u32::from(v.width) || y as u32 >= u32::from(v.height) {
        return 0;
    }
    target.put(x as usize, y as usize, depth, color)
}

/// [`draw_splat`] of a splat of `size` (clamped) larger than a pixel, or round and exact.
#[inline(never)]
fn splat_area<T: DepthTarget + ?Sized>(
    target: &mut T,
    s: Splat,
    size: i32,
    kernel: Kernel,
    exact: bool,
) -> u32 {
    let (mut x0, mut x1, mut y0, mut y1) = footprint(&s, size, exact);
    if x1 <= x0 || y1 <= y0 {
        if exact {
            return 0;
        }
        (x0, y0) = (s.x_q8 >> SUBPIXEL_BITS, s.y_q8 >> SUBPIXEL_BITS);
        (x1, y1) = (x0 + 1, y0 + 1);
    }
    let round = kernel == Kernel::Round && (exact || size > ONE_PX_Q8);
    let half = half_side(size, exact);
    let v = target.viewport();
    let (x0, x1) = (x0.max(0), x1.min(i32::from(v.width)));
    let (y0, y1) = (y0.max(0), y1.min(i32::from(v.height)));
    let mut written = 0;
    if !round {
        // A square: its rows.
        if x1 <= x0 {
            return 0;
        }
        for y in y0..y1 {
            written += target.put_span(y as usize, x0 as usize, x1 as usize, s.depth, s.color);
        }
        return written;
    }
    let r2 = i64::from(half) * i64::from(half);
    for y in y0..y1 {
        let dy = i64::from((y << SUBPIXEL_BITS) + ONE_PX_Q8 / 2 - s.y_q8);
        for x in x0..x1 {
            let dx = i64::from((x << SUBPIXEL_BITS) + ONE_PX_Q8 / 2 - s.x_q8);
            if dx * dx + dy * dy > r2 {
                continue;
            }
            written += target.put(x as usize, y as usize, s.depth, || s.color);
        }
    }
    written
}

/// A framebuffer and depth buffer of `W × H` pixels, borrowed: the project's own buffers, whose
/// size the compiler knows (the device's fast path: every index and clip is a constant).
pub struct Framebuffer<'a, const W: usize = 240, const H: usize = 320> {
    color: &'a mut [[u16; W]; H],
    depth: &'a mut [[u16; W]; H],
}

impl<'a, const W: usize, const H: usize> Framebuffer<'a, W, H> {
    /// Wraps colour and depth buffers.
    pub fn new(color: &'a mut [[u16; W]; H], depth: &'a mut [[u16; W]; H]) -> Self {
        Self { color, depth }
    }

    /// Clears colour to `background` and depth to [`DEPTH_FAR`].
    pub fn clear(&mut self, background: u16) {
        fill(self.color.as_flattened_mut(), background);
        fill(self.depth.as_flattened_mut(), DEPTH_FAR);
    }

    /// The colour rows.
    pub fn rows(&self) -> &[[u16; W]; H] {
        self.color
    }

    /// The depth rows.
    pub fn depth_rows(&self) -> &[[u16; W]; H] {
        self.depth
    }

    /// CRC-32 of the colour buffer (pixels little-endian, row by row): the frame checksum that host
    /// and firmware compare.
    pub fn crc(&self) -> u32 {
        crc565(self.color.as_flattened())
    }

    /// [`draw_splat`] into this framebuffer.
    #[inline(always)]
    pub fn splat(&mut self, s: &Splat, kernel: Kernel, exact: bool) -> u32 {
        draw_splat(self, s, kernel, exact)
    }

    /// [`draw_pixel`] into this framebuffer.
    #[inline(always)]
    pub fn pixel(&mut self, x: i32, y: i32, depth: u16, color: impl FnOnce() -> u16) -> u32 {
        draw_pixel(self, x, y, depth, color)
    }
}

impl<const W: usize, const H: usize> DepthTarget for Framebuffer<'_, W, H> {
    #[inline(always)]
    fn viewport(&self) -> Viewport {
        Viewport {
            width: W as u16,
            height: H as u16,
        }
    }

    fn clear(&mut self, background: u16) {
        Framebuffer::clear(self, background);
    }

    #[inline(always)]
    fn put(&mut self, x: usize, y: usize, depth: u16, color: impl FnOnce() -> u16) -> u32 {
        let d = &mut self.depth[y][x];
        if depth < *d {
            *d = depth;
            self.color[y][x] = color();
            1
        } else {
            0
        }
    }

    /// Most rows of a square splat are one to four pixels long (a splat of 2 px or less covering two
    /// pixel centres; a QSplat leaf), which the match writes without a loop.
    #[inline(always)]
    fn put_span(&mut self, y: usize, x0: usize, x1: usize, depth: u16, color: u16) -> u32 {
        let mut written = 0;
        let (crow, drow) = (&mut self.color[y][x0..x1], &mut self.depth[y][x0..x1]);
        let mut put = |c: &mut u16, d: &mut u16| {
            if depth < *d {
                *d = depth;
                *c = color;
                written += 1;
            }
        };
        match (crow, drow) {
            ([c], [d]) => put(c, d),
            ([c0, c1], [d0, d1]) => {
                put(c0, d0);
                put(c1, d1);
            }
            // A QSplat leaf at a 1 px cutoff is two to four pixels across: its rows likewise.
            ([c0, c1, c2], [d0, d1, d2]) => {
                put(c0, d0);
                put(c1, d1);
                put(c2, d2);
            }
            ([c0, c1, c2, c3], [d0, d1, d2, d3]) => {
                put(c0, d0);
                put(c1, d1);
                put(c2, d2);
                put(c3, d3);
            }
            (crow, drow) => crow.iter_mut().zip(drow).for_each(|(c, d)| put(c, d)),
        }
        written
    }
}

/// Rows `top..top + h` of an image of `full`'s size, drawn into a target `h` rows high: a band of
/// the frame, which a device with less RAM than a whole frame's colour and depth draws and sends to
/// the panel before drawing the next (issue 31, the 520 KB handheld).
///
/// The walk is the whole frame's (the same culling, levels of detail and, with one-pass shadows,
/// the same fills of the map in the same order); only the pixels outside the band are dropped. The
/// bands of a frame, put together, are therefore that frame bit for bit, whatever the shadows; a
/// frame in `n` bands costs `n` walks and one frame's pixels.
pub struct Band<T> {
    inner: T,
    top: usize,
    rows: usize,
    full: Viewport,
}

impl<T: DepthTarget> Band<T> {
    /// Rows `top..` of an image of `full`'s size into `inner` (as many rows as it has), or `None`
    /// when `inner` is not as wide as the image or reaches past its last row.
    pub fn new(inner: T, top: u16, full: Viewport) -> Option<Self> {
        let v = inner.viewport();
        if v.width != full.width || u32::from(top) + u32::from(v.height) > u32::from(full.height) {
            return None;
        }
        Some(Self {
            rows: usize::from(v.height),
            top: usize::from(top),
            inner,
            full,
        })
    }

    /// The band's own target.
    pub fn inner(&self) -> &T {
        &self.inner
    }

    /// The band's own target, given back.
    pub fn into_inner(self) -> T {
        self.inner
    }
}

impl<T: DepthTarget> DepthTarget for Band<T> {
    #[inline(always)]
    fn viewport(&self) -> Viewport {
        self.full
    }

    fn clear(&mut self, background: u16) {
        self.inner.clear(background);
    }

    #[inline(always)]
    fn put(&mut self, x: usize, y: usize, depth: u16, color: impl FnOnce() -> u16) -> u32 {
        match y.checked_sub(self.top) {
            Some(r) if r < self.rows => self.inner.put(x, r, depth, color),
            _ => 0,
        }
    }

    #[inline(always)]
    fn put_span(&mut self, y: usize, x0: usize, x1: usize, depth: u16, color: u16) -> u32 {
        match y.checked_sub(self.top) {
            Some(r) if r < self.rows => self.inner.put_span(r, x0, x1, depth, color),
            _ => 0,
        }
    }
}

/// CRC-32 of RGB565 pixels, little-endian, in order: the frame checksum host and firmware compare.
pub fn crc565(pixels: &[u16]) -> u32 {
    let mut c = crate::crc::Crc32::new();
    c.update_u16_le(pixels);
    c.finish()
}

/// Any embedded-graphics display as a [`DepthTarget`], with a depth buffer the caller owns: a
/// frame's pixels go to the display as they pass the depth test, one [`DrawTarget::draw_iter`] per
/// pixel (a display that keeps its own framebuffer in RAM takes them at memory speed; over a slow
/// bus, drawing into a [`Framebuffer`] and sending it in one transfer is faster).
///
/// The viewport is the display's bounding box (its size from the display, pixels drawn relative to
/// its top-left corner).
///
/// ```
/// use pocketsplat_core::{DepthTarget, DisplayTarget, TestPanel};
/// let mut panel = TestPanel::new(128, 160);
/// let mut depth = vec![0u16; 128 * 160];
/// let target = DisplayTarget::new(&mut panel, &mut depth).expect("a depth value per pixel");
/// assert_eq!((target.viewport().width, target.viewport().height), (128, 160));
/// ```
pub struct DisplayTarget<'a, D> {
    display: &'a mut D,
    depth: &'a mut [u16],
    viewport: Viewport,
    origin: Point,
}

impl<'a, D: DrawTarget<Color = Rgb565>> DisplayTarget<'a, D> {
    /// `display` with `depth` as its depth buffer (row by row, at least one value per pixel of the
    /// display's bounding box); `None` when the buffer is too small or the display's size is not a
    /// [`Viewport`].
    pub fn new(display: &'a mut D, depth: &'a mut [u16]) -> Option<Self> {
        let area = display.bounding_box();
        let viewport = Viewport::new(area.size.width, area.size.height)?;
        if depth.len() < viewport.pixels() {
            return None;
        }
        Some(Self {
            display,
            depth,
            viewport,
            origin: area.top_left,
        })
    }

    /// The display.
    pub fn display(&mut self) -> &mut D {
        self.display
    }

    /// The depth buffer (row by row, the viewport's width per row).
    pub fn depth(&self) -> &[u16] {
        &self.depth[..self.viewport.pixels()]
    }
}

impl<D: DrawTarget<Color = Rgb565>> DepthTarget for DisplayTarget<'_, D> {
    fn viewport(&self) -> Viewport {
        self.viewport
    }

    fn clear(&mut self, background: u16) {
        fill(&mut self.depth[..self.viewport.pixels()], DEPTH_FAR);
        let area = Rectangle::new(
            self.origin,
            Size::new(self.viewport.width.into(), self.viewport.height.into()),
        );
        // A display's error cannot stop a frame: the pixel is lost, as on a flaky bus.
        let _ = self
            .display
            .fill_solid(&area, Rgb565::from(RawU16::new(background)));
    }

    #[inline]
    fn put(&mut self, x: usize, y: usize, depth: u16, color: impl FnOnce() -> u16) -> u32 {
        let d = &mut self.depth[y * usize::from(self.viewport.width) + x];
        if depth >= *d {
            return 0;
        }
        *d = depth;
        let at = self.origin + Point::new(x as i32, y as i32);
        let c = Rgb565::from(RawU16::new(color()));
        let _ = self.display.draw_iter(core::iter::once(Pixel(at, c)));
        1
    }
}

/// Sets every element of `buf` to `v`, 32 bytes per step where `buf` is word-aligned (a Cortex-M3
/// then stores 8 words per loop turn instead of a byte loop's one: a clear is 0.23 M instructions
/// per frame otherwise).
#[allow(unsafe_code)]
pub(crate) fn fill(buf: &mut [u16], v: u16) {
    // SAFETY: every bit pattern is a valid `u16` and a valid `u32`, so viewing the aligned middle of
    // the slice as words is sound; `align_to_mut` keeps the ends that are not aligned as `u16`s.
    let (head, body, tail) = unsafe { buf.align_to_mut::<[u32; 8]>() };
    head.fill(v);
    // The value through `black_box`: a constant with one repeated byte (0, `u16::MAX`) would
    // otherwise become a call to the `memset` of compiler-builtins, which stores a word per loop.
    let word = core::hint::black_box(u32::from(v) * 0x1_0001);
    body.fill([word; 8]);
    tail.fill(v);
}

/// The pixels `[x0, x1, y0, y1]` (`x0..x1 × y0..y1`, before clipping to the screen) whose centres
/// an exact square splat of `size_q8` at `(x_q8, y_q8)` covers, as [`Framebuffer::splat`] draws it:
/// empty (`x1 ≤ x0` or `y1 ≤ y0`) when it covers none, so that a traversal can skip the rest of a
/// splat that would draw nothing, and hand one that covers a single pixel to
/// [`Framebuffer::pixel`] without finding its footprint again.
#[inline(always)]
pub fn exact_footprint(x_q8: i32, y_q8: i32, size_q8: i32) -> [i32; 4] {
    clamped_footprint(x_q8, y_q8, size_q8, true)
}

/// [`footprint`] of a splat at `(x_q8, y_q8)` of `size_q8`, clamped as [`Framebuffer::splat`]
/// clamps it, as `[x0, x1, y0, y1]`.
#[inline(always)]
fn clamped_footprint(x_q8: i32, y_q8: i32, size_q8: i32, exact: bool) -> [i32; 4] {
    let s = Splat {
        x_q8,
        y_q8,
        size_q8,
        depth: 0,
        color: 0,
    };
    let (x0, x1, y0, y1) = footprint(&s, size_q8.clamp(1, MAX_SPLAT_PX * ONE_PX_Q8), exact);
    [x0, x1, y0, y1]
}

/// The pixels `x0..x1 × y0..y1` (before clipping to the screen) a square splat at
/// `(x_q8, y_q8)` of `size_q8` writes, as [`Framebuffer::splat`] draws it: those whose centres
/// it covers; when none, nothing if `exact`, else the pixel under its centre.
pub fn drawn_pixels(x_q8: i32, y_q8: i32, size_q8: i32, exact: bool) -> [i32; 4] {
    let [x0, x1, y0, y1] = clamped_footprint(x_q8, y_q8, size_q8, exact);
    if x1 > x0 && y1 > y0 {
        [x0, x1, y0, y1]
    } else if exact {
        [x0, x0, y0, y0]
    } else {
        let (x, y) = (x_q8 >> SUBPIXEL_BITS, y_q8 >> SUBPIXEL_BITS);
        [x, x + 1, y, y + 1]
    }
}

/// Half the side of a splat of `size` (Q8): an exact footprint rounds up, so that rounding never
/// opens a gap between neighbours.
#[inline(always)]
fn half_side(size: i32, exact: bool) -> i32 {
    if exact {
        (size + 1) >> 1
    } else {
        size >> 1
    }
}

/// The pixels `x0..x1 × y0..y1` whose centres `i + ½` lie in `[x − half, x + half)` (and the same
/// in `y`) for a splat of `size` (empty when none does).
#[inline(always)]
fn footprint(s: &Splat, size: i32, exact: bool) -> (i32, i32, i32, i32) {
    let half = half_side(size, exact);
    let first = |c: i32| (c - half + (ONE_PX_Q8 / 2 - 1)) >> SUBPIXEL_BITS;
    let end = |c: i32| (c + half + (ONE_PX_Q8 / 2 - 1)) >> SUBPIXEL_BITS;
    (first(s.x_q8), end(s.x_q8), first(s.y_q8), end(s.y_q8))
}

impl<const W: usize, const H: usize> OriginDimensions for Framebuffer<'_, W, H> {
    fn size(&self) -> Size {
        Size::new(W as u32, H as u32)
    }
}

/// A finished frame is an image any embedded-graphics display can draw, in one contiguous write:
///
/// ```
/// use core::convert::Infallible;
/// use embedded_graphics_core::prelude::*;
/// use embedded_graphics_core::image::ImageDrawable;
/// use embedded_graphics_core::pixelcolor::Rgb565;
/// use pocketsplat_core::Framebuffer;
///
/// // A caller's display: here one that counts the white pixels it is sent.
/// struct Panel(usize);
/// impl OriginDimensions for Panel {
///     fn size(&self) -> Size { Size::new(240, 320) }
/// }
/// impl DrawTarget for Panel {
///     type Color = Rgb565;
///     type Error = Infallible;
///     fn draw_iter<I: IntoIterator<Item = Pixel<Rgb565>>>(&mut self, px: I) -> Result<(), Infallible> {
///         self.0 += px.into_iter().filter(|Pixel(_, c)| *c == Rgb565::WHITE).count();
///         Ok(())
///     }
/// }
///
/// let (mut color, mut depth) = (Box::new([[0u16; 240]; 320]), Box::new([[0u16; 240]; 320]));
/// let mut fb = Framebuffer::new(&mut color, &mut depth);
/// fb.clear(0xFFFF);
/// let mut panel = Panel(0);
/// fb.draw(&mut panel).unwrap();
/// assert_eq!(panel.0, 240 * 320);
/// ```
impl<const W: usize, const H: usize> ImageDrawable for Framebuffer<'_, W, H> {
    type Color = Rgb565;

    fn draw<D: DrawTarget<Color = Rgb565>>(&self, target: &mut D) -> Result<(), D::Error> {
        let pixels = self
            .color
            .iter()
            .flatten()
            .map(|&p| Rgb565::from(RawU16::new(p)));
        target.fill_contiguous(&self.bounding_box(), pixels)
    }

    fn draw_sub_image<D: DrawTarget<Color = Rgb565>>(
        &self,
        target: &mut D,
        area: &Rectangle,
    ) -> Result<(), D::Error> {
        let area = area.intersection(&self.bounding_box());
        let Some(br) = area.bottom_right() else {
            return Ok(());
        };
        let (x0, y0) = (area.top_left.x as usize, area.top_left.y as usize);
        let pixels = self.color[y0..=br.y as usize].iter().flat_map(|row| {
            row[x0..=br.x as usize]
                .iter()
                .map(|&p| Rgb565::from(RawU16::new(p)))
        });
        // Drawn at the target's origin, as embedded-graphics' sub-images are.
        target.fill_contiguous(&Rectangle::new(Point::zero(), area.size), pixels)
    }
}

impl<const W: usize, const H: usize> DrawTarget for Framebuffer<'_, W, H> {
    type Color = Rgb565;
    type Error = Infallible;

    fn draw_iter<I: IntoIterator<Item = Pixel<Rgb565>>>(
        &mut self,
        pixels: I,
    ) -> Result<(), Infallible> {
        for Pixel(p, c) in pixels {
            if let (Ok(x), Ok(y)) = (usize::try_from(p.x), usize::try_from(p.y)) {
                if x < W && y < H {
                    self.color[y][x] = RawU16::from(c).into_inner();
                }
            }
        }
        Ok(())
    }

    fn fill_contiguous<I: IntoIterator<Item = Rgb565>>(
        &mut self,
        area: &Rectangle,
        colors: I,
    ) -> Result<(), Infallible> {
        let clipped = area.intersection(&self.bounding_box());
        let mut colors = colors.into_iter();
        let (ax, ay, aw) = (area.top_left.x, area.top_left.y, area.size.width as i32);
        // Walk the whole area in row order (the iterator covers it), writing only the clipped part.
        for y in ay..ay + area.size.height as i32 {
            for x in ax..ax + aw {
                let Some(c) = colors.next() else {
                    return Ok(());
                };
                if clipped.contains(embedded_graphics_core::geometry::Point::new(x, y)) {
                    self.color[y as usize][x as usize] = RawU16::from(c).into_inner();
                }
            }
        }
        Ok(())
    }

    fn fill_solid(&mut self, area: &Rectangle, color: Rgb565) -> Result<(), Infallible> {
        let area = area.intersection(&self.bounding_box());
        let Some(br) = area.bottom_right() else {
            return Ok(());
        };
        let raw = RawU16::from(color).into_inner();
        for row in &mut self.color[area.top_left.y as usize..=br.y as usize] {
            row[area.top_left.x as usize..=br.x as usize].fill(raw);
        }
        Ok(())
    }

    fn clear(&mut self, color: Rgb565) -> Result<(), Infallible> {
        let raw = RawU16::from(color).into_inner();
        for row in self.color.iter_mut() {
            row.fill(raw);
        }
        Ok(())
    }
}

/// The RGB565 value of an embedded-graphics colour.
pub fn raw565<C: PixelColor + Into<Rgb565>>(c: C) -> u16 {
    RawU16::from(c.into()).into_inner()
}

#[cfg(test)]
mod tests {
    use super::*;
    extern crate std;
    use std::boxed::Box;

    type Rows = Box<[[u16; 240]; 320]>;

    fn buffers() -> (Rows, Rows) {
        (Box::new([[0; 240]; 320]), Box::new([[0; 240]; 320]))
    }

    #[test]
    fn a_sub_image_is_the_area_s_pixels_at_the_target_s_origin() {
        use embedded_graphics_core::geometry::Point;
        use embedded_graphics_core::image::ImageDrawable;
        let (mut c, mut d) = buffers();
        for (y, row) in c.iter_mut().enumerate() {
            for (x, p) in row.iter_mut().enumerate() {
                *p = (x + 1000 * y) as u16;
            }
        }
        let fb = Framebuffer::new(&mut c, &mut d);
        let (mut c2, mut d2) = buffers();
        let mut out = Framebuffer::new(&mut c2, &mut d2);
        // Clipped to the frame: 10 × 2 of the asked 20 × 2.
        let area = Rectangle::new(Point::new(230, 5), Size::new(20, 2));
        fb.draw_sub_image(&mut out, &area).unwrap();
        let rows = out.rows();
        assert_eq!(rows[0][0], 230 + 5000);
        assert_eq!(rows[1][9], 239 + 6000);
        assert_eq!(rows[0][10], 0);
        assert_eq!(rows[2][0], 0);
        let drawn: usize = rows.iter().flatten().filter(|&&p| p != 0).count();
        assert_eq!(drawn, 20);
    }

    #[test]
    fn square_splat_covers_pixel_centres_and_depth_tests() {
        let (mut c, mut d) = buffers();
        let mut fb = Framebuffer::new(&mut c, &mut d);
        fb.clear(0);
        // Centre (10, 20), 4 px wide: pixels 8..12 × 18..22.
        let s = Splat {
            x_q8: 10 * 256,
            y_q8: 20 * 256,
            size_q8: 4 * 256,
            depth: 100,
            color: 0xFFFF,
        };
        assert_eq!(fb.splat(&s, Kernel::Square, false), 16);
        assert_eq!(fb.rows()[18][8], 0xFFFF);
        assert_eq!(fb.rows()[17][8], 0);
        assert_eq!(fb.rows()[21][11], 0xFFFF);
        assert_eq!(fb.rows()[22][11], 0);
        // Farther: nothing written; nearer: all written.
        assert_eq!(
            fb.splat(
                &Splat {
                    depth: 200,
                    color: 1,
                    ..s
                },
                Kernel::Square,
                false
            ),
            0
        );
        assert_eq!(
            fb.splat(
                &Splat {
                    depth: 50,
                    color: 2,
                    ..s
                },
                Kernel::Square,
                false
            ),
            16
        );
        // Tiny splat: the pixel under the centre.
        assert_eq!(
            fb.splat(
                &Splat {
                    x_q8: 5 * 256 + 48,
                    y_q8: 7 * 256 + 240,
                    size_q8: 4,
                    depth: 1,
                    color: 3
                },
                Kernel::Square,
                false
            ),
            1
        );
        assert_eq!(fb.rows()[7][5], 3);
        // Off screen: clipped, no panic.
        assert_eq!(
            fb.splat(
                &Splat {
                    x_q8: -1000,
                    y_q8: 99999,
                    size_q8: 9999,
                    depth: 0,
                    color: 3
                },
                Kernel::Round,
                false
            ),
            0
        );
    }

    #[test]
    fn round_splat_is_a_disc() {
        let (mut c, mut d) = buffers();
        let mut fb = Framebuffer::new(&mut c, &mut d);
        fb.clear(0);
        let n = fb.splat(
            &Splat {
                x_q8: 100 * 256,
                y_q8: 100 * 256,
                size_q8: 20 * 256,
                depth: 1,
                color: 9,
            },
            Kernel::Round,
            false,
        );
        // π·10² ≈ 314 pixels.
        assert!((300..=330).contains(&n), "{n}");
        assert_eq!(fb.rows()[100][100], 9);
        assert_eq!(
            fb.rows()[91][91],
            0,
            "corner of the square is outside the disc"
        );
    }

    #[test]
    fn draw_target_fills_and_clips() {
        use embedded_graphics_core::geometry::Point;
        let (mut c, mut d) = buffers();
        let mut fb = Framebuffer::new(&mut c, &mut d);
        fb.fill_solid(
            &Rectangle::new(Point::new(230, 310), Size::new(50, 50)),
            Rgb565::new(31, 0, 0),
        )
        .unwrap();
        assert_eq!(fb.rows()[319][239], 0xF800);
        assert_eq!(fb.rows()[309][239], 0);
        let area = Rectangle::new(Point::new(-1, 0), Size::new(3, 1));
        fb.fill_contiguous(
            &area,
            [
                Rgb565::new(0, 63, 0),
                Rgb565::new(0, 0, 31),
                Rgb565::new(31, 63, 31),
            ],
        )
        .unwrap();
        assert_eq!(fb.rows()[0][0], 0x001F);
        assert_eq!(fb.rows()[0][1], 0xFFFF);
    }
}
