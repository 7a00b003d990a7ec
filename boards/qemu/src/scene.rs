//! Scene packs (feature `scene`): the named views of a resident `.pack` (several placed tri-grids,
//! their materials, a light, shadows), drawn as `pocketsplat-sim`'s `render_pack` draws them, so
//! that the firmware's frames, the host's and the simulator's can only be the same frame.
//!
//! A frame is: the pack's options ([`Scene::options`]: its light, its shadows, its map size) at the
//! spec's cutoff, the orbit camera of the pack's view with the pack's field of view
//! ([`Scene::camera`]), [`Scene::update_table`] (one slot per material of the scene), then clear
//! and traverse through the same steps as a single model ([`crate::views`]' `draw_shaded`), the
//! traversal being the core's [`render_scene`](pocketsplat_core::scene::render_scene). Shadows are the pack's when the build has the
//! `shadows` feature, none otherwise (the frame line says which).
//!
//! Per-object setup (each object's tri-grid frame and light frame) runs inside
//! [`Phase::Traverse`], one object at a time, as [`render_scene`](pocketsplat_core::scene::render_scene) does it; [`Phase::Setup`] covers
//! the camera and options only.

use core::fmt;

use pocketsplat_core::crc::Crc32;
use pocketsplat_core::raster::{Band, Framebuffer};
use pocketsplat_core::render::{render_scene_marked, Direct, Target};
use pocketsplat_core::scene::{Scene, MAX_SLOTS};
use pocketsplat_core::shade::ShadingTable;
#[cfg(feature = "shadows")]
use pocketsplat_core::shadow::LightFrame;
use pocketsplat_core::splat::Stats;

use crate::{Phase, RenderError, Shadows, BANDS, BAND_ROWS, WIDTH};

/// LOD cutoffs the firmware renders each view of a pack at, pixels, finest first (the first is the
/// reference the coarser frames' PSNR is measured against). 3 and 6 px are there so that a curve
/// of error against instructions has points between the powers of two.
pub const SCENE_CUTOFFS_PX: [u8; 6] = [1, 2, 3, 4, 6, 8];

/// The largest shadow map side a firmware's scene may ask for, texels (the Big Scene's: 512² ×
/// 2 bytes = 512 KB of RAM). A pack asking for more is refused per frame
/// ([`pocketsplat_core::scene::SceneError::ShadowBuffer`]), not drawn wrongly.
pub const SCENE_MAP_SIZE: usize = 512;

/// The shading table of a scene: a slot for every material slot a pack can have
/// ([`MAX_SLOTS`], as the simulator's `SceneTable`).
pub type SceneTable = ShadingTable<MAX_SLOTS>;

/// Whether `bytes` start like a scene pack (its magic, `PSPK`).
pub fn is_pack(bytes: &[u8]) -> bool {
    pocketsplat_core::format::FileFormat::sniff(bytes)
        == Some(pocketsplat_core::format::FileFormat::Pack)
}

/// Where a frame of a scene is drawn (statics on the device, the heap on the host).
pub struct SceneTargets<'a, const ROWS: usize = BAND_ROWS> {
    /// RGB565 rows of a band (`ROWS`: [`crate::BAND_ROWS`], the whole panel unless the build draws
    /// in bands; a streamed pack's `PACK_BAND_ROWS`).
    pub color: &'a mut [[u16; WIDTH]; ROWS],
    /// Depth rows of a band.
    pub depth: &'a mut [[u16; WIDTH]; ROWS],
    /// The shading table, kept between frames (slots rebuilt only when their directions change).
    pub table: &'a mut SceneTable,
    /// Shadow-map depths: at least the pack's map side² when it has shadows (may be empty
    /// otherwise).
    pub shadow: &'a mut [u16],
    /// Where each object's light frame is set in turn (a `static` on the device: 17 KB off the
    /// stack).
    #[cfg(feature = "shadows")]
    pub light: &'a mut LightFrame,
}

impl<const ROWS: usize> SceneTargets<'_, ROWS> {
    /// The core's target over these buffers: the band's pixels, the table, and (with `shadows`)
    /// the map's first `map_texels` and the light frame.
    pub fn target(
        &mut self,
        #[cfg(feature = "shadows")] map_texels: usize,
    ) -> Target<'_, Framebuffer<'_, WIDTH, ROWS>, MAX_SLOTS> {
        let target = Target::new(Framebuffer::new(self.color, self.depth), self.table);
        #[cfg(feature = "shadows")]
        let target = target.with_shadows(&mut self.shadow[..map_texels], self.light);
        target
    }
}

