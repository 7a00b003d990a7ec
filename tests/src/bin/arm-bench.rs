//! `arm-bench`: the cost of a frame on ARM, in guest instructions counted exactly under QEMU.
//!
//! ```text
//! cargo run -p pocketsplat-tests --bin arm-bench -- [--model FILE.tg|FILE.qs]...
//!     [--format tg|qsplat|both] [--target TRIPLE]... [--no-shadows] [--json]
//!     [--profile VIEW:CUTOFF:MODE]
//! cargo run -p pocketsplat-tests --bin arm-bench -- --big-scene [--rho 2|3] [--target TRIPLE]...
//!     [--json] [--profile VIEW:CUTOFF]
//! ```
//!
//! Builds the firmware with each model linked into PSRAM (default: the bunny, baked into
//! `target/arm/models/` in the formats `--format` names, both by default: a tri-grid at paper
//! level 5, depth 6, and a QSplat file as `pocketsplat bake --format qsplat` bakes it; a `--model`
//! is told by its magic), for each target (default: thumbv7m-none-eabi on mps2-an385,
//! thumbv6m-none-eabi on the same machine, thumbv7em-none-eabihf on mps2-an386). A tri-grid is built
//! once without and once with the `shadows` feature, a QSplat file once with `qsplat` (no shadows:
//! they are tri-grid only). Each build boots in QEMU with the instruction counter
//! (`tests/qemu-plugin/icount.c`), every frame's CRC is checked against the host's, and per model a
//! table gives per frame: view, cutoff, shadows, splats, nodes, instructions (and by phase),
//! instructions per visited node and per drawn splat, and frames per second at 200 MHz assuming one
//! instruction per cycle. The unshadowed tri-grid frames come from the build without shadows (what
//! firmware for a scene without shadows runs); the shadowed ones from the shadows build. Then each
//! build's flash, RAM, stack and PSRAM, and, with both formats, the unshadowed frames side by side.
//!
//! `--big-scene` benchmarks the Big Scene instead (`boards/sim/scenes/big.toml` baked into
//! `target/arm/models/big.pack`, firmware with `scene` and `shadows`): every named view of the pack
//! at each cutoff of `SCENE_CUTOFFS_PX` (1, 2, 3, 4, 6 and 8 px) with its one-pass shadows, CRCs
//! checked against the host, instructions per frame by phase, and each frame's PSNR against the
//! same view at 1 px (the scene has no float reference render yet). The model-only options
//! (`--model`, `--format`, `--no-shadows`) are refused with it. Its `--profile` names a frame by the
//! pack's view and a cutoff (`far:8`), the shadows being the pack's. `--rho 2` bakes and runs the
//! scene's octree pack instead (`BakeOverrides { rho: Some(2), .. }`, the bytes the error-vs-time
//! report bakes for its octree frames), into `target/arm/models/big-octree.pack`; the default,
//! `--rho 3`, is the tri-grid pack above. Its CRC goes to stderr.
//!
//! `--json` prints one JSON object per frame instead, one line each, and nothing else on stdout
//! (progress goes to stderr), for the error-vs-time report to match against its own frames by
//! model file CRC, view, cutoff, shadows and kernel. The keys, for models and scenes alike:
//! `model` (file name), `model_crc` (CRC-32 of the file linked into the firmware, `0x…`), `target`,
//! `build` (the firmware variant), `view`, `cutoff_px`, `shadows` (`off`, `one-pass`, `two-pass`:
//! as the frame ran), `kernel` (`square` or `round`), `crc` (of the frame), `splats`, `nodes`,
//! `instructions` and by phase `setup`, `table`, `clear`, `traverse`, `traverse_per_node`,
//! `traverse_per_splat`, `fps_200mhz`, `flash_bytes`, `ram_bytes`; a scene's frames add
//! `psnr_vs_finest_db` (`null` for the 1 px frames themselves, which are their own reference).
//!
//! `--profile std:1:off` also profiles that frame's traversal by function, for each model (needs
//! `llvm-addr2line`, or `$LLVM_ADDR2LINE`); with `--big-scene`, `--profile far:8` profiles that
//! frame of the scene (the traversal phase holds the per-object setup too).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

use anyhow::{bail, ensure, Context, Result};
use pocketsplat_core::crc::crc32;
use pocketsplat_core::format::FileFormat;
use pocketsplat_core::raster::Kernel;
use pocketsplat_core::splat::Stats;
use pocketsplat_core::tg::Verify;
use pocketsplat_qemu::{frame_specs_for, FrameReport, FrameSpec, Model, Phase, Shadows};

