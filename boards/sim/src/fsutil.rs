//! Files in and out: every whole-file read goes through [`read_file`] (a regular file, at most a
//! limit's bytes), and every output through [`write_atomic`] or an [`AtomicFile`], so that a
//! failure never leaves a partial file behind; temporary files and folders are [`Removed`] when
//! dropped, and by [`remove_on_interrupt`]'s handler when the program is interrupted.

use std::fs::File;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

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
    let tmp = temp_name(path);
    let _guard = Removed::new(tmp.clone());
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

/// The temporary name an output is written under, in its folder: `.NAME.PID.tmp`.
fn temp_name(path: &Path) -> PathBuf {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    dir.join(format!(".{name}.{}.tmp", std::process::id()))
}

/// Paths removed when the program is interrupted: every [`Removed`] alive.
static PENDING: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// A temporary file or folder, removed (a folder with everything in it) when this is dropped or
/// the program is interrupted ([`remove_on_interrupt`]); [`Removed::keep`] keeps it (a renamed
/// output).
#[derive(Debug)]
pub struct Removed {
    path: PathBuf,
    keep: bool,
}

impl Removed {
    /// Takes charge of `path` (which need not exist yet).
    pub fn new(path: PathBuf) -> Self {
        PENDING
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .push(path.clone());
        Self { path, keep: false }
    }

    /// The path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Leaves the path where it is from now on.
    pub fn keep(mut self) {
        self.keep = true;
    }
}

impl Drop for Removed {
    fn drop(&mut self) {
        let mut pending = PENDING.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(i) = pending.iter().rposition(|p| *p == self.path) {
            pending.swap_remove(i);
        }
        if !self.keep {
            remove_path(&self.path);
        }
    }
}

fn remove_path(path: &Path) {
    if path.is_dir() {
        let _ = std::fs::remove_dir_all(path);
    } else {
        let _ = std::fs::remove_file(path);
    }
}

/// Installs a handler of Ctrl-C, SIGTERM and SIGHUP that removes every [`Removed`] path (spill
/// folders, temporary outputs) and exits with status 130, so that an interrupted bake leaves
/// nothing behind. Once per process; later calls do nothing.
pub fn remove_on_interrupt() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        // The handler runs on a thread of its own, so it may take the lock and remove files.
        let _ = ctrlc::set_handler(|| {
            let pending = PENDING.lock().unwrap_or_else(|e| e.into_inner());
            // A worker may add a file to a folder while it is removed: try again.
            for _ in 0..5 {
                for p in pending.iter() {
                    remove_path(p);
                }
                if pending.iter().all(|p| !p.exists()) {
                    break;
                }
            }
            eprintln!("\ninterrupted: temporary files removed");
            std::process::exit(130);
        });
    });
}

/// An output file written in place at any offsets (`write_at`), under a temporary name in its
/// folder, and renamed to its name by [`AtomicFile::commit`]; dropped before that (an error) or
/// interrupted, it is removed.
pub struct AtomicFile {
    file: File,
    tmp: Removed,
    path: PathBuf,
}

impl AtomicFile {
    /// Creates the temporary file for `path`, `len` bytes long (zeros, sparse where the file
    /// system allows).
    ///
    /// # Errors
    /// When the folder is not writable; the message names the file.
    pub fn create(path: &Path, len: u64) -> Result<Self> {
        let tmp = Removed::new(temp_name(path));
        let file = File::create(tmp.path())
            .with_context(|| format!("cannot create {}", tmp.path().display()))?;
        file.set_len(len)
            .with_context(|| format!("cannot write {}", tmp.path().display()))?;
        Ok(Self {
            file,
            tmp,
            path: path.to_owned(),
        })
    }

    /// Writes `bytes` at `offset`; `&self`, so that threads write their parts at once.
    ///
    /// # Errors
    /// When the write fails (a full disk); the message names the file.
    pub fn write_at(&self, offset: u64, bytes: &[u8]) -> std::io::Result<()> {
        use std::os::unix::fs::FileExt;
        self.file.write_all_at(bytes, offset)
    }

    /// The temporary file's path (for errors).
    pub fn tmp_path(&self) -> &Path {
        self.tmp.path()
    }

    /// Flushes the file and renames it to its name.
    ///
    /// # Errors
    /// When the flush or the rename fails; the temporary file is removed then.
    pub fn commit(self) -> Result<()> {
        self.file.sync_all().ok();
        std::fs::rename(self.tmp.path(), &self.path).with_context(|| {
            format!(
                "cannot rename {} to {}",
                self.tmp.path().display(),
                self.path.display()
            )
        })?;
        self.tmp.keep();
        Ok(())
    }
}
