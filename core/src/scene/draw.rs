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
//!   objects). Where two objects overlap along the light, a part of the later one nearer the
//!   light than a part of the earlier one cannot shadow it: that part of the map was not filled
//!   yet when the earlier object was drawn (the one-pass limitation, now between objects as well
//!   as within one). The last object drawn fills nothing, since nothing is drawn after it.
//! - **Where the files are** ([`Objects`]): in memory (a [`Scene`] opened whole) or read through
//!   block caches (`crate::stream::SceneStream`); one frame function draws both.
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

use super::open::{Scene, SceneError, SceneStats};
#[cfg_attr(not(feature = "shadows"), allow(unused_imports))]
use super::ShadowMode;
use super::{ObjectRecord, MAX_SLOTS};
use crate::camera::Camera;
use crate::frame::FrameError;
use crate::frame::{RenderOptions, Walk};
use crate::normal::NORMAL_BITS;
#[cfg(feature = "qsplat")]
use crate::qs::{render_qs, QsFrame};
#[cfg(feature = "shadows")]
use crate::shadow::{Fill, LightFrame, OnePass, ShadowMap, TwoPass};
use crate::splat::{ColorSink, SampleSplat, SplatSink, Stats};
use crate::tg::frame::DepthRange;
use crate::tg::read::Header;
use crate::tg::traverse::{fill_tg, render_tg_with, NoShadows, ShadowHooks};
use crate::tg::TgFrame;

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

/// A scene's frame ready to walk ([`Walk`]): every object in turn into the shared depth buffer,
/// with the shadows the options ask for. [`SceneWalk::finish`] says what each object did.
pub struct SceneWalk<'a, 's> {
    scene: &'a Scene<'s>,
    camera: &'a Camera,
    options: &'a RenderOptions,
    map: &'a mut [u16],
    #[cfg(feature = "shadows")]
    light: Option<&'a mut LightFrame>,
    result: Option<Result<SceneStats, SceneError>>,
}

impl<'a, 's> SceneWalk<'a, 's> {
    /// A frame of `scene` from `camera` (already fitted to the target), with `map` for the
    /// shadow map (empty without shadows) and, with the `shadows` feature, a place for the
    /// light's tables (a `static` on a device; `None`: one on the stack, [`render_scene`]).
    pub fn new(
        scene: &'a Scene<'s>,
        camera: &'a Camera,
        options: &'a RenderOptions,
        map: &'a mut [u16],
        #[cfg(feature = "shadows")] light: Option<&'a mut LightFrame>,
    ) -> Self {
        Self {
            scene,
            camera,
            options,
            map,
            #[cfg(feature = "shadows")]
            light,
            result: None,
        }
    }

    /// What the walk did, per object (empty counts if it never ran).
    ///
    /// # Errors
    /// [`SceneError`] when an object's frame could not be set up or the map is too small.
    pub fn finish(self) -> Result<SceneStats, SceneError> {
        self.result.unwrap_or(Ok(SceneStats::default()))
    }
}

impl Walk for SceneWalk<'_, '_> {
    fn walk<S: ColorSink>(&mut self, sink: &mut S) -> Stats {
        let (scene, camera, options) = (self.scene, self.camera, self.options);
        let r = render_objects(
            scene,
            &mut Resident(scene),
            camera,
            options,
            self.map,
            #[cfg(feature = "shadows")]
            self.light.as_deref_mut(),
            sink,
        );
        let total = r.as_ref().map(|s| s.total).unwrap_or_default();
        self.result = Some(r);
        total
    }
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
    render_objects(
        scene,
        &mut Resident(scene),
        camera,
        opts,
        shadow_depths,
        #[cfg(feature = "shadows")]
        None,
        sink,
    )
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
    render_objects(
        scene,
        &mut Resident(scene),
        camera,
        opts,
        shadow_depths,
        Some(light),
        sink,
    )
}

