//! LOD / footprint laboratory (f64 oracle traversals against the reference). Not a product.
use std::path::Path;

use pocketsplat_core::camera::{self, Camera, Vec3, HEIGHT, WIDTH};
use pocketsplat_core::normal::{NORMALS_Q14, NORMAL_COUNT};
use pocketsplat_core::shade::{rgb565_to_rgb888, ShadingTable, DEFAULT_MATERIAL};
use pocketsplat_core::tg::{TriGrid, Verify};
use pocketsplat_sim::metrics::psnr_rgb8;
use pocketsplat_sim::reference::{render_reference, RefImage};
use pocketsplat_sim::render::{FrameBuffers, Settings};

struct Oracle<'a> {
    grid: &'a TriGrid<'a>,
    cam: Camera,
    table: &'a ShadingTable<1>,
    origin: Vec3,
    side: f64,
    rho: u32,
    depth: u8,
    cutoff: f64,
    mode: Mode,
    color: Vec<u16>,
    z: Vec<f64>,
    nodes: u64,
    splats: u64,
    back: u64,
    /// per level, per cell: cone half-angle (radians), None = not computed
    cones: Option<Vec<Vec<f64>>>,
    cone_culled: u64,
    /// quantised classes (upper bounds, radians); empty = exact
    classes: Vec<f64>,
    /// occlusion stats: front-facing splats that wrote nothing
    wrote_nothing: u64,
    /// oracle occlusion: final z-buffer of a previous pass
    final_z: Option<Vec<f64>>,
    occl: [u64; 8],
    who: Vec<(u8, u32)>,
}

#[derive(Clone, Copy, Debug)]
struct Mode {
    /// LOD on side (true) or √3 side (false)
    side_lod: bool,
    /// splat side factor times projected side; 0 = single pixel
    size_factor: f64,
    /// place at centroid of children
    centroid: bool,
    /// exact backface
    exact_back: bool,
    round: bool,
    /// no min-one-pixel fallback
    strict: bool,
    /// silhouette cells: refine until side <= cutoff * sil
    sil: f64,
    /// lod factor on side (stop when side*lodk <= cutoff)
    lodk: f64,
    /// centroid quantisation: steps per cell (3 = nearest child slot); 0 = exact
    cq: f64,
}

