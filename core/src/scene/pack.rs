//! Reading scene packs: a raw layer of bounds-checked little-endian reads, then [`Pack`], validated
//! once by [`Pack::open`], whose accessors cannot panic afterwards (`docs/ARCHITECTURE.md`,
//! convention 5).

use super::{
    Kind, MaterialRecord, ObjectRecord, Savings, ShadowMode, ALIGN_LOG2_RANGE, FLAG_CASTS,
    FLAG_GROUND, FLAG_IN_BOUNDS, HEADER_BYTES, MAGIC, MATERIAL_BYTES, MAX_MAP_SIZE, MAX_OBJECTS,
    MAX_PATH_KEYS, MAX_SLOTS, MAX_VIEWS, MIN_MAP_SIZE, NAME_BYTES, OBJECT_BYTES, PATH_BYTES,
    VERSION, VIEW_BYTES,
};
use crate::camera::{Placement, Sphere, View};
use crate::crc::crc32;
use crate::shade::Material;

/// What is wrong with a pack. Each variant carries the offending value or where it is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PackError {
    /// Shorter than the header or than its tables.
    TooShort {
        /// Bytes needed.
        need: u64,
        /// Bytes present.
        found: u64,
    },
    /// The first four bytes are not `PSPK`.
    BadMagic([u8; 4]),
    /// A version this reader does not know.
    UnsupportedVersion(u16),
    /// Unknown flags in the header.
    UnsupportedFlags(u16),
    /// The file length is not what the header says.
    LengthMismatch {
        /// Bytes the header announces.
        expected: u64,
        /// Bytes present.
        found: u64,
    },
    /// `meta_len` is not the header plus the tables the counts announce.
    MetaLength {
        /// What the counts imply.
        expected: u32,
        /// The header's value.
        found: u32,
    },
    /// The metadata fails its CRC.
    Crc {
        /// CRC in the header.
        stored: u32,
        /// CRC of the bytes.
        computed: u32,
    },
    /// A count or size in the header is out of range.
    BadCount {
        /// Byte offset of the field in the header.
        offset: u8,
        /// Its value.
        value: u16,
    },
    /// A reserved byte is not 0.
    ReservedNotZero {
        /// Its byte offset in the file.
        offset: u32,
    },
    /// A number is not finite or out of its range.
    BadNumber {
        /// Byte offset of the number in the file.
        offset: u32,
    },
    /// A name is not UTF-8, or has bytes after its terminating zero (or, for a view, is empty).
    BadName {
        /// Byte offset of the name in the file.
        offset: u32,
    },
    /// Two views have the same name.
    DuplicateView {
        /// Index of the second.
        view: u8,
    },
    /// An object's kind is unknown.
    UnknownKind {
        /// The object.
        object: u8,
        /// Its kind byte.
        kind: u8,
    },
    /// An object's flags have unknown bits.
    UnknownObjectFlags {
        /// The object.
        object: u8,
        /// Its flags.
        flags: u8,
    },
    /// An object's material count or slot list is invalid (a slot beyond the slot count, 0xFF
    /// missing after the used entries).
    BadSlots {
        /// The object.
        object: u8,
    },
    /// Two objects share a material slot but not the rotation the slot is shaded in.
    SlotRotation {
        /// The slot.
        slot: u8,
        /// The second object using it.
        object: u8,
    },
    /// An object's rotation is not orthonormal with determinant +1, or its scale is not positive.
    BadPlacement {
        /// The object.
        object: u8,
    },
    /// An object's data is misaligned, before the metadata's end, past the end of the file, empty,
    /// or overlaps the previous object's.
    BadData {
        /// The object.
        object: u8,
        /// Its data offset.
        offset: u32,
        /// Its data length.
        len: u32,
    },
    /// An object keeps more depth than the scene asked for.
    BadDepth {
        /// The object.
        object: u8,
    },
    /// Camera path times are negative or not strictly increasing.
    PathTime {
        /// The keyframe.
        key: u16,
    },
}

impl core::error::Error for PackError {}

