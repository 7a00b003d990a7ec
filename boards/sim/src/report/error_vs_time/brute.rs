//! The brute-force baseline of the error-against-run-time report: every leaf sample of a grid as a
//! flat point list, each one projected with an `f64` matrix and splatted at its leaf size. No
//! hierarchy, no level of detail, no integer tables: the naive method the hierarchical renderers have
//! to beat (it runs on the host's FPU; a handheld without one would emulate every operation).
//!
//! A point is skipped when it lies in front of the near plane, faces away from the eye
//! (`n · (p − eye) > 0`, exact per point, where the tri-grid's test is conservative per frame) or its
//! splat misses the frame. The splat ([`Footprint`]) is, for the report's baseline, the one the
//! tri-grid traversal drew for a leaf before its exact footprints (the projected diameter of the
//! cell's bounding sphere, `√3 · side · f / z`, at least one pixel), or the tri-grid's exact
//! footprint; either is shaded through the same table and depth-tested in the same 16-bit buffer,
//! so the two differ only in how they choose and project samples.
//!
//! A scene pack's baseline ([`SceneCloud`]) is every object's leaves placed in the world, drawn as
//! the scene renderer draws its objects (`pocketsplat_core::scene::render`): each point's material
//! index replaced by its object's slot of the one shading table, its normal turned by its object's
//! rotation for the backface test, its splat scaled by its object's scale, its depth mapped over
//! the range all objects share. Both clouds draw through one per-point loop.

use std::ops::Range;
use std::time::Instant;

use pocketsplat_core::camera::{self, Camera, Placement, Vec3};
use pocketsplat_core::fixed::ONE_PX_Q8;
use pocketsplat_core::normal::{NORMALS_Q14, NORMAL_COUNT};
use pocketsplat_core::raster::{draw_splat, DepthTarget, Kernel, Splat};
use pocketsplat_core::render::RenderOptions;
use pocketsplat_core::scene::{slot_attr, slot_bits, Scene};
use pocketsplat_core::shade::ShadingTable;
use pocketsplat_core::splat::Stats;
use pocketsplat_core::tg::frame::{FOOTPRINT, FOOTPRINT_ROUND};
use pocketsplat_core::tg::TriGrid;

use crate::render::{FrameBuffers, FrameReport, Settings};
use crate::scene::render::SceneTable;

/// One pixel in the splats' fixed point.
const ONE_PX: f64 = ONE_PX_Q8 as f64;

/// The splat a brute-force point draws.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Footprint {
    /// The baseline the error-against-run-time report has always compared with (the splat the
    /// tri-grid drew before its exact footprints): the projected diameter of the leaf cell's
    /// bounding sphere, `√3 · side · f / z`, and at least one pixel.
    #[default]
    Sphere,
    /// The tri-grid's footprint (`pocketsplat_core::tg::frame`): `FOOTPRINT` × the projected
    /// side, only on the pixel centres it covers.
    Exact,
}

impl Footprint {
    /// Splat diameter per projected leaf side.
    fn scale(self, kernel: Kernel) -> f64 {
        match (self, kernel) {
            (Footprint::Sphere, _) => 3f64.sqrt(),
            (Footprint::Exact, Kernel::Square) => FOOTPRINT,
            (Footprint::Exact, Kernel::Round) => FOOTPRINT_ROUND,
        }
    }
}

/// The leaf samples of a grid as a flat point list (the brute-force "format").
#[derive(Clone, Debug)]
pub struct LeafCloud {
    /// Cell centres, model units.
    pub points: Vec<Vec3>,
    /// Attribute (normal code | material << 13) of each point.
    pub attrs: Vec<u16>,
    /// Side of a leaf cell, model units.
    pub leaf_side: f64,
    /// Minimum corner and side of the root cube, model units (for the depth range).
    pub root: (Vec3, f64),
    /// Bounding box of the mesh, model units (the views orbit its centre).
    pub bounds: [[f32; 3]; 2],
    /// The splat each point draws ([`Footprint::Sphere`], the report's baseline, by default).
    pub footprint: Footprint,
}

