//! Files built by hand from the format description, as QSplat 1.0 lays them out (no original
//! `.qs` file was available): both byte orders, a comment, the 4-leaf quirk, and every error.
use super::*;
extern crate std;
use std::vec::Vec;

/// A node record in a byte order.
fn node(
    order: ByteOrder,
    sphere: u16,
    children: u8,
    grand: bool,
    normal: u16,
    cone: u8,
) -> [u8; 4] {
    let b = Node {
        sphere,
        children,
        grandchildren: grand,
        normal,
        cone,
        color: None,
    }
    .to_bytes();
    // Node records are big-endian whatever the file's order (FORMAT.md).
    let _ = order;
    [b[0], b[1], b[2], b[3]]
}

fn u32b(order: ByteOrder, v: u32) -> [u8; 4] {
    match order {
        ByteOrder::Big => v.to_be_bytes(),
        ByteOrder::Little => v.to_le_bytes(),
    }
}

const PZ: u16 = 4 * 2704 + 26 * 52 + 26; // a +Z normal

/// A comment, then a 7-leaf tree:
/// root → [A → (A1, A2), B, C → (C1, C2 → (C2a, C2b), C3)].
fn hand_made(order: ByteOrder) -> Vec<u8> {
    let mut f = Vec::new();
    f.extend_from_slice(b"QSplat11");
    f.extend_from_slice(&u32b(order, 36));
    f.extend_from_slice(&u32b(order, 0));
    f.extend_from_slice(&u32b(order, 2));
    f.extend_from_slice(b"made by hand\0\0\0\0");
    let t = f.len();
    f.extend_from_slice(b"QSplat11");
    f.extend_from_slice(&u32b(order, 88));
    f.extend_from_slice(&u32b(order, 7));
    f.extend_from_slice(&u32b(order, 0));
    for v in [1.0f32, 2.0, 3.0, 0.5] {
        f.extend_from_slice(&u32b(order, v.to_bits()));
    }
    f.extend_from_slice(&u32b(order, 3));
    // 40: root pointer → A's group at 56.
    f.extend_from_slice(&u32b(order, 16));
    f.extend_from_slice(&node(order, 100, 2, false, PZ, 1)); // 44 A
    f.extend_from_slice(&node(order, 200, 0, false, PZ, 0)); // 48 B
    f.extend_from_slice(&node(order, 300, 3, true, PZ, 2)); // 52 C
    f.extend_from_slice(&node(order, 1, 0, false, 5, 0)); // 56 A1
    f.extend_from_slice(&node(order, 2, 0, false, 6, 0)); // 60 A2
    f.extend_from_slice(&u32b(order, 16)); // 64: C's pointer → C2's group at 80
    f.extend_from_slice(&node(order, 3, 0, false, 7, 0)); // 68 C1
    f.extend_from_slice(&node(order, 7620, 2, false, 8, 3)); // 72 C2
    f.extend_from_slice(&node(order, 5, 0, false, 9, 0)); // 76 C3
    f.extend_from_slice(&node(order, 6, 0, false, 10, 0)); // 80 C2a
    f.extend_from_slice(&node(order, 7, 0, false, 11, 0)); // 84 C2b
    assert_eq!(f.len() - t, 88);
    f
}

fn breadth_first(tree: &Tree<'_>) -> Vec<(u16, u8, u16, u8)> {
    let mut out = Vec::new();
    let mut queue = std::vec![tree.root_group()];
    let mut k = 0;
    while k < queue.len() {
        for (_, n, g) in tree.children(queue[k]) {
            out.push((n.sphere, n.children, n.normal, n.cone));
            queue.extend(g);
        }
        k += 1;
    }
    out
}