/// The model formats a benchmark draws (a scene pack has its own run, `--big-scene`).
const MODEL_FORMATS: [FileFormat; 2] = [FileFormat::TriGrid, FileFormat::QSplat];
use pocketsplat_tests::arm::{
    baked_bunny_as, check_memory, compare_frames, frame_costs, have_qemu, Counter, Firmware,
    FrameCost, HostFrames, BENCH_TARGETS,
};
use pocketsplat_tests::elf::Memory;
use serde_json::json;

/// Seconds a benchmark run may take: Cortex-M0 code under the counter on a loaded machine is slow.
const TIMEOUT_S: u32 = 1800;

/// Clock for the frames-per-second column, Hz (one instruction per cycle).
const CLOCK_HZ: f64 = 200e6;

struct Args {
    models: Vec<PathBuf>,
    formats: Vec<FileFormat>,
    targets: Vec<String>,
    shadows: bool,
    json: bool,
    /// `--profile`'s frame, as given: `VIEW:CUTOFF:MODE` for models, `VIEW:CUTOFF` for the scene.
    profile: Option<String>,
    big_scene: bool,
    /// `--rho`: the Big Scene's branching factor, 3 (tri-grid, the scene's own) or 2 (octree).
    rho: Option<u8>,
    /// The model-only options given, to refuse them with `--big-scene`.
    model_only: Vec<String>,
}

const USAGE: &str = "usage: arm-bench [--model FILE.tg|FILE.qs]... [--format tg|qsplat|both] \
                     [--target TRIPLE]... [--no-shadows] [--json] [--profile VIEW:CUTOFF:MODE] | \
                     --big-scene [--rho 2|3] [--target TRIPLE]... [--json] \
                     [--profile VIEW:CUTOFF]";

fn parse_args() -> Result<Args> {
    let mut args = Args {
        models: Vec::new(),
        formats: MODEL_FORMATS.to_vec(),
        targets: Vec::new(),
        shadows: true,
        json: false,
        profile: None,
        big_scene: false,
        rho: None,
        model_only: Vec::new(),
    };
    let mut it = std::env::args().skip(1);
    while let Some(a) = it.next() {
        let mut value = || {
            it.next()
                .with_context(|| format!("{a} needs a value\n{USAGE}"))
        };
        if matches!(a.as_str(), "--model" | "--format" | "--no-shadows") {
            args.model_only.push(a.clone());
        }
        match a.as_str() {
            "--model" => args.models.push(value()?.into()),
            "--format" => {
                let v = value()?;
                args.formats = match v.as_str() {
                    "both" => MODEL_FORMATS.to_vec(),
                    name => vec![FileFormat::from_name(name)
                        .filter(|f| MODEL_FORMATS.contains(f))
                        .with_context(|| {
                            format!("--format {name}: want tg, qsplat or both\n{USAGE}")
                        })?],
                };
            }
            "--target" => args.targets.push(value()?),
            "--no-shadows" => args.shadows = false,
            "--json" => args.json = true,
            "--big-scene" => args.big_scene = true,
            "--rho" => {
                let v = value()?;
                args.rho = Some(
                    v.parse()
                        .ok()
                        .filter(|r| matches!(r, 2 | 3))
                        .with_context(|| format!("--rho {v}: want 2 or 3\n{USAGE}"))?,
                );
            }
            "--profile" => args.profile = Some(value()?),
            "-h" | "--help" => {
                println!("{USAGE}");
                std::process::exit(0);
            }
            _ => bail!("unknown argument {a}\n{USAGE}"),
        }
    }
    if args.big_scene && !args.model_only.is_empty() {
        bail!(
            "--big-scene benchmarks the Big Scene only: {} do not apply to it\n{USAGE}",
            args.model_only.join(", ")
        );
    }
    if args.rho.is_some() && !args.big_scene {
        bail!("--rho applies to --big-scene only\n{USAGE}");
    }
    if let (false, Some(p)) = (args.big_scene, &args.profile) {
        parse_frame(p)?; // refused now, not after the first build
    }
    if args.targets.is_empty() {
        args.targets = BENCH_TARGETS.map(str::to_owned).to_vec();
    }
    Ok(args)
}

