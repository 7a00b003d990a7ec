//! Baking a scene file into a pack: load or generate each object's mesh, place it, bake it, leave
//! out what the scene does not need, and lay everything out in one file.
//!
//! **Levels the views cannot resolve.** For every named view and camera-path sample the nearest
//! point of each object's placed bounding box (camera depth `z`, clamped to the near plane; objects
//! wholly outside the frustum are skipped) bounds how large its cells can appear: a cell of level
//! `L` projects to at most `√3 · side_L · f / z` pixels (the traversal's own LOD measure). Levels
//! below the deepest one whose cells reach `min_cell_px` in some view are dropped: the grid is
//! baked at the depth the scene asks for and cut there, so `info` reports the exact bytes saved.
//! For every cutoff of at least `3 · min_cell_px` (1.5 px by default, ρ = 3) the frames of those
//! views are those of the full-depth file, since the traversal never descends into a cell smaller
//! than the cutoff; at 1 px it may draw a few cells one level coarser where a cell lands between 1
//! and 1.5 px.
//!
//! **Attributes nothing draws.** A tri-grid sample is shaded by its object's material, so a colour
//! channel baked from vertex colours is never drawn: it is left out, and its size reported. Material
//! bits are kept when an object has several materials (a tree's bark and leaves); they cost no bytes,
//! sharing the `u16` attribute with the 13-bit normal code.

use std::path::Path;
use std::time::{Duration, Instant};

use anyhow::{bail, Context, Result};
use pocketsplat_core::bake::{bake_grid, BakeOptions, BakedGrid, TriMesh};
use pocketsplat_core::camera::{Camera, Placement, Sphere, Vec3, View, HEIGHT, WIDTH};
use pocketsplat_core::qs::QSplat;
use pocketsplat_core::scene::write::{write_pack, PackContents, PackObject};
use pocketsplat_core::scene::{Kind, Pack, Savings, Scene as CoreScene, MAX_SLOTS};
use pocketsplat_core::shade::Material;
use pocketsplat_core::tg::write::{write_tg_as, Layout};
use pocketsplat_core::tg::{TriGrid, Verify};
use serde::Serialize;

use super::{rotation, Anchor, SceneSpec, Source};
use crate::ply;

/// How a pack's tri-grids are laid out: without bricks (version 3, every level one array). A pack
/// is drawn in place, never streamed, and the resident walk of a bricked grid costs a few percent
/// more (README, "Measured"), which the Big Scene's 40 M-instruction frame has no room for.
const PACK_LAYOUT: Layout = Layout::Unbricked;

/// Changes to a scene's `[bake]` settings, for reports that bake one scene several ways.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BakeOverrides {
    /// ρ instead of the scene's (2 octree, 3 tri-grid). Objects' depths, written for the scene's ρ,
    /// become those of the nearest resolution in this one ([`depth_near`]).
    pub rho: Option<u8>,
    /// At most this depth (of the scene's ρ) for every baked object.
    pub max_depth: Option<u8>,
    /// `min_cell_px` instead of the scene's (0 keeps every level).
    pub min_cell_px: Option<f64>,
    /// Bake even when the estimate of the memory the objects' bakes need is over the `bake` limit.
    pub force: bool,
}

/// The depth of a `to_rho` grid whose cells per axis (`to_rho^d`) are nearest those of a `rho` grid
/// of `depth` (`rho^depth`): e.g. the octree at a tri-grid's resolution. A tie goes to the coarser.
pub fn depth_near(rho: u8, depth: u8, to_rho: u8) -> u8 {
    let cells = u64::from(rho).pow(u32::from(depth));
    (0..=pocketsplat_core::tg::MAX_DEPTH)
        .min_by_key(|&d| u64::from(to_rho).pow(u32::from(d)).abs_diff(cells))
        .unwrap_or(0)
}

/// An object loaded (or generated) and placed, before baking.
#[derive(Clone, Debug)]
pub struct LoadedObject {
    /// Its mesh in model units (`None` for a `.tg` file).
    pub mesh: Option<TriMesh>,
    /// A `.tg` file's bytes (`None` for a mesh or a `.qs` file).
    pub tg: Option<Vec<u8>>,
    /// A `.qs` file's bytes (`None` for a mesh or a `.tg` file): packed as it is, kind 2.
    pub qs: Option<Vec<u8>>,
    /// Where it sits in the world.
    pub placement: Placement,
    /// Its model-space bounding box as its `.tg` (or `.qs`) file stores it.
    pub bounds: [[f32; 3]; 2],
    /// Time spent reading or generating it.
    pub load: Duration,
}

