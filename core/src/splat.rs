//! What a traversal emits and how it is counted: format-neutral, so a new format needs no raster
//! change (docs/ARCHITECTURE.md "The way data flows").
#![deny(clippy::float_arithmetic)]

use crate::raster::{draw_pixel, draw_splat, DepthTarget, Kernel, Splat};
use crate::shade::ShadingTable;

/// A splat as a traversal emits it: screen position, size, depth and the sample's attribute.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SampleSplat {
    /// Centre x, Q8 pixels.
    pub x_q8: i32,
    /// Centre y, Q8 pixels (down).
    pub y_q8: i32,
    /// Diameter, Q8 pixels.
    pub size_q8: i32,
    /// Depth, 0 = nearest.
    pub depth: u16,
    /// Normal code | material << 13.
    pub attr: u16,
    /// Level of the sample in its hierarchy (0 = root).
    pub level: u8,
    /// Index of the sample within its level (breadth-first), for tests and streaming.
    pub index: u32,
    /// In shadow: shaded with the material's ambient term only.
    pub shadowed: bool,
    /// Draw exactly the pixels whose centres the splat covers, none when it covers none (a
    /// tri-grid cell: the cells of a surface tile its projection); otherwise at least the pixel
    /// under its centre (a QSplat sphere). [`crate::raster::draw_splat`] says which pixels.
    pub exact: bool,
}

/// Receives splats (a generic parameter of every traversal, so the call is inlined).
pub trait SplatSink {
    /// Draws (or records) one splat.
    fn splat(&mut self, s: &SampleSplat);

    /// Draws (or records) an exact square splat whose footprint the caller has found to be the one
    /// pixel `(x, y)` ([`crate::raster::exact_footprint`]): what [`SplatSink::splat`] does with
    /// it, without finding the footprint again. By default, exactly that call.
    #[inline(always)]
    fn pixel(&mut self, s: &SampleSplat, x: i32, y: i32) {
        let _ = (x, y);
        self.splat(s);
    }

    /// The splats that follow are object `object`'s, of a scene pack (called by the scene
    /// renderer before each object's traversal). By default, nothing.
    #[inline(always)]
    fn begin_object(&mut self, object: u8) {
        let _ = object;
    }
}

/// Counts of one frame's traversal.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Stats {
    /// Nodes (cells) visited.
    pub nodes_visited: u32,
    /// Subtrees culled by the frustum or near plane.
    pub culled: u32,
    /// Samples skipped as backfacing.
    pub backfacing: u32,
    /// Splats emitted.
    pub splats: u32,
    /// Splats drawn in shadow.
    pub shadowed: u32,
    /// Deepest level emitted.
    pub max_level: u8,
}

/// The usual sink: shade through the table and draw into a framebuffer or display.
pub struct ShadedRaster<'f, 't, T: ?Sized, const M: usize> {
    /// Where the pixels go (a [`crate::raster::Framebuffer`], a [`crate::raster::DisplayTarget`]).
    pub fb: &'f mut T,
    /// The shading table.
    pub table: &'t ShadingTable<M>,
    /// Splat kernel.
    pub kernel: Kernel,
}

impl<T: DepthTarget + ?Sized, const M: usize> SplatSink for ShadedRaster<'_, '_, T, M> {
    #[inline(always)]
    fn splat(&mut self, s: &SampleSplat) {
        let color = if s.shadowed {
            self.table.shadowed(s.attr)
        } else {
            self.table.color(s.attr)
        };
        draw_splat(
            self.fb,
            &Splat {
                x_q8: s.x_q8,
                y_q8: s.y_q8,
                size_q8: s.size_q8,
                depth: s.depth,
                color,
            },
            self.kernel,
            s.exact,
        );
    }

    #[inline(always)]
    fn pixel(&mut self, s: &SampleSplat, x: i32, y: i32) {
        // A round kernel tests the disc, not the square's one pixel centre.
        if self.kernel != Kernel::Square || !s.exact {
            return self.splat(s);
        }
        let table = self.table;
        // Shaded only if it passes the depth test.
        draw_pixel(self.fb, x, y, s.depth, || {
            if s.shadowed {
                table.shadowed(s.attr)
            } else {
                table.color(s.attr)
            }
        });
    }
}

/// A sink that keeps nothing (for counting and benchmarks of the traversal alone).
#[derive(Clone, Copy, Debug, Default)]
pub struct NullSink {
    /// Sum of positions and depths, so the work cannot be optimised away.
    pub checksum: u32,
}

