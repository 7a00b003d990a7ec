//! The firmware (`boards/qemu`) under QEMU: building it for a bare-metal ARM target, booting it
//! with the runner of `.cargo/config.toml`, counting its instructions with the TCG plugin in
//! `tests/qemu-plugin/icount.c`, and comparing the frames it reports with the host's. Shared by the
//! QEMU tests (`tests/tests/qemu_*.rs`) and `arm-bench`.
//!
//! Everything is built into `target/arm`, a target dir of its own: the `cargo test` or `cargo run`
//! calling this holds the lock on `target/`. `.ci/test-all` builds the plain firmware there first.

use std::fmt::Write as _;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::Mutex;

use anyhow::{bail, ensure, Context, Result};
use pocketsplat_core::bake::BakeOptions;
use pocketsplat_core::camera::View;
use pocketsplat_core::format::FileFormat;
use pocketsplat_core::qs::write::QsBakeOptions;
use pocketsplat_core::raster::Framebuffer;
use pocketsplat_core::scene::Scene;
use pocketsplat_core::shade::ShadingTable;
use pocketsplat_core::shadow::LightFrame;
use pocketsplat_core::splat::Stats;
use pocketsplat_core::tg::write::{write_tg_as, Layout};
use pocketsplat_qemu::scene::{
    render_scene_bands, scene_frame_specs, SceneFrameReport, SceneFrameSpec, SceneTable,
    SceneTargets, SCENE_MAP_SIZE,
};
use pocketsplat_qemu::{
    render_standard_view, render_view, FrameLine, FrameReport, FrameSpec, Model, Phase, Shadows,
    Targets, BAND_ROWS, HEIGHT, SHADOW_MAP_SIZE, WIDTH,
};

use crate::elf::{Elf, Memory};
use crate::{model, workspace_root};

/// The reference target: QEMU's mps2-an385 (Cortex-M3).
pub const TARGET: &str = "thumbv7m-none-eabi";
/// The Cortex-M33 target (the Pico 2 handheld's core, with its FPU): QEMU's mps2-an505.
pub const M33_TARGET: &str = "thumbv8m.main-none-eabihf";
/// Targets `arm-bench` builds and runs: Cortex-M0+ code (on the M3 machine, which runs it), M3, M4F
/// on mps2-an386 and M33 on mps2-an505.
pub const BENCH_TARGETS: [&str; 4] = [
    TARGET,
    "thumbv6m-none-eabi",
    "thumbv7em-none-eabihf",
    M33_TARGET,
];
/// Start of RAM in the mps2-an385 map (boards/qemu/memory/an385/memory.x).
pub const RAM_ORIGIN: u32 = 0x2000_0000;
/// Start of PSRAM in the mps2-an385 map.
pub const PSRAM_ORIGIN: u32 = 0x2100_0000;
/// Start of the flash (SSRAM1's Secure alias), RAM and PSRAM in the mps2-an505 map
/// (boards/qemu/memory/an505/memory.x).
pub const AN505_ORIGINS: [u32; 3] = [0x1000_0000, 0x2800_0000, 0x8000_0000];
/// RAM of the board, bytes (memory.x).
pub const BOARD_RAM_BYTES: u64 = 4 << 20;
/// Flash of the board, bytes (memory.x).
pub const BOARD_FLASH_BYTES: u64 = 4 << 20;
/// PSRAM of the board, bytes (memory.x).
pub const BOARD_PSRAM_BYTES: u64 = 16 << 20;
/// Seconds a QEMU run of the tests may take before it counts as hung (a few times what the slowest,
/// the shadowed bunny with the counter, takes on a loaded 2-core machine).
pub const QEMU_TIMEOUT_S: u32 = 300;
/// The marker functions of the firmware, in [`Phase::ALL`] order.
pub const MARKERS: [&str; 5] = [
    "pocketsplat_mark_setup",
    "pocketsplat_mark_table",
    "pocketsplat_mark_clear",
    "pocketsplat_mark_traverse",
    "pocketsplat_mark_end",
];

/// A cleared frame's rows, on the heap (the firmware's are statics).
fn rows<const W: usize, const H: usize>() -> Box<[[u16; W]; H]> {
    vec![[0u16; W]; H]
        .into_boxed_slice()
        .try_into()
        .expect("H rows")
}

/// The host's side of a comparison: the buffers the firmware keeps in statics, on the heap, and
/// the very library call the firmware makes to fill them. The default panel's size, or a firmware
/// built for another (`Firmware::panel`).
pub struct HostFrames<const W: usize = WIDTH, const H: usize = HEIGHT> {
    color: Box<[[u16; W]; H]>,
    depth: Box<[[u16; W]; H]>,
    table: Box<ShadingTable<1>>,
    shadow: Box<[u16; SHADOW_MAP_SIZE * SHADOW_MAP_SIZE]>,
    light: Box<LightFrame>,
}

impl Default for HostFrames {
    fn default() -> Self {
        Self::new()
    }
}

impl HostFrames {
    /// Cleared buffers of the default panel's size.
    pub fn new() -> Self {
        Self::sized()
    }
}