#[test]
fn a_hand_made_file_reads_in_both_byte_orders() {
    let want = std::vec![
        (100, 2, PZ, 1),
        (200, 0, PZ, 0),
        (300, 3, PZ, 2),
        (1, 0, 5, 0),
        (2, 0, 6, 0),
        (3, 0, 7, 0),
        (7620, 2, 8, 3),
        (5, 0, 9, 0),
        (6, 0, 10, 0),
        (7, 0, 11, 0),
    ];
    for order in [ByteOrder::Big, ByteOrder::Little] {
        let bytes = hand_made(order);
        let q = QSplat::open(&bytes).unwrap();
        assert_eq!(q.byte_order(), order);
        let c = q.counts();
        assert_eq!((c.fragments, c.comments, c.trees), (2, 1, 1));
        assert_eq!(
            (c.leaves, c.interior, c.pointers, c.max_depth),
            (7, 3, 2, 3)
        );
        assert_eq!(
            c.header_bytes + c.node_bytes + 4 * c.pointers,
            bytes.len() as u64
        );
        assert_eq!(q.comments().next(), Some(&b"made by hand"[..]));
        let tree = q.trees().next().unwrap();
        assert_eq!((tree.center(), tree.radius()), ([1.0, 2.0, 3.0], 0.5));
        assert_eq!(tree.offset(), 36);
        assert_eq!(breadth_first(&tree), want);
        // No pocketsplat comment: framed by the decoded leaves, inside the root sphere's box.
        let root = [[0.5, 1.5, 2.5], [1.5, 2.5, 3.5]];
        assert_eq!(q.tree_bounds(0), root);
        let b = q.bounds();
        assert_eq!(b, q.tree_bounds(BOUNDS_DEPTH));
        assert!((0..3).all(|k| root[0][k] <= b[0][k] && b[0][k] < b[1][k] && b[1][k] <= root[1][k]));
        assert!(b != root, "{b:?}");
    }
}

/// A tree of 4 leaves under the root, with or without the root pointer.
fn four_leaves(pointer: bool) -> Vec<u8> {
    let o = ByteOrder::Big;
    let mut f = Vec::new();
    f.extend_from_slice(b"QSplat11");
    f.extend_from_slice(&u32b(o, if pointer { 60 } else { 56 }));
    f.extend_from_slice(&u32b(o, 4));
    f.extend_from_slice(&u32b(o, 0));
    for v in [0.0f32, 0.0, 0.0, 1.0] {
        f.extend_from_slice(&u32b(o, v.to_bits()));
    }
    f.extend_from_slice(&u32b(o, 4));
    if pointer {
        f.extend_from_slice(&u32b(o, 20));
    }
    for s in 0..4 {
        f.extend_from_slice(&node(o, s, 0, false, PZ, 0));
    }
    f
}

#[test]
fn the_four_leaf_root_quirk_is_read_by_length() {
    for pointer in [false, true] {
        let bytes = four_leaves(pointer);
        let q = QSplat::open(&bytes).unwrap();
        let tree = q.trees().next().unwrap();
        assert_eq!(tree.root_group().pointer.is_some(), pointer);
        assert_eq!(q.counts().leaves, 4);
        assert_eq!(breadth_first(&tree).len(), 4);
    }
}

/// A chain: each level holds an interior node and a leaf, `interior` levels deep.
fn chain_file(interior: usize) -> Vec<u8> {
    let o = ByteOrder::Big;
    let len = 40 + 12 * interior + 8;
    let mut f = Vec::new();
    f.extend_from_slice(b"QSplat11");
    f.extend_from_slice(&u32b(o, len as u32));
    f.extend_from_slice(&u32b(o, interior as u32 + 2));
    f.extend_from_slice(&u32b(o, 0));
    for v in [0.0f32, 0.0, 0.0, 1.0] {
        f.extend_from_slice(&u32b(o, v.to_bits()));
    }
    f.extend_from_slice(&u32b(o, 2));
    for level in 0..interior {
        f.extend_from_slice(&u32b(o, 12));
        let grand = level + 1 < interior;
        f.extend_from_slice(&node(o, 7620, 2, grand, PZ, 3));
        f.extend_from_slice(&node(o, 0, 0, false, PZ, 0));
    }
    f.extend_from_slice(&node(o, 0, 0, false, PZ, 0));
    f.extend_from_slice(&node(o, 0, 0, false, PZ, 0));
    f
}

#[test]
fn depth_is_limited() {
    let ok = chain_file(MAX_DEPTH - 1);
    assert_eq!(
        QSplat::open(&ok).unwrap().counts().max_depth as usize,
        MAX_DEPTH
    );
    let deep = chain_file(MAX_DEPTH);
    assert!(matches!(QSplat::open(&deep), Err(QsError::TooDeep { .. })));
}

fn set_u32(f: &mut [u8], at: usize, v: u32) {
    f[at..at + 4].copy_from_slice(&v.to_be_bytes());
}

