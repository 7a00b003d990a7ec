//! Hostile `.tg` files (issue 9): real baked files truncated at every block boundary, a flipped bit in
//! every header field, pointers that point backwards, into themselves or past the end, child masks
//! inconsistent with the data, depth beyond the limit, 4 GB length fields, levels that alias one
//! another. `TriGrid::open` must answer each with the specific error variant carrying the offending
//! value; what opens must render within the traversal's bounds (at most one visit per sample per
//! pass, no level deeper than the file: `render_bounded`). A panic anywhere is a failure, and the test
//! profile keeps overflow checks on.
//!
//! Most damage is "sealed" afterwards (`write::seal` or `seal_header`): its CRCs are recomputed, so
//! that the field and structure checks are what fires, not the checksum.
//!
//! The files here have one array per level (version 2, and version 3 without bricks), which these
//! mutations address through the level directory; bricked files (version 3's default) have their
//! own hostile tests in `hostile_bricks.rs`.

use pocketsplat_core::bake::{BakeOptions, TriMesh};
use pocketsplat_core::camera::{Placement, View, STANDARD_VIEWS};
use pocketsplat_core::crc::crc32;
use pocketsplat_core::render::RenderOptions;
use pocketsplat_core::splat::NullSink;
use pocketsplat_core::tg::write::{seal, write_tg_as, Layout};
use pocketsplat_core::tg::{
    render_tg, TgError, TgFrame, TriGrid, Verify, CONE_SHIFT, DIRECTORY_ENTRY, DIRECTORY_OFFSET,
    FLAG_COLOR, FLAG_CONES, FLAG_PRECISE, MAX_DEPTH,
};
use pocketsplat_sim::bake::bake_mesh;
use pocketsplat_sim::render::{render_tg_frame, FrameBuffers, Settings, ShadowMode};

/// 512-byte blocks: the most blocks, so the most boundaries, per file.
const LOG2: u8 = 9;
const BS: usize = 1 << LOG2;

/// `mesh` baked and written in version 2's layout: every level one array (`Layout::Version2` or
/// `Layout::Unbricked`).
fn bake_as(mesh: &TriMesh, rho: u8, depth: u8, log2: u8, layout: Layout) -> Vec<u8> {
    let (grid, _) = bake_mesh(mesh, BakeOptions { rho, depth }, log2, false).expect("bakes");
    write_tg_as(&grid, log2, layout).expect("writes")
}

fn bake(mesh: &TriMesh, rho: u8, depth: u8, log2: u8) -> Vec<u8> {
    bake_as(mesh, rho, depth, log2, Layout::Unbricked)
}

/// The demo's trefoil knot, coarse, with three materials and vertex colours.
fn trefoil() -> TriMesh {
    let mut mesh = pocketsplat_sim::demo::trefoil(96, 8, 0.45);
    mesh.materials = Some((0..mesh.triangles.len()).map(|t| (t % 3) as u8).collect());
    mesh.colors = Some(
        (0..mesh.positions.len())
            .map(|v| [(v * 37) as u8, (v * 11) as u8, 200])
            .collect(),
    );
    mesh
}

/// Real baked files: the trefoil as a tri-grid (with colours and materials) and as an octree, and the
/// Stanford bunny (res4) as a tri-grid when the models are present (always under CI); each as
/// version 2 and as version 3 without bricks.
fn bases() -> Vec<(String, Vec<u8>)> {
    let t = trefoil();
    let mut plain = t.clone();
    plain.materials = None;
    plain.colors = None;
    let mut meshes = vec![
        ("trefoil rho 3 depth 4", t, 3, 4),
        ("trefoil rho 2 depth 5", plain, 2, 5),
    ];
    if let Some(path) = pocketsplat_tests::model("bun_zipper_res4.ply") {
        let bunny = pocketsplat_sim::ply::load_mesh(&path).expect("bunny loads");
        meshes.push(("bunny rho 3 depth 4", bunny, 3, 4));
    }
    let mut out = Vec::new();
    for (name, mesh, rho, depth) in meshes {
        for (v, layout) in [("v2", Layout::Version2), ("v3", Layout::Unbricked)] {
            out.push((
                format!("{name} {v}"),
                bake_as(&mesh, rho, depth, LOG2, layout),
            ));
        }
    }
    out
}

fn open(bytes: &[u8]) -> Result<TriGrid<'_>, TgError> {
    TriGrid::open(bytes, Verify::Full)
}