impl<const W: usize, const H: usize> HostFrames<W, H> {
    /// Cleared buffers of `W` × `H` pixels.
    pub fn sized() -> Self {
        HostFrames {
            color: rows(),
            depth: rows(),
            table: Box::new(ShadingTable::new()),
            shadow: vec![0; SHADOW_MAP_SIZE * SHADOW_MAP_SIZE]
                .into_boxed_slice()
                .try_into()
                .expect("a square map"),
            light: Box::new(LightFrame::UNSET),
        }
    }

    /// The buffers, as the firmware's library calls take them.
    pub fn targets(&mut self) -> Targets<'_, W, H> {
        Targets {
            color: &mut self.color,
            depth: &mut self.depth,
            table: &mut self.table,
            shadow: &mut self.shadow,
            light: &mut self.light,
        }
    }

    /// Renders frame `spec` of `model` (either format) as the firmware does.
    ///
    /// # Errors
    /// When the frame cannot be set up (e.g. shadows of a QSplat model).
    pub fn render(&mut self, model: &Model<'_>, spec: FrameSpec) -> Result<FrameReport> {
        let mut targets = self.targets();
        Ok(render_standard_view(model, spec, &mut targets, |_| {})?)
    }

    /// Renders `model` seen from `view` at `cutoff_px`, without shadows, as the firmware's
    /// [`render_view`] does; returns the frame's CRC and counts.
    ///
    /// # Errors
    /// When the frame cannot be set up.
    pub fn render_view(
        &mut self,
        model: &Model<'_>,
        view: View,
        cutoff_px: f32,
    ) -> Result<(u32, Stats)> {
        let mut targets = self.targets();
        let drawn = render_view(model, view, cutoff_px, Shadows::Off, &mut targets, |_| {})?;
        let crc = Framebuffer::new(&mut self.color, &mut self.depth).crc();
        Ok((crc, drawn.stats))
    }
}

/// Serialises firmware builds: every variant builds into the same target dir and output path.
static BUILD: Mutex<()> = Mutex::new(());

/// `target/arm` of the workspace.
pub fn target_dir() -> PathBuf {
    workspace_root().join("target/arm")
}

/// A firmware variant: target triple, cargo features, and the baked model it links in (the `model`
/// feature is added when there is one).
#[derive(Clone, Debug)]
pub struct Firmware<'a> {
    /// Target triple.
    pub target: &'a str,
    /// Cargo features of pocketsplat-qemu.
    pub features: &'a [&'a str],
    /// The panel's size, `WxH` for `POCKETSPLAT_PDA_PANEL` (`None`: the default 240 × 320). Another
    /// size builds in a target dir of its own, so that switching does not rebuild the default.
    pub panel: Option<&'a str>,
    /// Baked `.tg` or `.qs` file for `POCKETSPLAT_PDA_MODEL` (a `.qs` needs the `qsplat` feature).
    pub model: Option<&'a Path>,
    /// FAT disk image for `POCKETSPLAT_PDA_IMAGE`, which the `stream` feature opens at run time
    /// (the `stream` feature is added when there is one).
    pub image: Option<&'a Path>,
}

