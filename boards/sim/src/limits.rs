//! How much the desktop program reads and builds before it refuses: one table of limits with
//! defaults that fit every Stanford scan with room to spare on a 4 GB machine, raised (or lowered)
//! with one option, `--limits NAME=SIZE[,NAME=SIZE...]` (any subcommand, repeatable). Sizes take
//! `K`, `M`, `G` (powers of 1024) for bytes and counts alike.
//!
//! | name | default | what it bounds |
//! |---|---|---|
//! | `file` | 1G | a file read whole (`.tg`, `.qs`, `.pack`, PNG) |
//! | `scene` | 16M | a scene file (`.toml`) |
//! | `ply` | 2G | the bytes a PLY file may hold once decompressed (header, body, anything after) |
//! | `vertices` | 16M | vertices a PLY file may declare |
//! | `triangles` | 32M | faces a PLY file may declare |
//! | `bake` | 1G | memory a bake may use: past its estimate a mesh bakes out of core (`--force` bakes in memory anyway) |
//!
//! The command line starts from [`Limits::for_memory`] of `--memory` (default: half the machine's
//! memory), which raises `bake`, `vertices`, `triangles` and `ply` with the budget.
//! | `stream` | 8G | the file `render --stream` reads, as its header claims (its block table is kept whole) |
//!
//! The command line sets the limits once ([`set_current`]); library functions that take none read
//! [`current`].

use std::sync::RwLock;

use anyhow::{bail, Result};

use crate::args::{format_size, parse_size};

/// The limits in force.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limits {
    /// `file`: bytes of a file read whole.
    pub file: u64,
    /// `scene`: bytes of a scene file.
    pub scene: u64,
    /// `ply`: bytes of a PLY file once decompressed.
    pub ply: u64,
    /// `vertices`: vertices a PLY file may declare.
    pub vertices: u64,
    /// `triangles`: faces a PLY file may declare.
    pub triangles: u64,
    /// `bake`: bytes of memory a bake is estimated to need.
    pub bake: u64,
    /// `stream`: bytes of the file `render --stream` reads, as its header claims.
    pub stream: u64,
}

impl Limits {
    /// The defaults.
    pub const DEFAULT: Limits = Limits {
        file: 1 << 30,
        scene: 16 << 20,
        ply: 2 << 30,
        vertices: 16 << 20,
        triangles: 32 << 20,
        bake: 1 << 30,
        stream: 8 << 30,
    };

    /// No limits at all (tests and reports that must not be refused).
    pub const NONE: Limits = Limits {
        file: u64::MAX,
        scene: u64::MAX,
        ply: u64::MAX,
        vertices: u64::MAX,
        triangles: u64::MAX,
        bake: u64::MAX,
        stream: u64::MAX,
    };

    /// The defaults for a bake budget of `memory` bytes (`--memory`): `bake` is the budget, and
    /// the counts an out-of-core bake can hold within it follow (64 bytes a vertex at most, 16
    /// a triangle, which go to disk), as does `ply`, the bytes such a file may inflate to (at
    /// least the default 2G).
    pub fn for_memory(memory: u64) -> Limits {
        Limits {
            bake: memory,
            vertices: memory / 64,
            triangles: memory / 16,
            ply: memory.saturating_mul(4).max(Self::DEFAULT.ply),
            ..Self::DEFAULT
        }
    }

    /// Every limit by name, with what it bounds.
    pub const NAMES: [(&'static str, &'static str); 7] = [
        ("file", "bytes of a file read whole (.tg, .qs, .pack, PNG)"),
        ("scene", "bytes of a scene file (.toml)"),
        ("ply", "bytes of a PLY file once decompressed"),
        ("vertices", "vertices a PLY file may declare"),
        ("triangles", "faces a PLY file may declare"),
        ("bake", "memory a bake may use (--memory)"),
        (
            "stream",
            "bytes of a file read with --stream, as its header claims",
        ),
    ];

