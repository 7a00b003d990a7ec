//! `pocketsplat report error-vs-time --quick` as CI runs it: the smallest Stanford bunny at depth 4,
//! every row the sweep promises and no other, numbers in their ranges, plots that decode and show
//! curves, and no output at all when the input is bad.

use crate::common;
use common::{model, models_dir, pocketsplat};

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use pocketsplat_sim::image::decode_rgb8_png;
use pocketsplat_sim::report::error_vs_time::CSV_HEADER;

/// A CSV line split on commas outside double quotes.
fn fields(line: &str) -> Vec<String> {
    let mut out = vec![String::new()];
    let mut quoted = false;
    for c in line.chars() {
        match c {
            '"' => quoted = !quoted,
            ',' if !quoted => out.push(String::new()),
            _ => out.last_mut().unwrap().push(c),
        }
    }
    out
}

#[test]
fn quick_sweep_writes_every_row_and_plot() {
    let Some(bunny) = model("bun_zipper_res4.ply") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = pocketsplat(
        &[
            "report",
            "error-vs-time",
            bunny.to_str().unwrap(),
            "-o",
            "report",
            "--quick",
        ],
        dir.path(),
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report = dir.path().join("report");

    // The CSV: exactly the promised rows.
    let text = std::fs::read_to_string(report.join("results.csv")).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some(CSV_HEADER));
    let header: Vec<&str> = CSV_HEADER.split(',').collect();
    let rows: Vec<BTreeMap<&str, String>> = lines
        .map(|l| {
            let f = fields(l);
            assert_eq!(f.len(), header.len(), "{l}");
            header.iter().copied().zip(f).collect()
        })
        .collect();
    let mut expected = BTreeSet::new();
    for view in ["std", "front", "close", "far"] {
        for kernel in ["square", "round"] {
            for method in ["trigrid", "octree"] {
                for shadows in ["off", "one-pass", "two-pass"] {
                    for cutoff in ["1", "4"] {
                        expected.insert([view, method, kernel, shadows, cutoff].map(str::to_owned));
                    }
                }
            }
            for cutoff in ["1", "4"] {
                expected.insert([view, "qsplat", kernel, "off", cutoff].map(str::to_owned));
            }
            expected.insert([view, "brute", kernel, "off", ""].map(str::to_owned));
        }
    }
    let got: Vec<[String; 5]> = rows
        .iter()
        .map(|r| ["view", "method", "kernel", "shadows", "cutoff_px"].map(|k| r[k].clone()))
        .collect();
    let got_set: BTreeSet<[String; 5]> = got.iter().cloned().collect();
    assert_eq!(got.len(), got_set.len(), "a configuration appears twice");
    assert_eq!(got_set, expected);

    // The numbers: in range, and consistent with what each method is.
    let num = |r: &BTreeMap<&str, String>, k: &str| -> f64 {
        r[k].parse()
            .unwrap_or_else(|_| panic!("{k} = {:?} in {r:?}", r[k]))
    };
    for r in &rows {
        let psnr = num(r, "psnr_db");
        assert!(psnr > 5.0 && psnr < 60.0, "{r:?}");
        let cov = num(r, "coverage_mismatch");
        assert!((0.0..=1.0).contains(&cov), "{r:?}");
        if r["method"] != "qsplat" {
            // The grids' leaves are smaller than a pixel in most views; QSplat's 453 leaves are
            // not, and leave holes in the close view.
            assert!(psnr > 15.0 && cov < 0.1, "{r:?}");
        }
        assert!(num(r, "holes") <= cov, "{r:?}");
        assert!(num(r, "ms") > 0.0 && num(r, "wall_ms") > 0.0, "{r:?}");
        let (nodes, splats) = (num(r, "nodes_visited"), num(r, "splats"));
        assert!(splats > 0.0 && nodes >= splats, "{r:?}");
        if r["method"] != "qsplat" {
            // Grids at depth 4 have thousands of leaves; QSplat has one per vertex.
            assert!(splats > 100.0, "{r:?}");
        }
        assert_eq!(r["arm_instructions"], "", "{r:?}");
        let reference = r["reference"].as_str();
        if r["shadows"] == "off" {
            assert_eq!(reference, "-");
        } else {
            assert_eq!(reference, "ray-cast", "{r:?}");
        }
    }
    // The brute force processes every leaf of the tri-grid in every view.
    let leaves: BTreeSet<String> = rows
        .iter()
        .filter(|r| r["method"] == "brute")
        .map(|r| r["nodes_visited"].clone())
        .collect();
    assert_eq!(leaves.len(), 1, "{leaves:?}");
    let trigrid_detail = &rows.iter().find(|r| r["method"] == "trigrid").unwrap()["detail"];
    let leaves = leaves.into_iter().next().unwrap();
    assert!(
        trigrid_detail.contains(&format!("{leaves} leaves")),
        "{trigrid_detail} vs {leaves} points"
    );
    // A coarser cutoff never visits more nodes.
    for r in rows.iter().filter(|r| r["cutoff_px"] == "4") {
        let fine = rows
            .iter()
            .find(|f| {
                f["cutoff_px"] == "1"
                    && ["view", "method", "kernel", "shadows"]
                        .iter()
                        .all(|k| f[k] == r[k])
            })
            .unwrap();
        assert!(
            num(r, "nodes_visited") <= num(fine, "nodes_visited"),
            "{r:?}"
        );
    }

    // The markdown: the headline table and every view's table.
    let md = std::fs::read_to_string(report.join("results.md")).unwrap();
    assert!(md.contains("## Best PSNR within a time budget"));
    for m in ["trigrid", "octree", "qsplat", "brute"] {
        assert!(
            md.lines()
                .any(|l| l.starts_with(&format!("| {m} | ")) && l.contains(" dB (")),
            "no budget line for {m}"
        );
    }
    assert!(md.contains("not measured"));
    assert_eq!(md.matches("\n| trigrid | square | off | 1 |").count(), 4);

    // The plots: decode, right size, curves in the methods' colours, text.
    for view in ["", "-std", "-front", "-close", "-far"] {
        let name = format!("psnr-vs-ms{view}.png");
        assert!(
            md.contains(&format!("]({name})")),
            "results.md does not show {name}"
        );
        let bytes = std::fs::read(report.join(&name)).unwrap();
        let img = decode_rgb8_png(&bytes).unwrap();
        assert_eq!((img.width, img.height), (900, 600), "{name}");
        let count = |c: [u8; 3]| img.pixels.iter().filter(|&&p| p == c).count();
        // At least a front dot (a disc of radius 4) of each method's colour, where curves that
        // lie close together may overlap.
        for (colour, method) in [
            ([31, 119, 180], "tri-grid"),
            ([230, 120, 20], "octree"),
            ([44, 160, 44], "QSplat"),
            ([30, 30, 30], "brute-force"),
        ] {
            assert!(count(colour) > 20, "{name}: no {method} curve");
        }
        let white = count([255, 255, 255]);
        assert!(
            white > img.pixels.len() / 2 && white < img.pixels.len(),
            "{name}: blank"
        );
    }
    // Nothing else: no temporary files left behind.
    let mut names: Vec<String> = std::fs::read_dir(&report)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names.len(), 7, "{names:?}");
}

