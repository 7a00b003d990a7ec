//! `pocketsplat view INPUT`: a point file in a window.

use std::path::PathBuf;

use anyhow::Result;
use pocketsplat_sim::args;
use pocketsplat_sim::view::ViewOptions;

use super::FrameArgs;

/// The arguments of `view`.
#[derive(Debug, clap::Args)]
pub struct ViewArgs {
    /// A `.tg`, `.qs` or `.pack` file.
    input: PathBuf,
    #[command(flatten)]
    frame: FrameArgs,
    /// LOD cutoff while moving, pixels (1..=64); idle frames refine it down to 1 px.
    #[arg(long, default_value_t = 2.0, value_parser = super::cutoff_px)]
    cutoff: f32,
    /// Window pixels per framebuffer pixel: 1, 2 or 4.
    #[arg(long, default_value_t = 2, value_parser = args::int::<usize>(1, 4))]
    scale: usize,
    /// Keep the moving cutoff when idle (no progressive refinement).
    #[arg(long)]
    no_refine: bool,
    /// Adapt the moving cutoff to hold this frame rate (QSplat's frame-rate control).
    #[arg(long, value_parser = args::float::<f32>(0.0, 1000.0, args::Ends::OpenLow))]
    target_fps: Option<f32>,
    /// Quit after N window updates (60 per second at most); for scripts and tests.
    #[arg(long, value_name = "N", value_parser = args::size::<u64>(1, 1 << 30))]
    frames: Option<u64>,
    /// Write the frame on screen (HUD included) as a PNG when fully refined, and at exit.
    #[arg(long, value_name = "PNG")]
    screenshot: Option<PathBuf>,
    /// Start with colour by resolution on (the `V` key toggles it).
    #[arg(long)]
    color_by_level: bool,
}

impl ViewArgs {
    /// The file the command reads (what its errors name).
    pub fn input(&self) -> &std::path::Path {
        &self.input
    }
}

/// The `view` command.
///
/// # Errors
/// As [`pocketsplat_sim::view::run`], and a bad `--view`.
pub fn run(args: ViewArgs) -> Result<()> {
    let opts = ViewOptions {
        settings: args.frame.settings(args.cutoff, args.color_by_level)?,
        scale: args.scale,
        refine: !args.no_refine,
        target_fps: args.target_fps,
        frames: args.frames,
        screenshot: args.screenshot,
    };
    pocketsplat_sim::view::run(&args.input, &opts)
}