impl LeafCloud {
    /// Every leaf sample of `grid`, in file order: the cells of each level are found from their
    /// parents' child masks (FORMAT.md: breadth-first, by parent then slot).
    pub fn from_grid(grid: &TriGrid<'_>) -> Self {
        let h = grid.header();
        let rho = u32::from(h.rho);
        let mut cells: Vec<[u32; 3]> = vec![[0; 3]];
        for level in 0..h.depth {
            let mut next = Vec::with_capacity(grid.level(level + 1).count as usize);
            for (i, c) in cells.iter().enumerate() {
                let mut mask = grid.mask(level, i as u32);
                while mask != 0 {
                    let s = mask.trailing_zeros();
                    mask &= mask - 1;
                    let ijk = [s % rho, (s / rho) % rho, s / (rho * rho)];
                    next.push([0, 1, 2].map(|k| c[k] * rho + ijk[k]));
                }
            }
            cells = next;
        }
        let side = h.side64;
        let leaf_side = side / f64::from(rho).powi(i32::from(h.depth));
        let origin = h.origin64;
        let points = cells
            .iter()
            .map(|c| [0, 1, 2].map(|k| origin[k] + (f64::from(c[k]) + 0.5) * leaf_side))
            .collect();
        let attrs = (0..cells.len() as u32)
            .map(|i| grid.attr(h.depth, i))
            .collect();
        Self {
            points,
            attrs,
            leaf_side,
            root: (origin, side),
            bounds: h.bounds,
            footprint: Footprint::default(),
        }
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether there are no points.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Renders one frame with `settings` (view, kernel, light, material; the cutoff and shadows are
    /// ignored: every point is drawn, unshadowed) into `out`, cleared first. The time covers the
    /// same span as the tri-grid's: camera and shading-table setup, projection and raster.
    /// `nodes_visited` counts every point, `culled` the points in front of the near plane or off
    /// the frame.
    pub fn render(
        &self,
        settings: &Settings,
        table: &mut ShadingTable<1>,
        out: &mut FrameBuffers,
    ) -> FrameReport {
        let t = Instant::now();
        let cam = settings.camera(self.bounds).for_viewport(out.viewport());
        table.update(
            &[settings.material],
            settings.light_dir(),
            camera::scale(cam.forward, -1.0),
        );
        let (z0, z_scale) = self.depth_map(&cam);
        let mut fb = out.display();
        fb.clear(0);
        let mut stats = Stats {
            nodes_visited: self.points.len() as u32,
            ..Stats::default()
        };
        let frame = BruteFrame {
            cam: &cam,
            z0,
            z_scale,
            table,
            kernel: settings.kernel,
            exact: self.footprint == Footprint::Exact,
            backface_culling: true,
        };
        frame.draw(
            PointRun {
                points: &self.points,
                attrs: &self.attrs,
                rotation: &Placement::IDENTITY.rotation,
                size_k: self.footprint.scale(settings.kernel)
                    * self.leaf_side
                    * cam.focal_px
                    * ONE_PX,
            },
            &mut fb,
            &mut stats,
        );
        FrameReport {
            stats,
            time: t.elapsed(),
            scene: None,
        }
    }

    /// Depth `(z − z0) · scale` spreads 0..=65534 over the root cube's camera depths (as the
    /// tri-grid frame does), from the near plane at the closest.
    fn depth_map(&self, cam: &Camera) -> (f64, f64) {
        let (origin, side) = self.root;
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for corner in 0..8 {
            let p: Vec3 =
                std::array::from_fn(|k| origin[k] + if corner >> k & 1 != 0 { side } else { 0.0 });
            let z = cam.to_camera(p)[2];
            lo = lo.min(z);
            hi = hi.max(z);
        }
        depth_map(lo, hi, cam.near)
    }
}

/// One object of a [`SceneCloud`]: where its points are and how they are drawn.
#[derive(Clone, Debug, PartialEq)]
pub struct CloudObject {
    /// Its points' indices in [`SceneCloud::points`] and [`SceneCloud::attrs`].
    pub range: Range<usize>,
    /// Model-to-world rotation of its normals: its placement's (row-major).
    pub rotation: [[f64; 3]; 3],
    /// Side of its leaf cells, world units: its file's leaf side times its placement's scale.
    pub leaf_side: f64,
}

/// Every leaf sample of every object of a scene pack, placed in the world: the brute-force
/// baseline of a scene, drawn as the scene renderer draws its objects' leaves (one shading table
/// with a slot per material and rotation, one depth range shared by all objects), without shadows.
#[derive(Clone, Debug)]
pub struct SceneCloud {
    /// Cell centres, world units (each object's leaf centres through its placement).
    pub points: Vec<Vec3>,
    /// Attribute of each point: its normal code (model frame, as the table's slots are shaded) and
    /// its object's slot for its file's material index in the material bits, as the scene
    /// renderer's slot sink hands them to the shading table.
    pub attrs: Vec<u16>,
    /// The objects, in pack order.
    pub objects: Vec<CloudObject>,
    /// The splat each point draws, as [`LeafCloud::footprint`].
    pub footprint: Footprint,
}

impl SceneCloud {
    /// Every leaf of every object of `scene` ([`LeafCloud::from_grid`] of each file), placed.
    pub fn from_scene(scene: &Scene<'_>) -> Self {
        let mut cloud = SceneCloud {
            points: Vec::new(),
            attrs: Vec::new(),
            objects: Vec::with_capacity(scene.len()),
            footprint: Footprint::default(),
        };
        for i in 0..scene.len() {
            // The scene renderer skips such an object too (never, for an opened scene).
            let (Some(grid), Some(rec)) = (scene.grid(i), scene.pack().object(i)) else {
                continue;
            };
            let leaves = LeafCloud::from_grid(grid);
            let placement = rec.placement;
            let bits = slot_bits(Some(&rec));
            let start = cloud.points.len();
            cloud
                .points
                .extend(leaves.points.iter().map(|&p| placement.apply(p)));
            cloud
                .attrs
                .extend(leaves.attrs.iter().map(|&a| slot_attr(&bits, a)));
            cloud.objects.push(CloudObject {
                range: start..cloud.points.len(),
                rotation: placement.rotation,
                leaf_side: leaves.leaf_side * placement.scale,
            });
        }
        cloud
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether there are no points.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Renders one frame of `scene` (the one this cloud was made from) from `camera` with `opts`
    /// (kernel, light and backface culling; the cutoff and shadows are ignored: every leaf is
    /// drawn, unshadowed) into `out`, cleared first, with a caller-owned `table` that
    /// [`Scene::update_table`] brings up to date. A point faces away when its world normal (its
    /// normal code turned by its object's rotation) points away from the eye, exactly per point;
    /// its splat is its leaf's bounding-sphere diameter `√3 · side · scale · f / z`; its depth is
    /// mapped over [`Scene::depth_range`], the range the scene renderer's frames share. The time
    /// covers the span the scene renderer's does: table update, setup, projection and raster.
    /// `nodes_visited` counts every point, `culled` those in front of the near plane or off the
    /// frame.
    ///
    /// # Panics
    /// Never: a [`SceneTable`] has a slot for every slot a pack can have.
    pub fn render(
        &self,
        scene: &Scene<'_>,
        camera: &Camera,
        opts: &RenderOptions,
        table: &mut SceneTable,
        out: &mut FrameBuffers,
    ) -> FrameReport {
        let t = Instant::now();
        let camera = &camera.for_viewport(out.viewport());
        scene
            .update_table(table, camera, opts.light_dir)
            .expect("a scene table has MAX_SLOTS slots");
        let range = scene.depth_range(camera);
        let (z0, z_scale) = depth_map(range.near, range.far, camera.near);
        let mut fb = out.display();
        fb.clear(0);
        let mut stats = Stats {
            nodes_visited: self.points.len() as u32,
            ..Stats::default()
        };
        let frame = BruteFrame {
            cam: camera,
            z0,
            z_scale,
            table,
            kernel: opts.kernel,
            exact: self.footprint == Footprint::Exact,
            backface_culling: opts.backface_culling,
        };
        for o in &self.objects {
            frame.draw(
                PointRun {
                    points: &self.points[o.range.clone()],
                    attrs: &self.attrs[o.range.clone()],
                    rotation: &o.rotation,
                    size_k: self.footprint.scale(opts.kernel)
                        * o.leaf_side
                        * camera.focal_px
                        * ONE_PX,
                },
                &mut fb,
                &mut stats,
            );
        }
        FrameReport {
            stats,
            time: t.elapsed(),
            scene: None,
        }
    }
}

/// `(z0, scale)` spreading depth `(z − z0) · scale` over 0..=65534 for camera depths `lo..=hi`,
/// `lo` at least the near plane (an empty or flat range still gets a finite scale).
fn depth_map(lo: f64, hi: f64, near: f64) -> (f64, f64) {
    let lo = lo.max(near);
    let hi = hi.max(lo * (1.0 + 1e-9) + f64::MIN_POSITIVE);
    (lo, 65534.0 / (hi - lo))
}

/// Points drawn with one normal rotation and one splat size: a [`LeafCloud`], or one object of a
/// [`SceneCloud`].
struct PointRun<'p> {
    /// World positions.
    points: &'p [Vec3],
    /// Attributes; their material bits pick the shading table's slot.
    attrs: &'p [u16],
    /// Model-to-world rotation of the normal codes (row-major).
    rotation: &'p [[f64; 3]; 3],
    /// Splat diameter in Q8 pixels times camera depth: `scale · leaf side (world) · f · 256`.
    size_k: f64,
}

/// What every point of a frame is projected, shaded and depth-mapped with.
struct BruteFrame<'f, const M: usize> {
    cam: &'f Camera,
    /// Depth `(z − z0) · z_scale`.
    z0: f64,
    z_scale: f64,
    table: &'f ShadingTable<M>,
    kernel: Kernel,
    /// Draw only on covered pixel centres ([`Footprint::Exact`]), else at least one pixel.
    exact: bool,
    /// Skip points whose world normal faces away from the eye.
    backface_culling: bool,
}

impl<const M: usize> BruteFrame<'_, M> {
    /// Projects, culls and splats every point of `run` into `fb`, counting into `stats`
    /// (`culled`, `backfacing`, `splats`; the caller counts `nodes_visited`). The one per-point
    /// loop both clouds draw with.
    fn draw(&self, run: PointRun<'_>, fb: &mut impl DepthTarget, stats: &mut Stats) {
        let cam = self.cam;
        let rot = run.rotation;
        let (cx, cy) = cam.viewport.center();
        let (w, h) = (
            f64::from(cam.viewport.width),
            f64::from(cam.viewport.height),
        );
        for (p, &attr) in run.points.iter().zip(run.attrs) {
            let d = camera::sub(*p, cam.eye);
            let z = camera::dot(d, cam.forward);
            if z < cam.near {
                stats.culled += 1;
                continue;
            }
            let n = NORMALS_Q14[usize::from(attr) & (NORMAL_COUNT - 1)];
            let n = n.map(f64::from);
            // The world normal (with the identity, exactly the model normal).
            let n = [0, 1, 2].map(|k| camera::dot(rot[k], n));
            if self.backface_culling && camera::dot(n, d) > 0.0 {
                stats.backfacing += 1;
                continue;
            }
            let inv = cam.focal_px / z;
            let sx = cx + camera::dot(d, cam.right) * inv;
            let sy = cy - camera::dot(d, cam.up) * inv;
            let size_q8 = run.size_k / z;
            let r = size_q8 / (2.0 * ONE_PX) + 1.0;
            if sx + r < 0.0 || sy + r < 0.0 || sx - r > w || sy - r > h {
                stats.culled += 1;
                continue;
            }
            let depth = ((z - self.z0) * self.z_scale).clamp(0.0, 65534.0) as u16;
            draw_splat(
                fb,
                &Splat {
                    x_q8: (sx * ONE_PX).round() as i32,
                    y_q8: (sy * ONE_PX).round() as i32,
                    size_q8: size_q8.round().min(f64::from(i32::MAX)) as i32,
                    depth,
                    color: self.table.color(attr),
                },
                self.kernel,
                self.exact,
            );
            stats.splats += 1;
        }
    }
}

