//! Streaming torture tests (issue 7; docs/ARCHITECTURE.md, Conventions 6): the bunny at paper level 5 (depth 6), read through
//! 512-byte chunks, prime-sized chunks, chunks in reverse order, 1 KB file blocks, and sources
//! that fail or damage 10 % of reads at random (seeded), must converge to exactly the frame the
//! fully resident file gives, for every standard view; with a cache smaller than the file too. A
//! block that never arrives intact leaves the frame coarser, counted, without a panic.

use std::sync::OnceLock;

use pocketsplat_core::bake::BakeOptions;
use pocketsplat_core::camera::STANDARD_VIEWS;
use pocketsplat_core::shade::ShadingTable;
use pocketsplat_core::stream::torture::{Chunked, Flaky};
use pocketsplat_core::stream::{
    table_entries, BlockEntry, ChunkSource, MemSource, SlotEntry, TgStream,
};
use pocketsplat_core::tg::write::write_tg;
use pocketsplat_core::tg::{TriGrid, Verify};
use pocketsplat_sim::render::{render_tg_frame, FrameBuffers, Settings};
use pocketsplat_sim::stream::run::{camera_for, stream_frame};
use pocketsplat_sim::stream::{stream_render, OwnedStream, StreamOptions};
use pocketsplat_tests::model;

/// Bytes read per frame: 128 KB, so that the 5 MB file streams in about 40 frames.
const IO_BUDGET: u32 = 128 * 1024;

/// The bunny baked at depth 6 with 4 KB blocks and with 1 KB blocks (Streaming QSplat's size; with
/// 512-byte blocks a 5 MB file needs more CRC-table blocks than its header block can list, and the
/// writer refuses it: `WriteError::TooLarge`).
fn bunny() -> Option<&'static (Vec<u8>, Vec<u8>)> {
    static FILES: OnceLock<Option<(Vec<u8>, Vec<u8>)>> = OnceLock::new();
    FILES
        .get_or_init(|| {
            let path = model("bun_zipper.ply.gz")?;
            let mesh = pocketsplat_sim::ply::load_mesh(&path).unwrap();
            let (grid, big) = pocketsplat_sim::bake::bake_mesh(
                &mesh,
                BakeOptions { rho: 3, depth: 6 },
                12,
                false,
            )
            .unwrap();
            let small = write_tg(&grid, 10).unwrap();
            Some((big, small))
        })
        .as_ref()
}

/// The frame of the resident file: CRC and depth buffer.
fn resident(file: &[u8], settings: &Settings) -> (u32, Vec<u16>) {
    let grid = TriGrid::open(file, Verify::Full).unwrap();
    let mut fb = FrameBuffers::new();
    render_tg_frame(&grid, settings, &mut fb).unwrap();
    (fb.crc(), fb.depths().to_vec())
}

fn opts(cache_bytes: usize) -> StreamOptions {
    StreamOptions {
        io_budget: IO_BUDGET,
        cache_bytes,
        max_frames: 3000,
        ..StreamOptions::default()
    }
}

