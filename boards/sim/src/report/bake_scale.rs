//! `pocketsplat report bake-scale`: how bakes grow with the mesh (issue 32). For each size a
//! displaced sphere is generated ([`crate::generate`], kept in the work folder for reruns) and
//! baked into `.qs` and `.tg` by this program as a child process, within one `--memory` budget;
//! the wall time, the peak resident size (the child's own `VmHWM`, from its summary line) and the
//! output's bytes go into a CSV, a Markdown table and a PNG plot (time and peak memory against
//! triangles, log–log). `scripts/bake-scale` runs it for 1, 8, 32 and 100 M triangles.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use anyhow::{anyhow, bail, Context, Result};
use plotters::prelude::*;

use super::error_vs_time::plot::register_font;
use crate::bake::budget::human;
use crate::generate::Sphere;
use crate::image::encode_rgb8_png;

/// What to measure.
#[derive(Clone, Debug)]
pub struct ScaleOptions {
    /// Triangles of each mesh (about: the sphere has `12 n²`).
    pub sizes: Vec<u64>,
    /// The budget of every bake (`--memory`).
    pub memory: u64,
    /// Depth of the `.tg` bakes.
    pub depth: u8,
    /// Where the meshes are generated (and kept) and the outputs written (and removed).
    pub work: PathBuf,
    /// Output prefix: `PREFIX.csv`, `PREFIX.md`, `PREFIX.png`.
    pub out: PathBuf,
    /// Bake every size out of core (`bake --out-of-core`), so that the sizes that fit in memory
    /// show the out-of-core path too.
    pub out_of_core: bool,
}

/// One bake measured.
#[derive(Clone, Debug, PartialEq)]
pub struct ScaleRow {
    /// Triangles of the mesh.
    pub triangles: u64,
    /// `qs` or `tg`.
    pub format: String,
    /// Wall time, seconds.
    pub seconds: f64,
    /// Peak resident size, bytes.
    pub peak_rss: u64,
    /// Output bytes.
    pub bytes: u64,
    /// Pieces of an out-of-core bake (0: baked in memory).
    pub pieces: u64,
}

/// The number after `key` in `text` (`peak RSS 1.23 GB` → bytes with `unit`).
fn field(text: &str, key: &str) -> Option<(f64, String)> {
    let at = text.rfind(key)? + key.len();
    let mut words = text[at..].split_whitespace();
    let value = words.next()?.trim_end_matches(',').parse().ok()?;
    let unit = words.next().unwrap_or_default().to_owned();
    Some((value, unit))
}

/// Bytes from a summary's `1.23 GB`.
fn bytes_of((v, unit): (f64, String)) -> Option<u64> {
    let scale = match unit.trim_end_matches(|c: char| !c.is_alphabetic()) {
        "B" => 1u64,
        "KB" => 1 << 10,
        "MB" => 1 << 20,
        "GB" => 1 << 30,
        "TB" => 1 << 40,
        _ => return None,
    };
    Some((v * scale as f64) as u64)
}

/// Runs the bakes with the program `exe`; appends each row to `PREFIX.csv` as it is measured.
///
/// # Errors
/// When a mesh cannot be generated, a bake fails (its message is passed on) or a file cannot be
/// written.
pub fn measure(o: &ScaleOptions, exe: &Path) -> Result<Vec<ScaleRow>> {
    std::fs::create_dir_all(&o.work)
        .with_context(|| format!("cannot create {}", o.work.display()))?;
    let csv = o.out.with_extension("csv");
    std::fs::write(
        &csv,
        "triangles,format,seconds,peak_rss_bytes,output_bytes,pieces\n",
    )
    .with_context(|| format!("cannot write {}", csv.display()))?;
    let mut rows = Vec::new();
    for &n in &o.sizes {
        let sphere = Sphere::with_triangles(n, 1);
        let mesh = o.work.join(format!("sphere-{}.ply", sphere.triangles()));
        if std::fs::metadata(&mesh).map(|m| m.len()).ok() != Some(sphere.file_bytes()) {
            eprintln!(
                "generating {} ({} triangles)",
                mesh.display(),
                sphere.triangles()
            );
            sphere.write(&mesh, &|_| {})?;
        }
        for format in ["qs", "tg"] {
            let out = o.work.join(format!("scale.{format}"));
            let t = Instant::now();
            let run = Command::new(exe)
                .arg("bake")
                .arg(&mesh)
                .arg("-o")
                .arg(&out)
                .args(["--format", format, "--depth", &o.depth.to_string()])
                .args(["--memory", &o.memory.to_string()])
                .args(o.out_of_core.then_some("--out-of-core"))
                .output()
                .with_context(|| format!("cannot run {}", exe.display()))?;
            let seconds = t.elapsed().as_secs_f64();
            let err = String::from_utf8_lossy(&run.stderr);
            if !run.status.success() {
                bail!("{} → {format}: {}", mesh.display(), err.trim());
            }
            let summary = err.lines().last().unwrap_or_default();
            let peak_rss = field(summary, "peak RSS ")
                .and_then(bytes_of)
                .ok_or_else(|| anyhow!("no peak RSS in {summary:?}"))?;
            let pieces = summary
                .find(" pieces (largest")
                .and_then(|at| summary[..at].rsplit(' ').next()?.parse().ok())
                .unwrap_or(0);
            let bytes = std::fs::metadata(&out)?.len();
            std::fs::remove_file(&out).ok();
            let row = ScaleRow {
                triangles: sphere.triangles(),
                format: format.to_owned(),
                seconds,
                peak_rss,
                bytes,
                pieces,
            };
            eprintln!("{summary}");
            let line = format!(
                "{},{},{:.2},{},{},{}\n",
                row.triangles, row.format, row.seconds, row.peak_rss, row.bytes, row.pieces
            );
            let mut f = std::fs::OpenOptions::new().append(true).open(&csv)?;
            std::io::Write::write_all(&mut f, line.as_bytes())?;
            rows.push(row);
        }
    }
    Ok(rows)
}

