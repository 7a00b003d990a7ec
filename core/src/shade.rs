//! Materials, the light and the Phong model, and the per-frame shading table: an RGB565 colour for
//! each of the 8192 normal codes and each material present (Duguet §5.5, "pre-rendering indexed
//! materials"). The table is per-frame setup; per node a sample's colour is one look-up.
//!
//! The shading model is Blinn–Phong with a directional light and an infinitely distant viewer (the
//! view direction is the camera's, the same for every pixel), so that a colour depends on the normal
//! alone and can be tabulated. The float reference renderer uses the same [`phong`].

use crate::camera::{self, Vec3};
use crate::normal::{self, NORMAL_COUNT};

/// A Phong material. Colours are linear, 0..=1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// Base (diffuse and ambient) colour.
    pub color: [f32; 3],
    /// Ambient weight.
    pub ambient: f32,
    /// Diffuse weight.
    pub diffuse: f32,
    /// Specular weight (white highlights).
    pub specular: f32,
    /// Specular exponent.
    pub shininess: f32,
}

/// Light grey with a modest highlight: the material of a model that names none.
pub const DEFAULT_MATERIAL: Material = Material {
    color: [0.8, 0.8, 0.8],
    ambient: 0.15,
    diffuse: 0.8,
    specular: 0.25,
    shininess: 20.0,
};

/// Default light direction: azimuth −40°, elevation 60° (the view convention).
pub const DEFAULT_LIGHT_AZ_EL: (f64, f64) = (-40.0, 60.0);

/// Most materials a model can carry (3 material bits).
pub const MAX_MATERIALS: usize = 8;

/// The Phong colour of a unit normal `n`, with unit vectors `l` to the light and `v` to the viewer.
/// Components are clamped to 0..=1.
pub fn phong(m: &Material, n: Vec3, l: Vec3, v: Vec3) -> [f64; 3] {
    let ndl = camera::dot(n, l);
    let diffuse = f64::from(m.diffuse) * ndl.max(0.0);
    let spec = if ndl > 0.0 {
        let h = camera::normalize(camera::add(l, v));
        let ndh = camera::dot(n, h).max(0.0);
        f64::from(m.specular) * libm::pow(ndh, f64::from(m.shininess))
    } else {
        0.0
    };
    let k = f64::from(m.ambient) + diffuse;
    let c = |i: usize| (f64::from(m.color[i]) * k + spec).clamp(0.0, 1.0);
    [c(0), c(1), c(2)]
}

/// The RGB565 bit layout, red in the high five bits, then six of green, then five of blue: every
/// packer in the project ends here. Channels must already fit their widths.
pub const fn pack565(r: u16, g: u16, b: u16) -> u16 {
    r << 11 | g << 5 | b
}

/// Packs a linear 0..=1 colour into RGB565, rounding to nearest (NaN packs as 0).
pub fn to_rgb565(c: [f64; 3]) -> u16 {
    let q = |v: f64, max: f64| (v.clamp(0.0, 1.0) * max + 0.5) as u16;
    pack565(q(c[0], 31.0), q(c[1], 63.0), q(c[2], 31.0))
}

/// Packs a 0..=255 colour (a scan's vertex colours, averaged) into RGB565, rounding to nearest.
pub fn rgb255_to_rgb565(c: [f64; 3]) -> u16 {
    to_rgb565(c.map(|v| v / 255.0))
}

/// Packs 8-bit channels into RGB565 by dropping their low bits (for colours made on the device).
pub const fn rgb888_to_rgb565(r: u8, g: u8, b: u8) -> u16 {
    pack565(r as u16 >> 3, g as u16 >> 2, b as u16 >> 3)
}

/// Expands RGB565 to 8-bit RGB by bit replication.
pub fn rgb565_to_rgb888(c: u16) -> [u8; 3] {
    let r = ((c >> 11) & 31) as u8;
    let g = ((c >> 5) & 63) as u8;
    let b = (c & 31) as u8;
    [r << 3 | r >> 2, g << 2 | g >> 4, b << 3 | b >> 2]
}