#[test]
fn every_torture_source_converges_to_the_resident_frame() {
    let Some((big, small)) = bunny() else {
        return;
    };
    type Make = fn(&'static [u8]) -> Box<dyn ChunkSource<Error = String>>;
    // Erase the error types so that one loop runs every source.
    struct Erased<S>(S);
    impl<S: ChunkSource> ChunkSource for Erased<S> {
        type Error = String;
        fn read_at(&mut self, offset: u64, buf: &mut [u8]) -> Result<(), String> {
            self.0.read_at(offset, buf).map_err(|e| format!("{e:?}"))
        }
    }
    let sources: [(&str, bool, Make); 8] = [
        ("4 KB blocks in 512-byte chunks", false, |f| {
            Box::new(Erased(Chunked::new(MemSource::new(f), 512, false)))
        }),
        ("1 KB blocks", true, |f| Box::new(Erased(MemSource::new(f)))),
        ("prime 509-byte chunks", false, |f| {
            Box::new(Erased(Chunked::new(MemSource::new(f), 509, false)))
        }),
        ("prime 4093-byte chunks, reversed", false, |f| {
            Box::new(Erased(Chunked::new(MemSource::new(f), 4093, true)))
        }),
        ("512-byte chunks, reversed", false, |f| {
            Box::new(Erased(Chunked::new(MemSource::new(f), 512, true)))
        }),
        ("10 % of reads fail", false, |f| {
            Box::new(Erased(Flaky::new(MemSource::new(f), 7, 10, 0)))
        }),
        ("10 % of reads damaged", false, |f| {
            Box::new(Erased(Flaky::new(MemSource::new(f), 11, 0, 10)))
        }),
        (
            "1 KB blocks, prime chunks, 10 % failed or damaged",
            true,
            |f| {
                Box::new(Erased(Flaky::new(
                    Chunked::new(MemSource::new(f), 131, true),
                    13,
                    5,
                    5,
                )))
            },
        ),
    ];
    let mut failures = Vec::new();
    let mut seen_failures = std::collections::BTreeMap::new();
    for (view_name, view) in STANDARD_VIEWS {
        let settings = Settings {
            view,
            ..Settings::default()
        };
        let want = [resident(big, &settings), resident(small, &settings)];
        for (name, use_small, make) in &sources {
            let file: &'static [u8] = if *use_small { small } else { big };
            let mut src = make(file);
            let mut fb = FrameBuffers::new();
            // The far view needs the coarse levels only: a cache of half the file holds them, and
            // the eviction policy is exercised while prefetch fills it. The nearer views at 1 px
            // need nearly every block resident at once, so they get a cache of the whole file
            // (with half, they could never converge: what one frame draws would not fit).
            let cache = if view_name == "far" {
                file.len() / 2
            } else {
                file.len()
            };
            let out = stream_render(&mut *src, &settings, &opts(cache), &mut fb);
            let out = match out {
                Ok(o) => o,
                Err(e) => {
                    failures.push(format!("{view_name}, {name}: {e:#}"));
                    continue;
                }
            };
            let (crc, depth) = &want[usize::from(*use_small)];
            if fb.crc() != *crc || fb.depths() != &depth[..] {
                failures.push(format!(
                    "{view_name}, {name}: frame CRC {:08x}, resident {crc:08x}",
                    fb.crc()
                ));
            }
            let c = out.counters;
            // A view that needs few blocks may draw none of the failures: count them per source.
            *seen_failures.entry(*name).or_insert(0) += c.read_errors + c.crc_errors;
            // Every frame kept to its budget (the budget rounds up to one block).
            let bs = 1u32
                << TriGrid::open(file, Verify::Full)
                    .unwrap()
                    .header()
                    .block_log2;
            assert!(out.per_frame.iter().all(|r| r.bytes <= IO_BUDGET.max(bs)));
            eprintln!(
                "{view_name:5} {name:55} {:4} frames, {:8} of {:8} bytes read, {} read errors, {} CRC failures, {} evictions",
                out.frames, c.bytes_read, file.len(), c.read_errors, c.crc_errors, c.evictions
            );
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    for (name, _, _) in &sources {
        if name.contains('%') {
            assert!(
                seen_failures[name] > 0,
                "{name}: no failure was counted in any view"
            );
        }
    }
}

/// A source that fails every read of one block, or damages it, forever.
struct OneBadBlock<'a> {
    file: &'a [u8],
    bad: std::ops::Range<u64>,
    damage: bool,
    bad_reads: u32,
}

impl ChunkSource for OneBadBlock<'_> {
    type Error = &'static str;
    fn read_at(&mut self, offset: u64, buf: &mut [u8]) -> Result<(), &'static str> {
        MemSource::new(self.file)
            .read_at(offset, buf)
            .map_err(|_| "out of range")?;
        if offset < self.bad.end && offset + buf.len() as u64 > self.bad.start {
            self.bad_reads += 1;
            if !self.damage {
                return Err("bad sector");
            }
            buf[0] ^= 0x80;
        }
        Ok(())
    }
}

