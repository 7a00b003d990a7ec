//! Hostile bricked `.tg` files (version 3), made by class from a valid one, for the host tests
//! (`tests/hostile_bricks.rs`) and the QEMU leg (`tests/qemu_hostile.rs`): every kind of value a
//! file holds, damaged in ways that keep its CRCs valid (sealed), at several places (first, middle
//! and last cells of a level, of a brick, of the table).
//!
//! The classes: header fields (blocks against the source, the brick fields, the version); brick
//! table entries (each field moved by one either way, zeroed, maxed; entries swapped or doubled);
//! level counts; child masks in the head and in bricks (bits at or above ρ³ or above the cone
//! class, empty, a child more or fewer, a child moved); group pointers in the head and in bricks
//! (aliased to the predecessor's, backward, zero, past the end, one forward, and runs shifted alike
//! in the middle of a level or of a brick, the hole issue 17 closed); the leaves' partition between
//! two bricks; a truncated file.

use pocketsplat_core::tg::brick::{entry_bytes, Array};
use pocketsplat_core::tg::write::seal;
use pocketsplat_core::tg::{
    TriGrid, Verify, BRICKS_OFFSET, BRICK_LEVEL_OFFSET, CONE_SHIFT, DIRECTORY_ENTRY,
    DIRECTORY_OFFSET,
};

/// One hostile file: what was done, and the sealed bytes.
pub struct Case {
    /// What was damaged, for messages.
    pub name: String,
    /// The file.
    pub bytes: Vec<u8>,
}

fn put_u32(b: &mut [u8], at: usize, v: u32) {
    b[at..at + 4].copy_from_slice(&v.to_le_bytes());
}

fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(b[at..at + 4].try_into().expect("4 bytes"))
}

