//! FAT disk images as an SD card holds them, for the streaming tests (`stream_sd`, `qemu_stream`):
//! an MBR and one FAT16 partition made by `mkfs.fat` holding a model copied in by `mcopy` (apt
//! packages dosfstools and mtools, which `.ci/test-all` installs).

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::under_ci;

/// Whether `tool` runs; under CI its absence is a failure.
///
/// # Panics
/// When it is missing and [`under_ci`] is true.
pub fn have(tool: &str, package: &str) -> bool {
    let ok = Command::new(tool)
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success() || !o.stderr.is_empty() || !o.stdout.is_empty());
    assert!(
        ok || !under_ci(),
        "{tool} is missing and CI=true: install the apt package {package}"
    );
    if !ok {
        eprintln!("note: {tool} not found (apt package {package}); test skipped");
    }
    ok
}

fn run(cmd: &mut Command) {
    let out = cmd.output().unwrap_or_else(|e| panic!("{cmd:?}: {e}"));
    assert!(
        out.status.success(),
        "{cmd:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Sectors before the partition (1 MiB, as partitioning tools align).
pub const PART_START: u32 = 2048;

/// A disk image: an MBR with one FAT16 (LBA) partition at sector 2048, formatted by `mkfs.fat`,
/// holding `name` copied in by `mcopy`; the image is `dir/sd.img` (scratch files beside it).
///
/// # Panics
/// When a tool fails or `dir` cannot be written: the tests that call this have nothing to test
/// without the image.
pub fn make_image(dir: &Path, file: &[u8], name: &str) -> PathBuf {
    make_image_of(dir, &[(name, file)])
}

/// [`make_image`] holding several files, each `(name, bytes)` in the root directory (8.3 names).
///
/// # Panics
/// As [`make_image`].
pub fn make_image_of(dir: &Path, files: &[(&str, &[u8])]) -> PathBuf {
    let part = dir.join("part.img");
    let total: u64 = files.iter().map(|(_, f)| f.len() as u64 + 4096).sum();
    // Room for the files plus FAT overhead, at least 16 MB (FAT16 wants more than 4085 clusters).
    let kib = (total / 1024 + 1024).max(16 * 1024);
    // mkfs.fat -C refuses to overwrite: a fixed `dir` is reused from run to run.
    let _ = std::fs::remove_file(&part);
    run(Command::new("mkfs.fat")
        .args(["-C", "-F", "16", "-n", "POCKETSPLAT"])
        .arg(&part)
        .arg(kib.to_string()));
    let host_file = dir.join("model.bin");
    for (name, file) in files {
        std::fs::write(&host_file, file).unwrap();
        run(Command::new("mcopy")
            .arg("-i")
            .arg(&part)
            .arg(&host_file)
            .arg(format!("::{name}")));
    }
    let part_bytes = std::fs::read(&part).unwrap();
    let sectors = (part_bytes.len() / 512) as u32;
    let mut disk = vec![0u8; PART_START as usize * 512];
    let entry = &mut disk[446..462];
    entry[0] = 0x00; // not bootable
    entry[4] = 0x0E; // FAT16, LBA
    entry[8..12].copy_from_slice(&PART_START.to_le_bytes());
    entry[12..16].copy_from_slice(&sectors.to_le_bytes());
    disk[510] = 0x55;
    disk[511] = 0xAA;
    disk.extend_from_slice(&part_bytes);
    let image = dir.join("sd.img");
    std::fs::write(&image, disk).unwrap();
    image
}
