//! Reading `.qs` files: a raw layer of bounds-checked reads in the file's byte order, then [`QSplat`],
//! a view validated once by [`QSplat::open`] whose accessors cannot panic afterwards.
//!
//! `open` detects the byte order from the fragment lengths, walks every tree once (pointers in bounds
//! and forward, table indices valid, leaf counts as announced, no bytes left over) and keeps only
//! counts: the trees are read in place, so a file in flash costs no RAM.
#![deny(clippy::float_arithmetic)]

use super::table::SPHERE_COUNT;
use super::{
    BOUNDS_COMMENT_PREFIX, COMMENT_HEADER_BYTES, HEADER_BYTES, MAGIC, MAX_DEPTH, OPT_COLOR,
    OPT_COMMENT, POINTER_BYTES,
};

/// What is wrong with a `.qs` file. Each variant carries the offending value and, where it has one,
/// the byte offset in the file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum QsError {
    /// Shorter than a comment fragment's header (20 bytes).
    TooShort(usize),
    /// Larger than the 32-bit offsets of the format allow.
    TooLarge(usize),
    /// A fragment does not start with `QSplat11`.
    BadMagic {
        /// Offset of the fragment.
        offset: u32,
        /// The eight bytes found.
        magic: [u8; 8],
    },
    /// In neither byte order do the fragment lengths add up to the file: the length at `offset` is
    /// the first that does not fit (read big-endian).
    BadFragmentLength {
        /// Offset of the fragment.
        offset: u32,
        /// Its length field, big-endian.
        length: u32,
    },
    /// Unknown bits in a fragment's options.
    UnknownOptions {
        /// Offset of the fragment.
        offset: u32,
        /// The options word.
        options: u32,
    },
    /// The file holds only comments.
    NoTree,
    /// A tree fragment is shorter than its 40-byte header.
    TreeTooShort {
        /// Offset of the fragment.
        offset: u32,
        /// Its length.
        length: u32,
    },
    /// The root sphere is not finite or its radius is not positive.
    BadRootSphere {
        /// Offset of the fragment.
        offset: u32,
    },
    /// The root has a child count other than 2, 3 or 4.
    BadRootChildren {
        /// Offset of the fragment.
        offset: u32,
        /// The count found.
        children: u32,
    },
    /// A sibling group runs past the end of its fragment.
    OutOfBounds {
        /// Offset of the group (or of its pointer).
        offset: u32,
    },
    /// A group pointer points back into or before its own group, or past the fragment.
    BadPointer {
        /// Offset of the pointer.
        offset: u32,
        /// Its value.
        pointer: i32,
    },
    /// A node's position/radius index is not in the 7621-entry table.
    BadSphereIndex {
        /// Offset of the node.
        offset: u32,
        /// The index.
        index: u16,
    },
    /// A leaf has the grandchildren bit set.
    LeafWithGrandchildren {
        /// Offset of the node.
        offset: u32,
    },
    /// A node has children but its sibling group has no pointer to find them.
    ChildrenWithoutPointer {
        /// Offset of the node.
        offset: u32,
    },
    /// The tree is deeper than [`MAX_DEPTH`] levels below the root.
    TooDeep {
        /// Offset of the node that goes too deep.
        offset: u32,
    },
    /// Groups overlap: the walk reads more node bytes than the fragment holds.
    Overlap {
        /// Offset of the group where the count ran over.
        offset: u32,
    },
    /// The leaves found are not the number the header announces.
    LeafCount {
        /// Offset of the fragment.
        offset: u32,
        /// The header's count.
        expected: u32,
        /// Leaves found.
        found: u32,
    },
    /// Bytes after the tree that are more than padding to 4 bytes.
    UnusedBytes {
        /// Offset of the fragment.
        offset: u32,
        /// Bytes not reached by the tree.
        unused: u32,
    },
}

impl core::error::Error for QsError {}