/// Every hostile file of every class made from `base`, a valid bricked file (version 3 with
/// bricks): a few hundred for a small grid.
///
/// # Panics
/// When `base` is not a valid bricked file.
pub fn bricked_cases(base: &[u8]) -> Vec<Case> {
    let grid = TriGrid::open(base, Verify::Full).expect("a valid file");
    let h = *grid.header();
    assert!(h.bricked(), "a bricked file");
    let r = h.brick_level;
    let mb = h.mask_bytes() as usize;
    let mut out = Vec::new();
    let mut push = |name: String, mut bytes: Vec<u8>, sealed: bool| {
        if sealed {
            seal(&mut bytes);
        }
        out.push(Case { name, bytes });
    };
    let edit = |f: &dyn Fn(&mut Vec<u8>)| {
        let mut b = base.to_vec();
        f(&mut b);
        b
    };
    // Cells to damage in a level: the first, one in the middle, the last.
    let picks = |n: u32| -> Vec<u32> {
        let mut v = vec![0, n / 2, n.saturating_sub(1)];
        v.dedup();
        v
    };

    // Header fields.
    let blocks = h.blocks;
    push(
        "header: twice the blocks the source holds".into(),
        edit(&|b| put_u32(b, 32, blocks * 2)),
        true,
    );
    for (what, at, v) in [
        ("brick count + 1", BRICKS_OFFSET, h.bricks + 1),
        ("brick count - 1", BRICKS_OFFSET, h.bricks - 1),
        ("brick count 0", BRICKS_OFFSET, 0),
        ("brick count max", BRICKS_OFFSET, u32::MAX),
        ("brick table + 16", BRICKS_OFFSET + 4, h.brick_table + 16),
        ("brick table - 16", BRICKS_OFFSET + 4, h.brick_table - 16),
        ("brick table at 0", BRICKS_OFFSET + 4, 0),
    ] {
        push(
            format!("header: {what}"),
            edit(&|b| put_u32(b, at, v)),
            true,
        );
    }
    for level in [r.wrapping_sub(1), r + 1, h.depth] {
        push(
            format!("header: brick level {level}"),
            edit(&|b| b[BRICK_LEVEL_OFFSET] = level),
            true,
        );
    }
    push(
        "header: version 2 (the bricked layout read as level-ordered)".into(),
        edit(&|b| b[4] = 2),
        true,
    );

    // The brick table.
    let entry = entry_bytes(r, h.depth);
    let words = entry / 4;
    for b in picks(h.bricks) {
        for k in 0..words {
            let at = h.brick_table as usize + entry * b as usize + 4 * k;
            let v = u32_at(base, at);
            for (what, nv) in [
                ("+1", v.wrapping_add(1)),
                ("-1", v.wrapping_sub(1)),
                ("0", 0),
                ("max", u32::MAX),
            ] {
                if nv != v {
                    push(
                        format!("table: brick {b} word {k} {what}"),
                        edit(&|x| put_u32(x, at, nv)),
                        true,
                    );
                }
            }
        }
    }
    if h.bricks >= 3 {
        let at = |b: u32| h.brick_table as usize + entry * b as usize;
        let m = h.bricks / 2;
        push(
            format!("table: entries {m} and {} swapped", m + 1),
            edit(&|x| {
                let a = x[at(m)..at(m) + entry].to_vec();
                x.copy_within(at(m + 1)..at(m + 1) + entry, at(m));
                x[at(m + 1)..at(m + 1) + entry].copy_from_slice(&a);
            }),
            true,
        );
        push(
            format!("table: entry {m} doubled"),
            edit(&|x| x.copy_within(at(m)..at(m) + entry, at(m + 1))),
            true,
        );
        // The leaves' partition: one leaf moved from brick m - 1 to brick m in the table.
        let leaf = at(m) + 4 * (words - 1);
        push(
            format!("table: brick {m} starts its leaves one earlier"),
            edit(&|x| {
                let v = u32_at(x, leaf);
                put_u32(x, leaf, v - 1);
            }),
            true,
        );
    }

    // Level counts.
    for l in 0..=h.depth {
        let at = DIRECTORY_OFFSET + DIRECTORY_ENTRY * usize::from(l);
        let n = grid.level(l).count;
        for (what, v) in [("+1", n + 1), ("-1", n - 1), ("0", 0), ("max", u32::MAX)] {
            push(
                format!("count: level {l} {what}"),
                edit(&|x| put_u32(x, at, v)),
                true,
            );
        }
    }

    // Child masks, in the head and in bricks.
    let slots = u32::from(h.rho).pow(3);
    let spare = if h.has_cones() { CONE_SHIFT + 3 } else { slots };
    for l in 0..h.depth {
        for i in picks(grid.level(l).count) {
            let Some(at) = grid.element_offset(l, Array::Mask, i) else {
                continue;
            };
            let word = grid.mask(l, i);
            let stored = {
                let mut w = [0u8; 16];
                w[..mb].copy_from_slice(&base[at..at + mb]);
                u128::from_le_bytes(w)
            };
            let mut masks = vec![("empty", 0u128)];
            if (spare as usize) < 8 * mb {
                masks.push(("a bit above the format's", stored | 1 << spare));
                masks.push(("the top bit", stored | 1 << (8 * mb - 1)));
            }
            if let Some(s) = (0..slots).find(|s| word >> s & 1 == 0) {
                masks.push(("a child more", stored | 1 << s));
                masks.push((
                    "a child moved",
                    (stored & !(word & word.wrapping_neg())) | 1 << s,
                ));
            }
            if word.count_ones() > 1 {
                masks.push(("a child fewer", stored & !(word & word.wrapping_neg())));
            }
            for (what, m) in masks {
                push(
                    format!("mask: level {l} cell {i} {what}"),
                    edit(&|x| x[at..at + mb].copy_from_slice(&m.to_le_bytes()[..mb])),
                    true,
                );
            }
        }
    }

    // Group pointers, in the head (levels below R) and in bricks (R and below).
    for l in 0..h.depth.saturating_sub(1) {
        let n = grid.level(l).count;
        let below = grid.level(l + 2).count;
        let at = |i: u32| {
            grid.element_offset(l, Array::Group, i)
                .expect("a group pointer")
        };
        for i in picks(n) {
            let g = grid.group(l, i);
            let prev = if i > 0 { grid.group(l, i - 1) } else { 0 };
            for (what, v) in [
                ("aliased to its predecessor's", prev),
                ("backward", prev.wrapping_sub(1)),
                ("zero", 0),
                ("forward by one", g + 1),
                ("past the end", below + 5),
                ("max", u32::MAX),
            ] {
                if v != g {
                    push(
                        format!("group: level {l} cell {i} {what}"),
                        edit(&|x| put_u32(x, at(i), v)),
                        true,
                    );
                }
            }
        }
        // Runs shifted alike: the middle third of the level, and (in a brick) the cells of one
        // brick but its first and last, by one either way.
        let mut runs = vec![(n / 3, 2 * n / 3)];
        if l >= r {
            if let Some(b) = grid.brick_at(l, n / 2) {
                let (f, c) = (b.first[usize::from(l)], b.count[usize::from(l)]);
                if c > 2 {
                    runs.push((f + 1, f + c - 1));
                }
                runs.push((f, f + c));
            }
        }
        for (a, z) in runs {
            if z <= a {
                continue;
            }
            for (what, d) in [("+1", 1i64), ("-1", -1)] {
                push(
                    format!("group: level {l} cells {a}..{z} shifted {what}"),
                    edit(&|x| {
                        for i in a..z {
                            let v = i64::from(u32_at(x, at(i))) + d;
                            put_u32(x, at(i), v as u32);
                        }
                    }),
                    true,
                );
            }
        }
    }

    // Truncated: half the file, sealed as what is left, the header still claiming the whole.
    push(
        "truncated to half".into(),
        edit(&|x| {
            let bs = h.block_size();
            x.truncate(x.len() / 2 / bs * bs);
            seal(x);
        }),
        false,
    );
    out
}

