//! The float reference renderer: the original triangle mesh drawn in f64, the ground truth of every
//! error figure in the project.
//!
//! It uses the camera, light, materials and Phong model of the device renderer
//! ([`Camera`], [`shade::phong`]) and nothing else of it:
//!
//! - vertices go to camera space, triangles are clipped against the near plane (`camera.near`; the
//!   `close` view puts the eye inside the bounding sphere) and projected with [`Camera::screen`];
//! - each pixel is sampled once at its centre `(i + 0.5, j + 0.5)` with a top-left fill rule, so
//!   triangles sharing an edge cover every pixel of their union exactly once;
//! - a z-buffer keeps the nearest camera-space depth (the first triangle in mesh order wins a tie);
//! - the normal is the perspective-correct interpolation of the area-weighted vertex normals
//!   (computed like the baker: the sum of the unnormalised face cross products at each vertex),
//!   renormalised, and shaded with [`shade::phong`] with the viewer at `−camera.forward`. Both sides
//!   of a triangle are drawn and the interpolated normal is used as it is (no flip towards the eye);
//! - vertex colours, when the mesh has them, are interpolated the same way and replace the
//!   material's base colour;
//! - with [`ShadowRays`] ([`render_reference_shadowed`]), each visible sample casts an exact shadow
//!   ray against every triangle of the mesh (through a [`Bvh`]) towards a directional light or a
//!   point light; a blocked sample is shaded with its material's ambient term only, as the device
//!   shades a shadowed splat. The ray starts on the triangle, moved off its plane by 10⁻⁷ bounding
//!   radii towards the light's side, so a surface never shadows itself through rounding.
//!   [`shadow_light`] places that light where the integer renderer's [`Settings`] put theirs.
//!
//! Each pixel is also classified lit or unlit ([`RefImage::shadowed`]): unlit when the interpolated
//! normal faces away from the light (`n·l ≤ 0`, an attached shadow) or, when rays are cast, the ray
//! is blocked (a cast shadow). The device renderer's classification is compared with it by
//! [`crate::metrics::shadow_disagreement`].
//!
//! Work is split into setup (per vertex, then per triangle, in parallel) and raster (per band of
//! rows, in parallel); the result does not depend on the number of threads.
//!
//! # Example
//!
//! ```
//! use pocketsplat_core::bake::TriMesh;
//! use pocketsplat_core::camera::{self, Camera, Sphere, View};
//! use pocketsplat_core::shade::DEFAULT_MATERIAL;
//! use pocketsplat_sim::reference::render_reference;
//!
//! let mesh = TriMesh {
//!     positions: vec![[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [0.0, 1.0, 0.0]],
//!     triangles: vec![[0, 1, 2]],
//!     ..TriMesh::default()
//! };
//! let cam = Camera::orbit(Sphere::from_bounds(mesh.bounds_f32()), View::new(0.0, 0.0, 3.0), 45.0);
//! let img = render_reference(&mesh, &cam, &[DEFAULT_MATERIAL], camera::direction(0.0, 0.0));
//! assert!(img.covered[camera::WIDTH * 160 + 120]); // the centre of the 240 × 320 frame
//! ```

use pocketsplat_core::bake::TriMesh;
use pocketsplat_core::camera::{self, Camera, Sphere, Vec3, Viewport};
use pocketsplat_core::shade::{self, Material, DEFAULT_MATERIAL};
use rayon::prelude::*;

use crate::bvh::Bvh;
use crate::render::{Settings, ShadowMode};

/// Rows per raster band (the unit of parallel work).
const BAND_ROWS: usize = 8;

/// A frame of the reference renderer, row-major, one entry per pixel of the camera's viewport per
/// field (240 × 320 by default).
#[derive(Clone, Debug, PartialEq)]
pub struct RefImage {
    /// Linear colour, 0..=1 per channel; black where nothing is drawn.
    pub rgb: Vec<[f64; 3]>,
    /// Whether a triangle covers the pixel centre.
    pub covered: Vec<bool>,
    /// Camera-space depth (distance along `camera.forward`, model units) at the pixel centre;
    /// `f64::INFINITY` where nothing is drawn.
    pub depth: Vec<f64>,
    /// Covered and unlit: the normal faces away from the light, or (with shadow rays) the ray to the
    /// light is blocked.
    pub shadowed: Vec<bool>,
}