/// Recomputes the header block's CRC only.
fn seal_header(bytes: &mut [u8]) {
    let bs = 1usize << bytes[12];
    let c = crc32(&bytes[..bs - 4]);
    bytes[bs - 4..bs].copy_from_slice(&c.to_le_bytes());
}

fn u32_at(bytes: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap())
}

fn put_u32(bytes: &mut [u8], at: usize, v: u32) {
    bytes[at..at + 4].copy_from_slice(&v.to_le_bytes());
}

/// Byte offset of a level directory field: 0 count, 1 attributes, 2 colours, 3 masks, 4 groups.
fn dir_at(level: usize, field: usize) -> usize {
    DIRECTORY_OFFSET + DIRECTORY_ENTRY * level + 4 * field
}

/// Renders `grid` from many views, cutoffs and shadow modes, and checks the traversal's bounds.
/// Returns the nodes visited over all frames without shadows (to compare files).
fn render_bounded(grid: &TriGrid<'_>) -> u64 {
    render_views(grid, true)
}

/// [`render_bounded`], from a few views only when not `thorough` (thousands of files).
fn render_views(grid: &TriGrid<'_>, thorough: bool) -> u64 {
    render_views_culling(grid, thorough, true)
}

/// [`render_views`] with backface culling (per splat and by normal cones) on or off.
fn render_views_culling(grid: &TriGrid<'_>, thorough: bool, backface_culling: bool) -> u64 {
    let h = *grid.header();
    let total = grid.total_samples();
    let mut views: Vec<View> = STANDARD_VIEWS.iter().map(|(_, v)| *v).collect();
    views.extend([
        View::new(0.0, 90.0, 2.5),
        View::new(10.0, -90.0, 0.01),
        View::new(200.0, 5.0, 1e-6),
        View::new(-30.0, 45.0, 1e30),
    ]);
    let cutoffs: &[f32] = if thorough { &[1e-3, 1.0, 64.0] } else { &[0.5] };
    if !thorough {
        views.drain(1..5);
    }
    let mut visited = 0u64;
    for view in views {
        for &cutoff in cutoffs {
            let settings = Settings {
                view,
                cutoff_px: cutoff,
                ..Settings::default()
            };
            let cam = settings.camera(h.bounds);
            let opts = RenderOptions {
                cutoff_px: cutoff,
                backface_culling,
                ..RenderOptions::default()
            };
            // A header number so extreme that no frame can be set up is refused here, not drawn.
            let Ok(frame) = TgFrame::new(&h, &Placement::IDENTITY, &cam, &opts) else {
                continue;
            };
            let s = render_tg(grid, &frame, &mut NullSink::default());
            assert!(u64::from(s.nodes_visited) <= total, "{s:?} > {total}");
            assert!(s.max_level <= h.depth && s.splats <= s.nodes_visited);
            visited += u64::from(s.nodes_visited);
        }
    }
    for shadows in [ShadowMode::OnePass, ShadowMode::TwoPass] {
        let settings = Settings {
            shadows,
            shadow_map_size: 64,
            ..Settings::default()
        };
        if let Ok(r) = render_tg_frame(grid, &settings, &mut FrameBuffers::new()) {
            assert!(
                u64::from(r.stats.nodes_visited) <= 2 * total,
                "{:?}",
                r.stats
            );
        }
    }
    visited
}

#[test]
fn bases_open_and_render() {
    for (name, bytes) in bases() {
        let grid = open(&bytes).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(!grid.header().bricked(), "{name}: one array per level");
        assert!(render_bounded(&grid) > 0, "{name}");
    }
}

#[test]
fn truncated_at_every_block_boundary() {
    for (name, bytes) in bases() {
        let len = bytes.len();
        let grid = open(&bytes).unwrap();
        let h = *grid.header();
        for cut in (0..len).step_by(BS).flat_map(|b| [b, b + 1, b + BS - 1]) {
            let short = &bytes[..cut];
            let want = if cut < BS {
                TgError::TooShort(cut)
            } else {
                TgError::LengthMismatch {
                    expected: len as u64,
                    found: cut as u64,
                }
            };
            for verify in [Verify::Full, Verify::Structure] {
                let got = TriGrid::open(short, verify).unwrap_err();
                assert_eq!(got, want, "{name} cut at {cut} ({verify:?})");
            }
        }
        // Cut at a boundary with the header's block count made to agree: the first array that now
        // runs past the end is named, or the CRC table is.
        for blocks in 1..h.blocks {
            let mut cut = bytes[..blocks as usize * BS].to_vec();
            put_u32(&mut cut, 32, blocks);
            seal(&mut cut);
            let end = u64::from(blocks) * BS as u64;
            let want = if blocks <= h.crc_table_blocks {
                Some(TgError::BadCrcTable(h.crc_table_blocks))
            } else {
                first_array_past(&grid, end)
            };
            // (A last block holding only alignment padding may go: the rest is a valid file.)
            assert_eq!(
                open(&cut).err(),
                want,
                "{name}: {blocks} of {} blocks",
                h.blocks
            );
        }
    }
}

