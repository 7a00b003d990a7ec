//! Spill files of an out-of-core bake: triangles as three little-endian `u32` vertex numbers each,
//! written and read in order through large buffers, in a temporary folder beside the output that
//! is removed when the bake ends, fails or is interrupted ([`crate::fsutil::Removed`]).

use std::fs::File;
use std::io::{self, BufReader, BufWriter, Read, Write};
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};

use crate::fsutil::Removed;

/// Bytes of one spilled triangle.
pub const TRIANGLE_BYTES: u64 = 12;

/// Buffer of a spill file's reader or writer.
const BUFFER: usize = 1 << 20;

/// The temporary folder of one bake's spill files.
pub struct SpillDir {
    dir: Removed,
    next: std::sync::atomic::AtomicU64,
}

impl SpillDir {
    /// Creates `.{name}.{pid}.spill` in `parent` (the output's folder unless the user named
    /// another).
    ///
    /// # Errors
    /// When the folder cannot be made; the message names it.
    pub fn create(parent: &Path, name: &str) -> Result<Self> {
        let dir = Removed::new(parent.join(format!(".{name}.{}.spill", std::process::id())));
        std::fs::create_dir_all(dir.path())
            .with_context(|| format!("cannot create the spill folder {}", dir.path().display()))?;
        Ok(Self {
            dir,
            next: std::sync::atomic::AtomicU64::new(0),
        })
    }

    /// The folder.
    pub fn path(&self) -> &Path {
        self.dir.path()
    }

    /// A new, empty spill file.
    ///
    /// # Errors
    /// When it cannot be created; the message names it.
    pub fn file(&self, what: &str) -> Result<SpillWriter> {
        let n = self.next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let path = self.path().join(format!("{n:06}.{what}"));
        let file = File::create(&path)
            .with_context(|| format!("cannot create the spill file {}", path.display()))?;
        Ok(SpillWriter {
            out: BufWriter::with_capacity(BUFFER, file),
            path,
            count: 0,
        })
    }
}

/// A spill file being written.
pub struct SpillWriter {
    out: BufWriter<File>,
    path: PathBuf,
    count: u64,
}

impl SpillWriter {
    /// Appends a triangle.
    ///
    /// # Errors
    /// When the write fails (a full disk).
    pub fn push(&mut self, t: [u32; 3]) -> io::Result<()> {
        let mut b = [0u8; 12];
        for (k, v) in t.iter().enumerate() {
            b[4 * k..4 * k + 4].copy_from_slice(&v.to_le_bytes());
        }
        self.count += 1;
        self.out.write_all(&b)
    }

    /// The file's path (for errors).
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Finishes the file: its path and triangle count.
    ///
    /// # Errors
    /// When the last write fails; the message names the file.
    pub fn finish(self) -> Result<Spilled> {
        let path = self.path;
        self.out
            .into_inner()
            .map_err(|e| e.into_error())
            .with_context(|| format!("cannot write the spill file {}", path.display()))?;
        Ok(Spilled {
            path,
            count: self.count,
            turned: false,
        })
    }
}

/// A finished spill file.
#[derive(Debug)]
pub struct Spilled {
    /// Its path (inside the spill folder, removed with it).
    pub path: PathBuf,
    /// Triangles in it.
    pub count: u64,
    /// Read every triangle turned (its last two vertices swapped): a mesh the file winds inward
    /// (`scan`'s facing pass).
    pub turned: bool,
}

impl Spilled {
    /// Calls `each` with every triangle in order; stops at its first error.
    ///
    /// # Errors
    /// When the file cannot be read (the message names it), or what `each` returns.
    pub fn for_each(&self, mut each: impl FnMut([u32; 3]) -> Result<()>) -> Result<()> {
        let file = File::open(&self.path)
            .with_context(|| format!("cannot read the spill file {}", self.path.display()))?;
        let mut r = BufReader::with_capacity(BUFFER, file);
        let mut b = [0u8; 12];
        for _ in 0..self.count {
            r.read_exact(&mut b)
                .with_context(|| format!("cannot read the spill file {}", self.path.display()))?;
            let v =
                |k: usize| u32::from_le_bytes([b[4 * k], b[4 * k + 1], b[4 * k + 2], b[4 * k + 3]]);
            each(if self.turned {
                [v(0), v(2), v(1)]
            } else {
                [v(0), v(1), v(2)]
            })?;
        }
        Ok(())
    }

    /// Every triangle, in memory.
    ///
    /// # Errors
    /// As [`Spilled::for_each`].
    pub fn read_all(&self) -> Result<Vec<[u32; 3]>> {
        let mut out = Vec::with_capacity(self.count as usize);
        self.for_each(|t| {
            out.push(t);
            Ok(())
        })?;
        Ok(out)
    }

    /// Removes the file now (its folder goes at the end anyway): disk is freed as a partition
    /// moves down.
    pub fn remove(self) {
        let _ = std::fs::remove_file(&self.path);
    }
}
