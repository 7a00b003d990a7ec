//! Drawing a scene: every object through its own tri-grid frame into one framebuffer.
//!
//! - **Depth**: each object's frame maps depth over the range all objects share
//!   ([`Scene::depth_range`], [`TgFrame::share_depth_range`]), so objects z-test against each other.
//! - **Materials**: a splat's attribute leaves the traversal with its file's material index; a
//!   small sink in front of the caller's replaces it by the object's slot (`slots[index]`), so one
//!   shading table with a slot per (material, rotation) shades every object
//!   ([`Scene::update_table`]).
//! - **Shadows** (feature `shadows`): one map in one light space over the whole scene
//!   ([`LightSpace`]). Two-pass: every casting object fills the map, then every object is drawn
//!   testing it. One-pass: objects are drawn in order of their distance from the light, nearest
//!   first, the ground last, each testing and filling the shared map as it goes (Duguet §5.3 across
//!   objects; see [`crate::shadow::render_tg_in_scene`] for where that is not exact). The last
//!   object drawn fills nothing, since nothing is drawn after it.
//!
//! Per frame one [`TgFrame`] (and [`LightFrame`]) is set in place for each object in turn, so RAM
//! does not grow with the number of objects ([`ram_budget`]) and nothing is rebuilt that the last
//! object's frame already holds; the tri-grid frame is on the stack, the light frame where the
//! caller keeps it ([`render_scene_in`]: a `static` on the device).
//!
//! - **QSplat objects** (kind 2, feature `qsplat`): drawn through their own [`QsFrame`] and
//!   [`render_qs`], their depth mapped over the same shared range
//!   ([`QsFrame::share_depth_range`]) and their samples through the same slot sink. QSplat has no
//!   shadow code: in a shadowed scene a QSplat object is drawn unshadowed (after the shadow map is
//!   filled, in the one-pass light order like any object) and casts nothing. A build without
//!   `qsplat` refuses such a scene in [`Scene::open`] ([`SceneError::NoQSplat`]).
//!
//! Setup uses floats, as every frame setup does; per splat the slot sink is integer only.

use super::pack::Pack;
use super::{Kind, ObjectRecord, ShadowMode, MAX_OBJECTS, MAX_SLOTS};
use crate::camera::{self, Camera, Sphere, Vec3, View, Viewport};
use crate::normal::NORMAL_BITS;
#[cfg(feature = "qsplat")]
use crate::qs::{render_qs, QSplat, QsError, QsFrame};
use crate::render::{FrameError, RenderOptions};
use crate::shade::{Material, ShadingTable};
#[cfg(feature = "shadows")]
use crate::shadow::{cast_shadow_map, render_tg_in_scene, LightFrame, LightSpace, ShadowMap};
use crate::splat::{SampleSplat, SplatSink, Stats};
use crate::tg::frame::DepthRange;
use crate::tg::{TgError, TgFrame, TriGrid, Verify};

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