impl SplatSink for NullSink {
    #[inline]
    fn splat(&mut self, s: &SampleSplat) {
        self.checksum = self
            .checksum
            .wrapping_add(s.x_q8 as u32 ^ (s.y_q8 as u32) << 7 ^ u32::from(s.depth));
    }
}

/// A sink that can also take a sample's own RGB565 colour (QSplat nodes may carry one).
pub trait ColorSink: SplatSink {
    /// Draws (or records) one splat whose sample has colour `rgb565`.
    fn splat_colored(&mut self, s: &SampleSplat, rgb565: u16);
}

/// Multiplies two RGB565 colours channel by channel (each channel as a fraction of its maximum).
#[inline]
pub fn modulate(a: u16, b: u16) -> u16 {
    let ch = |shift: u32, max: u32, k: u32| {
        let (x, y) = (u32::from(a) >> shift & max, u32::from(b) >> shift & max);
        // x·y/max, rounded: k = 2¹⁶/max.
        ((x * y * k + 32768) >> 16).min(max) << shift
    };
    (ch(11, 31, 2114) | ch(5, 63, 1040) | ch(0, 31, 2114)) as u16
}

/// The material's shading (light, view, ambient, highlight) modulated by the sample's colour: for a
/// coloured model, give the shading table a white material.
impl<T: DepthTarget + ?Sized, const M: usize> ColorSink for ShadedRaster<'_, '_, T, M> {
    #[inline]
    fn splat_colored(&mut self, s: &SampleSplat, rgb565: u16) {
        let lit = if s.shadowed {
            self.table.shadowed(s.attr)
        } else {
            self.table.color(s.attr)
        };
        draw_splat(
            self.fb,
            &Splat {
                x_q8: s.x_q8,
                y_q8: s.y_q8,
                size_q8: s.size_q8,
                depth: s.depth,
                color: modulate(lit, rgb565),
            },
            self.kernel,
            s.exact,
        );
    }
}

impl ColorSink for NullSink {
    #[inline]
    fn splat_colored(&mut self, s: &SampleSplat, rgb565: u16) {
        self.splat(s);
        self.checksum = self.checksum.wrapping_add(u32::from(rgb565));
    }
}

/// Colour by resolution (Streaming QSplat §4.1): the tint of a splat drawn `levels` levels above full
/// detail, RGB565. 0 (a leaf: full detail) is white, which leaves the shading as it is; then yellow,
/// orange, red, magenta, blue, cyan, and green for 7 levels or more. The firmware can use the same
/// table (it is 16 bytes).
pub const LEVEL_TINTS: [u16; 8] = [
    0xFFFF, // 0: full detail
    0xFF2A, // 1: yellow
    0xFCA5, // 2: orange
    0xF1E7, // 3: red
    0xDA3B, // 4: magenta
    0x537F, // 5: blue
    0x3EFC, // 6: cyan
    0x56EB, // 7 or more: green
];

/// The tint of a splat `levels` levels above full detail ([`LEVEL_TINTS`]).
#[inline]
pub fn level_tint(levels: u32) -> u16 {
    LEVEL_TINTS[(levels as usize).min(LEVEL_TINTS.len() - 1)]
}

/// A sink in front of `sink` that tints every splat by how many levels above full detail it was
/// drawn, as `levels(object, splat)` says (the object is the scene pack's, 0 outside a pack): where
/// the cutoff or a missing block stopped the descent. A sample's own colour is kept, tinted.
pub struct LevelTint<'s, S, F> {
    /// Where the tinted splats go.
    pub sink: &'s mut S,
    /// Levels between a splat and full detail below it.
    pub levels: F,
    /// The object being drawn.
    pub object: u8,
}

impl<S: ColorSink, F: FnMut(u8, &SampleSplat) -> u32> SplatSink for LevelTint<'_, S, F> {
    #[inline]
    fn splat(&mut self, s: &SampleSplat) {
        let tint = level_tint((self.levels)(self.object, s));
        self.sink.splat_colored(s, tint);
    }

    fn begin_object(&mut self, object: u8) {
        self.object = object;
        self.sink.begin_object(object);
    }
}

impl<S: ColorSink, F: FnMut(u8, &SampleSplat) -> u32> ColorSink for LevelTint<'_, S, F> {
    #[inline]
    fn splat_colored(&mut self, s: &SampleSplat, rgb565: u16) {
        let tint = level_tint((self.levels)(self.object, s));
        self.sink.splat_colored(s, modulate(rgb565, tint));
    }
}