impl Firmware<'_> {
    /// The plain firmware for the reference target with `features`.
    pub fn plain<'a>(features: &'a [&'a str]) -> Firmware<'a> {
        Firmware {
            target: TARGET,
            features,
            panel: None,
            model: None,
            image: None,
        }
    }

    /// The firmware for the reference target with `features` that streams from `image` (the
    /// `stream` feature added).
    pub fn streaming<'a>(features: &'a [&'a str], image: &'a Path) -> Firmware<'a> {
        Firmware {
            image: Some(image),
            ..Firmware::plain(features)
        }
    }

    /// Builds this firmware and runs it under QEMU: its ELF and its run, which ended through
    /// semihosting with status 0.
    ///
    /// # Errors
    /// When it does not build, QEMU cannot run it, or it exits otherwise.
    pub fn build_and_run(&self) -> Result<(PathBuf, Run)> {
        let elf = self.build()?;
        let run = self.run(&elf, None)?;
        ensure!(
            run.output.status.code() == Some(0),
            "the firmware must exit through semihosting with status 0:\n{}",
            run.transcript()
        );
        Ok((elf, run))
    }

    /// A name for this variant (`thumbv7m-none-eabi-model+shadows`).
    pub fn name(&self) -> String {
        let mut features: Vec<&str> = self.features.to_vec();
        if self.model.is_some() {
            features.insert(0, "model");
        }
        if self.image.is_some() && !features.contains(&"stream") {
            features.insert(0, "stream");
        }
        if features.is_empty() {
            features.push("default");
        }
        let panel = self.panel.map_or(String::new(), |p| format!("-{p}"));
        format!("{}-{}{panel}", self.target, features.join("+"))
    }

    /// The QEMU machine and CPU for the target: mps2-an386 (Cortex-M4F) for `thumbv7em-*hf`,
    /// mps2-an505 (Cortex-M33) for `thumbv8m.main-*`, otherwise the runner's mps2-an385.
    fn machine(&self) -> Option<(&'static str, &'static str)> {
        if self.target.starts_with("thumbv7em") {
            Some(("mps2-an386", "cortex-m4"))
        } else if self.target.starts_with("thumbv8m.main") {
            Some(("mps2-an505", "cortex-m33"))
        } else {
            None
        }
    }

    /// Builds the firmware (release) and returns a copy of the ELF that later builds do not
    /// overwrite, in `target/arm/elf/`.
    ///
    /// # Errors
    /// When cargo fails (its stderr is in the error) or the ELF cannot be copied.
    pub fn build(&self) -> Result<PathBuf> {
        let root = workspace_root();
        let target_dir = match self.panel {
            Some(panel) => target_dir().join(format!("panel-{panel}")),
            None => target_dir(),
        };
        let _guard = BUILD
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner());
        // scripts/arm-cargo: plain cargo, or cargo building `core` from source where this
        // toolchain has no prebuilt standard library for the target.
        let mut cmd = Command::new(root.join("scripts/arm-cargo"));
        cmd.current_dir(&root).env("CARGO_TARGET_DIR", &target_dir);
        cmd.args([
            "build",
            "-p",
            "pocketsplat-qemu",
            "--target",
            self.target,
            "--release",
        ]);
        match self.panel {
            Some(panel) => cmd.env("POCKETSPLAT_PDA_PANEL", panel),
            None => cmd.env_remove("POCKETSPLAT_PDA_PANEL"),
        };
        let mut features: Vec<&str> = self.features.to_vec();
        if let Some(model) = self.model {
            features.push("model");
            cmd.env("POCKETSPLAT_PDA_MODEL", model);
        } else {
            cmd.env_remove("POCKETSPLAT_PDA_MODEL");
        }
        if let Some(image) = self.image {
            if !features.contains(&"stream") {
                features.push("stream");
            }
            cmd.env("POCKETSPLAT_PDA_IMAGE", image);
        } else {
            cmd.env_remove("POCKETSPLAT_PDA_IMAGE");
        }
        if !features.is_empty() {
            cmd.args(["--features", &features.join(",")]);
        }
        let out = cmd.output().context("running cargo")?;
        ensure!(
            out.status.success(),
            "firmware build failed ({cmd:?}):\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let built = target_dir
            .join(self.target)
            .join("release/pocketsplat-qemu");
        let elf = self::target_dir()
            .join("elf")
            .join(format!("pocketsplat-qemu-{}.elf", self.name()));
        fs::create_dir_all(elf.parent().expect("a parent"))?;
        fs::copy(&built, &elf)
            .with_context(|| format!("copy {} to {}", built.display(), elf.display()))?;
        Ok(elf)
    }

    /// The QEMU command line for this firmware: the bare-metal ARM runner of `.cargo/config.toml`
    /// (so the tests run it exactly as `cargo run --target …` does), with the machine switched for
    /// an M4F target.
    pub fn qemu_command(&self) -> Vec<String> {
        let mut cmd = runner();
        if let Some((machine, cpu)) = self.machine() {
            for (flag, value) in [("-machine", machine), ("-cpu", cpu)] {
                if let Some(i) = cmd.iter().position(|a| a == flag) {
                    if let Some(v) = cmd.get_mut(i + 1) {
                        *v = value.to_owned();
                    }
                }
            }
        }
        cmd
    }

    /// Boots `elf` (built from this variant) under `timeout` [`QEMU_TIMEOUT_S`], with the
    /// instruction counter when `counter` is given.
    ///
    /// # Errors
    /// When `timeout` or QEMU cannot be started.
    pub fn run(&self, elf: &Path, counter: Option<&Counter>) -> Result<Run> {
        self.run_for(elf, counter, QEMU_TIMEOUT_S)
    }

    /// [`Firmware::run`] with a timeout of `timeout_s` seconds.
    ///
    /// # Errors
    /// When `timeout` or QEMU cannot be started.
    pub fn run_for(&self, elf: &Path, counter: Option<&Counter>, timeout_s: u32) -> Result<Run> {
        let mut qemu = self.qemu_command();
        // The runner ends with `-kernel`, for cargo to append the ELF; the plugin goes before it.
        if qemu.last().is_some_and(|a| a == "-kernel") {
            qemu.pop();
        }
        let mut cmd = Command::new("timeout");
        cmd.arg(timeout_s.to_string()).args(&qemu);
        let marks = counter.map(|c| c.args(elf)).transpose()?;
        if let Some((args, _)) = &marks {
            cmd.arg("-plugin").arg(args);
        }
        cmd.arg("-kernel").arg(elf);
        let command = format!("{cmd:?}");
        let output = cmd.output().context("timeout (coreutils) runs")?;
        let marks = match marks {
            Some((_, path)) if output.status.success() => Some(
                parse_marks(
                    &fs::read_to_string(&path).with_context(|| path.display().to_string())?,
                )
                .with_context(|| format!("{}", path.display()))?,
            ),
            _ => None,
        };
        Ok(Run {
            command,
            output,
            marks,
        })
    }
}

/// What one QEMU run printed, and what the instruction counter saw.
#[derive(Debug)]
pub struct Run {
    /// The command, for messages.
    pub command: String,
    /// Exit status, stdout, stderr.
    pub output: Output,
    /// The counter's marks and total, when it ran and QEMU exited with success.
    pub marks: Option<Marks>,
}

impl Run {
    /// Standard output as text.
    pub fn stdout(&self) -> String {
        String::from_utf8_lossy(&self.output.stdout).into_owned()
    }

    /// Everything QEMU printed, with the command and status, for failure messages.
    pub fn transcript(&self) -> String {
        format!(
            "{}\nstatus: {}\nstdout:\n{}stderr:\n{}",
            self.command,
            self.output.status,
            self.stdout(),
            String::from_utf8_lossy(&self.output.stderr)
        )
    }