#[test]
fn bad_input_names_the_file_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = pocketsplat(
        &[
            "report",
            "error-vs-time",
            "missing.ply",
            "-o",
            "report",
            "--quick",
        ],
        dir.path(),
    );
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("missing.ply"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(!dir.path().join("report").exists());

    // A broken mesh: the same, and nothing created.
    std::fs::write(
        dir.path().join("bad.ply"),
        "ply\nformat ascii 1.0\nend_header\n",
    )
    .unwrap();
    let out = pocketsplat(
        &[
            "report",
            "error-vs-time",
            "bad.ply",
            "-o",
            "report",
            "--quick",
        ],
        dir.path(),
    );
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("bad.ply"), "{err}");
    assert!(!dir.path().join("report").exists());

    // An output path that is a file.
    std::fs::write(dir.path().join("taken"), "x").unwrap();
    let out = pocketsplat(
        &[
            "report",
            "error-vs-time",
            "bad.ply",
            "-o",
            "taken",
            "--quick",
        ],
        dir.path(),
    );
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("taken"));
    assert_eq!(std::fs::read(dir.path().join("taken")).unwrap(), b"x");
}

/// The rows of a `results.csv`, by column name.
fn csv_rows(path: &Path) -> Vec<BTreeMap<String, String>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some(CSV_HEADER));
    let header: Vec<&str> = CSV_HEADER.split(',').collect();
    lines
        .map(|l| {
            let f = fields(l);
            assert_eq!(f.len(), header.len(), "{l}");
            header.iter().map(|h| (*h).to_owned()).zip(f).collect()
        })
        .collect()
}