/// The error for the first array (in directory order) that ends after `end`.
fn first_array_past(grid: &TriGrid<'_>, end: u64) -> Option<TgError> {
    let h = grid.header();
    for l in 0..=h.depth {
        let d = grid.level(l);
        let arrays = [
            (d.attr_off, 2),
            (d.color_off, 2),
            (d.mask_off, u64::from(h.mask_bytes())),
            (d.group_off, 4),
        ];
        for (offset, size) in arrays {
            if offset != 0 && u64::from(offset) + u64::from(d.count) * size > end {
                return Some(TgError::BadArray { level: l, offset });
            }
        }
    }
    None
}

/// What a header field is, for the flipped-bit test.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Field {
    Magic,
    Version,
    Flags,
    Rho,
    Depth,
    NormalBits,
    MaterialBits,
    BlockLog2,
    Reserved,
    /// Version 3: the brick level, the brick count and the brick table's offset.
    Bricks,
    RootCube,
    Blocks,
    TableBlocks,
    Bounds,
    Count(u8),
    Array(u8),
    TableCrc,
    Padding,
    HeaderCrc,
}

fn field_of(at: usize, version: u16, depth: u8, table_blocks: u32) -> Field {
    let list_at = DIRECTORY_OFFSET + DIRECTORY_ENTRY * (usize::from(depth) + 1);
    match at {
        0..=3 => Field::Magic,
        4..=5 => Field::Version,
        6..=7 => Field::Flags,
        8 => Field::Rho,
        9 => Field::Depth,
        10 => Field::NormalBits,
        11 => Field::MaterialBits,
        12 => Field::BlockLog2,
        13 | 40..=47 if version >= 3 => Field::Bricks,
        13..=15 | 40..=47 => Field::Reserved,
        16..=31 => Field::RootCube,
        32..=35 => Field::Blocks,
        36..=39 => Field::TableBlocks,
        48..=71 => Field::Bounds,
        _ if at < list_at => {
            let level = ((at - DIRECTORY_OFFSET) / DIRECTORY_ENTRY) as u8;
            match (at - DIRECTORY_OFFSET) % DIRECTORY_ENTRY {
                0..=3 => Field::Count(level),
                4..=19 => Field::Array(level),
                _ => Field::Reserved,
            }
        }
        _ if at < list_at + 4 * table_blocks as usize => Field::TableCrc,
        _ if at < BS - 4 => Field::Padding,
        _ => Field::HeaderCrc,
    }
}

