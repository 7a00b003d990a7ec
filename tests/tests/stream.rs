//! Streaming torture tests (issue 7; STYLE.md 6): the bunny at paper level 5 (depth 6), read through
//! 512-byte chunks, prime-sized chunks, chunks in reverse order, 1 KB file blocks, and sources
//! that fail or damage 10 % of reads at random (seeded), must converge to exactly the frame the
//! fully resident file gives, for every standard view; with a cache smaller than the file too. A
//! block that never arrives intact leaves the frame coarser, counted, without a panic.

use std::sync::OnceLock;

use pocketsplat_core::bake::BakeOptions;
use pocketsplat_core::camera::STANDARD_VIEWS;
use pocketsplat_core::shade::ShadingTable;
use pocketsplat_core::stream::torture::{Chunked, Flaky};
use pocketsplat_core::stream::{BlockEntry, ChunkSource, MemSource, SlotEntry, TgStream};
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
            let (grid, big) = pocketsplat_sim::cmd::bake::bake_mesh(
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
    (fb.crc(), fb.depth.as_flattened().to_vec())
}

fn opts(cache_bytes: usize) -> StreamOptions {
    StreamOptions {
        io_budget: IO_BUDGET,
        cache_bytes,
        max_frames: 3000,
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
            if fb.crc() != *crc || fb.depth.as_flattened() != &depth[..] {
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
    // Too little memory is said as such.
    let mut src = MemSource::new(big);
    let err = TgStream::open(&mut src, &mut data, &mut slots, &mut blocks).unwrap_err();
    assert!(err.to_string().contains("block table holds 0"), "{err}");
    let mut blocks = vec![BlockEntry::EMPTY; big.len() / 4096];
    let mut slots = vec![SlotEntry::EMPTY; 16];
    let mut tiny = vec![0u8; 3 * 4096];
    let err = TgStream::open(&mut src, &mut tiny, &mut slots, &mut blocks).unwrap_err();
    assert!(err.to_string().contains("needs at least 4"), "{err}");
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
    let err = out.unwrap_err().to_string();
    assert!(err.contains("did not converge in 200 frames"), "{err}");
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
