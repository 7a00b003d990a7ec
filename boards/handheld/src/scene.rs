//! A scene pack (`SCENE.PAK`) on the card, with its one-pass shadows: the QEMU firmware's streamed
//! pack (`pocketsplat_qemu::pack_stream`: every object through its share of one 80 KB cache, the
//! panel in eight bands of 40 rows, a 128² shadow map) driven by the buttons. While a button is held,
//! or until what the view needs at [`PREVIEW_CUTOFF_PX`] is resident, a whole frame at that cutoff
//! from what is resident, band by band, each band sent to the panel as it is drawn; then the 1 px
//! frame in passes ([`BandPasses`]), each band sent to the panel once its passes complete it: the
//! frame the pack opened whole gives in as many bands with that map.

use embedded_graphics::pixelcolor::raw::RawU16;
use embedded_graphics::pixelcolor::Rgb565;
use embedded_graphics::prelude::*;
use embedded_graphics::primitives::Rectangle;
use pocketsplat_core::lod::FINEST_CUTOFF_PX;
use pocketsplat_core::render::StreamPass;
use pocketsplat_core::scene::MAX_SLOTS;
use pocketsplat_core::stream::{ChunkSource, SceneStream};
use pocketsplat_qemu::pack_stream::{
    draw_band, open_pack, pack_first_view, pack_frame_setup, pack_memory, BandPasses, PassEnd,
    PACK_BANDS, PACK_BAND_ROWS, PACK_MAX_PASSES,
};
use pocketsplat_qemu::scene::SceneTargets;
use pocketsplat_qemu::stream::{
    draw_error_marker, StreamRunError, IO_BUDGET_BYTES, MAX_CONVERGE_FRAMES, REFINE_IO_BUDGET_BYTES,
};
use pocketsplat_qemu::WIDTH;

use crate::memory::PackArena;
use crate::{elapsed, Clock, FrameInfo, LoadError, Marker, Orbit, StepOutcome};

/// Cutoff of the frames drawn while the camera moves, pixels: a pack's frame is several models',
/// so a coarser one than a model's first.
pub const PREVIEW_CUTOFF_PX: f32 = 4.0;

/// Opens the pack on `src` in `arena`: its metadata, then every object's stream through its share
/// of the cache.
///
/// # Errors
/// [`LoadError::Read`] when the card fails on the metadata, [`LoadError::PackMemory`] when the
/// objects need more than the arena has, [`LoadError::Invalid`] otherwise.
// Not inlined: opening holds several object streams at once on the stack, which the frames drawn
// afterwards need not keep beside their own.
#[inline(never)]
pub fn open_scene<'a, C: ChunkSource + ?Sized>(
    src: &mut C,
    arena: &'a mut PackArena<'a>,
) -> Result<(SceneStream<'a, 'a, 'a>, SceneTargets<'a, PACK_BAND_ROWS>), LoadError> {
    use pocketsplat_core::stream::SceneStreamError;
    let PackArena {
        buffers,
        tables,
        objects,
        light,
    } = arena;
    let (targets, mem) = pack_memory(buffers, tables, objects, light);
    let stream = open_pack(src, mem).map_err(|e| {
        log!(warn, "{}: {}", crate::SCENE_FILE, shown!(e));
        match e {
            StreamRunError::Pack(SceneStreamError::Device(_)) => LoadError::Read,
            StreamRunError::PackMemory { what, need, have } => {
                LoadError::PackMemory { what, need, have }
            }
            _ => LoadError::Invalid,
        }
    })?;
    Ok((stream, targets))
}

/// Where a pack's frame stands.
enum State {
    /// Whole frames at [`PREVIEW_CUTOFF_PX`] from what is resident: `tries` drawn so far.
    Preview { tries: u32 },
    /// The 1 px frame in passes, band by band.
    Passes(BandPasses),
    /// Nothing more to draw until a button is pressed.
    Rest,
}

/// The viewer of a scene pack: its stream, the card, the panel, the band buffers and the camera.
pub struct PackViewer<'a, C: ChunkSource, P: DrawTarget<Color = Rgb565>, K: Clock> {
    stream: SceneStream<'a, 'a, 'a>,
    src: C,
    panel: P,
    clock: K,
    targets: SceneTargets<'a, PACK_BAND_ROWS>,
    orbit: Orbit,
    state: State,
    marker: Marker,
}

impl<'a, C: ChunkSource, P: DrawTarget<Color = Rgb565>, K: Clock> PackViewer<'a, C, P, K> {
    /// A viewer of `stream` (opened on `src` by [`open_scene`]) drawing into `targets` and onto
    /// `panel`, from the pack's first view.
    pub fn new(
        stream: SceneStream<'a, 'a, 'a>,
        src: C,
        panel: P,
        clock: K,
        targets: SceneTargets<'a, PACK_BAND_ROWS>,
    ) -> Self {
        // The materials' power tables, once.
        targets
            .table
            .prepare(&stream.scene().materials::<MAX_SLOTS>());
        let orbit = Orbit {
            view: pack_first_view(&stream),
        };
        PackViewer {
            stream,
            src,
            panel,
            clock,
            targets,
            orbit,
            state: State::Preview { tries: 0 },
            marker: Marker::default(),
        }
    }

    /// The camera's view now.
    pub fn view(&self) -> pocketsplat_core::camera::View {
        self.orbit.view
    }