#[test]
fn flipped_bit_in_every_header_field() {
    for (name, bytes) in bases() {
        let grid = open(&bytes).unwrap();
        let h = *grid.header();
        let len = bytes.len() as u64;
        let mut accepted = Vec::new();
        for at in 0..BS {
            let field = field_of(at, h.version, h.depth, h.crc_table_blocks);
            for bit in 0..8 {
                let mut b = bytes.clone();
                b[at] ^= 1 << bit;
                let what = format!("{name}: byte {at} bit {bit} ({field:?})");

                // As damaged: the header CRC fails, unless a field checked before it already has.
                let raw = open(&b).unwrap_err();
                match field {
                    Field::Magic => {
                        assert_eq!(raw, TgError::BadMagic(b[..4].try_into().unwrap()), "{what}")
                    }
                    // Another version this reader knows reads the same header: its CRC fails.
                    Field::Version if (1..=3).contains(&u16::from_le_bytes([b[4], b[5]])) => {
                        assert_eq!(raw, TgError::BlockCrc(0), "{what}")
                    }
                    Field::Version => assert_eq!(
                        raw,
                        TgError::UnsupportedVersion(u16::from_le_bytes([b[4], b[5]])),
                        "{what}"
                    ),
                    Field::BlockLog2 if !(9..=16).contains(&b[12]) => {
                        assert_eq!(raw, TgError::UnsupportedBlockSize(b[12]), "{what}")
                    }
                    // A block bigger than the file; otherwise another block size fails its CRC.
                    Field::BlockLog2 if b.len() < 1 << b[12] => {
                        assert_eq!(raw, TgError::TooShort(b.len()), "{what}")
                    }
                    _ => assert_eq!(raw, TgError::BlockCrc(0), "{what}"),
                }
                if matches!(
                    field,
                    Field::Magic | Field::Version | Field::BlockLog2 | Field::HeaderCrc
                ) {
                    continue;
                }

                // Sealed: the header's CRC is right again, so the field itself must be caught.
                seal_header(&mut b);
                let full = open(&b);
                let structure = TriGrid::open(&b, Verify::Structure);
                let got = match (field, &full) {
                    // The table CRCs are checked by Full only.
                    (Field::TableCrc, _) => {
                        let t = (at - (DIRECTORY_OFFSET + DIRECTORY_ENTRY * h.levels())) / 4;
                        assert_eq!(full.unwrap_err(), TgError::BlockCrc(t as u32 + 1), "{what}");
                        assert!(structure.is_ok(), "{what}");
                        continue;
                    }
                    (_, Ok(_)) => {
                        accepted.push(field);
                        let g = structure.expect("Structure accepts what Full does");
                        // (Padding is never read: the same file, nothing new to render.)
                        if field != Field::Padding {
                            render_views(&g, false);
                        }
                        continue;
                    }
                    (_, Err(e)) => *e,
                };
                check_field_error(&what, field, &h, &b, len, got);
                // Structure finds the same, or (only a data CRC differing) accepts and renders.
                match structure {
                    Err(e) => assert_eq!(e, got, "{what}: Structure"),
                    Ok(g) => {
                        assert!(matches!(got, TgError::BlockCrc(_)), "{what}: {got:?}");
                        render_views(&g, false);
                    }
                }
            }
        }
        // What may be accepted after a flip: a harmless number (a corner, the bounds), the
        // material bit count (0..=3 all valid), an attribute or colour array moved to other data,
        // and the padding after the CRC list.
        for f in &accepted {
            assert!(
                matches!(
                    f,
                    Field::RootCube
                        | Field::Bounds
                        | Field::MaterialBits
                        | Field::Array(_)
                        | Field::Padding
                ),
                "{name}: {f:?} accepted a flipped bit"
            );
        }
    }
}

/// The error a sealed, flipped header field must give.
fn check_field_error(
    what: &str,
    field: Field,
    h: &pocketsplat_core::tg::Header,
    b: &[u8],
    len: u64,
    got: TgError,
) {
    let flags = u16::from_le_bytes([b[6], b[7]]);
    let ok = match field {
        // Unknown bits, or normal cones on a grid whose masks have no spare bits for them (ρ ≠ 3).
        Field::Flags
            if flags & !(FLAG_COLOR | FLAG_PRECISE | if h.rho == 3 { FLAG_CONES } else { 0 })
                != 0 =>
        {
            got == TgError::UnsupportedFlags(flags)
        }
        // The precise flag on a file without the extension: the zeros after the CRC list are no
        // cube (side 0).
        Field::Flags if (flags ^ h.flags) & FLAG_PRECISE != 0 => {
            matches!(got, TgError::BadPrecise { .. })
        }
        // The cone flag cleared: the cone classes in the masks' spare bits are now bad mask bits.
        Field::Flags if (flags ^ h.flags) & FLAG_CONES != 0 => {
            matches!(got, TgError::BadMask { .. })
        }
        // The colour flag without a colour array (offset 0), or a colour array without the flag.
        Field::Flags => matches!(got, TgError::BadArray { level: 0, offset }
            if offset == u32_at(b, dir_at(0, 2))),
        Field::Rho if !(2..=5).contains(&b[8]) => got == TgError::UnsupportedRho(b[8]),
        // Normal cones are for ρ = 3 only.
        Field::Rho if h.has_cones() && got == TgError::UnsupportedFlags(flags) => true,
        Field::Rho => matches!(
            got,
            TgError::BadArray { .. }
                | TgError::BadMask { .. }
                | TgError::CountMismatch { .. }
                | TgError::BadGroup { .. }
                | TgError::DepthTooLarge(_)
        ),
        Field::Depth if b[9] > MAX_DEPTH => got == TgError::DepthTooLarge(b[9]),
        // Another depth reads another directory: a missing or extra array, or the CRC list moves.
        Field::Depth => matches!(
            got,
            TgError::BadArray { .. } | TgError::BadCrcTable(_) | TgError::ReservedNotZero { .. }
        ),
        Field::NormalBits => got == TgError::UnsupportedNormalBits(b[10]),
        Field::MaterialBits => got == TgError::UnsupportedMaterialBits(b[11]),
        Field::Reserved => {
            let first = (0..BS).find(|&i| {
                field_of(i, h.version, h.depth, h.crc_table_blocks) == Field::Reserved && b[i] != 0
            });
            got == TgError::ReservedNotZero {
                offset: first.unwrap() as u16,
            }
        }
        // Bricks claimed by a file without any, or the brick level of a file without bricks.
        Field::Bricks => matches!(got, TgError::BadBricks { .. }),
        Field::RootCube | Field::Bounds => matches!(got, TgError::BadRootCube { offset }
            if (16..72).contains(&offset)),
        Field::Blocks => {
            let blocks = u32_at(b, 32);
            got == TgError::BadCrcTable(h.crc_table_blocks)
                || got
                    == TgError::LengthMismatch {
                        expected: u64::from(blocks) << LOG2,
                        found: len,
                    }
                || (u64::from(blocks) << LOG2 < len && matches!(got, TgError::BadArray { .. }))
        }
        Field::TableBlocks => {
            let t = u32_at(b, 36);
            got == TgError::BadCrcTable(t) || matches!(got, TgError::BadArray { level: 0, .. })
        }
        Field::Count(level) => {
            let count = u32_at(b, dir_at(usize::from(level), 0));
            matches!(got, TgError::BadArray { level: l, .. } if l == level)
                || matches!(got, TgError::CountMismatch { level: l, found, .. }
                    if l == level && found == count)
        }
        Field::Array(level) => {
            let offsets: Vec<u32> = (1..5)
                .map(|k| u32_at(b, dir_at(usize::from(level), k)))
                .collect();
            // A bad offset is named with its value; a moved mask or group array breaks the structure.
            matches!(got, TgError::BadArray { level: l, offset } if l == level && offsets.contains(&offset))
                || matches!(
                    got,
                    TgError::BadMask { .. }
                        | TgError::CountMismatch { .. }
                        | TgError::BadGroup { .. }
                )
        }
        // The data CRCs still match the data; a changed table block count is caught above.
        Field::Padding | Field::TableCrc => false,
        Field::Magic | Field::Version | Field::BlockLog2 | Field::HeaderCrc => unreachable!(),
    };
    assert!(ok, "{what}: unexpected {got:?}");
}