/// Entries of the specular power look-up: `(n·h)^shininess` for `n·h = i / POW_STEPS`.
const POW_STEPS: usize = 1024;

/// The shading table: `MATERIALS` materials × 8192 normal codes of RGB565 (16 KB per material).
///
/// Rebuilt by [`ShadingTable::update`] only when the light, the view direction or a material changed.
/// The per-entry work is integer (Q14 normals from [`normal::NORMALS_Q14`], Q16 weights and a
/// specular-power look-up), so a rebuild costs a few hundred thousand instructions on an FPU-less
/// core; only the light, half vector and power table are computed in floats.
pub struct ShadingTable<const MATERIALS: usize> {
    colors: [[u16; NORMAL_COUNT]; MATERIALS],
    ambient: [u16; MATERIALS],
    pow_q16: [[u16; POW_STEPS + 1]; MATERIALS],
    pow_key: [Option<f32>; MATERIALS],
    /// Per slot: the light, viewer and material it was built for.
    key: [Option<(Vec3, Vec3, Material)>; MATERIALS],
    rebuilds: u32,
}

impl<const MATERIALS: usize> Default for ShadingTable<MATERIALS> {
    fn default() -> Self {
        Self::new()
    }
}

fn q14(v: Vec3) -> [i32; 3] {
    v.map(|c| libm::round(c * 16384.0) as i32)
}

fn q16(x: f32) -> i32 {
    libm::roundf(x.clamp(0.0, 4.0) * 65536.0) as i32
}

impl<const MATERIALS: usize> ShadingTable<MATERIALS> {
    /// An empty (black) table.
    pub const fn new() -> Self {
        Self {
            colors: [[0; NORMAL_COUNT]; MATERIALS],
            ambient: [0; MATERIALS],
            pow_q16: [[0; POW_STEPS + 1]; MATERIALS],
            pow_key: [None; MATERIALS],
            key: [None; MATERIALS],
            rebuilds: 0,
        }
    }

    /// Makes the table match `materials`, light direction `l` and viewer direction `v` (unit vectors,
    /// in the model's frame). Does nothing when they are what the table was built for. Returns
    /// whether it rebuilt.
    pub fn update(&mut self, materials: &[Material; MATERIALS], l: Vec3, v: Vec3) -> bool {
        self.update_slots(materials, &[(l, v); MATERIALS])
    }

    /// [`ShadingTable::update`] with light and viewer directions of their own per slot: a scene
    /// (`crate::scene`) gives each object's materials slots shaded in that object's model frame,
    /// since normal codes are stored in the model frame and objects may be rotated. Only the slots
    /// whose material or directions changed are recomputed. Returns whether any was.
    pub fn update_slots(
        &mut self,
        materials: &[Material; MATERIALS],
        dirs: &[(Vec3, Vec3); MATERIALS],
    ) -> bool {
        let mut changed = false;
        for (k, (m, &(l, v))) in materials.iter().zip(dirs.iter()).enumerate() {
            if self.key[k] != Some((l, v, *m)) {
                self.build_slot(k, m, l, v);
                self.key[k] = Some((l, v, *m));
                changed = true;
            }
        }
        if changed {
            self.rebuilds += 1;
        }
        changed
    }

    /// Builds each slot's specular power table for `materials`, the part of a rebuild that depends
    /// on the material alone (1025 soft-float powers, ~6 M instructions on a Cortex-M3): a
    /// firmware does it once when it loads its model, so that no frame pays for it. Later updates
    /// with the same materials only recompute the colours. Slots beyond `materials` are left.
    pub fn prepare(&mut self, materials: &[Material]) {
        for (k, m) in materials.iter().enumerate().take(MATERIALS) {
            self.prepare_slot(k, m);
        }
    }