/// One hostile scene pack: what was done, the bytes, and what the simulator's error must say.
pub struct PackCase {
    /// What was damaged, for messages.
    pub name: &'static str,
    /// The pack.
    pub bytes: Vec<u8>,
    /// Words the simulator's streamed error must contain (`render --stream`).
    pub says: &'static str,
}

/// Hostile scene packs by class (issue 31, item 6), made from `good`, a valid pack whose object 0
/// is a tri-grid ground in 1 KB blocks, object 1 a tri-grid and object 2 a QSplat file: a header
/// and metadata cut short, half the pack, a metadata length and an object count beyond any pack's,
/// a NaN rotation, an object's data or length past the end, each kind called the other, an
/// object's header zeroed, a damaged block. Fields under the metadata's CRC are changed with the
/// CRC made right again, so that the checks behind it are what answers.
///
/// # Panics
/// When `good` is too short to be such a pack.
pub fn pack_cases(good: &[u8]) -> Vec<PackCase> {
    use pocketsplat_core::crc::crc32;
    let meta = u32_at(good, 16) as usize;
    let reseal = |mut b: Vec<u8>| {
        let end = meta.min(b.len());
        let crc = crc32(&b[16..end]);
        put_u32(&mut b, 12, crc);
        b
    };
    let object = |i: usize| 128 + 160 * i;
    let data_at = |b: &[u8], i: usize| u32_at(b, object(i) + 28) as usize;
    let case = |name, bytes, says| PackCase { name, bytes, says };
    let mut cases = vec![
        case(
            "a header cut short",
            good[..100].to_vec(),
            "shorter than the 128",
        ),
        case(
            "the metadata cut short",
            good[..meta - 10].to_vec(),
            "shorter than",
        ),
        case(
            "half the pack",
            good[..good.len() / 2].to_vec(),
            "header announces",
        ),
    ];
    let mut b = good.to_vec();
    put_u32(&mut b, 16, u32::MAX);
    cases.push(case(
        "metadata longer than any pack's",
        b,
        "metadata length 4294967295",
    ));
    let mut b = good.to_vec();
    b[20] = 200;
    cases.push(case("200 objects", reseal(b), "byte 20"));
    let mut b = good.to_vec();
    b[object(1) + 40..object(1) + 48].copy_from_slice(&f64::NAN.to_le_bytes());
    cases.push(case("a NaN rotation", reseal(b), "not finite"));
    let mut b = good.to_vec();
    let past = (good.len() as u32 + 4096) & !4095;
    put_u32(&mut b, object(1) + 28, past);
    cases.push(case(
        "an object past the end",
        reseal(b),
        "object 1: data at byte",
    ));
    let mut b = good.to_vec();
    put_u32(&mut b, object(2) + 32, u32::MAX);
    cases.push(case(
        "an object's length past the end",
        reseal(b),
        "object 2: data at byte",
    ));
    let mut b = good.to_vec();
    b[object(0) + 16] = 2;
    cases.push(case(
        "a tri-grid called a QSplat file",
        reseal(b),
        "not a QSplat",
    ));
    let mut b = good.to_vec();
    b[object(2) + 16] = 1;
    cases.push(case(
        "a QSplat file called a tri-grid",
        reseal(b),
        "object 2 (knot): not a .tg",
    ));
    let mut b = good.to_vec();
    let at = data_at(&b, 1);
    b[at..at + 64].fill(0);
    cases.push(case(
        "an object's header zeroed",
        b,
        "object 1 (tree): not a .tg",
    ));
    let mut b = good.to_vec();
    // The ground's second block (1 KB blocks): what opening it reads.
    let at = data_at(&b, 0) + 1024 + 10;
    b[at] ^= 0x5a;
    cases.push(case(
        "a damaged block of the ground",
        b,
        "block 1 fails its CRC",
    ));
    cases
}
