//! The standard views of a memory-resident tri-grid, rendered by one function that the firmware and
//! the host tests both call, so that an ARM frame and a host frame can only differ by what the two
//! machines compute, never by what the code asks them to (DESIGN.md: same frames, same CRC).
//!
//! A frame is what `pocketsplat-sim`'s `render_tg_with` does with default settings (square kernel,
//! default material and light, 45° field of view, a [`SHADOW_MAP_SIZE`]² shadow map): the camera
//! from the header's bounds, [`TgFrame::new`] (and the light's tables when shadows are on),
//! [`ShadingTable::update`], clear, [`render_tg`] (or the shadowed walk), CRC. The steps are
//! separated by [`Phase`] marks, which the firmware turns into calls of marker functions so that an
//! instruction counter in QEMU can attribute the cost of each step.
//!
//! Shadows need the `shadows` feature (which turns on `pocketsplat-core/shadows`); without it,
//! [`SHADOW_MODES`] holds [`Shadows::Off`] only and no shadow code is linked (DESIGN.md: leave out
//! what a scene does not need).

use core::fmt;

use pocketsplat_core::camera::{
    self, Camera, Placement, Sphere, View, DEFAULT_FOV_DEG, STANDARD_VIEWS,
};
use pocketsplat_core::raster::{Framebuffer, Kernel};
use pocketsplat_core::shade::{ShadingTable, DEFAULT_LIGHT_AZ_EL, DEFAULT_MATERIAL};
use pocketsplat_core::splat::{ShadedRaster, Stats};
use pocketsplat_core::tg::{render_tg, FrameError, RenderOptions, TgFrame, TriGrid};
#[cfg(feature = "shadows")]
use pocketsplat_core::{
    shadow::{render_tg_shadowed, LightFrame, ShadowMap, ShadowMode},
    tg::Header,
};

use crate::{HEIGHT, WIDTH};

/// LOD cutoffs the firmware renders each standard view at, pixels.
pub const CUTOFFS_PX: [u8; 4] = [1, 2, 4, 8];

/// Side of the shadow map, texels: the simulator's default (`pocketsplat render --shadows`), so that
/// the firmware's shadowed frames are the golden images' (256² × 2 bytes = 128 KB of RAM).
pub const SHADOW_MAP_SIZE: usize = 256;

/// The shadow algorithm of a frame (the names of `pocketsplat render --shadows`). Defined here, not
/// taken from the core, so that a build without the `shadows` feature still names its frames.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Shadows {
    /// No shadows.
    Off,
    /// One-pass shadow map, children in light order (Duguet §5.3).
    OnePass,
    /// Shadow map from the light first, then the view.
    TwoPass,
}

impl Shadows {
    /// Every mode.
    pub const ALL: [Shadows; 3] = [Shadows::Off, Shadows::OnePass, Shadows::TwoPass];

    /// `off`, `one-pass` or `two-pass`.
    pub fn name(self) -> &'static str {
        match self {
            Shadows::Off => "off",
            Shadows::OnePass => "one-pass",
            Shadows::TwoPass => "two-pass",
        }
    }

    /// The mode called `name`.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }

    #[cfg(feature = "shadows")]
    fn core_mode(self) -> ShadowMode {
        match self {
            Shadows::Off => ShadowMode::Off,
            Shadows::OnePass => ShadowMode::OnePass,
            Shadows::TwoPass => ShadowMode::TwoPass,
        }
    }
}

/// The shadow modes this build renders: all three with the `shadows` feature, `off` without.
#[cfg(feature = "shadows")]
pub const SHADOW_MODES: &[Shadows] = &Shadows::ALL;
/// The shadow modes this build renders: all three with the `shadows` feature, `off` without.
#[cfg(not(feature = "shadows"))]
pub const SHADOW_MODES: &[Shadows] = &[Shadows::Off];

/// One frame of the sequence: a standard view, a cutoff and a shadow mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FrameSpec {
    /// Index into [`STANDARD_VIEWS`].
    pub view: usize,
    /// LOD cutoff, pixels.
    pub cutoff_px: u8,
    /// Shadow algorithm.
    pub shadows: Shadows,
}

