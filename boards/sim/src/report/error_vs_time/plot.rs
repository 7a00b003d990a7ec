//! PSNR against time plots: plotters on its bitmap backend, drawn into memory and encoded with the
//! project's PNG writer. Text goes through plotters' `ab_glyph` feature with a font bundled in
//! `boards/sim/assets/fonts` (a subset of DejaVu Sans), so a machine without system fonts or
//! fontconfig draws the same plot.

use std::sync::Once;

use anyhow::{anyhow, Result};
use plotters::prelude::*;
use plotters::style::FontStyle;

use crate::image::encode_rgb8_png;

/// The x axis of a plot of host time.
pub const X_HOST_MS: &str = "host CPU time per frame, ms (log scale)";
/// The x axis of a plot of ARM cost.
pub const X_ARM_MINSTR: &str = "ARM instructions per frame, millions (log scale)";

/// Plot size, pixels.
pub const SIZE: (u32, u32) = (900, 600);

/// The bundled font (see `assets/fonts/LICENSE.txt`).
static FONT: &[u8] = include_bytes!("../../../assets/fonts/DejaVuSans-subset.ttf");

/// One method's frames: `(x, PSNR dB)`, x being time or instructions.
#[derive(Clone, Debug, PartialEq)]
pub struct Curve {
    /// Legend entry.
    pub label: String,
    /// Every frame configuration.
    pub points: Vec<(f64, f64)>,
}

/// The frames no other frame beats on both axes, by increasing time: the ones a renderer with a
/// time budget would choose.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut sorted: Vec<(f64, f64)> = points.to_vec();
    sorted.sort_by(|a, b| a.0.total_cmp(&b.0).then(b.1.total_cmp(&a.1)));
    let mut front: Vec<(f64, f64)> = Vec::new();
    for p in sorted {
        if front.last().is_none_or(|last| p.1 > last.1) {
            front.push(p);
        }
    }
    front
}

/// Colour of the `i`-th curve: tri-grid blue, octree orange, QSplat green, brute force black, then
/// plotters' palette.
fn colour(label: &str, i: usize) -> RGBColor {
    match label {
        "trigrid" => RGBColor(31, 119, 180),
        "octree" => RGBColor(230, 120, 20),
        "qsplat" => RGBColor(44, 160, 44),
        "brute" => RGBColor(30, 30, 30),
        _ => {
            let c = Palette99::pick(i + 4).to_rgba();
            RGBColor(c.0, c.1, c.2)
        }
    }
}

/// Registers the bundled font as plotters' `sans-serif` (once; other plots call it too).
///
/// # Errors
/// When the font does not parse.
pub fn register_font() -> Result<()> {
    static ONCE: Once = Once::new();
    let mut result = Ok(());
    ONCE.call_once(|| {
        result = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT)
            .map_err(|_| anyhow!("the bundled plot font does not parse"));
    });
    result
}

/// Draws the curves (all frames as faint dots, the Pareto front as a line with solid dots) on a
/// log x axis described by `x_desc` (e.g. [`X_HOST_MS`]) and returns the PNG.
///
/// # Errors
/// When plotters fails to draw or the PNG cannot be encoded.
pub fn plot_png(title: &str, x_desc: &str, curves: &[Curve]) -> Result<Vec<u8>> {
    register_font()?;
    let (w, h) = SIZE;
    let mut buf = vec![0u8; w as usize * h as usize * 3];
    draw(&mut buf, title, x_desc, curves).map_err(|e| anyhow!("plot {title:?}: {e}"))?;
    let pixels: Vec<[u8; 3]> = buf.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    encode_rgb8_png(w, h, &pixels)
}

