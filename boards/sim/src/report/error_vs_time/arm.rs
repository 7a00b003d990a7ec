//! ARM instructions per frame for the report, read from what `arm-bench --json` printed.
//!
//! `arm-bench` (`tests/src/bin/arm-bench.rs`) builds the firmware with a baked file linked in, runs
//! it under QEMU with an instruction counter and prints one JSON object per frame. Each object names
//! the file by the CRC-32 of its bytes (`model_crc`), and the frame by view, cutoff, shadows and
//! kernel. The report attaches a count to a row of its own when the row's method drew the same
//! bytes ([`super::Method::file_crc`]) with the same view, cutoff, shadows and kernel: the host
//! frame and the ARM frame are then the same frame (the QEMU tests check their CRCs are equal).
//!
//! A count file that names a file none of the report's methods baked is an error, not a silently
//! empty column: the bake changed since `arm-bench` ran, or the file is for another subject.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use serde::Deserialize;

/// The target the report quotes by default (the one the README's ARM figures are for).
pub const DEFAULT_TARGET: &str = "thumbv7m-none-eabi";

/// One line of `arm-bench --json`: the fields the report reads (others are ignored).
#[derive(Clone, Debug, Deserialize)]
struct Line {
    model: String,
    model_crc: String,
    target: String,
    view: String,
    cutoff_px: f64,
    shadows: String,
    kernel: String,
    instructions: u64,
}

/// What identifies a frame across the host and ARM: the file, the view, cutoff, shadows, kernel.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
struct Key {
    crc: u32,
    view: String,
    /// Cutoff as written by `f32`'s `Display` (1, 0.5, …), so 1 and 1.0 are the same key.
    cutoff: String,
    shadows: String,
    kernel: String,
}

/// Instruction counts of one target, from one or more `arm-bench --json` files.
#[derive(Clone, Debug, Default)]
pub struct ArmCounts {
    target: String,
    counts: BTreeMap<Key, u64>,
    /// Each file named: `(crc, model name, count file it came from)`.
    models: Vec<(u32, String, PathBuf)>,
    files: Vec<PathBuf>,
}

fn parse_crc(text: &str) -> Option<u32> {
    u32::from_str_radix(text.trim_start_matches("0x"), 16).ok()
}

impl ArmCounts {
    /// No counts (the column stays empty).
    pub fn none() -> Self {
        Self::default()
    }

    /// Reads `files` (JSON objects, one per line), keeping the lines of `target`.
    ///
    /// # Errors
    /// A file that cannot be read, a line that is not an `arm-bench` frame, or no frame of `target`
    /// in a file; each names the file and line.
    pub fn load(files: &[PathBuf], target: &str) -> Result<Self> {
        Self::read(files, target, true)
    }

    /// [`ArmCounts::load`] for a target that only some of `files` were run for (a second device
    /// listed beside the quoted one): files without it are skipped.
    ///
    /// # Errors
    /// As [`ArmCounts::load`], and when no file has a frame of `target`.
    pub fn load_where_present(files: &[PathBuf], target: &str) -> Result<Self> {
        let out = Self::read(files, target, false)?;
        if out.is_empty() {
            bail!("no frame of target {target} in the ARM count files (run arm-bench with --target {target})");
        }
        Ok(out)
    }

    fn read(files: &[PathBuf], target: &str, every_file: bool) -> Result<Self> {
        let mut out = Self {
            target: target.to_owned(),
            files: files.to_vec(),
            ..Self::default()
        };
        for file in files {
            let text = std::fs::read_to_string(file)
                .with_context(|| format!("cannot read ARM counts {}", file.display()))?;
            let mut kept = 0;
            for (n, line) in text.lines().enumerate() {
                if line.trim().is_empty() {
                    continue;
                }
                let l: Line = serde_json::from_str(line).with_context(|| {
                    format!(
                        "{} line {}: not a frame of `arm-bench --json`",
                        file.display(),
                        n + 1
                    )
                })?;
                let Some(crc) = parse_crc(&l.model_crc) else {
                    bail!(
                        "{} line {}: model_crc {:?} is not a hexadecimal CRC-32",
                        file.display(),
                        n + 1,
                        l.model_crc
                    );
                };
                if l.target != target {
                    continue;
                }
                kept += 1;
                if !out.models.iter().any(|m| m.0 == crc) {
                    out.models.push((crc, l.model.clone(), file.clone()));
                }
                // The first count of a frame wins: arm-bench prints a tri-grid's unshadowed frames
                // from the build without shadows first (what firmware for such a scene runs).
                out.counts
                    .entry(Key {
                        crc,
                        view: l.view,
                        cutoff: (l.cutoff_px as f32).to_string(),
                        shadows: l.shadows,
                        kernel: l.kernel,
                    })
                    .or_insert(l.instructions);
            }
            if kept == 0 && every_file {
                bail!(
                    "{}: no frame of target {target} (pass --arm-target, or run arm-bench with \
                     --target {target})",
                    file.display()
                );
            }
        }
        Ok(out)
    }

    /// Whether any count was read.
    pub fn is_empty(&self) -> bool {
        self.counts.is_empty()
    }

    /// The target the counts are for.
    pub fn target(&self) -> &str {
        &self.target
    }

    /// The count files read.
    pub fn files(&self) -> &[PathBuf] {
        &self.files
    }

