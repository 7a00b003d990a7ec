//! `firmware-sizes`: what each feature set of the firmware costs in flash, RAM and stack, the table
//! of "leave out what a scene does not need" in the README.
//!
//! ```text
//! cargo run --release -p pocketsplat-tests --bin firmware-sizes
//! ```
//!
//! Builds `pocketsplat-qemu` for thumbv7m-none-eabi (mps2-an385) once per feature set, with the
//! bunny linked into PSRAM where the set draws a model (a depth-6 tri-grid, or the QSplat file
//! `pocketsplat bake --format qsplat` makes, as `arm-bench` bakes them, or on a FAT disk image
//! that the `stream` set reads through semihosting as from an SD card), boots each in QEMU
//! (no instruction counter) so that it renders its frames and reports its memory, checks the
//! report against the ELF's sections, and prints a markdown table: flash (code, read-only data and
//! `.data`'s initial values), RAM (statics), the stack's high-water mark, and PSRAM (the model).

use std::process::ExitCode;

use anyhow::{ensure, Context, Result};
use pocketsplat_core::format::FileFormat;
use pocketsplat_tests::arm::{
    baked_big_scene, baked_bunny_as, check_memory, have_qemu, target_dir, Firmware, TARGET,
};
use pocketsplat_tests::fat::make_image;

/// Seconds a run may take (the shadows build renders 48 frames of 2 M samples).
const TIMEOUT_S: u32 = 900;

/// What a set links into PSRAM.
#[derive(Clone, Copy)]
enum Linked {
    /// The bunny in this format.
    Bunny(FileFormat),
    /// The Big Scene's pack (`boards/sim/scenes/big.toml`).
    BigScene,
}

/// One row: what the firmware includes.
struct Set {
    /// Cargo features of pocketsplat-qemu besides `model`.
    features: &'static [&'static str],
    /// The model it links in, if any.
    model: Option<Linked>,
    /// Whether it streams the bunny from a FAT image instead (the `stream` feature).
    image: bool,
    /// What a scene needing this set has.
    what: &'static str,
}

const SETS: [Set; 7] = [
    Set {
        features: &[],
        model: None,
        image: false,
        what: "no model (test pattern): runtime, raster, CRC",
    },
    Set {
        features: &[],
        model: Some(Linked::Bunny(FileFormat::TriGrid)),
        image: false,
        what: "a tri-grid, no shadows",
    },
    Set {
        features: &["shadows"],
        model: Some(Linked::Bunny(FileFormat::TriGrid)),
        image: false,
        what: "a tri-grid with one-pass and two-pass shadows (256² map)",
    },
    Set {
        features: &["qsplat"],
        model: Some(Linked::Bunny(FileFormat::QSplat)),
        image: false,
        what: "a QSplat file (tri-grid code linked too)",
    },
    Set {
        features: &["qsplat", "shadows"],
        model: Some(Linked::Bunny(FileFormat::TriGrid)),
        image: false,
        what: "both formats and shadows, drawing a tri-grid",
    },
    Set {
        features: &["stream"],
        model: None,
        image: true,
        what: "a tri-grid streamed from a FAT image (SD card) through a 64 KB block cache",
    },
    Set {
        features: &["scene", "shadows"],
        model: Some(Linked::BigScene),
        image: false,
        what: "the Big Scene's pack: six objects, eight materials, a 512² map",
    },
];

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("firmware-sizes: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn run() -> Result<()> {
    ensure!(have_qemu(), "qemu-system-arm is not installed");
    println!("| features | draws | flash | RAM | stack | PSRAM |");
    println!("|---|---|---|---|---|---|");
    for set in &SETS {
        let model = match set.model {
            Some(Linked::Bunny(format)) => Some(
                baked_bunny_as(format)?
                    .context("the bunny is not in ../shared/models (or $POCKETSPLAT_MODELS)")?,
            ),
            Some(Linked::BigScene) => Some(
                baked_big_scene(3)?.context("the Big Scene's scans are not in ../shared/models")?,
            ),
            None => None,
        };
        let image = if set.image {
            let bunny = baked_bunny_as(FileFormat::TriGrid)?
                .context("the bunny is not in ../shared/models")?;
            let dir = target_dir().join("models/sd-bunny-sizes");
            std::fs::create_dir_all(&dir)?;
            Some(make_image(&dir, &std::fs::read(&bunny)?, "BUNNY.TG"))
        } else {
            None
        };
        let fw = Firmware {
            target: TARGET,
            panel: None,
            features: set.features,
            model: model.as_deref(),
            image: image.as_deref(),
        };
        let elf = fw.build()?;
        let run = fw.run_for(&elf, None, TIMEOUT_S)?;
        ensure!(run.output.status.success(), "{}", run.transcript());
        let (m, stack) = check_memory(&run, &elf)?;
        let features = match (set.model.is_some(), set.features) {
            (false, []) => "(none)".to_owned(),
            (true, f) => ["model"]
                .iter()
                .chain(f)
                .copied()
                .collect::<Vec<_>>()
                .join(", "),
            (false, f) => f.join(", "),
        };
        println!(
            "| `{features}` | {} | {} | {} | {} | {} |",
            set.what,
            kb(m.flash),
            kb(m.ram),
            kb(stack),
            match (model.as_deref(), set.image) {
                (Some(p), _) => format!(
                    "{} ({})",
                    kb(m.psram),
                    p.file_name().unwrap_or_default().to_string_lossy()
                ),
                (None, true) => "– (reads the SD image)".to_owned(),
                (None, false) => "–".to_owned(),
            },
        );
    }
    Ok(())
}

/// Bytes as KB with one decimal (1 KB = 1024 B).
fn kb(bytes: u64) -> String {
    format!("{:.1} KB", bytes as f64 / 1024.0)
}