/// The rows of a CSV [`measure`] wrote.
///
/// # Errors
/// When it cannot be read or a row does not parse.
pub fn read_csv(path: &Path) -> Result<Vec<ScaleRow>> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    text.lines()
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            let bad = || anyhow!("{}: bad row {l:?}", path.display());
            if f.len() != 6 {
                return Err(bad());
            }
            Ok(ScaleRow {
                triangles: f[0].parse().map_err(|_| bad())?,
                format: f[1].to_owned(),
                seconds: f[2].parse().map_err(|_| bad())?,
                peak_rss: f[3].parse().map_err(|_| bad())?,
                bytes: f[4].parse().map_err(|_| bad())?,
                pieces: f[5].parse().map_err(|_| bad())?,
            })
        })
        .collect()
}

/// The Markdown table.
pub fn table(rows: &[ScaleRow], o: &ScaleOptions) -> String {
    let mut s = "| triangles | format | seconds | peak RSS | output bytes | pieces |\n\
                 |---|---|---|---|---|---|\n"
        .to_owned();
    for r in rows {
        let what = if r.format == "tg" {
            format!("`.tg` depth {}", o.depth)
        } else {
            "`.qs`".to_owned()
        };
        let _ = writeln!(
            s,
            "| {:.1} M | {what} | {:.1} | {} | {} | {} |",
            r.triangles as f64 / 1e6,
            r.seconds,
            human(r.peak_rss),
            r.bytes,
            if r.pieces == 0 {
                "in memory".to_owned()
            } else {
                r.pieces.to_string()
            }
        );
    }
    s
}

/// The plot: wall time and peak RSS against triangles, both formats, log–log, the budget drawn.
///
/// # Errors
/// When plotters fails or the PNG cannot be encoded.
pub fn plot(rows: &[ScaleRow], memory: u64) -> Result<Vec<u8>> {
    register_font()?;
    let (w, h) = (1000u32, 480u32);
    let mut buf = vec![0u8; w as usize * h as usize * 3];
    draw(&mut buf, (w, h), rows, memory).map_err(|e| anyhow!("plot: {e}"))?;
    let pixels: Vec<[u8; 3]> = buf.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    encode_rgb8_png(w, h, &pixels)
}

