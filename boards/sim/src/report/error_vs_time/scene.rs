//! A scene file (`.toml`) as a subject of the report: its named views, the f64 reference renderer of
//! every placed mesh of the scene (with exact ray-cast shadows from the objects that cast them), and
//! the scene baked as a tri-grid pack (ρ = 3, what `pocketsplat bake` writes and the firmware draws)
//! and as an octree pack (ρ = 2, each object at the nearest resolution), and the brute force over
//! every leaf of the tri-grid pack.
//!
//! A `.pack` alone cannot be a subject: it holds the baked grids, not the meshes the reference is
//! drawn from.

use anyhow::{anyhow, Context, Result};
use pocketsplat_core::bake::TriMesh;
use pocketsplat_core::camera::{Camera, View};
use pocketsplat_core::render::RenderOptions;
use pocketsplat_core::scene::{Pack, Scene as PackScene, ShadowMode};
use pocketsplat_core::shade::Material;
use pocketsplat_core::tg::Verify;

use super::brute::SceneCloud;
use super::sweep::{FrameConfig, Method, RefShadows, Reference, Subject};
use crate::bvh::Bvh;
use crate::reference::{render_reference_shadowed, ShadowLight, ShadowRays};
use crate::render::{FrameBuffers, FrameReport};
use crate::scene::bake::{bake_loaded, load_objects, world_mesh, BakeOverrides, BakedScene};
use crate::scene::render::{render_pack_from, scene_table, PackSettings, SceneTable};
use crate::scene::SceneSpec;

/// Cutoffs of the full sweep of a scene, pixels: finer steps than a mesh's between 1 and 8 px,
/// where a scene's frame cost falls fastest, and every cutoff the firmware renders a pack at.
pub const SCENE_CUTOFFS_PX: [f32; 8] = [0.5, 1.0, 2.0, 3.0, 4.0, 6.0, 8.0, 16.0];
/// Deepest object of `--quick` (of the scene's ρ).
pub const QUICK_SCENE_DEPTH: u8 = 4;

/// A scene's bakes and the meshes of its reference, owned here so the methods can borrow them.
pub struct SceneBakes {
    /// The scene as written (ρ = 3 unless its `[bake]` says otherwise).
    pub trigrid: BakedScene,
    /// The scene as an octree (ρ = 2).
    pub octree: BakedScene,
    /// Every object placed, material indices being slots.
    pub world: TriMesh,
    /// The slots' materials.
    pub materials: Vec<Material>,
    /// The objects that cast shadows, placed: what shadow rays are cast against.
    pub casters: Bvh,
    /// The named views.
    pub views: Vec<(String, View)>,
}

impl SceneBakes {
    /// Loads every object of `scene` once and bakes it both ways; `max_depth` caps the objects'
    /// depths (`--quick`).
    ///
    /// # Errors
    /// Load and bake errors, naming the scene and object; an object given as a `.tg` file (no mesh
    /// for the reference).
    pub fn bake(scene: &SceneSpec, max_depth: Option<u8>) -> Result<Self> {
        let objects = load_objects(scene)?;
        let over = |rho| BakeOverrides {
            rho: Some(rho),
            max_depth,
            ..BakeOverrides::default()
        };
        let trigrid = bake_loaded(scene, &objects, &over(scene.file.bake.rho))?;
        let octree = bake_loaded(scene, &objects, &over(2))?;
        let (world, materials) = world_mesh(scene, &objects, &trigrid, false)?;
        let (casters, _) = world_mesh(scene, &objects, &trigrid, true)?;
        Ok(Self {
            trigrid,
            octree,
            world,
            materials,
            casters: Bvh::new(&casters),
            views: scene.views(),
        })
    }
}

/// A pack drawn by the core's scene renderer (the firmware's), with a shading table kept across
/// frames.
pub struct PackMethod<'a> {
    name: &'static str,
    scene: PackScene<'a>,
    crc: u32,
    table: Box<SceneTable>,
}

impl<'a> PackMethod<'a> {
    /// Opens a baked pack.
    ///
    /// # Errors
    /// When the pack or an object's file is invalid.
    pub fn new(name: &'static str, bytes: &'a [u8]) -> Result<Self> {
        let pack = Pack::open(bytes).map_err(|e| anyhow!("baked {name} pack: {e}"))?;
        Ok(Self {
            name,
            scene: PackScene::open(pack, Verify::Full)
                .map_err(|e| anyhow!("baked {name} pack: {e}"))?,
            crc: pocketsplat_core::crc::crc32(bytes),
            table: scene_table(),
        })
    }

    /// The open scene.
    pub fn scene(&self) -> &PackScene<'a> {
        &self.scene
    }
}

/// The camera and options of a frame of `scene`: the pack's light and field of view, the frame's
/// knobs.
fn frame(scene: &PackScene<'_>, view: View, cfg: &FrameConfig) -> (Camera, RenderOptions) {
    let s = PackSettings {
        cutoff_px: cfg.cutoff_px,
        kernel: cfg.kernel,
        shadows: Some(cfg.shadows),
        ..PackSettings::new(view)
    };
    (s.camera(scene, [0.0; 3]), s.options(scene))
}

