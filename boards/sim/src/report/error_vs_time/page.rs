//! `results.md`: the headline table, the frames on ARM (and on another target), the comparison
//! with a baseline run, then every row.

use std::fmt::Write as _;

use super::arm;
use super::points::{budget_table, mean_plot_name, mean_points, modes_plotted, Point, ARM_PLOT};
use super::sweep::{shadows_name, Row, Subject, Sweep};

/// Why the ARM column is empty.
pub const ARM_NOT_MEASURED: &str = "not measured in this run (pass `--arm FILE`, the output of \
     `cargo run --release -p pocketsplat-tests --bin arm-bench -- --json`)";

/// The method name of a baseline run's tri-grid frames on the plots.
pub const BASELINE_METHOD: &str = "trigrid (baseline)";

/// The machine's load when the report was made (Linux), for reading the times.
pub(super) fn load_note() -> String {
    let cores = std::thread::available_parallelism().map_or(0, |n| n.get());
    match std::fs::read_to_string("/proc/loadavg") {
        Ok(l) => format!(
            "{cores} cores, load average {} at the end of the run",
            l.split_whitespace().take(3).collect::<Vec<_>>().join(" ")
        ),
        Err(_) => format!("{cores} cores"),
    }
}

/// `results.md`.
pub(super) fn markdown(
    subject: &Subject<'_>,
    sweep: &Sweep,
    rows: &[Row],
    baseline: &[Row],
    (arm, also): (&arm::ArmCounts, &[arm::ArmCounts]),
    command: &str,
) -> String {
    let mut md = format!("# Error against run time: {}\n\n", subject.name);
    let _ = writeln!(
        md,
        "Made by `{command}`. Every frame is 240 × 320 and compared with the f64 reference \
         renderer of the original meshes: PSNR over 8-bit RGB, coverage mismatch (pixels covered \
         by one image only) and holes (covered by the reference only). Time is the host's \
         CPU time of the rendering thread for setup + traversal + raster, the median of {} \
         repeat{} ({}; wall times are in `results.csv`); nodes are the cells visited (points \
         processed, for the brute force).\n",
        sweep.repeats,
        if sweep.repeats == 1 { "" } else { "s" },
        load_note()
    );
    md.push_str("| method | what |\n|---|---|\n");
    let mut seen = Vec::new();
    for r in rows {
        if !seen.contains(&&r.method) {
            seen.push(&r.method);
            let _ = writeln!(md, "| {} | {} |", r.method, r.detail);
        }
    }
    let shadow_ref = rows
        .iter()
        .find(|r| r.shadows != "off")
        .map(|r| r.reference.as_str());
    md.push('\n');
    match shadow_ref {
        Some("unshadowed") => md.push_str(
            "Shadowed frames are compared with the **unshadowed** reference (the reference \
             renderer casts no shadow rays for this subject), so their PSNR also counts the \
             shadows themselves as error.\n",
        ),
        Some(r) => {
            let _ = writeln!(md, "Shadowed frames are compared with the {r} reference.");
        }
        None => {}
    }
    if arm.is_empty() {
        let _ = writeln!(md, "ARM instructions per frame: {ARM_NOT_MEASURED}.\n");
    } else {
        let files: Vec<String> = arm.files().iter().map(|f| arm::file_name(f)).collect();
        let _ = writeln!(
            md,
            "ARM instructions per frame ({}, counted exactly under QEMU by `arm-bench --json`, \
             read from {}) are given for the frames the firmware draws, with square splats, \
             where the firmware was built with the same baked file (its CRC-32): see \
             [On ARM](#on-arm).\n",
            arm.target(),
            files.join(", ")
        );
    }
    for shadows in modes_plotted(subject) {
        let _ = writeln!(
            md,
            "## Best PSNR within a time budget, shadows {shadows}\n\nMean over the views: for \
             each method the best mean PSNR among its configurations (cutoff, kernel) whose mean \
             time fits the budget; 〃 is the same frame as in the smaller budget.\n"
        );
        md.push_str(&budget_table(&mean_points(rows, shadows, |r| Some(r.ms))));
        let _ = writeln!(
            md,
            "\n![PSNR against time, mean over views, shadows {shadows}]({})\n",
            mean_plot_name(subject, shadows)
        );
    }
    if !arm.is_empty() {
        md.push_str(&arm_section(subject, rows));
        for other in also {
            md.push_str(&other_target_section(subject, rows, other));
        }
    }
    if !baseline.is_empty() {
        md.push_str(&baseline_section(rows, baseline));
    }
    for (view, _) in &subject.views {
        let _ = writeln!(md, "\n## View `{view}`\n");
        let points: Vec<Point> = rows
            .iter()
            .filter(|r| &r.view == view && r.shadows == "off")
            .map(|r| Point::of(r, r.ms))
            .collect();
        md.push_str(&budget_table(&points));
        let _ = writeln!(
            md,
            "\n![PSNR against time, view {view}](psnr-vs-ms-{view}.png)\n"
        );
        md.push_str(
            "| method | kernel | shadows | cutoff px | PSNR dB | coverage mismatch | holes | \
             ms/frame | nodes | splats | ARM instructions |\n\
             |---|---|---|---|---|---|---|---|---|---|---|\n",
        );
        for r in rows.iter().filter(|r| &r.view == view) {
            let _ = writeln!(
                md,
                "| {} | {} | {} | {} | {:.2} | {:.2}% | {:.3}% | {:.2} | {} | {} | {} |",
                r.method,
                r.kernel,
                r.shadows,
                r.cutoff_px.map_or("—".to_owned(), |c| c.to_string()),
                r.psnr_db,
                100.0 * r.coverage_mismatch,
                100.0 * r.holes,
                r.ms,
                r.nodes_visited,
                r.splats,
                r.arm_instructions
                    .map_or("not measured".to_owned(), |n| n.to_string()),
            );
        }
    }
    md
}

