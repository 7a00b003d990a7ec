//! The `pocketsplat` program as a user meets it: exit codes, messages naming the file and element,
//! no partial output on failure, and the JSON fields other tools rely on.

use crate::common;
use common::{files_in, pocketsplat};
use std::process::Output;

/// A small closed mesh (an octahedron) as ASCII PLY, with an optional replacement line.
fn octahedron_ply(bad_vertex: Option<&str>) -> String {
    let mut v = ["1 0 0", "-1 0 0", "0 1 0", "0 -1 0", "0 0 1", "0 0 -1"];
    if let Some(b) = bad_vertex {
        v[3] = b;
    }
    let faces = [
        "3 0 2 4", "3 2 1 4", "3 1 3 4", "3 3 0 4", "3 2 0 5", "3 1 2 5", "3 3 1 5", "3 0 3 5",
    ];
    format!(
        "ply\nformat ascii 1.0\nelement vertex 6\nproperty float x\nproperty float y\nproperty float z\n\
         element face 8\nproperty list uchar int vertex_indices\nend_header\n{}\n{}\n",
        v.join("\n"),
        faces.join("\n")
    )
}

#[test]
fn bake_info_render_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("oct.ply"), octahedron_ply(None)).unwrap();
    let out = pocketsplat(
        &["bake", "oct.ply", "-o", "oct.tg", "--depth", "4"],
        dir.path(),
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );

    let out = pocketsplat(&["info", "oct.tg", "--json"], dir.path());
    assert!(out.status.success());
    let info: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(
        info["file_bytes"].as_u64().unwrap(),
        std::fs::metadata(dir.path().join("oct.tg")).unwrap().len()
    );
    let levels = info["levels"].as_array().unwrap();
    assert_eq!(levels.len(), 5);
    assert_eq!(levels[0]["depth"], 0);
    assert_eq!(levels[0]["samples"], 1);
    assert!(levels[1]["alpha"].as_f64().unwrap() > 1.0);
    assert!(levels[4]["alpha"].is_null());
    let total: u64 = levels.iter().map(|l| l["samples"].as_u64().unwrap()).sum();
    assert_eq!(info["total_samples"].as_u64().unwrap(), total);
    assert_eq!(info["leaf_samples"], levels[4]["samples"]);

    let out = pocketsplat(
        &[
            "render",
            "oct.tg",
            "-o",
            "oct.png",
            "--view",
            "30,20,2.5",
            "--stats-json",
        ],
        dir.path(),
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stats: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for key in ["nodes_visited", "splats", "max_level", "ms"] {
        assert!(stats[key].is_number(), "{key} missing from {stats}");
    }
    assert!(stats["splats"].as_u64().unwrap() > 0);
    assert!(dir.path().join("oct.png").is_file());

    // The same mesh through the reference renderer.
    let out = pocketsplat(
        &["render", "oct.ply", "-o", "ref.png", "--stats-json"],
        dir.path(),
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(dir.path().join("ref.png").is_file());
}

#[test]
fn bad_mesh_names_file_and_element_and_leaves_nothing() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("nan.ply"), octahedron_ply(Some("0 nan 0"))).unwrap();
    let before = files_in(dir.path());
    let out = pocketsplat(&["bake", "nan.ply", "-o", "nan.tg"], dir.path());
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("nan.ply") && err.contains("vertex 3"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(
        files_in(dir.path()),
        before,
        "no output or temporary file is left"
    );

    let out = pocketsplat(&["bake", "missing.ply", "-o", "x.tg"], dir.path());
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("missing.ply"));
}

#[test]
fn bad_arguments_and_bad_files_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("oct.ply"), octahedron_ply(None)).unwrap();
    std::fs::write(
        dir.path().join("junk.tg"),
        b"PSTG but not really a tri-grid file",
    )
    .unwrap();
    for (args, needle) in [
        (
            &["bake", "oct.ply", "-o", "o.tg", "--rho", "7"][..],
            "--rho 7",
        ),
        (
            &["bake", "oct.ply", "-o", "o.tg", "--block-size", "1000"][..],
            "--block-size 1000",
        ),
        (
            &["render", "oct.ply", "-o", "o.png", "--view", "1,2"][..],
            "--view",
        ),
        (
            &["render", "oct.ply", "-o", "o.png", "--fov", "200"][..],
            "--fov",
        ),
        (&["info", "junk.tg"][..], "junk.tg"),
        (&["render", "junk.tg", "-o", "o.png"][..], "junk.tg"),
    ] {
        let out = pocketsplat(args, dir.path());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} should fail");
        assert!(err.contains(needle), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
    assert!(!dir.path().join("o.tg").exists() && !dir.path().join("o.png").exists());
}