/// `std:1:off` → the frame of view `std` at cutoff 1 px without shadows.
fn parse_frame(s: &str) -> Result<FrameSpec> {
    let parts: Vec<&str> = s.split(':').collect();
    let [view, cutoff, mode] = parts[..] else {
        bail!("--profile {s}: want VIEW:CUTOFF:MODE, e.g. std:1:off");
    };
    let spec = frame_specs_for(&Shadows::ALL)
        .find(|f| {
            f.view_name() == view
                && cutoff.parse() == Ok(f.cutoff_px)
                && Some(f.shadows) == Shadows::from_name(mode)
        })
        .with_context(|| format!("--profile {s}: not one of the firmware's frames"))?;
    Ok(spec)
}

/// One benchmarked frame.
struct Row {
    report: FrameReport,
    cost: FrameCost,
    build: String,
    memory: Memory,
}

/// A model and the host's buffers, to render the frames the firmware must match.
struct Host<'m> {
    model: &'m Model<'m>,
    frames: HostFrames,
}

impl Host<'_> {
    fn render(&mut self, spec: FrameSpec) -> Result<FrameReport> {
        self.frames.render(self.model, spec)
    }
}

/// Builds and runs one firmware variant with the counter; returns its frames, checked against the
/// host, with their costs, and its memory use.
fn bench(
    fw: &Firmware<'_>,
    modes: &'static [Shadows],
    counter: &Counter,
    host: &mut Host<'_>,
) -> Result<(Vec<Row>, Memory, u64)> {
    eprintln!("building and running {} …", fw.name());
    let elf = fw.build()?;
    let run = fw.run_for(&elf, Some(counter), TIMEOUT_S)?;
    ensure!(
        run.output.status.success(),
        "{} failed:\n{}",
        fw.name(),
        run.transcript()
    );
    let expected: Vec<FrameSpec> = frame_specs_for(modes).collect();
    let reports = compare_frames(&run.stdout(), &expected, |s| host.render(s))
        .with_context(|| format!("{}: frames against the host", fw.name()))?;
    let marks = run.marks.as_ref().context("no counter output")?;
    let costs = frame_costs(marks)?;
    ensure!(
        costs.len() == reports.len(),
        "one counted frame per frame line"
    );
    let (memory, stack) = check_memory(&run, &elf)?;
    let rows = reports
        .into_iter()
        .zip(costs)
        .map(|(report, cost)| Row {
            report,
            cost,
            build: fw.name(),
            memory,
        })
        .collect();
    Ok((rows, memory, stack))
}

fn per(n: u64, d: u32) -> f64 {
    if d == 0 {
        0.0
    } else {
        n as f64 / f64::from(d)
    }
}

fn print_table(target: &str, model: &str, rows: &[Row]) {
    println!("\n{target}, {model}: instructions per frame (exact, QEMU TCG plugin); fps at 200 MHz, 1 instruction/cycle");
    println!(
        "{:<6} {:>6} {:<9} {:>9} {:>9} {:>12} {:>10} {:>10} {:>9} {:>12} {:>9} {:>10} {:>8}",
        "view",
        "cutoff",
        "shadows",
        "splats",
        "nodes",
        "instr/frame",
        "setup",
        "table",
        "clear",
        "traverse",
        "/node",
        "/splat",
        "fps@200"
    );
    for r in rows {
        let (s, c) = (&r.report, &r.cost);
        println!(
            "{:<6} {:>4}px {:<9} {:>9} {:>9} {:>12} {:>10} {:>10} {:>9} {:>12} {:>9.1} {:>10.1} {:>8.2}",
            s.spec.view_name(),
            s.spec.cutoff_px,
            s.spec.shadows.name(),
            s.stats.splats,
            s.stats.nodes_visited,
            c.frame(),
            c.setup,
            c.table,
            c.clear,
            c.traverse,
            per(c.traverse, s.stats.nodes_visited),
            per(c.traverse, s.stats.splats),
            CLOCK_HZ / c.frame() as f64
        );
    }
}

/// A benchmarked frame as its JSON row tells it, a model's or a scene's.
struct JsonFrame<'a> {
    /// The model's or pack's file name.
    model: &'a str,
    /// CRC-32 of that file's bytes, the ones linked into the firmware.
    model_crc: u32,
    target: &'a str,
    build: &'a str,
    view: &'a str,
    cutoff_px: u8,
    /// As the frame ran.
    shadows: Shadows,
    kernel: Kernel,
    /// The frame's CRC.
    crc: u32,
    stats: Stats,
    cost: FrameCost,
    memory: Memory,
}