/// One frame of a scene: a view of the pack and a cutoff.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SceneFrameSpec {
    /// Index of the pack's view.
    pub view: usize,
    /// LOD cutoff, pixels.
    pub cutoff_px: u8,
}

/// The frames the firmware renders of `scene`, in order: each of the pack's views at each cutoff
/// of [`SCENE_CUTOFFS_PX`].
pub fn scene_frame_specs(scene: &Scene<'_>) -> impl Iterator<Item = SceneFrameSpec> {
    (0..scene.pack().view_count()).flat_map(|view| {
        SCENE_CUTOFFS_PX
            .iter()
            .map(move |&cutoff_px| SceneFrameSpec { view, cutoff_px })
    })
}

/// What a frame of a scene did: the line the firmware prints, in the form of a model's
/// (`frame <view> cutoff <px> shadows <mode> crc 0x… splats N nodes N`, read by
/// [`crate::FrameLine::parse`]), the view being the pack's view name.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SceneFrameReport<'a> {
    /// The pack's name of the view.
    pub view_name: &'a str,
    /// Which frame.
    pub spec: SceneFrameSpec,
    /// The shadows drawn.
    pub shadows: Shadows,
    /// CRC-32 of the colour buffer ([`Framebuffer::crc`]).
    pub crc: u32,
    /// All objects' counts added.
    pub stats: Stats,
    /// Whether a slot of the shading table was rebuilt for this frame.
    pub table_rebuilt: bool,
}

impl fmt::Display for SceneFrameReport<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "frame {} cutoff {} shadows {} crc {:#010x} ",
            self.view_name,
            self.spec.cutoff_px,
            self.shadows.name(),
            self.crc,
        )?;
        crate::views::write_counts(f, &self.stats)
    }
}

/// Why a frame of a scene cannot be drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SceneViewError {
    /// The pack has no view of that index.
    NoView(usize),
    /// The core's renderer refused the frame.
    Render(RenderError),
}

impl core::error::Error for SceneViewError {}

impl fmt::Display for SceneViewError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SceneViewError::NoView(v) => write!(f, "the pack has no view {v}"),
            SceneViewError::Render(e) => write!(f, "{e}"),
        }
    }
}

impl From<RenderError> for SceneViewError {
    fn from(e: RenderError) -> Self {
        SceneViewError::Render(e)
    }
}

/// Renders frame `spec` of `scene` into `targets` and checksums it (after [`Phase::End`]). `mark` is
/// called at the start of each [`Phase`] and at [`Phase::End`], as for a model's frame.
///
/// # Errors
/// When the pack has no such view, or the frame cannot be set up ([`RenderError`]: a bad cutoff, a
/// shadow map larger than `targets.shadow`, more slots than [`MAX_SLOTS`]).
pub fn render_scene_view<'p>(
    scene: &Scene<'p>,
    spec: SceneFrameSpec,
    targets: &mut SceneTargets<'_>,
    mark: impl FnMut(Phase),
) -> Result<SceneFrameReport<'p>, SceneViewError> {
    render_scene_bands(scene, spec, targets, mark, |_, _| {})
}