impl RefImage {
    /// A frame of `viewport`'s size with nothing drawn: black, uncovered, infinitely far.
    pub fn empty(viewport: Viewport) -> Self {
        let n = viewport.pixels();
        Self {
            rgb: vec![[0.0; 3]; n],
            covered: vec![false; n],
            depth: vec![f64::INFINITY; n],
            shadowed: vec![false; n],
        }
    }

    /// The colours as 8-bit RGB ([`linear_to_rgb8`] per pixel), row-major.
    pub fn to_rgb8(&self) -> Vec<[u8; 3]> {
        self.rgb.iter().map(|&c| linear_to_rgb8(c)).collect()
    }

    /// The colours packed as RGB565 with [`shade::to_rgb565`], as the device would store them.
    pub fn to_rgb565(&self) -> Vec<u16> {
        self.rgb.iter().map(|&c| shade::to_rgb565(c)).collect()
    }

    /// Number of covered pixels.
    pub fn covered_count(&self) -> usize {
        self.covered.iter().filter(|&&c| c).count()
    }

    /// Number of covered pixels that are unlit.
    pub fn shadowed_count(&self) -> usize {
        self.shadowed.iter().filter(|&&c| c).count()
    }
}

/// Where shadow rays go, in model coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ShadowLight {
    /// A directional light: rays towards this direction (need not be unit), unbounded.
    Directional(Vec3),
    /// A point light at this position: rays end there.
    Point(Vec3),
}

/// Exact shadow rays: the mesh's hierarchy (built once, [`Bvh::new`]) and the light they go to.
#[derive(Clone, Copy, Debug)]
pub struct ShadowRays<'a> {
    /// The hierarchy over the same mesh that is rendered.
    pub bvh: &'a Bvh,
    /// Where the rays go.
    pub light: ShadowLight,
}

/// A linear 0..=1 colour as 8-bit RGB: `round(255 · c)` per channel, clamped to 0..=255.
pub fn linear_to_rgb8(c: [f64; 3]) -> [u8; 3] {
    c.map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8)
}

/// Area-weighted vertex normals, as the baker computes them: each vertex gets the sum of the
/// unnormalised cross products `(b − a) × (c − a)` of the triangles that use it (their length is
/// twice the triangle's area). Zero-area triangles add nothing. The sums are not normalised.
///
/// # Panics
/// When a triangle refers to a vertex that does not exist.
pub fn vertex_normals(mesh: &TriMesh) -> Vec<Vec3> {
    let mut normals = vec![[0.0; 3]; mesh.positions.len()];
    // Serial and in mesh order, so the sums are the same bits as the baker's.
    for idx in &mesh.triangles {
        let n = face_cross(mesh, idx);
        if camera::dot(n, n) > 0.0 {
            for &i in idx {
                let v = &mut normals[i as usize];
                *v = camera::add(*v, n);
            }
        }
    }
    normals
}

fn face_cross(mesh: &TriMesh, idx: &[u32; 3]) -> Vec3 {
    let [a, b, c] = idx.map(|i| mesh.positions[i as usize]);
    camera::cross(camera::sub(b, a), camera::sub(c, a))
}

/// Renders `mesh` as seen by `camera`, lit by a directional light towards `light_dir`.
///
/// - `materials[k]` is the material of the triangles whose material index is `k` (index 0 when the
///   mesh has no material list); an index past the end uses the last material, and an empty slice
///   means [`DEFAULT_MATERIAL`] for every triangle (the rule of the device's shading table).
/// - `light_dir` points from the surface to the light in model coordinates (e.g.
///   `camera::direction(az, el)`); it is normalised here.
/// - Vertex colours `[u8; 3]` are taken as linear `c / 255` and replace the material's base colour.
///
/// Zero-area triangles are not drawn. Triangles with a non-finite vertex are skipped.
///
/// # Panics
/// When a triangle refers to a vertex that does not exist, or the material or colour list is shorter
/// than the triangle or vertex list ([`TriMesh::validate`] rejects such meshes).
pub fn render_reference(
    mesh: &TriMesh,
    camera: &Camera,
    materials: &[Material],
    light_dir: Vec3,
) -> RefImage {
    render_reference_shadowed(mesh, camera, materials, light_dir, None)
}