impl Oracle<'_> {
    fn walk(&mut self, level: u8, index: u32, ijk: [u32; 3], first_child: u32) {
        self.nodes += 1;
        let cell = self.side / f64::from(self.rho).powi(i32::from(level));
        let c: Vec3 = std::array::from_fn(|k| self.origin[k] + (f64::from(ijk[k]) + 0.5) * cell);
        let [x, y, z] = self.cam.to_camera(c);
        let r = cell * 0.87;
        if z + r < self.cam.near {
            return;
        }
        let proj = self.cam.focal_px * cell / z.max(1e-9);
        let mut lod = if self.mode.side_lod { proj * self.mode.lodk } else { proj * 3f64.sqrt() };
        if self.mode.sil > 0.0 && level < self.depth {
            // silhouette: the cone of normals (with the cell's angular size) straddles the view ray
            let th = self.cones.as_ref().map_or(0.0, |c| c[usize::from(level)][index as usize]);
            let attr = self.grid.attr(level, index);
            let a = NORMALS_Q14[usize::from(attr) & (NORMAL_COUNT - 1)].map(|q| f64::from(q) / 16384.0);
            let v = camera::sub(c, self.cam.eye);
            let vl = camera::dot(v, v).sqrt();
            let al = (camera::dot(a, v) / vl / camera::dot(a, a).sqrt()).clamp(-1.0, 1.0).acos();
            let phi = (r / vl).min(1.0).asin();
            if (al - std::f64::consts::FRAC_PI_2).abs() <= th + phi {
                lod /= self.mode.sil;
            }
        }
        let mask = self.grid.mask(level, index) as u32;
        if let Some(fz) = &self.final_z {
            // bbox of the cube's 8 corners
            let (mut x0, mut x1, mut y0, mut y1, mut zmin) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN, f64::MAX);
            let mut ok = true;
            for corner in 0..8 {
                let p: Vec3 = std::array::from_fn(|k| c[k] + if corner >> k & 1 != 0 { 0.5 } else { -0.5 } * cell);
                let [a, b, zz] = self.cam.to_camera(p);
                if zz < self.cam.near { ok = false; break; }
                let sc = self.cam.screen(a, b, zz);
                x0 = x0.min(sc[0]); x1 = x1.max(sc[0]); y0 = y0.min(sc[1]); y1 = y1.max(sc[1]); zmin = zmin.min(zz);
            }
            if ok && level > 0 {
                let (px0, px1) = ((x0 - 0.5).ceil().max(0.0) as i64, ((x1 - 0.5).ceil().min(WIDTH as f64)) as i64);
                let (py0, py1) = ((y0 - 0.5).ceil().max(0.0) as i64, ((y1 - 0.5).ceil().min(HEIGHT as f64)) as i64);
                let mut hidden = true;
                'o: for py in py0..py1 { for px in px0..px1 { if fz[py as usize * WIDTH + px as usize] >= zmin { hidden = false; break 'o; } } }
                if hidden { self.occl[usize::from(level)] += 1; return; }
            }
        }
        if let Some(cones) = &self.cones {
            if level < self.depth {
                let mut th = cones[usize::from(level)][index as usize];
                if !self.classes.is_empty() {
                    th = *self.classes.iter().find(|&&c| c >= th).unwrap_or(&10.0);
                }
                let attr = self.grid.attr(level, index);
                let a = NORMALS_Q14[usize::from(attr) & (NORMAL_COUNT - 1)].map(|q| f64::from(q) / 16384.0);
                let v = camera::sub(c, self.cam.eye);
                let vl = camera::dot(v, v).sqrt();
                let al = (camera::dot(a, v) / vl / camera::dot(a, a).sqrt()).clamp(-1.0, 1.0).acos();
                let ang = (al + th).min(std::f64::consts::PI);
                if vl * ang.cos() > r {
                    self.cone_culled += 1;
                    return;
                }
            }
        }
        let stop = if self.mode.lodk < 0.0 {
            proj <= (self.cutoff / 3f64.sqrt()).max(self.cutoff.min(1.0))
        } else {
            lod <= self.cutoff
        };
        if level == self.depth || (z - r > 0.0 && stop) {
            self.draw(level, index, c, cell, mask, [x, y, z]);
            return;
        }
        let mut grand = if level + 1 < self.depth { self.grid.group(level, index) } else { 0 };
        let mut child = first_child;
        let mut m = mask;
        while m != 0 {
            let s = m.trailing_zeros();
            m &= m - 1;
            let rho = self.rho;
            let cijk = [ijk[0] * rho + s % rho, ijk[1] * rho + (s / rho) % rho, ijk[2] * rho + s / (rho * rho)];
            let cm = if level + 1 < self.depth { self.grid.mask(level + 1, child) as u32 } else { 0 };
            self.walk(level + 1, child, cijk, grand);
            grand += cm.count_ones();
            child += 1;
        }
    }

    fn draw(&mut self, level: u8, index: u32, c: Vec3, cell: f64, mask: u32, _xyz: Vec3) {
        let attr = self.grid.attr(level, index);
        let n = NORMALS_Q14[usize::from(attr) & (NORMAL_COUNT - 1)].map(f64::from);
        let mut p = c;
        if self.mode.centroid && level < self.depth {
            let rho = self.rho;
            let (mut sum, mut k) = ([0.0; 3], 0.0);
            let mut m = mask;
            while m != 0 {
                let s = m.trailing_zeros();
                m &= m - 1;
                let o = [s % rho, (s / rho) % rho, s / (rho * rho)];
                for a in 0..3 {
                    sum[a] += (f64::from(o[a]) + 0.5) / f64::from(rho) - 0.5;
                }
                k += 1.0;
            }
            let q = self.mode.cq;
            for a in 0..3 {
                let mut f = sum[a] / k; // in cell units, within [-1/3, 1/3]
                if q > 0.0 { f = (f * q).round() / q; }
                p[a] += f * cell;
            }
        }
        let d = camera::sub(p, self.cam.eye);
        if self.mode.exact_back && camera::dot(n, d) > 0.0 {
            self.back += 1;
            return;
        }
        let [x, y, z] = self.cam.to_camera(p);
        if z < self.cam.near {
            return;
        }
        let s = self.cam.screen(x, y, z);
        self.splats += 1;
        let color = self.table.color(attr);
        let mut wrote = false;
        let size = self.cam.focal_px * cell / z * self.mode.size_factor;
        let half = size / 2.0;
        let (x0, x1, y0, y1) = if size <= 0.0 {
            let (px, py) = (s[0].floor(), s[1].floor());
            (px, px + 1.0, py, py + 1.0)
        } else {
            // pixels whose centres i+0.5 in [s-half, s+half)
            let f = |v: f64| (v - half - 0.5).ceil();
            let e = |v: f64| (v + half - 0.5).ceil();
            let (a, b, cc, dd) = (f(s[0]), e(s[0]), f(s[1]), e(s[1]));
            if (b <= a || dd <= cc) && !self.mode.strict {
                let (px, py) = (s[0].floor(), s[1].floor());
                (px, px + 1.0, py, py + 1.0)
            } else {
                (a, b, cc, dd)
            }
        };
        for py in (y0.max(0.0) as i64)..(y1.min(HEIGHT as f64) as i64) {
            for px in (x0.max(0.0) as i64)..(x1.min(WIDTH as f64) as i64) {
                if self.mode.round && size > 1.0 {
                    let dx = px as f64 + 0.5 - s[0];
                    let dy = py as f64 + 0.5 - s[1];
                    if dx * dx + dy * dy > half * half {
                        continue;
                    }
                }
                let i = py as usize * WIDTH + px as usize;
                let _ = wrote;
                if z < self.z[i] {
                    self.z[i] = z;
                    self.color[i] = color;
                    self.who[i] = (level, index);
                    wrote = true;
                }
            }
        }
        if !wrote {
            self.wrote_nothing += 1;
        }
    }
}