/// (level, cell) of a cell with at least two children whose children have children, in the middle of
/// its level, at `level`.
fn interior_cell(grid: &TriGrid<'_>, level: u8) -> u32 {
    let n = grid.level(level).count;
    (n / 2..n)
        .chain(0..n / 2)
        .find(|&i| grid.mask(level, i).count_ones() >= 2)
        .expect("a cell with two children")
}

#[test]
fn group_pointers_backwards_into_themselves_and_past_the_end() {
    for (name, bytes) in bases() {
        let grid = open(&bytes).unwrap();
        let depth = grid.header().depth;
        for level in 0..depth - 1 {
            let p = interior_cell(&grid, level);
            let at = grid.level(level).group_off as usize + 4 * p as usize;
            let group = grid.group(level, p);
            let next_next = grid.level(level + 2).count;
            for bad in [
                group.wrapping_sub(1), // backwards: shares its predecessor's grandchildren
                0,                     // all the way back to the first
                p,                     // its own index
                group + 1,             // forwards by one
                next_next,             // just past the end of the level
                u32::MAX,              // far past the end
            ] {
                if bad == group {
                    continue;
                }
                let mut b = bytes.clone();
                put_u32(&mut b, at, bad);
                seal(&mut b);
                let want = TgError::BadGroup { level, index: p };
                assert_eq!(open(&b).unwrap_err(), want, "{name}: group {bad}");
                assert_eq!(
                    TriGrid::open(&b, Verify::Structure).unwrap_err(),
                    want,
                    "{name}"
                );
                // Unsealed, the data block's CRC is what Full finds first.
                let mut raw = bytes.clone();
                put_u32(&mut raw, at, bad);
                assert_eq!(
                    open(&raw).unwrap_err(),
                    TgError::BlockCrc((at / BS) as u32),
                    "{name}"
                );
            }
        }
    }
}