/// [`render_reference`] with exact shadows when `shadows` is given: every visible sample whose ray
/// to the light meets a triangle is shaded with its material's ambient term only and marked in
/// [`RefImage::shadowed`]. `light_dir` is still the shading direction (for a point light, the
/// direction from the model to the light, as on the device).
///
/// # Panics
/// As [`render_reference`].
pub fn render_reference_shadowed(
    mesh: &TriMesh,
    camera: &Camera,
    materials: &[Material],
    light_dir: Vec3,
    shadows: Option<&ShadowRays<'_>>,
) -> RefImage {
    let normals = vertex_normals(mesh);
    let colors: Option<Vec<Vec3>> = mesh.colors.as_ref().map(|cols| {
        cols.iter()
            .map(|c| c.map(|v| f64::from(v) / 255.0))
            .collect()
    });
    // Camera space, once per vertex, so a vertex shared by several triangles has the same bits in
    // each of them (watertight edges).
    let cam: Vec<Vec3> = mesh
        .positions
        .par_iter()
        .map(|&p| camera.to_camera(p))
        .collect();
    let setup = Setup {
        mesh,
        camera,
        cam: &cam,
        normals: &normals,
        colors: colors.as_deref(),
    };
    let prims: Vec<Prim> = (0..mesh.triangles.len())
        .into_par_iter()
        .flat_map_iter(|t| setup.triangle(t))
        .collect();

    // Bin primitives into bands of rows, keeping mesh order inside each band.
    let pixels = camera.viewport.pixels();
    let bands = usize::from(camera.viewport.height).div_ceil(BAND_ROWS);
    let mut bins: Vec<Vec<u32>> = vec![Vec::new(); bands];
    for (k, p) in prims.iter().enumerate() {
        for bin in &mut bins[p.rows.0 / BAND_ROWS..=p.rows.1 / BAND_ROWS] {
            bin.push(k as u32);
        }
    }

    let l = camera::normalize(light_dir);
    let v = camera::scale(camera.forward, -1.0);
    let shading = Shading {
        materials: if materials.is_empty() {
            std::slice::from_ref(&DEFAULT_MATERIAL)
        } else {
            materials
        },
        l,
        v,
        camera,
        shadows: shadows.copied(),
        offset: 1e-7 * Sphere::from_bounds(mesh.bounds_f32()).radius,
    };
    let band_images: Vec<RefImage> = bins
        .par_iter()
        .enumerate()
        .map(|(b, bin)| raster_band(b * BAND_ROWS, &prims, bin, &shading))
        .collect();

    let mut out = RefImage {
        rgb: Vec::with_capacity(pixels),
        covered: Vec::with_capacity(pixels),
        depth: Vec::with_capacity(pixels),
        shadowed: Vec::with_capacity(pixels),
    };
    for band in band_images {
        out.rgb.extend(band.rgb);
        out.covered.extend(band.covered);
        out.depth.extend(band.depth);
        out.shadowed.extend(band.shadowed);
    }
    out
}

/// A vertex of a primitive: camera-space position and the attributes to interpolate.
#[derive(Clone, Copy, Debug)]
struct ClipVertex {
    /// Camera-space position.
    cam: Vec3,
    /// Area-weighted normal (not normalised).
    normal: Vec3,
    /// Linear colour, when the mesh has vertex colours.
    color: Vec3,
}

/// A screen-space triangle ready to rasterize: a mesh triangle, or part of one after clipping.
#[derive(Clone, Copy, Debug)]
struct Prim {
    /// Screen positions (pixels, y down), ordered so that [`edge`] is ≥ 0 inside.
    screen: [[f64; 2]; 3],
    /// Camera-space positions (z ≥ `camera.near`).
    cam: [Vec3; 3],
    /// Vertex normals (not normalised).
    normal: [Vec3; 3],
    /// Vertex colours (linear), or `None` to use the material's colour.
    color: Option<[Vec3; 3]>,
    /// Face normal (fallback when the interpolated normal vanishes).
    face: Vec3,
    /// Material index.
    material: u8,
    /// Rows whose centres the bounding box contains (inclusive).
    rows: (usize, usize),
    /// Columns whose centres the bounding box contains (inclusive).
    cols: (usize, usize),
}