/// Where a scene's objects' files are read: in memory (every file of a [`Scene`] open,
/// [`Resident`]) or through a block cache (`crate::stream::SceneStream`). A scene's frame walks
/// each object through it, so both draw a scene by the same code (`render_objects`).
pub(crate) trait Objects {
    /// Object `i`'s tri-grid header (`None`: not a tri-grid).
    fn grid_header(&self, i: usize) -> Option<&Header>;
    /// Whether this frame's shadow map starts empty (not for a refined frame's later passes,
    /// which add to what the earlier ones cast).
    #[cfg_attr(not(feature = "shadows"), allow(dead_code))]
    fn fresh_map(&self) -> bool {
        true
    }
    /// Draws object `i`'s tri-grid through `hooks` (the shadows of its frame).
    fn draw_grid<S: SplatSink, H: ShadowHooks>(
        &mut self,
        i: usize,
        frame: &TgFrame,
        hooks: &mut H,
        sink: &mut S,
    ) -> Stats;
    /// Casts object `i`'s tri-grid through `hooks` (the light pass of two-pass shadows); returns
    /// nodes visited.
    #[cfg_attr(not(feature = "shadows"), allow(dead_code))]
    fn cast_grid<H: ShadowHooks>(&mut self, i: usize, frame: &TgFrame, hooks: &mut H) -> u32;
    /// Draws object `i` when it is a QSplat file (`None` otherwise; by default, a build without
    /// QSplat): its frame from `camera`, its depth over the scene's `range`, its colours ignored
    /// (the scene shades by slot).
    fn draw_qs<S: SplatSink>(
        &mut self,
        i: usize,
        rec: &ObjectRecord<'_>,
        camera: &Camera,
        opts: &RenderOptions,
        range: DepthRange,
        sink: &mut S,
    ) -> Option<Result<Stats, FrameError>> {
        let _ = (i, rec, camera, opts, range, sink);
        None
    }
}

/// A scene's files in memory: [`Scene::open`] opened them all.
pub(crate) struct Resident<'s, 'a>(pub &'s Scene<'a>);

impl Objects for Resident<'_, '_> {
    fn grid_header(&self, i: usize) -> Option<&Header> {
        self.0.grid(i).map(|g| g.header())
    }
    fn draw_grid<S: SplatSink, H: ShadowHooks>(
        &mut self,
        i: usize,
        frame: &TgFrame,
        hooks: &mut H,
        sink: &mut S,
    ) -> Stats {
        self.0
            .grid(i)
            .map_or_else(Stats::default, |g| render_tg_with(g, frame, hooks, sink))
    }
    fn cast_grid<H: ShadowHooks>(&mut self, i: usize, frame: &TgFrame, hooks: &mut H) -> u32 {
        self.0.grid(i).map_or(0, |g| fill_tg(g, frame, hooks))
    }
    #[cfg(feature = "qsplat")]
    fn draw_qs<S: SplatSink>(
        &mut self,
        i: usize,
        rec: &ObjectRecord<'_>,
        camera: &Camera,
        opts: &RenderOptions,
        range: DepthRange,
        sink: &mut S,
    ) -> Option<Result<Stats, FrameError>> {
        let file = self.0.qsplat(i)?;
        Some(
            QsFrame::new(file, &rec.placement, camera, opts).map(|mut frame| {
                frame.share_depth_range(range);
                render_qs(file, &frame, sink)
            }),
        )
    }
}

/// Sets `frame` to object `i`'s tri-grid frame, its depth mapped over the scene's `range`, and
/// returns its record when object `i` is a tri-grid. One frame is set in place per object in turn
/// ([`TgFrame::set`]): nothing is copied out, and tables that repeat are kept.
pub(crate) fn object_frame<'a, O: Objects>(
    scene: &Scene<'a>,
    objects: &O,
    i: usize,
    camera: &Camera,
    opts: &RenderOptions,
    range: DepthRange,
    frame: &mut TgFrame,
) -> Result<Option<ObjectRecord<'a>>, SceneError> {
    let (Some(header), Some(rec)) = (objects.grid_header(i), scene.pack().object(i)) else {
        return Ok(None);
    };
    frame
        .set(header, &rec.placement, camera, opts)
        .map_err(|error| SceneError::Frame {
            object: i as u8,
            error,
        })?;
    frame.share_depth_range(range);
    Ok(Some(rec))
}

/// One frame of `scene`, its objects' files read through `objects`, with the shadows `opts` ask
/// for (the map and `light` used only then; `None`: a light frame on the stack): [`render_scene`]
/// and the streamed scene's frame.
pub(crate) fn render_objects<O: Objects, S: SplatSink>(
    scene: &Scene<'_>,
    objects: &mut O,
    camera: &Camera,
    opts: &RenderOptions,
    shadow_depths: &mut [u16],
    #[cfg(feature = "shadows")] light: Option<&mut LightFrame>,
    sink: &mut S,
) -> Result<SceneStats, SceneError> {
    #[cfg(feature = "shadows")]
    if opts.shadows != ShadowMode::Off {
        let mut own = None;
        let light = match light {
            Some(l) => l,
            None => own.insert(LightFrame::UNSET),
        };
        return render_shadowed(scene, objects, camera, opts, shadow_depths, light, sink);
    }
    let _ = shadow_depths;
    render_unshadowed(scene, objects, camera, opts, sink)
}