#[test]
fn array_offsets_backwards_into_themselves_and_past_the_end() {
    for (name, bytes) in bases() {
        let grid = open(&bytes).unwrap();
        let h = *grid.header();
        let data_start = (h.crc_table_blocks as usize + 1) * BS;
        let len = bytes.len() as u32;
        for level in 0..=h.depth {
            let d = grid.level(level);
            for field in 1..5 {
                let here = u32_at(&bytes, dir_at(usize::from(level), field));
                if here == 0 {
                    continue;
                }
                let size = [0, 2, 2, h.mask_bytes(), 4][field];
                for bad in [
                    0x10,                                           // into the header
                    dir_at(usize::from(level), field) as u32 & !15, // onto its own entry
                    BS as u32,                                      // into the CRC table
                    data_start as u32 - 16,                         // just before the data
                    here + 8,                                       // misaligned
                    len,                                            // at the end
                    len - 16,    // starting inside, running past the end
                    0xFFFF_FFF0, // 4 GB away
                ] {
                    if bad == len - 16 && d.count * size <= 16 {
                        continue; // a short array still fits there
                    }
                    let mut b = bytes.clone();
                    put_u32(&mut b, dir_at(usize::from(level), field), bad);
                    seal(&mut b);
                    let want = TgError::BadArray { level, offset: bad };
                    assert_eq!(
                        open(&b).unwrap_err(),
                        want,
                        "{name}: level {level} field {field}"
                    );
                }
            }
            // An array that must be absent (groups of the two finest levels, masks of the leaves).
            if level + 1 >= h.depth {
                let mut b = bytes.clone();
                put_u32(&mut b, dir_at(usize::from(level), 4), d.attr_off);
                seal(&mut b);
                assert_eq!(
                    open(&b).unwrap_err(),
                    TgError::BadArray {
                        level,
                        offset: d.attr_off
                    },
                    "{name}"
                );
            }
        }
        // Backwards: a level reading its parent's masks (same bytes, another count).
        let mut b = bytes.clone();
        put_u32(&mut b, dir_at(2, 3), grid.level(1).mask_off);
        seal(&mut b);
        let got = open(&b).unwrap_err();
        assert!(
            matches!(
                got,
                TgError::BadMask { level: 2, .. }
                    | TgError::CountMismatch { level: 3, .. }
                    | TgError::BadGroup { level: 1, .. }
                    | TgError::BadArray { level: 2, .. }
            ),
            "{name}: {got:?}"
        );
    }
}

#[test]
fn child_masks_inconsistent_with_the_data() {
    for (name, bytes) in bases() {
        let grid = open(&bytes).unwrap();
        let h = *grid.header();
        let mb = h.mask_bytes() as usize;
        let slots = u32::from(h.rho).pow(3);
        for level in 0..h.depth {
            let index = interior_cell(&grid, level);
            let at = grid.level(level).mask_off as usize + mb * index as usize;
            let mask = grid.mask(level, index);
            let next = grid.level(level + 1).count;
            let put = |m: u128| {
                let mut b = bytes.clone();
                b[at..at + mb].copy_from_slice(&m.to_le_bytes()[..mb]);
                seal(&mut b);
                b
            };
            let bad_mask = TgError::BadMask { level, index };
            // Empty: an interior cell without children.
            assert_eq!(open(&put(0)).unwrap_err(), bad_mask, "{name}");
            // A bit at or above ρ³, or above the cone class where the file has cones (ρ = 2
            // fills its byte: no such bit).
            let spare = if h.has_cones() { CONE_SHIFT + 3 } else { slots };
            if (spare as usize) < 8 * mb {
                assert_eq!(
                    open(&put(mask | 1 << spare)).unwrap_err(),
                    bad_mask,
                    "{name}"
                );
                let top = 8 * mb as u32 - 1;
                assert_eq!(open(&put(mask | 1 << top)).unwrap_err(), bad_mask, "{name}");
            }
            // One more child than the level below holds, one fewer.
            let empty = (0..slots).find(|s| mask >> s & 1 == 0);
            if let Some(s) = empty {
                assert_eq!(
                    open(&put(mask | 1 << s)).unwrap_err(),
                    TgError::CountMismatch {
                        level: level + 1,
                        expected: next + 1,
                        found: next
                    },
                    "{name}"
                );
                // The same number of children in other slots: still a valid grid (the children are
                // drawn elsewhere), and it renders within bounds.
                let moved = (mask & (mask - 1)) | 1 << s;
                let b = put(moved);
                render_bounded(&open(&b).unwrap_or_else(|e| panic!("{name}: {e}")));
            }
            assert_eq!(
                open(&put(mask & (mask - 1))).unwrap_err(),
                TgError::CountMismatch {
                    level: level + 1,
                    expected: next - 1,
                    found: next
                },
                "{name}"
            );
        }
        // Two masks of one level swapped, with different child counts: the group pointers of the
        // level above no longer add up.
        let level = 2;
        let d = grid.level(level);
        let (i, j) = (0..d.count)
            .flat_map(|i| (i + 1..d.count).map(move |j| (i, j)))
            .find(|&(i, j)| grid.mask(level, i).count_ones() != grid.mask(level, j).count_ones())
            .expect("masks of different sizes");
        let mut b = bytes.clone();
        let (ai, aj) = (
            d.mask_off as usize + mb * i as usize,
            d.mask_off as usize + mb * j as usize,
        );
        let mi = b[ai..ai + mb].to_vec();
        b.copy_within(aj..aj + mb, ai);
        b[aj..aj + mb].copy_from_slice(&mi);
        seal(&mut b);
        let got = open(&b).unwrap_err();
        assert!(
            matches!(got, TgError::BadGroup { level: 1 | 2, .. }),
            "{name}: {got:?}"
        );
    }
}