impl core::fmt::Display for QsError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            QsError::TooShort(n) => write!(f, "file is {n} bytes, too short for a .qs fragment"),
            QsError::TooLarge(n) => write!(f, "file is {n} bytes; .qs offsets are 32-bit"),
            QsError::BadMagic { offset, magic } => write!(
                f,
                "byte {offset}: not a QSplat version 11 fragment (magic {magic:02x?}, expected \"QSplat11\")"
            ),
            QsError::BadFragmentLength { offset, length } => write!(
                f,
                "byte {offset}: fragment length {length} does not fit the file in either byte order"
            ),
            QsError::UnknownOptions { offset, options } => {
                write!(f, "byte {offset}: unknown fragment options {options:#x}")
            }
            QsError::NoTree => write!(f, "file holds only comment fragments"),
            QsError::TreeTooShort { offset, length } => write!(
                f,
                "byte {offset}: tree fragment of {length} bytes is shorter than its header"
            ),
            QsError::BadRootSphere { offset } => write!(
                f,
                "byte {offset}: root sphere is not finite or has no radius"
            ),
            QsError::BadRootChildren { offset, children } => write!(
                f,
                "byte {offset}: root has {children} children (2, 3 or 4 allowed)"
            ),
            QsError::OutOfBounds { offset } => {
                write!(f, "byte {offset}: sibling group runs past its fragment")
            }
            QsError::BadPointer { offset, pointer } => write!(
                f,
                "byte {offset}: group pointer {pointer} does not point forward into the fragment"
            ),
            QsError::BadSphereIndex { offset, index } => write!(
                f,
                "byte {offset}: sphere index {index} is past the {SPHERE_COUNT}-entry table"
            ),
            QsError::LeafWithGrandchildren { offset } => {
                write!(f, "byte {offset}: leaf node has the grandchildren bit set")
            }
            QsError::ChildrenWithoutPointer { offset } => write!(
                f,
                "byte {offset}: node has children but its group has no pointer"
            ),
            QsError::TooDeep { offset } => write!(
                f,
                "byte {offset}: tree is deeper than {MAX_DEPTH} levels"
            ),
            QsError::Overlap { offset } => {
                write!(f, "byte {offset}: sibling groups overlap")
            }
            QsError::LeafCount {
                offset,
                expected,
                found,
            } => write!(
                f,
                "byte {offset}: fragment announces {expected} leaves but holds {found}"
            ),
            QsError::UnusedBytes { offset, unused } => write!(
                f,
                "byte {offset}: {unused} bytes after the tree are not part of it"
            ),
        }
    }
}

use crate::bytes::take;
pub use crate::bytes::ByteOrder;

// ---- typed layer --------------------------------------------------------------------------------------

/// One node record: 4 bytes, or 6 with colour.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Node {
    /// Index into the position/radius table ([`super::table`]).
    pub sphere: u16,
    /// Number of children: 0 (a leaf), 2, 3 or 4.
    pub children: u8,
    /// The child group is preceded by a pointer: not all children are leaves.
    pub grandchildren: bool,
    /// 14-bit normal index ([`super::normal`]).
    pub normal: u16,
    /// 2-bit normal-cone code.
    pub cone: u8,
    /// RGB565 colour, when the fragment has colours.
    pub color: Option<u16>,
}

impl Node {
    /// Packs the record as the file stores it (big-endian).
    pub fn to_bytes(&self) -> [u8; 6] {
        let code = match self.children {
            0 => 0u8,
            n => n.saturating_sub(1).min(3),
        };
        let s = self.sphere & 0x1FFF;
        let b1 = ((s & 31) as u8) << 3 | u8::from(self.grandchildren) << 2 | code;
        let nc = (self.normal & 0x3FFF) << 2 | u16::from(self.cone & 3);
        let [c0, c1] = self.color.unwrap_or(0).to_be_bytes();
        let [n0, n1] = nc.to_be_bytes();
        [(s >> 5) as u8, b1, n0, n1, c0, c1]
    }
}

/// A sibling group: the children of one parent, stored contiguously, optionally preceded by a pointer
/// to the first child group of its first non-leaf member.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Group {
    /// Offset of the pointer within the fragment, when there is one.
    pub pointer: Option<u32>,
    /// Offset of the first node within the fragment.
    pub first: u32,
    /// Number of nodes (2–4).
    pub count: u8,
}

