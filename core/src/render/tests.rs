use super::*;
use crate::camera::View;
use crate::format::FileFormat;
use crate::raster::{DisplayTarget, Framebuffer};
use embedded_graphics_core::pixelcolor::raw::RawU16;
use embedded_graphics_core::prelude::*;
extern crate std;
use std::boxed::Box;
use std::vec;
use std::vec::Vec;

const EXAMPLE: &[u8] = include_bytes!("../../examples/data/trefoil.tg");

/// A display that keeps its pixels, sized at run time: one display type for every size, so the
/// tests instantiate the pipeline once for it (each target type is a copy of every walk).
struct Image {
    width: usize,
    pixels: Vec<u16>,
}

impl Image {
    fn new(width: usize, height: usize) -> Self {
        Image {
            width,
            pixels: vec![0; width * height],
        }
    }
}

impl OriginDimensions for Image {
    fn size(&self) -> Size {
        Size::new(self.width as u32, (self.pixels.len() / self.width) as u32)
    }
}

impl DrawTarget for Image {
    type Color = Rgb565;
    type Error = core::convert::Infallible;
    fn draw_iter<I: IntoIterator<Item = Pixel<Rgb565>>>(
        &mut self,
        pixels: I,
    ) -> Result<(), Self::Error> {
        for Pixel(p, c) in pixels {
            self.pixels[p.y as usize * self.width + p.x as usize] = RawU16::from(c).into_inner();
        }
        Ok(())
    }
}

use embedded_graphics_core::pixelcolor::Rgb565;

/// The frame of the example model at `view` through a `width` × `height` display.
fn display(width: usize, height: usize, view: View, options: &RenderOptions) -> Vec<u16> {
    let model = Model::open(EXAMPLE).unwrap();
    let camera = model.orbit(view);
    let mut table = Box::new(ShadingTable::<1>::new());
    let mut image = Image::new(width, height);
    let mut depth = vec![0u16; width * height];
    let mut target = Target::new(
        DisplayTarget::new(&mut image, &mut depth).unwrap(),
        &mut table,
    );
    render(&model, &camera, options, &mut target).unwrap();
    image.pixels
}

/// The frame of the example model at `view` in a `W` × `H` framebuffer and through a display.
fn both<const W: usize, const H: usize>(
    view: View,
    options: &RenderOptions,
) -> (Vec<u16>, Vec<u16>) {
    let model = Model::open(EXAMPLE).unwrap();
    let camera = model.orbit(view);
    let mut table = Box::new(ShadingTable::<1>::new());
    let (mut color, mut depth) = (Box::new([[0u16; W]; H]), Box::new([[0u16; W]; H]));
    let mut target = Target::new(Framebuffer::new(&mut color, &mut depth), &mut table);
    render(&model, &camera, options, &mut target).unwrap();
    (color.as_flattened().to_vec(), display(W, H, view, options))
}

#[test]
fn a_display_and_a_framebuffer_get_the_same_pixels_at_any_size() {
    let options = RenderOptions::default();
    for view in [View::new(30.0, 20.0, 2.5), View::new(-100.0, -40.0, 0.9)] {
        let (fb, display) = both::<240, 320>(view, &options);
        assert_eq!(fb, display);
        assert!(fb.iter().filter(|&&p| p != 0).count() > 5000);
        let (fb, display) = both::<320, 240>(
            view,
            &RenderOptions {
                cutoff_px: 3.0,
                ..options
            },
        );
        assert_eq!(fb, display);
    }
}

