#![allow(clippy::float_arithmetic)]
use super::*;
use crate::bake::{bake_grid, BakeOptions, TriMesh};
use crate::camera::{self, Placement, Sphere};
use crate::camera::{Camera, View, STANDARD_VIEWS};
use crate::frame::RenderOptions;
use crate::splat::SampleSplat;
use crate::tg::traverse::{ShadowHooks, SlotOrder};
use crate::tg::write::write_tg;
use crate::tg::Verify;
use std::vec::Vec;

/// A bumpy height field, which shadows itself under an oblique light.
fn terrain(n: u32) -> TriMesh {
    let mut m = TriMesh::default();
    for j in 0..=n {
        for i in 0..=n {
            let (x, z) = (
                f64::from(i) / f64::from(n) * 2.0 - 1.0,
                f64::from(j) / f64::from(n) * 2.0 - 1.0,
            );
            let y = 0.6 * libm::sin(7.0 * x) * libm::cos(6.0 * z);
            m.positions.push([x, y, z]);
        }
    }
    for j in 0..n {
        for i in 0..n {
            let a = j * (n + 1) + i;
            let (b, c, d) = (a + 1, a + n + 1, a + n + 2);
            m.triangles.push([a, c, b]);
            m.triangles.push([b, c, d]);
        }
    }
    m
}

/// One-pass shadows with the children in light order at every level, as the walk was before
/// it took slot order below the stop level.
struct OrderedEverywhere<'a, 'l, 'm, 'b>(&'a mut OnePass<'l, 'm, 'b>);

impl ShadowHooks for OrderedEverywhere<'_, '_, '_, '_> {
    type Pos = LightPos;
    const FILL_CULLED: bool = true;
    fn ordered(&self, _: usize) -> bool {
        true
    }
    fn root(&self) -> LightPos {
        self.0.root()
    }
    fn child(&self, p: LightPos, level: usize, slot: usize) -> LightPos {
        self.0.child(p, level, slot)
    }
    fn order(&self) -> &SlotOrder {
        self.0.order()
    }
    fn drawn(&mut self, level: usize, p: LightPos, attr: u16) -> bool {
        self.0.drawn(level, p, attr)
    }
    fn casts(&mut self, level: usize, p: LightPos) {
        self.0.casts(level, p);
    }
    fn light_stop(&self, level: usize) -> bool {
        self.0.light_stop(level)
    }
    fn unlit(&self, class: usize, code: usize) -> bool {
        self.0.unlit(class, code)
    }
    fn casts_subtree(&mut self, level: usize, p: LightPos, mask: u32) {
        self.0.casts_subtree(level, p, mask);
    }
    fn descended(&mut self, level: usize, p: LightPos, mask: u32) {
        self.0.descended(level, p, mask);
    }
}

/// Every drawn sample's (level, index, shadowed), sorted.
#[derive(Default)]
struct Classes(Vec<(u8, u32, bool)>);
impl SplatSink for Classes {
    fn splat(&mut self, s: &SampleSplat) {
        self.0.push((s.level, s.index, s.shadowed));
    }
}

#[test]
fn slot_order_below_the_stop_level_shadows_every_sample_as_light_order_does() {
    let baked = bake_grid(&terrain(60), BakeOptions { rho: 3, depth: 5 }, None).unwrap();
    let bytes = write_tg(&baked, 12).unwrap();
    let grid = TriGrid::open(&bytes, Verify::Full).unwrap();
    let h = grid.header();
    let sphere = Sphere::from_bounds(h.bounds);
    let light = LightFrame::new(h, &Placement::IDENTITY, camera::direction(-40.0, 35.0), 64);
    assert!(
        light.stop_level() < usize::from(h.depth),
        "the test needs levels below the stop"
    );
    let mut depth = std::vec![0u16; 64 * 64];
    let views = STANDARD_VIEWS
        .iter()
        .map(|&(_, v)| v)
        .chain([View::new(30.0, 20.0, 0.6)]);
    for view in views {
        for cutoff_px in [1.0, 3.0] {
            let cam = Camera::orbit(sphere, view, 45.0);
            let opts = RenderOptions {
                cutoff_px,
                ..RenderOptions::default()
            };
            let frame = TgFrame::new(h, &Placement::IDENTITY, &cam, &opts).unwrap();
            let mut classes = [Classes::default(), Classes::default()];
            for (everywhere, out) in [false, true].into_iter().zip(&mut classes) {
                let mut map = ShadowMap::new(&mut depth, 64);
                map.clear();
                let mut one = OnePass {
                    light: &light,
                    map: &mut map,
                };
                if everywhere {
                    render_tg_with(&grid, &frame, &mut OrderedEverywhere(&mut one), out);
                } else {
                    render_tg_with(&grid, &frame, &mut one, out);
                }
                out.0.sort_unstable();
            }
            let shadowed = classes[0].0.iter().filter(|c| c.2).count();
            assert!(
                shadowed > 0 && shadowed < classes[0].0.len(),
                "{view:?}: {shadowed} shadowed"
            );
            // The walk in light order everywhere places the last level's splats by the exact
            // divide where the other uses the linearised one (within 1/32 px), so a few
            // splats at the edge of a pixel centre or of facing differ; every sample both
            // draw must be shadowed alike.
            let both: std::collections::BTreeMap<_, _> =
                classes[1].0.iter().map(|c| ((c.0, c.1), c.2)).collect();
            let mut common = 0;
            for c in &classes[0].0 {
                if let Some(&s) = both.get(&(c.0, c.1)) {
                    assert_eq!(s, c.2, "{view:?} at {cutoff_px} px: sample {c:?}");
                    common += 1;
                }
            }
            assert!(
                common * 100 >= 97 * classes[0].0.len().max(classes[1].0.len()),
                "{view:?} at {cutoff_px} px: {common} of {} / {} in common",
                classes[0].0.len(),
                classes[1].0.len()
            );
        }
    }
}
