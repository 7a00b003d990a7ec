//! Scene files (TOML): objects, their transforms and materials, a light, shadows, views and a camera
//! path, baked into one scene pack (`core/src/scene/PACK.md`) by `pocketsplat bake scene.toml -o
//! scene.pack`.
//!
//! ```toml
//! fov = 45.0                                # degrees (default 45)
//! models = "../../../../shared/models"      # where `model = ...` looks, relative to this file
//!
//! [light]
//! az = -40.0                                # degrees, the views' convention
//! el = 60.0
//!
//! [shadows]
//! mode = "one-pass"                         # off | one-pass | two-pass
//! map_size = 512                            # texels per side
//!
//! [bake]
//! rho = 3                                   # 3 tri-grid, 2 octree
//! block_size = 4096
//! min_cell_px = 0.5                         # drop levels whose cells are smaller in every view; 0 keeps all
//!
//! [materials.clay]
//! color = [0.8, 0.7, 0.6]                   # linear 0..=1
//! ambient = 0.15
//! diffuse = 0.8
//! specular = 0.25
//! exponent = 20.0
//!
//! [[objects]]
//! name = "bunny"
//! model = "bun_zipper.ply.gz"               # or mesh = "path/relative/to/this/file.ply", or
//!                                           # file = "baked.tg" or "baked.qs", or tree = {..}, or ground = {..}
//! depth = 5                                 # subdivisions to bake (levels the views cannot resolve are dropped)
//! material = "clay"                         # or materials = ["a", "b"] for a mesh with material indices
//! scale = 4.0                               # uniform; or height = 0.6 (world height of its box)
//! rotate = { yaw = 30.0, pitch = 0.0, roll = 0.0 }   # degrees; or { axis = [0, 1, 0], angle = 30 }
//! translate = [0.0, 0.0, 0.0]
//! anchor = "base"                           # what `translate` places: origin (default), base, center
//!
//! [[views]]
//! name = "std"
//! az = 30.0
//! el = 20.0
//! dist = 2.5                                # radii of the scene's bounding sphere
//!
//! [[path]]                                  # camera path keyframes (optional)
//! t = 0.0
//! az = 0.0
//! el = 20.0
//! dist = 2.5
//! ```
//!
//! **Baked files.** `file` names a `.tg` or a `.qs` (QSplat) file, told apart by its magic (or,
//! failing that, its `.qs` extension), packed as it is (kind 1 or 2, `PACK.md`). A `.qs` object has
//! one material (`material = "..."`), takes no `depth`, and casts no shadows (QSplat has no shadow
//! code; it is drawn unshadowed).
//!
//! **Where files are found.** `mesh` and `file` paths are relative to the scene file (or absolute).
//! `model` names a file in the models folder: `$POCKETSPLAT_MODELS` when set, else the scene's
//! `models` key (relative to the scene file); without either it is an error that says so.
//!
//! Angles: `yaw` turns about +Y (from +Z towards +X, as view azimuths do), `pitch` about +X, `roll`
//! about +Z, applied roll, then pitch, then yaw (`R = yaw · pitch · roll`).

pub mod bake;
pub mod ground;
pub mod render;
pub mod tree;

#[cfg(test)]
mod qs_tests;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{bail, Result};
use pocketsplat_core::camera::View;
use pocketsplat_core::scene::{ShadowMode, MAX_OBJECTS, MAX_SLOTS, NAME_BYTES};
use pocketsplat_core::shade::Material;
use serde::Deserialize;

/// A scene file as written.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    /// Vertical field of view, degrees.
    #[serde(default = "default_fov")]
    pub fov: f64,
    /// Folder for `model = ...` objects, relative to the scene file (`$POCKETSPLAT_MODELS` wins).
    pub models: Option<String>,
    /// The directional light.
    #[serde(default)]
    pub light: LightSpec,
    /// Shadows.
    #[serde(default)]
    pub shadows: ShadowSpec,
    /// Bake settings shared by every object.
    #[serde(default)]
    pub bake: BakeSpec,
    /// Named materials.
    #[serde(default)]
    pub materials: BTreeMap<String, MaterialSpec>,
    /// The objects.
    pub objects: Vec<ObjectSpec>,
    /// Named views.
    #[serde(default)]
    pub views: Vec<ViewSpec>,
    /// Camera path keyframes.
    #[serde(default)]
    pub path: Vec<PathKey>,
}

fn default_fov() -> f64 {
    pocketsplat_core::camera::DEFAULT_FOV_DEG
}

/// `[light]`.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightSpec {
    /// Azimuth, degrees.
    pub az: f64,
    /// Elevation, degrees.
    pub el: f64,
}

