//! Writing scene packs (`bake` feature): the inverse of [`super::pack`].

use std::string::String;
use std::vec::Vec;

use super::{
    Savings, ShadowMode, ALIGN_LOG2_RANGE, FLAG_CASTS, FLAG_GROUND, FLAG_IN_BOUNDS, HEADER_BYTES,
    MAGIC, MATERIAL_BYTES, MAX_MAP_SIZE, MAX_OBJECTS, MAX_PATH_KEYS, MAX_SLOTS, MAX_VIEWS,
    MIN_MAP_SIZE, NAME_BYTES, OBJECT_BYTES, PATH_BYTES, VERSION, VIEW_BYTES,
};
use crate::camera::{Placement, Sphere, View};
use crate::crc::crc32;
use crate::shade::Material;

/// One object to pack.
#[derive(Clone, Debug, PartialEq)]
pub struct PackObject {
    /// Name, at most 16 bytes of UTF-8.
    pub name: String,
    /// What its file is.
    pub kind: super::Kind,
    /// Its `.tg` or `.qs` file.
    pub data: Vec<u8>,
    /// Where it sits in the world.
    pub placement: Placement,
    /// Slot of each material index its file carries (1..=8 entries).
    pub slots: Vec<u8>,
    /// Casts shadows.
    pub casts_shadows: bool,
    /// The ground: drawn last in one-pass shadows.
    pub ground: bool,
    /// Counts towards the views' sphere.
    pub in_bounds: bool,
    /// Depth the scene asked for.
    pub depth_asked: u8,
    /// Depth kept.
    pub depth_kept: u8,
    /// What the bake left out.
    pub savings: Savings,
}

/// Everything a pack holds.
#[derive(Clone, Debug, PartialEq)]
pub struct PackContents {
    /// 1..=16 objects.
    pub objects: Vec<PackObject>,
    /// 1..=8 material slots with their names.
    pub materials: Vec<(String, Material)>,
    /// Named views.
    pub views: Vec<(String, View)>,
    /// Camera path: (seconds, view), times increasing.
    pub path: Vec<(f64, View)>,
    /// Light azimuth and elevation, degrees.
    pub light_az_el: (f64, f64),
    /// Shadows.
    pub shadows: ShadowMode,
    /// Shadow map side (ignored without shadows).
    pub shadow_map_size: usize,
    /// Vertical field of view, degrees.
    pub fov_deg: f64,
    /// Smallest projected cell size the bake kept levels for (0: none dropped).
    pub min_cell_px: f64,
    /// The sphere the views orbit.
    pub sphere: Sphere,
    /// Objects' files start at multiples of `2^align_log2` (9..=16).
    pub align_log2: u8,
}

/// Why contents cannot be packed.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum PackWriteError {
    /// A count is out of range.
    Count {
        /// What.
        what: &'static str,
        /// How many.
        count: usize,
    },
    /// A name is longer than 16 bytes (or a view's is empty).
    Name(String),
    /// The shadow map side is out of range.
    MapSize(usize),
    /// `align_log2` is out of range.
    Align(u8),
    /// The pack would be 4 GiB or more.
    TooLarge,
}

impl core::fmt::Display for PackWriteError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            PackWriteError::Count { what, count } => {
                write!(f, "{count} {what}: out of the range a pack holds")
            }
            PackWriteError::Name(n) => {
                write!(f, "name {n:?} is longer than {NAME_BYTES} bytes (or empty)")
            }
            PackWriteError::MapSize(n) => write!(
                f,
                "shadow map side {n}: must be {MIN_MAP_SIZE}..={MAX_MAP_SIZE}"
            ),
            PackWriteError::Align(a) => write!(f, "alignment 2^{a} is outside 2^9..=2^16"),
            PackWriteError::TooLarge => write!(f, "the pack would be 4 GiB or more"),
        }
    }
}

impl std::error::Error for PackWriteError {}

fn put_name(out: &mut [u8], name: &str, non_empty: bool) -> Result<(), PackWriteError> {
    if name.len() > NAME_BYTES || name.contains('\0') || (non_empty && name.is_empty()) {
        return Err(PackWriteError::Name(name.into()));
    }
    out[..name.len()].copy_from_slice(name.as_bytes());
    Ok(())
}

fn put_f64s(out: &mut [u8], xs: &[f64]) {
    for (k, x) in xs.iter().enumerate() {
        out[8 * k..8 * k + 8].copy_from_slice(&x.to_le_bytes());
    }
}

fn put_f32s(out: &mut [u8], xs: &[f32]) {
    for (k, x) in xs.iter().enumerate() {
        out[4 * k..4 * k + 4].copy_from_slice(&x.to_le_bytes());
    }
}

