//! `pocketsplat render INPUT -o OUT.png`: one frame of a point file, a scene pack or a mesh, read
//! whole or streamed in blocks.

use std::path::PathBuf;

use anyhow::{bail, Result};
use clap::parser::ValueSource;
use clap::ArgMatches;
use pocketsplat_sim::args;
use pocketsplat_sim::snapshot::{self, PackArgs};
use pocketsplat_sim::stream::StreamOptions;

use super::FrameArgs;

/// The arguments of `render`.
#[derive(Debug, clap::Args)]
pub struct RenderArgs {
    /// A `.tg` file, a scene pack (its light, shadows and field of view unless given here;
    /// `--view` may also name one of its views or `path@SECONDS`), or a PLY mesh for the
    /// reference renderer.
    input: PathBuf,
    /// Output PNG.
    #[arg(short, long)]
    out: PathBuf,
    #[command(flatten)]
    frame: FrameArgs,
    /// LOD cutoff: largest projected cell drawn as one splat, pixels.
    #[arg(long, default_value_t = 1.0, value_parser = super::cutoff_px)]
    cutoff: f32,
    /// A point light instead of `--light`: X,Y,Z in bounding-sphere radii from the model's
    /// centre, outside the sphere around its bounding cube. Its shadows are two-pass; shading
    /// uses the direction from the centre.
    #[arg(long, allow_hyphen_values = true, value_name = "X,Y,Z", value_parser = args::light_pos)]
    light_pos: Option<[f64; 3]>,
    /// Print one JSON object with the frame's statistics on stdout.
    #[arg(long)]
    stats_json: bool,
    /// Tint each splat by how many levels above full detail it is drawn (Streaming QSplat
    /// §4.1): white is full detail, then yellow, orange, red, magenta, blue, cyan, green for 7
    /// or more; a key is drawn in the bottom-left corner. For .tg, .qs and .pack files.
    #[arg(long)]
    color_by_level: bool,
    #[command(flatten)]
    stream: StreamArgs,
}

impl RenderArgs {
    /// The file the command reads (what its errors name).
    pub fn input(&self) -> &std::path::Path {
        &self.input
    }
}

/// Streaming: `render --stream` and its budgets.
#[derive(Debug, clap::Args)]
pub struct StreamArgs {
    /// Read the `.tg`, `.qs` or `.pack` file (a path, or an `http://` URL served with byte
    /// ranges) in blocks through a block cache, as a handheld reads an SD card, drawing frames
    /// until one misses nothing; write that frame. A pack's objects share the cache, each in
    /// proportion to its file; its shadows are drawn while the cache holds the frame's blocks
    /// (a `.tg` or `.qs` file streams without shadows).
    #[arg(long)]
    stream: bool,
    /// With `--stream`: bytes read per frame at most, 512 to 1G (K, M, G: 1024, 1024², 1024³).
    #[arg(long, default_value = "64K", requires = "stream",
          value_parser = args::size::<u32>(512, 1 << 30))]
    io_budget: u32,
    /// With `--stream`: bytes of block cache, 4K to 1G.
    #[arg(long, default_value = "16M", requires = "stream",
          value_parser = args::size::<usize>(4 << 10, 1 << 30))]
    cache: usize,
    /// With `--stream`: INPUT names a file in the root directory of the FAT volume on this disk
    /// image (an SD card's image: an MBR, then FAT16 or FAT32), read through embedded-sdmmc as the
    /// handheld reads its card; a name ending `.PAK` or `.PACK` is a scene pack.
    #[arg(long, requires = "stream", value_name = "IMAGE")]
    sd_image: Option<std::path::PathBuf>,
    /// With `--stream`: give up (an error, no output) after this many frames (1 to 1M), e.g.
    /// when the view needs more blocks at once than the cache holds.
    #[arg(long, default_value = "1000", requires = "stream",
          value_parser = args::size::<u32>(1, 1 << 20))]
    max_frames: u32,
}

/// The `render` command; `matches` are its own (`render`'s), which tell the flags given from those
/// left at their defaults.
///
/// # Errors
/// Bad arguments or input, naming the file; no output is written then.
pub fn run(args: &RenderArgs, matches: &ArgMatches) -> Result<()> {
    let (input, out) = (&args.input, &args.out);
    let stream_opts = StreamOptions {
        io_budget: args.stream.io_budget,
        cache_bytes: args.stream.cache,
        max_frames: args.stream.max_frames,
        ..StreamOptions::default()
    };
    let sd_image = args.stream.sd_image.as_deref();
    let is_pack = is_pack_input(input, args.stream.stream, sd_image.is_some());
    if args.stream.stream && args.frame.bands > 1 && !is_pack {
        bail!(
            "--bands {}: a streamed model is drawn whole (of streamed files, scene packs are \
             drawn in bands)",
            args.frame.bands
        );
    }
    if is_pack_input(input, args.stream.stream, sd_image.is_some()) {
        // A pack brings its own light, shadows and field of view: flags left out keep them.
        let given = |id: &str| matches.value_source(id) == Some(ValueSource::CommandLine);
        let f = &args.frame;
        let pack = PackArgs {
            view: f.view.clone(),
            fov: given("fov").then_some(f.fov),
            cutoff_px: args.cutoff,
            kernel: f.kernel,
            light_az_el: given("light").then_some(f.light),
            shadows: given("shadows").then_some(f.shadows),
            color_by_level: args.color_by_level,
            size: f.size,
            bands: f.bands,
            shadow_map_size: f.shadow_map,
        };
        if args.stream.stream {
            let input = input.to_string_lossy();
            return pocketsplat_sim::stream::cmd::run_pack(
                &input,
                sd_image,
                out,
                &pack,
                &stream_opts,
                args.stats_json,
            );
        }
        return report(
            snapshot::render_pack_file(input, out, &pack)?,
            args.stats_json,
        );
    }
    let mut settings = args.frame.settings(args.cutoff, args.color_by_level)?;
    settings.light_pos = args.light_pos;
    if args.stream.stream {
        let input = input.to_string_lossy();
        return pocketsplat_sim::stream::cmd::run_on(
            &input,
            sd_image,
            out,
            &settings,
            &stream_opts,
            args.stats_json,
        );
    }
    report(
        snapshot::render_file(input, out, &settings)?,
        args.stats_json,
    )
}

/// Whether `input` is a scene pack: by its first bytes for a file, by its name (`.pack`, or `.pak`
/// on an SD image) for a URL or a file on a disk image that is streamed (which is not read before
/// the stream opens it).
fn is_pack_input(input: &std::path::Path, stream: bool, on_sd: bool) -> bool {
    let text = input.to_string_lossy();
    if stream && on_sd {
        let name = text.to_ascii_lowercase();
        return name.ends_with(".pak") || name.ends_with(".pack");
    }
    if stream && pocketsplat_sim::stream::HttpSource::is_url(&text) {
        return text
            .rsplit('/')
            .next()
            .and_then(|name| name.split(['?', '#']).next())
            .is_some_and(|name| name.to_ascii_lowercase().ends_with(".pack"));
    }
    pocketsplat_sim::input::is_pack(input)
}

/// Prints the statistics (`--stats-json`, on stdout) or what was written (on stderr).
fn report(snap: snapshot::Snapshot, stats_json: bool) -> Result<()> {
    if stats_json {
        println!("{}", snap.stats);
    } else {
        eprintln!("{}", snap.summary);
    }
    Ok(())
}