impl Default for LightSpec {
    fn default() -> Self {
        let (az, el) = pocketsplat_core::shade::DEFAULT_LIGHT_AZ_EL;
        Self { az, el }
    }
}

/// `[shadows]`.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShadowSpec {
    /// off, one-pass or two-pass.
    #[serde(default, deserialize_with = "shadow_mode")]
    pub mode: ShadowMode,
    /// Shadow map side, texels.
    #[serde(default = "default_map_size")]
    pub map_size: usize,
}

impl Default for ShadowSpec {
    fn default() -> Self {
        Self {
            mode: ShadowMode::Off,
            map_size: default_map_size(),
        }
    }
}

fn default_map_size() -> usize {
    crate::render::DEFAULT_SHADOW_MAP_SIZE
}

/// A shadow mode by its name in a scene file (`off`, `one-pass`, `two-pass`: [`ShadowMode::name`]).
fn shadow_mode<'de, D: serde::Deserializer<'de>>(d: D) -> Result<ShadowMode, D::Error> {
    let name = String::deserialize(d)?;
    ShadowMode::from_name(&name).ok_or_else(|| {
        serde::de::Error::custom(format!(
            "unknown shadow mode `{name}`, expected `off`, `one-pass` or `two-pass`"
        ))
    })
}

/// `[bake]`.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BakeSpec {
    /// ρ: 3 (tri-grid) or 2 (octree).
    #[serde(default = "default_rho")]
    pub rho: u8,
    /// Block size of each object's `.tg` file, bytes.
    #[serde(default = "default_block")]
    pub block_size: u32,
    /// Levels whose cells project smaller than this (pixels) in every view are left out; 0 keeps
    /// every level.
    #[serde(default = "default_min_cell")]
    pub min_cell_px: f64,
}

impl Default for BakeSpec {
    fn default() -> Self {
        Self {
            rho: default_rho(),
            block_size: default_block(),
            min_cell_px: default_min_cell(),
        }
    }
}

fn default_rho() -> u8 {
    3
}
fn default_block() -> u32 {
    4096
}
fn default_min_cell() -> f64 {
    0.5
}

/// `[materials.NAME]`.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialSpec {
    /// Linear RGB, 0..=1.
    pub color: [f32; 3],
    /// Ambient weight.
    #[serde(default = "default_ambient")]
    pub ambient: f32,
    /// Diffuse weight.
    #[serde(default = "default_diffuse")]
    pub diffuse: f32,
    /// Specular weight.
    #[serde(default = "default_specular")]
    pub specular: f32,
    /// Specular exponent.
    #[serde(default = "default_exponent")]
    pub exponent: f32,
}

fn default_ambient() -> f32 {
    pocketsplat_core::shade::DEFAULT_MATERIAL.ambient
}
fn default_diffuse() -> f32 {
    pocketsplat_core::shade::DEFAULT_MATERIAL.diffuse
}
fn default_specular() -> f32 {
    pocketsplat_core::shade::DEFAULT_MATERIAL.specular
}
fn default_exponent() -> f32 {
    pocketsplat_core::shade::DEFAULT_MATERIAL.shininess
}

impl MaterialSpec {
    /// The core material.
    pub fn material(&self) -> Material {
        Material {
            color: self.color,
            ambient: self.ambient,
            diffuse: self.diffuse,
            specular: self.specular,
            shininess: self.exponent,
        }
    }
}

/// `rotate = {...}`: yaw/pitch/roll or axis/angle, degrees.
#[derive(Clone, Copy, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RotateSpec {
    /// About +Y.
    #[serde(default)]
    pub yaw: f64,
    /// About +X.
    #[serde(default)]
    pub pitch: f64,
    /// About +Z.
    #[serde(default)]
    pub roll: f64,
    /// An axis (with `angle`), instead of yaw/pitch/roll.
    pub axis: Option<[f64; 3]>,
    /// Degrees about `axis`.
    pub angle: Option<f64>,
}

/// What `translate` places.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Anchor {
    /// The model's origin.
    #[default]
    Origin,
    /// The bottom centre of the placed model's bounding box (stand it on the ground).
    Base,
    /// The centre of the placed model's bounding box.
    Center,
}

