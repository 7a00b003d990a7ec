//! A scene pack with its objects' files open ([`Scene`]): validated once, each object by its own
//! reader, with the world-space boxes, camera, light space, light order and shading that a frame
//! of the scene needs; [`SceneError`] says why a pack cannot be opened or drawn.

use super::pack::Pack;
use super::{Kind, ShadowMode, MAX_OBJECTS};
use crate::camera::{self, Camera, Sphere, Vec3, View};
use crate::frame::{FrameError, RenderOptions, Shading};
#[cfg(feature = "qsplat")]
use crate::qs::{QSplat, QsError};
use crate::shade::{Material, ShadingTable};
use crate::splat::Stats;
use crate::tg::frame::DepthRange;
use crate::tg::{TgError, TriGrid, Verify};

/// Why a scene cannot be opened or drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SceneError {
    /// An object's file fails its reader's checks.
    Object {
        /// The object.
        object: u8,
        /// What its reader found.
        error: TgError,
    },
    /// An object's grid has a ρ the traversal does not draw (2 and 3 only).
    Rho {
        /// The object.
        object: u8,
        /// Its ρ.
        rho: u8,
    },
    /// An object's file carries more material indices than its record maps to slots.
    MaterialBits {
        /// The object.
        object: u8,
        /// The file's material bits.
        bits: u8,
        /// The record's material count.
        materials: u8,
    },
    /// A frame of an object cannot be set up.
    Frame {
        /// The object.
        object: u8,
        /// Why.
        error: FrameError,
    },
    /// The shading table has fewer materials than the scene has slots.
    TooFewSlots {
        /// Slots the scene needs.
        slots: u8,
        /// Materials of the table.
        table: u8,
    },
    /// The shadow-map buffer is smaller than the map the scene asks for.
    ShadowBuffer {
        /// Depths needed (side²).
        need: u32,
        /// Depths given.
        given: u32,
    },
    /// A streamed scene was given a different number of object streams than the pack has
    /// objects.
    Streams {
        /// Objects in the pack.
        objects: u8,
        /// Streams given.
        streams: u8,
    },
    /// A streamed object's stream is not of the kind its record says.
    StreamKind {
        /// The object.
        object: u8,
    },
    /// An object is a QSplat file but this build has no QSplat reader (feature `qsplat`).
    NoQSplat {
        /// The object.
        object: u8,
    },
    /// An object's QSplat file fails its reader's checks.
    #[cfg(feature = "qsplat")]
    QSplatObject {
        /// The object.
        object: u8,
        /// What its reader found.
        error: QsError,
    },
}

impl core::error::Error for SceneError {}

impl core::fmt::Display for SceneError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            SceneError::Object { object, error } => write!(f, "object {object}: {error}"),
            SceneError::Rho { object, rho } => write!(
                f,
                "object {object}: a rho {rho} grid cannot be drawn (2 and 3 only)"
            ),
            SceneError::MaterialBits {
                object,
                bits,
                materials,
            } => write!(
                f,
                "object {object}: its file has {bits} material bits but the pack maps {materials} \
                 material(s)"
            ),
            SceneError::Frame { object, error } => write!(f, "object {object}: {error}"),
            SceneError::TooFewSlots { slots, table } => write!(
                f,
                "the scene has {slots} material slots but the shading table only {table}"
            ),
            SceneError::ShadowBuffer { need, given } => write!(
                f,
                "the shadow map needs {need} depths but the buffer holds {given}"
            ),
            SceneError::Streams { objects, streams } => write!(
                f,
                "the pack has {objects} objects but {streams} streams were given"
            ),
            SceneError::StreamKind { object } => write!(
                f,
                "object {object}: its stream is not of the kind its record says"
            ),
            SceneError::NoQSplat { object } => write!(
                f,
                "object {object} is a QSplat (.qs) file but this build has no QSplat reader \
                 (feature `qsplat`)"
            ),
            #[cfg(feature = "qsplat")]
            SceneError::QSplatObject { object, error } => write!(f, "object {object}: {error}"),
        }
    }
}