    fn slot(&mut self, name: &str) -> Option<&mut u64> {
        Some(match name {
            "file" => &mut self.file,
            "scene" => &mut self.scene,
            "ply" => &mut self.ply,
            "vertices" => &mut self.vertices,
            "triangles" => &mut self.triangles,
            "bake" => &mut self.bake,
            "stream" => &mut self.stream,
            _ => return None,
        })
    }

    /// Applies `NAME=SIZE[,NAME=SIZE...]` (as `--limits` takes it).
    ///
    /// # Errors
    /// An unknown name or a size that is not one, naming `--limits` and the known names.
    pub fn apply(&mut self, text: &str) -> Result<()> {
        for item in text.split(',') {
            let Some((name, value)) = item.split_once('=') else {
                bail!(
                    "--limits {text:?}: {item:?} is not NAME=SIZE ({})",
                    Self::names()
                );
            };
            let name = name.trim();
            let n = parse_size(value)
                .map_err(|e| anyhow::anyhow!("--limits {text:?}: {name}={value}: {e}"))?;
            let Some(slot) = self.slot(name) else {
                bail!(
                    "--limits {text:?}: no limit named {name:?} ({})",
                    Self::names()
                );
            };
            *slot = n;
        }
        Ok(())
    }

    fn names() -> String {
        let names: Vec<&str> = Self::NAMES.iter().map(|(n, _)| *n).collect();
        format!("limits: {}", names.join(", "))
    }

    /// `Err` naming the limit when `value` is above limit `name`; `what` says what was measured.
    ///
    /// # Errors
    /// [`Exceeded`] when `value` is above the limit.
    pub fn check(&self, name: &'static str, what: &str, value: u64) -> Result<(), Exceeded> {
        let max = self.get(name);
        if value > max {
            Err(Exceeded {
                name,
                what: what.to_owned(),
                value,
                max,
            })
        } else {
            Ok(())
        }
    }

    /// The limit called `name` (`u64::MAX` for an unknown name).
    pub fn get(&self, name: &str) -> u64 {
        let mut copy = *self;
        copy.slot(name).map_or(u64::MAX, |v| *v)
    }
}

impl Default for Limits {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// A limit was exceeded: what, by how much, and how to raise it.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error(
    "{what} {value} is over the limit {name}={max_text} (raise it with --limits {name}=SIZE)",
    max_text = format_size(*.max)
)]
pub struct Exceeded {
    /// The limit's name (`--limits NAME=...`).
    pub name: &'static str,
    /// What was measured (`declared vertices`, `bytes`).
    pub what: String,
    /// The value found.
    pub value: u64,
    /// The limit.
    pub max: u64,
}

static CURRENT: RwLock<Limits> = RwLock::new(Limits::DEFAULT);

/// The limits in force (the defaults unless [`set_current`] changed them).
pub fn current() -> Limits {
    *CURRENT.read().unwrap_or_else(|e| e.into_inner())
}

/// Sets the limits in force for the whole process (the command line does, once).
pub fn set_current(limits: Limits) {
    *CURRENT.write().unwrap_or_else(|e| e.into_inner()) = limits;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn apply_and_check() {
        let mut l = Limits::DEFAULT;
        l.apply("ply=4G, triangles=100M").unwrap();
        assert_eq!((l.ply, l.triangles), (4 << 30, 100 << 20));
        assert!(l
            .apply("nope=1")
            .unwrap_err()
            .to_string()
            .contains("vertices"));
        assert!(l.apply("ply").is_err());
        assert!(l.apply("ply=1T").is_err());
        let e = l
            .check("vertices", "declared vertices", 1 << 40)
            .unwrap_err();
        assert_eq!(
            e.to_string(),
            "declared vertices 1099511627776 is over the limit vertices=16M \
             (raise it with --limits vertices=SIZE)"
        );
        assert!(l.check("vertices", "v", 16 << 20).is_ok());
    }
}