fn kernel_name(k: Kernel) -> &'static str {
    match k {
        Kernel::Square => "square",
        Kernel::Round => "round",
    }
}

/// The JSON object of one frame (the keys the module doc lists, but a scene's PSNR).
fn json_frame(f: &JsonFrame<'_>) -> serde_json::Value {
    let c = &f.cost;
    json!({
        "model": f.model,
        "model_crc": format!("{:#010x}", f.model_crc),
        "target": f.target,
        "build": f.build,
        "view": f.view,
        "cutoff_px": f.cutoff_px,
        "shadows": f.shadows.name(),
        "kernel": kernel_name(f.kernel),
        "crc": format!("{:#010x}", f.crc),
        "splats": f.stats.splats,
        "nodes": f.stats.nodes_visited,
        "instructions": c.frame(),
        "setup": c.setup,
        "table": c.table,
        "clear": c.clear,
        "traverse": c.traverse,
        "traverse_per_node": per(c.traverse, f.stats.nodes_visited),
        "traverse_per_splat": per(c.traverse, f.stats.splats),
        "fps_200mhz": CLOCK_HZ / c.frame() as f64,
        "flash_bytes": f.memory.flash,
        "ram_bytes": f.memory.ram,
    })
}

/// The JSON row of a model's frame.
fn json_row(model: &Bench, target: &str, r: &Row) -> serde_json::Value {
    let s = &r.report;
    json_frame(&JsonFrame {
        model: &model.name,
        model_crc: model.crc,
        target,
        build: &r.build,
        view: s.spec.view_name(),
        cutoff_px: s.spec.cutoff_px,
        shadows: s.spec.shadows,
        kernel: pocketsplat_qemu::views::KERNEL,
        crc: s.crc,
        stats: s.stats,
        cost: r.cost,
        memory: r.memory,
    })
}

/// Profiles the traversal phase of the `index`th frame `fw` renders (counted from 0; `what` names
/// it for the heading) by function, innermost inlined function first, with `llvm-addr2line`.
fn profile(fw: &Firmware<'_>, index: usize, what: &str, counter: &Counter) -> Result<()> {
    let elf = fw.build()?;
    let n = Phase::ALL.len();
    let phase = match std::env::var("ARM_BENCH_PHASE").as_deref() {
        Ok("setup") => Phase::Setup,
        Ok("table") => Phase::Table,
        Ok("clear") => Phase::Clear,
        _ => Phase::Traverse,
    };
    let traverse = Phase::ALL
        .iter()
        .position(|&p| p == phase)
        .expect("a phase");
    let out = elf.with_extension("profile");
    let counter = Counter {
        profile: Some(out.clone()),
        window: Some((index * n + traverse, index * n + traverse + 1)),
        ..counter.clone()
    };
    let run = fw.run_for(&elf, Some(&counter), TIMEOUT_S)?;
    ensure!(run.output.status.success(), "{}", run.transcript());
    let text = std::fs::read_to_string(&out).with_context(|| out.display().to_string())?;
    let counts: Vec<(String, u64)> = text
        .lines()
        .filter_map(|l| {
            let (a, c) = l.split_once(' ')?;
            Some((a.to_owned(), c.parse().ok()?))
        })
        .collect();
    let addr2line = std::env::var_os("LLVM_ADDR2LINE").unwrap_or_else(|| "llvm-addr2line".into());
    // `-i`: every inlined frame of each address, innermost first, as JSON (one entry per address).
    let child = Command::new(&addr2line)
        .args(["-f", "-i", "-C", "--output-style=JSON", "-e"])
        .arg(&elf)
        .args(counts.iter().map(|(a, _)| a))
        .output()
        .with_context(|| {
            format!(
                "running {} (install llvm, or set LLVM_ADDR2LINE)",
                addr2line.to_string_lossy()
            )
        })?;
    ensure!(
        child.status.success(),
        "{}",
        String::from_utf8_lossy(&child.stderr)
    );
    let answers: Vec<serde_json::Value> = serde_json::from_slice(&child.stdout)
        .context("addr2line's JSON (llvm-addr2line 13 or later)")?;
    ensure!(
        answers.len() == counts.len(),
        "addr2line answered {} of {}",
        answers.len(),
        counts.len()
    );
    // Self: by the innermost inlined function. Inclusive: each function on the inline chain (once
    // per address), so that a setup function's inlined helpers count towards it too; calls that
    // were not inlined (soft floats, memcpy) count only for themselves.
    let mut by_fn: BTreeMap<String, u64> = BTreeMap::new();
    let mut inclusive: BTreeMap<String, u64> = BTreeMap::new();
    for ((_, c), answer) in counts.iter().zip(&answers) {
        let mut chain: Vec<String> = answer["Symbol"]
            .as_array()
            .into_iter()
            .flatten()
            .map(|f| short_name(f["FunctionName"].as_str().unwrap_or("??")))
            .collect();
        if chain.is_empty() {
            chain.push("??".to_owned());
        }
        *by_fn.entry(chain[0].clone()).or_default() += c;
        chain.sort();
        chain.dedup();
        for name in chain {
            *inclusive.entry(name).or_default() += c;
        }
    }
    let total: u64 = by_fn.values().sum();
    println!(
        "\nprofile of {what} ({}), traversal phase: {total} instructions",
        fw.name()
    );
    for (heading, table, rows) in [
        ("self", by_fn, 200),
        ("inclusive of inlined", inclusive, 90),
    ] {
        println!("{heading}:");
        let mut v: Vec<_> = table.into_iter().collect();
        v.sort_by_key(|e| std::cmp::Reverse(e.1));
        for (name, c) in v.iter().take(rows) {
            println!("{:6.2}% {c:>12} {name}", 100.0 * *c as f64 / total as f64);
        }
    }
    Ok(())
}

