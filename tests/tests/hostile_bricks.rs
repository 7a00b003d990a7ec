//! Hostile bricked `.tg` files (version 3, issue 17): every class `pocketsplat_tests::hostile`
//! makes (header and brick-table fields, counts, masks and group pointers in the head and in
//! bricks, runs of pointers shifted alike, the leaves' partition, truncation), all with valid CRCs,
//! from real bakes (the trefoil with colours and materials as a tri-grid in 512-byte and 4 KB
//! blocks, as an octree, and the bunny res4 at depth 5 when the models are present).
//!
//! The rule, for the resident reader and the streamed one (the CLI's `stream_render`, views std,
//! close and far, caches of 16 and 64 KB): a file the resident reader rejects is refused when
//! streamed (at open, or as malformed: a clear error), or, where a view never reads the damage,
//! drawn as exactly the undamaged file's frame; a file it accepts streams to exactly its resident
//! frame. Never a panic, never a frame of damaged data, within a few seconds each.

use pocketsplat_core::bake::{BakeOptions, TriMesh};
use pocketsplat_core::camera::standard_view;
use pocketsplat_core::stream::MemSource;
use pocketsplat_core::tg::write::{write_tg_as, Layout};
use pocketsplat_core::tg::{TriGrid, Verify};
use pocketsplat_sim::render::{render_tg_frame, FrameBuffers, Settings};
use pocketsplat_sim::stream::{stream_render, StreamOptions};
use pocketsplat_tests::hostile::bricked_cases;

fn bake(mesh: &TriMesh, rho: u8, depth: u8, log2: u8) -> Vec<u8> {
    let (grid, _) = pocketsplat_sim::bake::bake_mesh(mesh, BakeOptions { rho, depth }, log2, false)
        .expect("bakes");
    let bytes = write_tg_as(&grid, log2, Layout::Bricked).expect("writes");
    assert!(
        TriGrid::open(&bytes, Verify::Full)
            .unwrap()
            .header()
            .bricked(),
        "bricked"
    );
    bytes
}

fn bases() -> Vec<(String, Vec<u8>)> {
    let mut t = pocketsplat_sim::demo::trefoil(96, 8, 0.45);
    let mut out = vec![(
        "trefoil rho 2 depth 5, 4 KB".to_string(),
        bake(&t, 2, 5, 12),
    )];
    t.materials = Some((0..t.triangles.len()).map(|k| (k % 3) as u8).collect());
    t.colors = Some(
        (0..t.positions.len())
            .map(|v| [(v * 37) as u8, (v * 11) as u8, 200])
            .collect(),
    );
    out.push(("trefoil rho 3 depth 4, 512 B".into(), bake(&t, 3, 4, 9)));
    out.push(("trefoil rho 3 depth 4, 4 KB".into(), bake(&t, 3, 4, 12)));
    if let Some(path) = pocketsplat_tests::model("bun_zipper_res4.ply") {
        let bunny = pocketsplat_sim::ply::load_mesh(&path).expect("loads");
        out.push((
            "bunny res4 rho 3 depth 5, 4 KB".into(),
            bake(&bunny, 3, 5, 12),
        ));
    }
    out
}

/// The frame of a file the resident reader accepts.
fn resident(bytes: &[u8], settings: &Settings) -> u32 {
    let grid = TriGrid::open(bytes, Verify::Full).unwrap();
    let mut fb = FrameBuffers::new();
    render_tg_frame(&grid, settings, &mut fb).unwrap();
    fb.crc()
}

/// The streamed frame (CRC) or the error's text.
fn streamed(bytes: &[u8], settings: &Settings, cache_bytes: usize) -> Result<u32, String> {
    let mut fb = FrameBuffers::new();
    let opts = StreamOptions {
        io_budget: 64 * 1024,
        cache_bytes,
        max_frames: 400,
        ..StreamOptions::default()
    };
    stream_render(&mut MemSource::new(bytes), settings, &opts, &mut fb)
        .map(|_| fb.crc())
        .map_err(|e| format!("{e:#}"))
}

#[test]
fn every_class_of_hostile_bricked_file_is_refused_or_drawn_as_the_resident_reader_draws() {
    let views = ["std", "close", "far"];
    let mut totals = [0usize; 4]; // refused resident, refused streamed, clean frame, accepted
    for (base_name, base) in bases() {
        let settings: Vec<Settings> = views
            .iter()
            .map(|v| Settings {
                view: standard_view(v).unwrap(),
                cutoff_px: 1.0,
                ..Settings::default()
            })
            .collect();
        let clean: Vec<u32> = settings.iter().map(|s| resident(&base, s)).collect();
        let cases = bricked_cases(&base);
        assert!(cases.len() > 100, "{base_name}: {} cases", cases.len());
        for case in cases {
            let what = format!("{base_name}: {}", case.name);
            let t = std::time::Instant::now();
            let accepted = TriGrid::open(&case.bytes, Verify::Full).is_ok();
            totals[if accepted { 3 } else { 0 }] += 1;
            for (k, s) in settings.iter().enumerate() {
                let want = if accepted {
                    Some(resident(&case.bytes, s))
                } else {
                    None
                };
                for cache in [16 << 10, 64 << 10] {
                    match (streamed(&case.bytes, s, cache), want) {
                        (Ok(crc), Some(w)) => assert_eq!(crc, w, "{what}: {}", views[k]),
                        (Ok(crc), None) => {
                            assert_eq!(
                                crc, clean[k],
                                "{what}, {} view, {cache} B cache: a frame of damaged data",
                                views[k]
                            );
                            totals[2] += 1;
                        }
                        (Err(e), None) => {
                            assert!(!e.contains("panicked"), "{what}: {e}");
                            totals[1] += 1;
                        }
                        // A valid file that a small cache cannot draw in passes is not damage.
                        (Err(e), Some(_)) => assert!(
                            cache < 64 << 10 && e.contains("did not converge"),
                            "{what}: a valid file refused: {e}"
                        ),
                    }
                }
            }
            assert!(t.elapsed().as_secs() < 20, "{what}: {:?}", t.elapsed());
        }
    }
    eprintln!(
        "files refused by the resident reader {}; streamed frames refused {}, drawn as the clean \
         file's {}; files accepted (streamed to their own frame) {}",
        totals[0], totals[1], totals[2], totals[3]
    );
}