/// What the bake did with one object: `pocketsplat info` prints the same from the pack.
#[derive(Clone, Debug, Serialize)]
pub struct ObjectReport {
    /// Its name.
    pub name: String,
    /// Depth the scene asked for.
    pub depth_asked: u8,
    /// Depth kept.
    pub depth_kept: u8,
    /// Samples kept.
    pub samples: u64,
    /// Bytes of its `.tg` file in the pack.
    pub file_bytes: usize,
    /// What was left out.
    pub saved_levels: u32,
    /// Bytes of the colour channel left out.
    pub saved_color: u32,
    /// Seconds spent baking.
    pub bake_s: f64,
}

/// A baked scene.
#[derive(Clone, Debug)]
pub struct BakedScene {
    /// The pack's bytes.
    pub bytes: Vec<u8>,
    /// Per object.
    pub objects: Vec<ObjectReport>,
    /// The materials of the pack's slots, in order.
    pub slot_materials: Vec<Material>,
    /// Each object's slots, one per material index.
    pub object_slots: Vec<Vec<u8>>,
}

/// The placed bounding box of a model-space box (the box around its placed corners).
pub fn placed_box(p: &Placement, b: [[f32; 3]; 2]) -> [Vec3; 2] {
    let mut out = [[f64::INFINITY; 3], [f64::NEG_INFINITY; 3]];
    for corner in 0..8 {
        let q: Vec3 = std::array::from_fn(|k| f64::from(b[corner >> k & 1][k]));
        let w = p.apply(q);
        for k in 0..3 {
            out[0][k] = out[0][k].min(w[k]);
            out[1][k] = out[1][k].max(w[k]);
        }
    }
    out
}

/// Loads or generates every object and places it.
///
/// # Errors
/// A file that cannot be read, a mesh that cannot be imported, a `.tg` file that fails its checks,
/// or materials that do not match the mesh; each names the object.
pub fn load_objects(scene: &SceneSpec) -> Result<Vec<LoadedObject>> {
    let mut out = Vec::new();
    for ((o, source), names) in scene
        .file
        .objects
        .iter()
        .zip(&scene.sources)
        .zip(&scene.object_materials)
    {
        let t = Instant::now();
        let what = || format!("{}: object {:?}", scene.path.display(), o.name);
        let mut qs = None;
        let (mesh, tg) = match source {
            Source::Mesh(path) => (Some(ply::load_mesh(path).with_context(what)?), None),
            Source::Tree(spec) => (Some(spec.mesh()), None),
            Source::Ground(g) => (Some(g.mesh(names.len() > 1)), None),
            Source::File(path)
                if crate::qsplat::is_qs(path)
                    .map_err(|e| anyhow::anyhow!("{}: {e}", what()))? =>
            {
                let bytes =
                    crate::qsplat::read_qs(path).map_err(|e| anyhow::anyhow!("{}: {e}", what()))?;
                if names.len() != 1 {
                    bail!(
                        "{}: {} is a .qs file, which has one material: give material = \"...\", \
                         not {} materials",
                        what(),
                        path.display(),
                        names.len()
                    );
                }
                qs = Some(bytes);
                (None, None)
            }
            Source::File(path) => {
                let bytes = crate::fsutil::read_file(path).with_context(what)?;
                TriGrid::open(&bytes, Verify::Full)
                    .map_err(|e| anyhow::anyhow!("{}: {}: {e}", what(), path.display()))?;
                (None, Some(bytes))
            }
        };
        let mut mesh = mesh;
        if let Some(m) = &mut mesh {
            if names.len() == 1 {
                // One material for everything: no material bits.
                m.materials = None;
            } else if usize::from(m.material_count()) > names.len() {
                bail!(
                    "{}: the mesh has {} material indices but the object names {} materials",
                    what(),
                    m.material_count(),
                    names.len()
                );
            }
            m.validate()
                .map_err(|e| anyhow::anyhow!("{}: {e}", what()))?;
        }
        let bounds = match (&mesh, &tg) {
            (Some(m), _) => m.bounds_f32(),
            (None, None) if qs.is_some() => {
                let q = QSplat::open(qs.as_deref().unwrap_or(&[]))
                    .map_err(|e| anyhow::anyhow!("{}: {e}", what()))?;
                q.bounds()
            }
            (None, Some(b)) => {
                let g = TriGrid::open(b, Verify::Structure)
                    .map_err(|e| anyhow::anyhow!("{}: {e}", what()))?;
                if g.header().material_bits == 0 && names.len() > 1 {
                    bail!(
                        "{}: the file has one material but the object names {}",
                        what(),
                        names.len()
                    );
                }
                g.header().bounds
            }
            (None, None) => unreachable!("a source is a mesh or a file"),
        };
        let r = rotation(&o.rotate).with_context(what)?;
        let unit = Placement {
            rotation: r,
            scale: 1.0,
            translation: [0.0; 3],
        };
        let scale = match (o.scale, o.height) {
            (Some(s), _) => s,
            (None, Some(h)) => {
                let b = placed_box(&unit, bounds);
                let extent = b[1][1] - b[0][1];
                if extent.is_nan() || extent <= 0.0 {
                    bail!("{}: height: the model has no height to scale", what());
                }
                h / extent
            }
            (None, None) => 1.0,
        };
        let scaled = Placement { scale, ..unit };
        let b = placed_box(&scaled, bounds);
        let anchor: Vec3 = match o.anchor {
            Anchor::Origin => [0.0; 3],
            Anchor::Base => [
                0.5 * (b[0][0] + b[1][0]),
                b[0][1],
                0.5 * (b[0][2] + b[1][2]),
            ],
            Anchor::Center => std::array::from_fn(|k| 0.5 * (b[0][k] + b[1][k])),
        };
        let placement = Placement {
            translation: std::array::from_fn(|k| o.translate[k] - anchor[k]),
            ..scaled
        };
        out.push(LoadedObject {
            mesh,
            tg,
            qs,
            placement,
            bounds,
            load: t.elapsed(),
        });
    }
    Ok(out)
}