#[test]
fn a_block_that_never_arrives_leaves_the_frame_coarser_and_is_retried_with_backoff() {
    let Some((big, _)) = bunny() else {
        return;
    };
    let settings = Settings::default();
    // The finest block the converged std view uses: stream it once from a good source; with a
    // cache as large as the file and no prefetch, what is resident is what the frame needs.
    let bs = 4096u64;
    let leaf = {
        let mut src = MemSource::new(big);
        let mut mem = OwnedStream::new(&mut src, big.len()).unwrap();
        let mut stream = mem.open(&mut src).unwrap();
        let cam = camera_for(&stream, &settings);
        let mut table = Box::new(ShadingTable::<1>::new());
        let mut fb = FrameBuffers::new();
        while {
            stream_frame(&mut stream, &cam, &settings, &mut table, &mut fb).unwrap();
            !stream.converged()
        } {
            stream.serve(&mut src, 64 * 1024);
        }
        (0..big.len() / 4096)
            .rev()
            .find(|&b| stream.cache().contains(b))
            .unwrap() as u64
    };
    for damage in [false, true] {
        let mut src = OneBadBlock {
            file: big,
            bad: leaf * bs..(leaf + 1) * bs,
            damage,
            bad_reads: 0,
        };
        let mut mem = OwnedStream::new(&mut src, big.len()).unwrap();
        let mut stream = mem.open(&mut src).unwrap();
        let cam = camera_for(&stream, &settings);
        let mut table = Box::new(ShadingTable::<1>::new());
        let mut fb = FrameBuffers::new();
        let mut splats = 0;
        for _ in 0..400 {
            splats = stream_frame(&mut stream, &cam, &settings, &mut table, &mut fb)
                .unwrap()
                .splats;
            stream.serve(&mut src, 64 * 1024);
        }
        assert!(!stream.converged());
        assert!(splats > 1000, "the frame is still drawn ({splats} splats)");
        let c = *stream.counters();
        let failures = if damage { c.crc_errors } else { c.read_errors };
        assert_eq!(failures, src.bad_reads, "every failure is counted");
        // Backoff: 2, 4, …, 64 frames between attempts, so about 6 + 400/64 attempts, not 400.
        assert!(
            (5..=16).contains(&failures),
            "{failures} attempts at the bad block in 400 frames"
        );
    }
}

#[test]
fn hostile_sources_give_errors_not_panics() {
    let Some((big, _)) = bunny() else {
        return;
    };
    // Every read fails: opening reports the device error.
    struct Dead;
    impl ChunkSource for Dead {
        type Error = &'static str;
        fn read_at(&mut self, _: u64, _: &mut [u8]) -> Result<(), &'static str> {
            Err("no card")
        }
    }
    let (mut data, mut slots, mut blocks) = (
        vec![0u8; 1 << 16],
        vec![SlotEntry::EMPTY; 0],
        vec![BlockEntry::EMPTY; 0],
    );
    let err = TgStream::open(&mut Dead, &mut data, &mut slots, &mut blocks).unwrap_err();
    assert_eq!(err.to_string(), "read failed: \"no card\"");
    // A damaged header is a format error naming the problem.
    let mut bad = big.clone();
    bad[100] ^= 1;
    let mut src = MemSource::new(&bad);
    let err = TgStream::open(&mut src, &mut data, &mut slots, &mut blocks).unwrap_err();
    assert_eq!(err.to_string(), "header block fails its CRC check");
    // Too little memory is said as such: a block table too small for the cache (its size
    // follows the cache's, not the file's), a cache too small for the file.
    let mut src = MemSource::new(big);
    let mut slots = vec![SlotEntry::EMPTY; 16];
    let err = TgStream::open(&mut src, &mut data, &mut slots, &mut blocks).unwrap_err();
    assert_eq!(
        err.to_string(),
        "a block table of 0 entries is too small for this cache: it needs 128"
    );
    let mut blocks = vec![BlockEntry::EMPTY; table_entries(16, 0)];
    let mut tiny = vec![0u8; 3 * 4096];
    let err = TgStream::open(&mut src, &mut tiny, &mut slots, &mut blocks).unwrap_err();
    assert!(err.to_string().contains("needs 4 blocks"), "{err}");
    // A file cut short: blocks past the end fail to read, the frame stays coarse, no panic. An
    // eighth ends inside level 5, which the standard view draws.
    let cut = &big[..big.len() / 8];
    let mut src = MemSource::new(cut);
    let settings = Settings::default();
    let mut fb = FrameBuffers::new();
    let out = stream_render(
        &mut src,
        &settings,
        &StreamOptions {
            max_frames: 200,
            ..opts(big.len())
        },
        &mut fb,
    );
    // The header announces more than the source holds: an error at open (issue 17), before the
    // block table is sized by it.
    let err = out.unwrap_err().to_string();
    assert!(
        err.contains(&format!(
            "file is {} bytes but the header announces {}",
            cut.len(),
            big.len()
        )),
        "{err}"
    );
}

