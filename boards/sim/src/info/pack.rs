//! What a scene pack holds: per object what is present and what the bake left out, and the RAM a
//! frame of it needs on the device.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Context, Result};
use pocketsplat_core::camera::{Sphere, Viewport};
use pocketsplat_core::scene::{ram_budget, RamBudget, Savings, ShadowMode};
use pocketsplat_core::stream::{table_entries, BlockEntry, QsStream, SlotEntry, TgStream};
use serde_json::json;

use super::tg::tg_info;
use crate::scene::render::ram_json;
use crate::stream::run::QS_BLOCK_LOG2;

/// Statistics of a scene pack (`.pack`).
#[derive(Clone, Debug)]
pub struct PackInfo {
    /// File size.
    pub file_bytes: usize,
    /// Bytes of the pack's own metadata (objects, materials, views, path).
    pub metadata_bytes: usize,
    /// Objects in the scene.
    pub object_count: usize,
    /// Per object, as `info --json` lists it: name, format, depths, samples, bytes, materials,
    /// colour, shadows, placement and what the bake left out.
    pub objects: Vec<serde_json::Value>,
    /// Material slots.
    pub material_slots: usize,
    /// The named views: name, az, el, dist.
    pub views: Vec<serde_json::Value>,
    /// Keyframes of the camera path.
    pub path_keyframes: usize,
    /// Length of the camera path, seconds.
    pub path_seconds: f64,
    /// The light's azimuth and elevation, degrees.
    pub light_az_el: (f64, f64),
    /// The pack's shadows.
    pub shadows: ShadowMode,
    /// Side of its shadow map, texels.
    pub shadow_map_size: usize,
    /// Vertical field of view, degrees.
    pub fov_deg: f64,
    /// Smallest cell the bake kept, pixels.
    pub min_cell_px: f64,
    /// The sphere the views orbit.
    pub sphere: Sphere,
    /// Bytes the bake left out, over all objects.
    pub saved_bytes: u64,
    /// RAM a frame needs on the device.
    pub ram: RamBudget,
    /// The fewest bytes of cache each object streams through (`render --stream`).
    pub stream_caches: Vec<usize>,
    /// The RAM of the pack streamed as a 520 KB device would draw it ([`DEVICE_BANDS`] bands,
    /// a [`DEVICE_MAP_SIZE`]² map, the least caches): `cache` holds the caches and the streams'
    /// tables (`stream_tables` below).
    pub device_ram: RamBudget,
    /// Of `device_ram.cache`, the streams' tables.
    pub stream_tables: usize,
    /// The objects' names, in pack order.
    pub object_names: Vec<String>,
}

/// The RP2350's SRAM, bytes (520 KB).
pub const PICO2_RAM: usize = 520 * 1024;

/// Bands a 520 KB device draws a streamed scene's frame in (`render --bands` draws a resident
/// frame so), as the QEMU firmware's streamed pack does (`pocketsplat_qemu::pack_stream::PACK_BANDS`,
/// which a test keeps equal): a band's colour and depth instead of a frame's (38,400 bytes, not
/// 307,200), for a walk of the scene per band (four bands do not fit beside an eight-slot shading
/// table, the cache the paper-scale Big Scene needs, the block tables and the objects' streams).
pub const DEVICE_BANDS: u16 = 8;

/// The shadow-map side such a device draws with (`render --shadow-map`; the firmware's
/// `PACK_MAP_SIZE`): 32 KB. Against the f64
/// reference the Big Scene's std view at 1 px loses 1.3 dB to the pack's 512² (25.11 against
/// 26.43 dB; 24.24 without shadows).
pub const DEVICE_MAP_SIZE: usize = 128;

/// Requests each object's stream of such a device queues at once (the firmware's `PACK_QUEUE`,
/// which a test keeps equal): its block table is sized by this and its cache, not by its file.
pub const DEVICE_QUEUE: usize = 32;