/// The sphere the views orbit: around the union of the in-bounds objects' placed boxes.
///
/// # Errors
/// When no object is in bounds.
pub fn scene_sphere(scene: &SceneSpec, objects: &[LoadedObject]) -> Result<Sphere> {
    let mut all = [[f64::INFINITY; 3], [f64::NEG_INFINITY; 3]];
    for (o, l) in scene.file.objects.iter().zip(objects) {
        if !o.in_bounds {
            continue;
        }
        let b = placed_box(&l.placement, l.bounds);
        for k in 0..3 {
            all[0][k] = all[0][k].min(b[0][k]);
            all[1][k] = all[1][k].max(b[1][k]);
        }
    }
    if !all[0][0].is_finite() {
        bail!(
            "{}: no object is in bounds (in_bounds = false everywhere): the views need a sphere",
            scene.path.display()
        );
    }
    let center = std::array::from_fn(|k| 0.5 * (all[0][k] + all[1][k]));
    let d: Vec3 = std::array::from_fn(|k| all[1][k] - all[0][k]);
    let radius = 0.5 * libm::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    Ok(Sphere {
        center,
        radius: if radius > 0.0 { radius } else { 1.0 },
    })
}

/// The cameras a scene can be seen from: its named views and samples of its camera path (16 per
/// segment and every keyframe).
pub fn scene_cameras(scene: &SceneSpec, sphere: Sphere) -> Vec<Camera> {
    let mut views: Vec<View> = scene.views().into_iter().map(|(_, v)| v).collect();
    let keys = &scene.file.path;
    for (k, p) in keys.iter().enumerate() {
        views.push(View::new(p.az, p.el, p.dist));
        if let Some(q) = keys.get(k + 1) {
            for s in 1..16 {
                let a = f64::from(s) / 16.0;
                let lerp = |x: f64, y: f64| x + (y - x) * a;
                views.push(View::new(
                    lerp(p.az, q.az),
                    lerp(p.el, q.el),
                    lerp(p.dist, q.dist),
                ));
            }
        }
    }
    views
        .into_iter()
        .map(|v| Camera::orbit(sphere, v, scene.file.fov))
        .collect()
}

