//! Frame time of the integer renderer on the bunny (paper level 5 = depth 6), the standard views,
//! cutoffs 1–8 px, tri-grid against octree; shadows off, one-pass and two-pass; and the traversal
//! alone, for nodes visited per second.
//!
//! `cargo bench -p pocketsplat-tests --bench render` (models from ../shared/models).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use pocketsplat_core::bake::BakeOptions;
use pocketsplat_core::camera::{Placement, STANDARD_VIEWS};
use pocketsplat_core::render::RenderOptions;
use pocketsplat_core::splat::NullSink;
use pocketsplat_core::tg::{render_tg, TgFrame, TriGrid, Verify};
use pocketsplat_sim::render::{render_tg_frame, FrameBuffers, Settings, ShadowMode};

fn bake(rho: u8, depth: u8) -> Vec<u8> {
    let path = pocketsplat_tests::model("bun_zipper.ply.gz")
        .expect("the bunny is needed for this benchmark");
    let mesh = pocketsplat_sim::ply::load_mesh(&path).expect("bunny loads");
    pocketsplat_sim::bake::bake_mesh(&mesh, BakeOptions { rho, depth }, 12, false)
        .expect("bake")
        .1
}

fn frames(c: &mut Criterion) {
    let models = [("trigrid", bake(3, 6)), ("octree", bake(2, 9))];
    let mut group = c.benchmark_group("frame");
    group.sample_size(20);
    for (name, bytes) in &models {
        let tg = TriGrid::open(bytes, Verify::Structure).unwrap();
        for (view_name, view) in STANDARD_VIEWS {
            for cutoff in [1.0f32, 2.0, 4.0, 8.0] {
                let settings = Settings {
                    view,
                    cutoff_px: cutoff,
                    ..Settings::default()
                };
                let mut fb = FrameBuffers::new();
                let id = BenchmarkId::new(format!("{name}/{view_name}"), cutoff);
                group.bench_with_input(id, &settings, |b, s| {
                    b.iter(|| render_tg_frame(&tg, s, &mut fb).unwrap().stats)
                });
            }
        }
    }
    group.finish();

    // Shadows (Duguet Table 5): the std view of the tri-grid at 1 px, off / one-pass / two-pass.
    let mut group = c.benchmark_group("shadows");
    group.sample_size(20);
    let tg = TriGrid::open(&models[0].1, Verify::Structure).unwrap();
    for (name, mode) in [
        ("off", ShadowMode::Off),
        ("one-pass", ShadowMode::OnePass),
        ("two-pass", ShadowMode::TwoPass),
    ] {
        let settings = Settings {
            shadows: mode,
            ..Settings::default()
        };
        let mut fb = FrameBuffers::new();
        group.bench_function(format!("trigrid/std/1px/{name}"), |b| {
            b.iter(|| render_tg_frame(&tg, &settings, &mut fb).unwrap().stats)
        });
    }
    group.finish();

    // The traversal alone (no raster): visited nodes per second on the std view.
    let mut group = c.benchmark_group("traversal");
    group.sample_size(20);
    for (name, bytes) in &models {
        let tg = TriGrid::open(bytes, Verify::Structure).unwrap();
        let settings = Settings::default();
        let camera = settings.camera(tg.header().bounds);
        let frame = TgFrame::new(
            tg.header(),
            &Placement::IDENTITY,
            &camera,
            &RenderOptions::default(),
        )
        .unwrap();
        let nodes = render_tg(&tg, &frame, &mut NullSink::default()).nodes_visited;
        group.throughput(Throughput::Elements(u64::from(nodes)));
        group.bench_function(format!("{name}/std/1px"), |b| {
            b.iter(|| {
                let mut sink = NullSink::default();
                render_tg(&tg, &frame, &mut sink);
                sink.checksum
            })
        });
    }
    group.finish();
}

criterion_group!(benches, frames);
criterion_main!(benches);
