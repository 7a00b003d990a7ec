//! The scene side of `pocketsplat bake`, `render` and `info`: what `main.rs` calls when the input is
//! a scene file (`.toml`) or a pack (magic `PSPK`).

use std::path::Path;
use std::time::Instant;

use anyhow::{anyhow, Result};
use pocketsplat_core::camera::View;
use pocketsplat_core::format::FileFormat;
use pocketsplat_core::raster::Kernel;
use pocketsplat_core::scene::{ram_budget, Pack, Scene, ShadowMode};
use pocketsplat_core::tg::Verify;
use serde_json::json;

use super::bake::{bake_scene, BakeOverrides};
use super::render::{ram_json, render_pack, stats_json, PackSettings};
use crate::fsutil::write_atomic;
use crate::render::FrameBuffers;
use crate::{image, scene};

/// Whether `path` names a scene file (by its `.toml` extension).
pub fn is_scene_file(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("toml"))
}

/// Whether `path` is a scene pack (by its magic). A file that cannot be opened is not one (the
/// caller's own reader then names the problem).
pub fn is_pack(path: &Path) -> bool {
    crate::fsutil::sniff(path).is_ok_and(|f| f == Some(FileFormat::Pack))
}

/// Whether the command line names `flag` (`--flag VALUE` or `--flag=VALUE`): for a pack, options
/// left out take the pack's own values rather than the command's defaults.
pub fn flag_given(flag: &str) -> bool {
    std::env::args_os().any(|a| {
        let a = a.to_string_lossy();
        a == flag || a.strip_prefix(flag).is_some_and(|r| r.starts_with('='))
    })
}

/// Reads a pack and opens its scene (every object's file checked), naming `path` in errors.
///
/// # Errors
/// When the file cannot be read, or the pack or an object's file is invalid.
pub fn read_pack(path: &Path) -> Result<Vec<u8>> {
    let bytes = crate::fsutil::read_file(path)?;
    open_scene(path, &bytes)?;
    Ok(bytes)
}

/// Opens a pack's bytes as a scene, naming `path` in errors.
///
/// # Errors
/// When the pack or an object's file is invalid.
pub fn open_scene<'a>(path: &Path, bytes: &'a [u8]) -> Result<Scene<'a>> {
    let pack = Pack::open(bytes).map_err(|e| anyhow!("{}: {e}", path.display()))?;
    Scene::open(pack, Verify::Full).map_err(|e| anyhow!("{}: {e}", path.display()))
}

/// `pocketsplat bake scene.toml -o scene.pack`.
///
/// # Errors
/// Scene file, import and bake errors, naming the file and object; nothing is written then.
pub fn bake(scene_path: &Path, out: &Path, force: bool) -> Result<()> {
    let t = Instant::now();
    let s = scene::Scene::load(scene_path)?;
    let overrides = BakeOverrides {
        force,
        ..BakeOverrides::default()
    };
    let baked = bake_scene(&s, &overrides)?;
    write_atomic(out, &baked.bytes)?;
    for o in &baked.objects {
        eprintln!(
            "  {:<16} depth {} of {}: {:>9} samples, {:>9} bytes{}{} ({:.2} s)",
            o.name,
            o.depth_kept,
            o.depth_asked,
            o.samples,
            o.file_bytes,
            if o.saved_levels > 0 {
                format!("; {} bytes of unresolvable levels left out", o.saved_levels)
            } else {
                String::new()
            },
            if o.saved_color > 0 {
                format!("; {} bytes of colour left out", o.saved_color)
            } else {
                String::new()
            },
            o.bake_s
        );
    }
    eprintln!(
        "{}: {} objects, {} bytes, in {:.2} s",
        out.display(),
        baked.objects.len(),
        baked.bytes.len(),
        t.elapsed().as_secs_f64()
    );
    Ok(())
}

/// What `render` was asked for, for a pack: `None` takes the pack's own value.
#[derive(Clone, Debug)]
pub struct RenderArgs {
    /// A view of the pack, a standard view, `AZ,EL,DIST`, or `path@SECONDS`.
    pub view: String,
    /// Field of view, degrees.
    pub fov: Option<f64>,
    /// Cutoff, pixels.
    pub cutoff_px: f32,
    /// Kernel.
    pub kernel: Kernel,
    /// Light `AZ,EL`.
    pub light: Option<String>,
    /// Shadows.
    pub shadows: Option<ShadowMode>,
    /// Print one JSON object of statistics.
    pub stats_json: bool,
    /// Tint splats by their levels above full detail, with a key.
    pub color_by_level: bool,
}