impl FrameSpec {
    /// The view's name (`std`, `front`, `close`, `far`).
    pub fn view_name(&self) -> &'static str {
        STANDARD_VIEWS[self.view].0
    }
}

/// The frames the firmware renders, in order: each standard view, in each mode of [`SHADOW_MODES`],
/// at each cutoff of [`CUTOFFS_PX`] ([`frame_specs_for`] of [`SHADOW_MODES`]).
pub fn frame_specs() -> impl Iterator<Item = FrameSpec> {
    frame_specs_for(SHADOW_MODES)
}

/// The frame sequence of a build rendering `modes`. The light is fixed, so the shading table changes
/// only with the view, at its first frame.
pub fn frame_specs_for(modes: &'static [Shadows]) -> impl Iterator<Item = FrameSpec> {
    (0..STANDARD_VIEWS.len()).flat_map(move |view| {
        modes.iter().flat_map(move |&shadows| {
            CUTOFFS_PX.iter().map(move |&cutoff_px| FrameSpec {
                view,
                cutoff_px,
                shadows,
            })
        })
    })
}

/// The steps of a frame, in order. [`render_standard_view`] reports the start of each (and
/// [`Phase::End`] after the traversal) to its `mark` callback.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Phase {
    /// Camera and per-frame integer tables ([`TgFrame::new`], and the light's with shadows; soft
    /// floats on an FPU-less core).
    Setup,
    /// The shading table ([`ShadingTable::update`]; rebuilds only when the view direction changes).
    Table,
    /// Clearing colour and depth.
    Clear,
    /// Traversal and raster ([`render_tg`]; with two-pass shadows, the light's pass first).
    Traverse,
    /// The frame is drawn (the CRC that follows is not part of the frame).
    End,
}

impl Phase {
    /// Every phase, in frame order.
    pub const ALL: [Phase; 5] = [
        Phase::Setup,
        Phase::Table,
        Phase::Clear,
        Phase::Traverse,
        Phase::End,
    ];
}

/// Where a frame is drawn: colour and depth rows, the shading table and, with shadows, the shadow
/// map (statics on the device, the heap on the host).
pub struct Targets<'a> {
    /// RGB565 rows.
    pub color: &'a mut [[u16; WIDTH]; HEIGHT],
    /// Depth rows.
    pub depth: &'a mut [[u16; WIDTH]; HEIGHT],
    /// The shading table, kept between frames (rebuilt only when the view direction changes).
    pub table: &'a mut ShadingTable<1>,
    /// Shadow-map depths, [`SHADOW_MAP_SIZE`]² of them.
    #[cfg(feature = "shadows")]
    pub shadow: &'a mut [u16; SHADOW_MAP_SIZE * SHADOW_MAP_SIZE],
}

/// What one frame did: the line the firmware prints, `frame <view> cutoff <px> shadows <mode> crc
/// 0x… splats N nodes N` (for two-pass shadows, `nodes` counts both passes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FrameReport {
    /// Which frame.
    pub spec: FrameSpec,
    /// CRC-32 of the colour buffer ([`Framebuffer::crc`]).
    pub crc: u32,
    /// Traversal counts.
    pub stats: Stats,
    /// Whether the shading table was rebuilt for this frame.
    pub table_rebuilt: bool,
}

impl fmt::Display for FrameReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "frame {} cutoff {} shadows {} crc {:#010x} splats {} nodes {}",
            self.spec.view_name(),
            self.spec.cutoff_px,
            self.spec.shadows.name(),
            self.crc,
            self.stats.splats,
            self.stats.nodes_visited
        )
    }
}

/// A frame line as printed by the firmware, read back (tests and `arm-bench`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameLine<'a> {
    /// View name.
    pub view: &'a str,
    /// Cutoff, pixels.
    pub cutoff_px: u8,
    /// Shadow mode.
    pub shadows: Shadows,
    /// Frame CRC.
    pub crc: u32,
    /// Splats drawn.
    pub splats: u32,
    /// Nodes visited.
    pub nodes: u32,
}

