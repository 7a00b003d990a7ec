//! `pocketsplat`: bake scanned meshes into point files, inspect them, render them, report on them.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use pocketsplat_core::raster::Kernel;
use pocketsplat_core::scene::ShadowMode;
use pocketsplat_sim::args::{self, Ends};
use pocketsplat_sim::{cmd, report, scene};

#[derive(Parser)]
#[command(
    name = "pocketsplat",
    version,
    about = "Hierarchical point rendering for FPU-less handhelds"
)]
struct Cli {
    /// Raise or lower input limits, NAME=SIZE[,NAME=SIZE...] (K, M, G = 1024, 1024², 1024³):
    /// file=1G (a file read whole), scene=16M (a scene file), ply=2G (a PLY once decompressed),
    /// vertices=16M and triangles=32M (declared in a PLY), bake=1G (a bake's estimated memory),
    /// stream=8G (a file read with --stream, as its header claims).
    #[arg(long, global = true, value_name = "NAME=SIZE")]
    limits: Vec<String>,
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// Bake a triangle mesh (PLY, ASCII or binary, optionally gzipped) into a point file, or a
    /// scene file (`.toml`, see boards/sim/scenes/) into a scene pack.
    Bake {
        /// The mesh, or a scene file (`.toml`: the other options are then the scene's).
        mesh: PathBuf,
        /// Output file.
        #[arg(short, long)]
        out: PathBuf,
        /// Cells per axis per subdivision: 2 (octree), 3 (tri-grid), 4, 5.
        #[arg(long, default_value_t = 3, value_parser = args::int::<u8>(2, 5))]
        rho: u8,
        /// Subdivisions (ρ^depth cells across); the paper's level L is depth L+1.
        #[arg(long, default_value_t = 6,
              value_parser = args::int::<u8>(0, u64::from(pocketsplat_core::tg::MAX_DEPTH)))]
        depth: u8,
        /// Block size in bytes (power of two, 512..=64K); each block carries a CRC.
        #[arg(long, default_value = "4096", value_parser = args::block_size)]
        block_size: u32,
        /// Output format.
        #[arg(long, default_value = "tg")]
        format: String,
        /// Bake even when the estimate of its memory is over the `bake` limit (see --limits).
        #[arg(long)]
        force: bool,
    },
    /// Describe a point file (header, samples and α per level, size per leaf sample) or a scene
    /// pack (per object what is present and what was left out, and the RAM a frame needs).
    Info {
        /// The file.
        file: PathBuf,
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Render a point file (integer renderer) or a mesh (f64 reference renderer) to a PNG.
    Render {
        /// A `.tg` file, a scene pack (its light, shadows and field of view unless given here;
        /// `--view` may also name one of its views or `path@SECONDS`), or a PLY mesh for the
        /// reference renderer.
        input: PathBuf,
        /// Output PNG.
        #[arg(short, long)]
        out: PathBuf,
        /// A standard view (std, front, close, far) or AZ,EL,DIST (degrees, degrees, radii).
        #[arg(long, default_value = "std", allow_hyphen_values = true)]
        view: String,
        /// Vertical field of view, degrees.
        #[arg(long, default_value_t = 45.0, value_parser = args::float::<f64>(0.0, 180.0, Ends::Open))]
        fov: f64,
        /// LOD cutoff: largest projected cell drawn as one splat, pixels.
        #[arg(long, default_value_t = 1.0, value_parser = cutoff_px)]
        cutoff: f32,
        /// Splat kernel.
        #[arg(long, value_enum, default_value_t = KernelArg::Square)]
        kernel: KernelArg,
        /// Light direction AZ,EL in degrees (world, same convention as views).
        #[arg(long, default_value = "-40,60", allow_hyphen_values = true)]
        light: String,
        /// A point light instead of `--light`: X,Y,Z in bounding-sphere radii from the model's
        /// centre, outside the sphere around its bounding cube. Its shadows are two-pass; shading
        /// uses the direction from the centre.
        #[arg(long, allow_hyphen_values = true, value_name = "X,Y,Z")]
        light_pos: Option<String>,
        /// Shadows from the light: none, one-pass (light-ordered traversal) or two-pass (shadow
        /// map first). For a mesh, the reference renderer casts exact shadow rays instead.
        #[arg(long, default_value = "off", value_parser = args::shadow_mode())]
        shadows: ShadowMode,
        /// Print one JSON object with the frame's statistics on stdout.
        #[arg(long)]
        stats_json: bool,
        /// Tint each splat by how many levels above full detail it is drawn (Streaming QSplat
        /// §4.1): white is full detail, then yellow, orange, red, magenta, blue, cyan, green for 7
        /// or more; a key is drawn in the bottom-left corner. For .tg, .qs and .pack files.
        #[arg(long)]
        color_by_level: bool,
        /// Read the `.tg` file (a path, or an `http://` URL served with byte ranges) in blocks
        /// through a block cache, as a handheld reads an SD card, drawing frames until one misses
        /// nothing; write that frame. Without shadows.
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
        /// With `--stream`: give up (an error, no output) after this many frames (1 to 1M), e.g.
        /// when the view needs more blocks at once than the cache holds.
        #[arg(long, default_value = "1000", requires = "stream",
              value_parser = args::size::<u32>(1, 1 << 20))]
        max_frames: u32,
    },
    /// Show a point file in a window: orbit, pan and zoom with the mouse and keys, refined to
    /// 1 px whenever nothing moves. Needs a display; without one, use `render`.
    #[command(after_help = cmd::view::KEYS_HELP)]
    View {
        /// A `.tg`, `.qs` or `.pack` file.
        input: PathBuf,
        /// Starting view: a standard view (std, front, close, far) or AZ,EL,DIST.
        #[arg(long, default_value = "std", allow_hyphen_values = true)]
        view: String,
        /// Vertical field of view, degrees.
        #[arg(long, default_value_t = 45.0, value_parser = args::float::<f64>(0.0, 180.0, Ends::Open))]
        fov: f64,
        /// LOD cutoff while moving, pixels (1..=64); idle frames refine it down to 1 px.
        #[arg(long, default_value_t = 2.0, value_parser = cutoff_px)]
        cutoff: f32,
        /// Splat kernel.
        #[arg(long, value_enum, default_value_t = KernelArg::Square)]
        kernel: KernelArg,
        /// Light direction AZ,EL in degrees.
        #[arg(long, default_value = "-40,60", allow_hyphen_values = true)]
        light: String,
        /// Shadows from the light.
        #[arg(long, default_value = "off", value_parser = args::shadow_mode())]
        shadows: ShadowMode,
        /// Window pixels per framebuffer pixel: 1, 2 or 4.
        #[arg(long, default_value_t = 2, value_parser = args::int::<usize>(1, 4))]
        scale: usize,
        /// Keep the moving cutoff when idle (no progressive refinement).
        #[arg(long)]
        no_refine: bool,
        /// Adapt the moving cutoff to hold this frame rate (QSplat's frame-rate control).
        #[arg(long, value_parser = args::float::<f32>(0.0, 1000.0, Ends::OpenLow))]
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
    },
    /// Write a `.tg` file again in another layout, every value kept (the same pixels): a
    /// version 2 file becomes version 3 with bricks, which `render --stream` reads.
    Migrate {
        /// The `.tg` file (version 1, 2 or 3).
        input: PathBuf,
        /// Output file.
        #[arg(short, long)]
        out: PathBuf,
        /// bricked (version 3, for streaming; the default), bricked:LEVEL (bricks below that
        /// level), unbricked (version 3, every level one array: what a resident walk draws
        /// fastest) or v2.
        #[arg(long, default_value = "bricked", value_parser = cmd::migrate::layout)]
        layout: pocketsplat_core::tg::write::Layout,
    },
    /// Reports measured live.
    Report {
        #[command(subcommand)]
        which: ReportKind,
    },
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum KernelArg {
    Square,
    Round,
}