/// per level, per cell, the max angle between its normal and any descendant's normal
fn cones(grid: &TriGrid<'_>) -> Vec<Vec<f64>> {
    let h = grid.header();
    let nrm = |l: u8, i: u32| {
        let q = NORMALS_Q14[usize::from(grid.attr(l, i)) & (NORMAL_COUNT - 1)].map(|q| f64::from(q));
        let n = camera::dot(q, q).sqrt();
        q.map(|c| c / n)
    };
    // parent index per level
    let mut parent: Vec<Vec<u32>> = vec![vec![]];
    for l in 0..h.depth {
        let mut p = Vec::new();
        for i in 0..grid.level(l).count {
            for _ in 0..(grid.mask(l, i) as u32).count_ones() {
                p.push(i);
            }
        }
        parent.push(p);
    }
    let mut cones: Vec<Vec<f64>> = (0..=h.depth).map(|l| vec![0.0; grid.level(l).count as usize]).collect();
    for l in 1..=h.depth {
        for i in 0..grid.level(l).count {
            let n = nrm(l, i);
            let (mut al, mut ai) = (l - 1, parent[usize::from(l)][i as usize]);
            loop {
                let a = nrm(al, ai);
                let ang = camera::dot(a, n).clamp(-1.0, 1.0).acos();
                let c = &mut cones[usize::from(al)][ai as usize];
                if ang > *c { *c = ang; }
                if al == 0 { break; }
                ai = parent[usize::from(al)][ai as usize];
                al -= 1;
            }
        }
    }
    cones
}