/// `[[objects]]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectSpec {
    /// Name (at most 16 bytes).
    pub name: String,
    /// A mesh file, relative to the scene file.
    pub mesh: Option<String>,
    /// A mesh file in the models folder.
    pub model: Option<String>,
    /// An already baked `.tg` or `.qs` file, relative to the scene file.
    pub file: Option<String>,
    /// A generated tree.
    pub tree: Option<tree::TreeSpec>,
    /// A generated ground plane.
    pub ground: Option<ground::GroundSpec>,
    /// Subdivisions to bake (meshes, trees and grounds).
    pub depth: Option<u8>,
    /// The material of every sample.
    pub material: Option<String>,
    /// The material of each material index of the mesh.
    pub materials: Option<Vec<String>>,
    /// Uniform scale.
    pub scale: Option<f64>,
    /// World height of the placed bounding box (instead of `scale`).
    pub height: Option<f64>,
    /// Rotation.
    #[serde(default)]
    pub rotate: RotateSpec,
    /// Translation.
    #[serde(default)]
    pub translate: [f64; 3],
    /// What `translate` places.
    #[serde(default)]
    pub anchor: Anchor,
    /// Whether it casts shadows (default true).
    #[serde(default = "yes")]
    pub casts_shadows: bool,
    /// Whether it counts towards the sphere the views orbit (default true).
    #[serde(default = "yes")]
    pub in_bounds: bool,
}

fn yes() -> bool {
    true
}

/// `[[views]]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ViewSpec {
    /// Name (at most 16 bytes, unique).
    pub name: String,
    /// Azimuth, degrees.
    pub az: f64,
    /// Elevation, degrees.
    pub el: f64,
    /// Distance, scene-sphere radii.
    pub dist: f64,
}

/// `[[path]]`.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PathKey {
    /// Seconds.
    pub t: f64,
    /// Azimuth, degrees.
    pub az: f64,
    /// Elevation, degrees.
    pub el: f64,
    /// Distance, scene-sphere radii.
    pub dist: f64,
}

/// Where an object's samples come from, resolved.
#[derive(Clone, Debug, PartialEq)]
pub enum Source {
    /// A mesh file to bake.
    Mesh(PathBuf),
    /// A `.tg` or `.qs` file to pack as it is.
    File(PathBuf),
    /// A generated tree to bake.
    Tree(tree::TreeSpec),
    /// A generated ground plane to bake.
    Ground(ground::GroundSpec),
}

/// A scene file read and checked: every reference resolved, every number in range.
#[derive(Clone, Debug)]
pub struct SceneSpec {
    /// The file it came from.
    pub path: PathBuf,
    /// What it says.
    pub file: SceneFile,
    /// Each object's source.
    pub sources: Vec<Source>,
    /// Each object's material names, one per material index.
    pub object_materials: Vec<Vec<String>>,
}

