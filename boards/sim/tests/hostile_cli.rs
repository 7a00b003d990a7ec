//! `pocketsplat` on hostile input (issue 9): every subcommand on garbage, empty, a folder, a missing
//! file and truncated files; meshes with NaN/Inf, out-of-range and negative indices, polygons, no
//! triangles, coordinates too large to store, and extreme but valid ranges. Each must end with a
//! non-zero exit and a message naming the file (and the element, for meshes), never a panic, and
//! leave no output or temporary file behind; valid extremes must bake, read back and render.

use crate::common;
use common::{fails, files_in, pocketsplat, succeeds};
use std::process::Stdio;
use std::time::{Duration, Instant};

/// An ASCII PLY from vertex and face lines.
fn ply(vertices: &[&str], faces: &[&str]) -> String {
    format!(
        "ply\nformat ascii 1.0\nelement vertex {}\nproperty double x\nproperty double y\n\
         property double z\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n{}{}",
        vertices.len(),
        faces.len(),
        vertices.iter().map(|v| format!("{v}\n")).collect::<String>(),
        faces.iter().map(|f| format!("{f}\n")).collect::<String>(),
    )
}

const OCTAHEDRON_V: [&str; 6] = ["1 0 0", "-1 0 0", "0 1 0", "0 -1 0", "0 0 1", "0 0 -1"];
const OCTAHEDRON_F: [&str; 8] = [
    "3 0 2 4", "3 2 1 4", "3 1 3 4", "3 3 0 4", "3 2 0 5", "3 1 2 5", "3 3 1 5", "3 0 3 5",
];

/// A binary little-endian PLY of the octahedron (to truncate).
fn binary_octahedron() -> Vec<u8> {
    let mut b = String::from(
        "ply\nformat binary_little_endian 1.0\nelement vertex 6\nproperty float x\n\
         property float y\nproperty float z\nelement face 8\n\
         property list uchar int vertex_indices\nend_header\n",
    )
    .into_bytes();
    for v in OCTAHEDRON_V {
        for c in v.split(' ') {
            b.extend(c.parse::<f32>().unwrap().to_le_bytes());
        }
    }
    for f in OCTAHEDRON_F {
        let mut it = f.split(' ').map(|x| x.parse::<i32>().unwrap());
        b.push(it.next().unwrap() as u8);
        for i in it {
            b.extend(i.to_le_bytes());
        }
    }
    b
}

/// Every subcommand that reads a file, with `input` in place.
fn commands(input: &str) -> Vec<Vec<String>> {
    let s = |v: &[&str]| v.iter().map(|x| x.to_string()).collect::<Vec<_>>();
    vec![
        s(&["bake", input, "-o", "out.tg", "--depth", "3"]),
        s(&["info", input]),
        s(&["info", input, "--json"]),
        s(&["render", input, "-o", "out.png"]),
        s(&[
            "render",
            input,
            "-o",
            "out.png",
            "--shadows",
            "two-pass",
            "--stats-json",
        ]),
        s(&["view", input, "--frames", "1"]),
        s(&["report", "views", "--mesh", input, "--repeats", "1"]),
    ]
}

#[test]
fn every_command_on_bad_files_fails_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("oct.ply"), ply(&OCTAHEDRON_V, &OCTAHEDRON_F)).unwrap();
    assert!(succeeds(
        d,
        &[
            "bake",
            "oct.ply",
            "-o",
            "oct.tg",
            "--depth",
            "3",
            "--block-size",
            "512"
        ]
    )
    .status
    .success());
    let tg = std::fs::read(d.join("oct.tg")).unwrap();
    let bin = binary_octahedron();
    let mut garbage = Vec::new();
    let mut x = 0x2545_f491_u32;
    for _ in 0..4096 {
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        garbage.push(x as u8);
    }
    let mut tg_garbage = b"PSTG".to_vec();
    tg_garbage.extend(&garbage);
    let files: Vec<(&str, Vec<u8>)> = vec![
        ("empty.bin", Vec::new()),
        ("garbage.bin", garbage.clone()),
        ("garbage.tg", tg_garbage),
        ("half.tg", tg[..tg.len() / 2].to_vec()),
        ("header-only.tg", tg[..512].to_vec()),
        ("short.tg", tg[..100].to_vec()),
        ("half.ply", bin[..bin.len() / 2].to_vec()),
        (
            "header-only.ply",
            bin[..bin.iter().position(|&c| c == b'e').unwrap()].to_vec(),
        ),
        (
            "text.ply",
            b"ply\nformat ascii 1.0\nelement vertex 1\nend_header\n".to_vec(),
        ),
    ];
    for (name, bytes) in &files {
        std::fs::write(d.join(name), bytes).unwrap();
    }
    std::fs::create_dir(d.join("folder.tg")).unwrap();
    let mut inputs: Vec<&str> = files.iter().map(|(n, _)| *n).collect();
    inputs.extend(["folder.tg", "missing.tg", "missing.ply"]);
    for input in inputs {
        for args in commands(input) {
            let args: Vec<&str> = args.iter().map(String::as_str).collect();
            fails(d, &args, &[input]);
        }
    }
    // Outputs that cannot be written: into a missing folder, onto a folder.
    std::fs::create_dir(d.join("outdir")).unwrap();
    fails(
        d,
        &["bake", "oct.ply", "-o", "no/such/dir/x.tg"],
        &["no/such/dir"],
    );
    fails(d, &["bake", "oct.ply", "-o", "outdir"], &["outdir"]);
    fails(d, &["render", "oct.tg", "-o", "outdir"], &["outdir"]);
    fails(
        d,
        &["render", "oct.tg", "-o", "no/such/dir/x.png"],
        &["no/such/dir"],
    );
}

