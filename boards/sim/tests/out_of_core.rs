//! Out-of-core bakes as a user runs them (issue 32): a generated scan of 2 M triangles baked
//! into both formats under a memory budget that forces spilling, its peak resident size (the
//! bake's own `VmHWM`, printed in its summary) held under the budget; the Stanford bunny and
//! dragon baked in many pieces to the in-memory bytes; and a bake that is refused, fails or is
//! interrupted leaves nothing behind — no output, no spill folder.

use crate::common;

use std::path::Path;
use std::process::Stdio;
use std::time::{Duration, Instant};

use common::{command, fails, files_in, model, succeeds};
use pocketsplat_sim::generate::Sphere;

/// The peak RSS in a bake's summary line (`peak RSS 123.45 MB`), in bytes.
fn peak_rss(stderr: &str) -> u64 {
    let at = stderr.rfind("peak RSS ").expect("a summary line") + "peak RSS ".len();
    let mut words = stderr[at..].split_whitespace();
    let value: f64 = words.next().unwrap().parse().unwrap();
    let unit = match words
        .next()
        .unwrap()
        .trim_end_matches(|c: char| !c.is_alphabetic())
    {
        "KB" => 1u64 << 10,
        "MB" => 1 << 20,
        "GB" => 1 << 30,
        u => panic!("unit {u}"),
    };
    (value * unit as f64) as u64
}

/// The number of pieces in an out-of-core summary (`, 12 pieces (largest …`).
fn pieces(stderr: &str) -> u64 {
    let at = stderr
        .find(" pieces (largest")
        .expect("an out-of-core summary");
    stderr[..at].rsplit(' ').next().unwrap().parse().unwrap()
}

/// A generated scan of 2 M triangles (1 M vertices) baked out of core into both formats within
/// budgets far below what the in-memory bakes take (about 450 and 100 bytes a vertex): each runs
/// in pieces, and its peak resident size stays under its budget.
#[test]
fn a_scan_bakes_out_of_core_within_its_budget() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let t = Instant::now();
    let sphere = Sphere::with_triangles(2_000_000, 3);
    sphere.write(&d.join("scan.ply"), &|_| {}).unwrap();

    for (format, out, memory) in [("qs", "scan.qs", 160u64), ("tg", "scan.tg", 128)] {
        let budget = format!("{memory}M");
        let out_path = d.join(out);
        let run = succeeds(
            d,
            &[
                "bake", "scan.ply", "-o", out, "--format", format, "--memory", &budget,
            ],
        );
        let err = String::from_utf8_lossy(&run.stderr);
        assert!(err.contains("out of core"), "{err}");
        assert!(pieces(&err) > 1, "{err}");
        let peak = peak_rss(&err);
        assert!(
            peak <= memory << 20,
            "{format}: peak {peak} over {budget}: {err}"
        );
        let bytes = std::fs::read(&out_path).unwrap();
        match format {
            "qs" => {
                let qs = pocketsplat_core::qs::QSplat::open(&bytes).unwrap();
                assert_eq!(qs.counts().leaves, sphere.vertices());
            }
            _ => {
                pocketsplat_core::tg::TriGrid::open(&bytes, pocketsplat_core::tg::Verify::Full)
                    .unwrap();
            }
        }
        eprintln!("{format}: {err}");
    }
    // Nothing but the mesh and the two files.
    assert_eq!(files_in(d), ["scan.ply", "scan.qs", "scan.tg"]);
    eprintln!("{:.1} s", t.elapsed().as_secs_f64());
}