#[test]
fn every_problem_is_a_specific_error() {
    let good = hand_made(ByteOrder::Big);
    let t = 36; // the tree fragment
    assert_eq!(
        QSplat::open(&good[..10]).unwrap_err(),
        QsError::TooShort(10)
    );
    let mut f = good.clone();
    f[0] = b'X';
    assert!(matches!(
        QSplat::open(&f),
        Err(QsError::BadMagic { offset: 0, .. })
    ));
    let mut f = good.clone();
    set_u32(&mut f, t + 8, 1000);
    assert_eq!(
        QSplat::open(&f).unwrap_err(),
        QsError::BadFragmentLength {
            offset: 36,
            length: 1000
        }
    );
    let mut f = good.clone();
    set_u32(&mut f, t + 16, 4);
    assert_eq!(
        QSplat::open(&f).unwrap_err(),
        QsError::UnknownOptions {
            offset: 36,
            options: 4
        }
    );
    assert_eq!(QSplat::open(&good[..36]).unwrap_err(), QsError::NoTree);
    let mut f = good.clone();
    set_u32(&mut f, t + 36, 5);
    assert_eq!(
        QSplat::open(&f).unwrap_err(),
        QsError::BadRootChildren {
            offset: 36,
            children: 5
        }
    );
    let mut f = good.clone();
    set_u32(&mut f, t + 32, f32::NAN.to_bits());
    assert_eq!(
        QSplat::open(&f).unwrap_err(),
        QsError::BadRootSphere { offset: 36 }
    );
    // B (at 48) gets sphere index 8000.
    let mut f = good.clone();
    f[t + 48..t + 52].copy_from_slice(&node(ByteOrder::Big, 8000, 0, false, PZ, 0));
    assert_eq!(
        QSplat::open(&f).unwrap_err(),
        QsError::BadSphereIndex {
            offset: 36 + 48,
            index: 8000
        }
    );
    let mut f = good.clone();
    f[t + 49] |= 4;
    assert_eq!(
        QSplat::open(&f).unwrap_err(),
        QsError::LeafWithGrandchildren { offset: 36 + 48 }
    );
    let mut f = good.clone();
    set_u32(&mut f, t + 40, (-4i32) as u32);
    assert_eq!(
        QSplat::open(&f).unwrap_err(),
        QsError::BadPointer {
            offset: 40,
            pointer: -4
        }
    );
    let mut f = good.clone();
    set_u32(&mut f, t + 12, 8);
    assert_eq!(
        QSplat::open(&f).unwrap_err(),
        QsError::LeafCount {
            offset: 36,
            expected: 8,
            found: 7
        }
    );
    let mut f = good.clone();
    f.extend_from_slice(&[0; 8]);
    set_u32(&mut f, t + 8, 96);
    assert_eq!(
        QSplat::open(&f).unwrap_err(),
        QsError::UnusedBytes {
            offset: 36,
            unused: 8
        }
    );
    // Cut the last node: C2's group runs past the fragment.
    let mut f = good[..good.len() - 4].to_vec();
    set_u32(&mut f, t + 8, 84);
    assert_eq!(
        QSplat::open(&f).unwrap_err(),
        QsError::OutOfBounds { offset: 80 }
    );
    // A has children but the root group... give B children instead: A's group has no pointer.
    let mut f = good.clone();
    f[t + 56..t + 60].copy_from_slice(&node(ByteOrder::Big, 1, 2, false, 5, 0));
    assert_eq!(
        QSplat::open(&f).unwrap_err(),
        QsError::ChildrenWithoutPointer { offset: 36 + 56 }
    );
    // Every error names itself.
    let e = std::format!(
        "{}",
        QsError::BadSphereIndex {
            offset: 7,
            index: 9000
        }
    );
    assert!(e.contains("9000") && e.contains("byte 7"), "{e}");
}

#[test]
fn mutated_files_never_panic() {
    let good = hand_made(ByteOrder::Big);
    let mut state = 0x2545_F491_4F6C_DD1Du64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let mut opened = 0;
    for _ in 0..20_000 {
        let mut f = good.clone();
        for _ in 0..1 + next() % 4 {
            let i = (next() % f.len() as u64) as usize;
            f[i] ^= 1 << (next() % 8);
        }
        let cut = if next() % 8 == 0 {
            (next() % f.len() as u64) as usize
        } else {
            f.len()
        };
        if let Ok(q) = QSplat::open(&f[..cut]) {
            opened += 1;
            for tree in q.trees() {
                let _ = breadth_first(&tree);
            }
            let _ = q.bounds();
        }
    }
    assert!(opened > 100, "some mutations stay valid: {opened}");
}