#[test]
fn garbage_arguments_fail_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("oct.ply"), ply(&OCTAHEDRON_V, &OCTAHEDRON_F)).unwrap();
    for (args, needle) in [
        (
            &["bake", "oct.ply", "-o", "o.tg", "--depth", "11"][..],
            "--depth 11",
        ),
        (
            &["bake", "oct.ply", "-o", "o.tg", "--depth", "-1"][..],
            "-1",
        ),
        (
            &["bake", "oct.ply", "-o", "o.tg", "--rho", "1"][..],
            "--rho 1",
        ),
        (
            &["bake", "oct.ply", "-o", "o.tg", "--block-size", "0"][..],
            "--block-size 0",
        ),
        (
            &["bake", "oct.ply", "-o", "o.tg", "--format", "zip"][..],
            "zip",
        ),
        (
            &["render", "oct.ply", "-o", "o.png", "--view", "nan,0,1"][..],
            "--view",
        ),
        (
            &["render", "oct.ply", "-o", "o.png", "--view", "0,0,-1"][..],
            "--view",
        ),
        (
            &["render", "oct.ply", "-o", "o.png", "--view", "0,0,1e999"][..],
            "--view",
        ),
        (
            &["render", "oct.ply", "-o", "o.png", "--cutoff", "0"][..],
            "--cutoff",
        ),
        (
            &["render", "oct.ply", "-o", "o.png", "--cutoff", "inf"][..],
            "--cutoff",
        ),
        (
            &["render", "oct.ply", "-o", "o.png", "--fov", "nan"][..],
            "--fov",
        ),
        (
            &["render", "oct.ply", "-o", "o.png", "--light", "1"][..],
            "--light",
        ),
        (
            &["render", "oct.ply", "-o", "o.png", "--kernel", "hex"][..],
            "hex",
        ),
        (&["frobnicate"][..], "frobnicate"),
    ] {
        fails(d, args, &[needle]);
    }
}

#[test]
fn bad_meshes_name_file_and_element_and_leave_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let with_vertex = |i: usize, v: &'static str| {
        let mut vs = OCTAHEDRON_V;
        vs[i] = v;
        ply(&vs, &OCTAHEDRON_F)
    };
    let with_face = |i: usize, f: &'static str| {
        let mut fs = OCTAHEDRON_F;
        fs[i] = f;
        ply(&OCTAHEDRON_V, &fs)
    };
    let cases: Vec<(&str, String, Vec<&str>)> = vec![
        ("nan.ply", with_vertex(2, "0 nan 0"), vec!["vertex 2"]),
        ("inf.ply", with_vertex(4, "0 0 -inf"), vec!["vertex 4"]),
        (
            "huge.ply",
            with_vertex(1, "-1e300 0 0"),
            vec!["vertex 1", "too large"],
        ),
        (
            "over-f32.ply",
            with_vertex(5, "0 0 3.5e38"),
            vec!["vertex 5", "too large"],
        ),
        (
            "index.ply",
            with_face(3, "3 0 1 99"),
            vec!["face 3", "vertex 99"],
        ),
        (
            "negative.ply",
            with_face(6, "3 0 -2 1"),
            vec!["face 6", "-2"],
        ),
        (
            "quad.ply",
            with_face(0, "4 0 2 4 1"),
            vec!["face 0", "4 vertices"],
        ),
        (
            "line.ply",
            with_face(7, "2 0 1"),
            vec!["face 7", "2 vertices"],
        ),
        ("empty.ply", ply(&[], &[]), vec!["empty"]),
        ("no-faces.ply", ply(&OCTAHEDRON_V, &[]), vec!["empty"]),
        (
            "flat.ply",
            ply(&["0 0 0", "1 1 1", "2 2 2"], &["3 0 1 2"]),
            vec!["zero area"],
        ),
    ];
    for (name, text, needles) in cases {
        std::fs::write(d.join(name), text).unwrap();
        let mut all = vec![name];
        all.extend(needles);
        fails(d, &["bake", name, "-o", "out.tg", "--depth", "3"], &all);
        fails(d, &["render", name, "-o", "out.png"], &all);
        std::fs::remove_file(d.join(name)).unwrap();
    }
}