/// The bunny and the dragon baked out of core in pieces of a few thousand triangles or points:
/// the in-memory bytes, in both formats.
#[test]
fn stanford_scans_bake_out_of_core_to_the_in_memory_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (name, tg_piece, qs_piece) in [
        ("bun_zipper.ply.gz", "3000", "2000"),
        ("dragon_vrip.ply.gz", "40000", "9000"),
    ] {
        let Some(mesh) = model(name) else { return };
        let mesh = mesh.to_str().unwrap();
        for (format, piece) in [("tg", tg_piece), ("qs", qs_piece)] {
            succeeds(d, &["bake", mesh, "-o", "memory.out", "--format", format]);
            let run = succeeds(
                d,
                &[
                    "bake",
                    mesh,
                    "-o",
                    "pieces.out",
                    "--format",
                    format,
                    "--out-of-core",
                    "--piece-size",
                    piece,
                ],
            );
            let err = String::from_utf8_lossy(&run.stderr);
            assert!(pieces(&err) >= 10, "{name} {format}: {err}");
            let (a, b) = (
                std::fs::read(d.join("memory.out")).unwrap(),
                std::fs::read(d.join("pieces.out")).unwrap(),
            );
            assert!(a == b, "{name} {format}: the out-of-core bytes differ");
        }
    }
}

/// The bunny written wound inward throughout (every triangle reversed): in memory the importer
/// orients it, out of core the facing pass turns it whole; both bake the bytes of the bunny as
/// written outward, in both formats.
#[test]
fn a_scan_wound_inward_bakes_out_of_core_to_the_outward_bytes() {
    let Some(path) = model("bun_zipper.ply.gz") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mesh = pocketsplat_sim::ply::load_mesh(&path).unwrap();
    common::write_ply(&mesh, &d.join("out.ply"));
    let mut inward = mesh.clone();
    for t in &mut inward.triangles {
        t.swap(0, 1);
    }
    common::write_ply(&inward, &d.join("in.ply"));
    let said = |o: &std::process::Output| {
        String::from_utf8_lossy(&o.stdout).into_owned() + &String::from_utf8_lossy(&o.stderr)
    };
    for (format, piece) in [("tg", "3000"), ("qs", "2000")] {
        let plain = succeeds(d, &["bake", "out.ply", "-o", "out.bin", "--format", format]);
        assert!(!said(&plain).contains("turned"), "{}", said(&plain));
        let memory = succeeds(
            d,
            &["bake", "in.ply", "-o", "memory.bin", "--format", format],
        );
        let n = mesh.triangles.len();
        assert!(
            said(&memory).contains(&format!("{n} triangles turned to wind outward")),
            "{}",
            said(&memory)
        );
        let run = succeeds(
            d,
            &[
                "bake",
                "in.ply",
                "-o",
                "pieces.bin",
                "--format",
                format,
                "--out-of-core",
                "--piece-size",
                piece,
            ],
        );
        let err = String::from_utf8_lossy(&run.stderr);
        assert!(pieces(&err) >= 10, "{format}: {err}");
        assert!(
            said(&run).contains("the mesh winds inward: read turned"),
            "{}",
            said(&run)
        );
        let read = |f: &str| std::fs::read(d.join(f)).unwrap();
        assert!(read("memory.bin") == read("out.bin"), "{format}: in memory");
        assert!(
            read("pieces.bin") == read("out.bin"),
            "{format}: out of core"
        );
    }
}

/// A budget too small for the vertices, a bad face and a truncated file: a clear error naming
/// the file, before the budget is used up, and nothing left behind.
#[test]
fn refused_and_failed_bakes_leave_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    Sphere::with_triangles(200_000, 1)
        .write(&d.join("s.ply"), &|_| {})
        .unwrap();
    let err = fails(
        d,
        &[
            "bake", "s.ply", "-o", "s.qs", "--format", "qs", "--memory", "8M",
        ],
        &["s.ply", "--memory", "vertices"],
    );
    assert!(err.contains("out of core"), "{err}");
    // A face that refers to a vertex past the end, found in the pass over the spilled faces.
    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
               property float z\nelement face 2\nproperty list uchar int vertex_indices\n\
               end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 7\n";
    std::fs::write(d.join("bad.ply"), ply).unwrap();
    for format in ["tg", "qs"] {
        fails(
            d,
            &[
                "bake",
                "bad.ply",
                "-o",
                "o.out",
                "--format",
                format,
                "--out-of-core",
            ],
            &[
                "bad.ply",
                "face 1 refers to vertex 7, but there are only 3 vertices",
            ],
        );
    }
    // Cut short in its faces.
    let bytes = std::fs::read(d.join("s.ply")).unwrap();
    std::fs::write(d.join("cut.ply"), &bytes[..bytes.len() - 1000]).unwrap();
    fails(
        d,
        &[
            "bake",
            "cut.ply",
            "-o",
            "o.qs",
            "--format",
            "qs",
            "--out-of-core",
        ],
        &["cut.ply", "truncated"],
    );
}

