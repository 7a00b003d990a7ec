//! The viewer's HUD, drawn with embedded-graphics fonts into the frame itself.

use embedded_graphics::mono_font::ascii::FONT_6X10;
use embedded_graphics::mono_font::{MonoTextStyle, MonoTextStyleBuilder};
use embedded_graphics::pixelcolor::Rgb565;
use embedded_graphics::prelude::*;
use embedded_graphics::text::{Baseline, Text};
use pocketsplat_core::raster::Kernel;
use pocketsplat_core::splat::Stats;

use super::state::{HudMode, ViewState};
use crate::render::{FrameReport, ShadowMode};

/// The HUD's help lines (FONT_6X10: at most 40 characters across 240 pixels).
const HUD_HELP: [&str; 3] = [
    "drag/arrows orbit  rdrag/shift/WASD pan",
    "wheel/+- zoom IJKL light []cutoff V lvl",
    "C kernel O shadow P refine R home H hud",
];

/// What the HUD says about a frame.
#[derive(Clone, Debug)]
pub struct HudInfo<'a> {
    /// Frames drawn per second (smoothed).
    pub fps: f32,
    /// The frame's report: traversal counts and render time.
    pub report: FrameReport,
    /// The frame's cutoff, pixels.
    pub cutoff_px: f32,
    /// The session: settings, refinement state, HUD mode.
    pub state: &'a ViewState,
    /// The model's [`Shown::label`](super::scene::Shown::label).
    pub label: &'a str,
}

const HUD_TEXT: Rgb565 = Rgb565::new(31, 63, 31);
const HUD_DIM: Rgb565 = Rgb565::new(20, 44, 24);
const HUD_LINE_PX: i32 = 10;

/// Draws the HUD over a frame: statistics at the top left (fps, render time, splats, level,
/// cutoff, kernel, shadows, light), the help lines at the bottom, on black so they read over the
/// model.
///
/// # Errors
/// When the target fails to draw.
pub fn draw_hud<D: DrawTarget<Color = Rgb565>>(
    target: &mut D,
    info: &HudInfo<'_>,
) -> Result<(), D::Error> {
    let state = info.state;
    if state.hud == HudMode::Off {
        return Ok(());
    }
    let s = &state.settings;
    let r = &state.refiner;
    let stats: &Stats = &info.report.stats;
    let refine = if !r.is_refining() {
        "fixed"
    } else if r.is_settled() {
        "done"
    } else {
        "refining"
    };
    let kernel = match s.kernel {
        Kernel::Square => "square",
        Kernel::Round => "round",
    };
    let shadows = match s.shadows {
        ShadowMode::Off => "off",
        ShadowMode::OnePass => "1-pass",
        ShadowMode::TwoPass => "2-pass",
    };
    let lines = [
        format!(
            "{:.0} fps {:.1} ms  {}",
            info.fps,
            info.report.time.as_secs_f64() * 1e3,
            info.label
        ),
        format!(
            "splats {}  nodes {}  lvl {}",
            stats.splats, stats.nodes_visited, stats.max_level
        ),
        format!(
            "cutoff {:.1} px {}  moving {:.1}{}",
            info.cutoff_px,
            refine,
            r.moving_cutoff(),
            if r.is_adaptive() { " auto" } else { "" }
        ),
        format!(
            "{kernel}  shadows {shadows}  light {:.0},{:.0}",
            s.light_az_el.0, s.light_az_el.1
        ),
    ];
    let text = hud_style(HUD_TEXT);
    for (i, line) in lines.iter().enumerate() {
        Text::with_baseline(
            line,
            Point::new(1, 1 + HUD_LINE_PX * i as i32),
            text,
            Baseline::Top,
        )
        .draw(target)?;
    }
    let height = target.bounding_box().size.height as i32;
    let help_top = height - 1 - HUD_LINE_PX * HUD_HELP.len() as i32;
    if s.color_by_level {
        // The key of the tints, above the help lines when they are shown.
        let bottom = if state.hud == HudMode::Full {
            help_top
        } else {
            height
        };
        crate::levels::legend(target, 0, bottom - crate::levels::LEGEND_HEIGHT)?;
    }
    if state.hud == HudMode::Full {
        let dim = hud_style(HUD_DIM);
        let top = help_top;
        for (i, line) in HUD_HELP.iter().enumerate() {
            Text::with_baseline(
                line,
                Point::new(1, top + HUD_LINE_PX * i as i32),
                dim,
                Baseline::Top,
            )
            .draw(target)?;
        }
    }
    Ok(())
}

fn hud_style(color: Rgb565) -> MonoTextStyle<'static, Rgb565> {
    MonoTextStyleBuilder::new()
        .font(&FONT_6X10)
        .text_color(color)
        .background_color(Rgb565::BLACK)
        .build()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::FrameBuffers;
    use crate::view::options::ViewOptions;
    use crate::view::state::Action;

    #[test]
    fn hud_draws_inside_the_frame_and_not_when_off() {
        let mut s = ViewState::new(&ViewOptions::default());
        let report = FrameReport {
            stats: Stats {
                splats: 12345,
                ..Stats::default()
            },
            time: std::time::Duration::from_millis(3),
            scene: None,
        };
        let drawn = |s: &ViewState| {
            let mut fb = FrameBuffers::new();
            let info = HudInfo {
                fps: 60.0,
                report,
                cutoff_px: 1.0,
                state: s,
                label: "tri-grid d5",
            };
            draw_hud(&mut fb.image, &info).unwrap();
            let px = fb.pixels();
            let half = crate::render::HEIGHT / 2 * crate::render::WIDTH;
            let top = px[..half].iter().filter(|&&p| p != 0).count();
            let bottom = px[half..].iter().filter(|&&p| p != 0).count();
            (top, bottom)
        };
        let (top, bottom) = drawn(&s);
        assert!(top > 200 && bottom > 200, "{top} {bottom}");
        s.apply(Action::CycleHud);
        let (top, bottom) = drawn(&s);
        assert!(top > 200 && bottom == 0, "stats only: {top} {bottom}");
        s.apply(Action::CycleHud);
        assert_eq!(drawn(&s), (0, 0));
    }

    #[test]
    fn help_lines_fit_the_frame() {
        for line in HUD_HELP {
            // 6 px per glyph, drawn from x = 1.
            assert!(line.len() * 6 < crate::render::WIDTH, "{line}");
            assert!(line.is_ascii());
        }
    }
}