impl core::fmt::Display for PackError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            PackError::TooShort { need, found } => {
                write!(
                    f,
                    "pack is {found} bytes, shorter than the {need} its header needs"
                )
            }
            PackError::BadMagic(m) => {
                write!(f, "not a scene pack (magic {m:02x?}, expected \"PSPK\")")
            }
            PackError::UnsupportedVersion(v) => {
                write!(
                    f,
                    "unsupported pack version {v} (this reader knows {VERSION})"
                )
            }
            PackError::UnsupportedFlags(x) => write!(f, "unknown pack flags {x:#06x}"),
            PackError::LengthMismatch { expected, found } => {
                write!(
                    f,
                    "pack is {found} bytes but its header announces {expected}"
                )
            }
            PackError::MetaLength { expected, found } => write!(
                f,
                "metadata length {found} does not match the tables the counts announce ({expected})"
            ),
            PackError::Crc { stored, computed } => write!(
                f,
                "metadata fails its CRC check (stored {stored:#010x}, computed {computed:#010x})"
            ),
            PackError::BadCount { offset, value } => write!(
                f,
                "header field at byte {offset} ({}) is {value}, out of range",
                match offset {
                    20 => "objects, 1..=16",
                    21 => "material slots, 1..=8",
                    22 => "views, 0..=32",
                    23 => "shadow mode, 0..=2",
                    24 => "shadow map side, 0 without shadows, else 16..=4096",
                    26 => "path keyframes, 0..=256",
                    _ => "data alignment, 2^9..=2^16",
                }
            ),
            PackError::ReservedNotZero { offset } => {
                write!(f, "reserved byte at {offset} is not 0")
            }
            PackError::BadNumber { offset } => {
                write!(
                    f,
                    "the number at byte {offset} is not finite or out of range"
                )
            }
            PackError::BadName { offset } => write!(
                f,
                "the name at byte {offset} is not zero-padded UTF-8 (or is an empty view name)"
            ),
            PackError::DuplicateView { view } => {
                write!(f, "view {view} has the name of an earlier view")
            }
            PackError::UnknownKind { object, kind } => {
                write!(
                    f,
                    "object {object} has unknown kind {kind} (1 = .tg, 2 = .qs)"
                )
            }
            PackError::UnknownObjectFlags { object, flags } => {
                write!(f, "object {object} has unknown flags {flags:#04x}")
            }
            PackError::BadSlots { object } => {
                write!(f, "object {object}: material count or slot list is invalid")
            }
            PackError::SlotRotation { slot, object } => write!(
                f,
                "object {object} uses material slot {slot} with another rotation than an earlier \
                 object (a slot is shaded in one model frame)"
            ),
            PackError::BadPlacement { object } => write!(
                f,
                "object {object}: rotation is not a rotation matrix or scale is not positive"
            ),
            PackError::BadData {
                object,
                offset,
                len,
            } => write!(
                f,
                "object {object}: data at byte {offset} of length {len} is misaligned, empty, \
                 outside the file or overlaps another object"
            ),
            PackError::BadDepth { object } => {
                write!(
                    f,
                    "object {object} keeps more levels than the scene asked for"
                )
            }
            PackError::PathTime { key } => write!(
                f,
                "camera path keyframe {key}: times must start at 0 or later and increase"
            ),
        }
    }
}

// ---- raw layer: crate::bytes, on the ranges `Pack::open` proves ---------------------------------------

use crate::bytes::{le, take};

// `Pack::open` first checks that the file holds its header, then that it holds the tables the header
// declares; every read below lies inside one or the other, so none can miss. The header's checks and
// `Check` turn a miss into an error all the same; the accessors behind a validated `Pack` have nothing
// to report, and a miss (a bug) reads as zero, never NaN, and fails debug builds.
fn field<T: Default>(v: Option<T>) -> T {
    debug_assert!(
        v.is_some(),
        "a pack field outside the ranges Pack::open checked"
    );
    v.unwrap_or_default()
}
fn u8_at(bytes: &[u8], at: usize) -> u8 {
    field(le::u8_at(bytes, at))
}
fn u16_at(bytes: &[u8], at: usize) -> u16 {
    field(le::u16_at(bytes, at))
}
fn u32_at(bytes: &[u8], at: usize) -> u32 {
    field(le::u32_at(bytes, at))
}
fn f32_at(bytes: &[u8], at: usize) -> f32 {
    field(le::f32_at(bytes, at))
}
fn f64_at(bytes: &[u8], at: usize) -> f64 {
    field(le::f64_at(bytes, at))
}
fn name_at(bytes: &[u8], at: usize) -> &str {
    let raw = bytes.get(at..at + NAME_BYTES).unwrap_or(&[]);
    let end = raw.iter().position(|&b| b == 0).unwrap_or(raw.len());
    core::str::from_utf8(&raw[..end]).unwrap_or("")
}