impl Method for PackMethod<'_> {
    fn name(&self) -> &str {
        self.name
    }
    fn detail(&self) -> String {
        let p = self.scene.pack();
        let (mut leaves, mut depth) = (0u64, 0u8);
        let mut rho = 0;
        for i in 0..p.object_count() {
            if let Some(g) = self.scene.grid(i) {
                leaves += u64::from(g.leaf_samples());
                depth = depth.max(g.header().depth);
                rho = g.header().rho;
            }
        }
        format!(
            "ρ={rho} pack of {} objects, depth ≤ {depth}, {leaves} leaves, file CRC {:#010x}",
            p.object_count(),
            self.crc
        )
    }
    fn uses_cutoff(&self) -> bool {
        true
    }
    fn supports(&self, _: ShadowMode) -> bool {
        true
    }
    fn file_crc(&self) -> Option<u32> {
        Some(self.crc)
    }
    fn render(
        &mut self,
        view: View,
        cfg: &FrameConfig,
        out: &mut FrameBuffers,
    ) -> Result<FrameReport> {
        let (cam, opts) = frame(&self.scene, view, cfg);
        Ok(render_pack_from(
            &self.scene,
            &cam,
            &opts,
            None,
            &mut self.table,
            out,
            |_, _| {},
        )?
        .report())
    }
}

/// The brute-force baseline over every leaf of the tri-grid pack ([`SceneCloud`]).
pub struct BruteSceneMethod<'a> {
    scene: PackScene<'a>,
    cloud: SceneCloud,
    table: Box<SceneTable>,
}

impl<'a> BruteSceneMethod<'a> {
    /// The leaves of every object of `pack`'s scene, placed.
    pub fn new(pack: &PackMethod<'a>) -> Self {
        Self {
            cloud: SceneCloud::from_scene(pack.scene()),
            scene: pack.scene().clone(),
            table: scene_table(),
        }
    }
}

impl Method for BruteSceneMethod<'_> {
    fn name(&self) -> &str {
        "brute"
    }
    fn detail(&self) -> String {
        format!(
            "every leaf of the tri-grid pack's {} objects, {} points",
            self.cloud.objects.len(),
            self.cloud.len()
        )
    }
    fn uses_cutoff(&self) -> bool {
        false
    }
    fn supports(&self, shadows: ShadowMode) -> bool {
        shadows == ShadowMode::Off
    }
    fn render(
        &mut self,
        view: View,
        cfg: &FrameConfig,
        out: &mut FrameBuffers,
    ) -> Result<FrameReport> {
        let (cam, opts) = frame(&self.scene, view, cfg);
        Ok(self
            .cloud
            .render(&self.scene, &cam, &opts, &mut self.table, out))
    }
}

/// A scene as a subject: its named views, the reference of its meshes, the tri-grid and octree
/// packs and the brute force over the tri-grid pack's leaves. `name` titles the outputs.
///
/// # Errors
/// When a baked pack does not open.
pub fn scene_subject<'a>(name: &str, bakes: &'a SceneBakes) -> Result<Subject<'a>> {
    let trigrid = PackMethod::new("trigrid", &bakes.trigrid.bytes)?;
    let octree = PackMethod::new("octree", &bakes.octree.bytes)?;
    let brute = BruteSceneMethod::new(&trigrid);
    // The reference sees what the pack's frames see: its sphere, field of view and light.
    let frame = PackSettings::new(View::new(0.0, 0.0, 1.0));
    let light = trigrid.scene().options().light_dir;
    let shadows = trigrid.scene().pack().shadows();
    let views: Vec<(String, View)> = bakes.views.clone();
    // The camera needs the open scene; keep one for the reference closure.
    let scene = trigrid.scene().clone();
    Ok(Subject {
        name: name.to_owned(),
        views,
        shadows,
        reference: Box::new(move |view, with_shadows| {
            let cam = PackSettings { view, ..frame }.camera(&scene, [0.0; 3]);
            let rays = ShadowRays {
                bvh: &bakes.casters,
                light: ShadowLight::Directional(light),
            };
            let image = render_reference_shadowed(
                &bakes.world,
                &cam,
                &bakes.materials,
                light,
                with_shadows.then_some(&rays),
            );
            Ok(Reference {
                image,
                shadows: if with_shadows {
                    RefShadows::RayCast
                } else {
                    RefShadows::None
                },
            })
        }),
        methods: vec![Box::new(trigrid), Box::new(octree), Box::new(brute)],
    })
}

/// Reads and bakes a scene file for the report.
///
/// # Errors
/// As [`SceneSpec::load`] and [`SceneBakes::bake`], naming the file.
pub fn bake_scene_file(path: &std::path::Path, max_depth: Option<u8>) -> Result<SceneBakes> {
    let scene = SceneSpec::load(path)?;
    SceneBakes::bake(&scene, max_depth).with_context(|| format!("{}: bake", path.display()))
}
