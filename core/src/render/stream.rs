//! Streamed frames through the pipeline: a [`TgStream`]'s frame, or the next pass of a refined
//! frame, drawn by the same table, clear and raster as every resident frame.

use super::{view_dir, Drawn, Layer, Phase, RenderError, Target};
use crate::camera::{Camera, Placement};
use crate::format::FileFormat;
use crate::frame::{RenderOptions, Shading};
use crate::raster::DepthTarget;
use crate::shade::ShadowMode;
use crate::stream::{StreamWalk, TgStream};
use crate::tg::TgFrame;
#[cfg(feature = "qsplat")]
use crate::{
    qs::{material_for_colors, QsFrame},
    stream::{QsStream, QsStreamWalk},
};

/// A frame of a tri-grid streamed through a block cache ([`TgStream::render`]: it draws what is
/// resident and queues what is missing, [`TgStream::serve`] reads it), through the same camera,
/// shading table, clear and raster as [`render`](super::render()). `pass` draws the next pass of a refined frame
/// instead ([`TgStream::render_pass`]): the pixels are cleared only for the first pass (which
/// also starts the refined frame), so that the passes add up to the resident frame. Without
/// shadows: the streamed walk takes no light pass.
///
/// # Errors
/// [`RenderError::Frame`] when the frame cannot be set up, [`RenderError::NoShadows`] when the
/// options ask for shadows.
pub fn render_stream<P: DepthTarget, L: Layer, const M: usize>(
    stream: &mut TgStream<'_>,
    camera: &Camera,
    options: &RenderOptions,
    target: &mut Target<'_, P, M>,
    pass: StreamPass,
    layer: &mut L,
    mut mark: impl FnMut(Phase),
) -> Result<Drawn, RenderError> {
    mark(Phase::Setup);
    if options.shadows != ShadowMode::Off {
        return Err(RenderError::NoShadows(FileFormat::TriGrid, options.shadows));
    }
    let camera = camera.for_viewport(target.pixels.viewport());
    let frame = TgFrame::new(stream.header(), &Placement::IDENTITY, &camera, options)?;
    let shading = Shading::uniform(options.material, options.light_dir, view_dir(&camera));
    if pass == StreamPass::FirstPass {
        stream.begin_refined();
    }
    let mut walk = StreamWalk {
        stream,
        frame: &frame,
        refined: pass != StreamPass::Frame,
    };
    let clear = pass != StreamPass::NextPass;
    Ok(target.draw(&mut walk, &shading, clear, options, layer, &mut mark))
}

/// Which frame of a stream [`render_stream`] draws.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StreamPass {
    /// A whole frame from what is resident (coarser where blocks are absent).
    Frame,
    /// The first pass of a refined frame: clears and starts it.
    FirstPass,
    /// The next pass of the refined frame: draws over what the earlier passes drew.
    NextPass,
}

/// A frame of a QSplat file streamed through a block cache ([`QsStream::render`], or with `pass`
/// the next pass of a refined frame, [`QsStream::render_pass`]), through the same camera, shading
/// table, clear and raster as [`render`](super::render()): [`render_stream`] for `.qs` files.
///
/// # Errors
/// [`RenderError::Frame`] when the frame cannot be set up, [`RenderError::NoShadows`] when the
/// options ask for shadows (QSplat files have none).
#[cfg(feature = "qsplat")]
pub fn render_qs_stream<P: DepthTarget, L: Layer, const M: usize>(
    stream: &mut QsStream<'_>,
    camera: &Camera,
    options: &RenderOptions,
    target: &mut Target<'_, P, M>,
    pass: StreamPass,
    layer: &mut L,
    mut mark: impl FnMut(Phase),
) -> Result<Drawn, RenderError> {
    mark(Phase::Setup);
    if options.shadows != ShadowMode::Off {
        return Err(RenderError::NoShadows(FileFormat::QSplat, options.shadows));
    }
    let camera = camera.for_viewport(target.pixels.viewport());
    let frame = QsFrame::of_trees(
        stream.trees().iter().copied(),
        &Placement::IDENTITY,
        &camera,
        options,
    )?;
    let material = material_for_colors(stream.has_color(), options.material);
    let shading = Shading::uniform(material, options.light_dir, view_dir(&camera));
    if pass == StreamPass::FirstPass {
        stream.begin_refined();
    }
    let mut walk = QsStreamWalk {
        stream,
        frame: &frame,
        refined: pass != StreamPass::Frame,
    };
    let clear = pass != StreamPass::NextPass;
    Ok(target.draw(&mut walk, &shading, clear, options, layer, &mut mark))
}