/// One tree fragment: a header with the root sphere, then its nodes in breadth-first order.
#[derive(Clone, Copy, Debug)]
pub struct Tree<'a> {
    bytes: &'a [u8],
    order: ByteOrder,
    offset: u32,
    leaves: u32,
    color: bool,
    center: [f32; 3],
    radius: f32,
    root: Group,
}

impl<'a> Tree<'a> {
    /// Offset of the fragment in the file.
    pub fn offset(&self) -> u32 {
        self.offset
    }
    /// The fragment's bytes, header included.
    pub fn bytes(&self) -> &'a [u8] {
        self.bytes
    }
    /// Leaf points.
    pub fn leaves(&self) -> u32 {
        self.leaves
    }
    /// Whether nodes carry RGB565 colours (6-byte nodes).
    pub fn has_color(&self) -> bool {
        self.color
    }
    /// Bytes per node record.
    pub fn node_bytes(&self) -> u32 {
        if self.color {
            6
        } else {
            4
        }
    }
    /// Centre of the root sphere, model units.
    pub fn center(&self) -> [f32; 3] {
        self.center
    }
    /// Radius of the root sphere, model units.
    pub fn radius(&self) -> f32 {
        self.radius
    }
    /// The root's children (the root itself has no record: its sphere is in the header and it has
    /// no normal).
    pub fn root_group(&self) -> Group {
        self.root
    }

    /// The node record at `at` (zeros where the fragment ends; never after [`QSplat::open`]).
    #[inline]
    pub fn node(&self, at: u32) -> Node {
        node_at(self.bytes, at as usize, self.color)
    }

    /// The 32-bit group pointer at `at` (0 where the fragment ends).
    #[inline]
    pub fn pointer(&self, at: u32) -> i32 {
        self.order.u32(self.bytes, at as usize).unwrap_or(0) as i32
    }

    /// The nodes of `group` in order, each with its own child group.
    #[inline]
    pub fn children(&self, group: Group) -> Children<'a> {
        let cursor = match group.pointer {
            Some(p) => i64::from(p) + i64::from(self.pointer(p)),
            None => 0,
        };
        Children(Records {
            bytes: self.bytes,
            color: self.color,
            at: group.first,
            left: group.count,
            cursor: u32::try_from(cursor).unwrap_or(u32::MAX),
        })
    }

    /// What the header says, without the bytes.
    pub fn head(&self) -> TreeHead {
        TreeHead {
            offset: self.offset,
            len: self.bytes.len() as u32,
            leaves: self.leaves,
            color: self.color,
            center: self.center,
            radius: self.radius,
            root: self.root,
        }
    }
}

/// The node record at `at` of `bytes` (zeros where they end). Node records are big-endian in every
/// file: QSplat 1.0 wrote them byte by byte and swapped only the header fields and the pointers
/// (FORMAT.md, "Byte order").
#[inline]
pub(crate) fn node_at(bytes: &[u8], at: usize, color: bool) -> Node {
    // The whole record in one read where it is all there (every record of a validated file).
    let (b0, b1, nc) = match ByteOrder::Big.u32(bytes, at) {
        Some(w) => ((w >> 24) as u8, (w >> 16) as u8, w as u16),
        None => {
            let (Some(b0), Some(b1)) = (bytes.get(at), bytes.get(at + 1)) else {
                return Node::default();
            };
            (*b0, *b1, ByteOrder::Big.u16(bytes, at + 2).unwrap_or(0))
        }
    };
    let code = b1 & 3;
    Node {
        sphere: u16::from(b0) << 5 | u16::from(b1 >> 3),
        children: if code == 0 { 0 } else { code + 1 },
        grandchildren: b1 & 4 != 0,
        normal: nc >> 2,
        cone: (nc & 3) as u8,
        color: if color {
            Some(ByteOrder::Big.u16(bytes, at + 4).unwrap_or(0))
        } else {
            None
        },
    }
}