#[test]
fn extreme_but_valid_meshes_bake_read_back_and_render() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let tri = |a: f64, s: f64| {
        ply(
            &[
                &format!("{a} {a} {a}"),
                &format!("{} {a} {a}", a + s),
                &format!("{a} {} {a}", a + s),
            ],
            &["3 0 1 2"],
        )
    };
    let cases = [
        // The widest range a .tg file can hold.
        (
            "widest.ply",
            ply(
                &["-1e38 -1e38 0", "1e38 -1e38 0", "0 1e38 1e38"],
                &["3 0 1 2"],
            ),
        ),
        // Tiny meshes far from the origin, where the root cube's corner rounds (in f32) by far
        // more than the mesh's size.
        ("speck-1e6.ply", tri(1e6, 1e-3)),
        ("speck-1e20.ply", tri(1e20, 1e6)),
        ("speck-1e-30.ply", tri(1e-30, 1e-38)),
        // Flat in x at 2^126, exactly an f32: the corner rounds down a whole f32 step there while
        // the side starts at 1e-30. Growing the side one f32 at a time took ~10^9 steps.
        (
            "plane-far.ply",
            ply(
                &[
                    "8.507059173023462e37 0 0",
                    "8.507059173023462e37 1e-30 0",
                    "8.507059173023462e37 0 1e-30",
                ],
                &["3 0 1 2"],
            ),
        ),
    ];
    for (name, text) in cases {
        std::fs::write(d.join(name), text).unwrap();
        let t = Instant::now();
        succeeds(d, &["bake", name, "-o", "x.tg", "--depth", "6"]);
        assert!(
            t.elapsed() < Duration::from_secs(60),
            "{name} took {:?}",
            t.elapsed()
        );
        succeeds(d, &["info", "x.tg"]);
        for shadows in ["off", "one-pass", "two-pass"] {
            succeeds(d, &["render", "x.tg", "-o", "x.png", "--shadows", shadows]);
            succeeds(
                d,
                &[
                    "render", "x.tg", "-o", "x.png", "--view", "close", "--cutoff", "0.01",
                ],
            );
        }
        succeeds(d, &["render", name, "-o", "ref.png"]);
    }
}

#[test]
fn a_closed_stdout_is_not_a_crash() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("oct.ply"), ply(&OCTAHEDRON_V, &OCTAHEDRON_F)).unwrap();
    succeeds(d, &["bake", "oct.ply", "-o", "oct.tg", "--depth", "3"]);
    for args in [
        &["info", "oct.tg"][..],
        &["info", "oct.tg", "--json"][..],
        &["render", "oct.tg", "-o", "x.png", "--stats-json"][..],
    ] {
        // `pocketsplat info oct.tg | head -0`: the reader is gone before anything is written.
        let (reader, writer) = std::io::pipe().unwrap();
        drop(reader);
        let out = common::command(args, d)
            .stdout(Stdio::from(writer))
            .stderr(Stdio::piped())
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
}

