//! The memory a bake may use and what it did use: the machine's memory (the default budget is
//! half of it), the process's peak resident size, and the free space of a disk (spill files).
//! Linux `/proc` files and `statvfs`; elsewhere `None`, and the callers fall back.

use std::path::Path;

/// The default budget when the machine's memory cannot be read.
const FALLBACK_BUDGET: u64 = 4 << 30;
/// The smallest default budget.
const MIN_DEFAULT_BUDGET: u64 = 1 << 30;

/// Bytes of physical memory (`MemTotal`).
pub fn machine_memory() -> Option<u64> {
    kib_field("/proc/meminfo", "MemTotal:")
}

/// The budget of a bake when none is given: half the machine's memory, at least 1 GiB (4 GiB
/// when the machine's memory cannot be read), so that a bake leaves room for the rest.
pub fn default_budget() -> u64 {
    machine_memory().map_or(FALLBACK_BUDGET, |m| (m / 2).max(MIN_DEFAULT_BUDGET))
}

/// The process's peak resident size so far (`VmHWM`).
pub fn peak_rss() -> Option<u64> {
    kib_field("/proc/self/status", "VmHWM:")
}

/// The process's resident size now (`VmRSS`).
pub fn current_rss() -> Option<u64> {
    kib_field("/proc/self/status", "VmRSS:")
}

/// Bytes free for an unprivileged user on the file system holding `path`.
pub fn free_disk(path: &Path) -> Option<u64> {
    let s = rustix::fs::statvfs(path).ok()?;
    Some(s.f_bavail.saturating_mul(s.f_frsize))
}

/// A `NAME:  1234 kB` line of a `/proc` file, in bytes.
fn kib_field(file: &str, name: &str) -> Option<u64> {
    let text = std::fs::read_to_string(file).ok()?;
    let line = text.lines().find(|l| l.starts_with(name))?;
    let kib: u64 = line[name.len()..]
        .trim()
        .trim_end_matches("kB")
        .trim()
        .parse()
        .ok()?;
    Some(kib * 1024)
}

/// `1.23 GB` style (powers of 1024), for progress and summaries.
pub fn human(bytes: u64) -> String {
    let mut v = bytes as f64;
    for unit in ["B", "KB", "MB", "GB", "TB"] {
        if v < 1024.0 || unit == "TB" {
            return if unit == "B" {
                format!("{bytes} B")
            } else {
                format!("{v:.2} {unit}")
            };
        }
        v /= 1024.0;
    }
    unreachable!()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_machine_and_the_process_are_measured() {
        let total = machine_memory().expect("Linux /proc/meminfo");
        assert!(total > 64 << 20);
        assert!(default_budget() >= MIN_DEFAULT_BUDGET && default_budget() <= total.max(1 << 30));
        let peak = peak_rss().expect("/proc/self/status");
        assert!(peak >= current_rss().unwrap() / 2 && peak > 1 << 20);
        assert!(free_disk(Path::new(".")).unwrap() > 0);
        assert_eq!(human(512), "512 B");
        assert_eq!(human(3 << 29), "1.50 GB");
    }
}