/// A view of the pack by name, a standard view, `AZ,EL,DIST`, or `path@T` (the camera path at `T`
/// seconds).
///
/// # Errors
/// When it is none of these.
pub fn parse_pack_view(pack: &Pack<'_>, text: &str) -> Result<View> {
    if let Some(v) = pack.view_named(text) {
        return Ok(v);
    }
    if let Some(t) = text.strip_prefix("path@") {
        let t: f64 = t
            .parse()
            .map_err(|e| anyhow!("--view {text:?}: {t:?} is not a time in seconds ({e})"))?;
        return pack
            .path_view(t)
            .ok_or_else(|| anyhow!("--view {text:?}: the pack has no camera path"));
    }
    crate::args::parse_view(text).map_err(|e| {
        let names: Vec<&str> = (0..pack.view_count())
            .filter_map(|v| pack.view(v).map(|(n, _)| n))
            .collect();
        anyhow!("{e} (the pack's views: {})", names.join(", "))
    })
}

fn shadows_name(s: ShadowMode) -> &'static str {
    match s {
        ShadowMode::Off => "off",
        ShadowMode::OnePass => "one-pass",
        ShadowMode::TwoPass => "two-pass",
    }
}

/// `pocketsplat render scene.pack -o OUT.png`.
///
/// # Errors
/// Bad arguments or input, naming the file; no output is written then.
pub fn render(input: &Path, out: &Path, args: &RenderArgs) -> Result<()> {
    let bytes = crate::fsutil::read_file(input)?;
    let scene = open_scene(input, &bytes)?;
    let pack = scene.pack();
    let mut settings = PackSettings::new(parse_pack_view(pack, &args.view)?);
    settings.cutoff_px = args.cutoff_px;
    settings.kernel = args.kernel;
    settings.fov_deg = args.fov;
    settings.shadows = args.shadows;
    if let Some(l) = &args.light {
        let [az, el] = crate::args::parse_numbers::<2>("--light", l)?;
        settings.light_az_el = Some((az, el));
    }
    settings.color_by_level = args.color_by_level;
    let mut fb = FrameBuffers::new();
    let frame = render_pack(&scene, &settings, &mut fb)?;
    if args.color_by_level {
        crate::levels::legend_in_corner(&mut fb.framebuffer());
    }
    image::write_rgb565_png(out, fb.pixels())?;
    if args.stats_json {
        let mut v = stats_json(&frame.stats.total);
        let o = v.as_object_mut().expect("an object");
        o.insert("input".into(), json!(input.display().to_string()));
        o.insert("renderer".into(), json!("scene"));
        o.insert("objects".into(), json!(scene.len()));
        o.insert("shadows".into(), json!(shadows_name(frame.stats.shadows)));
        o.insert(
            "shadow_fill_nodes".into(),
            json!(frame.stats.shadow_fill_nodes),
        );
        o.insert("ms".into(), json!(frame.time.as_secs_f64() * 1e3));
        o.insert("cutoff_px".into(), json!(args.cutoff_px));
        o.insert(
            "kernel".into(),
            json!(match args.kernel {
                Kernel::Square => "square",
                Kernel::Round => "round",
            }),
        );
        o.insert(
            "per_object".into(),
            json!((0..scene.len())
                .map(|i| {
                    let mut s = stats_json(&frame.stats.objects[i]);
                    let name = pack.object(i).map_or("", |r| r.name);
                    s.as_object_mut()
                        .expect("an object")
                        .insert("name".into(), json!(name));
                    s
                })
                .collect::<Vec<_>>()),
        );
        o.insert("ram".into(), ram_json(&frame.ram));
        println!("{v}");
    } else {
        eprintln!(
            "wrote {} in {:.1} ms ({} objects, {} splats, shadows {}; device RAM {} bytes)",
            out.display(),
            frame.time.as_secs_f64() * 1e3,
            scene.len(),
            frame.stats.total.splats,
            shadows_name(frame.stats.shadows),
            frame.ram.total()
        );
    }
    Ok(())
}