    /// The rest of the first stdout line that starts with `prefix`, trimmed.
    pub fn field(&self, prefix: &str) -> Option<String> {
        self.stdout()
            .lines()
            .find_map(|l| l.strip_prefix(prefix))
            .map(|s| s.trim().to_owned())
    }

    /// A `key N` line of the firmware's memory report, as a number.
    ///
    /// # Errors
    /// When the line is missing or not a number.
    pub fn number(&self, key: &str) -> Result<u64> {
        let v = self
            .field(&format!("{key} "))
            .with_context(|| format!("no `{key} N` line in:\n{}", self.transcript()))?;
        v.parse()
            .with_context(|| format!("`{key} {v}` is not a number"))
    }
}

/// The QEMU command line of the bare-metal ARM runner in `.cargo/config.toml`.
///
/// # Panics
/// When the file or the runner line is missing (the workspace is broken).
pub fn runner() -> Vec<String> {
    let path = workspace_root().join(".cargo/config.toml");
    let config = fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let table = r#"[target.'cfg(all(target_arch = "arm", target_os = "none"))']"#;
    let line = config
        .lines()
        .skip_while(|l| l.trim() != table)
        .find_map(|l| l.trim().strip_prefix("runner"))
        .unwrap_or_else(|| panic!("no runner under {table} in {}", path.display()));
    let command = line
        .trim_start()
        .trim_start_matches('=')
        .trim()
        .trim_matches('"');
    command.split_whitespace().map(str::to_owned).collect()
}

/// Whether QEMU can be run here; `false` (after a note) only off CI.
///
/// # Panics
/// Under CI when QEMU is missing: the QEMU tests must never skip there.
pub fn have_qemu() -> bool {
    let qemu = &runner()[0];
    if Command::new(qemu)
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
    {
        return true;
    }
    assert!(
        !crate::under_ci(),
        "{qemu} is missing and CI=true: install it (.ci/test-all does)"
    );
    eprintln!("note: {qemu} not found; QEMU test skipped (run .ci/test-all, or set CI=true to make this fail)");
    false
}

/// The bunny baked at paper level 5 (tri-grid depth 6) as `pocketsplat bake` bakes it by default
/// (version 3 with bricks, what a card is streamed from) in `target/arm/models/bunny-d6.tg`, or
/// `None` off CI when the scan is missing ([`model`]).
///
/// # Errors
/// When the scan cannot be read or baked, or the file cannot be written.
pub fn baked_bunny() -> Result<Option<PathBuf>> {
    baked_bunny_in(FileFormat::TriGrid, Layout::Bricked)
}

/// The bunny baked in `format` into `target/arm/models/`: a tri-grid at paper level 5 (depth 6,
/// `bunny-d6-flash.tg`), or a QSplat file as `pocketsplat bake --format qsplat` bakes it (the default
/// options, as `tests/tests/qsplat.rs`; `bunny.qs`). `None` off CI when the scan is missing
/// ([`model`]).
///
/// Baked afresh every time (a few seconds), so the file always matches the current baker; written
/// only when its bytes change, so that cargo does not relink the firmware that includes it.
///
/// The tri-grid is the one a firmware links into flash and draws in place: without bricks
/// (`pocketsplat bake --layout unbricked`, `bunny-d6-flash.tg`), the layout the resident walk
/// draws fastest (FORMAT.md "Bricks"); [`baked_bunny`] is the streamed one.
///
/// # Errors
/// When the scan cannot be read or baked, or the file cannot be written.
pub fn baked_bunny_as(format: FileFormat) -> Result<Option<PathBuf>> {
    baked_bunny_in(format, Layout::Unbricked)
}

/// [`baked_bunny_as`] with a tri-grid in `layout`.
fn baked_bunny_in(format: FileFormat, layout: Layout) -> Result<Option<PathBuf>> {
    static BAKE: Mutex<()> = Mutex::new(());
    let Some(mesh) = model("bun_zipper.ply.gz") else {
        return Ok(None);
    };
    let _guard = BAKE.lock().unwrap_or_else(|p| p.into_inner());
    let (name, bytes) = match format {
        FileFormat::TriGrid => {
            let mesh = pocketsplat_sim::ply::load_mesh(&mesh)?;
            let (grid, bytes) = pocketsplat_sim::bake::bake_mesh(
                &mesh,
                BakeOptions { rho: 3, depth: 6 },
                12,
                false,
            )?;
            match layout {
                Layout::Bricked => ("bunny-d6.tg", bytes),
                _ => ("bunny-d6-flash.tg", write_tg_as(&grid, 12, layout)?),
            }
        }
        FileFormat::QSplat => {
            let report = pocketsplat_sim::bake::bake_qs_file(&mesh, &QsBakeOptions::default())?;
            ("bunny.qs", report.baked.bytes)
        }
        FileFormat::Pack => bail!("the bunny is a model, not a scene pack"),
    };
    let out = target_dir().join("models").join(name);
    if fs::read(&out).ok().as_deref() != Some(&bytes[..]) {
        fs::create_dir_all(out.parent().expect("a parent"))?;
        pocketsplat_sim::fsutil::write_atomic(&out, &bytes)
            .with_context(|| format!("writing {}", out.display()))?;
    }
    Ok(Some(out))
}