#[cfg(feature = "shadows")]
fn render_shadowed<O: Objects, S: SplatSink>(
    scene: &Scene<'_>,
    objects: &mut O,
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
    if objects.fresh_map() {
        map.clear();
    }
    let space = scene.light_space(opts.light_dir, side);
    let order = scene.light_order(&space);
    let two_pass = opts.shadows == ShadowMode::TwoPass;
    if two_pass {
        for i in 0..n {
            if !scene.pack().object(i).is_some_and(|r| r.casts_shadows) {
                continue;
            }
            if let Some(rec) = object_frame(scene, objects, i, camera, opts, range, &mut frame)? {
                if let Some(h) = objects.grid_header(i) {
                    light.set_in_space(h, &rec.placement, &space);
                }
                let mut fill = Fill::<false> {
                    light,
                    map: &mut map,
                };
                stats.shadow_fill_nodes += objects.cast_grid(i, &frame, &mut fill);
            }
        }
    }
    for (k, &i) in order[..n].iter().enumerate() {
        let i = usize::from(i);
        // QSplat has no shadow code: drawn unshadowed, casting nothing.
        if let Some(st) = draw_qsplat(scene, objects, i, camera, opts, range, sink)? {
            add(&mut stats.total, &st);
            stats.objects[i] = st;
            continue;
        }
        let Some(rec) = object_frame(scene, objects, i, camera, opts, range, &mut frame)? else {
            continue;
        };
        if let Some(h) = objects.grid_header(i) {
            light.set_in_space(h, &rec.placement, &space);
        }
        let mut s = slotted(scene, i, sink);
        // One-pass: an object that casts nothing, or the last one drawn, only tests.
        let st = if two_pass || !rec.casts_shadows || k + 1 == n {
            let mut test = TwoPass::<false> { light, map: &map };
            objects.draw_grid(i, &frame, &mut test, &mut s)
        } else {
            let mut one = OnePass {
                light,
                map: &mut map,
            };
            objects.draw_grid(i, &frame, &mut one, &mut s)
        };
        add(&mut stats.total, &st);
        stats.objects[i] = st;
    }
    stats.total.nodes_visited += stats.shadow_fill_nodes;
    stats.shadows = opts.shadows;
    Ok(stats)
}

fn render_unshadowed<O: Objects, S: SplatSink>(
    scene: &Scene<'_>,
    objects: &mut O,
    camera: &Camera,
    opts: &RenderOptions,
    sink: &mut S,
) -> Result<SceneStats, SceneError> {
    let range = scene.depth_range(camera);
    let mut frame = TgFrame::UNSET;
    let mut stats = SceneStats::default();
    for i in 0..scene.len() {
        if let Some(st) = draw_qsplat(scene, objects, i, camera, opts, range, sink)? {
            add(&mut stats.total, &st);
            stats.objects[i] = st;
            continue;
        }
        if object_frame(scene, objects, i, camera, opts, range, &mut frame)?.is_none() {
            continue;
        }
        let mut s = slotted(scene, i, sink);
        let st = objects.draw_grid(i, &frame, &mut NoShadows, &mut s);
        add(&mut stats.total, &st);
        stats.objects[i] = st;
    }
    Ok(stats)
}

/// Draws object `i` when it is a QSplat file (`None` otherwise): its own frame, its depth over the
/// scene's `range`, its samples through the slot sink. Never shadowed.
fn draw_qsplat<O: Objects, S: SplatSink>(
    scene: &Scene<'_>,
    objects: &mut O,
    i: usize,
    camera: &Camera,
    opts: &RenderOptions,
    range: DepthRange,
    sink: &mut S,
) -> Result<Option<Stats>, SceneError> {
    // Most objects are tri-grids: their records are not read (nor their slot sink made) twice.
    if scene.pack().kind(i) != Some(super::Kind::QSplat) {
        return Ok(None);
    }
    let Some(rec) = scene.pack().object(i) else {
        return Ok(None);
    };
    let mut s = slotted(scene, i, sink);
    objects
        .draw_qs(i, &rec, camera, opts, range, &mut s)
        .transpose()
        .map_err(|error| SceneError::Frame {
            object: i as u8,
            error,
        })
}

/// The slot sink of object `i` in front of `sink`.
fn slotted<'s, S: SplatSink>(scene: &Scene<'_>, i: usize, sink: &'s mut S) -> Slotted<'s, S> {
    sink.begin_object(i as u8);
    Slotted {
        inner: sink,
        slot_bits: slot_bits(scene.pack().object(i).as_ref()),
    }
}