/// `render --stream` on `.tg` files whose CRCs are valid but whose structure is not (issue 17): a
/// child mask with bits at or above ρ³, sibling-group pointers that alias one subtree or run
/// backwards, a level count out of range, a header that declares more blocks than the file holds.
/// The resident reader rejects each; streamed, each must fail with a message and write no PNG.
#[test]
fn streamed_hostile_files_fail_cleanly_and_write_no_png() {
    use pocketsplat_core::bake::BakeOptions;
    use pocketsplat_core::tg::brick::Array;
    use pocketsplat_core::tg::write::{seal, write_tg_as, Layout};
    use pocketsplat_core::tg::{TriGrid, Verify, DIRECTORY_ENTRY, DIRECTORY_OFFSET};
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mesh = pocketsplat_sim::demo::trefoil(96, 8, 0.45);
    let (baked, base) =
        pocketsplat_sim::bake::bake_mesh(&mesh, BakeOptions { rho: 3, depth: 4 }, 9, false)
            .unwrap();
    let u32_at = |b: &[u8], at: usize| u32::from_le_bytes(b[at..at + 4].try_into().unwrap());
    let put = |b: &mut [u8], at: usize, v: u32| b[at..at + 4].copy_from_slice(&v.to_le_bytes());
    let dir_at =
        |level: usize, field: usize| DIRECTORY_OFFSET + DIRECTORY_ENTRY * level + 4 * field;
    let grid = TriGrid::open(&base, Verify::Full).unwrap();
    // Where element `i` of array `field` (3 masks, 4 groups) of `level` lies, in the level
    // directory's arrays or in the bricks of the version 3 file.
    let elem = |_: &[u8], level: usize, field: usize, i: u32| {
        let array = if field == 3 {
            Array::Mask
        } else {
            Array::Group
        };
        grid.element_offset(level as u8, array, i).unwrap()
    };
    let n1 = grid.level(1).count;
    // A needle, or (its alternative) what the checks at open name: damage in the head or the brick
    // table is found before the first frame, damage in a brick when the walk first enters it.
    let mut cases: Vec<(&str, Vec<u8>, [&str; 2])> = Vec::new();
    let mut b = base.clone();
    let at = elem(&b, 1, 3, 0);
    let m = u32_at(&b, at);
    put(&mut b, at, m | 1 << 31);
    cases.push(("mask-bit31.tg", b, ["malformed", "invalid child mask"]));
    let mut b = base.clone();
    for i in 0..n1 {
        let at = elem(&b, 1, 4, i);
        put(&mut b, at, 0);
    }
    cases.push((
        "aliased.tg",
        b,
        ["malformed", "wrong sibling-group pointer"],
    ));
    let mut b = base.clone();
    let at = elem(&b, 1, 4, n1 / 2);
    let prev = u32_at(&b, at - 4);
    put(&mut b, at, prev - 1);
    cases.push((
        "backward.tg",
        b,
        ["malformed", "wrong sibling-group pointer"],
    ));
    let mut b = base.clone();
    put(&mut b, dir_at(2, 0), grid.level(1).count - 1);
    let count = "samples, but the level above announces";
    cases.push(("count.tg", b, [count, count]));
    let mut b = base[..base.len() / 2].to_vec();
    seal(&mut b);
    let short = "but the header announces";
    cases.push(("short.tg", b, [short, short]));
    // A valid version 2 file: refused, with the way to migrate it.
    let v2 = write_tg_as(&baked, 9, Layout::Version2).unwrap();
    let refusal = "a version 2 .tg file cannot be streamed";
    cases.push(("v2.tg", v2, [refusal, refusal]));
    for (name, mut bytes, needles) in cases {
        if name != "short.tg" && name != "v2.tg" {
            seal(&mut bytes);
        }
        assert!(
            TriGrid::open(&bytes, Verify::Full).is_err() || name == "v2.tg",
            "{name}"
        );
        std::fs::write(d.join(name), &bytes).unwrap();
        let t = Instant::now();
        let args = [
            "render",
            name,
            "--stream",
            "-o",
            "out.png",
            "--max-frames",
            "100000",
        ];
        let before = files_in(d);
        let out = pocketsplat(&args, d);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{name}: should fail");
        assert!(!err.contains("panicked"), "{name}: {err}");
        assert!(err.contains(name), "{name}: {err}");
        assert!(
            needles.iter().any(|n| err.contains(n)),
            "{name}: none of {needles:?} in {err:?}"
        );
        if name == "v2.tg" {
            assert!(err.contains("pocketsplat migrate"), "{err}");
        }
        assert_eq!(files_in(d), before, "{name}: left a file behind");
        assert!(
            t.elapsed() < Duration::from_secs(30),
            "{name}: {:?}",
            t.elapsed()
        );
    }
    // The clean file streams and writes its PNG.
    std::fs::write(d.join("clean.tg"), &base).unwrap();
    succeeds(d, &["render", "clean.tg", "--stream", "-o", "out.png"]);
    assert!(d.join("out.png").exists());
}