/// The checks of the raw layer, each naming where it failed.
struct Check<'a>(&'a [u8]);

impl Check<'_> {
    fn zero(&self, at: usize, len: usize) -> Result<(), PackError> {
        match self.0[at..at + len].iter().position(|&b| b != 0) {
            Some(i) => Err(PackError::ReservedNotZero {
                offset: (at + i) as u32,
            }),
            None => Ok(()),
        }
    }
    fn f64_in(&self, at: usize, lo: f64, hi: f64) -> Result<f64, PackError> {
        le::f64_at(self.0, at)
            .filter(|v| v.is_finite() && (lo..=hi).contains(v))
            .ok_or(PackError::BadNumber { offset: at as u32 })
    }
    fn f32_in(&self, at: usize, lo: f32, hi: f32) -> Result<f32, PackError> {
        le::f32_at(self.0, at)
            .filter(|v| v.is_finite() && (lo..=hi).contains(v))
            .ok_or(PackError::BadNumber { offset: at as u32 })
    }
    fn name(&self, at: usize, non_empty: bool) -> Result<(), PackError> {
        let raw = &self.0[at..at + NAME_BYTES];
        let end = raw.iter().position(|&b| b == 0).unwrap_or(NAME_BYTES);
        let bad = PackError::BadName { offset: at as u32 };
        if core::str::from_utf8(&raw[..end]).is_err()
            || raw[end..].iter().any(|&b| b != 0)
            || (non_empty && end == 0)
        {
            return Err(bad);
        }
        Ok(())
    }
}

/// Largest coordinate a placement or the scene sphere may hold (world units), so that setup products
/// stay far from overflow.
const MAX_COORD: f64 = 1e12;

/// A validated scene pack (a flash slice, or a file read into RAM).
#[derive(Clone, Copy, Debug)]
pub struct Pack<'a> {
    /// The whole pack, or its metadata alone ([`Pack::open_meta`]).
    bytes: &'a [u8],
    /// The pack's length in bytes (the header's; `bytes.len()` when `bytes` is the whole pack).
    file_len: u64,
    objects: u8,
    slots: u8,
    views: u8,
    keys: u16,
    shadows: ShadowMode,
    map_size: u16,
}

impl<'a> Pack<'a> {
    /// Validates `bytes` as a pack (see `PACK.md`, "Validation"): the metadata only; the objects'
    /// files are opened by `scene::Scene::open`.
    ///
    /// # Errors
    /// The first problem found, as a [`PackError`] naming where.
    pub fn open(bytes: &'a [u8]) -> Result<Self, PackError> {
        Self::parse(bytes, bytes.len() as u64)
    }

    /// Validates a pack's metadata, the pack's first [`Pack::meta_len_of`] bytes (or more), as
    /// [`Pack::open`] validates a whole pack, for a pack `file_len` bytes long that is read from a
    /// medium in blocks: every check but the objects' own files, which a stream checks block by
    /// block. [`ObjectRecord::data`] is then empty; `data_offset` and `data_len` say where each
    /// object's file lies.
    ///
    /// # Errors
    /// As [`Pack::open`]; [`PackError::LengthMismatch`] when the header's length is not
    /// `file_len`.
    pub fn open_meta(meta: &'a [u8], file_len: u64) -> Result<Self, PackError> {
        let meta = match meta.get(16..20) {
            Some(_) => meta.get(..Self::meta_len_of(meta) as usize).unwrap_or(meta),
            None => meta,
        };
        Self::parse(meta, file_len)
    }

