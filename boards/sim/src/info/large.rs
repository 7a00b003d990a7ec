//! `info` of a file too large to read whole (over [`RESIDENT_MAX`] bytes): read front to back
//! in bounded memory. A `.tg` file: its header block parsed and checked as the resident reader
//! checks it, and every block's CRC against its table (the masks' structure is left to
//! `render`, which checks each brick as it streams it). A `.qs` file: its fragments' chain, and
//! each tree walked breadth-first as the file lays it out (QSplat 1.0's layout and ours), one
//! byte a pending group and the pointers checked level by level.

use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::Path;

use anyhow::{anyhow, bail, Context, Result};
use pocketsplat_core::crc::crc32;
use pocketsplat_core::qs::{ByteOrder, QsCounts, HEADER_BYTES, MAGIC as QS_MAGIC, OPT_COMMENT};
use pocketsplat_core::tg::read::{check_counts, parse_header};

use super::qs::QsInfo;
use super::tg::{tg_info_of, TgInfo};

/// Largest file `info` reads whole (and checks entirely); larger ones are read as this module
/// reads them.
pub const RESIDENT_MAX: u64 = 16 << 20;

/// Reads exactly `buf.len()` bytes or says the file ends early.
fn read_exact(r: &mut impl Read, buf: &mut [u8], path: &Path, what: &str) -> Result<()> {
    r.read_exact(buf)
        .with_context(|| format!("{}: cannot read {what}", path.display()))
}

/// A `.tg` file's statistics from its header, its blocks' CRCs checked.
///
/// # Errors
/// When the header or a block is damaged, or the file cannot be read; the message names it.
pub fn tg(path: &Path, len: u64) -> Result<TgInfo> {
    let mut f = BufReader::with_capacity(1 << 20, File::open(path)?);
    let mut first = vec![0u8; 512.min(len as usize)];
    read_exact(&mut f, &mut first, path, "the header")?;
    let block_log2 = *first
        .get(12)
        .ok_or_else(|| anyhow!("{}: too short", path.display()))?;
    if !pocketsplat_core::tg::BLOCK_LOG2_RANGE.contains(&block_log2) {
        bail!("{}: block size 2^{block_log2} out of range", path.display());
    }
    let bs = 1usize << block_log2;
    let mut block0 = first;
    block0.resize(bs.min(len as usize), 0);
    read_exact(
        &mut f,
        &mut block0[512.min(len as usize)..],
        path,
        "the header",
    )?;
    let (h, levels) = parse_header(&block0).map_err(|e| anyhow!("{}: {e}", path.display()))?;
    check_counts(&h, &levels).map_err(|e| anyhow!("{}: {e}", path.display()))?;
    let expected = u64::from(h.blocks) << h.block_log2;
    if expected != len {
        bail!(
            "{}: the header says {expected} bytes, the file has {len}",
            path.display()
        );
    }
    // The CRC table (blocks 1..=T), each checked against the header's list, then every data
    // block against the table.
    let list_at =
        pocketsplat_core::tg::DIRECTORY_OFFSET + pocketsplat_core::tg::DIRECTORY_ENTRY * h.levels();
    let t = h.crc_table_blocks as usize;
    let mut table = vec![0u8; t * bs];
    for k in 0..t {
        let block = &mut table[k * bs..(k + 1) * bs];
        read_exact(&mut f, block, path, "the CRC table")?;
        let want = u32::from_le_bytes(block0[list_at + 4 * k..list_at + 4 * k + 4].try_into()?);
        if crc32(block) != want {
            bail!("{}: block {} fails its CRC", path.display(), k + 1);
        }
    }
    let mut block = vec![0u8; bs];
    for b in t + 1..h.blocks as usize {
        read_exact(&mut f, &mut block, path, "a block")?;
        // The CRC of block b is at byte bs + 4b of the file: 4b into the table.
        let want = u32::from_le_bytes(table[4 * b..4 * b + 4].try_into()?);
        if crc32(&block) != want {
            bail!("{}: block {b} fails its CRC", path.display());
        }
    }
    // What streaming needs, from the file read in blocks as a stream reads it.
    let mut src = crate::stream::file::FileSource::open(path)
        .with_context(|| format!("{}: cannot open", path.display()))?;
    Ok(TgInfo {
        stream: super::tg::stream_need(&h, &levels, &mut src),
        ..tg_info_of(&h, &levels, len)
    })
}