/// `file` with the precise (`f64`) root cube and bounds extension (header flag bit 2) holding its
/// own `f32` cube and bounds times `scale`, sealed again.
fn with_precise_cube(file: &[u8], scale: f64) -> Vec<u8> {
    use pocketsplat_core::tg::{DIRECTORY_ENTRY, DIRECTORY_OFFSET, FLAG_PRECISE};
    let mut f = file.to_vec();
    let f32_at =
        |f: &[u8], at: usize| f64::from(f32::from_le_bytes(f[at..at + 4].try_into().unwrap()));
    let t = u32::from_le_bytes(f[36..40].try_into().unwrap()) as usize;
    let at = DIRECTORY_OFFSET + DIRECTORY_ENTRY * (usize::from(f[9]) + 1) + 4 * t;
    let flags = u16::from_le_bytes([f[6], f[7]]) | FLAG_PRECISE;
    f[6..8].copy_from_slice(&flags.to_le_bytes());
    // Corner, side, then the bounding box.
    let values: Vec<f64> = (0..4)
        .map(|k| f32_at(&f, 16 + 4 * k))
        .chain((0..6).map(|k| f32_at(&f, 48 + 4 * k)))
        .collect();
    for (k, v) in values.iter().enumerate() {
        f[at + 8 * k..at + 8 * k + 8].copy_from_slice(&(v * scale).to_le_bytes());
    }
    pocketsplat_core::tg::write::seal(&mut f);
    f
}

/// The precise root cube is held to what rendering draws (issue 33): a side near 1e−300 drew an
/// empty frame with exit 0, one near 1e300 passed `info` and `migrate` and failed `render` with a
/// camera error. Outside the f32 cube's range (2^±1000, a side below 2^−149, the smallest f32) every command refuses
/// the file by name; inside it (2^±100) the file renders, and not an empty frame.
#[test]
fn the_precise_root_cube_is_held_to_what_rendering_draws() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("oct.ply"), ply(&OCTAHEDRON_V, &OCTAHEDRON_F)).unwrap();
    succeeds(d, &["bake", "oct.ply", "-o", "oct.tg", "--depth", "3"]);
    let tg = std::fs::read(d.join("oct.tg")).unwrap();
    // Powers of two: the scaled numbers keep their order exactly.
    let two = |e: i32| 2f64.powi(e);
    for (name, scale) in [
        ("tiny.tg", two(-1000)),
        ("huge.tg", two(1000)),
        ("sub.tg", two(-153)),
    ] {
        std::fs::write(d.join(name), with_precise_cube(&tg, scale)).unwrap();
        let needles = [name, "precise root cube", "outside what rendering draws"];
        for args in [
            vec!["info", name],
            vec!["migrate", name, "-o", "m.tg"],
            vec!["render", name, "-o", "out.png"],
            vec!["render", name, "-o", "out.png", "--stream"],
            vec!["view", name, "--frames", "1"],
        ] {
            fails(d, &args, &needles);
        }
    }
    for (name, scale) in [("small.tg", two(-100)), ("large.tg", two(100))] {
        std::fs::write(d.join(name), with_precise_cube(&tg, scale)).unwrap();
        succeeds(d, &["info", name]);
        succeeds(d, &["render", name, "-o", "out.png", "--stats-json"]);
        let out = pocketsplat(&["render", name, "-o", "out.png", "--stats-json"], d);
        let stats: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert!(stats["splats"].as_u64().unwrap() > 100, "{name}: {stats}");
    }
}

/// Every error names the file it is about (issue 33): a ρ = 4 file, which the renderer does not
/// draw ("rendering supports rho 2 and 3, not 4" named none), resident and streamed, and an
/// argument the command refuses while reading a file.
#[test]
fn errors_name_the_file_they_are_about() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("oct.ply"), ply(&OCTAHEDRON_V, &OCTAHEDRON_F)).unwrap();
    succeeds(
        d,
        &[
            "bake", "oct.ply", "-o", "r4.tg", "--rho", "4", "--depth", "2",
        ],
    );
    succeeds(d, &["info", "r4.tg"]);
    for args in [
        vec!["render", "r4.tg", "-o", "out.png"],
        vec!["render", "r4.tg", "-o", "out.png", "--stream"],
        vec!["render", "r4.tg", "-o", "out.png", "--view", "0,0,0"],
    ] {
        let err = fails(d, &args, &["r4.tg"]);
        assert!(err.starts_with("error: r4.tg: "), "{err}");
    }
}