/// Axis ranges covering every point, with margins; a fixed range when there is none.
fn ranges(curves: &[Curve]) -> ((f64, f64), (f64, f64)) {
    let all = || curves.iter().flat_map(|c| c.points.iter().copied());
    let (mut x0, mut x1, mut y0, mut y1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for (x, y) in all() {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if !(x0.is_finite() && x1.is_finite() && y0.is_finite() && y1.is_finite()) {
        return ((0.1, 100.0), (0.0, 40.0));
    }
    let (x0, x1) = (x0 / 1.5, x1 * 1.5);
    let pad = ((y1 - y0) * 0.08).max(0.5);
    ((x0, x1), ((y0 - pad).floor(), (y1 + pad).ceil()))
}

/// Ticks at 1, 2 and 5 times each power of ten within `lo..=hi` (plotters' own log axis labels only
/// powers of ten, so a range within one or two decades would show one or two labels).
fn ticks_125(lo: f64, hi: f64) -> Vec<f64> {
    let mut out = Vec::new();
    let mut decade = 10f64.powi(lo.log10().floor() as i32);
    while decade <= hi {
        for m in [1.0, 2.0, 5.0] {
            let t = m * decade;
            if (lo..=hi).contains(&t) {
                out.push(t);
            }
        }
        decade *= 10.0;
    }
    out
}

fn draw(
    buf: &mut [u8],
    title: &str,
    x_desc: &str,
    curves: &[Curve],
) -> Result<(), Box<dyn std::error::Error>> {
    let root = BitMapBackend::with_buffer(buf, SIZE).into_drawing_area();
    root.fill(&WHITE)?;
    let ((x0, x1), (y0, y1)) = ranges(curves);
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 22))
        .margin(16)
        .x_label_area_size(48)
        .y_label_area_size(64)
        .build_cartesian_2d(
            (x0..x1).log_scale().with_key_points(ticks_125(x0, x1)),
            y0..y1,
        )?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc("PSNR against the f64 reference, dB")
        .label_style(("sans-serif", 15))
        .bold_line_style(RGBColor(200, 200, 200))
        .light_line_style(RGBColor(240, 240, 240))
        .axis_desc_style(("sans-serif", 17))
        .x_label_formatter(&|v| {
            if *v >= 1.0 {
                format!("{v:.0}")
            } else {
                format!("{v:.2}")
            }
        })
        .draw()?;
    for (i, c) in curves.iter().enumerate() {
        let col = colour(&c.label, i);
        chart.draw_series(
            c.points
                .iter()
                .map(|&p| Circle::new(p, 3, col.mix(0.35).filled())),
        )?;
        let front = pareto_front(&c.points);
        chart
            .draw_series(LineSeries::new(front.clone(), col.stroke_width(2)))?
            .label(c.label.clone())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], col.stroke_width(3)));
        chart.draw_series(front.iter().map(|&p| Circle::new(p, 4, col.filled())))?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .label_font(("sans-serif", 16))
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK)
        .draw()?;
    root.present()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::decode_rgb8_png;

    #[test]
    fn the_front_keeps_only_unbeaten_frames() {
        let pts = [
            (2.0, 20.0),
            (1.0, 18.0),
            (3.0, 19.0),
            (4.0, 25.0),
            (2.0, 21.0),
        ];
        assert_eq!(
            pareto_front(&pts),
            vec![(1.0, 18.0), (2.0, 21.0), (4.0, 25.0)]
        );
        assert!(pareto_front(&[]).is_empty());
    }

    #[test]
    fn a_plot_has_text_axes_and_curves() {
        let curves = [
            Curve {
                label: "trigrid".into(),
                points: vec![(1.0, 20.0), (3.0, 28.0), (10.0, 31.0)],
            },
            Curve {
                label: "brute".into(),
                points: vec![(40.0, 30.0)],
            },
        ];
        let png = plot_png("test", X_HOST_MS, &curves).unwrap();
        let img = decode_rgb8_png(&png).unwrap();
        assert_eq!((img.width, img.height), SIZE);
        let count = |c: [u8; 3]| img.pixels.iter().filter(|&&p| p == c).count();
        // The tri-grid's line and dots, in its colour.
        assert!(count([31, 119, 180]) > 200);
        // Black text and axes, and a mostly white background.
        let dark = img
            .pixels
            .iter()
            .filter(|p| p.iter().all(|&v| v < 80))
            .count();
        assert!(dark > 2000, "{dark} dark pixels");
        assert!(count([255, 255, 255]) > img.pixels.len() / 2);
    }

    #[test]
    fn log_ticks_are_one_two_five_per_decade() {
        assert_eq!(ticks_125(8.0, 450.0), vec![10.0, 20.0, 50.0, 100.0, 200.0]);
        assert_eq!(ticks_125(0.3, 3.0), vec![0.5, 1.0, 2.0]);
    }

    #[test]
    fn an_empty_plot_still_draws() {
        let png = plot_png("nothing", X_ARM_MINSTR, &[]).unwrap();
        assert!(decode_rgb8_png(&png).is_ok());
    }
}