    /// Slot `k`'s power table for `m`, unless it has it.
    fn prepare_slot(&mut self, k: usize, m: &Material) {
        if self.pow_key[k] != Some(m.shininess) {
            for (i, p) in self.pow_q16[k].iter_mut().enumerate() {
                let x = i as f32 / POW_STEPS as f32;
                *p = libm::roundf(libm::powf(x, m.shininess) * 65535.0) as u16;
            }
            self.pow_key[k] = Some(m.shininess);
        }
    }

    /// Recomputes slot `k`'s colours for material `m`, light `l` and viewer `v`.
    // Out of line: its loop over the 8192 codes is the same code whoever asks for a rebuild.
    #[inline(never)]
    fn build_slot(&mut self, k: usize, m: &Material, l: Vec3, v: Vec3) {
        let lq = q14(l);
        let hq = q14(camera::normalize(camera::add(l, v)));
        self.prepare_slot(k, m);
        let (amb, dif, spc) = (q16(m.ambient), q16(m.diffuse), q16(m.specular));
        let base = m.color.map(q16);
        let shade = |c: i32, max: i32| {
            (((i64::from(c) * i64::from(amb)) >> 16).clamp(0, 65535) as i32 * max + 32768) >> 16
        };
        self.ambient[k] = pack565(
            shade(base[0], 31) as u16,
            shade(base[1], 63) as u16,
            shade(base[2], 31) as u16,
        );
        let pow = &self.pow_q16[k];
        for (out, n) in self.colors[k].iter_mut().zip(normal::NORMALS_Q14.iter()) {
            let n = n.map(i32::from);
            let ndl = (n[0] * lq[0] + n[1] * lq[1] + n[2] * lq[2]) >> 14;
            // Weights reach 4.0 (Q16 2^18), so these products need more than 32 bits.
            let light = amb + ((i64::from(dif) * i64::from(ndl.max(0))) >> 14) as i32;
            let spec = if ndl > 0 {
                let ndh = ((n[0] * hq[0] + n[1] * hq[1] + n[2] * hq[2]) >> 14).clamp(0, 16384);
                ((i64::from(spc) * i64::from(pow[(ndh >> 4) as usize])) >> 16) as i32
            } else {
                0
            };
            // Channel in Q16, rounded to 5 or 6 bits.
            let ch = |c: i32, max: i32| {
                let lit = ((i64::from(c) * i64::from(light)) >> 16) as i32;
                ((lit + spec).clamp(0, 65535) * max + 32768) >> 16
            };
            *out = pack565(
                ch(base[0], 31) as u16,
                ch(base[1], 63) as u16,
                ch(base[2], 31) as u16,
            );
        }
    }

    /// The RGB565 colour of an attribute (`normal code | material << 13`). Materials beyond the
    /// table's count use the last one.
    #[inline]
    pub fn color(&self, attr: u16) -> u16 {
        let m = usize::from(attr >> normal::NORMAL_BITS).min(MATERIALS - 1);
        self.colors[m][usize::from(attr) & (NORMAL_COUNT - 1)]
    }

    /// The colour of an attribute in shadow: its material's ambient term.
    #[inline]
    pub fn shadowed(&self, attr: u16) -> u16 {
        self.ambient[usize::from(attr >> normal::NORMAL_BITS).min(MATERIALS - 1)]
    }

