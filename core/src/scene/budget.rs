//! The RAM a frame of a scene needs on the device ([`RamBudget`], docs/ARCHITECTURE.md "Device
//! budget"): what the firmware and `pocketsplat render --stats-json` print.

use super::open::Scene;
use super::pack::Pack;
use super::{Kind, ShadowMode};
use crate::camera::Viewport;
#[cfg(feature = "qsplat")]
use crate::qs::QsFrame;
use crate::shade::ShadingTable;
#[cfg(feature = "shadows")]
use crate::shadow::LightFrame;
use crate::tg::TgFrame;

/// RAM a scene needs on the device, bytes (docs/ARCHITECTURE.md "Device budget"): what the firmware and
/// `pocketsplat render --stats-json` print.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RamBudget {
    /// RGB565 colour, a value per pixel of the frame.
    pub framebuffer: usize,
    /// 16-bit depth, a value per pixel.
    pub depth: usize,
    /// The shadow map (0 without shadows).
    pub shadow_map: usize,
    /// The shading table, one slot per (material, rotation) of the scene.
    pub shading_tables: usize,
    /// Block cache (0: a pack in flash or RAM is resident, read in place).
    pub cache: usize,
    /// Per-frame setup live at a time (one object's tri-grid frame, on the stack, and with
    /// shadows its light frame, a `static` on the device; with QSplat objects their frame too).
    pub frame_setup: usize,
    /// The opened scene (pack view and the objects' readers).
    pub scene: usize,
}

impl RamBudget {
    /// Everything added.
    pub fn total(&self) -> usize {
        self.framebuffer
            + self.depth
            + self.shadow_map
            + self.shading_tables
            + self.cache
            + self.frame_setup
            + self.scene
    }
}

/// Bytes of a shading table with `slots` slots (1..=8; more count as 8).
pub fn shading_table_bytes(slots: usize) -> usize {
    use core::mem::size_of;
    match slots {
        0 | 1 => size_of::<ShadingTable<1>>(),
        2 => size_of::<ShadingTable<2>>(),
        3 => size_of::<ShadingTable<3>>(),
        4 => size_of::<ShadingTable<4>>(),
        5 => size_of::<ShadingTable<5>>(),
        6 => size_of::<ShadingTable<6>>(),
        7 => size_of::<ShadingTable<7>>(),
        _ => size_of::<ShadingTable<8>>(),
    }
}

/// The RAM a frame of `pack` needs with `shadows` (usually the pack's; `Off` when the build leaves
/// shadows out) and a shadow map of `map_size`² texels, its shading table holding exactly the
/// pack's slots (a build with a larger table pays for it), for frames of `viewport`'s size.
pub fn ram_budget(
    pack: &Pack<'_>,
    shadows: ShadowMode,
    map_size: usize,
    viewport: Viewport,
) -> RamBudget {
    let side = map_size;
    let shadowed = shadows != ShadowMode::Off && cfg!(feature = "shadows");
    #[cfg(feature = "shadows")]
    let light = if shadowed {
        core::mem::size_of::<LightFrame>()
    } else {
        0
    };
    #[cfg(not(feature = "shadows"))]
    let light = 0;
    // A QSplat object's frame is on the stack beside the tri-grid frame while it is drawn.
    let has_qs =
        (0..pack.object_count()).any(|i| pack.object(i).is_some_and(|r| r.kind == Kind::QSplat));
    #[cfg(feature = "qsplat")]
    let qs_frame = if has_qs {
        core::mem::size_of::<QsFrame>()
    } else {
        0
    };
    #[cfg(not(feature = "qsplat"))]
    let qs_frame = {
        let _ = has_qs;
        0
    };
    RamBudget {
        framebuffer: viewport.pixels() * 2,
        depth: viewport.pixels() * 2,
        shadow_map: if shadowed { side * side * 2 } else { 0 },
        shading_tables: shading_table_bytes(pack.slot_count()),
        cache: 0,
        frame_setup: core::mem::size_of::<TgFrame>() + light + qs_frame,
        scene: core::mem::size_of::<Scene<'_>>(),
    }
}
