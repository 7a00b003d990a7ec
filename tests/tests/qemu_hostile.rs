//! Hostile `.tg` files streamed under QEMU (issue 17): the firmware built with `selftest-hostile`
//! streams every file `pocketsplat_tests::hostile` makes from a bricked trefoil (version 3, 4 KB
//! blocks, colours and materials; header and brick-table fields, counts, masks and group pointers
//! in the head and in bricks, shifted runs, the leaves' partition, truncation), plus the clean file
//! and its version 2 twin, from a real FAT image through embedded-sdmmc: the std view at 16 px,
//! then refined at 1 px in passes (`pocketsplat_qemu::hostile`).
//!
//! Checked: the firmware exits through semihosting with status 0 after every file (a panic, a
//! HardFault or a hang would fail the run), its lines equal the host's over the same image, and
//! each file ends as the resident reader says it must: a file the resident reader refuses is
//! refused when it opens, or ends unconverged with the error marker, or (where the views never read
//! the damage) converges to the clean file's frame; a file it accepts converges to its own resident
//! frame. The version 2 twin is refused (not streamable), the clean file converges. CI streams every
//! third hostile file; `scripts/hostile` streams them all.

use pocketsplat_core::stream::sdmmc::{NoClock, SdFile};
use pocketsplat_core::tg::write::{write_tg_as, Layout};
use pocketsplat_core::tg::{TgError, TriGrid, Verify};
use pocketsplat_qemu::hostile::{file_name, hostile_run, HostileLine, Verdict};
use pocketsplat_qemu::stream::{orbit_view, StreamTables, CACHE_BYTES};
use pocketsplat_qemu::Model;
use pocketsplat_sim::stream::FileBlockDevice;
use pocketsplat_tests::arm::{have_qemu, target_dir, Firmware, HostFrames, TARGET};
use pocketsplat_tests::fat::{have, make_image_of};
use pocketsplat_tests::hostile::bricked_cases;

/// Parses `hostile N …` back into the line the firmware printed.
fn parse(line: &str) -> Option<(u32, &str)> {
    let rest = line.strip_prefix("hostile ")?;
    let (n, tail) = rest.split_once(' ')?;
    Some((n.parse().ok()?, tail))
}