/// `pocketsplat info scene.pack [--json]`: per object what is present and what was left out.
///
/// # Errors
/// When the file cannot be read or is invalid.
pub fn info(path: &Path, as_json: bool) -> Result<()> {
    let bytes = crate::fsutil::read_file(path)?;
    let scene = open_scene(path, &bytes)?;
    let pack = scene.pack();
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
        let info = crate::info::tg_info(g);
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
    let (az, el) = pack.light_az_el();
    let saved: u64 = objects
        .iter()
        .map(|o| o["saved"]["total"].as_u64().unwrap_or(0))
        .sum();
    let ram = ram_budget(pack, pack.shadows(), pack.shadow_map_size());
    let sphere = pack.sphere();
    let report = json!({
        "format": "pack",
        "file_bytes": bytes.len(),
        "metadata_bytes": pack.meta_len(),
        "objects": objects,
        "material_slots": pack.slot_count(),
        "views": views,
        "path_keyframes": pack.path_len(),
        "path_seconds": pack.path_duration(),
        "light": {"az": az, "el": el},
        "shadows": shadows_name(pack.shadows()),
        "shadow_map_size": pack.shadow_map_size(),
        "fov": pack.fov_deg(),
        "min_cell_px": pack.min_cell_px(),
        "sphere": {"center": sphere.center, "radius": sphere.radius},
        "saved_bytes": saved,
        "ram": ram_json(&ram),
    });
    if as_json {
        println!("{report}");
        return Ok(());
    }
    println!(
        "{}: scene pack version 1, {} bytes ({} of metadata), {} objects, {} material slots",
        path.display(),
        bytes.len(),
        pack.meta_len(),
        scene.len(),
        pack.slot_count()
    );
    println!(
        "  light az {az} el {el}; shadows {} (map {}²); fov {}°; views orbit a sphere of radius {:.4} at ({:.4}, {:.4}, {:.4})",
        shadows_name(pack.shadows()),
        pack.shadow_map_size(),
        pack.fov_deg(),
        sphere.radius,
        sphere.center[0],
        sphere.center[1],
        sphere.center[2]
    );
    let names: Vec<String> = views
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
    println!(
        "  views: {}{}",
        if names.is_empty() {
            "none".to_string()
        } else {
            names.join(", ")
        },
        if pack.path_len() > 0 {
            format!(
                "; camera path of {} keyframes over {} s",
                pack.path_len(),
                pack.path_duration()
            )
        } else {
            String::new()
        }
    );
    println!(
        "  {:<16} {:<8} {:>5} {:>10} {:>10}  {:<22} {:<10} left out",
        "object", "format", "depth", "samples", "bytes", "materials (bits)", "colour"
    );
    for o in &objects {
        let s = &o["saved"];
        let mut out = Vec::new();
        if s["levels"].as_u64().unwrap_or(0) > 0 {
            out.push(format!(
                "levels {}..={}: {} B",
                o["depth_kept"].as_u64().unwrap_or(0) + 1,
                o["depth_asked"],
                s["levels"]
            ));
        }
        if s["color"].as_u64().unwrap_or(0) > 0 {
            out.push(format!("colour: {} B", s["color"]));
        }
        let mats: Vec<&str> = o["materials"]
            .as_array()
            .map(|a| a.iter().filter_map(|m| m.as_str()).collect())
            .unwrap_or_default();
        println!(
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
            if out.is_empty() {
                "nothing".to_string()
            } else {
                out.join("; ")
            }
        );
    }
    println!(
        "  left out in all: {saved} bytes (material bits cost 0 bytes here: they share the u16 attribute with the normal code)"
    );
    println!(
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
    Ok(())
}

/// What the bake left out of an object, as `info --json` lists it.
fn saved_json(s: &pocketsplat_core::scene::Savings) -> serde_json::Value {
    json!({
        "levels": s.levels,
        "color": s.color,
        "material_bits": s.material_bits,
        "total": u64::from(s.levels) + u64::from(s.color) + u64::from(s.material_bits),
    })
}