impl<'a> Scene<'a> {
    /// Opens every object's file of a validated pack with its own reader.
    ///
    /// # Errors
    /// [`SceneError`] naming the first object whose file is damaged, not drawable, or carries more
    /// materials than its record maps.
    pub fn open(pack: Pack<'a>, verify: Verify) -> Result<Self, SceneError> {
        let mut grids = [None; MAX_OBJECTS];
        #[cfg(feature = "qsplat")]
        let mut qsplats = [None; MAX_OBJECTS];
        let mut bounds = [[[0.0; 3]; 2]; MAX_OBJECTS];
        for i in 0..pack.object_count() {
            let object = i as u8;
            let Some(rec) = pack.object(i) else { break };
            if rec.kind == Kind::QSplat {
                #[cfg(feature = "qsplat")]
                {
                    let file = QSplat::open(rec.data)
                        .map_err(|error| SceneError::QSplatObject { object, error })?;
                    if rec.materials != 1 {
                        return Err(SceneError::MaterialBits {
                            object,
                            bits: 0,
                            materials: rec.materials,
                        });
                    }
                    bounds[i] = placed_box(&rec.placement, file.bounds());
                    qsplats[i] = Some(file);
                    continue;
                }
                #[cfg(not(feature = "qsplat"))]
                return Err(SceneError::NoQSplat { object });
            }
            let grid = TriGrid::open(rec.data, verify)
                .map_err(|error| SceneError::Object { object, error })?;
            let h = *grid.header();
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
            bounds[i] = placed_box(&rec.placement, h.bounds);
            grids[i] = Some(grid);
        }
        Ok(Scene {
            pack,
            grids,
            #[cfg(feature = "qsplat")]
            qsplats,
            bounds,
        })
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
                0 => crate::render::DEFAULT_SHADOW_MAP_SIZE,
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

    /// Makes `table` shade every slot for `camera` and the light towards `light_dir` (world): each
    /// slot in the model frame of the objects that use it. Rebuilds only slots that changed.
    ///
    /// # Errors
    /// [`SceneError::TooFewSlots`] when `M` is below the scene's slot count.
    pub fn update_table<const M: usize>(
        &self,
        table: &mut ShadingTable<M>,
        camera: &Camera,
        light_dir: Vec3,
    ) -> Result<bool, SceneError> {
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
        Ok(table.update_slots(&self.materials(), &dirs))
    }

    /// The light space of a directional light towards `light_dir` over every object's box.
    #[cfg(feature = "shadows")]
    pub fn light_space(&self, light_dir: Vec3, map_size: usize) -> LightSpace {
        let mut all = [[f64::INFINITY; 3], [f64::NEG_INFINITY; 3]];
        for b in &self.bounds[..self.len()] {
            for k in 0..3 {
                all[0][k] = all[0][k].min(b[0][k]);
                all[1][k] = all[1][k].max(b[1][k]);
            }
        }
        LightSpace::directional(light_dir, all, map_size)
    }

    /// The objects in the order one-pass shadows draw them: by the distance of their box's centre
    /// from the light, nearest first, the ground after everything else; ties keep pack order.
    #[cfg(feature = "shadows")]
    pub fn light_order(&self, space: &LightSpace) -> [u8; MAX_OBJECTS] {
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

/// `slot << 13` for each file material index of an object: the slot of the scene's shading table
/// its samples are shaded with; indices beyond the object's materials take its last (none: slot
/// 0).
pub fn slot_bits(rec: Option<&ObjectRecord<'_>>) -> [u16; MAX_SLOTS] {
    core::array::from_fn(|m| {
        let slot = rec.map_or(0, |r| {
            let used = usize::from(r.materials.max(1));
            r.slots[m.min(used - 1)]
        });
        u16::from(slot) << NORMAL_BITS
    })
}

/// An attribute with its file material index replaced by its slot (`bits` from [`slot_bits`]): what
/// the scene renderer hands its sink.
#[deny(clippy::float_arithmetic)]
#[inline(always)]
pub fn slot_attr(bits: &[u16; MAX_SLOTS], attr: u16) -> u16 {
    let m = usize::from(attr >> NORMAL_BITS) & (MAX_SLOTS - 1);
    (attr & ((1 << NORMAL_BITS) - 1)) | bits[m]
}

/// Replaces a splat's file material index by the object's slot (per splat: one mask, one look-up).
struct Slotted<'s, S> {
    inner: &'s mut S,
    /// `slot << 13` for each file material index.
    slot_bits: [u16; MAX_SLOTS],
}

#[deny(clippy::float_arithmetic)]
impl<S: SplatSink> SplatSink for Slotted<'_, S> {
    #[inline(always)]
    fn splat(&mut self, s: &SampleSplat) {
        let attr = slot_attr(&self.slot_bits, s.attr);
        self.inner.splat(&SampleSplat { attr, ..*s });
    }

    #[inline(always)]
    fn pixel(&mut self, s: &SampleSplat, x: i32, y: i32) {
        let attr = slot_attr(&self.slot_bits, s.attr);
        self.inner.pixel(&SampleSplat { attr, ..*s }, x, y);
    }
}

fn add(total: &mut Stats, s: &Stats) {
    total.nodes_visited += s.nodes_visited;
    total.culled += s.culled;
    total.backfacing += s.backfacing;
    total.splats += s.splats;
    total.shadowed += s.shadowed;
    total.max_level = total.max_level.max(s.max_level);
}

/// Draws one frame of `scene` from `camera` into `sink`, which receives attributes whose material
/// bits are slots of the table [`Scene::update_table`] prepared. The caller clears the framebuffer.
///
/// `shadow_depths` holds the shadow map when the options ask for shadows: at least side² depths,
/// the side being [`RenderOptions::shadow_map_size`]; it may be empty otherwise. With shadows, each
/// object's light frame is set in turn in one [`LightFrame`] on the stack (17 KB); firmware passes
/// its own to [`render_scene_in`] instead.
///
/// # Errors
/// [`SceneError::Frame`] when an object's frame cannot be set up (bad camera or cutoff),
/// [`SceneError::ShadowBuffer`] when the buffer is too small.
pub fn render_scene<S: SplatSink>(
    scene: &Scene<'_>,
    camera: &Camera,
    opts: &RenderOptions,
    shadow_depths: &mut [u16],
    sink: &mut S,
) -> Result<SceneStats, SceneError> {
    #[cfg(feature = "shadows")]
    if opts.shadows != ShadowMode::Off {
        let mut light = LightFrame::UNSET;
        return render_shadowed(scene, camera, opts, shadow_depths, &mut light, sink);
    }
    let _ = shadow_depths;
    render_unshadowed(scene, camera, opts, sink)
}

/// [`render_scene`] with each object's light frame set in `light` (whatever it held before):
/// firmware keeps it in a `static`, as for a single model ([`LightFrame::set`]), so that its 17 KB
/// are neither on the stack nor copied per object.
///
/// # Errors
/// As [`render_scene`].
#[cfg(feature = "shadows")]
pub fn render_scene_in<S: SplatSink>(
    scene: &Scene<'_>,
    camera: &Camera,
    opts: &RenderOptions,
    shadow_depths: &mut [u16],
    light: &mut LightFrame,
    sink: &mut S,
) -> Result<SceneStats, SceneError> {
    if opts.shadows == ShadowMode::Off {
        return render_unshadowed(scene, camera, opts, sink);
    }
    render_shadowed(scene, camera, opts, shadow_depths, light, sink)
}

/// Sets `frame` to object `i`'s tri-grid frame, its depth mapped over the scene's `range`, and
/// returns the object's grid (`None`: no object `i`). One frame is set in place per object in turn
/// ([`TgFrame::set`]): nothing is copied out, and tables that repeat are kept.
fn object_frame<'s, 'a>(
    scene: &'s Scene<'a>,
    i: usize,
    camera: &Camera,
    opts: &RenderOptions,
    range: DepthRange,
    frame: &mut TgFrame,
) -> Result<Option<&'s TriGrid<'a>>, SceneError> {
    let (Some(grid), Some(rec)) = (scene.grid(i), scene.pack.object(i)) else {
        return Ok(None);
    };
    frame
        .set(grid.header(), &rec.placement, camera, opts)
        .map_err(|error| SceneError::Frame {
            object: i as u8,
            error,
        })?;
    frame.share_depth_range(range);
    Ok(Some(grid))
}

#[cfg(feature = "shadows")]
fn render_shadowed<S: SplatSink>(
    scene: &Scene<'_>,
    camera: &Camera,
    opts: &RenderOptions,
    shadow_depths: &mut [u16],
    light: &mut LightFrame,
    sink: &mut S,
) -> Result<SceneStats, SceneError> {
    let range = scene.depth_range(camera);
    let mut frame = TgFrame::UNSET;
    let mut stats = SceneStats::default();
    let n = scene.len();
    let side = opts.shadow_map_size.clamp(1, super::MAX_MAP_SIZE);
    let need = side * side;
    if shadow_depths.len() < need {
        return Err(SceneError::ShadowBuffer {
            need: need as u32,
            given: shadow_depths.len() as u32,
        });
    }
    let mut map = ShadowMap::new(shadow_depths, side);
    map.clear();
    let space = scene.light_space(opts.light_dir, side);
    let order = scene.light_order(&space);
    let two_pass = opts.shadows == ShadowMode::TwoPass;
    if two_pass {
        for i in 0..n {
            let Some(rec) = scene.pack.object(i).filter(|r| r.casts_shadows) else {
                continue;
            };
            if let Some(grid) = object_frame(scene, i, camera, opts, range, &mut frame)? {
                light.set_in_space(grid.header(), &rec.placement, &space);
                stats.shadow_fill_nodes += cast_shadow_map(grid, &frame, light, &mut map);
            }
        }
    }
    for (k, &i) in order[..n].iter().enumerate() {
        let i = usize::from(i);
        // QSplat has no shadow code: drawn unshadowed, casting nothing.
        if let Some(st) = draw_qsplat(scene, i, camera, opts, range, sink)? {
            add(&mut stats.total, &st);
            stats.objects[i] = st;
            continue;
        }
        let Some(grid) = object_frame(scene, i, camera, opts, range, &mut frame)? else {
            continue;
        };
        let Some(rec) = scene.pack.object(i) else {
            continue;
        };
        light.set_in_space(grid.header(), &rec.placement, &space);
        // One-pass: an object that casts nothing, or the last one drawn, only tests.
        let mode = if two_pass || !rec.casts_shadows || k + 1 == n {
            ShadowMode::TwoPass
        } else {
            ShadowMode::OnePass
        };
        let mut s = slotted(scene, i, sink);
        let st = render_tg_in_scene(grid, &frame, light, &mut map, mode, &mut s);
        add(&mut stats.total, &st);
        stats.objects[i] = st;
    }
    stats.total.nodes_visited += stats.shadow_fill_nodes;
    stats.shadows = opts.shadows;
    Ok(stats)
}

fn render_unshadowed<S: SplatSink>(
    scene: &Scene<'_>,
    camera: &Camera,
    opts: &RenderOptions,
    sink: &mut S,
) -> Result<SceneStats, SceneError> {
    let range = scene.depth_range(camera);
    let mut frame = TgFrame::UNSET;
    let mut stats = SceneStats::default();
    for i in 0..scene.len() {
        if let Some(st) = draw_qsplat(scene, i, camera, opts, range, sink)? {
            add(&mut stats.total, &st);
            stats.objects[i] = st;
            continue;
        }
        let Some(grid) = object_frame(scene, i, camera, opts, range, &mut frame)? else {
            continue;
        };
        let mut s = slotted(scene, i, sink);
        let st = crate::tg::render_tg(grid, &frame, &mut s);
        add(&mut stats.total, &st);
        stats.objects[i] = st;
    }
    Ok(stats)
}

/// Draws object `i` when it is a QSplat file (`None` otherwise): its own frame, its depth over the
/// scene's `range`, its samples through the slot sink. Never shadowed.
#[cfg(feature = "qsplat")]
fn draw_qsplat<S: SplatSink>(
    scene: &Scene<'_>,
    i: usize,
    camera: &Camera,
    opts: &RenderOptions,
    range: DepthRange,
    sink: &mut S,
) -> Result<Option<Stats>, SceneError> {
    let (Some(file), Some(rec)) = (scene.qsplat(i), scene.pack.object(i)) else {
        return Ok(None);
    };
    let mut frame =
        QsFrame::new(file, &rec.placement, camera, opts).map_err(|error| SceneError::Frame {
            object: i as u8,
            error,
        })?;
    frame.share_depth_range(range);
    let mut s = slotted(scene, i, sink);
    Ok(Some(render_qs(file, &frame, &mut s)))
}

/// Without the `qsplat` feature [`Scene::open`] refuses QSplat objects: nothing to draw here.
#[cfg(not(feature = "qsplat"))]
fn draw_qsplat<S: SplatSink>(
    _scene: &Scene<'_>,
    _i: usize,
    _camera: &Camera,
    _opts: &RenderOptions,
    _range: DepthRange,
    _sink: &mut S,
) -> Result<Option<Stats>, SceneError> {
    Ok(None)
}

/// The slot sink of object `i` in front of `sink`.
fn slotted<'s, S: SplatSink>(scene: &Scene<'_>, i: usize, sink: &'s mut S) -> Slotted<'s, S> {
    sink.begin_object(i as u8);
    Slotted {
        inner: sink,
        slot_bits: slot_bits(scene.pack.object(i).as_ref()),
    }
}

/// RAM a scene needs on the device, bytes (docs/ARCHITECTURE.md "Device budget"): what the firmware and
/// `pocketsplat render --stats-json` print.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RamBudget {
    /// RGB565 colour, a value per pixel of the frame.
    pub framebuffer: usize,
    /// 16-bit depth, a value per pixel.
    pub depth: usize,
    /// The shadow map (0 without shadows).
    pub shadow_map: usize,
    /// The shading table, one slot per (material, rotation) of the scene.
    pub shading_tables: usize,
    /// Block cache (0: a pack in flash or RAM is resident, read in place).
    pub cache: usize,
    /// Per-frame setup live at a time (one object's tri-grid frame, on the stack, and with
    /// shadows its light frame, a `static` on the device; with QSplat objects their frame too).
    pub frame_setup: usize,
    /// The opened scene (pack view and the objects' readers).
    pub scene: usize,
}