/// The frames of `rows` that have a count for `other` (a second target, as `arm-bench` ran it on
/// the same baked file), beside the quoted target's count.
pub(super) fn other_target_section(
    subject: &Subject<'_>,
    rows: &[Row],
    other: &arm::ArmCounts,
) -> String {
    let own = shadows_name(subject.shadows);
    let mut md = format!(
        "\n### The same frames on {}\n\nShadows {own}, square splats: instructions per frame \
         on {} beside the quoted target's.\n\n| view | method | cutoff px | PSNR dB | {} | \
         quoted target | fps at 200 MHz |\n|---|---|---|---|---|---|---|\n",
        other.target(),
        other.target(),
        other.target()
    );
    for r in rows
        .iter()
        .filter(|r| r.shadows == own && r.kernel == "square")
    {
        let (Some(crc), Some(cutoff)) = (r.file_crc, r.cutoff_px) else {
            continue;
        };
        let Some(n) = other.get(crc, &r.view, cutoff, own, &r.kernel) else {
            continue;
        };
        let _ = writeln!(
            md,
            "| {} | {} | {cutoff} | {:.2} | {:.2} M | {} | {:.2} |",
            r.view,
            r.method,
            r.psnr_db,
            n as f64 / 1e6,
            r.arm_instructions
                .map_or("—".to_owned(), |q| format!("{:.2} M", q as f64 / 1e6)),
            200e6 / n as f64
        );
    }
    md
}