/// The kernel names used in the report.
pub fn kernel_name(k: Kernel) -> &'static str {
    match k {
        Kernel::Square => "square",
        Kernel::Round => "round",
    }
}

#[cfg(test)]
mod tests {
    use pocketsplat_core::bake::{BakeOptions, TriMesh};
    use pocketsplat_core::tg::Verify;

    use super::*;
    use crate::bake::bake_mesh;
    use crate::metrics::{coverage_mismatch, psnr_rgb8};
    use crate::render::render_tg_frame;
    use pocketsplat_core::shade::rgb565_to_rgb888;

    fn knot_grid(depth: u8) -> Vec<u8> {
        let mesh: TriMesh = crate::demo::trefoil(96, 12, 0.45);
        bake_mesh(&mesh, BakeOptions { rho: 3, depth }, 12, false)
            .unwrap()
            .1
    }

    #[test]
    fn every_leaf_is_found_once_at_its_cell_centre() {
        let bytes = knot_grid(4);
        let grid = TriGrid::open(&bytes, Verify::Full).unwrap();
        let cloud = LeafCloud::from_grid(&grid);
        assert_eq!(cloud.len(), grid.leaf_samples() as usize);
        let h = grid.header();
        let cells = 81.0;
        // Every point is the centre of a distinct leaf cell inside the root cube.
        let mut seen = std::collections::HashSet::new();
        for p in &cloud.points {
            let ijk: [i64; 3] = std::array::from_fn(|k| {
                let u = (p[k] - h.origin64[k]) / cloud.leaf_side - 0.5;
                assert!((u - u.round()).abs() < 1e-6, "{p:?} is not a cell centre");
                assert!(
                    u > -0.5 && u < cells - 0.5,
                    "{p:?} is outside the root cube"
                );
                u.round() as i64
            });
            assert!(seen.insert(ijk), "cell {ijk:?} twice");
        }
        assert_eq!(cloud.attrs.len(), cloud.len());
    }