impl<'a> FrameLine<'a> {
    /// Parses `frame <view> cutoff <px> shadows <mode> crc 0x… splats N nodes N`; `None` for any
    /// other line.
    pub fn parse(line: &'a str) -> Option<Self> {
        let mut w = line.split_ascii_whitespace();
        let mut after = |key: &str| -> Option<&'a str> { (w.next()? == key).then(|| w.next())? };
        let view = after("frame")?;
        let cutoff_px = after("cutoff")?.parse().ok()?;
        let shadows = Shadows::from_name(after("shadows")?)?;
        let crc = u32::from_str_radix(after("crc")?.strip_prefix("0x")?, 16).ok()?;
        let splats = after("splats")?.parse().ok()?;
        let nodes = after("nodes")?.parse().ok()?;
        if w.next().is_some() {
            return None;
        }
        Some(Self {
            view,
            cutoff_px,
            shadows,
            crc,
            splats,
            nodes,
        })
    }

    /// The frame this line reports, or `None` when its view is not a standard view.
    pub fn spec(&self) -> Option<FrameSpec> {
        let view = STANDARD_VIEWS.iter().position(|(n, _)| *n == self.view)?;
        Some(FrameSpec {
            view,
            cutoff_px: self.cutoff_px,
            shadows: self.shadows,
        })
    }

    /// Whether this line reports the same frame, CRC and counts as `report`.
    pub fn matches(&self, report: &FrameReport) -> bool {
        self.spec() == Some(report.spec)
            && self.crc == report.crc
            && self.splats == report.stats.splats
            && self.nodes == report.stats.nodes_visited
    }
}

/// Renders frame `spec` of `grid` into `targets` and checksums it ([`render_view`] of the standard
/// view at the spec's cutoff, then the CRC of the colour buffer, after [`Phase::End`]).
///
/// # Errors
/// When the frame cannot be set up ([`FrameError`]: ρ above 3, degenerate bounds).
///
/// # Panics
/// When `spec` asks for shadows from a build without the `shadows` feature (no [`frame_specs`] of
/// such a build does).
pub fn render_standard_view(
    grid: &TriGrid<'_>,
    spec: FrameSpec,
    targets: &mut Targets<'_>,
    mark: impl FnMut(Phase),
) -> Result<FrameReport, FrameError> {
    let (_, view) = STANDARD_VIEWS[spec.view];
    let frame = render_view(
        grid,
        view,
        f32::from(spec.cutoff_px),
        spec.shadows,
        targets,
        mark,
    )?;
    Ok(FrameReport {
        spec,
        crc: Framebuffer::new(targets.color, targets.depth).crc(),
        stats: frame.stats,
        table_rebuilt: frame.table_rebuilt,
    })
}

/// What [`render_view`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Drawn {
    /// Traversal counts.
    pub stats: Stats,
    /// Whether the shading table was rebuilt for this frame.
    pub table_rebuilt: bool,
}