/// What a tree fragment's header says: where the fragment is, its root sphere and root group. A
/// streamed tree is known by its head alone; its nodes stay on the medium.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TreeHead {
    /// Offset of the fragment in the file.
    pub offset: u32,
    /// Its length, header included.
    pub len: u32,
    /// Leaf points.
    pub leaves: u32,
    /// Whether nodes carry RGB565 colours (6-byte nodes).
    pub color: bool,
    /// Centre of the root sphere, model units.
    pub center: [f32; 3],
    /// Radius of the root sphere, model units.
    pub radius: f32,
    /// The root's children.
    pub root: Group,
}

impl TreeHead {
    /// Bytes per node record.
    pub fn node_bytes(&self) -> u32 {
        if self.color {
            6
        } else {
            4
        }
    }

    /// The head of the tree fragment whose first 40 bytes are `header`, `len` bytes long, at
    /// `offset` (no validation beyond bounds).
    pub fn parse(header: &[u8], len: u32, order: ByteOrder, offset: u32) -> Option<Self> {
        let leaves = order.u32(header, 12)?;
        let color = order.u32(header, 16)? & OPT_COLOR != 0;
        let f = |i: usize| order.f32(header, 20 + 4 * i);
        let center = [f(0)?, f(1)?, f(2)?];
        let radius = f(3)?;
        let children = order.u32(header, 36)?;
        let node_bytes = if color { 6 } else { 4 };
        let count = u8::try_from(children).unwrap_or(u8::MAX);
        // The root's group starts with a pointer, except that QSplat 1.0 wrote none for a model of
        // exactly 4 leaves. Only when every root child is a leaf can the pointer be missing, and
        // then the fragment length tells: the pointer adds exactly 4 bytes.
        let bare = HEADER_BYTES as u64 + u64::from(children) * node_bytes;
        let pointer = !(u64::from(leaves) == u64::from(children) && u64::from(len) < bare + 4);
        let root = Group {
            pointer: pointer.then_some(HEADER_BYTES as u32),
            first: HEADER_BYTES as u32 + if pointer { POINTER_BYTES } else { 0 },
            count,
        };
        Some(Self {
            offset,
            len,
            leaves,
            color,
            center,
            radius,
            root,
        })
    }
}

/// Iterator over a sibling group: `(offset, node, child group)`.
#[derive(Clone, Debug)]
pub struct Children<'a>(Records<&'a [u8]>);

impl Iterator for Children<'_> {
    type Item = (u32, Node, Option<Group>);

    #[inline]
    fn next(&mut self) -> Option<Self::Item> {
        self.0.next()
    }
}

/// Where a group's records are: the whole fragment in place, or one group copied out of a block
/// cache ([`GroupBytes`]).
pub(crate) trait RecordBytes {
    /// The bytes and the index in them of fragment offset `at`.
    fn at(&self, at: u32) -> (&[u8], usize);
}

impl RecordBytes for &[u8] {
    #[inline(always)]
    fn at(&self, at: u32) -> (&[u8], usize) {
        (self, at as usize)
    }
}

/// One group's bytes copied out of a block cache: the fragment from offset `base` on.
#[derive(Clone, Debug)]
#[cfg_attr(not(feature = "stream"), allow(dead_code))]
pub(crate) struct GroupBytes<const N: usize> {
    pub(crate) bytes: [u8; N],
    pub(crate) base: u32,
}

impl<const N: usize> RecordBytes for GroupBytes<N> {
    #[inline(always)]
    fn at(&self, at: u32) -> (&[u8], usize) {
        (&self.bytes, at.wrapping_sub(self.base) as usize)
    }
}

/// A sibling group's records read from `bytes`.
#[derive(Clone, Debug)]
pub(crate) struct Records<B> {
    pub(crate) bytes: B,
    pub(crate) color: bool,
    /// Offset of the next record in the fragment.
    pub(crate) at: u32,
    pub(crate) left: u8,
    /// Where the next child group starts (the target of the group's pointer, then each child
    /// group's end).
    pub(crate) cursor: u32,
}