    /// With a cutoff far below a pixel the tri-grid draws its leaves too: the two images must agree
    /// but for the rounding of the integer projection and the backface tests.
    #[test]
    fn matches_the_trigrid_drawing_all_leaves() {
        let bytes = knot_grid(4);
        let grid = TriGrid::open(&bytes, Verify::Full).unwrap();
        // The tri-grid's own footprint: the two differ only in how they pick and project.
        let cloud = LeafCloud {
            footprint: Footprint::Exact,
            ..LeafCloud::from_grid(&grid)
        };
        for kernel in [Kernel::Square, Kernel::Round] {
            let settings = Settings {
                cutoff_px: 0.01,
                kernel,
                ..Settings::default()
            };
            let mut tg = FrameBuffers::new();
            let r = render_tg_frame(&grid, &settings, &mut tg).unwrap();
            let mut brute = FrameBuffers::new();
            let mut table = Box::new(ShadingTable::<1>::new());
            let b = cloud.render(&settings, &mut table, &mut brute);
            assert_eq!(r.stats.max_level, h_depth(&grid));
            assert_eq!(b.stats.nodes_visited as usize, cloud.len());
            assert!(b.stats.splats > 0 && b.stats.splats <= cloud.len() as u32);
            let rgb = |f: &FrameBuffers| -> Vec<[u8; 3]> {
                f.pixels().iter().map(|&p| rgb565_to_rgb888(p)).collect()
            };
            let mismatch = coverage_mismatch(&tg.covered(), &brute.covered());
            let psnr = psnr_rgb8(&rgb(&tg), &rgb(&brute));
            // Differences are at silhouettes: the tri-grid also draws samples that face away
            // from some rays of the view (its test is per frame), the brute force none.
            let differ = tg
                .pixels()
                .iter()
                .zip(brute.pixels())
                .filter(|(a, b)| a != b)
                .count();
            assert!(mismatch < 0.01, "{kernel:?}: coverage mismatch {mismatch}");
            assert!(
                differ < tg.pixels().len() / 50,
                "{kernel:?}: {differ} pixels differ"
            );
            assert!(psnr > 25.0, "{kernel:?}: PSNR {psnr} dB");
        }
    }