#[test]
fn depth_beyond_the_limit() {
    let (_, bytes) = &bases()[0];
    for depth in [MAX_DEPTH + 1, 12, 100, 255] {
        let mut b = bytes.clone();
        b[9] = depth;
        seal_header(&mut b);
        assert_eq!(open(&b).unwrap_err(), TgError::DepthTooLarge(depth));
    }
}

/// Two specks far apart: a grid at the deepest depth allowed with few samples per level.
fn specks() -> TriMesh {
    let s = 1e-5;
    TriMesh {
        positions: vec![
            [0.0, 0.0, 0.0],
            [s, 0.0, 0.0],
            [0.0, s, 0.0],
            [1.0, 1.0, 1.0],
            [1.0 - s, 1.0, 1.0],
            [1.0, 1.0 - s, 1.0],
        ],
        triangles: vec![[0, 1, 2], [3, 4, 5]],
        materials: None,
        colors: None,
    }
}

#[test]
fn the_deepest_grids_render_within_bounds() {
    for rho in [2, 3] {
        let bytes = bake(&specks(), rho, MAX_DEPTH, LOG2);
        let grid = open(&bytes).unwrap();
        assert_eq!(grid.header().depth, MAX_DEPTH);
        render_bounded(&grid);
        // From up close at a tiny cutoff the walk reaches the leaves, and stops there.
        let settings = Settings {
            view: View::new(45.0, 35.0, 0.05),
            cutoff_px: 1e-6,
            ..Settings::default()
        };
        let r = render_tg_frame(&grid, &settings, &mut FrameBuffers::new()).unwrap();
        assert!(u64::from(r.stats.nodes_visited) <= grid.total_samples());
    }
}

/// A hand-made file whose levels all alias the same three arrays: one cell per level, one child each,
/// group pointer 0. The nearest thing to a cycle the format can express (pointers only lead two
/// levels down), and valid; the walk still ends at the deepest level. Blocks of `2^log2` bytes, `t`
/// CRC-table blocks, one data block.
fn aliased_chain(depth: u8, log2: u8, t: u32) -> Vec<u8> {
    let bs = 1usize << log2;
    let blocks = t + 2;
    let mut b = vec![0u8; blocks as usize * bs];
    b[..4].copy_from_slice(b"PSTG");
    b[4] = 1; // version
    b[8] = 3; // ρ
    b[9] = depth;
    b[10] = 13; // normal bits
    b[12] = log2;
    // Root cube: corner 0, side 1; bounds: the unit cube.
    for (at, v) in [(28, 1f32), (60, 1.0), (64, 1.0), (68, 1.0)] {
        b[at..at + 4].copy_from_slice(&v.to_le_bytes());
    }
    put_u32(&mut b, 32, blocks);
    put_u32(&mut b, 36, t);
    let data = (t + 1) << log2;
    for l in 0..=usize::from(depth) {
        put_u32(&mut b, dir_at(l, 0), 1);
        put_u32(&mut b, dir_at(l, 1), data);
        if l < usize::from(depth) {
            put_u32(&mut b, dir_at(l, 3), data + 16);
        }
        if l + 1 < usize::from(depth) {
            put_u32(&mut b, dir_at(l, 4), data + 32);
        }
    }
    put_u32(&mut b, data as usize + 16, 1 << 13); // the centre slot of the 3×3×3
    seal(&mut b);
    b
}