#[derive(Subcommand)]
enum ReportKind {
    /// Extreme and stiff cases (cameras, scales, depths, shapes, lights, frame-rate control) against
    /// f64, each with pass/fail and its worst error; exits non-zero when a case fails. Run it in the
    /// dev profile (overflow checks on).
    Stability {
        /// Also write the page (e.g. docs/stability.md).
        #[arg(short, long)]
        out: Option<PathBuf>,
        /// Only these groups (repeatable): distance, inside, fov, axes, scale, depth, shapes, lights,
        /// lod.
        #[arg(long)]
        group: Vec<String>,
    },
    /// PSNR and coverage against the f64 reference, time and nodes per frame: standard views ×
    /// cutoffs 1, 2, 4, 8 px, tri-grid (depth 6) and octree (depth 9).
    Views {
        /// The mesh (default: the Stanford bunny in $POCKETSPLAT_MODELS or ../shared/models).
        #[arg(long)]
        mesh: Option<PathBuf>,
        /// Timed repeats per frame (the median is reported).
        #[arg(long, default_value_t = 5, value_parser = args::int::<usize>(1, 1000))]
        repeats: usize,
    },
    /// Error against run time: every view × cutoff (0.5–16 px) × method (tri-grid, octree, QSplat,
    /// brute force; a scene's tri-grid and octree packs) × kernel × shadows, measured against the
    /// f64 reference renderer. Writes DIR/results.csv, DIR/results.md and PNG plots of PSNR
    /// against time (and against ARM instructions, with --arm).
    ErrorVsTime {
        /// A mesh (PLY) or a scene file (.toml).
        scene: PathBuf,
        /// Output folder.
        #[arg(short, long)]
        out: PathBuf,
        /// The reduced sweep for CI: depth 4, cutoffs 1 and 4 px, one repeat.
        #[arg(long)]
        quick: bool,
        /// A mesh: tri-grid subdivisions (default 6, or 4 with --quick; the octree gets the
        /// nearest resolution). A scene: the deepest object (default the scene's, 4 with --quick).
        #[arg(long, value_parser = args::int::<u8>(0, u64::from(pocketsplat_core::tg::MAX_DEPTH)))]
        depth: Option<u8>,
        /// Timed repeats per frame, the median is reported (default 5, or 1 with --quick).
        #[arg(long, value_parser = args::int::<usize>(1, 1000))]
        repeats: Option<usize>,
        /// ARM instruction counts: a file `arm-bench --json` wrote (repeatable). Frames of the
        /// same baked file, view, cutoff, shadows and kernel get its count.
        #[arg(long, value_name = "FILE")]
        arm: Vec<PathBuf>,
        /// The target of the ARM counts quoted (default thumbv7m-none-eabi).
        #[arg(long, value_name = "TRIPLE")]
        arm_target: Option<String>,
        /// A further target whose counts in the --arm files are listed beside the quoted one
        /// (repeatable; e.g. thumbv6m-none-eabi, the Cortex-M0+ device build).
        #[arg(long, value_name = "TRIPLE")]
        arm_also: Vec<String>,
        /// A results.csv of an earlier run: its tri-grid frames drawn as their own curve and
        /// compared frame by frame with this run's.
        #[arg(long, value_name = "FILE")]
        baseline: Option<PathBuf>,
    },
    /// The tri-grid paper's Tables 1, 3 and 4 side by side with ours, on the Stanford scans.
    Paper {
        /// Folder with the Stanford models (default: $POCKETSPLAT_MODELS or ../shared/models).
        #[arg(long)]
        models: Option<PathBuf>,
        /// Smaller bakes only (no dragon, no paper level 5).
        #[arg(long)]
        quick: bool,
    },
    /// Shadows against exact ray-cast shadows of the mesh: per standard view of the bunny and the
    /// dragon (tri-grid depth 6), off / two-pass / one-pass: lit/shadowed disagreement, PSNR and
    /// host time per frame. Prints a markdown table.
    Shadows {
        /// Folder with the Stanford models (default: $POCKETSPLAT_MODELS or ../shared/models).
        #[arg(long)]
        models: Option<PathBuf>,
        /// Timed repeats per frame (the median is reported).
        #[arg(long, default_value_t = 5, value_parser = args::int::<usize>(1, 1000))]
        repeats: usize,
        /// The bunny only, at depth 5 (a quick check, not the paper's level 5).
        #[arg(long)]
        quick: bool,
        /// Shadow-map side, texels.
        #[arg(long, default_value_t = pocketsplat_sim::render::DEFAULT_SHADOW_MAP_SIZE,
              value_parser = args::int::<usize>(
                  pocketsplat_core::scene::MIN_MAP_SIZE as u64,
                  pocketsplat_core::scene::MAX_MAP_SIZE as u64))]
        map: usize,
    },
}