impl<B: RecordBytes> Iterator for Records<B> {
    type Item = (u32, Node, Option<Group>);

    #[inline]
    fn next(&mut self) -> Option<Self::Item> {
        if self.left == 0 {
            return None;
        }
        self.left -= 1;
        let at = self.at;
        let nb = if self.color { 6 } else { 4 };
        let (bytes, i) = self.bytes.at(at);
        let node = node_at(bytes, i, self.color);
        self.at = at.saturating_add(nb);
        let group = (node.children > 0).then(|| {
            let pointer = node.grandchildren.then_some(self.cursor);
            let first =
                self.cursor
                    .saturating_add(if node.grandchildren { POINTER_BYTES } else { 0 });
            self.cursor = first.saturating_add(u32::from(node.children) * nb);
            Group {
                pointer,
                first,
                count: node.children,
            }
        });
        Some((at, node, group))
    }
}

/// One fragment, as the file lists them.
#[derive(Clone, Copy, Debug)]
pub enum Fragment<'a> {
    /// A comment: its text (padding included).
    Comment(&'a [u8]),
    /// A tree.
    Tree(Tree<'a>),
}

/// What a file holds, counted once by [`QSplat::open`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct QsCounts {
    /// Fragments, comments included.
    pub fragments: u32,
    /// Comment fragments.
    pub comments: u32,
    /// Tree fragments.
    pub trees: u32,
    /// Leaf nodes (the points).
    pub leaves: u64,
    /// Interior node records (the roots, which have none, not counted).
    pub interior: u64,
    /// Group pointers.
    pub pointers: u64,
    /// Deepest level below a root (the root's children are level 1).
    pub max_depth: u8,
    /// Tree fragments with colours.
    pub color_trees: u32,
    /// Bytes of fragment headers (comments included) and padding.
    pub header_bytes: u64,
    /// Bytes of node records.
    pub node_bytes: u64,
}

/// A validated `.qs` file.
#[derive(Clone, Copy, Debug)]
pub struct QSplat<'a> {
    bytes: &'a [u8],
    order: ByteOrder,
    counts: QsCounts,
    /// [`QSplat::bounds`], found once at open.
    bounds: [[f32; 3]; 2],
}

/// Iterator over a file's fragments.
#[derive(Clone, Debug)]
pub struct Fragments<'a> {
    bytes: &'a [u8],
    order: ByteOrder,
    at: usize,
}

impl<'a> Iterator for Fragments<'a> {
    type Item = Fragment<'a>;

    fn next(&mut self) -> Option<Fragment<'a>> {
        let at = self.at;
        let length = self.order.u32(self.bytes, at + 8)? as usize;
        let frag = self.bytes.get(at..at.checked_add(length)?)?;
        self.at = at + length.max(1);
        let options = self.order.u32(frag, 16)?;
        if options & OPT_COMMENT != 0 {
            return Some(Fragment::Comment(frag.get(COMMENT_HEADER_BYTES..)?));
        }
        Some(Fragment::Tree(tree_header(frag, self.order, at as u32)?))
    }
}

/// The typed header of a tree fragment (no validation beyond bounds).
fn tree_header(frag: &[u8], order: ByteOrder, offset: u32) -> Option<Tree<'_>> {
    let h = TreeHead::parse(frag, frag.len() as u32, order, offset)?;
    Some(Tree {
        bytes: frag,
        order,
        offset,
        leaves: h.leaves,
        color: h.color,
        center: h.center,
        radius: h.radius,
        root: h.root,
    })
}

/// Walks the fragments' lengths in one byte order: `Ok` when they add up to the file exactly.
fn chain(bytes: &[u8], order: ByteOrder) -> Result<(), QsError> {
    let mut at = 0usize;
    while at < bytes.len() {
        let magic = take::<8>(bytes, at).unwrap_or([0; 8]);
        if magic != MAGIC {
            return Err(QsError::BadMagic {
                offset: at as u32,
                magic,
            });
        }
        let length = order.u32(bytes, at + 8).unwrap_or(0);
        let fits = (length as usize) >= COMMENT_HEADER_BYTES
            && at
                .checked_add(length as usize)
                .is_some_and(|end| end <= bytes.len());
        if !fits {
            return Err(QsError::BadFragmentLength {
                offset: at as u32,
                length: ByteOrder::Big.u32(bytes, at + 8).unwrap_or(0),
            });
        }
        at += length as usize;
    }
    Ok(())
}