/// Per-frame data shared by the setup of every triangle.
struct Setup<'a> {
    mesh: &'a TriMesh,
    camera: &'a Camera,
    cam: &'a [Vec3],
    normals: &'a [Vec3],
    colors: Option<&'a [Vec3]>,
}

impl Setup<'_> {
    /// The primitives of triangle `t`: none (zero area, behind the near plane, off screen or
    /// covering no pixel centre), one, or two (a quadrilateral left by the near plane).
    fn triangle(&self, t: usize) -> impl Iterator<Item = Prim> {
        let mut out = [None, None];
        let idx = self.mesh.triangles[t];
        let face = face_cross(self.mesh, &idx);
        if camera::dot(face, face) > 0.0 {
            let material = self.mesh.materials.as_ref().map_or(0, |m| m[t]);
            let vertex = |i: u32| {
                let i = i as usize;
                ClipVertex {
                    cam: self.cam[i],
                    normal: self.normals[i],
                    color: self.colors.map_or([0.0; 3], |c| c[i]),
                }
            };
            let near = self.camera.near;
            let verts = idx.map(|i| (i, vertex(i)));
            let has_color = self.colors.is_some();
            let mut make = |k: usize, tri: [ClipVertex; 3]| {
                out[k] = self.prim(tri, face, material, has_color);
            };
            if verts.iter().all(|(_, v)| v.cam[2] >= near) {
                make(0, verts.map(|(_, v)| v));
            } else if verts.iter().any(|(_, v)| v.cam[2] >= near) {
                // Sutherland–Hodgman against z ≥ near: a triangle or a quadrilateral.
                let mut poly: [ClipVertex; 4] = [verts[0].1; 4];
                let mut n = 0;
                for k in 0..3 {
                    let (ia, a) = verts[k];
                    let (ib, b) = verts[(k + 1) % 3];
                    let (ina, inb) = (a.cam[2] >= near, b.cam[2] >= near);
                    if ina {
                        poly[n] = a;
                        n += 1;
                    }
                    if ina != inb {
                        poly[n] = clip_point((ia, a), (ib, b), near);
                        n += 1;
                    }
                }
                make(0, [poly[0], poly[1], poly[2]]);
                if n == 4 {
                    make(1, [poly[0], poly[2], poly[3]]);
                }
            }
        }
        out.into_iter().flatten()
    }

    fn prim(&self, v: [ClipVertex; 3], face: Vec3, material: u8, has_color: bool) -> Option<Prim> {
        let mut screen = v.map(|v| {
            let s = self.camera.screen(v.cam[0], v.cam[1], v.cam[2]);
            [s[0], s[1]]
        });
        if screen.iter().flatten().any(|c| !c.is_finite()) {
            return None;
        }
        let mut order = [0, 1, 2];
        let area = edge(screen[0], screen[1], screen[2]);
        if area == 0.0 || area.is_nan() {
            return None;
        }
        // Both sides are drawn: make every primitive wind the same way on screen, so the edge
        // functions are ≥ 0 inside and the top-left rule has one meaning.
        if area < 0.0 {
            order = [0, 2, 1];
            screen = order.map(|k| screen[k]);
        }
        let min = |a: usize| screen.iter().map(|s| s[a]).fold(f64::INFINITY, f64::min);
        let max = |a: usize| {
            screen
                .iter()
                .map(|s| s[a])
                .fold(f64::NEG_INFINITY, f64::max)
        };
        let view = self.camera.viewport;
        let cols = centre_range(min(0), max(0), usize::from(view.width))?;
        let rows = centre_range(min(1), max(1), usize::from(view.height))?;
        let v = order.map(|k| v[k]);
        Some(Prim {
            screen,
            cam: v.map(|v| v.cam),
            normal: v.map(|v| v.normal),
            color: has_color.then(|| v.map(|v| v.color)),
            face,
            material,
            rows,
            cols,
        })
    }
}