/// A function's name without hash and generic arguments:
/// `pocketsplat_core::tg::traverse::Walker::node`.
fn short_name(name: &str) -> String {
    let short = match name.rsplit_once("::h") {
        Some((n, hash)) if hash.len() == 16 && hash.bytes().all(|b| b.is_ascii_hexdigit()) => n,
        _ => name,
    };
    strip_generics(&unescape(short))
}

/// Undoes the legacy mangling's escapes that `llvm-addr2line -C` leaves in (`$LT$` for `<`, …).
fn unescape(s: &str) -> String {
    let mut s = s
        .strip_prefix('_')
        .filter(|r| r.starts_with('$'))
        .unwrap_or(s)
        .to_owned();
    for (from, to) in [
        ("$LT$", "<"),
        ("$GT$", ">"),
        ("$C$", ","),
        ("$u20$", " "),
        ("$u7b$", "{"),
        ("$u7d$", "}"),
        ("$u5b$", "["),
        ("$u5d$", "]"),
        ("$RF$", "&"),
        ("..", "::"),
    ] {
        s = s.replace(from, to);
    }
    s
}

/// Drops generic arguments; a qualified path keeps its type (`<Walker<…>>::node` → `Walker::node`,
/// `<u32 as CastInto<f64>>::cast` → `<u32 as CastInto>::cast`).
fn strip_generics(s: &str) -> String {
    if let Some(rest) = s.strip_prefix('<') {
        let mut depth = 1;
        if let Some(close) = rest.find(|ch| {
            match ch {
                '<' => depth += 1,
                '>' => depth -= 1,
                _ => {}
            }
            depth == 0
        }) {
            let inner = strip_generics(&rest[..close]);
            let inner = if inner.contains(" as ") {
                format!("<{inner}>")
            } else {
                inner
            };
            return inner + &strip_generics(&rest[close + 1..]);
        }
    }
    let mut out = String::new();
    let mut depth = 0;
    for ch in s.chars() {
        match ch {
            '<' => depth += 1,
            '>' => depth -= 1,
            _ if depth == 0 => out.push(ch),
            _ => {}
        }
    }
    out.trim_end_matches("::").to_owned()
}

/// One model to bench: its file, bytes, their CRC-32 and its name.
struct Bench {
    path: PathBuf,
    bytes: Vec<u8>,
    crc: u32,
    name: String,
}

/// The builds of one target and model: the frames, checked, and each build's memory.
struct Benched {
    rows: Vec<Row>,
    builds: Vec<(String, Memory, u64)>,
}