#[test]
fn no_arguments_without_a_display_writes_the_demo_png() {
    let dir = tempfile::tempdir().unwrap();
    let out = pocketsplat(&[], dir.path());
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let png = dir.path().join("pocketsplat-demo.png");
    let img = pocketsplat_sim::image::read_rgb8_frame(&png).unwrap();
    let lit = img.iter().filter(|p| **p != [0, 0, 0]).count();
    assert!(
        lit > 2000,
        "the demo frame shows the model ({lit} lit pixels)"
    );
    assert!(String::from_utf8_lossy(&out.stderr).contains("pocketsplat-demo.png"));
}

#[test]
fn qsplat_bake_info_render_and_bad_qs_files() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("oct.ply"), octahedron_ply(None)).unwrap();
    let out = pocketsplat(
        &["bake", "oct.ply", "--format", "qsplat", "-o", "oct.qs"],
        dir.path(),
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let bytes = std::fs::read(dir.path().join("oct.qs")).unwrap();

    let out = pocketsplat(&["info", "oct.qs", "--json"], dir.path());
    assert!(out.status.success());
    let info: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(info["format"], "qsplat");
    assert_eq!(info["file_bytes"].as_u64().unwrap(), bytes.len() as u64);
    assert_eq!(info["leaves"], 6);
    assert_eq!(info["tree_fragments"], 1);
    assert_eq!(info["comment_fragments"], 1);
    assert_eq!(info["byte_order"], "big");
    assert_eq!(info["color"], false);
    assert!(info["interior_nodes"].as_u64().unwrap() >= 2);
    assert!(info["pointer_share"].as_f64().unwrap() > 0.0);
    let text = pocketsplat(&["info", "oct.qs"], dir.path());
    assert!(String::from_utf8_lossy(&text.stdout).contains("6 leaves"));

    let out = pocketsplat(
        &["render", "oct.qs", "-o", "oct.png", "--stats-json"],
        dir.path(),
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stats: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(stats["renderer"], "qsplat");
    assert!(stats["splats"].as_u64().unwrap() > 0);
    let img = pocketsplat_sim::image::read_rgb8_frame(&dir.path().join("oct.png")).unwrap();
    assert!(img.iter().filter(|p| **p != [0, 0, 0]).count() > 1000);

    // A cut file, a wrong leaf count, garbage named .qs, and shadows: clear errors, no output.
    std::fs::write(dir.path().join("cut.qs"), &bytes[..bytes.len() - 4]).unwrap();
    let mut wrong = bytes.clone();
    // The comment fragment comes first; its length says where the tree's header starts.
    let tree = u32::from_be_bytes(bytes[8..12].try_into().unwrap()) as usize;
    wrong[tree + 15] ^= 1; // the tree's leaf count
    std::fs::write(dir.path().join("wrong.qs"), &wrong).unwrap();
    std::fs::write(dir.path().join("junk.qs"), b"not a qsplat file at all").unwrap();
    let before = files_in(dir.path());
    for (args, needles) in [
        (
            &["render", "cut.qs", "-o", "x.png"][..],
            &["cut.qs", "fragment"][..],
        ),
        (&["info", "wrong.qs"][..], &["wrong.qs", "leaves"][..]),
        (
            &["render", "junk.qs", "-o", "x.png"][..],
            &["junk.qs", "QSplat11"][..],
        ),
        (
            &["render", "oct.qs", "-o", "x.png", "--shadows", "one-pass"][..],
            &["shadows"][..],
        ),
        (
            &["bake", "oct.ply", "--format", "qsplat9", "-o", "x.qs"][..],
            &["qsplat9"][..],
        ),
    ] {
        let out = pocketsplat(args, dir.path());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} should fail");
        for n in needles {
            assert!(err.contains(n), "{args:?}: {err}");
        }
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
    assert_eq!(files_in(dir.path()), before, "no output is left");
}

#[test]
fn render_stream_gives_the_resident_frame_or_a_clear_error_and_no_output() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("oct.ply"), octahedron_ply(None)).unwrap();
    let out = pocketsplat(
        &[
            "bake",
            "oct.ply",
            "-o",
            "oct.tg",
            "--depth",
            "5",
            "--block-size",
            "1024",
        ],
        dir.path(),
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let view = ["--view", "30,20,1.5", "--cutoff", "1"];
    let plain = pocketsplat(
        &[&["render", "oct.tg", "-o", "plain.png"], &view[..]].concat(),
        dir.path(),
    );
    assert!(
        plain.status.success(),
        "{}",
        String::from_utf8_lossy(&plain.stderr)
    );
    let streamed = pocketsplat(
        &[
            &[
                "render",
                "oct.tg",
                "-o",
                "streamed.png",
                "--stream",
                "--io-budget",
                "4K",
                "--stats-json",
            ],
            &view[..],
        ]
        .concat(),
        dir.path(),
    );
    assert!(
        streamed.status.success(),
        "{}",
        String::from_utf8_lossy(&streamed.stderr)
    );
    let stats: serde_json::Value = serde_json::from_slice(&streamed.stdout).unwrap();
    assert!(
        stats["frames"].as_u64().unwrap() > 1,
        "{stats}: a 4 KB budget takes several frames"
    );
    assert_eq!(
        std::fs::read(dir.path().join("plain.png")).unwrap(),
        std::fs::read(dir.path().join("streamed.png")).unwrap(),
        "the converged stream is the resident frame"
    );
    // A cache too small for the file would never converge: refused at open (issue 33), naming
    // the file and the cache it needs, nothing written; through that cache it converges.
    let small = pocketsplat(
        &[
            &[
                "render",
                "oct.tg",
                "-o",
                "small.png",
                "--stream",
                "--cache",
                "4K",
                "--max-frames",
                "50",
            ],
            &view[..],
        ]
        .concat(),
        dir.path(),
    );
    assert!(!small.status.success());
    let err = String::from_utf8_lossy(&small.stderr);
    assert!(
        err.contains("oct.tg") && err.contains("--cache 4K is too small"),
        "{err}"
    );
    assert!(!dir.path().join("small.png").exists());
    let need = err.split("needs --cache ").nth(1).unwrap();
    let need = need.split_whitespace().next().unwrap();
    let enough = pocketsplat(
        &[
            &[
                "render",
                "oct.tg",
                "-o",
                "small.png",
                "--stream",
                "--cache",
                need,
            ],
            &view[..],
        ]
        .concat(),
        dir.path(),
    );
    assert!(
        enough.status.success(),
        "{}",
        String::from_utf8_lossy(&enough.stderr)
    );
    assert_eq!(
        std::fs::read(dir.path().join("plain.png")).unwrap(),
        std::fs::read(dir.path().join("small.png")).unwrap(),
        "--cache {need} converges to the resident frame"
    );
}