/// `$POCKETSPLAT_MODELS`, else `../shared/models`.
fn default_models() -> PathBuf {
    std::env::var_os("POCKETSPLAT_MODELS")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("../shared/models"))
}

/// A positive, finite LOD cutoff in pixels.
fn cutoff_px(text: &str) -> Result<f32, String> {
    args::float::<f32>(0.0, f64::from(f32::MAX), Ends::OpenLow)(text)
}

fn run(cli: Cli) -> anyhow::Result<()> {
    let mut limits = pocketsplat_sim::limits::Limits::DEFAULT;
    for l in &cli.limits {
        limits.apply(l)?;
    }
    pocketsplat_sim::limits::set_current(limits);
    match cli.command {
        None => pocketsplat_sim::demo::run(),
        Some(Command::Bake {
            mesh, out, force, ..
        }) if scene::cmd::is_scene_file(&mesh) => scene::cmd::bake(&mesh, &out, force),
        Some(Command::Bake {
            mesh,
            out,
            rho,
            depth,
            block_size,
            format,
            force,
        }) => cmd::bake::run(&mesh, &out, rho, depth, block_size, &format, force),
        Some(Command::Info { file, json }) if scene::cmd::is_pack(&file) => {
            scene::cmd::info(&file, json)
        }
        Some(Command::Info { file, json }) => cmd::info::run(&file, json),
        Some(Command::Migrate { input, out, layout }) => cmd::migrate::run(&input, &out, layout),
        Some(Command::Render {
            input,
            out,
            view,
            fov,
            cutoff,
            kernel,
            light,
            shadows,
            stats_json,
            stream,
            color_by_level,
            ..
        }) if scene::cmd::is_pack(&input) => {
            if stream {
                anyhow::bail!(
                    "{}: --stream reads one .tg file (a path or an http:// URL); a scene pack \
                     cannot be streamed yet: render it without --stream",
                    input.display()
                );
            }
            // A pack brings its own light, shadows and field of view: flags left out keep them.
            let given = scene::cmd::flag_given;
            let args = scene::cmd::RenderArgs {
                view,
                fov: given("--fov").then_some(fov),
                cutoff_px: cutoff,
                kernel: match kernel {
                    KernelArg::Square => Kernel::Square,
                    KernelArg::Round => Kernel::Round,
                },
                light: given("--light").then_some(light),
                shadows: given("--shadows").then_some(shadows),
                stats_json,
                color_by_level,
            };
            scene::cmd::render(&input, &out, &args)
        }
        Some(Command::Render {
            input,
            out,
            view,
            fov,
            cutoff,
            kernel,
            light,
            light_pos,
            shadows,
            stats_json,
            stream,
            io_budget,
            cache,
            max_frames,
            color_by_level,
        }) => {
            let [az, el] = args::parse_numbers::<2>("--light", &light)?;
            let settings = pocketsplat_sim::render::Settings {
                view: cmd::render::parse_view(&view)?,
                fov_deg: fov,
                cutoff_px: cutoff,
                kernel: match kernel {
                    KernelArg::Square => Kernel::Square,
                    KernelArg::Round => Kernel::Round,
                },
                light_az_el: (az, el),
                shadows,
                ..Default::default()
            };
            let settings = pocketsplat_sim::render::Settings {
                light_pos: light_pos
                    .as_deref()
                    .map(cmd::render::parse_light_pos)
                    .transpose()?,
                color_by_level,
                ..settings
            };
            if stream {
                let opts = pocketsplat_sim::stream::StreamOptions {
                    io_budget,
                    cache_bytes: cache,
                    max_frames,
                };
                let input = input.to_string_lossy();
                return pocketsplat_sim::stream::cmd::run(
                    &input, &out, &settings, &opts, stats_json,
                );
            }
            cmd::render::run(&input, &out, &settings, stats_json)
        }
        Some(Command::View {
            input,
            view,
            fov,
            cutoff,
            kernel,
            light,
            shadows,
            scale,
            no_refine,
            target_fps,
            frames,
            screenshot,
            color_by_level,
        }) => {
            let [az, el] = args::parse_numbers::<2>("--light", &light)?;
            let settings = pocketsplat_sim::render::Settings {
                view: cmd::render::parse_view(&view)?,
                fov_deg: fov,
                cutoff_px: cutoff,
                kernel: match kernel {
                    KernelArg::Square => Kernel::Square,
                    KernelArg::Round => Kernel::Round,
                },
                light_az_el: (az, el),
                shadows,
                color_by_level,
                ..Default::default()
            };
            let opts = cmd::view::ViewOptions {
                settings,
                scale,
                refine: !no_refine,
                target_fps,
                frames,
                screenshot,
            };
            cmd::view::run(&input, &opts)
        }
        Some(Command::Report {
            which: ReportKind::Stability { out, group },
        }) => report::stability::command(out.as_deref(), &group),
        Some(Command::Report {
            which:
                ReportKind::ErrorVsTime {
                    scene,
                    out,
                    quick,
                    depth,
                    repeats,
                    arm,
                    arm_target,
                    arm_also,
                    baseline,
                },
        }) => {
            let opts = report::error_vs_time::Options {
                quick,
                depth,
                repeats,
                arm,
                arm_target,
                arm_also,
                baseline,
            };
            for path in report::error_vs_time::run(&scene, &out, &opts)? {
                println!("{}", path.display());
            }
            Ok(())
        }
        Some(Command::Report {
            which: ReportKind::Paper { models, quick },
        }) => {
            print!(
                "{}",
                report::paper::run(&models.unwrap_or_else(default_models), quick)?
            );
            Ok(())
        }
        Some(Command::Report {
            which: ReportKind::Views { mesh, repeats },
        }) => {
            let mesh = mesh.unwrap_or_else(|| default_models().join("bun_zipper.ply.gz"));
            print!("{}", report::views::run(&mesh, repeats)?);
            Ok(())
        }
        Some(Command::Report {
            which:
                ReportKind::Shadows {
                    models,
                    repeats,
                    quick,
                    map,
                },
        }) => {
            let models = models.unwrap_or_else(default_models);
            print!("{}", report::shadows::run(&models, repeats, quick, map)?);
            Ok(())
        }
    }
}