/// The scans the Big Scene (`boards/sim/scenes/big.toml`) places.
pub const BIG_SCENE_SCANS: [&str; 3] = [
    "bun_zipper.ply.gz",
    "dragon_vrip.ply.gz",
    "happy_vrip_res3.ply.gz",
];

/// The Big Scene baked with branching factor `rho`: 3 as `pocketsplat bake boards/sim/scenes/big.toml`
/// bakes it (the scene's tri-grid), into `target/arm/models/big.pack`; 2 as the error-vs-time report
/// bakes its octree pack (`BakeOverrides { rho: Some(2), .. }`), into
/// `target/arm/models/big-octree.pack`. `None` off CI when a scan is missing ([`model`]).
///
/// Baked afresh every time, so the pack always matches the current baker; written only when its
/// bytes change, so that cargo does not relink the firmware that includes it.
///
/// # Errors
/// When `rho` is neither 2 nor 3, the scene or a scan cannot be read or baked, or the file cannot
/// be written.
pub fn baked_big_scene(rho: u8) -> Result<Option<PathBuf>> {
    static BAKE: Mutex<()> = Mutex::new(());
    let name = match rho {
        3 => "big.pack",
        2 => "big-octree.pack",
        _ => bail!("rho {rho}: the Big Scene is baked with rho 2 (octree) or 3 (tri-grid)"),
    };
    for scan in BIG_SCENE_SCANS {
        if model(scan).is_none() {
            return Ok(None);
        }
    }
    let _guard = BAKE.lock().unwrap_or_else(|p| p.into_inner());
    let toml = workspace_root().join("boards/sim/scenes/big.toml");
    let overrides = pocketsplat_sim::scene::bake::BakeOverrides {
        rho: Some(rho),
        ..Default::default()
    };
    let baked = pocketsplat_sim::scene::bake::bake_path(&toml, &overrides)
        .with_context(|| format!("baking {} with rho {rho}", toml.display()))?;
    let out = target_dir().join("models").join(name);
    if fs::read(&out).ok().as_deref() != Some(&baked.bytes[..]) {
        fs::create_dir_all(out.parent().expect("a parent"))?;
        pocketsplat_sim::fsutil::write_atomic(&out, &baked.bytes)
            .with_context(|| format!("writing {}", out.display()))?;
    }
    Ok(Some(out))
}

/// The Big Scene as `boards/sim/scenes/big.toml` places it, baked in 1 KB blocks (its least
/// cache falls from 228 KB in 4 KB blocks to 78 KB): what a 520 KB device streams. `None` off CI
/// when a scan is missing ([`model`]).
///
/// # Errors
/// When `big.toml` no longer has 4 KB blocks to change, or the bake fails.
pub fn big_scene_in_1k_blocks() -> Result<Option<Vec<u8>>> {
    scene_in_1k_blocks("big")
}

/// The scene `boards/sim/scenes/{name}.toml` baked in 1 KB blocks (`paper`: the Big Scene at the
/// paper's scale, 32 MB, whose least caches fall from 416 KB in 4 KB blocks to 126 KB). `None` off
/// CI when a scan is missing ([`model`]).
///
/// # Errors
/// When the scene file no longer has 4 KB blocks to change, or the bake fails.
pub fn scene_in_1k_blocks(name: &str) -> Result<Option<Vec<u8>>> {
    for scan in BIG_SCENE_SCANS {
        if model(scan).is_none() {
            return Ok(None);
        }
    }
    let text = fs::read_to_string(workspace_root().join(format!("boards/sim/scenes/{name}.toml")))?;
    ensure!(
        text.contains("block_size = 4096"),
        "{name}.toml's blocks changed"
    );
    let text = text
        .replace("block_size = 4096", "block_size = 1024")
        .replace(
            "models = \"../../../../shared/models\"",
            &format!("models = {:?}", crate::models_dir().display().to_string()),
        );
    // One bake at a time: tests running at once write the same file.
    static BAKE: Mutex<()> = Mutex::new(());
    let _guard = BAKE.lock().unwrap_or_else(|p| p.into_inner());
    let dir = target_dir().join(format!("models/{name}1k"));
    fs::create_dir_all(&dir)?;
    let toml = dir.join(format!("{name}1k.toml"));
    fs::write(&toml, text)?;
    let baked = pocketsplat_sim::scene::bake::bake_path(&toml, &Default::default())
        .with_context(|| format!("baking {}", toml.display()))?;
    Ok(Some(baked.bytes))
}

/// The host's side of a scene comparison: the buffers the firmware keeps in statics for a pack, on
/// the heap, and the library call the firmware makes to fill them.
pub struct HostSceneFrames {
    color: Box<[[u16; WIDTH]; HEIGHT]>,
    depth: Box<[[u16; WIDTH]; HEIGHT]>,
    table: Box<SceneTable>,
    shadow: Vec<u16>,
    light: Box<LightFrame>,
}

impl Default for HostSceneFrames {
    fn default() -> Self {
        Self::new()
    }
}

impl HostSceneFrames {
    /// Cleared buffers, the shadow map as large as the firmware's ([`SCENE_MAP_SIZE`]²).
    pub fn new() -> Self {
        HostSceneFrames {
            color: rows(),
            depth: rows(),
            table: Box::new(SceneTable::new()),
            shadow: vec![0; SCENE_MAP_SIZE * SCENE_MAP_SIZE],
            light: Box::new(LightFrame::UNSET),
        }
    }