/// The deepest level whose cells some camera sees at `min_cell_px` or larger, for a grid of `rho`
/// and root cube `side` (model units) up to `depth`, with model box `bounds` placed by `placement`.
/// At least 1; `depth` when `cameras` is empty.
pub fn resolvable_depth(
    cameras: &[Camera],
    placement: &Placement,
    bounds: [[f32; 3]; 2],
    side: f64,
    rho: u8,
    depth: u8,
    min_cell_px: f64,
) -> u8 {
    if cameras.is_empty() || min_cell_px <= 0.0 {
        return depth;
    }
    let b = placed_box(placement, bounds);
    let corners: Vec<Vec3> = (0..8)
        .map(|c| std::array::from_fn(|k| b[c >> k & 1][k]))
        .collect();
    let mut kept = 1u8.min(depth);
    for cam in cameras {
        let (cx, cy) = (WIDTH as f64 / 2.0, HEIGHT as f64 / 2.0);
        // Homogeneous screen coordinates of the corners (X/W, Y/W pixels, W depth).
        let hom: Vec<[f64; 3]> = corners
            .iter()
            .map(|&p| {
                let [x, y, z] = cam.to_camera(p);
                [cam.focal_px * x + cx * z, -cam.focal_px * y + cy * z, z]
            })
            .collect();
        let outside = |f: &dyn Fn(&[f64; 3]) -> f64| hom.iter().all(|h| f(h) < 0.0);
        if outside(&|h| h[2] - cam.near)
            || outside(&|h| h[0])
            || outside(&|h| WIDTH as f64 * h[2] - h[0])
            || outside(&|h| h[1])
            || outside(&|h| HEIGHT as f64 * h[2] - h[1])
        {
            continue;
        }
        let z = hom
            .iter()
            .map(|h| h[2])
            .fold(f64::INFINITY, f64::min)
            .max(cam.near);
        let mut cell = side * placement.scale;
        for level in 0..=depth {
            let px = libm::sqrt(3.0) * cell * cam.focal_px / z;
            if px < min_cell_px {
                break;
            }
            kept = kept.max(level);
            cell /= f64::from(rho);
        }
    }
    kept
}

/// `grid` cut after level `depth`: the samples of that level become the leaves.
pub fn truncate(grid: &BakedGrid, depth: u8) -> BakedGrid {
    let mut g = grid.clone();
    g.levels.truncate(usize::from(depth) + 1);
    if let Some(last) = g.levels.last_mut() {
        last.masks.clear();
    }
    g
}

fn strip_colors(grid: &mut BakedGrid) -> bool {
    let mut had = false;
    for l in &mut grid.levels {
        had |= l.colors.take().is_some();
    }
    had
}

/// Bakes a checked scene into a pack.
///
/// # Errors
/// Anything [`load_objects`] finds, bake and layout errors, more than 8 material slots; each names
/// the scene and the object.
pub fn bake_scene(scene: &SceneSpec, overrides: &BakeOverrides) -> Result<BakedScene> {
    let objects = load_objects(scene)?;
    bake_loaded(scene, &objects, overrides)
}