#[test]
fn a_scene_with_a_qs_file_bakes_lists_and_renders() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("oct.ply"), octahedron_ply(None)).unwrap();
    let out = pocketsplat(
        &["bake", "oct.ply", "--format", "qsplat", "-o", "oct.qs"],
        dir.path(),
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    std::fs::write(
        dir.path().join("scene.toml"),
        r#"
[materials.clay]
color = [0.8, 0.7, 0.6]

[materials.grass]
color = [0.2, 0.7, 0.2]

[[objects]]
name = "ground"
ground = { size = 6.0 }
depth = 3
material = "grass"

[[objects]]
name = "oct"
file = "oct.qs"
material = "clay"
anchor = "base"
rotate = { yaw = 30.0 }

[[views]]
name = "v"
az = 30.0
el = 25.0
dist = 1.5
"#,
    )
    .unwrap();
    let out = pocketsplat(&["bake", "scene.toml", "-o", "s.pack"], dir.path());
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );

    let out = pocketsplat(&["info", "s.pack", "--json"], dir.path());
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let info: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let objects = info["objects"].as_array().unwrap();
    assert_eq!(objects.len(), 2);
    assert_eq!(objects[1]["name"], "oct");
    assert_eq!(objects[1]["format"], "qsplat");
    assert_eq!(objects[1]["leaf_samples"], 6);
    assert_eq!(objects[1]["materials"], serde_json::json!(["clay"]));
    let text = pocketsplat(&["info", "s.pack"], dir.path());
    assert!(String::from_utf8_lossy(&text.stdout).contains("qsplat"));

    let out = pocketsplat(
        &[
            "render",
            "s.pack",
            "--view",
            "v",
            "-o",
            "s.png",
            "--stats-json",
        ],
        dir.path(),
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stats: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let per: Vec<u64> = stats["per_object"]
        .as_array()
        .unwrap()
        .iter()
        .map(|o| o["splats"].as_u64().unwrap())
        .collect();
    assert!(per.iter().all(|&s| s > 0), "every object draws: {per:?}");
    let img = pocketsplat_sim::image::read_rgb8_frame(&dir.path().join("s.png")).unwrap();
    assert!(img.iter().filter(|p| **p != [0, 0, 0]).count() > 1000);

    // Two materials for a .qs object: an error naming the scene file and the object, no pack.
    let bad = std::fs::read_to_string(dir.path().join("scene.toml"))
        .unwrap()
        .replace("material = \"clay\"", "materials = [\"clay\", \"grass\"]");
    std::fs::write(dir.path().join("bad.toml"), bad).unwrap();
    let out = pocketsplat(&["bake", "bad.toml", "-o", "bad.pack"], dir.path());
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("bad.toml") && err.contains("\"oct\""), "{err}");
    assert!(!dir.path().join("bad.pack").exists());
}