    /// The stream (its counters).
    pub fn stream(&self) -> &SceneStream<'a, 'a, 'a> {
        &self.stream
    }

    /// The panel.
    pub fn panel(&self) -> &P {
        &self.panel
    }

    /// One turn of the loop with the buttons `held` ([`crate::Button::ALL`] order): see the
    /// module docs.
    pub fn step(&mut self, held: [bool; 6]) -> StepOutcome {
        let moved = self.orbit.step(held);
        if moved || held.contains(&true) {
            self.state = State::Preview { tries: 0 };
            return StepOutcome::Frame(self.preview(IO_BUDGET_BYTES));
        }
        match core::mem::replace(&mut self.state, State::Rest) {
            State::Rest => StepOutcome::Idle,
            State::Preview { tries } => {
                let info = self.preview(REFINE_IO_BUDGET_BYTES);
                // On to the 1 px frame once the preview misses nothing, or reads nothing more (the
                // cache cannot hold it whole, or the card fails), or has tried long enough.
                self.state =
                    if info.missing == 0 || info.read == 0 || tries + 1 >= MAX_CONVERGE_FRAMES {
                        State::Passes(BandPasses::new())
                    } else {
                        State::Preview { tries: tries + 1 }
                    };
                StepOutcome::Frame(info)
            }
            State::Passes(passes) => self.pass(passes),
        }
    }

    /// A whole frame at [`PREVIEW_CUTOFF_PX`] from what is resident, each band sent to the panel
    /// as it is drawn and followed by a read of a band's share of `budget`.
    #[inline(never)]
    fn preview(&mut self, budget: u32) -> FrameInfo {
        let t0 = self.clock.now_us();
        let (camera, options) = pack_frame_setup(&self.stream, self.orbit.view, PREVIEW_CUTOFF_PX);
        let (mut splats, mut nodes, mut missing, mut read) = (0, 0, 0, 0);
        for band in 0..PACK_BANDS {
            match draw_band(
                &mut self.stream,
                &camera,
                &options,
                &mut self.targets,
                band,
                StreamPass::Frame,
                |_| {},
            ) {
                Ok(drawn) => {
                    splats += drawn.stats.splats;
                    nodes += drawn.stats.nodes_visited;
                    missing += self.stream.missing();
                }
                Err(e) => {
                    log!(error, "frame: {}", shown!(e));
                    missing += 1;
                }
            }
            self.blit_band(band);
            read += self
                .stream
                .serve(&mut self.src, budget / PACK_BANDS as u32, false)
                .bytes;
        }
        let marker = self
            .marker
            .update(&self.stream.counters(), self.stream.inconsistent());
        if marker {
            let _ = draw_error_marker(&mut self.panel);
        }
        let info = FrameInfo {
            cutoff_px: PREVIEW_CUTOFF_PX,
            splats,
            nodes,
            missing,
            marker,
            read,
            frame_us: elapsed(t0, self.clock.now_us()),
        };
        log!(
            info,
            "scene frame: {} splats, missing {}, read {} B, {} us",
            splats,
            missing,
            read,
            info.frame_us
        );
        info
    }

    /// The next pass of the 1 px frame; a band it completes goes to the panel.
    #[inline(never)]
    fn pass(&mut self, mut passes: BandPasses) -> StepOutcome {
        let t0 = self.clock.now_us();
        let band = passes.band();
        let (camera, options) = pack_frame_setup(&self.stream, self.orbit.view, FINEST_CUTOFF_PX);
        let result = passes.pass(
            &mut self.stream,
            &mut self.src,
            &camera,
            &options,
            &mut self.targets,
            |_| {},
        );
        let (line, end) = match result {
            Ok(r) => r,
            Err(e) => {
                log!(error, "pass: {}", shown!(e));
                return StepOutcome::GaveUp(FrameInfo {
                    cutoff_px: FINEST_CUTOFF_PX,
                    splats: 0,
                    nodes: 0,
                    missing: 1,
                    marker: self.marker.up(),
                    read: 0,
                    frame_us: elapsed(t0, self.clock.now_us()),
                });
            }
        };
        let marker = self
            .marker
            .update(&self.stream.counters(), self.stream.inconsistent());
        let info = FrameInfo {
            cutoff_px: FINEST_CUTOFF_PX,
            splats: line.splats,
            nodes: line.nodes,
            missing: line.missing,
            marker,
            read: line.read,
            frame_us: elapsed(t0, self.clock.now_us()),
        };
        if matches!(end, PassEnd::Band | PassEnd::Frame) {
            self.blit_band(band);
        }
        if marker {
            let _ = draw_error_marker(&mut self.panel);
        }
        match end {
            PassEnd::Frame if line.missing == 0 => {
                log!(info, "scene refined: {} passes", passes.passes());
                StepOutcome::Refined(info)
            }
            PassEnd::Frame | PassEnd::Stuck => StepOutcome::GaveUp(info),
            PassEnd::More | PassEnd::Band if passes.passes() >= PACK_MAX_PASSES => {
                log!(warn, "refinement stopped after {} passes", passes.passes());
                StepOutcome::GaveUp(info)
            }
            PassEnd::More | PassEnd::Band => {
                self.state = State::Passes(passes);
                StepOutcome::Pass(info)
            }
        }
    }

    /// Sends the band buffer's rows to the panel as band `band`.
    fn blit_band(&mut self, band: usize) {
        let area = Rectangle::new(
            Point::new(0, (band * PACK_BAND_ROWS) as i32),
            Size::new(WIDTH as u32, PACK_BAND_ROWS as u32),
        );
        let pixels = self
            .targets
            .color
            .as_flattened()
            .iter()
            .map(|&c| Rgb565::from(RawU16::new(c)));
        if self.panel.fill_contiguous(&area, pixels).is_err() {
            log!(error, "panel write failed");
        }
    }
}