/// A pack whose objects' files are open: what a frame of the scene needs, validated once.
#[derive(Clone, Debug)]
pub struct Scene<'a> {
    pack: Pack<'a>,
    grids: [Option<TriGrid<'a>>; MAX_OBJECTS],
    /// The QSplat objects' opened files.
    #[cfg(feature = "qsplat")]
    qsplats: [Option<QSplat<'a>>; MAX_OBJECTS],
    /// World-space bounding box of each object (its file's box, placed).
    bounds: [[Vec3; 2]; MAX_OBJECTS],
}

/// What a frame of a scene did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SceneStats {
    /// All objects' counts added (`max_level` the deepest).
    pub total: Stats,
    /// Each object's counts (its view pass).
    pub objects: [Stats; MAX_OBJECTS],
    /// Nodes visited filling the shadow map before the view (two-pass).
    pub shadow_fill_nodes: u32,
    /// The shadows actually drawn (`Off` when the build has no `shadows` feature).
    pub shadows: ShadowMode,
}

/// Placed bounding box of a model-space box: the box around its eight placed corners.
fn placed_box(p: &camera::Placement, b: [[f32; 3]; 2]) -> [Vec3; 2] {
    let mut out = [[f64::INFINITY; 3], [f64::NEG_INFINITY; 3]];
    for corner in 0..8 {
        let q: Vec3 = core::array::from_fn(|k| f64::from(b[corner >> k & 1][k]));
        let w = p.apply(q);
        for k in 0..3 {
            out[0][k] = out[0][k].min(w[k]);
            out[1][k] = out[1][k].max(w[k]);
        }
    }
    out
}

/// What placing an object in a scene needs of its file, whoever holds the file: a tri-grid's
/// header, or a QSplat file's box.
#[derive(Clone, Copy, Debug)]
pub enum ObjectFile<'h> {
    /// A tri-grid (kind 1).
    Grid(&'h crate::tg::Header),
    /// A QSplat file (kind 2), its model-space box.
    QSplat([[f32; 3]; 2]),
}

/// Checks object `i`'s file against its record (the kind it says, ρ, the material indices its
/// record maps) and returns the file's placed box.
fn place(
    i: usize,
    rec: &super::ObjectRecord<'_>,
    file: ObjectFile<'_>,
) -> Result<[Vec3; 2], SceneError> {
    let object = i as u8;
    match file {
        ObjectFile::QSplat(b) => {
            if !cfg!(feature = "qsplat") {
                return Err(SceneError::NoQSplat { object });
            }
            if rec.materials != 1 {
                return Err(SceneError::MaterialBits {
                    object,
                    bits: 0,
                    materials: rec.materials,
                });
            }
            Ok(placed_box(&rec.placement, b))
        }
        ObjectFile::Grid(h) => {
            if h.rho > 3 {
                return Err(SceneError::Rho { object, rho: h.rho });
            }
            let carried = if h.material_bits == 0 { 1 } else { 8 };
            if (h.material_bits == 0 && rec.materials != 1) || rec.materials > carried {
                return Err(SceneError::MaterialBits {
                    object,
                    bits: h.material_bits,
                    materials: rec.materials,
                });
            }
            Ok(placed_box(&rec.placement, h.bounds))
        }
    }
}

impl<'a> Scene<'a> {
    /// Opens every object's file of a validated pack with its own reader.
    ///
    /// # Errors
    /// [`SceneError`] naming the first object whose file is damaged, not drawable, or carries more
    /// materials than its record maps.
    pub fn open(pack: Pack<'a>, verify: Verify) -> Result<Self, SceneError> {
        let mut scene = Self::placed(pack);
        for i in 0..pack.object_count() {
            let object = i as u8;
            let Some(rec) = pack.object(i) else { break };
            if rec.kind == Kind::QSplat {
                #[cfg(feature = "qsplat")]
                {
                    let file = QSplat::open(rec.data)
                        .map_err(|error| SceneError::QSplatObject { object, error })?;
                    scene.bounds[i] = place(i, &rec, ObjectFile::QSplat(file.bounds()))?;
                    scene.qsplats[i] = Some(file);
                    continue;
                }
                #[cfg(not(feature = "qsplat"))]
                return Err(SceneError::NoQSplat { object });
            }
            let grid = TriGrid::open(rec.data, verify)
                .map_err(|error| SceneError::Object { object, error })?;
            scene.bounds[i] = place(i, &rec, ObjectFile::Grid(grid.header()))?;
            scene.grids[i] = Some(grid);
        }
        Ok(scene)
    }