/// RAM of the streams' own tables when each object streams through `caches[i]` bytes: a block
/// table of [`table_entries`] of its slots and [`DEVICE_QUEUE`] [`BlockEntry`]s, per slot of its
/// cache a [`SlotEntry`], and the stream itself.
fn stream_tables(scene: &pocketsplat_core::scene::Scene<'_>, caches: &[usize]) -> usize {
    use core::mem::size_of;
    (0..scene.len())
        .filter_map(|i| Some((caches.get(i).copied()?, i)))
        .map(|(cache, i)| {
            let (log2, stream) = match scene.grid(i) {
                Some(g) => (g.header().block_log2, size_of::<TgStream<'static>>()),
                None => (QS_BLOCK_LOG2, size_of::<QsStream<'static>>()),
            };
            let slots = cache >> log2;
            table_entries(slots, DEVICE_QUEUE) * size_of::<BlockEntry>()
                + slots * size_of::<SlotEntry>()
                + stream
        })
        .sum()
}

/// Statistics of a pack's bytes; `path` names it in errors.
///
/// # Errors
/// When the pack or an object's file is invalid.
pub fn pack_info(path: &Path, bytes: &[u8]) -> Result<PackInfo> {
    let scene = crate::input::open_pack(path, bytes)?;
    let pack = scene.pack();
    let mut src = pocketsplat_core::stream::MemSource::new(bytes);
    let stream_caches = crate::stream::pack::least_caches(&mut src, pack)
        .with_context(|| path.display().to_string())?;
    let stream_tables = stream_tables(&scene, &stream_caches);
    let band = Viewport::new(
        u32::from(Viewport::DEFAULT.width),
        u32::from(Viewport::DEFAULT.height.div_ceil(DEVICE_BANDS)),
    )
    .expect("a band of the panel");
    let mut device_ram = ram_budget(pack, pack.shadows(), DEVICE_MAP_SIZE, band);
    device_ram.cache = stream_caches.iter().sum::<usize>() + stream_tables;
    let mut objects = Vec::new();
    for i in 0..scene.len() {
        let Some(r) = pack.object(i) else {
            continue;
        };
        let slots: Vec<String> = r.slots[..usize::from(r.materials)]
            .iter()
            .map(|&s| {
                pack.material(usize::from(s))
                    .map_or("?", |m| m.name)
                    .to_string()
            })
            .collect();
        if let Some(q) = scene.qsplat(i) {
            let c = q.counts();
            objects.push(json!({
                "name": r.name,
                "format": "qsplat",
                "depth_asked": r.depth_asked,
                "depth_kept": r.depth_kept,
                "samples": c.leaves + c.interior + u64::from(c.trees),
                "leaf_samples": c.leaves,
                "file_bytes": r.data.len(),
                "materials": slots,
                "material_bits": 0,
                "color": c.color_trees > 0,
                "casts_shadows": false,
                "ground": r.ground,
                "scale": r.placement.scale,
                "translation": r.placement.translation,
                "saved": saved_json(&r.savings),
            }));
            continue;
        }
        let Some(g) = scene.grid(i) else {
            continue;
        };
        let h = g.header();
        let info = tg_info(g);
        objects.push(json!({
            "name": r.name,
            "format": match h.rho { 2 => "octree", _ => "tri-grid" },
            "depth_asked": r.depth_asked,
            "depth_kept": r.depth_kept,
            "samples": info.total_samples,
            "leaf_samples": info.leaf_samples,
            "file_bytes": info.file_bytes,
            "materials": slots,
            "material_bits": h.material_bits,
            "color": h.has_color(),
            "casts_shadows": r.casts_shadows,
            "ground": r.ground,
            "scale": r.placement.scale,
            "translation": r.placement.translation,
            "saved": saved_json(&r.savings),
        }));
    }
    let views: Vec<_> = (0..pack.view_count())
        .filter_map(|v| pack.view(v))
        .map(|(n, v)| json!({"name": n, "az": v.az_deg, "el": v.el_deg, "dist": v.dist}))
        .collect();
    let saved_bytes: u64 = objects
        .iter()
        .map(|o| o["saved"]["total"].as_u64().unwrap_or(0))
        .sum();
    Ok(PackInfo {
        file_bytes: bytes.len(),
        metadata_bytes: pack.meta_len(),
        object_count: scene.len(),
        objects,
        material_slots: pack.slot_count(),
        views,
        path_keyframes: pack.path_len(),
        path_seconds: pack.path_duration(),
        light_az_el: pack.light_az_el(),
        shadows: pack.shadows(),
        shadow_map_size: pack.shadow_map_size(),
        fov_deg: pack.fov_deg(),
        min_cell_px: pack.min_cell_px(),
        sphere: pack.sphere(),
        saved_bytes,
        ram: ram_budget(
            pack,
            pack.shadows(),
            pack.shadow_map_size(),
            Viewport::DEFAULT,
        ),
        device_ram,
        stream_tables,
        stream_caches,
        object_names: (0..pack.object_count())
            .filter_map(|i| pack.object(i))
            .map(|r| r.name.to_string())
            .collect(),
    })
}

impl PackInfo {
    /// The statistics as `info --json` prints them.
    pub fn to_json(&self) -> serde_json::Value {
        let (az, el) = self.light_az_el;
        json!({
            "format": "pack",
            "file_bytes": self.file_bytes,
            "metadata_bytes": self.metadata_bytes,
            "objects": self.objects,
            "material_slots": self.material_slots,
            "views": self.views,
            "path_keyframes": self.path_keyframes,
            "path_seconds": self.path_seconds,
            "light": {"az": az, "el": el},
            "shadows": self.shadows.name(),
            "shadow_map_size": self.shadow_map_size,
            "fov": self.fov_deg,
            "min_cell_px": self.min_cell_px,
            "sphere": {"center": self.sphere.center, "radius": self.sphere.radius},
            "saved_bytes": self.saved_bytes,
            "ram": ram_json(&self.ram),
            "device_ram": ram_json(&self.device_ram),
            "stream_tables": self.stream_tables,
            "stream_cache_bytes": self.stream_caches.iter().sum::<usize>(),
        })
    }

    /// The statistics as `info` prints them, a table of the objects included; `path` heads them.
    pub fn to_text(&self, path: &Path) -> String {
        let mut out = String::new();
        let (az, el) = self.light_az_el;
        let sphere = &self.sphere;
        let _ = writeln!(
            out,
            "{}: scene pack version 1, {} bytes ({} of metadata), {} objects, {} material slots",
            path.display(),
            self.file_bytes,
            self.metadata_bytes,
            self.object_count,
            self.material_slots
        );
        let _ = writeln!(
            out,
            "  light az {az} el {el}; shadows {} (map {}²); fov {}°; views orbit a sphere of radius {:.4} at ({:.4}, {:.4}, {:.4})",
            self.shadows.name(),
            self.shadow_map_size,
            self.fov_deg,
            sphere.radius,
            sphere.center[0],
            sphere.center[1],
            sphere.center[2]
        );
        let names: Vec<String> = self
            .views
            .iter()
            .map(|v| {
                format!(
                    "{} ({},{},{})",
                    v["name"].as_str().unwrap_or(""),
                    v["az"],
                    v["el"],
                    v["dist"]
                )
            })
            .collect();
        let _ = writeln!(
            out,
            "  views: {}{}",
            if names.is_empty() {
                "none".to_string()
            } else {
                names.join(", ")
            },
            if self.path_keyframes > 0 {
                format!(
                    "; camera path of {} keyframes over {} s",
                    self.path_keyframes, self.path_seconds
                )
            } else {
                String::new()
            }
        );
        let _ = writeln!(
            out,
            "  {:<16} {:<8} {:>5} {:>10} {:>10}  {:<22} {:<10} left out",
            "object", "format", "depth", "samples", "bytes", "materials (bits)", "colour"
        );
        for o in &self.objects {
            let s = &o["saved"];
            let mut left_out = Vec::new();
            if s["levels"].as_u64().unwrap_or(0) > 0 {
                left_out.push(format!(
                    "levels {}..={}: {} B",
                    o["depth_kept"].as_u64().unwrap_or(0) + 1,
                    o["depth_asked"],
                    s["levels"]
                ));
            }
            if s["color"].as_u64().unwrap_or(0) > 0 {
                left_out.push(format!("colour: {} B", s["color"]));
            }
            let mats: Vec<&str> = o["materials"]
                .as_array()
                .map(|a| a.iter().filter_map(|m| m.as_str()).collect())
                .unwrap_or_default();
            let _ = writeln!(
                out,
                "  {:<16} {:<8} {:>2}/{:<2} {:>10} {:>10}  {:<22} {:<10} {}",
                o["name"].as_str().unwrap_or(""),
                o["format"].as_str().unwrap_or(""),
                o["depth_kept"],
                o["depth_asked"],
                o["samples"],
                o["file_bytes"],
                format!("{} ({})", mats.join("+"), o["material_bits"]),
                if o["color"].as_bool().unwrap_or(false) {
                    "RGB565"
                } else {
                    "absent"
                },
                if left_out.is_empty() {
                    "nothing".to_string()
                } else {
                    left_out.join("; ")
                }
            );
        }
        let _ = writeln!(
            out,
            "  left out in all: {} bytes (material bits cost 0 bytes here: they share the u16 attribute with the normal code)",
            self.saved_bytes
        );
        let ram = &self.ram;
        let _ = writeln!(
            out,
            "  device RAM per frame: {} bytes = framebuffer {} + depth {} + shadow map {} + shading table {} + cache {} + frame setup {} + scene {}",
            ram.total(),
            ram.framebuffer,
            ram.depth,
            ram.shadow_map,
            ram.shading_tables,
            ram.cache,
            ram.frame_setup,
            ram.scene
        );
        let total: usize = self.stream_caches.iter().sum();
        let _ = writeln!(
            out,
            "  streaming needs --cache {} or more ({}), and the cache must hold a frame's blocks \
             for its shadows",
            crate::stream::run::cache_arg(total as u64),
            self.object_names
                .iter()
                .zip(&self.stream_caches)
                .map(|(n, c)| format!("{n} {}", crate::stream::run::cache_arg(*c as u64)))
                .collect::<Vec<_>>()
                .join(", ")
        );
        let d = &self.device_ram;
        let _ = writeln!(
            out,
            "  streamed as a 520 KB device would ({DEVICE_BANDS} bands, shadow map \
             {DEVICE_MAP_SIZE}², the least caches): {} bytes = band {} + band depth {} + shadow \
             map {} + shading table {} + caches {} + stream tables {} + frame setup {} + scene \
             {}, before the stack; the Pico 2 has {} ({})",
            d.total(),
            d.framebuffer,
            d.depth,
            d.shadow_map,
            d.shading_tables,
            d.cache - self.stream_tables,
            self.stream_tables,
            d.frame_setup,
            d.scene,
            PICO2_RAM,
            if d.total() <= PICO2_RAM {
                "fits"
            } else {
                "does not fit"
            }
        );
        out
    }
}

/// What the bake left out of an object, as `info --json` lists it.
fn saved_json(s: &Savings) -> serde_json::Value {
    json!({
        "levels": s.levels,
        "color": s.color,
        "material_bits": s.material_bits,
        "total": u64::from(s.levels) + u64::from(s.color) + u64::from(s.material_bits),
    })
}