impl RamBudget {
    /// Everything added.
    pub fn total(&self) -> usize {
        self.framebuffer
            + self.depth
            + self.shadow_map
            + self.shading_tables
            + self.cache
            + self.frame_setup
            + self.scene
    }
}

/// Bytes of a shading table with `slots` slots (1..=8; more count as 8).
pub fn shading_table_bytes(slots: usize) -> usize {
    use core::mem::size_of;
    match slots {
        0 | 1 => size_of::<ShadingTable<1>>(),
        2 => size_of::<ShadingTable<2>>(),
        3 => size_of::<ShadingTable<3>>(),
        4 => size_of::<ShadingTable<4>>(),
        5 => size_of::<ShadingTable<5>>(),
        6 => size_of::<ShadingTable<6>>(),
        7 => size_of::<ShadingTable<7>>(),
        _ => size_of::<ShadingTable<8>>(),
    }
}

/// The RAM a frame of `pack` needs with `shadows` (usually the pack's; `Off` when the build leaves
/// shadows out) and a shadow map of `map_size`² texels, its shading table holding exactly the
/// pack's slots (a build with a larger table pays for it), for frames of `viewport`'s size.
pub fn ram_budget(
    pack: &Pack<'_>,
    shadows: ShadowMode,
    map_size: usize,
    viewport: Viewport,
) -> RamBudget {
    let side = map_size;
    let shadowed = shadows != ShadowMode::Off && cfg!(feature = "shadows");
    #[cfg(feature = "shadows")]
    let light = if shadowed {
        core::mem::size_of::<LightFrame>()
    } else {
        0
    };
    #[cfg(not(feature = "shadows"))]
    let light = 0;
    // A QSplat object's frame is on the stack beside the tri-grid frame while it is drawn.
    let has_qs =
        (0..pack.object_count()).any(|i| pack.object(i).is_some_and(|r| r.kind == Kind::QSplat));
    #[cfg(feature = "qsplat")]
    let qs_frame = if has_qs {
        core::mem::size_of::<QsFrame>()
    } else {
        0
    };
    #[cfg(not(feature = "qsplat"))]
    let qs_frame = {
        let _ = has_qs;
        0
    };
    RamBudget {
        framebuffer: viewport.pixels() * 2,
        depth: viewport.pixels() * 2,
        shadow_map: if shadowed { side * side * 2 } else { 0 },
        shading_tables: shading_table_bytes(pack.slot_count()),
        cache: 0,
        frame_setup: core::mem::size_of::<TgFrame>() + light + qs_frame,
        scene: core::mem::size_of::<Scene<'_>>(),
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