    /// How many times the table was rebuilt.
    pub fn rebuilds(&self) -> u32 {
        self.rebuilds
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rgb565_round_trip_of_extremes() {
        assert_eq!(to_rgb565([1.0, 1.0, 1.0]), 0xFFFF);
        assert_eq!(rgb565_to_rgb888(0xFFFF), [255, 255, 255]);
        assert_eq!(to_rgb565([1.0, 0.0, 0.0]), 0xF800);
        assert_eq!(rgb888_to_rgb565(255, 255, 255), 0xFFFF);
        assert_eq!(rgb888_to_rgb565(0, 255, 0), 0x07E0);
        assert_eq!(rgb888_to_rgb565(0, 0, 255), 0x001F);
    }

    /// The bakers' 0..=255 packer rounds as their own `round()` did before it replaced them (a
    /// fine sweep over averaged colours, past both ends), so no baked file changes a byte.
    #[test]
    fn rgb255_packs_as_round_to_nearest() {
        for i in -64..=(256 * 64) {
            let v = f64::from(i) / 64.0;
            let q = |max: f64| ((v.clamp(0.0, 255.0) / 255.0) * max).round() as u16;
            assert_eq!(
                rgb255_to_rgb565([v, v, v]),
                pack565(q(31.0), q(63.0), q(31.0)),
                "{v}"
            );
        }
        assert_eq!(rgb255_to_rgb565([f64::NAN; 3]), 0);
    }

    /// Every entry of `t`'s slot 0 within one step per channel of the float Phong model of `m`.
    fn assert_within_a_step_of_phong(t: &ShadingTable<1>, m: &Material, l: Vec3, v: Vec3) {
        for code in 0..NORMAL_COUNT as u16 {
            let n = normal::decode(code).map(f64::from);
            let want = to_rgb565(phong(m, n, l, v));
            let got = t.color(code);
            for (shift, mask) in [(11, 31), (5, 63), (0, 31)] {
                let (a, b) = (
                    i32::from(want >> shift & mask),
                    i32::from(got >> shift & mask),
                );
                assert!((a - b).abs() <= 1, "code {code}: {want:#06x} vs {got:#06x}");
            }
        }
    }

    #[test]
    fn table_is_rebuilt_only_on_change_and_matches_phong() {
        let mut t = ShadingTable::<1>::new();
        let l = camera::direction(-40.0, 60.0);
        let v = [0.0, 0.0, 1.0];
        assert!(t.update(&[DEFAULT_MATERIAL], l, v));
        assert!(!t.update(&[DEFAULT_MATERIAL], l, v));
        assert_eq!(t.rebuilds(), 1);
        assert_within_a_step_of_phong(&t, &DEFAULT_MATERIAL, l, v);
        // Facing away from the light: ambient only.
        let away = normal::encode(camera::scale(l, -1.0));
        assert_eq!(t.color(away), to_rgb565([0.12, 0.12, 0.12]));
    }

    /// The heaviest material a scene file may name (weights 4, colour 1, exponent 0 or 1024): no
    /// product overflows (tests run with overflow checks), and every entry is within one step of the
    /// float Phong model, which saturates to white where the light reaches.
    #[test]
    fn the_heaviest_materials_saturate_without_overflow() {
        let l = camera::direction(-40.0, 60.0);
        let v = [0.0, 0.0, 1.0];
        for shininess in [0.0, 1.0, 1024.0] {
            let m = Material {
                color: [1.0, 1.0, 1.0],
                ambient: 4.0,
                diffuse: 4.0,
                specular: 4.0,
                shininess,
            };
            let mut t = ShadingTable::<1>::new();
            t.update(&[m], l, v);
            assert_within_a_step_of_phong(&t, &m, l, v);
        }
    }
}

/// Which shadow algorithm a frame uses (the names of `pocketsplat render --shadows`, and a scene pack's
/// byte). Here, always compiled, so that a build without the `shadows` feature still names what it
/// leaves out; the algorithms are in `shadow` (feature `shadows`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ShadowMode {
    /// No shadows: no map, no light tables.
    #[default]
    Off,
    /// One pass, children in light order (Duguet §5.3; in a scene, objects nearest the light
    /// first); directional lights only (a point light's frame is drawn in two passes).
    OnePass,
    /// Shadow map first (of every object, in a scene), then the view.
    TwoPass,
}

impl ShadowMode {
    /// Every mode.
    pub const ALL: [ShadowMode; 3] = [ShadowMode::Off, ShadowMode::OnePass, ShadowMode::TwoPass];

    /// `off`, `one-pass` or `two-pass`.
    pub fn name(self) -> &'static str {
        match self {
            ShadowMode::Off => "off",
            ShadowMode::OnePass => "one-pass",
            ShadowMode::TwoPass => "two-pass",
        }
    }

    /// The mode called `name` ([`ShadowMode::name`]).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }
}