/// A `.qs` file's statistics, walked front to back.
///
/// # Errors
/// When a fragment or tree is damaged or not laid out breadth-first, or the file cannot be
/// read; the message names the file and the offset.
pub fn qs(path: &Path, len: u64) -> Result<QsInfo> {
    let mut f = BufReader::with_capacity(1 << 20, File::open(path)?);
    let mut head = [0u8; 12];
    read_exact(&mut f, &mut head, path, "the first fragment")?;
    let order = if ByteOrder::Big
        .u32(&head, 8)
        .is_some_and(|l| u64::from(l) <= len)
    {
        ByteOrder::Big
    } else {
        ByteOrder::Little
    };
    f.seek(SeekFrom::Start(0))?;
    let mut c = QsCounts::default();
    let mut comments = Vec::new();
    let mut at = 0u64;
    while at < len {
        let mut h = [0u8; HEADER_BYTES];
        let n = 20.min(len - at) as usize;
        read_exact(&mut f, &mut h[..n], path, "a fragment header")?;
        let length = u64::from(order.u32(&h, 8).unwrap_or(0));
        if h[..8] != QS_MAGIC || length < 20 || at + length > len {
            bail!("{}: bad fragment at offset {at}", path.display());
        }
        c.fragments += 1;
        let options = order.u32(&h, 16).unwrap_or(0);
        if options & OPT_COMMENT != 0 {
            let mut text = vec![0u8; (length - 20) as usize];
            read_exact(&mut f, &mut text, path, "a comment")?;
            c.comments += 1;
            c.header_bytes += length;
            let text = String::from_utf8_lossy(&text);
            comments.push(text.trim_end_matches('\0').to_owned());
        } else {
            if length < HEADER_BYTES as u64 {
                bail!("{}: tree fragment at offset {at} too short", path.display());
            }
            read_exact(&mut f, &mut h[20..], path, "a tree header")?;
            tree(&mut f, &h, length, order, &mut c)
                .map_err(|e| anyhow!("{}: tree at offset {at}: {e}", path.display()))?;
        }
        at += length;
    }
    if c.trees == 0 {
        bail!("{}: no tree fragment", path.display());
    }
    Ok(super::qs::qs_info_of(&c, len, order, comments))
}