#[test]
fn levels_aliasing_one_another_end_at_the_depth() {
    for depth in [1, 5, MAX_DEPTH] {
        let b = aliased_chain(depth, LOG2, 1);
        let grid = open(&b).unwrap_or_else(|e| panic!("depth {depth}: {e}"));
        assert_eq!(grid.total_samples(), u64::from(depth) + 1);
        render_bounded(&grid);
        // Pointing the deepest group pointer anywhere but 0 breaks it.
        let mut bad = b.clone();
        put_u32(&mut bad, 2 * BS + 32, 1);
        seal(&mut bad);
        if depth >= 2 {
            assert_eq!(
                open(&bad).unwrap_err(),
                TgError::BadGroup { level: 0, index: 0 }
            );
        }
        // A second child at one level, with no sample for it below: the counts disagree.
        let mut bad = b.clone();
        put_u32(&mut bad, 2 * BS + 16, 1 << 13 | 1);
        seal(&mut bad);
        assert_eq!(
            open(&bad).unwrap_err(),
            TgError::CountMismatch {
                level: 1,
                expected: 2,
                found: 1
            }
        );
    }
}

#[test]
fn four_gigabyte_length_and_count_fields() {
    for (name, bytes) in bases() {
        let grid = open(&bytes).unwrap();
        let h = *grid.header();
        // 2³² − 1 blocks: far more than the CRC table covers.
        let mut b = bytes.clone();
        put_u32(&mut b, 32, u32::MAX);
        seal_header(&mut b);
        assert_eq!(
            open(&b).unwrap_err(),
            TgError::BadCrcTable(h.crc_table_blocks),
            "{name}"
        );
        // As many blocks as the table covers: a length mismatch carrying both lengths.
        let covered = h.crc_table_blocks << (LOG2 - 2);
        let mut b = bytes.clone();
        put_u32(&mut b, 32, covered);
        seal_header(&mut b);
        assert_eq!(
            open(&b).unwrap_err(),
            TgError::LengthMismatch {
                expected: u64::from(covered) << LOG2,
                found: bytes.len() as u64
            },
            "{name}"
        );
        // 2³² − 1 CRC-table blocks, and a table list too long for the header.
        for t in [u32::MAX, 1 << 20, 200] {
            let mut b = bytes.clone();
            put_u32(&mut b, 36, t);
            seal_header(&mut b);
            assert_eq!(open(&b).unwrap_err(), TgError::BadCrcTable(t), "{name}");
        }
        // A count of 2³² − 1 samples at every level in turn: its arrays cannot fit.
        for level in 0..=h.depth {
            let mut b = bytes.clone();
            put_u32(&mut b, dir_at(usize::from(level), 0), u32::MAX);
            seal(&mut b);
            let got = open(&b).unwrap_err();
            assert_eq!(
                got,
                TgError::BadArray {
                    level,
                    offset: grid.level(level).attr_off
                },
                "{name}: level {level}"
            );
        }
    }
    // The largest block size with a CRC table big enough: 2¹⁶ blocks of 64 KB, a 4 GB file
    // announced by a 384 KB one.
    let bytes = aliased_chain(3, 16, 4);
    assert!(open(&bytes).is_ok());
    let mut b = bytes.clone();
    put_u32(&mut b, 32, 1 << 16);
    seal_header(&mut b);
    assert_eq!(
        open(&b).unwrap_err(),
        TgError::LengthMismatch {
            expected: 1 << 32,
            found: bytes.len() as u64
        }
    );
}

#[test]
fn damaged_data_fails_full_and_renders_under_structure() {
    for (name, bytes) in bases() {
        let grid = open(&bytes).unwrap();
        let h = *grid.header();
        // Attributes and colours: any 16 bits are a normal code and a material (clamped), so a
        // file trusted as flash (Structure) renders the same cells, in other colours. (With
        // backface culling the normals decide which cells are drawn and, as the axes of the
        // normal cones, which subtrees are visited: compare without it.)
        let clean = render_views_culling(&grid, true, false);
        for level in [0, h.depth / 2, h.depth] {
            let d = grid.level(level);
            let mut b = bytes.clone();
            for i in 0..d.count as usize {
                b[d.attr_off as usize + 2 * i] ^= 0xA5;
                b[d.attr_off as usize + 2 * i + 1] ^= 0xFF;
            }
            let got = open(&b).unwrap_err();
            assert_eq!(
                got,
                TgError::BlockCrc((d.attr_off as usize / BS) as u32),
                "{name}"
            );
            let g = TriGrid::open(&b, Verify::Structure).expect("structure intact");
            render_bounded(&g);
            assert_eq!(
                render_views_culling(&g, true, false),
                clean,
                "{name}: same cells visited"
            );
        }
        // A damaged CRC-table block: Full names it, Structure does not read it.
        let mut b = bytes.clone();
        b[BS + 7] ^= 0x10;
        assert_eq!(open(&b).unwrap_err(), TgError::BlockCrc(1), "{name}");
        assert!(TriGrid::open(&b, Verify::Structure).is_ok());
    }
}