fn draw(
    buf: &mut [u8],
    size: (u32, u32),
    rows: &[ScaleRow],
    memory: u64,
) -> Result<(), Box<dyn std::error::Error>> {
    let root = BitMapBackend::with_buffer(buf, size).into_drawing_area();
    root.fill(&WHITE)?;
    let panels = root.split_evenly((1, 2));
    let m = |t: u64| t as f64 / 1e6;
    let x0 = rows
        .iter()
        .map(|r| m(r.triangles))
        .fold(f64::INFINITY, f64::min)
        / 1.5;
    let x1 = rows.iter().map(|r| m(r.triangles)).fold(0.0, f64::max) * 1.5;
    let series = |f: &str| -> Vec<&ScaleRow> { rows.iter().filter(|r| r.format == f).collect() };
    let colours = [
        ("qs", RGBColor(44, 160, 44)),
        ("tg", RGBColor(31, 119, 180)),
    ];
    for (k, panel) in panels.iter().enumerate() {
        let value = |r: &ScaleRow| -> f64 {
            if k == 0 {
                r.seconds
            } else {
                r.peak_rss as f64 / f64::from(1u32 << 30)
            }
        };
        let top = rows.iter().map(value).fold(0.0, f64::max).max(if k == 1 {
            memory as f64 / f64::from(1u32 << 30)
        } else {
            1.0
        });
        let bottom = rows
            .iter()
            .map(value)
            .fold(f64::INFINITY, f64::min)
            .min(top)
            / 2.0;
        let mut chart = ChartBuilder::on(panel)
            .caption(
                if k == 0 {
                    "wall time"
                } else {
                    "peak resident memory"
                },
                ("sans-serif", 20),
            )
            .margin(14)
            .x_label_area_size(44)
            .y_label_area_size(56)
            .build_cartesian_2d(
                (x0.max(1e-3)..x1).log_scale(),
                (bottom.max(1e-3)..top * 1.6).log_scale(),
            )?;
        chart
            .configure_mesh()
            .x_desc("triangles, millions (log)")
            .y_desc(if k == 0 { "seconds (log)" } else { "GiB (log)" })
            .label_style(("sans-serif", 14))
            .axis_desc_style(("sans-serif", 15))
            .light_line_style(RGBColor(240, 240, 240))
            .draw()?;
        for (name, col) in colours {
            let pts: Vec<(f64, f64)> = series(name)
                .iter()
                .map(|r| (m(r.triangles), value(r)))
                .collect();
            chart
                .draw_series(LineSeries::new(pts.clone(), col.stroke_width(2)))?
                .label(if name == "qs" { ".qs" } else { ".tg" })
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], col.stroke_width(3))
                });
            chart.draw_series(pts.iter().map(|&p| Circle::new(p, 4, col.filled())))?;
        }
        if k == 1 {
            let b = memory as f64 / f64::from(1u32 << 30);
            chart
                .draw_series(LineSeries::new(
                    vec![(x0.max(1e-3), b), (x1, b)],
                    RGBColor(200, 40, 40).stroke_width(1),
                ))?
                .label("--memory")
                .legend(|(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], RGBColor(200, 40, 40))
                });
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .label_font(("sans-serif", 14))
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK)
            .draw()?;
    }
    root.present()?;
    Ok(())
}

/// Measures, then writes `PREFIX.md` (the table) and `PREFIX.png` (the plot) beside the CSV.
///
/// # Errors
/// As [`measure`], and when the table or plot cannot be written.
pub fn run(o: &ScaleOptions, exe: &Path) -> Result<Vec<ScaleRow>> {
    let rows = measure(o, exe)?;
    write_page(&rows, o)?;
    Ok(rows)
}

/// Writes `PREFIX.md` and `PREFIX.png` for `rows`.
///
/// # Errors
/// When a file cannot be written.
pub fn write_page(rows: &[ScaleRow], o: &ScaleOptions) -> Result<()> {
    let md = o.out.with_extension("md");
    let png = o.out.with_extension("png");
    let name = png
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let page = format!(
        "# Bakes of generated scans{}\n\nMeasured by `pocketsplat --memory {} report bake-scale{}` \
         (`scripts/bake-scale`) on the 2-core machine: a displaced sphere of each size (`pocketsplat \
         generate`) baked into `.qs` and `.tg` (ρ 3, depth {}) by a child process within the \
         budget; wall time, peak resident memory (the bake's own `VmHWM`) and output bytes. \
         \"pieces\": baked out of core in that many pieces; \"in memory\": the bake fitted the \
         budget. Wall times depend on what else the machine runs.\n\n{}\n![time and peak memory \
         against triangles]({name})\n",
        if o.out_of_core { ", all out of core" } else { "" },
        crate::args::format_size(o.memory),
        if o.out_of_core { " --out-of-core" } else { "" },
        o.depth,
        table(rows, o)
    );
    std::fs::write(&md, page).with_context(|| format!("cannot write {}", md.display()))?;
    std::fs::write(&png, plot(rows, o.memory)?)
        .with_context(|| format!("cannot write {}", png.display()))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn summaries_parse_and_the_page_draws() {
        let s = "x.qs: QSplat: 5 leaves; 3.20 s, peak RSS 1.50 GB (out of core within 4.00 GB, \
                 12 pieces (largest 9 points): reading 1.0 s)";
        assert_eq!(field(s, "peak RSS ").and_then(bytes_of), Some(3 << 29));
        let rows: Vec<ScaleRow> = [(1_000_000, "qs", 3.0), (8_000_000, "tg", 20.0)]
            .iter()
            .map(|&(t, f, s)| ScaleRow {
                triangles: t,
                format: f.into(),
                seconds: s,
                peak_rss: 1 << 30,
                bytes: 1000,
                pieces: 3,
            })
            .collect();
        let o = ScaleOptions {
            sizes: vec![],
            memory: 4 << 30,
            depth: 7,
            work: PathBuf::new(),
            out: PathBuf::new(),
            out_of_core: false,
        };
        assert!(table(&rows, &o).contains("| 8.0 M | `.tg` depth 7 | 20.0 | 1.00 GB | 1000 | 3 |"));
        let png = plot(&rows, 4 << 30).unwrap();
        assert_eq!(&png[1..4], b"PNG");
    }
}