    /// A scene whose objects' files are read elsewhere (streamed, `crate::stream`): the pack's
    /// metadata ([`Pack::open_meta`]) and what `file` says of each object's file. Its camera, depth range, light space and order and shading are those
    /// of the scene [`Scene::open`] gives for the same pack; it draws nothing itself
    /// ([`Scene::grid`] and [`Scene::qsplat`] are `None`).
    ///
    /// # Errors
    /// As [`Scene::open`], for what the files' headers say.
    pub fn streamed<'h>(
        pack: Pack<'a>,
        mut file: impl FnMut(usize) -> ObjectFile<'h>,
    ) -> Result<Self, SceneError> {
        let mut scene = Self::placed(pack);
        for i in 0..pack.object_count() {
            let Some(rec) = pack.object(i) else { break };
            scene.bounds[i] = place(i, &rec, file(i))?;
        }
        Ok(scene)
    }

    /// The pack with no file open yet.
    fn placed(pack: Pack<'a>) -> Self {
        Scene {
            pack,
            grids: [None; MAX_OBJECTS],
            #[cfg(feature = "qsplat")]
            qsplats: [None; MAX_OBJECTS],
            bounds: [[[0.0; 3]; 2]; MAX_OBJECTS],
        }
    }

    /// The pack.
    pub fn pack(&self) -> &Pack<'a> {
        &self.pack
    }

    /// Number of objects.
    pub fn len(&self) -> usize {
        self.pack.object_count()
    }

    /// Whether there are no objects (never, for a valid pack).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Object `i`'s opened file, when it is a tri-grid (`None` for a QSplat object).
    pub fn grid(&self, i: usize) -> Option<&TriGrid<'a>> {
        self.grids.get(i)?.as_ref()
    }

    /// Object `i`'s opened file, when it is a QSplat file (`None` for a tri-grid).
    #[cfg(feature = "qsplat")]
    pub fn qsplat(&self, i: usize) -> Option<&QSplat<'a>> {
        self.qsplats.get(i)?.as_ref()
    }

    /// Object `i`'s world-space bounding box (min, max).
    pub fn world_bounds(&self, i: usize) -> Option<[Vec3; 2]> {
        (i < self.len()).then(|| self.bounds[i])
    }

    /// The sphere the views orbit.
    pub fn sphere(&self) -> Sphere {
        self.pack.sphere()
    }

    /// How the scene is drawn by default: the pack's light, shadows and shadow map side (256 when
    /// the pack has no shadows), a 1 px cutoff, square splats, backface culling.
    pub fn options(&self) -> RenderOptions {
        let (az, el) = self.pack.light_az_el();
        RenderOptions {
            shadows: self.pack.shadows(),
            light_dir: camera::direction(az, el),
            shadow_map_size: match self.pack.shadow_map_size() {
                0 => crate::frame::DEFAULT_SHADOW_MAP_SIZE,
                n => n,
            },
            ..RenderOptions::default()
        }
    }

    /// The orbit camera of `view` about the scene's sphere, with the pack's field of view.
    pub fn camera(&self, view: View) -> Camera {
        Camera::orbit(self.sphere(), view, self.pack.fov_deg())
    }

    /// The camera depths every object's bounding box spans from `camera` (clamped to the near plane
    /// when an object reaches behind it): the range their frames share.
    pub fn depth_range(&self, camera: &Camera) -> DepthRange {
        let mut r = DepthRange {
            near: f64::INFINITY,
            far: f64::NEG_INFINITY,
        };
        for b in &self.bounds[..self.len()] {
            for corner in 0..8 {
                let p: Vec3 = core::array::from_fn(|k| b[corner >> k & 1][k]);
                let z = camera.to_camera(p)[2];
                r.near = r.near.min(z);
                r.far = r.far.max(z);
            }
        }
        r.near = r.near.max(camera.near);
        r.far = r.far.max(r.near);
        r
    }

    /// The materials of the shading table's slots (slots beyond the scene's repeat its last).
    pub fn materials<const M: usize>(&self) -> [Material; M] {
        let last = self.pack.slot_count().saturating_sub(1);
        core::array::from_fn(|s| {
            self.pack
                .material(s.min(last))
                .map_or(crate::shade::DEFAULT_MATERIAL, |m| m.material)
        })
    }

    /// What the shading table holds for `camera` and the light towards `light_dir` (world): each
    /// slot in the model frame of the objects that use it.
    ///
    /// # Errors
    /// [`SceneError::TooFewSlots`] when `M` is below the scene's slot count.
    pub fn shading<const M: usize>(
        &self,
        camera: &Camera,
        light_dir: Vec3,
    ) -> Result<Shading<M>, SceneError> {
        if M < self.pack.slot_count() {
            return Err(SceneError::TooFewSlots {
                slots: self.pack.slot_count() as u8,
                table: M as u8,
            });
        }
        let view = camera::scale(camera.forward, -1.0);
        let mut dirs = [(light_dir, view); M];
        for i in 0..self.len() {
            let Some(rec) = self.pack.object(i) else {
                break;
            };
            let p = rec.placement;
            for &slot in &rec.slots[..usize::from(rec.materials)] {
                if let Some(d) = dirs.get_mut(usize::from(slot)) {
                    *d = (p.to_model_dir(light_dir), p.to_model_dir(view));
                }
            }
        }
        Ok(Shading {
            materials: self.materials(),
            dirs,
        })
    }

    /// Makes `table` shade every slot ([`Scene::shading`]); rebuilds only slots that changed and
    /// returns whether any did.
    ///
    /// # Errors
    /// As [`Scene::shading`].
    pub fn update_table<const M: usize>(
        &self,
        table: &mut ShadingTable<M>,
        camera: &Camera,
        light_dir: Vec3,
    ) -> Result<bool, SceneError> {
        Ok(self.shading(camera, light_dir)?.apply(table))
    }
}

