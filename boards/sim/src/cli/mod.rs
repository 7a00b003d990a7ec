//! The command line of `pocketsplat`: one module per subcommand, each an argument struct and a
//! `run` that calls the `pocketsplat_sim` library and prints what it returns. These modules belong to
//! the binary (`main.rs`), not to the library, so nothing in the library can import them.
//!
//! Here: the argument groups several subcommands share ([`FrameArgs`]) and the value parsers that
//! map a word on the command line to a library type ([`kernel`], [`shadow_mode`]); the numbers'
//! parsers are the library's ([`pocketsplat_sim::args`]).

pub mod bake;
pub mod demo;
pub mod generate;
pub mod info;
pub mod migrate;
pub mod render;
pub mod report;
pub mod view;

use std::path::PathBuf;

use anyhow::Result;
use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
use pocketsplat_core::camera::Viewport;
use pocketsplat_core::raster::Kernel;
use pocketsplat_core::shade::ShadowMode;
use pocketsplat_sim::args::{self, Ends};
use pocketsplat_sim::render::Settings;

/// How a frame looks, for `render` and `view` alike (and for a scene pack, where each flag left
/// out keeps the pack's own value): view, field of view, kernel, light and shadows.
#[derive(Clone, Debug, clap::Args)]
pub struct FrameArgs {
    /// A standard view (std, front, close, far) or AZ,EL,DIST (degrees, degrees, radii); for
    /// `view`, the starting view.
    #[arg(long, default_value = "std", allow_hyphen_values = true)]
    pub view: String,
    /// Vertical field of view, degrees.
    #[arg(long, default_value_t = 45.0, value_parser = args::float::<f64>(0.0, 180.0, Ends::Open))]
    pub fov: f64,
    /// Splat kernel.
    #[arg(long, default_value = "square", value_parser = kernel())]
    pub kernel: Kernel,
    /// Light direction AZ,EL in degrees (world, same convention as views).
    #[arg(long, default_value = "-40,60", allow_hyphen_values = true, value_name = "AZ,EL",
          value_parser = args::light_az_el)]
    pub light: (f64, f64),
    /// Shadows from the light: off, one-pass (light-ordered traversal) or two-pass (shadow map
    /// first). For a mesh, `render`'s reference renderer casts exact shadow rays instead.
    #[arg(long, default_value = "off", value_parser = shadow_mode())]
    pub shadows: ShadowMode,
    /// The frame's size WIDTHxHEIGHT in pixels, e.g. 320x240 (landscape) or 128x160; the
    /// projection follows it, keeping the vertical field of view.
    #[arg(long, default_value = "240x320", value_name = "WxH", value_parser = args::frame_size)]
    pub size: Viewport,
    /// Draw the frame in N horizontal bands, each with a band's colour and depth buffers (what a
    /// device with less RAM than a whole frame does, e.g. the 520 KB handheld with a scene): the
    /// same frame, bit for bit, for N walks of the model.
    #[arg(long, default_value_t = 1, value_name = "N", value_parser = args::int::<u16>(1, 2048))]
    pub bands: u16,
    /// Shadow-map side in texels (a scene pack's own otherwise; 256 for a model): a smaller map
    /// is less RAM and softer, coarser shadows.
    #[arg(long, value_name = "SIDE", value_parser = args::int::<usize>(16, 4096))]
    pub shadow_map: Option<usize>,
}

impl FrameArgs {
    /// The settings of one model's frame: these, with `cutoff_px` and colour by resolution.
    ///
    /// # Errors
    /// When `--view` is neither a standard view nor `AZ,EL,DIST`.
    pub fn settings(&self, cutoff_px: f32, color_by_level: bool) -> Result<Settings> {
        Ok(Settings {
            view: args::parse_view(&self.view)?,
            fov_deg: self.fov,
            cutoff_px,
            kernel: self.kernel,
            light_az_el: self.light,
            shadows: self.shadows,
            color_by_level,
            size: self.size,
            bands: self.bands,
            shadow_map_size: self
                .shadow_map
                .unwrap_or(pocketsplat_sim::render::DEFAULT_SHADOW_MAP_SIZE),
            ..Settings::default()
        })
    }
}

/// `--kernel`: `square` or `round`, listed in `--help`.
pub fn kernel() -> impl TypedValueParser<Value = Kernel> {
    PossibleValuesParser::new(["square", "round"]).map(|name| match name.as_str() {
        "round" => Kernel::Round,
        _ => Kernel::Square,
    })
}

/// `--shadows`: `off`, `one-pass` or `two-pass` ([`ShadowMode::name`]), listed in `--help`.
pub fn shadow_mode() -> impl TypedValueParser<Value = ShadowMode> {
    PossibleValuesParser::new(ShadowMode::ALL.map(ShadowMode::name))
        .map(|name| ShadowMode::from_name(&name).unwrap_or_default())
}

/// `--format` of `bake`: `tg` or `qsplat` (also `qs`), listed in `--help`.
pub fn bake_format() -> impl TypedValueParser<Value = pocketsplat_sim::bake::BakeFormat> {
    use pocketsplat_sim::bake::BakeFormat;
    PossibleValuesParser::new(BakeFormat::ALL.map(|f| match f {
        BakeFormat::QSplat => PossibleValue::new(f.name()).alias("qs"),
        BakeFormat::TriGrid => PossibleValue::new(f.name()),
    }))
    .map(|name| BakeFormat::from_name(&name).unwrap_or_default())
}

/// A positive, finite LOD cutoff in pixels.
pub fn cutoff_px(text: &str) -> Result<f32, String> {
    args::float::<f32>(0.0, f64::from(f32::MAX), Ends::OpenLow)(text)
}

/// `$POCKETSPLAT_MODELS`, else `../shared/models`.
pub fn default_models() -> PathBuf {
    std::env::var_os("POCKETSPLAT_MODELS")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("../shared/models"))
}