/// `report error-vs-time` of the Big Scene's file, `--quick`: every view of the scene, both packs,
/// shadowed frames against ray-cast shadows; then again with an `arm-bench --json` file for one of
/// its frames, which that frame (and only it) gets, and the ARM section and plot appear; a count
/// file for another bake is refused and nothing is written.
#[test]
fn quick_sweep_of_the_big_scene_with_arm_counts() {
    if model("bun_zipper.ply.gz").is_none()
        || model("dragon_vrip.ply.gz").is_none()
        || model("happy_vrip_res3.ply.gz").is_none()
    {
        return;
    }
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/big.toml");
    let scene = scene.to_str().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let run = |extra: &[&str], out: &str| {
        let mut args = vec!["report", "error-vs-time", scene, "-o", out, "--quick"];
        args.extend_from_slice(extra);
        let mut cmd = common::command(&args, dir.path());
        if std::env::var_os("POCKETSPLAT_MODELS").is_none() {
            cmd.env("POCKETSPLAT_MODELS", models_dir());
        }
        cmd.output().expect("pocketsplat runs")
    };
    let out = run(&[], "plain");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rows = csv_rows(&dir.path().join("plain/results.csv"));
    let mut expected = BTreeSet::new();
    for view in ["std", "front", "top", "far"] {
        for kernel in ["square", "round"] {
            for method in ["trigrid", "octree"] {
                for shadows in ["off", "one-pass", "two-pass"] {
                    for cutoff in ["1", "4"] {
                        expected.insert([view, method, kernel, shadows, cutoff].map(str::to_owned));
                    }
                }
            }
            expected.insert([view, "brute", kernel, "off", ""].map(str::to_owned));
        }
    }
    let got: BTreeSet<[String; 5]> = rows
        .iter()
        .map(|r| ["view", "method", "kernel", "shadows", "cutoff_px"].map(|k| r[k].clone()))
        .collect();
    assert_eq!(got.len(), rows.len(), "a configuration appears twice");
    assert_eq!(got, expected);
    let num = |r: &BTreeMap<String, String>, k: &str| -> f64 { r[k].parse().unwrap() };
    for r in &rows {
        assert_eq!(r["scene"], "big.toml");
        let psnr = num(r, "psnr_db");
        // Six objects and a ground at depth ≤ 4 against their meshes: clearly alike, not equal.
        assert!(psnr > 18.0 && psnr < 40.0, "{r:?}");
        assert!(num(r, "coverage_mismatch") < 0.08, "{r:?}");
        assert!(num(r, "splats") > 1000.0, "{r:?}");
        assert_eq!(r["arm_instructions"], "", "{r:?}");
        let want = if r["shadows"] == "off" {
            "-"
        } else {
            "ray-cast"
        };
        assert_eq!(r["reference"], want, "{r:?}");
    }
    let md = std::fs::read_to_string(dir.path().join("plain/results.md")).unwrap();
    assert!(md.contains("ray-cast reference"), "{md}");
    assert!(md.contains("not measured in this run"), "{md}");
    assert!(!md.contains("## On ARM"));
    for plot in [
        "psnr-vs-ms.png",
        "psnr-vs-ms-one-pass.png",
        "psnr-vs-ms-top.png",
    ] {
        assert!(md.contains(&format!("]({plot})")), "{plot}");
        decode_rgb8_png(&std::fs::read(dir.path().join("plain").join(plot)).unwrap()).unwrap();
    }
    assert!(!dir.path().join("plain/psnr-vs-arm.png").exists());

    // The pack's CRC, from the method's detail, keys the ARM counts.
    let detail = &rows.iter().find(|r| r["method"] == "trigrid").unwrap()["detail"];
    let crc = detail
        .split("file CRC ")
        .nth(1)
        .unwrap_or_else(|| panic!("no CRC in {detail:?}"));
    let line = |crc: &str, view: &str, cutoff: u32, n: u64| {
        format!(
            "{{\"model\":\"big.pack\",\"model_crc\":\"{crc}\",\"target\":\"thumbv7m-none-eabi\",\
             \"build\":\"scene,shadows\",\"view\":\"{view}\",\"cutoff_px\":{cutoff},\
             \"shadows\":\"one-pass\",\"kernel\":\"square\",\"instructions\":{n}}}\n"
        )
    };
    let mut counts = String::new();
    for (view, n) in [("std", 1), ("front", 2), ("top", 3), ("far", 4)] {
        counts.push_str(&line(crc, view, 1, 40_000_000 + n));
        counts.push_str(&line(crc, view, 4, 10_000_000 + n));
    }
    std::fs::write(dir.path().join("arm.jsonl"), counts).unwrap();
    let out = run(&["--arm", "arm.jsonl"], "arm");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rows = csv_rows(&dir.path().join("arm/results.csv"));
    let with: Vec<_> = rows
        .iter()
        .filter(|r| !r["arm_instructions"].is_empty())
        .collect();
    assert_eq!(with.len(), 8, "{with:?}");
    for r in with {
        assert_eq!(
            [&r["method"], &r["kernel"], &r["shadows"]],
            ["trigrid", "square", "one-pass"]
        );
        let base = if r["cutoff_px"] == "1" { 40 } else { 10 };
        let n = ["std", "front", "top", "far"]
            .iter()
            .position(|v| *v == r["view"])
            .unwrap() as u64
            + 1;
        assert_eq!(num(r, "arm_instructions") as u64, base * 1_000_000 + n);
    }
    let md = std::fs::read_to_string(dir.path().join("arm/results.md")).unwrap();
    assert!(md.contains("## On ARM"), "{md}");
    assert!(md.contains("| std | trigrid | 4 |"), "{md}");
    assert!(md.contains("within 1 dB of the 1 px frame"), "{md}");
    decode_rgb8_png(&std::fs::read(dir.path().join("arm/psnr-vs-arm.png")).unwrap()).unwrap();

    // Counts for another bake: refused, naming the file and both CRCs, and nothing written.
    std::fs::write(
        dir.path().join("other.jsonl"),
        line("0x12345678", "std", 1, 5),
    )
    .unwrap();
    let out = run(&["--arm", "other.jsonl"], "other");
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("other.jsonl") && err.contains("0x12345678") && err.contains(crc),
        "{err}"
    );
    assert!(!dir.path().join("other").exists());
}

#[test]
fn a_pack_is_refused_with_a_reason() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("s.pack"), b"PSPK").unwrap();
    let out = pocketsplat(
        &["report", "error-vs-time", "s.pack", "-o", "report"],
        dir.path(),
    );
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("s.pack") && err.contains(".toml"), "{err}");
    assert!(!dir.path().join("report").exists());
}