    /// Renders frame `spec` of `scene` as the firmware does.
    ///
    /// # Errors
    /// When the frame cannot be set up.
    pub fn render<'p>(
        &mut self,
        scene: &Scene<'p>,
        spec: SceneFrameSpec,
    ) -> Result<SceneFrameReport<'p>> {
        let (band_color, _) = self.color.split_at_mut(BAND_ROWS);
        let (band_depth, _) = self.depth.split_at_mut(BAND_ROWS);
        let mut band = vec![[0u16; WIDTH]; HEIGHT];
        let mut targets = SceneTargets {
            color: band_color.try_into().expect("BAND_ROWS rows"),
            depth: band_depth.try_into().expect("BAND_ROWS rows"),
            table: &mut self.table,
            shadow: &mut self.shadow,
            light: &mut self.light,
        };
        // The bands put together (the firmware sends them to the panel instead).
        let report = render_scene_bands(
            scene,
            spec,
            &mut targets,
            |_| {},
            |top, rows| {
                band[top..top + BAND_ROWS].copy_from_slice(rows);
            },
        )?;
        self.color.copy_from_slice(&band);
        Ok(report)
    }

    /// The colour rows of the last frame.
    pub fn color(&self) -> &[[u16; WIDTH]; HEIGHT] {
        &self.color
    }
}

/// Checks the firmware's frame lines against every frame of `scene` ([`scene_frame_specs`], in
/// order) as the host renders them; returns the host's reports.
///
/// # Errors
/// Naming the first frame that differs (view, cutoff, both lines), or missing or extra frames.
pub fn compare_scene_frames<'p>(
    stdout: &str,
    scene: &Scene<'p>,
    host: &mut HostSceneFrames,
) -> Result<Vec<SceneFrameReport<'p>>> {
    let lines: Vec<&str> = stdout
        .lines()
        .filter(|l| FrameLine::parse(l).is_some())
        .collect();
    let specs: Vec<SceneFrameSpec> = scene_frame_specs(scene).collect();
    let mut reports = Vec::with_capacity(specs.len());
    for (i, &spec) in specs.iter().enumerate() {
        let report = host.render(scene, spec)?;
        let want = report.to_string();
        let Some(got) = lines.get(i) else {
            bail!(
                "frame {i} ({} cutoff {} px): the firmware printed only {} of {} frame lines",
                report.view_name,
                spec.cutoff_px,
                lines.len(),
                specs.len()
            );
        };
        // A firmware without counts prints `splats - nodes -`: the rest must match.
        let same = match (FrameLine::parse(got), FrameLine::parse(&want)) {
            (Some(g), Some(w)) => {
                (g.view, g.cutoff_px, g.shadows, g.crc) == (w.view, w.cutoff_px, w.shadows, w.crc)
                    && g.splats.is_none_or(|n| Some(n) == w.splats)
                    && g.nodes.is_none_or(|n| Some(n) == w.nodes)
            }
            _ => false,
        };
        ensure!(
            same,
            "frame {i} ({} cutoff {} px) differs:\n  ARM:  {got}\n  host: {want}",
            report.view_name,
            spec.cutoff_px
        );
        reports.push(report);
    }
    ensure!(
        lines.len() == specs.len(),
        "the firmware printed {} frame lines, {} expected",
        lines.len(),
        specs.len()
    );
    Ok(reports)
}

/// The instruction-counting TCG plugin (`tests/qemu-plugin/icount.c`), built with the C compiler.
#[derive(Clone, Debug)]
pub struct Counter {
    /// The plugin's shared object.
    pub plugin: PathBuf,
    /// Also write a per-address profile to this file.
    pub profile: Option<PathBuf>,
    /// Limit the profile to what runs between these two marker hits (counted from 0).
    pub window: Option<(usize, usize)>,
}

impl Counter {
    /// Builds the plugin into `target/arm/qemu-plugin/icount.so` with `$CC` (default `cc`):
    /// `cc -O2 -shared -fPIC`, a fraction of a second.
    ///
    /// # Errors
    /// When the compiler is missing or fails.
    pub fn build() -> Result<Self> {
        let src = workspace_root().join("tests/qemu-plugin/icount.c");
        let dir = target_dir().join("qemu-plugin");
        fs::create_dir_all(&dir)?;
        let plugin = dir.join("icount.so");
        let cc = std::env::var_os("CC").unwrap_or_else(|| "cc".into());
        let out = Command::new(&cc)
            .args(["-O2", "-Wall", "-shared", "-fPIC", "-o"])
            .arg(&plugin)
            .arg(&src)
            .output()
            .with_context(|| {
                format!(
                    "running {} (a C compiler builds the QEMU plugin)",
                    cc.to_string_lossy()
                )
            })?;
        ensure!(
            out.status.success(),
            "building the QEMU plugin {} failed:\n{}",
            src.display(),
            String::from_utf8_lossy(&out.stderr)
        );
        Ok(Counter {
            plugin,
            profile: None,
            window: None,
        })
    }