/// The point where the edge between two vertices crosses `z = near`, computed from the vertex with
/// the lower mesh index, so that the two triangles sharing the edge get the same bits.
fn clip_point(a: (u32, ClipVertex), b: (u32, ClipVertex), near: f64) -> ClipVertex {
    let ((_, p), (_, q)) = if a.0 <= b.0 { (a, b) } else { (b, a) };
    let t = (near - p.cam[2]) / (q.cam[2] - p.cam[2]);
    let lerp = |x: Vec3, y: Vec3| camera::add(x, camera::scale(camera::sub(y, x), t));
    let mut cam = lerp(p.cam, q.cam);
    // Exactly on the plane, whatever the rounding.
    cam[2] = near;
    ClipVertex {
        cam,
        normal: lerp(p.normal, q.normal),
        color: lerp(p.color, q.color),
    }
}

/// The indices `i` in `0..len` with `min ≤ i + 0.5 ≤ max`, or `None` when there are none.
fn centre_range(min: f64, max: f64, len: usize) -> Option<(usize, usize)> {
    let lo = (min - 0.5).ceil().max(0.0);
    let hi = (max - 0.5).floor().min(len as f64 - 1.0);
    (lo <= hi).then_some((lo as usize, hi as usize))
}

/// Twice the signed area of `(a, b, p)` in screen coordinates (y down): > 0 when `p` lies to the
/// right of `a → b` as seen on the screen (clockwise on screen).
///
/// Evaluated from the lexicographically smaller endpoint, and negated when the edge is given the
/// other way round, so the two triangles sharing an edge get exactly opposite values: with the
/// top-left rule no pixel centre is then missed or drawn twice along the edge.
fn edge(a: [f64; 2], b: [f64; 2], p: [f64; 2]) -> f64 {
    let raw =
        |a: [f64; 2], b: [f64; 2]| (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]);
    if (a[0], a[1]) <= (b[0], b[1]) {
        raw(a, b)
    } else {
        -raw(b, a)
    }
}

/// Whether a pixel centre exactly on edge `a → b` belongs to the triangle (top-left rule): the edge
/// is a top edge (horizontal, interior below) or a left edge (interior to its right on screen).
/// With the winding of [`Prim::screen`], those are the edges going right along a row or going up.
fn top_left(a: [f64; 2], b: [f64; 2]) -> bool {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    (dy == 0.0 && dx > 0.0) || dy < 0.0
}

/// Materials, light, viewer and shadow rays of a frame.
struct Shading<'a> {
    materials: &'a [Material],
    l: Vec3,
    v: Vec3,
    camera: &'a Camera,
    shadows: Option<ShadowRays<'a>>,
    /// How far a ray's origin is moved off its triangle, model units.
    offset: f64,
}

/// Rasterizes the primitives of one band (rows `y0 ..`), then shades the visible samples.
fn raster_band(y0: usize, prims: &[Prim], bin: &[u32], shading: &Shading<'_>) -> RefImage {
    let (width, height) = (
        usize::from(shading.camera.viewport.width),
        usize::from(shading.camera.viewport.height),
    );
    let rows = BAND_ROWS.min(height - y0);
    let n = rows * width;
    let mut depth = vec![f64::INFINITY; n];
    // Winning primitive and its perspective-correct barycentric weights, shaded at the end so that
    // overdrawn samples cost no Phong evaluation.
    let mut winner: Vec<Option<(u32, [f64; 3])>> = vec![None; n];
    for &k in bin {
        let p = &prims[k as usize];
        let [s0, s1, s2] = p.screen;
        let inc = [top_left(s1, s2), top_left(s2, s0), top_left(s0, s1)];
        for y in p.rows.0.max(y0)..=p.rows.1.min(y0 + rows - 1) {
            let py = y as f64 + 0.5;
            for x in p.cols.0..=p.cols.1 {
                let q = [x as f64 + 0.5, py];
                // e[i]: the edge opposite vertex i, proportional to its barycentric coordinate.
                let e = [edge(s1, s2, q), edge(s2, s0, q), edge(s0, s1, q)];
                if !(0..3).all(|i| e[i] > 0.0 || (e[i] == 0.0 && inc[i])) {
                    continue;
                }
                // 1/z is affine on the screen: weights b_i / z_i, normalised, are the
                // perspective-correct barycentrics, and their sum's inverse is the depth.
                let w = [e[0] / p.cam[0][2], e[1] / p.cam[1][2], e[2] / p.cam[2][2]];
                let s = w[0] + w[1] + w[2];
                let z = (e[0] + e[1] + e[2]) / s;
                let i = (y - y0) * width + x;
                if z < depth[i] {
                    depth[i] = z;
                    winner[i] = Some((k, w.map(|w| w / s)));
                }
            }
        }
    }
    let mut rgb = vec![[0.0; 3]; n];
    let mut shadowed = vec![false; n];
    for ((c, sh), w) in rgb.iter_mut().zip(&mut shadowed).zip(&winner) {
        if let Some((k, w)) = *w {
            (*c, *sh) = shade_sample(&prims[k as usize], w, shading);
        }
    }
    RefImage {
        rgb,
        covered: winner.iter().map(Option::is_some).collect(),
        depth,
        shadowed,
    }
}