fn score(reference: &RefImage, color: &[u16], covered: &[bool]) -> (f64, usize, usize, f64) {
    let rgb: Vec<[u8; 3]> = color.iter().map(|&p| rgb565_to_rgb888(p)).collect();
    let ref_rgb = reference.to_rgb8();
    let psnr = psnr_rgb8(&ref_rgb, &rgb);
    let (mut only_ref, mut only_us) = (0, 0);
    let mut sse_cov = 0.0;
    for i in 0..color.len() {
        let (a, b) = (reference.covered[i], covered[i]);
        if a && !b {
            only_ref += 1;
        }
        if b && !a {
            only_us += 1;
        }
        if a != b {
            for c in 0..3 {
                sse_cov += (f64::from(ref_rgb[i][c]) - f64::from(rgb[i][c])).powi(2);
            }
        }
    }
    let total: f64 = (0..color.len())
        .map(|i| (0..3).map(|c| (f64::from(ref_rgb[i][c]) - f64::from(rgb[i][c])).powi(2)).sum::<f64>())
        .sum();
    (psnr, only_ref, only_us, sse_cov / total)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let tg = args.get(1).map(String::as_str).unwrap_or("/tmp/m/bunny.tg");
    let mesh_path = args.get(2).map(String::as_str).unwrap_or("../shared/models/bun_zipper.ply.gz");
    let views: Vec<String> = args.get(3).map(|v| v.split(',').map(String::from).collect()).unwrap_or(vec!["std".into()]);
    let bytes = std::fs::read(tg).unwrap();
    let grid = TriGrid::open(&bytes, Verify::Structure).unwrap();
    let mesh = pocketsplat_sim::ply::load_mesh(Path::new(mesh_path)).unwrap();
    let h = *grid.header();
    let cone_data = cones(&grid);
    for l in 0..h.depth {
        let c = &cone_data[usize::from(l)];
        let mut hist = [0usize; 10];
        for &a in c { hist[((a.to_degrees() / 10.0) as usize).min(9)] += 1; }
        println!("level {l}: cone hist (10 deg bins) {hist:?}");
    }
    for vname in &views {
        let settings = Settings { view: camera::standard_view(vname).unwrap(), ..Settings::default() };
        let cam = settings.camera(h.bounds);
        let reference = render_reference(&mesh, &cam, &[DEFAULT_MATERIAL], settings.light_dir());
        let mut table = Box::new(ShadingTable::<1>::new());
        table.update(&[DEFAULT_MATERIAL], settings.light_dir(), camera::scale(cam.forward, -1.0));
        // Today's renderer
        for cutoff in std::env::var("LAB_CUTS").map(|v| v.split(',').map(|c| c.parse().unwrap()).collect::<Vec<f32>>()).unwrap_or(vec![1.0f32, 2.0, 4.0, 8.0]) {
            let mut out = FrameBuffers::new();
            let s = Settings { cutoff_px: cutoff, ..settings };
            let rep = pocketsplat_sim::render::render_tg_frame(&grid, &s, &mut out).unwrap();
            let (p, a, b, f) = score(&reference, out.pixels(), &out.covered());
            println!("{vname} today cutoff {cutoff}: psnr {p:.3} refonly {a} usonly {b} covfrac {f:.2} nodes {} splats {}", rep.stats.nodes_visited, rep.stats.splats);
        }
        let m = |side_lod, size_factor, centroid, round, strict| Mode { side_lod, size_factor, centroid, exact_back: true, round, strict, sil: 0.0, lodk: 1.0, cq: 0.0 };
        let modes0 = [
            ("side-lod pixel exact", 1.0, m(true, 0.0, false, false, false)),
            ("side-lod pixel centroid", 1.0, m(true, 0.0, true, false, false)),
            ("side-lod strict1.0 centroid", 1.0, m(true, 1.0, true, false, true)),
            ("side-lod strict1.1 centroid", 1.0, m(true, 1.1, true, false, true)),
            ("side-lod strict1.2 centroid", 1.0, m(true, 1.2, true, false, true)),
            ("side-lod strict1.0 nocentroid", 1.0, m(true, 1.0, false, false, true)),
            ("2px strict1.0 centroid", 2.0, m(true, 1.0, true, false, true)),
            ("2px strict1.2 centroid", 2.0, m(true, 1.2, true, false, true)),
            ("2px strict1.2 centroid round", 2.0, m(true, 1.3, true, true, true)),
            ("4px strict1.0 centroid", 4.0, m(true, 1.0, true, false, true)),
            ("leaves strict1.0", 0.0001, m(true, 1.0, false, false, true)),
            ("leaves strict1.2", 0.0001, m(true, 1.2, false, false, true)),
            ("sphere-lod 1px strict1.0 centroid", 1.0, m(false, 1.0, true, false, true)),
        ];
        let mut modes = vec![modes0[3]];
        if std::env::var("LAB_ALL").is_ok() { modes = modes0.to_vec(); }
        for c in [1.0, 2.0, 4.0, 8.0] { modes.push(("new", c, m(true, 1.1, true, false, true))); }
        if std::env::var("LAB_ROUND").is_ok() { for c in [1.0, 2.0, 4.0, 8.0] { modes.push(("new-round", c, m(true, 1.25, true, true, true))); } }
        for c in [0.5, 1.0, 2.0, 4.0, 8.0] { modes.push(("rule", c, Mode { lodk: -1.0, ..m(true, 1.1, true, false, true) })); }
        for cq in [3.0, 6.0, 9.0] { for c in [1.0, 8.0] { modes.push(("rule-cq", c, Mode { lodk: -1.0, cq, ..m(true, 1.1, true, false, true) })); } }
        for (sil, lodk) in [(1.0/3.0, 1.0), (1.0/9.0, 1.0)] {
            for c in [1.0, 3.0, 4.0, 8.0] { modes.push(("sil", c, Mode { sil, lodk, ..m(true, 1.1, true, false, true) })); }
        }
        let q = |v: &[f64]| v.iter().map(|d: &f64| d.to_radians()).collect::<Vec<f64>>();
        let runs: Vec<(&str, f64, Mode, Option<Vec<Vec<f64>>>, Vec<f64>)> = modes.iter().map(|&(n, c, m)| (n, c, m, None, vec![]))
            .chain([
                ("cone exact", 1.0, modes0[3].2, Some(cone_data.clone()), vec![]),
                ("rule cone exact", 1.0, Mode { lodk: -1.0, ..modes0[3].2 }, Some(cone_data.clone()), vec![]),
                ("cone q(4,15,35,90)", 1.0, modes0[3].2, Some(cone_data.clone()), q(&[4.0, 15.0, 35.0, 90.0])),
                ("cone q(5,10,20,30,45,60,90)", 1.0, modes0[3].2, Some(cone_data.clone()), q(&[5.0, 10.0, 20.0, 30.0, 45.0, 60.0, 90.0])),
                ("cone q(2.5,5,10,20,40,60,90) leaves", 0.0001, modes0[3].2, Some(cone_data.clone()), q(&[2.5, 5.0, 10.0, 20.0, 40.0, 60.0, 90.0])),
            ]).collect();
        for (name, cutoff, mode, cone, classes) in runs {
            let mut o = Oracle {
                grid: &grid,
                cam,
                table: &table,
                origin: h.origin.map(f64::from),
                side: f64::from(h.side),
                rho: u32::from(h.rho),
                depth: h.depth,
                cutoff,
                mode,
                color: vec![0; WIDTH * HEIGHT],
                z: vec![f64::INFINITY; WIDTH * HEIGHT],
                nodes: 0,
                splats: 0,
                back: 0,
                cones: if mode.sil > 0.0 { Some(cone_data.clone()) } else { cone },
                cone_culled: 0,
                classes: classes.clone(),
                wrote_nothing: 0,
                final_z: None,
                occl: [0; 8],
                who: vec![(0, 0); WIDTH * HEIGHT],
            };
            o.walk(0, 0, [0; 3], 0);
            if std::env::var("LAB_OCCL").is_ok() {
                let (n0, s0) = (o.nodes, o.splats);
                let fz = o.z.clone();
                o.final_z = Some(fz);
                o.nodes = 0; o.splats = 0;
                o.walk(0, 0, [0; 3], 0);
                println!("   occlusion oracle: nodes {n0} -> {}, splats {s0} -> {}, occluded cells per level {:?}", o.nodes, o.splats, o.occl);
            }
            let covered: Vec<bool> = o.z.iter().map(|z| z.is_finite()).collect();
            if std::env::var("LAB_HOLES").is_ok() && name == "rule" && cutoff == 1.0 {
                let mut out = FrameBuffers::new();
                let s1 = Settings { cutoff_px: 1.0, ..settings };
                struct Rec(Vec<(u8, u32, i32, i32, i32, u16)>);
                impl pocketsplat_core::splat::SplatSink for Rec {
                    fn splat(&mut self, s: &pocketsplat_core::splat::SampleSplat) { self.0.push((s.level, s.index, s.x_q8, s.y_q8, s.size_q8, s.depth)); }
                }
                let _ = pocketsplat_sim::render::render_tg_frame(&grid, &s1, &mut out).unwrap();
                let ours = out.covered();
                let mut rec = Rec(vec![]);
                let opts = pocketsplat_core::tg::RenderOptions { cutoff_px: 1.0, ..Default::default() };
                let fr = pocketsplat_core::tg::TgFrame::new(grid.header(), &pocketsplat_core::camera::Placement::IDENTITY, &cam, &opts).unwrap();
                pocketsplat_core::tg::render_tg(&grid, &fr, &mut rec);
                let mut shown = 0;
                for i in 0..WIDTH*HEIGHT {
                    if reference.covered[i] && !ours[i] && shown < 8 {
                        shown += 1;
                        let (l, idx) = o.who[i];
                        let hit: Vec<_> = rec.0.iter().filter(|r| r.0 == l && r.1 == idx).collect();
                        println!("hole px ({}, {}) oracle cell L{l} #{idx} covered={} ; integer splat of that cell: {:?} oracle side px at ref depth {:.3}", i % WIDTH, i / WIDTH, covered[i], hit, cam.focal_px * f64::from(h.side) / 3f64.powi(i32::from(l)) / reference.depth[i]);
                        // parent chain: which integer splats are near
                        let near: Vec<_> = rec.0.iter().filter(|r| ((r.2 >> 4) - (i % WIDTH) as i32).abs() <= 1 && ((r.3 >> 4) - (i / WIDTH) as i32).abs() <= 1).take(6).collect();
                        println!("    integer splats near: {near:?}");
                    }
                }
            }
            let (p, a, b, f) = score(&reference, &o.color, &covered);
            println!("{vname} {name} cq {} sil {:.2} lodk {:.2} cut {cutoff}: psnr {p:.3} refonly {a} usonly {b} covfrac {f:.2} nodes {} splats {} back {} conecull {} wrote-nothing {}", mode.cq, mode.sil, mode.lodk, o.nodes, o.splats, o.back, o.cone_culled, o.wrote_nothing);
        }
    }
}