/// What one-pass and two-pass shadows need of a scene: its light space and light order.
#[cfg(feature = "shadows")]
impl Scene<'_> {
    /// The light space of a directional light towards `light_dir` over every object's box.
    pub fn light_space(&self, light_dir: Vec3, map_size: usize) -> crate::shadow::LightSpace {
        let mut all = [[f64::INFINITY; 3], [f64::NEG_INFINITY; 3]];
        for b in &self.bounds[..self.len()] {
            for k in 0..3 {
                all[0][k] = all[0][k].min(b[0][k]);
                all[1][k] = all[1][k].max(b[1][k]);
            }
        }
        crate::shadow::LightSpace::directional(light_dir, all, map_size)
    }

    /// The objects in the order one-pass shadows draw them: by the distance of their box's centre
    /// from the light, nearest first, the ground after everything else; ties keep pack order.
    pub fn light_order(&self, space: &crate::shadow::LightSpace) -> [u8; MAX_OBJECTS] {
        let n = self.len();
        let mut order: [u8; MAX_OBJECTS] = core::array::from_fn(|i| i as u8);
        let key = |i: u8| -> (bool, f64) {
            let i = usize::from(i);
            let b = &self.bounds[i];
            let centre: Vec3 = core::array::from_fn(|k| 0.5 * (b[0][k] + b[1][k]));
            let ground = self.pack.object(i).is_some_and(|r| r.ground);
            (ground, space.distance(centre))
        };
        order[..n].sort_unstable_by(|&a, &b| {
            let (ka, kb) = (key(a), key(b));
            ka.0.cmp(&kb.0).then(ka.1.total_cmp(&kb.1)).then(a.cmp(&b))
        });
        order
    }
}

#[cfg(all(test, feature = "bake"))]
mod tests {
    use super::*;
    use crate::camera::Placement;
    use crate::scene::write::{write_pack, PackContents, PackObject};
    use crate::scene::Kind;

    /// A pack of one kind-2 object whose data is not a `.qs` file.
    fn qsplat_pack() -> std::vec::Vec<u8> {
        write_pack(&PackContents {
            objects: std::vec![PackObject {
                name: "q".into(),
                kind: Kind::QSplat,
                data: std::vec![0u8; 64],
                placement: Placement::IDENTITY,
                slots: std::vec![0],
                casts_shadows: false,
                ground: false,
                in_bounds: true,
                depth_asked: 0,
                depth_kept: 0,
                savings: Default::default(),
            }],
            materials: std::vec![("m".into(), crate::shade::DEFAULT_MATERIAL)],
            views: std::vec![],
            path: std::vec![],
            light_az_el: (0.0, 45.0),
            shadows: ShadowMode::Off,
            shadow_map_size: 0,
            fov_deg: 45.0,
            min_cell_px: 0.0,
            sphere: Sphere {
                center: [0.0; 3],
                radius: 1.0,
            },
            align_log2: 9,
        })
        .unwrap()
    }

    #[test]
    fn scene_kind_2_objects_are_opened_by_the_qsplat_reader_or_refused_without_it() {
        let bytes = qsplat_pack();
        let pack = Pack::open(&bytes).unwrap();
        assert_eq!(pack.object(0).unwrap().kind, Kind::QSplat);
        let e = Scene::open(pack, Verify::Full).unwrap_err();
        #[cfg(not(feature = "qsplat"))]
        {
            assert_eq!(e, SceneError::NoQSplat { object: 0 });
            assert!(std::format!("{e}").contains("no QSplat reader"));
        }
        #[cfg(feature = "qsplat")]
        assert!(matches!(e, SceneError::QSplatObject { object: 0, .. }));
    }
}