/// `pocketsplat info x.tg | head`: a reader that closes the pipe early is not a crash. Rust ignores
/// SIGPIPE, so `print!` panics on the broken pipe instead; end quietly with the status a shell
/// gives a process killed by SIGPIPE (128 + 13), as C tools end.
fn quiet_broken_pipe() {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let payload = info.payload();
        let msg = payload
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| payload.downcast_ref::<&str>().copied())
            .unwrap_or_default();
        if msg.starts_with("failed printing to stdout") && msg.contains("Broken pipe") {
            std::process::exit(141);
        }
        default(info);
    }));
}

/// The command line, or exit with clap's message. A number refused by one of [`args`]'s parsers
/// is reported as `error: --cache 100000M: must be from 4K to 1G` (the option, the value, why).
fn parse_cli() -> Cli {
    use clap::error::{ContextKind, ErrorKind};
    match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if e.kind() == ErrorKind::ValueValidation => {
            let arg = e.get(ContextKind::InvalidArg).map(ToString::to_string);
            let value = e.get(ContextKind::InvalidValue).map(ToString::to_string);
            let why = std::error::Error::source(&e).map(ToString::to_string);
            match (arg, value, why) {
                (Some(arg), Some(value), Some(why)) => {
                    let option = arg.split_whitespace().next().unwrap_or(&arg).to_owned();
                    eprintln!("error: {option} {value}: {why}");
                    std::process::exit(2);
                }
                _ => e.exit(),
            }
        }
        Err(e) => e.exit(),
    }
}

fn main() -> ExitCode {
    quiet_broken_pipe();
    match run(parse_cli()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