    /// The count of a frame, if `arm-bench` ran it.
    pub fn get(
        &self,
        crc: u32,
        view: &str,
        cutoff_px: f32,
        shadows: &str,
        kernel: &str,
    ) -> Option<u64> {
        self.counts
            .get(&Key {
                crc,
                view: view.to_owned(),
                cutoff: cutoff_px.to_string(),
                shadows: shadows.to_owned(),
                kernel: kernel.to_owned(),
            })
            .copied()
    }

    /// These counts with every frame of a file whose CRC is `from` counted as `to`'s: the same
    /// samples in another byte layout (a report's bricked tri-grid and the unbricked rewrite the
    /// firmware links into flash, [`super::Method::flash_crc`]), whose resident frames are the same
    /// pixels (the QEMU tests compare them by CRC).
    pub fn aliased(&self, pairs: &[(u32, u32)]) -> Self {
        let to = |crc: u32| {
            pairs
                .iter()
                .find(|(from, _)| *from == crc)
                .map_or(crc, |(_, to)| *to)
        };
        let mut out = self.clone();
        out.counts = self
            .counts
            .iter()
            .map(|(k, &n)| {
                (
                    Key {
                        crc: to(k.crc),
                        ..k.clone()
                    },
                    n,
                )
            })
            .collect();
        for m in &mut out.models {
            m.0 = to(m.0);
        }
        out
    }

    /// Fails when a count file names a file none of `crcs` is: its counts would match nothing.
    ///
    /// # Errors
    /// Naming the count file, its model and CRC, and what the report baked.
    pub fn check_models(&self, crcs: &[(String, u32)]) -> Result<()> {
        for (crc, model, file) in &self.models {
            if !crcs.iter().any(|c| c.1 == *crc) {
                let baked: Vec<String> =
                    crcs.iter().map(|(m, c)| format!("{m} {c:#010x}")).collect();
                bail!(
                    "{}: counts for {model} (CRC {crc:#010x}), which is none of the files this \
                     report baked ({}): run arm-bench again on the same bake, or drop --arm",
                    file.display(),
                    baked.join(", ")
                );
            }
        }
        Ok(())
    }
}

/// Display name of a count file in the report.
pub fn file_name(path: &Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(text: &str) -> (tempfile::TempDir, PathBuf) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("arm.jsonl");
        std::fs::write(&path, text).unwrap();
        (dir, path)
    }

    const LINES: &str = r#"{"model":"big.pack","model_crc":"0x0000abcd","target":"thumbv7m-none-eabi","build":"x","view":"std","cutoff_px":2,"shadows":"one-pass","kernel":"square","instructions":1234}
{"model":"big.pack","model_crc":"0x0000abcd","target":"thumbv7m-none-eabi","build":"y","view":"std","cutoff_px":2,"shadows":"one-pass","kernel":"square","instructions":9999}
{"model":"big.pack","model_crc":"0x0000abcd","target":"thumbv6m-none-eabi","build":"x","view":"std","cutoff_px":4,"shadows":"one-pass","kernel":"square","instructions":77}
"#;

    #[test]
    fn a_frame_is_found_by_file_view_cutoff_shadows_and_kernel() {
        let (_d, path) = write(LINES);
        let c = ArmCounts::load(&[path], DEFAULT_TARGET).unwrap();
        assert_eq!(c.get(0xabcd, "std", 2.0, "one-pass", "square"), Some(1234));
        assert_eq!(c.get(0xabcd, "std", 2.0, "off", "square"), None);
        assert_eq!(c.get(0xabcd, "std", 2.0, "one-pass", "round"), None);
        assert_eq!(c.get(0xabce, "std", 2.0, "one-pass", "square"), None);
        // Another target's frame is not this target's.
        assert_eq!(c.get(0xabcd, "std", 4.0, "one-pass", "square"), None);
        assert!(c.check_models(&[("big.toml".into(), 0xabcd)]).is_ok());
        let e = c
            .check_models(&[("big.toml".into(), 0x1234)])
            .unwrap_err()
            .to_string();
        assert!(e.contains("0x0000abcd") && e.contains("0x00001234"), "{e}");
    }

    #[test]
    fn a_flash_layout_counts_as_the_bake_it_was_rewritten_from() {
        let (_d, path) = write(LINES);
        let c = ArmCounts::load(&[path], DEFAULT_TARGET).unwrap();
        // The firmware's unbricked file 0xabcd is the report's bricked bake 0x1234.
        let a = c.aliased(&[(0xabcd, 0x1234)]);
        assert_eq!(a.get(0x1234, "std", 2.0, "one-pass", "square"), Some(1234));
        assert_eq!(a.get(0xabcd, "std", 2.0, "one-pass", "square"), None);
        assert!(a.check_models(&[("bunny.tg".into(), 0x1234)]).is_ok());
        // Another file's alias changes nothing.
        let b = c.aliased(&[(0x5555, 0x1234)]);
        assert_eq!(b.get(0xabcd, "std", 2.0, "one-pass", "square"), Some(1234));
        assert!(b.check_models(&[("bunny.tg".into(), 0x1234)]).is_err());
    }

    #[test]
    fn a_bad_line_or_a_missing_target_names_the_file() {
        let (_d, path) = write("{\"model\": 3}\n");
        let e = format!(
            "{:#}",
            ArmCounts::load(std::slice::from_ref(&path), DEFAULT_TARGET).unwrap_err()
        );
        assert!(e.contains("arm.jsonl line 1"), "{e}");
        let (_d, path) = write(LINES);
        let e = ArmCounts::load(&[path], "thumbv7em-none-eabihf")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("no frame of target thumbv7em-none-eabihf"),
            "{e}"
        );
    }
}