    /// The metadata length a pack's header (its first 20 bytes or more) announces; 0 when `head`
    /// is shorter. A stream reads the header, then this many bytes ([`super::MAX_META_BYTES`] at most in
    /// a valid pack).
    pub fn meta_len_of(head: &[u8]) -> u32 {
        head.get(16..20)
            .map_or(0, |b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    fn parse(bytes: &'a [u8], file_len: u64) -> Result<Self, PackError> {
        let found = file_len;
        if bytes.len() < HEADER_BYTES {
            return Err(PackError::TooShort {
                need: HEADER_BYTES as u64,
                found: bytes.len() as u64,
            });
        }
        let c = Check(bytes);
        let magic: [u8; 4] = take(bytes, 0).unwrap_or_default();
        if magic != MAGIC {
            return Err(PackError::BadMagic(magic));
        }
        let version = u16_at(bytes, 4);
        if version != VERSION {
            return Err(PackError::UnsupportedVersion(version));
        }
        let flags = u16_at(bytes, 6);
        if flags != 0 {
            return Err(PackError::UnsupportedFlags(flags));
        }
        let length = u32_at(bytes, 8);
        if u64::from(length) != found {
            return Err(PackError::LengthMismatch {
                expected: u64::from(length),
                found,
            });
        }
        let bad = |offset: u8, value: u16| Err(PackError::BadCount { offset, value });
        let objects = u8_at(bytes, 20);
        if !(1..=MAX_OBJECTS as u8).contains(&objects) {
            return bad(20, objects.into());
        }
        let slots = u8_at(bytes, 21);
        if !(1..=MAX_SLOTS as u8).contains(&slots) {
            return bad(21, slots.into());
        }
        let views = u8_at(bytes, 22);
        if usize::from(views) > MAX_VIEWS {
            return bad(22, views.into());
        }
        let shadows = match u8_at(bytes, 23) {
            0 => ShadowMode::Off,
            1 => ShadowMode::OnePass,
            2 => ShadowMode::TwoPass,
            m => return bad(23, m.into()),
        };
        let map_size = u16_at(bytes, 24);
        let map_ok = match shadows {
            ShadowMode::Off => map_size == 0,
            _ => (MIN_MAP_SIZE..=MAX_MAP_SIZE).contains(&usize::from(map_size)),
        };
        if !map_ok {
            return bad(24, map_size);
        }
        let keys = u16_at(bytes, 26);
        if usize::from(keys) > MAX_PATH_KEYS {
            return bad(26, keys);
        }
        let align_log2 = u8_at(bytes, 28);
        if !ALIGN_LOG2_RANGE.contains(&align_log2) {
            return bad(28, align_log2.into());
        }
        let meta = HEADER_BYTES
            + usize::from(objects) * OBJECT_BYTES
            + usize::from(slots) * MATERIAL_BYTES
            + usize::from(views) * VIEW_BYTES
            + usize::from(keys) * PATH_BYTES;
        let meta_len = u32_at(bytes, 16);
        if meta_len as usize != meta {
            return Err(PackError::MetaLength {
                expected: meta as u32,
                found: meta_len,
            });
        }
        if bytes.len() < meta {
            return Err(PackError::TooShort {
                need: meta as u64,
                found: bytes.len() as u64,
            });
        }
        let stored = u32_at(bytes, 12);
        let computed = crc32(&bytes[16..meta]);
        if stored != computed {
            return Err(PackError::Crc { stored, computed });
        }
        c.zero(29, 3)?;
        c.zero(96, 32)?;
        c.f64_in(32, -1e6, 1e6)?;
        c.f64_in(40, -1e6, 1e6)?;
        let fov = c.f64_in(48, 0.0, 180.0)?;
        if fov <= 0.0 || fov >= 180.0 {
            return Err(PackError::BadNumber { offset: 48 });
        }
        c.f64_in(56, 0.0, 1e6)?;
        for k in 0..3 {
            c.f64_in(64 + 8 * k, -MAX_COORD, MAX_COORD)?;
        }
        if c.f64_in(88, 0.0, MAX_COORD)? <= 0.0 {
            return Err(PackError::BadNumber { offset: 88 });
        }

        let pack = Pack {
            bytes,
            file_len,
            objects,
            slots,
            views,
            keys,
            shadows,
            map_size,
        };
        pack.check_objects(align_log2, meta)?;
        for s in 0..usize::from(slots) {
            let at = pack.material_at(s);
            c.name(at, false)?;
            for k in 0..3 {
                c.f32_in(at + 16 + 4 * k, 0.0, 1.0)?;
            }
            for k in 0..3 {
                c.f32_in(at + 28 + 4 * k, 0.0, 4.0)?;
            }
            c.f32_in(at + 40, 0.0, 1024.0)?;
            c.zero(at + 44, 4)?;
        }
        for v in 0..usize::from(views) {
            let at = pack.view_at(v);
            c.name(at, true)?;
            c.f64_in(at + 16, -1e6, 1e6)?;
            c.f64_in(at + 24, -1e6, 1e6)?;
            if c.f64_in(at + 32, 0.0, 1e9)? <= 0.0 {
                return Err(PackError::BadNumber {
                    offset: (at + 32) as u32,
                });
            }
            c.zero(at + 40, 8)?;
            if (0..v).any(|w| name_at(bytes, pack.view_at(w)) == name_at(bytes, at)) {
                return Err(PackError::DuplicateView { view: v as u8 });
            }
        }
        let mut last = -1.0f64;
        for k in 0..usize::from(keys) {
            let at = pack.key_at(k);
            let t = c.f64_in(at, 0.0, 1e9)?;
            if t <= last {
                return Err(PackError::PathTime { key: k as u16 });
            }
            last = t;
            c.f64_in(at + 8, -1e6, 1e6)?;
            c.f64_in(at + 16, -1e6, 1e6)?;
            if c.f64_in(at + 24, 0.0, 1e9)? <= 0.0 {
                return Err(PackError::BadNumber {
                    offset: (at + 24) as u32,
                });
            }
        }
        Ok(pack)
    }

    fn check_objects(&self, align_log2: u8, meta: usize) -> Result<(), PackError> {
        let c = Check(self.bytes);
        let mut data_end = meta as u64;
        // Per slot: the first object using it, whose rotation it is shaded in.
        let mut slot_owner = [None::<u8>; MAX_SLOTS];
        for i in 0..self.objects {
            let at = self.object_at(usize::from(i));
            c.name(at, false)?;
            let kind = u8_at(self.bytes, at + 16);
            if Kind::from_byte(kind).is_none() {
                return Err(PackError::UnknownKind { object: i, kind });
            }
            let flags = u8_at(self.bytes, at + 17);
            if flags & !(FLAG_CASTS | FLAG_GROUND | FLAG_IN_BOUNDS) != 0 {
                return Err(PackError::UnknownObjectFlags { object: i, flags });
            }
            let materials = usize::from(u8_at(self.bytes, at + 18));
            let bad_slots = PackError::BadSlots { object: i };
            if !(1..=MAX_SLOTS).contains(&materials) {
                return Err(bad_slots);
            }
            c.zero(at + 19, 1)?;
            for m in 0..MAX_SLOTS {
                let slot = u8_at(self.bytes, at + 20 + m);
                if m >= materials {
                    if slot != 0xFF {
                        return Err(bad_slots);
                    }
                    continue;
                }
                if slot >= self.slots {
                    return Err(bad_slots);
                }
            }
            let offset = u32_at(self.bytes, at + 28);
            let len = u32_at(self.bytes, at + 32);
            let end = u64::from(offset) + u64::from(len);
            if len == 0
                || !offset.is_multiple_of(1u32 << align_log2)
                || u64::from(offset) < data_end
                || end > self.file_len
            {
                return Err(PackError::BadData {
                    object: i,
                    offset,
                    len,
                });
            }
            data_end = end;
            c.zero(at + 36, 4)?;
            for k in 0..9 {
                c.f64_in(at + 40 + 8 * k, -2.0, 2.0)?;
            }
            let scale = c.f64_in(at + 112, 0.0, MAX_COORD)?;
            for k in 0..3 {
                c.f64_in(at + 120 + 8 * k, -MAX_COORD, MAX_COORD)?;
            }
            let r = self.rotation(usize::from(i));
            if !(scale > 0.0 && is_rotation(&r)) {
                return Err(PackError::BadPlacement { object: i });
            }
            if u8_at(self.bytes, at + 145) > u8_at(self.bytes, at + 144) {
                return Err(PackError::BadDepth { object: i });
            }
            c.zero(at + 146, 2)?;
            for m in 0..materials {
                let slot = u8_at(self.bytes, at + 20 + m);
                match slot_owner[usize::from(slot)] {
                    None => slot_owner[usize::from(slot)] = Some(i),
                    Some(o) if self.rotation(usize::from(o)) == r => {}
                    Some(_) => return Err(PackError::SlotRotation { slot, object: i }),
                }
            }
        }
        Ok(())
    }

    fn object_at(&self, i: usize) -> usize {
        HEADER_BYTES + i * OBJECT_BYTES
    }
    fn material_at(&self, s: usize) -> usize {
        HEADER_BYTES + usize::from(self.objects) * OBJECT_BYTES + s * MATERIAL_BYTES
    }
    fn view_at(&self, v: usize) -> usize {
        self.material_at(usize::from(self.slots)) + v * VIEW_BYTES
    }
    fn key_at(&self, k: usize) -> usize {
        self.view_at(usize::from(self.views)) + k * PATH_BYTES
    }
    fn rotation(&self, i: usize) -> [[f64; 3]; 3] {
        let at = self.object_at(i) + 40;
        core::array::from_fn(|r| core::array::from_fn(|c| f64_at(self.bytes, at + 8 * (3 * r + c))))
    }

    /// The whole pack (its metadata alone when opened by [`Pack::open_meta`]).
    pub fn bytes(&self) -> &'a [u8] {
        self.bytes
    }
    /// The pack's length in bytes.
    pub fn file_len(&self) -> u64 {
        self.file_len
    }
    /// Number of objects (1..=16).
    pub fn object_count(&self) -> usize {
        usize::from(self.objects)
    }
    /// Number of material slots (1..=8): the shading table needs at least this many materials.
    pub fn slot_count(&self) -> usize {
        usize::from(self.slots)
    }
    /// Number of named views.
    pub fn view_count(&self) -> usize {
        usize::from(self.views)
    }
    /// Number of camera path keyframes.
    pub fn path_len(&self) -> usize {
        usize::from(self.keys)
    }
    /// The shadows the scene asks for.
    pub fn shadows(&self) -> ShadowMode {
        self.shadows
    }
    /// Side of the shadow map in texels (0 without shadows).
    pub fn shadow_map_size(&self) -> usize {
        usize::from(self.map_size)
    }
    /// Light azimuth and elevation, degrees.
    pub fn light_az_el(&self) -> (f64, f64) {
        (f64_at(self.bytes, 32), f64_at(self.bytes, 40))
    }
    /// Vertical field of view, degrees.
    pub fn fov_deg(&self) -> f64 {
        f64_at(self.bytes, 48)
    }
    /// The smallest projected cell size (pixels) the bake kept levels for; 0 when none were dropped.
    pub fn min_cell_px(&self) -> f64 {
        f64_at(self.bytes, 56)
    }
    /// The sphere the views orbit.
    pub fn sphere(&self) -> Sphere {
        Sphere {
            center: core::array::from_fn(|k| f64_at(self.bytes, 64 + 8 * k)),
            radius: f64_at(self.bytes, 88),
        }
    }
    /// Bytes of the header and tables.
    pub fn meta_len(&self) -> usize {
        u32_at(self.bytes, 16) as usize
    }

    /// What object `i`'s file is (`None` beyond [`Pack::object_count`]), without reading the rest
    /// of its record: a scene frame asks it of every object.
    pub fn kind(&self, i: usize) -> Option<Kind> {
        if i >= self.object_count() {
            return None;
        }
        Kind::from_byte(u8_at(self.bytes, self.object_at(i) + 16))
    }

    /// Object `i` (`None` beyond [`Pack::object_count`]).
    pub fn object(&self, i: usize) -> Option<ObjectRecord<'a>> {
        if i >= self.object_count() {
            return None;
        }
        let at = self.object_at(i);
        let b = self.bytes;
        let flags = u8_at(b, at + 17);
        let offset = u32_at(b, at + 28) as usize;
        let len = u32_at(b, at + 32) as usize;
        Some(ObjectRecord {
            name: name_at(b, at),
            kind: Kind::from_byte(u8_at(b, at + 16)).unwrap_or(Kind::TriGrid),
            casts_shadows: flags & FLAG_CASTS != 0,
            ground: flags & FLAG_GROUND != 0,
            in_bounds: flags & FLAG_IN_BOUNDS != 0,
            materials: u8_at(b, at + 18),
            slots: core::array::from_fn(|m| u8_at(b, at + 20 + m)),
            data: b.get(offset..offset + len).unwrap_or(&[]),
            data_offset: offset as u32,
            data_len: len as u32,
            placement: Placement {
                rotation: self.rotation(i),
                scale: f64_at(b, at + 112),
                translation: core::array::from_fn(|k| f64_at(b, at + 120 + 8 * k)),
            },
            depth_asked: u8_at(b, at + 144),
            depth_kept: u8_at(b, at + 145),
            savings: Savings {
                levels: u32_at(b, at + 148),
                color: u32_at(b, at + 152),
                material_bits: u32_at(b, at + 156),
            },
        })
    }