#[test]
fn hostile_files_end_cleanly_under_qemu_as_the_resident_reader_says() {
    if !have_qemu() || !have("mkfs.fat", "dosfstools") | !have("mcopy", "mtools") {
        return;
    }
    let mut mesh = pocketsplat_sim::demo::trefoil(96, 8, 0.45);
    mesh.materials = Some((0..mesh.triangles.len()).map(|k| (k % 3) as u8).collect());
    mesh.colors = Some(
        (0..mesh.positions.len())
            .map(|v| [(v * 37) as u8, (v * 11) as u8, 200])
            .collect(),
    );
    let (grid, _) = pocketsplat_sim::bake::bake_mesh(
        &mesh,
        pocketsplat_core::bake::BakeOptions { rho: 3, depth: 4 },
        12,
        false,
    )
    .unwrap();
    let base = write_tg_as(&grid, 12, Layout::Bricked).unwrap();
    let v2 = write_tg_as(&grid, 12, Layout::Version2).unwrap();
    let mut files: Vec<(String, Vec<u8>)> =
        vec![("clean".into(), base.clone()), ("version 2".into(), v2)];
    // CI streams a sample, every third case of each class's run (every class is many cases:
    // places × values), and the clean and version 2 files; `scripts/hostile` (POCKETSPLAT_HOSTILE
    // =all) streams every case, which takes about three times as long.
    let every = if std::env::var("POCKETSPLAT_HOSTILE").as_deref() == Ok("all") {
        1
    } else {
        3
    };
    let cases = bricked_cases(&base);
    let all = cases.len();
    files.extend(cases.into_iter().step_by(every).map(|c| (c.name, c.bytes)));
    eprintln!(
        "{} of {all} hostile cases (POCKETSPLAT_HOSTILE=all for every one)",
        files.len() - 2
    );
    let names: Vec<String> = (0..files.len() as u32)
        .map(|i| String::from_utf8(file_name(i).to_vec()).unwrap())
        .collect();
    let dir = target_dir().join("models/sd-hostile");
    std::fs::create_dir_all(&dir).unwrap();
    let listing: Vec<(&str, &[u8])> = names
        .iter()
        .zip(&files)
        .map(|(n, (_, b))| (n.as_str(), b.as_slice()))
        .collect();
    let image = make_image_of(&dir, &listing);

    let fw = Firmware {
        target: TARGET,
        features: &["selftest-hostile"],
        panel: None,
        model: None,
        image: Some(&image),
    };
    let elf = fw.build().unwrap();
    let run = fw.run_for(&elf, None, 1800).unwrap();
    assert_eq!(
        run.output.status.code(),
        Some(0),
        "the firmware must exit through semihosting with status 0:\n{}",
        run.transcript()
    );
    let stdout = run.stdout();
    let arm: Vec<String> = stdout
        .lines()
        .filter(|l| parse(l).is_some())
        .map(str::to_owned)
        .collect();
    assert_eq!(
        run.field("hostile done").map(|n| n.trim().to_owned()),
        Some(files.len().to_string()),
        "every file was streamed:\n{}",
        run.transcript()
    );

    // The same library call on the host, over the same image.
    let device = FileBlockDevice::open(&image).unwrap();
    let volumes: embedded_sdmmc::VolumeManager<_, _, 1, 1, 1> =
        embedded_sdmmc::VolumeManager::new_with_limits(device, NoClock, 0);
    let volume = volumes
        .open_raw_volume(embedded_sdmmc::VolumeIdx(0))
        .unwrap();
    let root = volumes.open_root_dir(volume).unwrap();
    let mut tables = Box::new(StreamTables::EMPTY);
    let mut data = Box::new([0u8; CACHE_BYTES]);
    let mut mem = tables.with_cache(&mut data);
    let mut frames = HostFrames::new();
    let mut host: Vec<HostileLine> = Vec::new();
    for (i, name) in names.iter().enumerate() {
        let file = volumes
            .open_file_in_dir(root, name.as_str(), embedded_sdmmc::Mode::ReadOnly)
            .unwrap();
        let mut sd = SdFile::new(&volumes, file);
        host.push(hostile_run(
            i as u32,
            &mut sd,
            mem.reborrow(),
            &mut frames.targets(),
            |_| {},
        ));
        volumes.close_file(file).unwrap();
    }
    assert_eq!(arm.len(), host.len(), "one line per file");
    for (a, h) in arm.iter().zip(&host) {
        assert_eq!(a, &h.to_string(), "ARM and host differ");
    }

    // Each file as the resident reader says.
    let frame_of = |bytes: &[u8]| {
        let model = Model::open(bytes).unwrap();
        HostFrames::new()
            .render_view(&model, orbit_view(0), 1.0)
            .unwrap()
            .0
    };
    let clean = frame_of(&base);
    let mut tally = [0usize; 4];
    for ((what, bytes), line) in files.iter().zip(&host) {
        let accepted = TriGrid::open(bytes, Verify::Full).is_ok();
        match (line.verdict, accepted) {
            (Verdict::Refused(e), false) => {
                assert!(
                    e.is_some(),
                    "{what}: refused for the medium, not the format"
                );
                tally[0] += 1;
            }
            (Verdict::Refused(e), true) => {
                assert_eq!(
                    e,
                    Some(TgError::NotStreamable { version: 2 }),
                    "{what}: a valid file refused"
                );
                tally[0] += 1;
            }
            (
                Verdict::Drawn {
                    converged: true,
                    crc,
                    ..
                },
                true,
            ) => {
                assert_eq!(crc, frame_of(bytes), "{what}: not its resident frame");
                tally[3] += 1;
            }
            (
                Verdict::Drawn {
                    converged: true,
                    crc,
                    marker,
                    ..
                },
                false,
            ) => {
                assert_eq!(crc, clean, "{what}: converged on a frame of damaged data");
                assert!(!marker, "{what}");
                tally[2] += 1;
            }
            (
                Verdict::Drawn {
                    converged: false,
                    marker,
                    structure,
                    inconsistent,
                    ..
                },
                false,
            ) => {
                assert!(
                    marker && structure + inconsistent > 0,
                    "{what}: ended unconverged without saying why: {line}"
                );
                tally[1] += 1;
            }
            (
                Verdict::Drawn {
                    converged: false, ..
                },
                true,
            ) => {
                panic!("{what}: a valid file did not converge: {line}")
            }
        }
    }
    eprintln!(
        "QEMU, {} hostile and reference files streamed from a FAT image: {} refused at open, {} \
         ended malformed with the marker, {} drawn as the clean frame (damage unread), {} valid \
         ones converged to their resident frame",
        files.len(),
        tally[0],
        tally[1],
        tally[2],
        tally[3]
    );
}