/// Rotation matrix (row-major) of a rotation spec.
pub fn rotation(r: &RotateSpec) -> Result<[[f64; 3]; 3]> {
    if let Some(axis) = r.axis {
        let angle = r.angle.unwrap_or(0.0);
        let n = libm::sqrt(axis.iter().map(|a| a * a).sum());
        if !(n > 0.0 && n.is_finite() && angle.is_finite()) {
            bail!("rotate.axis {axis:?}: must be a non-zero finite vector (with a finite angle)");
        }
        let [x, y, z] = axis.map(|a| a / n);
        let (s, c) = (libm::sin(angle.to_radians()), libm::cos(angle.to_radians()));
        let t = 1.0 - c;
        return Ok([
            [t * x * x + c, t * x * y - s * z, t * x * z + s * y],
            [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
            [t * x * z - s * y, t * y * z + s * x, t * z * z + c],
        ]);
    }
    if r.angle.is_some() {
        bail!("rotate.angle needs rotate.axis");
    }
    if ![r.yaw, r.pitch, r.roll].iter().all(|a| a.is_finite()) {
        bail!("rotate: angles must be finite");
    }
    let (sy, cy) = (libm::sin(r.yaw.to_radians()), libm::cos(r.yaw.to_radians()));
    let (sp, cp) = (
        libm::sin(r.pitch.to_radians()),
        libm::cos(r.pitch.to_radians()),
    );
    let (sr, cr) = (
        libm::sin(r.roll.to_radians()),
        libm::cos(r.roll.to_radians()),
    );
    // Yaw about +Y takes +Z towards +X; pitch about +X; roll about +Z.
    let yaw = [[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]];
    let pitch = [[1.0, 0.0, 0.0], [0.0, cp, -sp], [0.0, sp, cp]];
    let roll = [[cr, -sr, 0.0], [sr, cr, 0.0], [0.0, 0.0, 1.0]];
    Ok(mul(&yaw, &mul(&pitch, &roll)))
}

fn mul(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}

/// The models folder for `model = ...`: `$POCKETSPLAT_MODELS`, else the scene's `models` key
/// relative to the scene file.
fn models_dir(scene_dir: &Path, models: Option<&str>) -> Option<PathBuf> {
    if let Some(dir) = std::env::var_os("POCKETSPLAT_MODELS") {
        return Some(PathBuf::from(dir));
    }
    models.map(|m| scene_dir.join(m))
}

impl SceneSpec {
    /// Reads and checks a scene file.
    ///
    /// # Errors
    /// TOML syntax and schema errors (with line and column), and every semantic problem, naming
    /// the file and the object, material or view.
    pub fn load(path: &Path) -> Result<Self> {
        let text = crate::fsutil::read_scene_text(path)?;
        Self::parse(path, &text)
    }

    /// Checks a scene file's text; `path` names it and anchors its relative paths.
    ///
    /// # Errors
    /// As [`SceneSpec::load`].
    pub fn parse(path: &Path, text: &str) -> Result<Self> {
        let file: SceneFile =
            toml::from_str(text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
        let dir = path.parent().unwrap_or(Path::new(".")).to_path_buf();
        let at = |what: String| format!("{}: {what}", path.display());
        if !(file.fov > 0.0 && file.fov < 180.0) {
            bail!(at(format!(
                "fov {}: must be between 0 and 180 degrees",
                file.fov
            )));
        }
        if !(file.light.az.is_finite() && file.light.el.is_finite()) {
            bail!(at("light: az and el must be finite".into()));
        }
        let s = file.shadows;
        if s.mode != ShadowMode::Off
            && !(pocketsplat_core::scene::MIN_MAP_SIZE..=pocketsplat_core::scene::MAX_MAP_SIZE)
                .contains(&s.map_size)
        {
            bail!(at(format!(
                "shadows.map_size {}: must be {}..={}",
                s.map_size,
                pocketsplat_core::scene::MIN_MAP_SIZE,
                pocketsplat_core::scene::MAX_MAP_SIZE
            )));
        }
        let b = file.bake;
        if !(2..=3).contains(&b.rho) {
            bail!(at(format!(
                "bake.rho {}: must be 2 (octree) or 3 (tri-grid)",
                b.rho
            )));
        }
        if !b.block_size.is_power_of_two() || !(512..=65536).contains(&b.block_size) {
            bail!(at(format!(
                "bake.block_size {}: must be a power of two from 512 to 65536",
                b.block_size
            )));
        }
        if !(b.min_cell_px >= 0.0 && b.min_cell_px.is_finite()) {
            bail!(at(format!(
                "bake.min_cell_px {}: must be 0 or more pixels",
                b.min_cell_px
            )));
        }
        for (name, m) in &file.materials {
            let ok = m.color.iter().all(|c| (0.0..=1.0).contains(c))
                && [m.ambient, m.diffuse, m.specular]
                    .iter()
                    .all(|w| (0.0..=4.0).contains(w))
                && (0.0..=1024.0).contains(&m.exponent);
            if !ok {
                bail!(at(format!(
                    "material {name:?}: colour must be 0..=1, weights 0..=4, exponent 0..=1024"
                )));
            }
            if name.len() > NAME_BYTES {
                bail!(at(format!(
                    "material {name:?}: names are at most {NAME_BYTES} bytes"
                )));
            }
        }
        if file.objects.is_empty() || file.objects.len() > MAX_OBJECTS {
            bail!(at(format!(
                "{} objects: a scene has 1..={MAX_OBJECTS}",
                file.objects.len()
            )));
        }
        let mut sources = Vec::new();
        let mut object_materials = Vec::new();
        for (i, o) in file.objects.iter().enumerate() {
            let at = |what: String| format!("{}: object {:?}: {what}", path.display(), o.name);
            if o.name.len() > NAME_BYTES || o.name.contains('\0') {
                bail!(at(format!("names are at most {NAME_BYTES} bytes")));
            }
            if file.objects[..i].iter().any(|p| p.name == o.name) {
                bail!(at("two objects have this name".into()));
            }
            let given = [
                o.mesh.is_some(),
                o.model.is_some(),
                o.file.is_some(),
                o.tree.is_some(),
                o.ground.is_some(),
            ];
            if given.iter().filter(|&&g| g).count() != 1 {
                bail!(at(
                    "give exactly one of mesh, model, file, tree, ground".into()
                ));
            }
            let source = if let Some(m) = &o.mesh {
                Source::Mesh(dir.join(m))
            } else if let Some(m) = &o.model {
                let Some(models) = models_dir(&dir, file.models.as_deref()) else {
                    bail!(at(format!(
                        "model {m:?}: set POCKETSPLAT_MODELS or the scene's `models` folder"
                    )));
                };
                Source::Mesh(models.join(m))
            } else if let Some(f) = &o.file {
                Source::File(dir.join(f))
            } else if let Some(t) = &o.tree {
                t.check()
                    .map_err(|e| anyhow::anyhow!(at(format!("tree: {e}"))))?;
                Source::Tree(t.clone())
            } else if let Some(g) = &o.ground {
                g.check()
                    .map_err(|e| anyhow::anyhow!(at(format!("ground: {e}"))))?;
                Source::Ground(*g)
            } else {
                unreachable!("one source is given")
            };
            match (&source, o.depth) {
                (Source::File(_), Some(_)) => {
                    bail!(at(
                        "depth applies to what is baked, not to a .tg or .qs file".into()
                    ))
                }
                (Source::File(_), None) => {}
                (_, None) => bail!(at("depth is missing (subdivisions to bake)".into())),
                (_, Some(d)) if d > pocketsplat_core::tg::MAX_DEPTH => bail!(at(format!(
                    "depth {d}: at most {}",
                    pocketsplat_core::tg::MAX_DEPTH
                ))),
                _ => {}
            }
            let names = match (&o.material, &o.materials) {
                (Some(m), None) => vec![m.clone()],
                (None, Some(ms)) if !ms.is_empty() && ms.len() <= MAX_SLOTS => ms.clone(),
                (None, Some(_)) => bail!(at(format!("materials: 1..={MAX_SLOTS} names"))),
                (None, None) => bail!(at("material (or materials) is missing".into())),
                (Some(_), Some(_)) => bail!(at("give material or materials, not both".into())),
            };
            for m in &names {
                if !file.materials.contains_key(m) {
                    bail!(at(format!(
                        "material {m:?} is not defined under [materials]"
                    )));
                }
            }
            match (o.scale, o.height) {
                (Some(_), Some(_)) => bail!(at("give scale or height, not both".into())),
                (Some(s), None) | (None, Some(s)) if !(s > 0.0 && s.is_finite()) => {
                    bail!(at(format!("scale/height {s}: must be positive")))
                }
                _ => {}
            }
            if !o.translate.iter().all(|t| t.is_finite() && t.abs() < 1e9) {
                bail!(at("translate: must be finite (and below 1e9)".into()));
            }
            rotation(&o.rotate).map_err(|e| anyhow::anyhow!(at(e.to_string())))?;
            sources.push(source);
            object_materials.push(names);
        }
        for (i, v) in file.views.iter().enumerate() {
            if v.name.is_empty() || v.name.len() > NAME_BYTES || v.name.contains('\0') {
                bail!(at(format!(
                    "view {:?}: names are 1..={NAME_BYTES} bytes",
                    v.name
                )));
            }
            if file.views[..i].iter().any(|w| w.name == v.name) {
                bail!(at(format!("view {:?}: two views have this name", v.name)));
            }
            if !(v.az.is_finite() && v.el.is_finite() && v.dist > 0.0 && v.dist < 1e9) {
                bail!(at(format!(
                    "view {:?}: az and el must be finite, dist positive",
                    v.name
                )));
            }
        }
        if file.views.len() > pocketsplat_core::scene::MAX_VIEWS {
            bail!(at(format!(
                "{} views: at most {}",
                file.views.len(),
                pocketsplat_core::scene::MAX_VIEWS
            )));
        }
        if file.path.len() > pocketsplat_core::scene::MAX_PATH_KEYS {
            bail!(at(format!(
                "{} path keyframes: at most {}",
                file.path.len(),
                pocketsplat_core::scene::MAX_PATH_KEYS
            )));
        }
        let mut last = -1.0;
        for (k, p) in file.path.iter().enumerate() {
            if !(p.t >= 0.0 && p.t > last && p.t < 1e9) {
                bail!(at(format!(
                    "path keyframe {k}: t must start at 0 or later and increase"
                )));
            }
            last = p.t;
            if !(p.az.is_finite() && p.el.is_finite() && p.dist > 0.0 && p.dist < 1e9) {
                bail!(at(format!(
                    "path keyframe {k}: az and el must be finite, dist positive"
                )));
            }
        }
        Ok(SceneSpec {
            path: path.to_path_buf(),
            file,
            sources,
            object_materials,
        })
    }

    /// The named views.
    pub fn views(&self) -> Vec<(String, View)> {
        self.file
            .views
            .iter()
            .map(|v| (v.name.clone(), View::new(v.az, v.el, v.dist)))
            .collect()
    }
}
