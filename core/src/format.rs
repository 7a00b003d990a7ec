//! Which point format a file holds, from its first bytes: the one place that knows the magics (each
//! format's module re-exports its own, and its reader checks it again).
//!
//! ```
//! use pocketsplat_core::FileFormat;
//! assert_eq!(FileFormat::sniff(b"PSTG\x02\x00"), Some(FileFormat::TriGrid));
//! assert_eq!(FileFormat::sniff(b"QSplat11"), Some(FileFormat::QSplat));
//! assert_eq!(FileFormat::sniff(b"ply\n"), None);
//! ```

/// The magic of a tri-grid (`.tg`) file.
pub const TG_MAGIC: [u8; 4] = *b"PSTG";
/// The magic of every QSplat 1.0 (`.qs`) fragment.
pub const QS_MAGIC: [u8; 8] = *b"QSplat11";
/// The part of [`QS_MAGIC`] every QSplat version shares ("QSplat" and then two version digits):
/// enough to tell a QSplat file of another version, which its reader then refuses by name.
pub const QS_MAGIC_PREFIX: [u8; 6] = *b"QSplat";
/// The magic of a scene pack (`.pack`).
pub const PACK_MAGIC: [u8; 4] = *b"PSPK";
/// Bytes [`FileFormat::sniff`] looks at, at most.
pub const SNIFF_BYTES: usize = 8;

/// A point file's format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FileFormat {
    /// A tri-grid (or octree) `.tg` file.
    TriGrid,
    /// A QSplat `.qs` file.
    QSplat,
    /// A scene pack.
    Pack,
}

impl FileFormat {
    /// The format whose magic `prefix` starts with (`None`: none of them, e.g. a mesh).
    pub fn sniff(prefix: &[u8]) -> Option<Self> {
        if prefix.starts_with(&TG_MAGIC) {
            Some(FileFormat::TriGrid)
        } else if prefix.starts_with(&QS_MAGIC_PREFIX) {
            Some(FileFormat::QSplat)
        } else if prefix.starts_with(&PACK_MAGIC) {
            Some(FileFormat::Pack)
        } else {
            None
        }
    }

    /// Every format.
    pub const ALL: [FileFormat; 3] = [FileFormat::TriGrid, FileFormat::QSplat, FileFormat::Pack];

    /// `tg`, `qsplat` or `pack`: the names of `pocketsplat bake --format` and of the firmware's
    /// frame lines.
    pub fn name(self) -> &'static str {
        match self {
            FileFormat::TriGrid => "tg",
            FileFormat::QSplat => "qsplat",
            FileFormat::Pack => "pack",
        }
    }

    /// The format called `name` ([`FileFormat::name`]).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|f| f.name() == name)
    }

    /// The cargo feature of `pocketsplat-core` that reads this format.
    pub fn feature(self) -> &'static str {
        match self {
            FileFormat::TriGrid => "trigrid",
            FileFormat::QSplat => "qsplat",
            FileFormat::Pack => "scene",
        }
    }
}