/// Lays out a pack (`PACK.md`). The numbers are written as given: [`super::Pack::open`] is the
/// check that they are in range.
///
/// # Errors
/// [`PackWriteError`] for counts, names, the map side or the alignment out of range.
pub fn write_pack(c: &PackContents) -> Result<Vec<u8>, PackWriteError> {
    let count = |what, n: usize, lo: usize, hi: usize| {
        if (lo..=hi).contains(&n) {
            Ok(n)
        } else {
            Err(PackWriteError::Count { what, count: n })
        }
    };
    let objects = count("objects", c.objects.len(), 1, MAX_OBJECTS)?;
    let slots = count("material slots", c.materials.len(), 1, MAX_SLOTS)?;
    let views = count("views", c.views.len(), 0, MAX_VIEWS)?;
    let keys = count("camera path keyframes", c.path.len(), 0, MAX_PATH_KEYS)?;
    for o in &c.objects {
        count("materials of one object", o.slots.len(), 1, MAX_SLOTS)?;
    }
    let map_size = match c.shadows {
        ShadowMode::Off => 0,
        _ if (MIN_MAP_SIZE..=MAX_MAP_SIZE).contains(&c.shadow_map_size) => c.shadow_map_size,
        _ => return Err(PackWriteError::MapSize(c.shadow_map_size)),
    };
    if !ALIGN_LOG2_RANGE.contains(&c.align_log2) {
        return Err(PackWriteError::Align(c.align_log2));
    }
    let meta = HEADER_BYTES
        + objects * OBJECT_BYTES
        + slots * MATERIAL_BYTES
        + views * VIEW_BYTES
        + keys * PATH_BYTES;
    let align = 1usize << c.align_log2;
    let mut offsets = Vec::with_capacity(objects);
    let mut end = meta;
    for o in &c.objects {
        let at = end.next_multiple_of(align);
        offsets.push(at);
        end = at + o.data.len();
    }
    if end > u32::MAX as usize {
        return Err(PackWriteError::TooLarge);
    }
    let mut out = std::vec![0u8; end];

    let h = &mut out[..HEADER_BYTES];
    h[0..4].copy_from_slice(&MAGIC);
    h[4..6].copy_from_slice(&VERSION.to_le_bytes());
    h[8..12].copy_from_slice(&(end as u32).to_le_bytes());
    h[16..20].copy_from_slice(&(meta as u32).to_le_bytes());
    h[20] = objects as u8;
    h[21] = slots as u8;
    h[22] = views as u8;
    h[23] = match c.shadows {
        ShadowMode::Off => 0,
        ShadowMode::OnePass => 1,
        ShadowMode::TwoPass => 2,
    };
    h[24..26].copy_from_slice(&(map_size as u16).to_le_bytes());
    h[26..28].copy_from_slice(&(keys as u16).to_le_bytes());
    h[28] = c.align_log2;
    put_f64s(
        &mut h[32..64],
        &[c.light_az_el.0, c.light_az_el.1, c.fov_deg, c.min_cell_px],
    );
    let s = &c.sphere;
    put_f64s(
        &mut h[64..96],
        &[s.center[0], s.center[1], s.center[2], s.radius],
    );

    for (i, o) in c.objects.iter().enumerate() {
        let at = HEADER_BYTES + i * OBJECT_BYTES;
        let r = &mut out[at..at + OBJECT_BYTES];
        put_name(&mut r[0..16], &o.name, false)?;
        r[16] = o.kind as u8;
        r[17] = (u8::from(o.casts_shadows) * FLAG_CASTS)
            | (u8::from(o.ground) * FLAG_GROUND)
            | (u8::from(o.in_bounds) * FLAG_IN_BOUNDS);
        r[18] = o.slots.len() as u8;
        r[20..28].fill(0xFF);
        r[20..20 + o.slots.len()].copy_from_slice(&o.slots);
        r[28..32].copy_from_slice(&(offsets[i] as u32).to_le_bytes());
        r[32..36].copy_from_slice(&(o.data.len() as u32).to_le_bytes());
        let p = &o.placement;
        let rot: Vec<f64> = p.rotation.iter().flatten().copied().collect();
        put_f64s(&mut r[40..112], &rot);
        put_f64s(&mut r[112..120], &[p.scale]);
        put_f64s(&mut r[120..144], &p.translation);
        r[144] = o.depth_asked;
        r[145] = o.depth_kept;
        r[148..152].copy_from_slice(&o.savings.levels.to_le_bytes());
        r[152..156].copy_from_slice(&o.savings.color.to_le_bytes());
        r[156..160].copy_from_slice(&o.savings.material_bits.to_le_bytes());
        out[offsets[i]..offsets[i] + o.data.len()].copy_from_slice(&o.data);
    }
    let mut at = HEADER_BYTES + objects * OBJECT_BYTES;
    for (name, m) in &c.materials {
        let r = &mut out[at..at + MATERIAL_BYTES];
        put_name(&mut r[0..16], name, false)?;
        put_f32s(&mut r[16..28], &m.color);
        put_f32s(
            &mut r[28..44],
            &[m.ambient, m.diffuse, m.specular, m.shininess],
        );
        at += MATERIAL_BYTES;
    }
    for (name, v) in &c.views {
        let r = &mut out[at..at + VIEW_BYTES];
        put_name(&mut r[0..16], name, true)?;
        put_f64s(&mut r[16..40], &[v.az_deg, v.el_deg, v.dist]);
        at += VIEW_BYTES;
    }
    for (t, v) in &c.path {
        put_f64s(
            &mut out[at..at + PATH_BYTES],
            &[*t, v.az_deg, v.el_deg, v.dist],
        );
        at += PATH_BYTES;
    }
    let crc = crc32(&out[16..meta]);
    out[12..16].copy_from_slice(&crc.to_le_bytes());
    Ok(out)
}