    fn h_depth(grid: &TriGrid<'_>) -> u8 {
        grid.header().depth
    }

    #[test]
    fn a_camera_inside_the_cloud_draws_nothing_behind_it() {
        let bytes = knot_grid(3);
        let grid = TriGrid::open(&bytes, Verify::Full).unwrap();
        let cloud = LeafCloud::from_grid(&grid);
        let settings = Settings {
            view: camera::View::new(0.0, 0.0, 0.0001),
            ..Settings::default()
        };
        let mut out = FrameBuffers::new();
        let mut table = Box::new(ShadingTable::<1>::new());
        let r = cloud.render(&settings, &mut table, &mut out);
        let s = r.stats;
        assert_eq!(s.culled + s.backfacing + s.splats, s.nodes_visited, "{s:?}");
        assert!(s.culled > 0, "{s:?}");
    }

    /// A small scene: a checkerboard ground, scaled and turned, a tree (bark and leaves) tilted,
    /// turned and scaled, and a wall turned away from the view, so a wrong placement, normal
    /// rotation, scale or slot shows. The orbit sphere is the tree's (the ground is not in bounds).
    const SCENE_TOML: &str = r#"
fov = 45.0

[light]
az = -40.0
el = 55.0

[bake]
rho = 3
min_cell_px = 0.0

[materials.grass]
color = [0.34, 0.50, 0.24]

[materials.sand]
color = [0.85, 0.75, 0.50]

[materials.bark]
color = [0.42, 0.30, 0.20]

[materials.leaves]
color = [0.25, 0.55, 0.18]
specular = 0.3

[[objects]]
name = "ground"
ground = { size = 2.0, tiles = 4 }
materials = ["grass", "sand"]
depth = 4
scale = 1.3
rotate = { yaw = 20.0 }
in_bounds = false

[[objects]]
name = "tree"
tree = { seed = 5, levels = 3, branches = 3 }
materials = ["bark", "leaves"]
depth = 4
height = 1.1
rotate = { yaw = 35.0, pitch = 25.0, roll = -15.0 }
translate = [0.15, 0.0, -0.1]
anchor = "base"

# Seen from behind: its model normal (+Y) faces the eye, its world normal (-Z) away, so only a
# backface test with world normals culls it (the scene renderer's conservative per-frame test
# culls all of it too).
[[objects]]
name = "wall"
ground = { size = 0.8 }
material = "sand"
depth = 4
rotate = { pitch = -90.0 }
translate = [-0.2, 0.4, -0.7]
anchor = "center"

# Behind the tree, facing the eye: only depths over the range all objects share put it behind.
[[objects]]
name = "backdrop"
ground = { size = 0.9 }
material = "grass"
depth = 4
rotate = { pitch = 90.0 }
translate = [0.3, 0.5, -0.75]
anchor = "center"
"#;