/// Builds, runs and checks the firmware variants of `model` for `target`: for a tri-grid, without
/// and (with `shadows`) with the `shadows` feature; for a QSplat file, with `qsplat`. Profiles the
/// frame `args.profile` names, if any.
fn bench_model(
    target: &str,
    file: &Bench,
    model: &Model<'_>,
    args: &Args,
    counter: &Counter,
) -> Result<Benched> {
    let mut host = Host {
        model,
        frames: HostFrames::new(),
    };
    let firmware = |features| Firmware {
        target,
        features,
        panel: None,
        model: Some(&file.path),
        image: None,
    };
    const OFF: &[Shadows] = &[Shadows::Off];
    // (firmware, the modes it renders)
    let variants: Vec<(Firmware<'_>, &'static [Shadows])> = match model.format() {
        FileFormat::TriGrid if args.shadows => vec![
            (firmware(&[]), OFF),
            (firmware(&["shadows"]), &Shadows::ALL),
        ],
        FileFormat::TriGrid => vec![(firmware(&[]), OFF)],
        FileFormat::QSplat => vec![(firmware(&["qsplat"]), OFF)],
        FileFormat::Pack => bail!("a scene pack is benchmarked by --big-scene"),
    };
    let mut rows: Vec<Row> = Vec::new();
    let mut builds = Vec::new();
    for (fw, modes) in &variants {
        let (variant_rows, m, stack) = bench(fw, modes, counter, &mut host)?;
        // The unshadowed frames of a model come from its first build, the one without shadows.
        let new: Vec<Row> = variant_rows
            .into_iter()
            .filter(|r| !rows.iter().any(|have| have.report.spec == r.report.spec))
            .collect();
        rows.extend(new);
        builds.push((fw.name(), m, stack));
    }
    // View by view, then mode, then cutoff: the firmware's order.
    let order = |r: &Row| {
        frame_specs_for(&Shadows::ALL)
            .position(|s| s == r.report.spec)
            .unwrap_or(usize::MAX)
    };
    rows.sort_by_key(order);
    if let Some(spec) = args.profile.as_deref().map(parse_frame).transpose()? {
        match variants
            .iter()
            .find(|(_, modes)| modes.contains(&spec.shadows))
        {
            Some((fw, modes)) => {
                let index = frame_specs_for(modes)
                    .position(|s| s == spec)
                    .with_context(|| format!("{} does not render {spec:?}", fw.name()))?;
                let what = format!(
                    "{} {} px shadows {}",
                    spec.view_name(),
                    spec.cutoff_px,
                    spec.shadows.name()
                );
                profile(fw, index, &what, counter)?;
            }
            None => eprintln!(
                "{}: no build renders shadows {}; not profiled",
                file.name,
                spec.shadows.name()
            ),
        }
    }
    Ok(Benched { rows, builds })
}

/// The unshadowed frames of a tri-grid and a QSplat model side by side, with the QSplat frame's
/// instructions as a multiple of the tri-grid's.
fn print_side_by_side(target: &str, tg: (&str, &[Row]), qs: (&str, &[Row])) {
    println!(
        "\n{target}: tri-grid {} against QSplat {}, shadows off, instructions per frame",
        tg.0, qs.0
    );
    println!(
        "{:<6} {:>6} {:>9} {:>12} {:>9} {:>12} {:>7}",
        "view", "cutoff", "tg splats", "tg instr", "qs splats", "qs instr", "qs/tg"
    );
    for q in
        qs.1.iter()
            .filter(|r| r.report.spec.shadows == Shadows::Off)
    {
        let spec = q.report.spec;
        let Some(t) = tg.1.iter().find(|r| r.report.spec == spec) else {
            continue;
        };
        println!(
            "{:<6} {:>4}px {:>9} {:>12} {:>9} {:>12} {:>7.2}",
            spec.view_name(),
            spec.cutoff_px,
            t.report.stats.splats,
            t.cost.frame(),
            q.report.stats.splats,
            q.cost.frame(),
            q.cost.frame() as f64 / t.cost.frame() as f64
        );
    }
}