/// Running totals of one tree's validation walk.
struct Walk<'t, 'a> {
    tree: &'t Tree<'a>,
    /// Node and pointer bytes reached so far.
    bytes: u64,
    /// Bytes the fragment has for them.
    budget: u64,
    leaves: u64,
    interior: u64,
    pointers: u64,
    max_depth: u8,
}

impl Walk<'_, '_> {
    fn group(&mut self, g: Group, depth: u8) -> Result<(), QsError> {
        let nb = u64::from(self.tree.node_bytes());
        let len = self.tree.bytes.len() as u64;
        let start = g.pointer.unwrap_or(g.first);
        let end = u64::from(g.first) + u64::from(g.count) * nb;
        if end > len {
            return Err(QsError::OutOfBounds { offset: start });
        }
        self.bytes += end - u64::from(start);
        if self.bytes > self.budget {
            return Err(QsError::Overlap { offset: start });
        }
        if let Some(p) = g.pointer {
            self.pointers += 1;
            let pointer = self.tree.pointer(p);
            let target = i64::from(p) + i64::from(pointer);
            if target < end as i64 || target > len as i64 {
                // A group whose members are all leaves needs no target (QSplat 1.0's root group of
                // a 2- or 3-leaf model has a pointer anyway).
                let any_children = self.tree.children(g).any(|(_, n, _)| n.children > 0);
                if any_children {
                    return Err(QsError::BadPointer { offset: p, pointer });
                }
            }
        }
        self.max_depth = self.max_depth.max(depth);
        for (at, node, child) in self.tree.children(g) {
            if usize::from(node.sphere) >= SPHERE_COUNT {
                return Err(QsError::BadSphereIndex {
                    offset: self.tree.offset + at,
                    index: node.sphere,
                });
            }
            match child {
                None => {
                    if node.grandchildren {
                        return Err(QsError::LeafWithGrandchildren {
                            offset: self.tree.offset + at,
                        });
                    }
                    self.leaves += 1;
                }
                Some(child) => {
                    if g.pointer.is_none() {
                        return Err(QsError::ChildrenWithoutPointer {
                            offset: self.tree.offset + at,
                        });
                    }
                    if usize::from(depth) >= MAX_DEPTH {
                        return Err(QsError::TooDeep {
                            offset: self.tree.offset + at,
                        });
                    }
                    self.interior += 1;
                    self.group(child, depth + 1)?;
                }
            }
        }
        Ok(())
    }
}

