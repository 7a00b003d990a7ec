//! `pocketsplat`: bake scanned meshes into point files, inspect them, render them, report on them.
//!
//! The command line only: the argument structs of each subcommand (in [`cli`]) and calls into the
//! `pocketsplat_sim` library, which does the work. The library never imports this binary's modules.

mod cli;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{ArgMatches, CommandFactory, FromArgMatches, Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "pocketsplat",
    version,
    about = "Hierarchical point rendering for FPU-less handhelds"
)]
struct Cli {
    /// Memory a bake may use (K, M, G = 1024, 1024², 1024³; default: half the machine's). A mesh
    /// whose bake needs more bakes out of core, in pieces through spill files; the limits on
    /// counts follow: vertices=MEMORY/64, triangles=MEMORY/16, ply=4×MEMORY (at least 2G).
    #[arg(long, global = true, value_name = "SIZE", value_parser = pocketsplat_sim::args::size::<u64>(1 << 20, 1 << 46))]
    memory: Option<u64>,
    /// Raise or lower input limits, NAME=SIZE[,NAME=SIZE...] (K, M, G = 1024, 1024², 1024³):
    /// file=1G (a file read whole), scene=16M (a scene file), ply (a PLY once decompressed),
    /// vertices and triangles (declared in a PLY), bake (= --memory), stream=8G (a file read with
    /// --stream, as its header claims).
    #[arg(long, global = true, value_name = "NAME=SIZE")]
    limits: Vec<String>,
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// Bake a triangle mesh (PLY, ASCII or binary, optionally gzipped) into a point file, or a
    /// scene file (`.toml`, see boards/sim/scenes/) into a scene pack.
    Bake(cli::bake::BakeArgs),
    /// Write a large test scan: a displaced sphere of about N triangles sampled as a scanner's
    /// range grids are, as binary PLY (for measuring bakes; never commit its output).
    Generate(cli::generate::GenerateArgs),
    /// Describe a point file (header, samples and α per level, size per leaf sample) or a scene
    /// pack (per object what is present and what was left out, and the RAM a frame needs).
    Info(cli::info::InfoArgs),
    /// Write a `.tg` file again in another layout, every value kept (the same pixels): a version 2
    /// file becomes version 3 with bricks, which `render --stream` reads.
    Migrate(cli::migrate::MigrateArgs),
    /// Render a point file (integer renderer) or a mesh (f64 reference renderer) to a PNG.
    Render(cli::render::RenderArgs),
    /// Show a point file in a window: orbit, pan and zoom with the mouse and keys, refined to
    /// 1 px whenever nothing moves. Needs a display; without one, use `render`.
    #[command(after_help = pocketsplat_sim::view::KEYS_HELP)]
    View(cli::view::ViewArgs),
    /// Reports measured live.
    Report {
        #[command(subcommand)]
        which: cli::report::ReportKind,
    },
}

impl Command {
    /// The file the command is about, which its errors name: the input it reads (for a report,
    /// the mesh, scene or folder of models it measures).
    fn subject(&self) -> Option<PathBuf> {
        match self {
            Command::Bake(a) => Some(a.input().to_path_buf()),
            Command::Info(a) => Some(a.input().to_path_buf()),
            Command::Migrate(a) => Some(a.input().to_path_buf()),
            Command::Render(a) => Some(a.input().to_path_buf()),
            Command::View(a) => Some(a.input().to_path_buf()),
            Command::Generate(a) => Some(a.output().to_path_buf()),
            Command::Report { which } => which.subject(),
        }
    }
}

/// Runs the command; `matches` are the whole command line's, parsed into `cli`. An error of a
/// command that does not name the file it is about gets its name in front (issue 33: every error
/// names its file; the readers and writers name it themselves, this catches the rest).
fn run(cli: Cli, matches: &ArgMatches) -> anyhow::Result<()> {
    let memory = cli
        .memory
        .unwrap_or_else(pocketsplat_sim::bake::budget::default_budget);
    let mut limits = pocketsplat_sim::limits::Limits::for_memory(memory);
    for l in &cli.limits {
        limits.apply(l)?;
    }
    pocketsplat_sim::limits::set_current(limits);
    pocketsplat_sim::fsutil::remove_on_interrupt();
    let subject = cli.command.as_ref().and_then(Command::subject);
    run_command(cli.command, matches).map_err(|e| match subject {
        Some(path) if !format!("{e:#}").contains(&path.display().to_string()) => {
            e.context(path.display().to_string())
        }
        _ => e,
    })
}

/// Runs the subcommand (the demo without one).
fn run_command(command: Option<Command>, matches: &ArgMatches) -> anyhow::Result<()> {
    match command {
        None => cli::demo::run(),
        Some(Command::Bake(args)) => cli::bake::run(&args),
        Some(Command::Generate(args)) => cli::generate::run(&args),
        Some(Command::Info(args)) => cli::info::run(&args),
        Some(Command::Migrate(args)) => cli::migrate::run(&args),
        Some(Command::Render(args)) => {
            let sub = matches
                .subcommand_matches("render")
                .expect("the render subcommand's arguments");
            cli::render::run(&args, sub)
        }
        Some(Command::View(args)) => cli::view::run(args),
        Some(Command::Report { which }) => cli::report::run(which),
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

/// The command line, parsed and as matched (which tells a flag given from one left at its
/// default), or exit with clap's message. A number refused by one of
/// [`pocketsplat_sim::args`]'s parsers is reported as `error: --cache 100000M: must be from 4K to
/// 1G` (the option, the value, why).
fn parse_cli() -> (Cli, ArgMatches) {
    use clap::error::{ContextKind, ErrorKind};
    let parsed = Cli::command()
        .try_get_matches()
        .and_then(|m| Ok((Cli::from_arg_matches(&m)?, m)));
    match parsed {
        Ok(parsed) => parsed,
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
    let (cli, matches) = parse_cli();
    match run(cli, &matches) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