/// Renders `grid` seen from the orbit `view` at `cutoff_px` into `targets` with the defaults of
/// `pocketsplat render` (square kernel, default material and light, 45° field of view). `mark` is
/// called at the start of each [`Phase`] and at [`Phase::End`]. The firmware's standard views and a
/// handheld's interactive camera draw through this one function.
///
/// # Errors
/// When the frame cannot be set up ([`FrameError`]: ρ above 3, degenerate bounds, a cutoff that is
/// not positive).
///
/// # Panics
/// When `shadows` is not [`Shadows::Off`] in a build without the `shadows` feature.
pub fn render_view(
    grid: &TriGrid<'_>,
    view: View,
    cutoff_px: f32,
    shadows: Shadows,
    targets: &mut Targets<'_>,
    mut mark: impl FnMut(Phase),
) -> Result<Drawn, FrameError> {
    mark(Phase::Setup);
    let cam = Camera::orbit(
        Sphere::from_bounds(grid.header().bounds),
        view,
        DEFAULT_FOV_DEG,
    );
    let opts = RenderOptions {
        cutoff_px,
        kernel: Kernel::Square,
        ..RenderOptions::default()
    };
    let frame = TgFrame::new(grid.header(), &Placement::IDENTITY, &cam, &opts)?;
    let light = camera::direction(DEFAULT_LIGHT_AZ_EL.0, DEFAULT_LIGHT_AZ_EL.1);
    #[cfg(feature = "shadows")]
    let light_frame = light_frame(grid.header(), shadows, light);

    mark(Phase::Table);
    let table_rebuilt =
        targets
            .table
            .update(&[DEFAULT_MATERIAL], light, camera::scale(cam.forward, -1.0));

    mark(Phase::Clear);
    let mut fb = Framebuffer::new(targets.color, targets.depth);
    fb.clear(0);

    mark(Phase::Traverse);
    let mut sink = ShadedRaster {
        fb: &mut fb,
        table: targets.table,
        kernel: opts.kernel,
    };
    let stats = match shadows {
        Shadows::Off => render_tg(grid, &frame, &mut sink),
        #[cfg(feature = "shadows")]
        mode => {
            let light = light_frame
                .as_ref()
                .expect("a light frame when shadows are on");
            let mut map = ShadowMap::new(targets.shadow, SHADOW_MAP_SIZE);
            render_tg_shadowed(grid, &frame, light, &mut map, mode.core_mode(), &mut sink)
        }
        #[cfg(not(feature = "shadows"))]
        mode => panic!("shadows {} need the `shadows` feature", mode.name()),
    };
    mark(Phase::End);
    Ok(Drawn {
        stats,
        table_rebuilt,
    })
}

/// The light's tables when `shadows` is on (setup, like [`TgFrame::new`]).
#[cfg(feature = "shadows")]
fn light_frame(header: &Header, shadows: Shadows, light: camera::Vec3) -> Option<LightFrame> {
    (shadows != Shadows::Off)
        .then(|| LightFrame::new(header, &Placement::IDENTITY, light, SHADOW_MAP_SIZE))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_lines_round_trip() {
        let report = FrameReport {
            spec: FrameSpec {
                view: 2,
                cutoff_px: 4,
                shadows: Shadows::OnePass,
            },
            crc: 0x00ab_cdef,
            stats: Stats {
                splats: 12,
                nodes_visited: 345,
                ..Stats::default()
            },
            table_rebuilt: true,
        };
        let line = report.to_string();
        assert_eq!(
            line,
            "frame close cutoff 4 shadows one-pass crc 0x00abcdef splats 12 nodes 345"
        );
        let parsed = FrameLine::parse(&line).unwrap();
        assert!(parsed.matches(&report));
        assert_eq!(parsed.spec(), Some(report.spec));
        let other = FrameReport { crc: 1, ..report };
        assert!(!parsed.matches(&other));
        assert_eq!(FrameLine::parse("frame 0 crc 0x12345678"), None);
        assert_eq!(FrameLine::parse("ram_bytes 12"), None);
        assert_eq!(FrameLine::parse(&format!("{line} extra")), None);
        let bad_mode = line.replace("one-pass", "three-pass");
        assert_eq!(FrameLine::parse(&bad_mode), None);
        let side = line.replace("close", "side");
        let bad_view = FrameLine::parse(&side).unwrap();
        assert_eq!(bad_view.spec(), None);
    }

    #[test]
    fn each_view_in_each_mode_at_each_cutoff() {
        let specs: Vec<_> = frame_specs_for(&Shadows::ALL).collect();
        assert_eq!(specs.len(), STANDARD_VIEWS.len() * 3 * CUTOFFS_PX.len());
        assert_eq!(specs[0].view_name(), "std");
        assert_eq!((specs[0].cutoff_px, specs[0].shadows), (1, Shadows::Off));
        assert_eq!(specs[CUTOFFS_PX.len()].shadows, Shadows::OnePass);
        assert_eq!(specs[3 * CUTOFFS_PX.len()].view_name(), "front");
        assert_eq!(frame_specs().count(), 4 * SHADOW_MODES.len() * 4);
        for m in Shadows::ALL {
            assert_eq!(Shadows::from_name(m.name()), Some(m));
        }
    }
}