impl<'a> QSplat<'a> {
    /// Validates a whole file once: fragments, byte order, every tree's structure.
    ///
    /// # Errors
    /// The first problem found, as a [`QsError`] naming the offending value and offset.
    pub fn open(bytes: &'a [u8]) -> Result<Self, QsError> {
        if bytes.len() < COMMENT_HEADER_BYTES {
            return Err(QsError::TooShort(bytes.len()));
        }
        if u32::try_from(bytes.len()).is_err() {
            return Err(QsError::TooLarge(bytes.len()));
        }
        let order = match chain(bytes, ByteOrder::Big) {
            Ok(()) => ByteOrder::Big,
            Err(e) => match chain(bytes, ByteOrder::Little) {
                Ok(()) => ByteOrder::Little,
                Err(_) => return Err(e),
            },
        };
        let mut counts = QsCounts::default();
        let mut at = 0usize;
        while at < bytes.len() {
            // `chain` checked every length and magic.
            let length = order.u32(bytes, at + 8).unwrap_or(0) as usize;
            let frag = bytes.get(at..at + length).unwrap_or(&[]);
            let offset = at as u32;
            at += length.max(1);
            counts.fragments += 1;
            let options = order.u32(frag, 16).unwrap_or(0);
            if options & !(OPT_COLOR | OPT_COMMENT) != 0 {
                return Err(QsError::UnknownOptions { offset, options });
            }
            if options & OPT_COMMENT != 0 {
                counts.comments += 1;
                counts.header_bytes += length as u64;
                continue;
            }
            let Some(tree) = tree_header(frag, order, offset).filter(|_| length >= HEADER_BYTES)
            else {
                return Err(QsError::TreeTooShort {
                    offset,
                    length: length as u32,
                });
            };
            let finite = tree.center.iter().all(|c| c.is_finite()) && tree.radius.is_finite();
            if !finite || tree.radius.is_sign_negative() || tree.radius.to_bits() == 0 {
                return Err(QsError::BadRootSphere { offset });
            }
            let children = order.u32(frag, 36).unwrap_or(0);
            if !(2..=4).contains(&children) {
                return Err(QsError::BadRootChildren { offset, children });
            }
            let mut walk = Walk {
                tree: &tree,
                bytes: 0,
                budget: (length - HEADER_BYTES) as u64,
                leaves: 0,
                interior: 0,
                pointers: 0,
                max_depth: 0,
            };
            walk.group(tree.root, 1)?;
            if walk.leaves != u64::from(tree.leaves) {
                return Err(QsError::LeafCount {
                    offset,
                    expected: tree.leaves,
                    found: u32::try_from(walk.leaves).unwrap_or(u32::MAX),
                });
            }
            let unused = walk.budget - walk.bytes;
            if unused >= 4 {
                return Err(QsError::UnusedBytes {
                    offset,
                    unused: unused as u32,
                });
            }
            counts.trees += 1;
            counts.color_trees += u32::from(tree.color);
            counts.leaves += walk.leaves;
            counts.interior += walk.interior;
            counts.pointers += walk.pointers;
            counts.max_depth = counts.max_depth.max(walk.max_depth);
            counts.node_bytes += (walk.leaves + walk.interior) * u64::from(tree.node_bytes());
            counts.header_bytes += HEADER_BYTES as u64 + unused;
        }
        if counts.trees == 0 {
            return Err(QsError::NoTree);
        }
        let mut file = Self {
            bytes,
            order,
            counts,
            bounds: [[0.0; 3]; 2],
        };
        file.bounds = file
            .comments()
            .find_map(parse_bounds)
            .unwrap_or_else(|| file.tree_bounds(BOUNDS_DEPTH));
        Ok(file)
    }

    /// The file's bytes.
    pub fn bytes(&self) -> &'a [u8] {
        self.bytes
    }
    /// The byte order detected.
    pub fn byte_order(&self) -> ByteOrder {
        self.order
    }
    /// What the file holds.
    pub fn counts(&self) -> &QsCounts {
        &self.counts
    }
    /// Every fragment in file order.
    pub fn fragments(&self) -> Fragments<'a> {
        Fragments {
            bytes: self.bytes,
            order: self.order,
            at: 0,
        }
    }
    /// The tree fragments in file order.
    pub fn trees(&self) -> impl Iterator<Item = Tree<'a>> + Clone + 'a {
        self.fragments().filter_map(|f| match f {
            Fragment::Tree(t) => Some(t),
            Fragment::Comment(_) => None,
        })
    }
    /// The comment fragments' texts (trailing NUL padding removed).
    pub fn comments(&self) -> impl Iterator<Item = &'a [u8]> + 'a {
        self.fragments().filter_map(|f| match f {
            Fragment::Comment(text) => {
                let end = text.iter().rposition(|&b| b != 0).map_or(0, |i| i + 1);
                Some(&text[..end])
            }
            Fragment::Tree(_) => None,
        })
    }
    /// The model's bounding box, `[min, max]` in model units: the one pocketsplat's writer records in
    /// its comment fragment (`pocketsplat bounds=…`, the mesh's box, so that views of a `.qs` and a
    /// `.tg` of the same mesh frame it identically), else the box around the decoded spheres of the
    /// trees down to [`BOUNDS_DEPTH`] levels (their leaves in most files). Found once, at open: the
    /// root sphere alone is about twice the model's half-diagonal, so a file without the comment
    /// (every file QSplat 1.0 made) would be drawn at half size.
    pub fn bounds(&self) -> [[f32; 3]; 2] {
        self.bounds
    }

    /// The box around every tree's decoded spheres at depth `max_depth` (or at their leaves, where
    /// a tree ends first; depth 0: the root spheres): the spheres enclose their subtrees, so the box
    /// encloses the model.
    pub fn tree_bounds(&self, max_depth: usize) -> [[f32; 3]; 2] {
        tree_bounds_by(self.trees().map(|t| (t.head(), t)), max_depth, |t, g| {
            Some(t.children(g))
        })
    }
}

