//! Hostile files streamed (`selftest-hostile`, issue 17): the firmware opens `H000.TG`, `H001.TG`, …
//! on its FAT image in turn and streams each as the handheld would: the std view at
//! [`crate::stream::STREAM_CUTOFF_PX`] until it converges (at most [`MAX_FRAMES`]), then refined at
//! 1 px in passes until the frame is complete (or [`MAX_PASSES`], or [`MAX_IDLE_PASSES`] without an
//! intact read). One line per file ([`HostileLine`]): refused when it opens, with the reason, or
//! what the frames ended on. [`hostile_run`] is the same code on the host, so the tests compare the
//! lines and judge each against the resident reader.

use core::fmt;

use pocketsplat_core::stream::{ChunkSource, StreamError, TgStream};
use pocketsplat_core::tg::TgError;

use crate::stream::{orbit_view, StreamMemory, MAX_IDLE_PASSES, STREAM_CUTOFF_PX};
use crate::{render_stream_pass, render_stream_view, Phase, Targets};

/// Whole frames at the streamed cutoff before the refined frame.
pub const MAX_FRAMES: u32 = 16;
/// Passes of the refined frame at most.
pub const MAX_PASSES: u32 = 512;
/// Bytes read after each frame or pass.
pub const IO_BUDGET_BYTES: u32 = 32 * 1024;

/// The name of hostile file `index` on the volume (8.3): `H000.TG`…
pub fn file_name(index: u32) -> [u8; 7] {
    let d = |k: u32| b'0' + (index / k % 10) as u8;
    [b'H', d(100), d(10), d(1), b'.', b'T', b'G']
}

/// How a hostile file ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Refused when opened: the format's reason, or `None` when the medium failed.
    Refused(Option<TgError>),
    /// Opened and streamed.
    Drawn {
        /// The refined 1 px frame was completed with nothing missing.
        converged: bool,
        /// CRC of the last frame drawn (the refined one).
        crc: u32,
        /// Blocks or bricks found malformed, and descents refused as inconsistent.
        structure: u32,
        /// Descents refused because resident data disagree.
        inconsistent: u32,
        /// Whether the frame carries the read-error marker (something failed).
        marker: bool,
        /// Frames and passes drawn.
        frames: u32,
    },
}

/// `hostile <index> refused <reason>` or `hostile <index> drawn converged 0|1 crc 0x… structure S
/// inconsistent I marker 0|1 frames F`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HostileLine {
    /// Which file.
    pub index: u32,
    /// What happened.
    pub verdict: Verdict,
}

impl fmt::Display for HostileLine {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "hostile {} ", self.index)?;
        match self.verdict {
            Verdict::Refused(Some(e)) => write!(f, "refused {e}"),
            Verdict::Refused(None) => write!(f, "refused: the medium failed"),
            Verdict::Drawn {
                converged,
                crc,
                structure,
                inconsistent,
                marker,
                frames,
            } => write!(
                f,
                "drawn converged {} crc {crc:#010x} structure {structure} inconsistent \
                 {inconsistent} marker {} frames {frames}",
                u8::from(converged),
                u8::from(marker)
            ),
        }
    }
}

/// Streams hostile file `index` from `src` over `mem` into `targets` (module docs).
pub fn hostile_run<C: ChunkSource + ?Sized>(
    index: u32,
    src: &mut C,
    mem: StreamMemory<'_>,
    targets: &mut Targets<'_>,
    mut mark: impl FnMut(Phase),
) -> HostileLine {
    let refused = |e: StreamError<C::Error>| HostileLine {
        index,
        verdict: Verdict::Refused(match e {
            StreamError::Format(t) => Some(t),
            _ => None,
        }),
    };
    let mut stream = match TgStream::open(src, mem.data, mem.slots, mem.blocks) {
        Ok(s) => s,
        Err(e) => return refused(e),
    };
    let view = orbit_view(0);
    let mut frames = 0;
    let mut crc = 0;
    for _ in 0..MAX_FRAMES {
        let drawn = render_stream_view(
            &mut stream,
            view,
            f32::from(STREAM_CUTOFF_PX),
            &mut targets.streamed(),
            &mut mark,
        );
        frames += 1;
        if drawn.is_err() || stream.converged() {
            break;
        }
        stream.serve(src, IO_BUDGET_BYTES);
    }
    stream.begin_refined();
    let intact = |s: &TgStream<'_>| {
        let c = s.counters();
        c.reads - c.read_errors - c.crc_errors - c.structure_errors
    };
    let mut idle = 0;
    for pass in 0..MAX_PASSES {
        let before = intact(&stream);
        let drawn = render_stream_pass(
            &mut stream,
            view,
            1.0,
            &mut targets.streamed(),
            pass == 0,
            &mut mark,
        );
        frames += 1;
        crc = pocketsplat_core::raster::Framebuffer::new(targets.color, targets.depth).crc();
        if drawn.is_err() || (stream.refined_done() && stream.missing() == 0) {
            break;
        }
        stream.serve(src, IO_BUDGET_BYTES);
        idle = if intact(&stream) == before {
            idle + 1
        } else {
            0
        };
        if idle >= MAX_IDLE_PASSES {
            break;
        }
    }
    let c = stream.counters();
    HostileLine {
        index,
        verdict: Verdict::Drawn {
            converged: stream.refined_done() && stream.missing() == 0,
            crc,
            structure: c.structure_errors,
            inconsistent: c.inconsistent,
            marker: c.structure_errors + c.read_errors + c.crc_errors + c.inconsistent > 0,
            frames,
        },
    }
}