    fn small_pack() -> Vec<u8> {
        let scene =
            crate::scene::SceneSpec::parse(std::path::Path::new("small.toml"), SCENE_TOML).unwrap();
        crate::scene::bake::bake_scene(&scene, &Default::default())
            .unwrap()
            .bytes
    }

    fn open_scene(bytes: &[u8]) -> Scene<'_> {
        let pack = pocketsplat_core::scene::Pack::open(bytes).unwrap();
        Scene::open(pack, Verify::Full).unwrap()
    }

    #[test]
    fn a_scene_cloud_holds_every_leaf_of_every_object_placed() {
        let bytes = small_pack();
        let scene = open_scene(&bytes);
        let cloud = SceneCloud::from_scene(&scene);
        assert_eq!(scene.len(), 4);
        assert_eq!(cloud.objects.len(), scene.len());
        let mut total = 0;
        for (i, o) in cloud.objects.iter().enumerate() {
            let grid = scene.grid(i).unwrap();
            let rec = scene.pack().object(i).unwrap();
            assert_eq!(o.range.start, total);
            assert_eq!(o.range.len(), grid.leaf_samples() as usize, "object {i}");
            total = o.range.end;
            assert_eq!(o.rotation, rec.placement.rotation);
            let model_leaf = LeafCloud::from_grid(grid).leaf_side;
            assert!((o.leaf_side - model_leaf * rec.placement.scale).abs() < 1e-12);
            // Placed: every leaf centre lies in the object's world box, widened by half a leaf's
            // diagonal.
            let b = scene.world_bounds(i).unwrap();
            let slack = 0.5 * 3f64.sqrt() * o.leaf_side + 1e-9;
            for p in &cloud.points[o.range.clone()] {
                for k in 0..3 {
                    assert!(
                        p[k] > b[0][k] - slack && p[k] < b[1][k] + slack,
                        "object {i}: {p:?} outside {b:?}"
                    );
                }
            }
            // Material bits are the object's slots.
            let slots = &rec.slots[..usize::from(rec.materials)];
            for &a in &cloud.attrs[o.range.clone()] {
                assert!(
                    slots.contains(&((a >> pocketsplat_core::normal::NORMAL_BITS) as u8)),
                    "object {i}: {a:#x}"
                );
            }
        }
        let leaves: u64 = (0..scene.len())
            .map(|i| u64::from(scene.grid(i).unwrap().leaf_samples()))
            .sum();
        assert_eq!(cloud.len() as u64, leaves);
        assert_eq!(cloud.attrs.len(), cloud.len());
    }

    /// As [`matches_the_trigrid_drawing_all_leaves`], for a scene: the scene renderer at a cutoff
    /// far below a pixel draws every object's leaves.
    #[test]
    fn matches_the_scene_renderer_drawing_all_leaves() {
        use crate::scene::render::{render_pack, scene_table, PackSettings};
        use pocketsplat_core::scene::ShadowMode;

        let bytes = small_pack();
        let scene = open_scene(&bytes);
        let cloud = SceneCloud {
            footprint: Footprint::Exact,
            ..SceneCloud::from_scene(&scene)
        };
        for kernel in [Kernel::Square, Kernel::Round] {
            let settings = PackSettings {
                cutoff_px: 0.01,
                kernel,
                shadows: Some(ShadowMode::Off),
                ..PackSettings::new(camera::View::new(30.0, 25.0, 2.2))
            };
            let mut real = FrameBuffers::new();
            let r = render_pack(&scene, &settings, &mut real).unwrap();
            let cam = settings.camera(&scene, [0.0; 3]);
            let opts = settings.options(&scene);
            let mut table = scene_table();
            let mut brute = FrameBuffers::new();
            let b = cloud.render(&scene, &cam, &opts, &mut table, &mut brute);
            // The ground, the tree and the backdrop are drawn down to their leaves; the wall faces
            // away.
            for i in [0, 1, 3] {
                let depth = scene.grid(i).unwrap().header().depth;
                assert_eq!(r.stats.objects[i].max_level, depth, "object {i}");
            }
            assert_eq!(r.stats.objects[2].splats, 0, "the wall faces away");
            assert_eq!(b.stats.nodes_visited as usize, cloud.len());
            assert!(b.stats.splats > 0 && b.stats.splats <= cloud.len() as u32);
            let s = b.stats;
            assert_eq!(s.culled + s.backfacing + s.splats, s.nodes_visited, "{s:?}");
            let covered = real.covered().iter().filter(|&&c| c).count();
            assert!(
                covered > real.pixels().len() / 5,
                "{kernel:?}: the scene covers only {covered} pixels"
            );
            let rgb = |f: &FrameBuffers| -> Vec<[u8; 3]> {
                f.pixels().iter().map(|&p| rgb565_to_rgb888(p)).collect()
            };
            let mismatch = coverage_mismatch(&real.covered(), &brute.covered());
            let psnr = psnr_rgb8(&rgb(&real), &rgb(&brute));
            let differ = real
                .pixels()
                .iter()
                .zip(brute.pixels())
                .filter(|(a, b)| a != b)
                .count();
            assert!(mismatch < 0.01, "{kernel:?}: coverage mismatch {mismatch}");
            assert!(
                differ < real.pixels().len() / 50,
                "{kernel:?}: {differ} pixels differ"
            );
            assert!(psnr > 25.0, "{kernel:?}: PSNR {psnr} dB");
        }
    }
}