fn run() -> Result<()> {
    let args = parse_args()?;
    ensure!(
        have_qemu(),
        "qemu-system-arm is needed (apt-get install qemu-system-arm)"
    );
    if args.big_scene {
        let rho = args.rho.unwrap_or(3);
        return big_scene(rho, &args.targets, args.json, args.profile.as_deref());
    }
    let paths: Vec<PathBuf> = if args.models.is_empty() {
        args.formats
            .iter()
            .map(|&f| {
                baked_bunny_as(f)?.context("the bunny scan is missing (set POCKETSPLAT_MODELS)")
            })
            .collect::<Result<_>>()?
    } else {
        args.models
            .iter()
            .map(|m| m.canonicalize().with_context(|| m.display().to_string()))
            .collect::<Result<_>>()?
    };
    let benches: Vec<Bench> = paths
        .into_iter()
        .map(|path| {
            let bytes = std::fs::read(&path).with_context(|| path.display().to_string())?;
            let name = model_name(&path);
            let crc = crc32(&bytes);
            Ok(Bench {
                path,
                bytes,
                crc,
                name,
            })
        })
        .collect::<Result<_>>()?;
    let models: Vec<Model<'_>> = benches
        .iter()
        .map(|b| {
            Model::open(&b.bytes)
                .with_context(|| format!("{}: not a valid model", b.path.display()))
        })
        .collect::<Result<_>>()?;
    if !args.json {
        for (b, model) in benches.iter().zip(&models) {
            println!(
                "model {}: {} bytes, {}",
                b.name,
                b.bytes.len(),
                describe(model)
            );
        }
    }
    let counter = Counter::build()?;
    for target in &args.targets {
        let mut done: Vec<(&Bench, FileFormat, Vec<Row>)> = Vec::new();
        for (b, model) in benches.iter().zip(&models) {
            let Benched { rows, builds } = bench_model(target, b, model, &args, &counter)?;
            if args.json {
                for r in &rows {
                    println!("{}", json_row(b, target, r));
                }
            } else {
                print_table(target, &b.name, &rows);
                println!("all {} frames: CRC identical to the host's", rows.len());
                println!(
                    "{:<44} {:>9} {:>9} {:>7} {:>9}",
                    "build", "flash", "RAM", "stack", "PSRAM"
                );
                for (name, m, stack) in &builds {
                    println!(
                        "{name:<44} {:>9} {:>9} {stack:>7} {:>9}",
                        m.flash, m.ram, m.psram
                    );
                }
            }
            done.push((b, model.format(), rows));
        }
        let of = |f: FileFormat| done.iter().find(|(_, format, _)| *format == f);
        if let (false, Some(tg), Some(qs)) =
            (args.json, of(FileFormat::TriGrid), of(FileFormat::QSplat))
        {
            print_side_by_side(target, (&tg.0.name, &tg.2), (&qs.0.name, &qs.2));
        }
    }
    Ok(())
}

/// What the model is, for the header line.
fn describe(model: &Model<'_>) -> String {
    match model {
        Model::TriGrid(grid) => {
            let h = grid.header();
            format!(
                "tri-grid rho {} depth {}, {} samples",
                h.rho,
                h.depth,
                grid.total_samples()
            )
        }
        Model::QSplat(file) => {
            let c = file.counts();
            format!(
                "QSplat, {} trees, depth {}, {} leaves, {} interior nodes",
                c.trees, c.max_depth, c.leaves, c.interior
            )
        }
        other => format!("a {}", other.format().name()),
    }
}

fn model_name(path: &Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}