/// Walks one tree fragment breadth-first from just after its header (`h`), adding to `c`.
fn tree(
    r: &mut impl Read,
    h: &[u8; HEADER_BYTES],
    length: u64,
    order: ByteOrder,
    c: &mut QsCounts,
) -> Result<()> {
    let leaves_declared = u64::from(order.u32(h, 12).unwrap_or(0));
    let color = order.u32(h, 16).unwrap_or(0) & 1 != 0;
    let ns: u64 = if color { 6 } else { 4 };
    let root_children = order.u32(h, 36).unwrap_or(0);
    if !(2..=4).contains(&root_children) {
        bail!("{root_children} root children");
    }
    let bare = HEADER_BYTES as u64 + u64::from(root_children) * ns;
    let root_pointer = !(leaves_declared == u64::from(root_children) && length < bare + 4);
    // One byte a pending group: children − 1 in bits 0–1, a pointer in bit 2. Level by level.
    let pack = |children: u8, pointer: bool| (children - 1) | u8::from(pointer) << 2;
    let mut level: Vec<u8> = vec![pack(root_children as u8, root_pointer)];
    let mut at = HEADER_BYTES as u64;
    let (mut leaves, mut interior, mut pointers, mut depth) = (0u64, 0u64, 0u64, 0u8);
    let mut rec = [0u8; 6];
    while !level.is_empty() {
        depth += 1;
        let mut next = Vec::new();
        // Where the next level starts, as the first pointer to it says.
        let mut next_base: Option<u64> = None;
        let mut pushed = 0u64;
        for &g in &level {
            let (children, pointer) = ((g & 3) + 1, g & 4 != 0);
            let here = at;
            let mut target = None;
            if pointer {
                let mut p = [0u8; 4];
                r.read_exact(&mut p)?;
                pointers += 1;
                target = Some(here as i64 + i64::from(order.u32(&p, 0).unwrap_or(0) as i32));
                at += 4;
            }
            let mut first_child_group = None;
            for _ in 0..children {
                r.read_exact(&mut rec[..ns as usize])?;
                at += ns;
                let code = rec[1] & 3;
                let grand = rec[1] & 4 != 0;
                if code == 0 {
                    if grand {
                        bail!("a leaf with grandchildren at offset {}", at - ns);
                    }
                    leaves += 1;
                } else {
                    interior += 1;
                    first_child_group.get_or_insert(pushed);
                    let k = code + 1;
                    pushed += u64::from(grand) * 4 + u64::from(k) * ns;
                    next.push(pack(k, grand));
                }
            }
            match (first_child_group, target) {
                (Some(before), Some(t)) => {
                    let base = t - before as i64;
                    if *next_base.get_or_insert(base as u64) as i64 != base {
                        bail!("not laid out breadth-first (pointer at offset {here})");
                    }
                }
                (Some(_), None) => bail!("children without a pointer at offset {here}"),
                _ => {}
            }
        }
        if next_base.is_some_and(|b| b != at) {
            bail!(
                "not laid out breadth-first (level {} starts at {at})",
                depth + 1
            );
        }
        if at > length {
            bail!("runs past its fragment");
        }
        level = next;
    }
    if leaves != leaves_declared {
        bail!("{leaves} leaves, the header says {leaves_declared}");
    }
    let unused = length - at;
    if unused >= 4 {
        bail!("{unused} unused bytes");
    }
    let mut pad = vec![0u8; unused as usize];
    r.read_exact(&mut pad)?;
    c.trees += 1;
    c.color_trees += u32::from(color);
    c.leaves += leaves;
    c.interior += interior;
    c.pointers += pointers;
    c.max_depth = c.max_depth.max(depth);
    c.node_bytes += (leaves + interior) * ns;
    c.header_bytes += HEADER_BYTES as u64 + unused;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use pocketsplat_core::bake::BakeOptions;
    use pocketsplat_core::qs::write::{bake_qs, QsBakeOptions};
    use pocketsplat_core::qs::QSplat;
    use pocketsplat_core::tg::{TriGrid, Verify};

    /// The front-to-back readers say what the resident ones say, and refuse damage.
    #[test]
    fn large_files_read_front_to_back_match_the_resident_info() {
        let dir = tempfile::tempdir().unwrap();
        let mesh = crate::demo::trefoil(96, 12, 0.45);
        for colors in [false, true] {
            let q = bake_qs(
                &mesh,
                &QsBakeOptions {
                    colors,
                    comment: true,
                },
            )
            .unwrap();
            let path = dir.path().join("t.qs");
            std::fs::write(&path, &q.bytes).unwrap();
            let resident = super::super::qs_info(&QSplat::open(&q.bytes).unwrap());
            let streamed = qs(&path, q.bytes.len() as u64).unwrap();
            assert_eq!(
                serde_json::to_string(&streamed).unwrap(),
                serde_json::to_string(&resident).unwrap()
            );
            // A leaf turned interior: the walk no longer adds up.
            let mut bad = q.bytes.clone();
            let last = bad.len() - 4;
            bad[last - 3] |= 1;
            std::fs::write(&path, &bad).unwrap();
            assert!(qs(&path, bad.len() as u64).is_err());
        }
        let (_, bytes) =
            crate::bake::bake_mesh(&mesh, BakeOptions { rho: 3, depth: 5 }, 12, false).unwrap();
        let path = dir.path().join("t.tg");
        std::fs::write(&path, &bytes).unwrap();
        let resident = super::super::tg_info(&TriGrid::open(&bytes, Verify::Full).unwrap());
        let streamed = tg(&path, bytes.len() as u64).unwrap();
        assert_eq!(
            serde_json::to_string(&streamed).unwrap(),
            serde_json::to_string(&resident).unwrap()
        );
        let mut bad = bytes.clone();
        let n = bad.len();
        bad[n - 100] ^= 1;
        std::fs::write(&path, &bad).unwrap();
        let e = tg(&path, n as u64).unwrap_err().to_string();
        assert!(e.contains("fails its CRC") && e.contains("t.tg"), "{e}");
    }
}