    /// The `-plugin` argument for `elf` (marker addresses from its symbols) and the file the marks go
    /// to.
    fn args(&self, elf: &Path) -> Result<(String, PathBuf)> {
        let image = Elf::read(elf)?;
        let out = elf.with_extension("marks");
        let mut arg = format!("{},out={}", self.plugin.display(), out.display());
        for name in MARKERS {
            let addr = image
                .symbol(name)
                .with_context(|| format!("{}: no symbol {name}", elf.display()))?;
            write!(arg, ",mark={addr:#x}").expect("a String");
        }
        if let Some(p) = &self.profile {
            write!(arg, ",profile={}", p.display()).expect("a String");
        }
        if let Some((from, to)) = self.window {
            write!(arg, ",window={from}:{to}").expect("a String");
        }
        ensure!(
            !arg.contains(' '),
            "QEMU plugin arguments cannot hold spaces: {arg}"
        );
        Ok((arg, out))
    }
}

/// The counter's report: `(marker, instructions so far)` in order, and the run's total.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Marks {
    /// Each marker hit: index into [`MARKERS`], and the instructions executed before it.
    pub hits: Vec<(usize, u64)>,
    /// Instructions of the whole run.
    pub total: u64,
}

/// Parses the plugin's `mark I N` and `total N` lines.
///
/// # Errors
/// On any other line, or without a `total` line (QEMU did not exit cleanly).
pub fn parse_marks(text: &str) -> Result<Marks> {
    let mut m = Marks::default();
    let mut total = None;
    for line in text.lines() {
        let w: Vec<&str> = line.split_whitespace().collect();
        match w[..] {
            ["mark", i, n] => m.hits.push((i.parse()?, n.parse()?)),
            ["total", n] => total = Some(n.parse()?),
            _ => bail!("unexpected counter line `{line}`"),
        }
    }
    m.total =
        total.context("no `total` line: the run did not end through the plugin's exit hook")?;
    Ok(m)
}

/// Instructions of one frame, by [`Phase`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FrameCost {
    /// Camera, per-frame integer tables, light tables (soft floats).
    pub setup: u64,
    /// Shading-table update.
    pub table: u64,
    /// Clearing colour and depth.
    pub clear: u64,
    /// Traversal and raster (both passes for two-pass shadows).
    pub traverse: u64,
}

impl FrameCost {
    /// The whole frame, setup to end (the CRC after it is not part of the frame).
    pub fn frame(&self) -> u64 {
        self.setup + self.table + self.clear + self.traverse
    }
}

/// Splits the marks into one [`FrameCost`] per frame: each frame hits the markers in
/// [`Phase::ALL`] order.
///
/// # Errors
/// When the hits do not come in whole, ordered groups.
pub fn frame_costs(marks: &Marks) -> Result<Vec<FrameCost>> {
    let n = Phase::ALL.len();
    ensure!(
        marks.hits.len().is_multiple_of(n),
        "{} marker hits is not a whole number of {n}-phase frames",
        marks.hits.len()
    );
    marks
        .hits
        .chunks_exact(n)
        .enumerate()
        .map(|(f, hits)| {
            for (k, &(i, _)) in hits.iter().enumerate() {
                ensure!(
                    i == k,
                    "frame {f}: marker {} where {} was due",
                    MARKERS.get(i).unwrap_or(&"?"),
                    MARKERS[k]
                );
            }
            let d = |k: usize| hits[k + 1].1 - hits[k].1;
            Ok(FrameCost {
                setup: d(0),
                table: d(1),
                clear: d(2),
                traverse: d(3),
            })
        })
        .collect()
}

/// The frame lines the firmware printed, in order.
pub fn frame_lines(stdout: &str) -> Vec<FrameLine<'_>> {
    stdout.lines().filter_map(FrameLine::parse).collect()
}

/// Checks the firmware's frame lines against the frames `expected` (in order) as the host renders
/// them with `host`. Returns the host's reports.
///
/// # Errors
/// Naming the first frame that differs (its view, cutoff and shadow mode, and both CRCs and
/// counts), a frame line for a frame that is not expected, or missing frames.
pub fn compare_frames(
    stdout: &str,
    expected: &[FrameSpec],
    mut host: impl FnMut(FrameSpec) -> Result<FrameReport>,
) -> Result<Vec<FrameReport>> {
    let lines = frame_lines(stdout);
    let mut reports = Vec::with_capacity(expected.len());
    for (i, &spec) in expected.iter().enumerate() {
        let name = format!(
            "frame {i} ({} cutoff {} px, shadows {})",
            spec.view_name(),
            spec.cutoff_px,
            spec.shadows.name()
        );
        let Some(line) = lines.get(i) else {
            bail!(
                "{name}: the firmware printed only {} of {} frame lines",
                lines.len(),
                expected.len()
            );
        };
        ensure!(
            line.spec() == Some(spec),
            "{name}: the firmware reported `{} cutoff {} shadows {}` in its place",
            line.view,
            line.cutoff_px,
            line.shadows.name()
        );
        let report = host(spec)?;
        ensure!(
            line.matches(&report),
            "{name} differs: ARM crc {:#010x} splats {:?} nodes {:?}, host crc {:#010x} splats {} nodes {}",
            line.crc,
            line.splats,
            line.nodes,
            report.crc,
            report.stats.splats,
            report.stats.nodes_visited
        );
        reports.push(report);
    }
    ensure!(
        lines.len() == expected.len(),
        "the firmware printed {} frame lines, {} expected",
        lines.len(),
        expected.len()
    );
    Ok(reports)
}