/// [`render_scene_view`], handing each band's colour rows to `band` with the panel row it starts
/// at, in order, as they are drawn (what a board sends to its panel; the host puts the frame
/// together from them).
///
/// # Errors
/// As [`render_scene_view`].
pub fn render_scene_bands<'p>(
    scene: &Scene<'p>,
    spec: SceneFrameSpec,
    targets: &mut SceneTargets<'_>,
    mark: impl FnMut(Phase),
    mut band_rows: impl FnMut(usize, &[[u16; WIDTH]; BAND_ROWS]),
) -> Result<SceneFrameReport<'p>, SceneViewError> {
    let (view_name, view) = scene
        .pack()
        .view(spec.view)
        .ok_or(SceneViewError::NoView(spec.view))?;
    let options = scene.options().with_cutoff(f32::from(spec.cutoff_px));
    let camera = scene.camera(view);
    // The frame band by band ([`Band`]: each band's walk is the whole frame's, its pixels
    // dropped outside the band), the CRC over the bands' rows in order: the whole frame's CRC.
    // The markers see one frame: the first band's set-up, table and clear, the rest in its
    // traversal, the last band's end.
    // A frame of one band draws straight into the buffers: the band's row test costs 2 % of a
    // frame's instructions (2.02 M of the Big Scene's 82.45 M at std 2 px).
    let mut mark = mark;
    let mut crc = Crc32::new();
    let mut first = None;
    for band in 0..BANDS {
        let (head, tail) = (band == 0, band + 1 == BANDS);
        let band_mark = |p| {
            if (head && p != Phase::End) || (tail && p == Phase::End) {
                mark(p);
            }
        };
        #[cfg(feature = "shadows")]
        let map = targets.shadow.len();
        let target = targets.target(
            #[cfg(feature = "shadows")]
            map,
        );
        let drawn = if BANDS == 1 {
            draw_in(scene, &camera, &options, target, band_mark)?
        } else {
            let top = (band * BAND_ROWS) as u16;
            draw_in(
                scene,
                &camera,
                &options,
                target.map_pixels(|f| {
                    Band::new(f, top, crate::PANEL)
                        .expect("BANDS bands of BAND_ROWS rows are the panel (build.rs)")
                }),
                band_mark,
            )?
        };
        crc.update_u16_le(targets.color.as_flattened());
        band_rows(band * BAND_ROWS, targets.color);
        first.get_or_insert(drawn);
    }
    let drawn = first.expect("a frame has a band");
    Ok(SceneFrameReport {
        view_name,
        spec,
        shadows: drawn.shadows,
        crc: crc.finish(),
        stats: drawn.stats,
        table_rebuilt: drawn.table_rebuilt,
    })
}

/// One walk of the scene's frame into `target` (the band's or the frame's buffers).
fn draw_in<P: pocketsplat_core::raster::DepthTarget>(
    scene: &Scene<'_>,
    camera: &pocketsplat_core::camera::Camera,
    options: &pocketsplat_core::render::RenderOptions,
    mut target: Target<'_, P, MAX_SLOTS>,
    mark: impl FnMut(Phase),
) -> Result<pocketsplat_core::render::Drawn, SceneViewError> {
    Ok(render_scene_marked(
        scene,
        camera,
        options,
        &mut target,
        &mut Direct,
        mark,
    )?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::FrameLine;

    #[test]
    fn a_scene_frame_line_reads_back_as_a_frame_line() {
        let report = SceneFrameReport {
            view_name: "top",
            spec: SceneFrameSpec {
                view: 2,
                cutoff_px: 4,
            },
            shadows: Shadows::OnePass,
            crc: 0x0012_3456,
            stats: Stats {
                splats: 7,
                nodes_visited: 9,
                ..Stats::default()
            },
            table_rebuilt: false,
        };
        let line = report.to_string();
        let counts = if crate::views::COUNTED {
            "splats 7 nodes 9"
        } else {
            "splats - nodes -"
        };
        assert_eq!(
            line,
            format!("frame top cutoff 4 shadows one-pass crc 0x00123456 {counts}")
        );
        let parsed = FrameLine::parse(&line).unwrap();
        assert_eq!(
            (parsed.view, parsed.cutoff_px, parsed.shadows, parsed.crc),
            ("top", 4, Shadows::OnePass, 0x0012_3456)
        );
        if crate::views::COUNTED {
            assert_eq!((parsed.splats, parsed.nodes), (Some(7), Some(9)));
        }
    }

    #[test]
    fn every_scene_cutoff_reads_back_from_its_frame_line() {
        for &cutoff_px in &SCENE_CUTOFFS_PX {
            let report = SceneFrameReport {
                view_name: "std",
                spec: SceneFrameSpec { view: 0, cutoff_px },
                shadows: Shadows::OnePass,
                crc: 1,
                stats: Stats::default(),
                table_rebuilt: false,
            };
            let line = report.to_string();
            let parsed = FrameLine::parse(&line).unwrap();
            assert_eq!(parsed.cutoff_px, cutoff_px, "{line}");
        }
        assert!(
            SCENE_CUTOFFS_PX.windows(2).all(|w| w[0] < w[1]),
            "finest first, each cutoff once: {SCENE_CUTOFFS_PX:?}"
        );
    }

    #[test]
    fn the_magic_tells_a_pack() {
        assert!(is_pack(b"PSPK\x01\x00"));
        assert!(!is_pack(b"PSP"));
        assert!(!is_pack(b"QSplat11"));
        assert!(pocketsplat_core::scene::Pack::open(b"PSPK junk").is_err());
    }
}