/// [`QSplat::tree_bounds`] of the trees `trees` yields, each group's records read by `children`
/// (`None`: a group that cannot be read, left out): the resident file's, or a stream's at open.
#[allow(clippy::float_arithmetic)] // setup, once per file
pub(crate) fn tree_bounds_by<T, R: Iterator<Item = (u32, Node, Option<Group>)>>(
    trees: impl Iterator<Item = (TreeHead, T)>,
    max_depth: usize,
    mut children: impl FnMut(&mut T, Group) -> Option<R>,
) -> [[f32; 3]; 2] {
    let mut b = [[f32::MAX; 3], [f32::MIN; 3]];
    let mut add = |c: [f32; 3], r: f32| {
        for k in 0..3 {
            b[0][k] = b[0][k].min(c[k] - r);
            b[1][k] = b[1][k].max(c[k] + r);
        }
    };
    // Depth first with a fixed stack: at most 4 siblings wait per level.
    let mut stack = [(Group::default(), [0f32; 3], 0f32, 0usize); 4 * (BOUNDS_DEPTH + 1)];
    for (head, mut t) in trees {
        if max_depth == 0 {
            add(head.center, head.radius);
            continue;
        }
        stack[0] = (head.root, head.center, head.radius, 1);
        let mut n = 1;
        while n > 0 {
            n -= 1;
            let (g, pc, pr, depth) = stack[n];
            let Some(records) = children(&mut t, g) else {
                continue;
            };
            for (_, node, child) in records {
                let Some(e) = super::table::sphere(node.sphere) else {
                    continue;
                };
                let k = pr / 13.0;
                let c = [
                    pc[0] + k * f32::from(e.a),
                    pc[1] + k * f32::from(e.b),
                    pc[2] + k * f32::from(e.c),
                ];
                let r = k * f32::from(e.s);
                match child {
                    Some(g) if depth < max_depth.min(BOUNDS_DEPTH) && n < stack.len() => {
                        stack[n] = (g, c, r, depth + 1);
                        n += 1;
                    }
                    _ => add(c, r),
                }
            }
        }
    }
    b
}

/// Levels of the trees [`QSplat::bounds`] decodes for a file without pocketsplat's bounds comment:
/// 8 (at most 4⁸ spheres per tree, the leaves of most scans), bounded so that opening a big file on
/// a device stays cheap.
pub const BOUNDS_DEPTH: usize = 8;

/// The bounding box in a comment `pocketsplat … bounds=x0,y0,z0,x1,y1,z1 …`, when it is one and
/// every number is finite with min ≤ max.
pub fn parse_bounds(comment: &[u8]) -> Option<[[f32; 3]; 2]> {
    let text = core::str::from_utf8(comment).ok()?;
    if !text.starts_with(BOUNDS_COMMENT_PREFIX) {
        return None;
    }
    let list = text
        .split_whitespace()
        .find_map(|w| w.strip_prefix("bounds="))?;
    let mut v = [0f32; 6];
    let mut parts = list.split(',');
    for x in &mut v {
        *x = parts.next()?.parse().ok().filter(|x: &f32| x.is_finite())?;
    }
    if parts.next().is_some() || (0..3).any(|k| v[k] > v[k + 3]) {
        return None;
    }
    Some([[v[0], v[1], v[2]], [v[3], v[4], v[5]]])
}

#[cfg(test)]
mod tests;
