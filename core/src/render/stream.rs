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

/// A frame of a scene pack streamed through its objects' block caches
/// ([`SceneStream::render`](crate::stream::SceneStream::render), or with `pass` the next pass of a
/// refined frame), through the same camera, shading table, clear and raster as
/// [`render`](super::render()) draws the pack opened whole: with its shadows in the target's map,
/// for a frame from what is resident and for each pass of a refined frame alike.
///
/// # Errors
/// [`RenderError::Scene`] when an object's frame cannot be set up or the table has fewer than the
/// scene's slots.
#[cfg(feature = "scene")]
pub fn render_scene_stream<P: DepthTarget, L: Layer, const M: usize>(
    stream: &mut crate::stream::SceneStream<'_, '_, '_>,
    camera: &Camera,
    options: &RenderOptions,
    target: &mut Target<'_, P, M>,
    pass: StreamPass,
    layer: &mut L,
    mut mark: impl FnMut(Phase),
) -> Result<Drawn, RenderError> {
    mark(Phase::Setup);
    let camera = camera.for_viewport(target.pixels.viewport());
    let shading = stream
        .scene()
        .shading::<M>(&camera, options.light_dir)
        .map_err(RenderError::Scene)?;
    if pass == StreamPass::FirstPass {
        stream.begin_refined();
    }
    #[cfg(feature = "shadows")]
    let (map, light): (&mut [u16], _) = match target.shadow.as_mut() {
        Some((map, light)) => (&mut **map, Some(&mut **light)),
        None => (&mut [], None),
    };
    #[cfg(not(feature = "shadows"))]
    let map: &mut [u16] = &mut [];
    let mut walk = SceneStreamWalk {
        stream,
        camera: &camera,
        options,
        map,
        #[cfg(feature = "shadows")]
        light,
        refined: pass != StreamPass::Frame,
        result: None,
    };
    let clear = pass != StreamPass::NextPass;
    let (pixels, table) = (&mut target.pixels, &mut *target.table);
    let drawn = super::draw(
        pixels, table, &mut walk, &shading, clear, options, layer, &mut mark,
    );
    let stats = walk.finish().map_err(RenderError::Scene)?;
    Ok(Drawn {
        stats: stats.total,
        shadows: stats.shadows,
        scene: Some(stats),
        ..drawn
    })
}

/// The walk of a streamed scene's frame, for [`render_scene_stream`].
#[cfg(feature = "scene")]
mod scene_walk {
    use super::*;

    /// A streamed scene's frame ready to walk ([`crate::frame::Walk`]): a frame from what is resident
    /// ([`SceneStream::render`](crate::stream::SceneStream::render)) or, `refined`, the next pass of a refined frame
    /// ([`SceneStream::render_pass`](crate::stream::SceneStream::render_pass)). [`SceneStreamWalk::finish`] says what each object did.
    pub(super) struct SceneStreamWalk<'w, 'm, 'a, 'o> {
        /// The stream.
        pub(super) stream: &'w mut crate::stream::SceneStream<'m, 'a, 'o>,
        /// The camera, fitted to the target.
        pub(super) camera: &'w Camera,
        /// The options.
        pub(super) options: &'w RenderOptions,
        /// The shadow map's depths (empty without shadows).
        pub(super) map: &'w mut [u16],
        /// Where the light's tables are set (`None`: on the stack).
        #[cfg(feature = "shadows")]
        pub(super) light: Option<&'w mut crate::shadow::LightFrame>,
        /// The next pass of a refined frame instead of a frame from what is resident.
        pub(super) refined: bool,
        /// What the walk did.
        pub(super) result: Option<Result<crate::scene::SceneStats, crate::scene::SceneError>>,
    }

    impl SceneStreamWalk<'_, '_, '_, '_> {
        /// What the walk did, per object (empty counts if it never ran).
        ///
        /// # Errors
        /// As the stream's frame or pass.
        pub(super) fn finish(self) -> Result<crate::scene::SceneStats, crate::scene::SceneError> {
            self.result
                .unwrap_or(Ok(crate::scene::SceneStats::default()))
        }
    }

    impl crate::frame::Walk for SceneStreamWalk<'_, '_, '_, '_> {
        fn walk<S: crate::splat::ColorSink>(&mut self, sink: &mut S) -> crate::splat::Stats {
            // A pass of the refined frame, or a frame from what is resident: the same arguments.
            let step = if self.refined {
                crate::stream::SceneStream::render_pass::<S>
            } else {
                crate::stream::SceneStream::render::<S>
            };
            let r = step(
                self.stream,
                self.camera,
                self.options,
                self.map,
                #[cfg(feature = "shadows")]
                self.light.as_deref_mut(),
                sink,
            );
            let total = r.as_ref().map(|s| s.total).unwrap_or_default();
            self.result = Some(r);
            total
        }
    }
}
#[cfg(feature = "scene")]
use scene_walk::SceneStreamWalk;