#[test]
fn close_view_reads_a_fraction_of_the_file_and_prefetch_fills_the_rest_coarse_first() {
    let Some((big, _)) = bunny() else {
        return;
    };
    let settings = Settings {
        view: pocketsplat_core::camera::standard_view("close").unwrap(),
        ..Settings::default()
    };
    let mut src = MemSource::new(big);
    let mut mem = OwnedStream::new(&mut src, big.len()).unwrap();
    let mut stream = mem.open(&mut src).unwrap();
    let cam = camera_for(&stream, &settings);
    let mut table = Box::new(ShadingTable::<1>::new());
    let mut fb = FrameBuffers::new();
    let mut frames = 0;
    loop {
        stream_frame(&mut stream, &cam, &settings, &mut table, &mut fb).unwrap();
        frames += 1;
        if stream.converged() {
            break;
        }
        let r = stream.serve(&mut src, 16 * 1024);
        assert_eq!(
            r.prefetched, 0,
            "no prefetch while visible blocks are missing"
        );
    }
    let read = stream.counters().bytes_read;
    assert!(
        read * 2 < big.len() as u64,
        "close view read {read} of {} bytes",
        big.len()
    );
    assert_eq!(fb.crc(), resident(big, &settings).0);
    // Idle: prefetch the rest in file order (coarse levels first), never evicting.
    let before = stream.cache().resident();
    let mut prefetched = 0;
    for _ in 0..10_000 {
        stream_frame(&mut stream, &cam, &settings, &mut table, &mut fb).unwrap();
        assert!(stream.converged());
        let r = stream.serve(&mut src, 16 * 1024);
        prefetched += r.prefetched;
        if r.reads == 0 {
            break;
        }
    }
    let resident_after = stream.cache().resident();
    assert_eq!(stream.counters().evictions, 0);
    assert_eq!(resident_after, before + prefetched as usize);
    let header = stream.header();
    let data_blocks = header.blocks - header.crc_table_blocks - 1;
    assert_eq!(
        resident_after as u32, data_blocks,
        "the whole file ends resident"
    );
    eprintln!("close view: {frames} frames, {read} of {} bytes", big.len());
}