/// The projection follows the target: the same camera framed for a landscape image keeps its
/// vertical field of view, so the model is as tall in pixels as the image is high, relatively.
#[test]
fn the_projection_follows_the_target_size() {
    let rows_covered = |pixels: &[u16], w: usize| -> (usize, usize) {
        let rows: Vec<usize> = pixels
            .chunks(w)
            .enumerate()
            .filter(|(_, r)| r.iter().any(|&p| p != 0))
            .map(|(y, _)| y)
            .collect();
        (rows[0], *rows.last().unwrap())
    };
    let view = View::new(0.0, 0.0, 3.0);
    let portrait = display(240, 320, view, &RenderOptions::default());
    let half = display(120, 160, view, &RenderOptions::default());
    let landscape = display(320, 240, view, &RenderOptions::default());
    let (p0, p1) = rows_covered(&portrait, 240);
    let (h0, h1) = rows_covered(&half, 120);
    let (l0, l1) = rows_covered(&landscape, 320);
    // Each edge's distance from the image's centre row scales with the height (within a
    // pixel of rounding at the smaller size): half at 160 rows, three quarters at 240.
    let from_centre = |y: usize, h: usize| 2 * y as i64 - h as i64;
    for (p, h, l) in [(p0, h0, l0), (p1, h1, l1)] {
        let (p, h, l) = (
            from_centre(p, 320),
            from_centre(h, 160),
            from_centre(l, 240),
        );
        assert!((2 * h - p).abs() <= 4, "{p} vs {h} at half the height");
        assert!((4 * l - 3 * p).abs() <= 8, "{p} vs {l} at 240 rows");
    }
}

#[test]
fn open_names_what_is_wrong() {
    assert_eq!(
        Model::open(b"ply\nformat ascii 1.0\n").unwrap_err(),
        ModelError::UnknownFormat
    );
    assert_eq!(Model::open(b"").unwrap_err(), ModelError::UnknownFormat);
    let mut tg = EXAMPLE.to_vec();
    tg[100] ^= 1;
    assert!(matches!(Model::open(&tg), Err(ModelError::TriGrid(_))));
    let mut qs = [0u8; 64];
    qs[..8].copy_from_slice(b"QSplat11");
    let err = Model::open(&qs).unwrap_err();
    #[cfg(feature = "qsplat")]
    assert!(matches!(err, ModelError::QSplat(_)), "{err:?}");
    #[cfg(not(feature = "qsplat"))]
    assert_eq!(err, ModelError::NotBuilt(FileFormat::QSplat));
    let pack = *b"PSPK\x01\x00\x00\x00";
    let err = Model::open(&pack).unwrap_err();
    #[cfg(feature = "scene")]
    assert!(matches!(err, ModelError::Pack(_)), "{err:?}");
    #[cfg(not(feature = "scene"))]
    assert_eq!(err, ModelError::NotBuilt(FileFormat::Pack));
    assert!(!err.to_string().is_empty());
    let model = Model::open(EXAMPLE).unwrap();
    assert_eq!(model.format(), FileFormat::TriGrid);
    assert_eq!(
        model.shadow_modes().len(),
        if cfg!(feature = "shadows") { 3 } else { 1 }
    );
}

#[test]
fn shadows_need_a_map_and_a_bad_cutoff_is_an_error() {
    let model = Model::open(EXAMPLE).unwrap();
    let camera = model.orbit(View::new(30.0, 20.0, 2.5));
    let mut table = Box::new(ShadingTable::<1>::new());
    // 96 × 64, the smallest panel the project names, through a display (one target type for
    // every size the tests draw at).
    let mut image = Image::new(96, 64);
    let mut depth = vec![0u16; 96 * 64];
    let mut target = Target::new(
        DisplayTarget::new(&mut image, &mut depth).unwrap(),
        &mut table,
    );
    let shadowed = RenderOptions {
        shadows: ShadowMode::OnePass,
        ..RenderOptions::default()
    };
    assert_eq!(
        render(&model, &camera, &shadowed, &mut target).unwrap_err(),
        RenderError::NoShadows(FileFormat::TriGrid, ShadowMode::OnePass)
    );
    for cutoff_px in [0.0, -1.0, f32::NAN, f32::INFINITY] {
        let bad = RenderOptions::default().with_cutoff(cutoff_px);
        assert_eq!(
            render(&model, &camera, &bad, &mut target).unwrap_err(),
            RenderError::Frame(FrameError::BadCamera),
            "{cutoff_px}"
        );
    }
    // It draws.
    render(&model, &camera, &RenderOptions::default(), &mut target).unwrap();
    assert!(image.pixels.iter().any(|&p| p != 0));
}
