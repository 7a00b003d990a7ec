//! The viewer's RAM: one [`Arena`] that holds, in the same bytes, either a model's buffers (the
//! whole panel's colour and depth, a one-slot shading table, the 64 KB cache and its tables) or a
//! scene pack's (a band's colour and depth, the 128² shadow map, the eight-slot shading table, the
//! 80 KB cache its objects share, their streams). The board has 520 KB: the two layouts side by
//! side would need 860 KB, the larger of them 455 KB. Every part is all zero bits at first, so the
//! board's arena is one `static` in `.bss` and laying out a file's memory is a `memset`.

use pocketsplat_core::shade::ShadingTable;
use pocketsplat_core::shadow::LightFrame;
use pocketsplat_qemu::pack_stream::{PackBuffers, PackObjects, PackTables};
use pocketsplat_qemu::{StreamTargets, HEIGHT, WIDTH};

use crate::{StreamTables, CACHE_BYTES};

/// The viewer's memory, laid out for the kind of file it opened (a `static` on the board, a box
/// on the host): see the module docs. `repr(u8)`: an explicit tag, 0 for [`Arena::Free`], so
/// that a `static` of it is all zero bits (`.bss`, not 455 KB of `.data` image in flash).
#[repr(u8)]
// The point: one piece of RAM the size of the larger layout, and `Free` before either.
#[allow(clippy::large_enum_variant)]
pub enum Arena<'a> {
    /// Before a file is opened.
    Free = 0,
    /// A `.tg` or `.qs` model's.
    Model(ModelArena),
    /// A scene pack's.
    Pack(PackArena<'a>),
}

/// A model's memory ([`crate::Viewer`]).
pub struct ModelArena {
    /// The frame's colour rows (the whole panel: a refined frame is drawn off screen, in passes).
    pub color: [[u16; WIDTH]; HEIGHT],
    /// Its depth rows.
    pub depth: [[u16; WIDTH]; HEIGHT],
    /// The shading table, kept between frames.
    pub table: ShadingTable<1>,
    /// The block cache.
    pub cache: [u8; CACHE_BYTES],
    /// Its tables.
    pub tables: StreamTables,
}

impl ModelArena {
    /// Before the model is opened (all zero bits).
    pub const EMPTY: Self = Self {
        color: [[0; WIDTH]; HEIGHT],
        depth: [[0; WIDTH]; HEIGHT],
        table: ShadingTable::new(),
        cache: [0; CACHE_BYTES],
        tables: StreamTables::EMPTY,
    };

    /// The cache, its tables and the frame's buffers, apart.
    pub fn parts(&mut self) -> (&mut [u8; CACHE_BYTES], &mut StreamTables, StreamTargets<'_>) {
        let ModelArena {
            color,
            depth,
            table,
            cache,
            tables,
        } = self;
        (
            cache,
            tables,
            StreamTargets {
                color,
                depth,
                table,
            },
        )
    }
}

/// A scene pack's memory ([`crate::scene::PackViewer`]): `pocketsplat_qemu::pack_stream`'s, as the
/// QEMU firmware's pack build holds it.
pub struct PackArena<'a> {
    /// A band's colour and depth, the shading table, the shadow map, the metadata, the cache.
    pub buffers: PackBuffers,
    /// The cache's slots and block entries.
    pub tables: PackTables,
    /// The objects' streams (they borrow the cache and tables above).
    pub objects: PackObjects<'a>,
    /// Where each object's light frame is set.
    pub light: LightFrame,
}

impl PackArena<'_> {
    /// Before the pack is opened.
    pub const EMPTY: Self = Self {
        buffers: PackBuffers::EMPTY,
        tables: PackTables::EMPTY,
        objects: PackObjects::new(),
        light: LightFrame::UNSET,
    };
}

impl<'a> Arena<'a> {
    /// Lays the arena out for a model (whatever it held is dropped) and hands out its parts.
    pub fn model(&'a mut self) -> &'a mut ModelArena {
        *self = Arena::Model(ModelArena::EMPTY);
        match self {
            Arena::Model(m) => m,
            // Just set.
            _ => unreachable!(),
        }
    }

    /// Lays the arena out for a scene pack (whatever it held is dropped).
    pub fn pack(&'a mut self) -> &'a mut PackArena<'a> {
        *self = Arena::Pack(PackArena::EMPTY);
        match self {
            Arena::Pack(p) => p,
            // Just set.
            _ => unreachable!(),
        }
    }
}