/// A refined frame needs more blocks than a 64 KB or 128 KB cache holds (the std view at 1 px
/// draws from about 330 blocks of 4 KB): it is drawn in passes over its walk, each pass reading in
/// ascending block order, and ends on exactly the resident frame, having read each needed block
/// about once (never more than the file).
#[test]
fn a_refined_frame_larger_than_the_cache_is_drawn_in_passes_to_the_resident_frame() {
    let Some((big, _)) = bunny() else {
        return;
    };
    let mut failures = Vec::new();
    for cache in [64 * 1024, 128 * 1024] {
        for (view_name, view) in STANDARD_VIEWS {
            let settings = Settings {
                view,
                ..Settings::default()
            };
            let (crc, depth) = resident(big, &settings);
            let mut src = MemSource::new(big);
            let mut fb = FrameBuffers::new();
            let out = match stream_render(&mut src, &settings, &opts(cache), &mut fb) {
                Ok(o) => o,
                Err(e) => {
                    failures.push(format!("{view_name}, {} KB: {e:#}", cache / 1024));
                    continue;
                }
            };
            if fb.crc() != crc || fb.depths() != &depth[..] {
                failures.push(format!(
                    "{view_name}, {} KB: frame CRC {:08x}, resident {crc:08x}",
                    cache / 1024,
                    fb.crc()
                ));
            }
            let c = out.counters;
            assert!(
                c.bytes_read <= big.len() as u64,
                "{view_name}, {} KB: read {} of {} bytes",
                cache / 1024,
                c.bytes_read,
                big.len()
            );
            // The far view fits: it converges without passes.
            assert_eq!(out.passes == 0, view_name == "far", "{view_name}");
            eprintln!(
                "{view_name:5} {:3} KB cache: {:3} passes, {:4} blocks ({:8} bytes) for the refined \
                 frame, {:8} in all of {:8}",
                cache / 1024,
                out.passes,
                out.refined_reads,
                out.refined_bytes,
                c.bytes_read,
                big.len()
            );
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The same without the scans: the demo's trefoil (depth 4, 108 blocks of 512 bytes) through a
/// cache of 12 blocks, at 1 px in every standard view, drawn in passes to exactly the resident
/// frame.
#[test]
fn the_trefoil_through_a_tiny_cache_is_drawn_in_passes_to_the_resident_frame() {
    let file = hostile::trefoil(9);
    for (view_name, view) in STANDARD_VIEWS {
        let settings = Settings {
            view,
            ..Settings::default()
        };
        let (crc, depth) = resident(&file, &settings);
        let mut src = MemSource::new(&file);
        let mut fb = FrameBuffers::new();
        let out = stream_render(&mut src, &settings, &opts(12 * 512), &mut fb)
            .unwrap_or_else(|e| panic!("{view_name}: {e:#}"));
        assert_eq!(fb.crc(), crc, "{view_name}");
        assert_eq!(fb.depths(), &depth[..], "{view_name}");
        // A cache of a ninth of the file: what the walk revisits across passes is read again at
        // times, but the refined frame stays near one read of the file.
        assert!(out.passes > 0, "{view_name}: drawn in passes");
        assert!(
            out.refined_bytes <= file.len() as u64 * 5 / 4,
            "{view_name}: {} bytes for a {}-byte file",
            out.refined_bytes,
            file.len()
        );
        eprintln!(
            "trefoil {view_name:5}: {} passes, {} blocks of 512 B for the refined frame, {} of {} bytes in all",
            out.passes,
            out.refined_reads,
            out.counters.bytes_read,
            file.len()
        );
    }
}

// ---- Hostile files with valid CRCs (issue 17) ------------------------------------------------------
//
// Each file below is a real bake with one structural fault, every CRC recomputed (`seal`), so that
// only the structure checks can catch it. The resident reader rejects every one; streamed, each must
// end in a clear error (at open, or as a malformed block or inconsistent descent), never a panic, a
// hang, a multi-gigabyte allocation or a frame of noise, and its frames stay within one visit per
// sample.

mod hostile {
    use super::*;
    use pocketsplat_core::tg::brick::Array;
    pub use pocketsplat_core::tg::write::seal;
    use pocketsplat_core::tg::{DIRECTORY_ENTRY, DIRECTORY_OFFSET};

    /// The demo's trefoil as a tri-grid with cones, depth 4, blocks of `2^log2` bytes.
    pub fn trefoil(log2: u8) -> Vec<u8> {
        let mesh = pocketsplat_sim::demo::trefoil(96, 8, 0.45);
        pocketsplat_sim::bake::bake_mesh(&mesh, BakeOptions { rho: 3, depth: 4 }, log2, false)
            .unwrap()
            .1
    }

    pub fn u32_at(b: &[u8], at: usize) -> u32 {
        u32::from_le_bytes(b[at..at + 4].try_into().unwrap())
    }

    pub fn put_u32(b: &mut [u8], at: usize, v: u32) {
        b[at..at + 4].copy_from_slice(&v.to_le_bytes());
    }

    /// Byte offset of a level directory field: 0 count, 1 attributes, 2 colours, 3 masks, 4 groups.
    pub fn dir_at(level: usize, field: usize) -> usize {
        DIRECTORY_OFFSET + DIRECTORY_ENTRY * level + 4 * field
    }

    /// Byte offset of element `i` of directory array `field` (3 masks, 4 groups) at `level` of the
    /// valid file `b`, in the level directory or in a brick.
    pub fn elem(b: &[u8], level: usize, field: usize, i: u32) -> usize {
        let array = if field == 3 {
            Array::Mask
        } else {
            Array::Group
        };
        TriGrid::open(b, Verify::Structure)
            .expect("a valid file")
            .element_offset(level as u8, array, i)
            .expect("an element the file has")
    }

    /// Streams `bytes` with the std view through `src`; checks the visit bound on every frame.
    /// Returns the converged frame's CRC.
    pub fn stream<C: ChunkSource>(bytes: &[u8], src: &mut C) -> Result<u32, String> {
        let total: u64 = pocketsplat_core::tg::read::parse_header(bytes)
            .map(|(_, d)| d.iter().map(|l| u64::from(l.count)).sum())
            .unwrap_or(u64::MAX);
        let settings = Settings::default();
        // The whole file, and at least the cache a stream of it needs (a tiny file needs 4
        // blocks, more than it has).
        let cache = bytes.len().max(1 << 20);
        let mut mem = OwnedStream::new(&mut *src, cache).map_err(|e| format!("at open: {e:#}"))?;
        let mut stream = mem.open(&mut *src).map_err(|e| format!("at open: {e:#}"))?;
        let cam = camera_for(&stream, &settings);
        let mut table = Box::new(ShadingTable::<1>::new());
        let mut fb = FrameBuffers::new();
        for _ in 0..200 {
            let stats = stream_frame(&mut stream, &cam, &settings, &mut table, &mut fb).unwrap();
            assert!(
                u64::from(stats.nodes_visited) <= total,
                "{stats:?} > {total}"
            );
            if stream.converged() {
                return Ok(fb.crc());
            }
            stream.serve(&mut *src, 64 * 1024);
        }
        let c = stream.counters();
        let what = if c.structure_errors + c.inconsistent > 0 {
            "malformed"
        } else {
            "no convergence"
        };
        Err(format!(
            "{what}: {} structure errors, {} inconsistent descents",
            c.structure_errors, c.inconsistent
        ))
    }

    /// `bytes` must be rejected by the resident reader, and streamed (as a slice, and through
    /// `stream_render` as the CLI does) end in an error containing one of `needles` (or, found when
    /// the stream opens, the error the checks of the head and the brick table name), or, where the
    /// std view never reads the damage, in exactly the frame of the undamaged file `base` (valid
    /// data only).
    pub fn rejected(what: &str, bytes: &[u8], base: &[u8], needles: &[&str]) {
        assert!(
            TriGrid::open(bytes, Verify::Full).is_err(),
            "{what}: the resident reader opens it"
        );
        let clean = resident(base, &Settings::default()).0;
        let err = match stream(bytes, &mut MemSource::new(bytes)) {
            Ok(crc) => {
                assert_eq!(crc, clean, "{what}: converged on a frame of damaged data");
                eprintln!("{what}: the view does not read the damage; the clean frame");
                return;
            }
            Err(e) => e,
        };
        let at_open = err.strip_prefix("at open: ");
        assert!(
            at_open.is_some() || needles.iter().any(|n| err.contains(n)),
            "{what}: {err:?} names none of {needles:?}"
        );
        let mut fb = FrameBuffers::new();
        let t = std::time::Instant::now();
        let err = stream_render(
            &mut MemSource::new(bytes),
            &Settings::default(),
            &opts(1 << 20),
            &mut fb,
        )
        .expect_err(what);
        let err = format!("{err:#}");
        assert!(
            needles.iter().any(|n| err.contains(n))
                || err.contains("malformed")
                || at_open.is_some_and(|e| err.contains(e)),
            "{what}: stream_render: {err}"
        );
        assert!(t.elapsed().as_secs() < 20, "{what}: took {:?}", t.elapsed());
        eprintln!("{what}: {err}");
    }
}

#[test]
fn hostile_masks_with_valid_crcs_are_absent_not_a_panic() {
    use hostile::*;
    for log2 in [9u8, 12, 16] {
        let base = trefoil(log2);
        TriGrid::open(&base, Verify::Full).unwrap();
        stream(&base, &mut MemSource::new(&base)).expect("the clean file converges");
        for level in [0usize, 1, 2] {
            for (bit, name) in [(31u32, "bit 31"), (30, "bit 30 (above the cone class)")] {
                let mut b = base.clone();
                let at = elem(&b, level, 3, 0);
                let m = u32_at(&b, at);
                put_u32(&mut b, at, m | 1 << bit);
                seal(&mut b);
                rejected(
                    &format!("2^{log2} blocks, level {level} mask {name}"),
                    &b,
                    &base,
                    &["malformed"],
                );
            }
            // An empty mask below the depth.
            let mut b = base.clone();
            let at = elem(&b, level, 3, 0);
            put_u32(&mut b, at, 0);
            seal(&mut b);
            rejected(
                &format!("2^{log2} blocks, level {level} empty mask"),
                &b,
                &base,
                &["malformed"],
            );
        }
    }
}

/// A root with fewer children than level 1 holds (one bit of its mask cleared), at depth 4 and at
/// depth 1, where no group pointer or deeper mask could show it: the root's block is malformed.
#[test]
fn a_root_mask_short_of_the_level_below_is_malformed() {
    use hostile::*;
    for depth in [1u8, 4] {
        let mesh = pocketsplat_sim::demo::trefoil(96, 8, 0.45);
        let base =
            pocketsplat_sim::bake::bake_mesh(&mesh, BakeOptions { rho: 3, depth }, 12, false)
                .unwrap()
                .1;
        TriGrid::open(&base, Verify::Full).unwrap();
        stream(&base, &mut MemSource::new(&base)).expect("the clean file converges");
        let mut b = base.clone();
        let at = elem(&b, 0, 3, 0);
        let m = u32_at(&b, at);
        put_u32(&mut b, at, m & (m - 1));
        seal(&mut b);
        rejected(
            &format!("depth {depth}, root mask one child short"),
            &b,
            &base,
            &["malformed"],
        );
    }
}

#[test]
fn hostile_group_pointers_with_valid_crcs_end_in_an_error_within_the_visit_bound() {
    use hostile::*;
    for log2 in [9u8, 12, 16] {
        let base = trefoil(log2);
        let grid = TriGrid::open(&base, Verify::Full).unwrap();
        for level in [1usize, 2] {
            let n = grid.level(level as u8).count;
            let below = grid.level(level as u8 + 2).count;
            // Where each group pointer of the level lies (in the directory's array or in bricks).
            let offs: std::rc::Rc<Vec<usize>> = std::rc::Rc::new(
                (0..n)
                    .map(|i| {
                        grid.element_offset(
                            level as u8,
                            pocketsplat_core::tg::brick::Array::Group,
                            i,
                        )
                        .unwrap()
                    })
                    .collect(),
            );
            let (o1, o2, o3, o4, o5) = (
                offs.clone(),
                offs.clone(),
                offs.clone(),
                offs.clone(),
                offs.clone(),
            );
            type Damage = Box<dyn Fn(&mut Vec<u8>)>;
            let cases: [(&str, Damage); 5] = [
                // Every cell's grandchildren are cell 0's: a DAG.
                (
                    "all aliased to the first group",
                    Box::new(move |b: &mut Vec<u8>| {
                        for i in 0..n {
                            put_u32(b, o1[i as usize], 0);
                        }
                    }),
                ),
                // Two neighbours share their grandchildren.
                (
                    "one pair aliased",
                    Box::new(move |b: &mut Vec<u8>| {
                        let i = (n / 2) as usize;
                        let prev = u32_at(b, o2[i - 1]);
                        put_u32(b, o2[i], prev);
                    }),
                ),
                // A pointer before its predecessor's.
                (
                    "backward",
                    Box::new(move |b: &mut Vec<u8>| {
                        let i = (n / 2) as usize;
                        let prev = u32_at(b, o3[i - 1]);
                        put_u32(b, o3[i], prev.saturating_sub(1));
                    }),
                ),
                // Past the end of the level two below.
                (
                    "past the end",
                    Box::new(move |b: &mut Vec<u8>| {
                        put_u32(b, o4[(n - 1) as usize], below + 5);
                    }),
                ),
                // Each group moved back by one: every entry increases, none is the running count,
                // so siblings' groups overlap by one cell (caught in the walk, across blocks too).
                (
                    "all shifted back by one",
                    Box::new(move |b: &mut Vec<u8>| {
                        for i in 1..n as usize {
                            let g = u32_at(b, o5[i]);
                            put_u32(b, o5[i], g - 1);
                        }
                    }),
                ),
            ];
            for (name, damage) in cases {
                let mut b = base.clone();
                damage(&mut b);
                seal(&mut b);
                rejected(
                    &format!("2^{log2} blocks, level {level} groups {name}"),
                    &b,
                    &base,
                    &["malformed", "inconsistent"],
                );
            }
        }
    }
}

#[test]
fn hostile_counts_and_block_counts_fail_at_open_without_allocating() {
    use hostile::*;
    let base = trefoil(12);
    let grid = TriGrid::open(&base, Verify::Full).unwrap();
    // A level with fewer samples than its parent has cells, or more than ρ³ times: at open.
    for (level, count) in [(2usize, grid.level(1).count - 1), (1, 28)] {
        let mut b = base.clone();
        put_u32(&mut b, dir_at(level, 0), count);
        seal(&mut b);
        rejected(
            &format!("level {level} count {count}"),
            &b,
            &base,
            &["samples, but", "misaligned"],
        );
    }
    // One sample fewer at the finest level: within the bounds at open, but the last cell's
    // children run past it (caught in the walk) or a group entry does (caught on arrival).
    let depth = 4usize;
    let mut b = base.clone();
    put_u32(&mut b, dir_at(depth, 0), grid.level(depth as u8).count - 1);
    seal(&mut b);
    rejected(
        "finest level one sample short",
        &b,
        &base,
        &["malformed", "inconsistent"],
    );
    // A header with 64 KB blocks that declares 262 M blocks (the 4.2 GB block table): the
    // CRC table grows to the most the header can list, the arrays move past it, and the header is
    // resealed. It must fail before the table is allocated, with or without a known length.
    let base = trefoil(16);
    let mut b = base.clone();
    let old_t = u32_at(&b, 36);
    let t = 16_000u32;
    put_u32(&mut b, 32, t << 14);
    put_u32(&mut b, 36, t);
    let levels = usize::from(b[9]) + 1;
    for l in 0..levels {
        for f in 1..5 {
            let off = u32_at(&b, dir_at(l, f));
            if off != 0 {
                put_u32(&mut b, dir_at(l, f), off + ((t - old_t) << 16));
            }
        }
    }
    // The brick table too (its entries are not read before the header is refused).
    let table = u32_at(&b, 44);
    if table != 0 {
        put_u32(&mut b, 44, table + ((t - old_t) << 16));
    }
    let bs = 1usize << 16;
    let c = pocketsplat_core::crc::crc32(&b[..bs - 4]);
    b[bs - 4..bs].copy_from_slice(&c.to_le_bytes());
    pocketsplat_core::tg::read::parse_header(&b).expect("the header itself is valid");
    rejected("262 M blocks declared", &b, &base, &["header announces"]);
    /// A source that does not know its length.
    struct Unsized<'a>(MemSource<'a>);
    impl ChunkSource for Unsized<'_> {
        type Error = pocketsplat_core::stream::OutOfRange;
        fn read_at(&mut self, o: u64, buf: &mut [u8]) -> Result<(), Self::Error> {
            self.0.read_at(o, buf)
        }
    }
    // Refused before anything is sized by it: by the `stream` limit on the size it claims (16 TB;
    // issue 18) before the source is asked for its last byte.
    let err = stream(&b, &mut Unsized(MemSource::new(&b))).unwrap_err();
    assert!(
        err.contains("over the limit stream=8G") && err.contains("17179869184000"),
        "{err}"
    );
}