#[test]
fn color_by_level_tints_tg_qs_and_pack_files_with_a_key_and_refuses_a_mesh() {
    use pocketsplat_core::shade::rgb565_to_rgb888;
    use pocketsplat_core::splat::LEVEL_TINTS;
    use pocketsplat_sim::image::read_rgb8_frame;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A UV sphere of 24 × 48 quads: fine enough that a coarse cutoff stops above its leaves.
    let (rings, segments) = (24u32, 48u32);
    let mut ply = format!(
        "ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\n\
         property float z\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
        (rings + 1) * segments,
        2 * rings * segments
    );
    for i in 0..=rings {
        let th = std::f64::consts::PI * f64::from(i) / f64::from(rings);
        for j in 0..segments {
            let ph = 2.0 * std::f64::consts::PI * f64::from(j) / f64::from(segments);
            ply += &format!(
                "{} {} {}\n",
                th.sin() * ph.cos(),
                th.cos(),
                th.sin() * ph.sin()
            );
        }
    }
    let at = |i: u32, j: u32| i * segments + j % segments;
    for i in 0..rings {
        for j in 0..segments {
            ply += &format!("3 {} {} {}\n", at(i, j), at(i, j + 1), at(i + 1, j + 1));
            ply += &format!("3 {} {} {}\n", at(i, j), at(i + 1, j + 1), at(i + 1, j));
        }
    }
    std::fs::write(d.join("ball.ply"), ply).unwrap();
    let ok = |out: Output| {
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    };
    ok(pocketsplat(
        &["bake", "ball.ply", "--depth", "4", "-o", "ball.tg"],
        d,
    ));
    ok(pocketsplat(
        &["bake", "ball.ply", "--format", "qsplat", "-o", "ball.qs"],
        d,
    ));
    std::fs::write(
        d.join("scene.toml"),
        "[materials.clay]\ncolor = [0.8, 0.7, 0.6]\n\
         [[objects]]\nname = \"t\"\nfile = \"ball.tg\"\nmaterial = \"clay\"\n\
         [[objects]]\nname = \"q\"\nfile = \"ball.qs\"\nmaterial = \"clay\"\n\
         translate = [1.5, 0.0, 0.0]\n",
    )
    .unwrap();
    ok(pocketsplat(&["bake", "scene.toml", "-o", "s.pack"], d));
    for input in ["ball.tg", "ball.qs", "s.pack"] {
        ok(pocketsplat(
            &["render", input, "-o", "plain.png", "--cutoff", "24"],
            d,
        ));
        ok(pocketsplat(
            &[
                "render",
                input,
                "-o",
                "levels.png",
                "--cutoff",
                "24",
                "--color-by-level",
            ],
            d,
        ));
        let plain = read_rgb8_frame(&d.join("plain.png")).unwrap();
        let levels = read_rgb8_frame(&d.join("levels.png")).unwrap();
        // The key: a swatch per level in the bottom-left corner, 14 px apart, 10 px below its top.
        let width = pocketsplat_core::camera::WIDTH;
        let top = pocketsplat_core::camera::HEIGHT - 30;
        for (i, &tint) in LEVEL_TINTS.iter().enumerate() {
            let (x, y) = (1 + 14 * i + 5, top + 14);
            assert_eq!(
                levels[y * width + x],
                rgb565_to_rgb888(tint),
                "{input}: swatch {i}"
            );
        }
        // Above the key, tinted splats: no channel brighter than untinted, some darker.
        let model = ..top * width;
        let darker = plain[model]
            .iter()
            .zip(&levels[model])
            .filter(|(p, q)| {
                assert!(
                    (0..3).all(|c| q[c] <= p[c]),
                    "{input}: {q:?} brighter than {p:?}"
                );
                p != q
            })
            .count();
        assert!(darker > 50, "{input}: {darker} pixels tinted");
    }
    let out = pocketsplat(
        &["render", "ball.ply", "-o", "m.png", "--color-by-level"],
        d,
    );
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("ball.ply") && err.contains("--color-by-level"),
        "{err}"
    );
    assert!(!d.join("m.png").exists());
}