    /// Material slot `s` (`None` beyond [`Pack::slot_count`]).
    pub fn material(&self, s: usize) -> Option<MaterialRecord<'a>> {
        if s >= self.slot_count() {
            return None;
        }
        let at = self.material_at(s);
        let b = self.bytes;
        Some(MaterialRecord {
            name: name_at(b, at),
            material: Material {
                color: core::array::from_fn(|k| f32_at(b, at + 16 + 4 * k)),
                ambient: f32_at(b, at + 28),
                diffuse: f32_at(b, at + 32),
                specular: f32_at(b, at + 36),
                shininess: f32_at(b, at + 40),
            },
        })
    }

    /// View `v`: its name and orbit (`None` beyond [`Pack::view_count`]).
    pub fn view(&self, v: usize) -> Option<(&'a str, View)> {
        if v >= self.view_count() {
            return None;
        }
        let at = self.view_at(v);
        let b = self.bytes;
        Some((
            name_at(b, at),
            View::new(f64_at(b, at + 16), f64_at(b, at + 24), f64_at(b, at + 32)),
        ))
    }

    /// The view named `name`.
    pub fn view_named(&self, name: &str) -> Option<View> {
        (0..self.view_count())
            .filter_map(|v| self.view(v))
            .find(|(n, _)| *n == name)
            .map(|(_, v)| v)
    }

    /// Camera path keyframe `k`: its time (seconds) and view.
    pub fn path_key(&self, k: usize) -> Option<(f64, View)> {
        if k >= self.path_len() {
            return None;
        }
        let at = self.key_at(k);
        let b = self.bytes;
        Some((
            f64_at(b, at),
            View::new(f64_at(b, at + 8), f64_at(b, at + 16), f64_at(b, at + 24)),
        ))
    }

    /// Duration of the camera path, seconds (0 without one).
    pub fn path_duration(&self) -> f64 {
        self.path_key(self.path_len().wrapping_sub(1))
            .map_or(0.0, |(t, _)| t)
    }

    /// The camera path's view at time `t` seconds: linear between keyframes, held before the first
    /// and after the last. `None` without a path.
    pub fn path_view(&self, t: f64) -> Option<View> {
        let (t0, first) = self.path_key(0)?;
        if t.is_nan() || t <= t0 {
            return Some(first);
        }
        let mut prev = (t0, first);
        for k in 1..self.path_len() {
            let (tk, vk) = self.path_key(k)?;
            if t <= tk {
                let a = (t - prev.0) / (tk - prev.0);
                let lerp = |x: f64, y: f64| x + (y - x) * a;
                return Some(View::new(
                    lerp(prev.1.az_deg, vk.az_deg),
                    lerp(prev.1.el_deg, vk.el_deg),
                    lerp(prev.1.dist, vk.dist),
                ));
            }
            prev = (tk, vk);
        }
        Some(prev.1)
    }
}

/// Whether `r` is orthonormal with determinant +1, within 1e-6.
fn is_rotation(r: &[[f64; 3]; 3]) -> bool {
    for i in 0..3 {
        for j in 0..3 {
            let d = r[i][0] * r[j][0] + r[i][1] * r[j][1] + r[i][2] * r[j][2];
            let want = if i == j { 1.0 } else { 0.0 };
            if libm::fabs(d - want).is_nan() || libm::fabs(d - want) > 1e-6 {
                return false;
            }
        }
    }
    let det = r[0][0] * (r[1][1] * r[2][2] - r[1][2] * r[2][1])
        - r[0][1] * (r[1][0] * r[2][2] - r[1][2] * r[2][0])
        + r[0][2] * (r[1][0] * r[2][1] - r[1][1] * r[2][0]);
    libm::fabs(det - 1.0) <= 1e-6
}