/// [`bake_scene`] over objects already loaded (a report bakes one scene several ways).
///
/// # Errors
/// As [`bake_scene`].
pub fn bake_loaded(
    scene: &SceneSpec,
    objects: &[LoadedObject],
    overrides: &BakeOverrides,
) -> Result<BakedScene> {
    let f = &scene.file;
    let rho = overrides.rho.unwrap_or(f.bake.rho);
    if !(2..=3).contains(&rho) {
        bail!("rho {rho}: a scene is baked with rho 2 or 3");
    }
    let min_cell_px = overrides.min_cell_px.unwrap_or(f.bake.min_cell_px);
    let block_log2 = f.bake.block_size.trailing_zeros() as u8;
    let sphere = scene_sphere(scene, objects)?;
    let cameras = scene_cameras(scene, sphere);

    // Slots: one per (material, rotation), in order of first use.
    let mut slot_keys: Vec<(String, [[u64; 3]; 3])> = Vec::new();
    let mut object_slots = Vec::new();
    for ((o, names), l) in f.objects.iter().zip(&scene.object_materials).zip(objects) {
        let rot = l.placement.rotation.map(|r| r.map(f64::to_bits));
        let mut slots = Vec::new();
        for n in names {
            let key = (n.clone(), rot);
            let s = match slot_keys.iter().position(|k| *k == key) {
                Some(s) => s,
                None => {
                    slot_keys.push(key);
                    slot_keys.len() - 1
                }
            };
            slots.push(s as u8);
        }
        if slot_keys.len() > MAX_SLOTS {
            bail!(
                "{}: object {:?}: the scene needs more than {MAX_SLOTS} material slots (one per \
                 material and rotation): share materials, or give objects with one material the \
                 same rotation",
                scene.path.display(),
                o.name
            );
        }
        object_slots.push(slots);
    }
    let slot_materials: Vec<Material> = slot_keys
        .iter()
        .map(|(n, _)| f.materials[n].material())
        .collect();

    // The depth each mesh object is baked at, and the estimate of them all before any starts.
    let asked_depth = |o: &super::ObjectSpec| {
        depth_near(
            f.bake.rho,
            o.depth
                .unwrap_or(6)
                .min(overrides.max_depth.unwrap_or(u8::MAX)),
            rho,
        )
    };
    // Every mesh object is estimated (a shallow probe each) before any is baked; past the `bake`
    // limit only with `force`. The estimates also say which objects get a progress bar.
    let limit = crate::limits::current().bake;
    let mut estimates = Vec::new();
    let mut files = 0u64;
    for (o, l) in f.objects.iter().zip(objects) {
        let Some(mesh) = &l.mesh else {
            estimates.push(None);
            continue;
        };
        let depth = asked_depth(o);
        let at = |e: anyhow::Error| {
            anyhow::anyhow!("{}: object {:?}: {e}", scene.path.display(), o.name)
        };
        let e = crate::bake::estimate_bake(mesh, BakeOptions { rho, depth }).map_err(at)?;
        if !overrides.force {
            e.check(limit, depth).map_err(at)?;
        }
        files = files.saturating_add(e.file_bytes);
        estimates.push(Some(e));
    }
    // The packed files of every object are held together at the end.
    if !overrides.force && files > limit {
        bail!(
            "{}: the objects' files would take about {} MB together, over the limit bake={} \
             (bake less deep, or pass --force, or raise it with --limits bake=SIZE)",
            scene.path.display(),
            files >> 20,
            crate::args::format_size(limit)
        );
    }
    let long = |i: usize| {
        estimates
            .get(i)
            .and_then(Option::as_ref)
            .is_some_and(|e| e.total_samples() > 1 << 20)
    };

    let mut pack_objects = Vec::new();
    let mut reports = Vec::new();
    for (i, (o, l)) in f.objects.iter().zip(objects).enumerate() {
        let t = Instant::now();
        let what = || format!("{}: object {:?}", scene.path.display(), o.name);
        let kind = if l.qs.is_some() {
            Kind::QSplat
        } else {
            Kind::TriGrid
        };
        let (data, asked, kept, savings, samples) = match (&l.mesh, &l.tg) {
            (Some(mesh), _) => {
                let asked = asked_depth(o);
                let bar = long(i).then(|| crate::bake::progress_bar(&format!(" {:?}", o.name)));
                let cb = |done: u64, total: u64| {
                    if let Some(bar) = &bar {
                        bar.set_length(total);
                        bar.set_position(done);
                    }
                };
                let progress: Option<pocketsplat_core::bake::BakeProgress<'_>> =
                    bar.as_ref().map(|_| &cb as _);
                let mut grid = bake_grid(mesh, BakeOptions { rho, depth: asked }, progress)
                    .map_err(|e| anyhow::anyhow!("{}: {e}", what()))?;
                if let Some(bar) = bar {
                    bar.finish_and_clear();
                }
                let had_color = grid.levels[0].colors.is_some();
                let with_color = if had_color {
                    Some(
                        write_tg_as(&grid, block_log2, PACK_LAYOUT)
                            .with_context(what)?
                            .len(),
                    )
                } else {
                    None
                };
                strip_colors(&mut grid);
                let full = write_tg_as(&grid, block_log2, PACK_LAYOUT).with_context(what)?;
                let kept = resolvable_depth(
                    &cameras,
                    &l.placement,
                    l.bounds,
                    grid.side,
                    rho,
                    asked,
                    min_cell_px,
                );
                let data = if kept < asked {
                    write_tg_as(&truncate(&grid, kept), block_log2, PACK_LAYOUT)
                        .with_context(what)?
                } else {
                    full.clone()
                };
                let samples = grid.levels[..=usize::from(kept)]
                    .iter()
                    .map(|l| l.attrs.len() as u64)
                    .sum();
                let savings = Savings {
                    levels: (full.len() - data.len()) as u32,
                    color: with_color.map_or(0, |w| (w - full.len()) as u32),
                    material_bits: 0,
                };
                (data, asked, kept, savings, samples)
            }
            (None, Some(bytes)) => {
                let g = TriGrid::open(bytes, Verify::Structure)
                    .map_err(|e| anyhow::anyhow!("{}: {e}", what()))?;
                let d = g.header().depth;
                (bytes.clone(), d, d, Savings::default(), g.total_samples())
            }
            (None, None) => {
                let Some(bytes) = &l.qs else {
                    unreachable!("a source is a mesh or a file")
                };
                let q = QSplat::open(bytes).map_err(|e| anyhow::anyhow!("{}: {e}", what()))?;
                let c = q.counts();
                let d = c.max_depth;
                let samples = c.leaves + c.interior + u64::from(c.trees);
                (bytes.clone(), d, d, Savings::default(), samples)
            }
        };
        reports.push(ObjectReport {
            name: o.name.clone(),
            depth_asked: asked,
            depth_kept: kept,
            samples,
            file_bytes: data.len(),
            saved_levels: savings.levels,
            saved_color: savings.color,
            bake_s: t.elapsed().as_secs_f64(),
        });
        pack_objects.push(PackObject {
            name: o.name.clone(),
            kind,
            data,
            placement: l.placement,
            slots: object_slots[i].clone(),
            // QSplat has no shadow code: a .qs object casts nothing.
            casts_shadows: o.casts_shadows && kind == Kind::TriGrid,
            ground: matches!(scene.sources[i], Source::Ground(_)),
            in_bounds: o.in_bounds,
            depth_asked: asked,
            depth_kept: kept,
            savings,
        });
    }
    let contents = PackContents {
        objects: pack_objects,
        materials: slot_keys
            .iter()
            .zip(&slot_materials)
            .map(|((n, _), m)| (n.clone(), *m))
            .collect(),
        views: scene.views(),
        path: f
            .path
            .iter()
            .map(|p| (p.t, View::new(p.az, p.el, p.dist)))
            .collect(),
        light_az_el: (f.light.az, f.light.el),
        shadows: f.shadows.mode,
        shadow_map_size: f.shadows.map_size,
        fov_deg: f.fov,
        min_cell_px: if cameras.is_empty() { 0.0 } else { min_cell_px },
        sphere,
        align_log2: block_log2,
    };
    let bytes =
        write_pack(&contents).map_err(|e| anyhow::anyhow!("{}: {e}", scene.path.display()))?;
    // The reader is the check of what was written.
    let pack = Pack::open(&bytes).map_err(|e| {
        anyhow::anyhow!(
            "{}: the baked pack fails its own check: {e}",
            scene.path.display()
        )
    })?;
    CoreScene::open(pack, Verify::Full).map_err(|e| {
        anyhow::anyhow!(
            "{}: the baked pack fails its own check: {e}",
            scene.path.display()
        )
    })?;
    Ok(BakedScene {
        bytes,
        objects: reports,
        slot_materials,
        object_slots,
    })
}