/// Checks the firmware's memory report (`ram_bytes`, `flash_bytes`, `psram_bytes`, `stack_bytes`)
/// against its ELF's sections and the board's memories; returns the ELF's figures.
///
/// # Errors
/// When a figure is missing, disagrees with the ELF beyond alignment padding, or does not fit.
pub fn check_memory(run: &Run, elf: &Path) -> Result<(Memory, u64)> {
    let image = Elf::read(elf)?;
    // Linked for mps2-an505 when its code lies in SSRAM1's Secure alias.
    // (below 0x2000_0000, where the mps2-an385 map has nothing: its RAM and PSRAM lie above).
    let [code, ram_at, psram_at] = AN505_ORIGINS;
    let an505 = image.alloc_in(code, RAM_ORIGIN).next().is_some();
    let m = if an505 {
        image.memory(ram_at, psram_at)
    } else {
        image.memory(RAM_ORIGIN, PSRAM_ORIGIN)
    };
    let (ram, flash, psram, stack) = (
        run.number("ram_bytes")?,
        run.number("flash_bytes")?,
        run.number("psram_bytes")?,
        run.number("stack_bytes")?,
    );
    // Linker symbols against section headers: equal up to the padding between sections.
    let close = |what: &str, reported: u64, sections: u64| {
        ensure!(
            (sections..=sections + 64).contains(&reported),
            "{what}: the firmware reports {reported} bytes, its ELF sections hold {sections}"
        );
        Ok(())
    };
    close("RAM", ram, m.ram)?;
    close("flash", flash, m.flash)?;
    close("PSRAM", psram, m.psram)?;
    ensure!(
        ram + stack <= BOARD_RAM_BYTES,
        "RAM {ram} + stack {stack} bytes exceed the board's {BOARD_RAM_BYTES}"
    );
    ensure!(
        flash <= BOARD_FLASH_BYTES,
        "flash {flash} bytes exceed the board's {BOARD_FLASH_BYTES}"
    );
    ensure!(
        psram <= BOARD_PSRAM_BYTES,
        "PSRAM {psram} bytes exceed the board's {BOARD_PSRAM_BYTES}"
    );
    Ok((m, stack))
}

#[cfg(test)]
mod tests {
    use super::*;
    use pocketsplat_qemu::frame_specs_for;

    fn report(spec: FrameSpec, crc: u32) -> FrameReport {
        FrameReport {
            spec,
            crc,
            stats: Stats {
                splats: 7,
                nodes_visited: 9,
                ..Stats::default()
            },
            table_rebuilt: false,
        }
    }

    #[test]
    fn a_differing_crc_names_the_first_differing_frame() {
        let specs: Vec<_> = frame_specs_for(&Shadows::ALL).collect();
        let stdout: String = specs
            .iter()
            .enumerate()
            .map(|(i, &s)| format!("{}\n", report(s, i as u32)))
            .collect();
        let host = |bad: Option<usize>| {
            let specs = specs.clone();
            move |s: FrameSpec| {
                let i = specs.iter().position(|&x| x == s).unwrap();
                Ok(report(s, if Some(i) == bad { 0xdead } else { i as u32 }))
            }
        };
        assert_eq!(
            compare_frames(&stdout, &specs, host(None)).unwrap().len(),
            specs.len()
        );
        let err = compare_frames(&stdout, &specs, host(Some(13)))
            .unwrap_err()
            .to_string();
        assert!(
            err.starts_with(
                "frame 13 (front cutoff 2 px, shadows off) differs: ARM crc 0x0000000d"
            ),
            "{err}"
        );
        // A missing frame, a frame out of place, an extra frame.
        let short: String = stdout.lines().take(5).map(|l| format!("{l}\n")).collect();
        let err = compare_frames(&short, &specs, host(None)).unwrap_err();
        assert!(err.to_string().contains("only 5 of 48"), "{err}");
        let err = compare_frames(&stdout, &specs[1..], host(None)).unwrap_err();
        assert!(err.to_string().contains("in its place"), "{err}");
        let err = compare_frames(&stdout, &specs[..47], host(None)).unwrap_err();
        assert!(err.to_string().contains("48 frame lines, 47"), "{err}");
    }

    #[test]
    fn marks_split_into_frames_by_phase() {
        let text = "mark 0 100\nmark 1 150\nmark 2 160\nmark 3 170\nmark 4 1170\n\
                    mark 0 2000\nmark 1 2001\nmark 2 2002\nmark 3 2003\nmark 4 2004\ntotal 9999\n";
        let marks = parse_marks(text).unwrap();
        assert_eq!(marks.total, 9999);
        let costs = frame_costs(&marks).unwrap();
        assert_eq!(
            costs[0],
            FrameCost {
                setup: 50,
                table: 10,
                clear: 10,
                traverse: 1000
            }
        );
        assert_eq!(costs[0].frame(), 1070);
        assert_eq!(costs[1].frame(), 4);
        assert!(parse_marks("mark 0 1\n").is_err(), "no total");
        assert!(parse_marks("mark 0 1\nnoise\ntotal 2\n").is_err());
        let swapped = parse_marks("mark 1 1\nmark 0 2\nmark 2 3\nmark 3 4\nmark 4 5\ntotal 5\n");
        assert!(frame_costs(&swapped.unwrap()).is_err());
        let partial = parse_marks("mark 0 1\nmark 1 2\ntotal 5\n").unwrap();
        assert!(frame_costs(&partial).is_err());
    }
}
