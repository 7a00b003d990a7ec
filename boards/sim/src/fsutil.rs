//! Files in and out: every whole-file read goes through [`read_file`] (a regular file, at most a
//! limit's bytes), and every output through [`write_atomic`], so that a failure never leaves a
//! partial file behind.

use std::fs::File;
use std::io::{Read, Write};
use std::path::Path;

use anyhow::{bail, Context, Result};

use crate::{limits, memory};

/// Opens `path` for reading if it is a regular file (not a folder, device or FIFO, whose reads
/// may never end); returns it with its length.
///
/// # Errors
/// When it cannot be opened or is not a regular file; the message names it.
pub fn open_regular(path: &Path) -> Result<(File, u64)> {
    // Looked at before it is opened: opening a FIFO blocks until something writes to it.
    let meta =
        std::fs::metadata(path).with_context(|| format!("cannot open {}", path.display()))?;
    check_regular(path, &meta)?;
    let file = File::open(path).with_context(|| format!("cannot open {}", path.display()))?;
    let meta = file
        .metadata()
        .with_context(|| format!("cannot read {}", path.display()))?;
    check_regular(path, &meta)?;
    Ok((file, meta.len()))
}

/// Reads the first bytes of a regular file into `buf` (a magic number); returns how many.
///
/// # Errors
/// As [`open_regular`], or when it cannot be read.
pub fn read_magic(path: &Path, buf: &mut [u8]) -> Result<usize> {
    let (file, _) = open_regular(path)?;
    let mut n = 0;
    let mut file = file.take(buf.len() as u64);
    while n < buf.len() {
        match file.read(buf.get_mut(n..).unwrap_or_default()) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e).with_context(|| format!("cannot read {}", path.display())),
        }
    }
    Ok(n)
}

/// The point format of the file at `path`, by its first bytes (`None`: not a point file, e.g. a mesh).
///
/// # Errors
/// When the file cannot be opened or read (or is not a regular file).
pub fn sniff(path: &Path) -> Result<Option<pocketsplat_core::format::FileFormat>> {
    let mut magic = [0u8; pocketsplat_core::format::SNIFF_BYTES];
    let n = read_magic(path, &mut magic)?;
    Ok(pocketsplat_core::format::FileFormat::sniff(
        magic.get(..n).unwrap_or_default(),
    ))
}

fn check_regular(path: &Path, meta: &std::fs::Metadata) -> Result<()> {
    if meta.is_dir() {
        bail!("cannot read {}: it is a folder", path.display());
    }
    if !meta.is_file() {
        bail!(
            "cannot read {}: not a regular file (a device, FIFO or socket); copy it to a file first",
            path.display()
        );
    }
    Ok(())
}

/// Reads a whole file of at most `max` bytes; `limit` names the limit in the error.
///
/// # Errors
/// When it is not a regular file, is larger than `max` (also when it grows while read), or cannot
/// be read; the message names the file, and for the size the limit and how to raise it.
pub fn read_limited(path: &Path, limit: &'static str, max: u64) -> Result<Vec<u8>> {
    let (file, len) = open_regular(path)?;
    let too_big = |value: u64| {
        let e = limits::Exceeded {
            name: limit,
            what: "size in bytes".into(),
            value,
            max,
        };
        anyhow::anyhow!("cannot read {}: {e}", path.display())
    };
    if len > max {
        return Err(too_big(len));
    }
    // The length was checked against the limit; whether the memory is there is asked, not
    // assumed (a raised limit on a machine without the memory is an error, not an abort).
    let mut bytes = Vec::new();
    memory::reserve(&mut bytes, usize::try_from(len).unwrap_or(usize::MAX))
        .with_context(|| format!("cannot read {}", path.display()))?;
    file.take(max.saturating_add(1))
        .read_to_end(&mut bytes)
        .with_context(|| format!("cannot read {}", path.display()))?;
    if bytes.len() as u64 > max {
        return Err(too_big(bytes.len() as u64));
    }
    Ok(bytes)
}

/// Reads a whole file (`.tg`, `.qs`, `.pack`, PNG) within the `file` limit in force.
///
/// # Errors
/// As [`read_limited`].
pub fn read_file(path: &Path) -> Result<Vec<u8>> {
    read_limited(path, "file", limits::current().file)
}

/// Reads a scene file (UTF-8 text) within the `scene` limit in force.
///
/// # Errors
/// As [`read_limited`], and when it is not UTF-8.
pub fn read_scene_text(path: &Path) -> Result<String> {
    let bytes = read_limited(path, "scene", limits::current().scene)?;
    String::from_utf8(bytes)
        .with_context(|| format!("cannot read {}: not UTF-8 text", path.display()))
}

/// Writes `bytes` to `path` through a temporary file in the same folder, renamed on success.
///
/// # Errors
/// When the folder is not writable or the rename fails; the temporary file is removed.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = dir.join(format!(".{name}.{}.tmp", std::process::id()));
    let result = (|| -> Result<()> {
        let mut f = std::fs::File::create(&tmp)
            .with_context(|| format!("cannot create {}", tmp.display()))?;
        f.write_all(bytes)
            .with_context(|| format!("cannot write {}", tmp.display()))?;
        f.sync_all().ok();
        std::fs::rename(&tmp, path)
            .with_context(|| format!("cannot rename {} to {}", tmp.display(), path.display()))
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}