/// Every mesh object placed in the world as one mesh whose material indices are slots (the f64
/// reference renderer's input), with the slots' materials. With `casters_only`, the objects that
/// cast shadows (`casts_shadows`, the default) and no others: the mesh shadow rays are cast against.
///
/// # Errors
/// When an object is a `.tg` file (there is no mesh to draw).
pub fn world_mesh(
    scene: &SceneSpec,
    objects: &[LoadedObject],
    baked: &BakedScene,
    casters_only: bool,
) -> Result<(TriMesh, Vec<Material>)> {
    let mut out = TriMesh {
        materials: Some(Vec::new()),
        ..TriMesh::default()
    };
    for ((o, l), slots) in scene
        .file
        .objects
        .iter()
        .zip(objects)
        .zip(&baked.object_slots)
        .filter(|((o, _), _)| o.casts_shadows || !casters_only)
    {
        let Some(mesh) = &l.mesh else {
            bail!(
                "{}: object {:?} is a baked .tg or .qs file: no mesh for the reference renderer",
                scene.path.display(),
                o.name
            );
        };
        let first = out.positions.len() as u32;
        out.positions
            .extend(mesh.positions.iter().map(|&p| l.placement.apply(p)));
        out.triangles
            .extend(mesh.triangles.iter().map(|t| t.map(|i| i + first)));
        let mats = out.materials.as_mut().expect("set above");
        match &mesh.materials {
            Some(m) => mats.extend(
                m.iter()
                    .map(|&k| slots[usize::from(k).min(slots.len() - 1)]),
            ),
            None => mats.extend(std::iter::repeat_n(slots[0], mesh.triangles.len())),
        }
    }
    Ok((out, baked.slot_materials.clone()))
}

/// Reads, checks and bakes `path`.
///
/// # Errors
/// As [`SceneSpec::load`] and [`bake_scene`].
pub fn bake_path(path: &Path, overrides: &BakeOverrides) -> Result<BakedScene> {
    bake_scene(&SceneSpec::load(path)?, overrides)
}