/// The tri-grid frames of this run beside the baseline's with the same view, shadows, kernel and
/// cutoff: PSNR, nodes and ARM instructions, before and after.
pub(super) fn baseline_section(rows: &[Row], baseline: &[Row]) -> String {
    let mut md = format!(
        "\n## Against the baseline\n\nThe tri-grid frames of this run beside those of the \
         baseline run (`--baseline`; `{BASELINE_METHOD}` on the plots), square splats.\n\n\
         | view | shadows | cutoff px | PSNR dB before | after | nodes before | after | ARM \
         instructions before | after |\n|---|---|---|---|---|---|---|---|---|\n"
    );
    let m = |n: Option<u64>| n.map_or("—".to_owned(), |n| format!("{:.2} M", n as f64 / 1e6));
    for r in rows
        .iter()
        .filter(|r| r.method == "trigrid" && r.kernel == "square")
    {
        let Some(b) = baseline.iter().find(|b| {
            b.view == r.view
                && b.shadows == r.shadows
                && b.kernel == r.kernel
                && b.cutoff_px == r.cutoff_px
        }) else {
            continue;
        };
        let _ = writeln!(
            md,
            "| {} | {} | {} | {:.2} | {:.2} | {} | {} | {} | {} |",
            r.view,
            r.shadows,
            r.cutoff_px.map_or("—".to_owned(), |c| c.to_string()),
            b.psnr_db,
            r.psnr_db,
            b.nodes_visited,
            r.nodes_visited,
            m(b.arm_instructions),
            m(r.arm_instructions)
        );
    }
    md
}

/// `## On ARM`: the frames with an instruction count, in the subject's own shadows, per view: cost,
/// frames per second at 200 MHz, PSNR and its loss against the same method's 1 px frame, and the
/// cheapest frame within 1 dB of 1 px.
pub(super) fn arm_section(subject: &Subject<'_>, rows: &[Row]) -> String {
    let own = shadows_name(subject.shadows);
    let mut md = format!(
        "## On ARM\n\nShadows {own}. Frames per second assume one instruction per cycle at \
         200 MHz; Δ is the PSNR lost against the same method's frame at 1 px.\n\n\
         ![PSNR against ARM instructions per frame, mean over views]({ARM_PLOT})\n\n\
         | view | method | cutoff px | PSNR dB | Δ dB | ARM instructions | fps at 200 MHz | host \
         ms |\n|---|---|---|---|---|---|---|---|\n"
    );
    let mut cheapest = String::new();
    for (view, _) in &subject.views {
        let mut on: Vec<&Row> = rows
            .iter()
            .filter(|r| &r.view == view && r.shadows == own && r.arm_instructions.is_some())
            .collect();
        on.sort_by(|a, b| {
            a.method.cmp(&b.method).then(
                a.cutoff_px
                    .unwrap_or(0.0)
                    .total_cmp(&b.cutoff_px.unwrap_or(0.0)),
            )
        });
        for r in &on {
            let fine = on
                .iter()
                .find(|f| f.method == r.method && f.cutoff_px == Some(1.0));
            let n = r.arm_instructions.expect("filtered");
            let _ = writeln!(
                md,
                "| {view} | {} | {} | {:.2} | {} | {:.1} M | {:.2} | {:.2} |",
                r.method,
                r.cutoff_px.map_or("—".to_owned(), |c| c.to_string()),
                r.psnr_db,
                fine.map_or("—".to_owned(), |f| format!(
                    "{:.2}",
                    f.psnr_db - r.psnr_db
                )),
                n as f64 / 1e6,
                200e6 / n as f64,
                r.ms
            );
        }
        let mut methods: Vec<&str> = on.iter().map(|r| r.method.as_str()).collect();
        methods.dedup();
        for m in methods {
            let Some(fine) = on
                .iter()
                .find(|f| f.method == m && f.cutoff_px == Some(1.0))
            else {
                continue;
            };
            if let Some(best) = on
                .iter()
                .filter(|r| r.method == m && r.psnr_db >= fine.psnr_db - 1.0)
                .min_by_key(|r| r.arm_instructions)
            {
                let _ = writeln!(
                    cheapest,
                    "- `{view}`, {m}: {} px, {:.1} M instructions ({:.2} dB; 1 px: {:.1} M, \
                     {:.2} dB)",
                    best.cutoff_px.unwrap_or(1.0),
                    best.arm_instructions.expect("filtered") as f64 / 1e6,
                    best.psnr_db,
                    fine.arm_instructions.expect("filtered") as f64 / 1e6,
                    fine.psnr_db
                );
            }
        }
    }
    if !cheapest.is_empty() {
        md.push_str("\nThe cheapest frame on ARM within 1 dB of the 1 px frame:\n\n");
        md.push_str(&cheapest);
    }
    md.push('\n');
    md
}