fn interpolate(a: &[Vec3; 3], w: [f64; 3]) -> Vec3 {
    std::array::from_fn(|c| w[0] * a[0][c] + w[1] * a[1][c] + w[2] * a[2][c])
}

/// The Phong colour of a primitive at perspective-correct barycentrics `w`, and whether the sample
/// is unlit (facing away from the light, or its shadow ray blocked).
fn shade_sample(p: &Prim, w: [f64; 3], s: &Shading<'_>) -> ([f64; 3], bool) {
    let mut n = interpolate(&p.normal, w);
    if camera::dot(n, n) == 0.0 {
        n = p.face;
    }
    let n = camera::normalize(n);
    let mut m = s.materials[usize::from(p.material).min(s.materials.len() - 1)];
    if let Some(c) = &p.color {
        m.color = interpolate(c, w).map(|v| v as f32);
    }
    let facing_away = camera::dot(n, s.l) <= 0.0;
    if !facing_away && s.shadows.is_some_and(|rays| blocked(p, w, s, &rays)) {
        m.diffuse = 0.0;
        m.specular = 0.0;
        return (shade::phong(&m, n, s.l, s.v), true);
    }
    (shade::phong(&m, n, s.l, s.v), facing_away)
}

/// Whether the ray from the sample at barycentrics `w` of `p` to the light meets the mesh.
fn blocked(p: &Prim, w: [f64; 3], s: &Shading<'_>, rays: &ShadowRays<'_>) -> bool {
    let c = interpolate(&p.cam, w);
    let cam = s.camera;
    let point = camera::add(
        camera::add(cam.eye, camera::scale(cam.right, c[0])),
        camera::add(
            camera::scale(cam.up, c[1]),
            camera::scale(cam.forward, c[2]),
        ),
    );
    let towards = |q: Vec3| match rays.light {
        ShadowLight::Directional(d) => d,
        ShadowLight::Point(at) => camera::sub(at, q),
    };
    // Off the triangle's plane, on the light's side of it.
    let face = camera::normalize(p.face);
    let side = if camera::dot(face, towards(point)) >= 0.0 {
        1.0
    } else {
        -1.0
    };
    let origin = camera::add(point, camera::scale(face, side * s.offset));
    let (dir, t_max) = match rays.light {
        ShadowLight::Directional(d) => (d, f64::INFINITY),
        ShadowLight::Point(at) => (camera::sub(at, origin), 1.0),
    };
    rays.bvh.occluded(origin, dir, 0.0, t_max)
}

/// Where the reference renderer's shadow rays go for these settings and a model with these bounds:
/// `None` without shadows.
pub fn shadow_light(settings: &Settings, bounds: [[f32; 3]; 2]) -> Option<ShadowLight> {
    if settings.shadows == ShadowMode::Off {
        return None;
    }
    Some(match settings.light_position(bounds) {
        Some(at) => ShadowLight::Point(at),
        None => ShadowLight::Directional(settings.light_dir()),
    })
}