/// A mesh whose spill file would not fit the disk: refused with the sizes before anything is
/// read. The PLY is sparse: a header of 3 vertices and more faces than the disk's free bytes / 12,
/// which the file's length can hold (its body, never read, is a hole).
#[test]
fn a_mesh_too_large_for_the_disk_is_refused_before_it_is_read() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let free = pocketsplat_sim::bake::budget::free_disk(d).expect("statvfs");
    let faces = free / 12 + free / 100 + (1 << 20);
    let header = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n\
         property float y\nproperty float z\nelement face {faces}\n\
         property list uchar int vertex_indices\nend_header\n"
    );
    let f = std::fs::File::create(d.join("huge.ply")).unwrap();
    std::io::Write::write_all(&mut &f, header.as_bytes()).unwrap();
    f.set_len(header.len() as u64 + 36 + 13 * faces).unwrap();
    drop(f);
    // A budget whose count limits admit the faces (triangles = MEMORY/16).
    let memory = (16 * faces).next_power_of_two().to_string();
    let t = Instant::now();
    for format in ["qs", "tg"] {
        fails(
            d,
            &[
                "bake",
                "huge.ply",
                "-o",
                "o.out",
                "--format",
                format,
                "--out-of-core",
                "--memory",
                &memory,
            ],
            &["huge.ply", "of disk for", "free", "--spill-dir"],
        );
    }
    assert!(t.elapsed() < Duration::from_secs(20), "{:?}", t.elapsed());
}

/// Ctrl-C in the middle of an out-of-core bake: exit 130, and the spill folder and the
/// temporary output are gone.
#[test]
fn an_interrupted_bake_leaves_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    Sphere::with_triangles(2_000_000, 5)
        .write(&d.join("s.ply"), &|_| {})
        .unwrap();
    let before = files_in(d);
    let mut child = command(
        &[
            "bake",
            "s.ply",
            "-o",
            "s.tg",
            "--out-of-core",
            "--piece-size",
            "20000",
        ],
        d,
    )
    .stderr(Stdio::null())
    .spawn()
    .unwrap();
    // Wait for the spill folder, then interrupt.
    let t = Instant::now();
    while !files_in(d).iter().any(|f| f.ends_with(".spill")) {
        assert!(t.elapsed() < Duration::from_secs(60), "no spill folder");
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(Duration::from_millis(300));
    let killed = std::process::Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(130), "{status:?}");
    assert_eq!(files_in(d), before);
}

/// The spill folder is made where `--spill-dir` says, and goes.
#[test]
fn spill_files_go_where_asked_and_go_away() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let spill = d.join("spill-here");
    std::fs::create_dir(&spill).unwrap();
    Sphere::with_triangles(20_000, 2)
        .write(&d.join("s.ply"), &|_| {})
        .unwrap();
    succeeds(
        d,
        &[
            "bake",
            "s.ply",
            "-o",
            "s.qs",
            "--format",
            "qs",
            "--out-of-core",
            "--spill-dir",
            spill.to_str().unwrap(),
        ],
    );
    assert!(files_in(&spill).is_empty());
    assert!(Path::new(&d.join("s.qs")).is_file());
}