/// `--big-scene`: the Big Scene's frames, baked with branching factor `rho`, on each target, with
/// their cost and PSNR against 1 px, as a table or (`json`) one JSON object per frame; then the
/// profile of frame `profile_of` (`VIEW:CUTOFF`), if given.
fn big_scene(rho: u8, targets: &[String], json: bool, profile_of: Option<&str>) -> Result<()> {
    use pocketsplat_core::scene::{Pack, Scene};
    use pocketsplat_core::shade::rgb565_to_rgb888;
    use pocketsplat_qemu::scene::scene_frame_specs;
    use pocketsplat_sim::metrics::psnr_rgb8;
    use pocketsplat_tests::arm::{baked_big_scene, compare_scene_frames, HostSceneFrames};

    let path = baked_big_scene(rho)?.context("a scan is missing (set POCKETSPLAT_MODELS)")?;
    let bytes = std::fs::read(&path).with_context(|| path.display().to_string())?;
    let (name, model_crc) = (model_name(&path), crc32(&bytes));
    eprintln!(
        "Big Scene, rho {rho}: {} ({} B, CRC {model_crc:#010x})",
        path.display(),
        bytes.len()
    );
    let scene = Scene::open(
        Pack::open(&bytes).map_err(anyhow::Error::msg)?,
        Verify::Full,
    )?;
    let opts = scene.options();
    let kernel = opts.kernel;
    // The firmware's index of the profiled frame, found before anything is built.
    let profiled = profile_of
        .map(|p| -> Result<(usize, String)> {
            let (view, cutoff) = p
                .split_once(':')
                .with_context(|| format!("--profile {p}: want VIEW:CUTOFF, e.g. far:8"))?;
            let index = scene_frame_specs(&scene)
                .position(|s| {
                    scene.pack().view(s.view).is_some_and(|(n, _)| n == view)
                        && cutoff.parse() == Ok(s.cutoff_px)
                })
                .with_context(|| {
                    format!("--profile {p}: not one of the scene firmware's frames")
                })?;
            let what = format!(
                "Big Scene (rho {rho}) {view} {cutoff} px shadows {:?}",
                opts.shadows
            );
            Ok((index, what))
        })
        .transpose()?;
    // PSNR of each frame against its view at the finest cutoff (the first of each view).
    let mut host = HostSceneFrames::new();
    let rgb = |h: &HostSceneFrames| -> Vec<[u8; 3]> {
        h.color()
            .as_flattened()
            .iter()
            .map(|&p| rgb565_to_rgb888(p))
            .collect()
    };
    let mut psnr = Vec::new();
    let mut fine = Vec::new();
    for spec in scene_frame_specs(&scene) {
        host.render(&scene, spec)?;
        if spec.cutoff_px == pocketsplat_qemu::scene::SCENE_CUTOFFS_PX[0] {
            fine = rgb(&host);
        }
        psnr.push(psnr_rgb8(&fine, &rgb(&host)));
    }
    let counter = Counter::build()?;
    for target in targets {
        let fw = Firmware {
            target,
            features: &["scene", "shadows"],
            panel: None,
            model: Some(&path),
            image: None,
        };
        eprintln!("building and running {} …", fw.name());
        let elf = fw.build()?;
        let run = fw.run_for(&elf, Some(&counter), TIMEOUT_S)?;
        ensure!(
            run.output.status.success(),
            "{} failed:\n{}",
            fw.name(),
            run.transcript()
        );
        let reports = compare_scene_frames(&run.stdout(), &scene, &mut host)
            .with_context(|| format!("{}: frames against the host", fw.name()))?;
        let costs = frame_costs(run.marks.as_ref().context("no counter output")?)?;
        ensure!(
            costs.len() == reports.len(),
            "one counted frame per frame line"
        );
        let (memory, stack) = check_memory(&run, &elf)?;
        if json {
            let build = fw.name();
            for ((r, &cost), &p) in reports.iter().zip(&costs).zip(&psnr) {
                let mut row = json_frame(&JsonFrame {
                    model: &name,
                    model_crc,
                    target,
                    build: &build,
                    view: r.view_name,
                    cutoff_px: r.spec.cutoff_px,
                    shadows: r.shadows,
                    kernel,
                    crc: r.crc,
                    stats: r.stats,
                    cost,
                    memory,
                });
                // Infinite for the finest frame, its own reference: JSON has no infinity.
                row["psnr_vs_finest_db"] = json!(p.is_finite().then_some(p));
                println!("{row}");
            }
        } else {
            print_scene_table(target, rho, bytes.len(), &reports, &costs, &psnr);
            println!(
                "{}: flash {} B, RAM {} B + stack {stack} B, PSRAM {} B",
                fw.name(),
                memory.flash,
                memory.ram,
                memory.psram
            );
        }
        if let Some((index, what)) = &profiled {
            profile(&fw, *index, what, &counter)?;
        }
    }
    Ok(())
}

/// The Big Scene's frames on `target` as a table: cost by phase and PSNR against 1 px.
fn print_scene_table(
    target: &str,
    rho: u8,
    pack_bytes: usize,
    reports: &[pocketsplat_qemu::scene::SceneFrameReport<'_>],
    costs: &[FrameCost],
    psnr: &[f64],
) {
    println!(
        "\n{target}, Big Scene (rho {rho}, {} B pack): instructions per frame (exact, QEMU TCG \
         plugin); PSNR against the view at 1 px",
        pack_bytes
    );
    println!(
        "{:<6} {:>6} {:<9} {:>8} {:>8} {:>12} {:>9} {:>10} {:>8} {:>12} {:>8}",
        "view",
        "cutoff",
        "shadows",
        "splats",
        "nodes",
        "instr/frame",
        "setup",
        "table",
        "clear",
        "traverse",
        "PSNR dB"
    );
    for ((r, c), p) in reports.iter().zip(costs).zip(psnr) {
        println!(
            "{:<6} {:>6} {:<9} {:>8} {:>8} {:>12} {:>9} {:>10} {:>8} {:>12} {:>8.2}",
            r.view_name,
            r.spec.cutoff_px,
            r.shadows.name(),
            r.stats.splats,
            r.stats.nodes_visited,
            c.frame(),
            c.setup,
            c.table,
            c.clear,
            c.traverse,
            p
        );
    }
}

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("arm-bench: {e:#}");
            ExitCode::FAILURE
        }
    }
}
