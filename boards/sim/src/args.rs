//! Command-line numbers, parsed once, here: sizes and counts with `K`, `M`, `G` suffixes, whole
//! numbers and floats, each checked for overflow and against its option's range, views and light
//! positions, and the `--limits NAME=SIZE` list.
//!
//! The raw layer ([`parse_size`], [`parse_float`], [`numbers`]) is pure and never panics (it is
//! fuzzed: `fuzz/fuzz_targets/cli_numbers.rs`); the value parsers ([`size`], [`int`], [`float`],
//! [`block_size`], [`light_az_el`], [`light_pos`]; plain functions, which the command line hands
//! to `clap`) add the range, so that the message names the option:
//!
//! ```text
//! error: invalid value '100000M' for '--cache <CACHE>': must be from 4K to 1G
//! ```
//!
//! # Example
//!
//! ```
//! use pocketsplat_sim::args::parse_size;
//! assert_eq!(parse_size("1G"), Ok(1 << 30));
//! assert_eq!(parse_size("64k"), Ok(65536));
//! assert!(parse_size("18446744073709551615K").is_err());
//! ```

use anyhow::{anyhow, bail, Result};
use pocketsplat_core::camera::{View, Viewport};
use pocketsplat_core::scene::Pack;

/// Why a number on the command line was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum NumberError {
    /// Nothing given.
    #[error("empty")]
    Empty,
    /// Not digits with an optional `K`, `M` or `G`.
    #[error("not a whole number with an optional K, M or G suffix (e.g. 65536, 64K, 16M, 1G)")]
    NotASize,
    /// Not a number at all.
    #[error("not a number")]
    NotANumber,
    /// Infinite or NaN.
    #[error("not finite")]
    NotFinite,
    /// Does not fit in 64 bits once the suffix is applied.
    #[error("too large (more than 2^64 - 1)")]
    Overflow,
}

/// `K`, `M`, `G`: powers of 1024, for bytes and counts alike.
const SUFFIXES: [(u8, u32); 3] = [(b'K', 10), (b'M', 20), (b'G', 30)];

/// Parses a whole number with an optional `K`, `M` or `G` suffix (any case; powers of 1024).
/// Surrounding spaces are allowed, a sign, fraction or exponent is not.
///
/// # Errors
/// [`NumberError`] when it is empty, not such a number, or above `u64::MAX`.
pub fn parse_size(text: &str) -> Result<u64, NumberError> {
    let t = text.trim().as_bytes();
    let (&last, _) = t.split_last().ok_or(NumberError::Empty)?;
    let (digits, shift) = match SUFFIXES
        .iter()
        .find(|(s, _)| last.to_ascii_uppercase() == *s)
    {
        Some(&(_, shift)) => (t.get(..t.len() - 1).unwrap_or_default(), shift),
        None => (t, 0),
    };
    if digits.is_empty() || !digits.iter().all(u8::is_ascii_digit) {
        return Err(NumberError::NotASize);
    }
    let mut n: u64 = 0;
    for &d in digits {
        n = n
            .checked_mul(10)
            .and_then(|n| n.checked_add(u64::from(d - b'0')))
            .ok_or(NumberError::Overflow)?;
    }
    n.checked_mul(1 << shift).ok_or(NumberError::Overflow)
}

/// A size as the help texts write it: the largest suffix that divides it exactly (`4K`, `1G`).
pub fn format_size(n: u64) -> String {
    for &(s, shift) in SUFFIXES.iter().rev() {
        if n != 0 && n.is_multiple_of(1 << shift) {
            return format!("{}{}", n >> shift, char::from(s));
        }
    }
    n.to_string()
}

/// Parses a finite floating-point number (spaces around it allowed).
///
/// # Errors
/// [`NumberError::NotANumber`] or [`NumberError::NotFinite`].
pub fn parse_float(text: &str) -> Result<f64, NumberError> {
    let t = text.trim();
    if t.is_empty() {
        return Err(NumberError::Empty);
    }
    let v: f64 = t.parse().map_err(|_| NumberError::NotANumber)?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(NumberError::NotFinite)
    }
}

/// Parses `N` comma-separated finite numbers (`A,B` or `A,B,C`: views and lights); the error says
/// why, without naming the option.
///
/// # Errors
/// When the text is not `N` comma-separated finite numbers.
pub fn numbers<const N: usize>(text: &str) -> Result<[f64; N], String> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    if parts.len() != N {
        return Err(format!("expected {N} comma-separated numbers"));
    }
    let mut out = [0.0; N];
    for (o, p) in out.iter_mut().zip(&parts) {
        *o = parse_float(p).map_err(|e| format!("{p:?} is {e}"))?;
    }
    Ok(out)
}

/// [`numbers`], the error naming the option (`what`) and the text.
///
/// # Errors
/// When the text is not `N` comma-separated finite numbers.
pub fn parse_numbers<const N: usize>(what: &str, text: &str) -> Result<[f64; N]> {
    numbers(text).map_err(|why| anyhow!("{what} {text:?}: {why}"))
}

/// Parses a view: a standard view's name or `AZ,EL,DIST`.
///
/// # Errors
/// When it is neither.
pub fn parse_view(text: &str) -> Result<View> {
    if let Some(v) = pocketsplat_core::camera::standard_view(text) {
        return Ok(v);
    }
    let [az, el, dist] = parse_numbers::<3>("--view", text)?;
    if dist <= 0.0 {
        bail!("--view {text:?}: distance must be positive");
    }
    Ok(View::new(az, el, dist))
}

/// A light direction `AZ,EL`: azimuth and elevation in degrees (a value parser for `--light`).
///
/// # Errors
/// When it is not two finite numbers.
pub fn light_az_el(text: &str) -> Result<(f64, f64), String> {
    let [az, el] = numbers::<2>(text)?;
    Ok((az, el))
}

/// A frame size `WxH` in pixels (a value parser for `--size`), each side from 16 to 2048: the
/// buffers' size, which the projection follows.
///
/// # Errors
/// When it is not two whole numbers joined by `x`, or a side is out of range.
pub fn frame_size(text: &str) -> Result<Viewport, String> {
    let (w, h) = text
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("`{text}`: want WIDTHxHEIGHT in pixels, e.g. 320x240"))?;
    let side = |t: &str, what: &str| -> Result<u32, String> {
        let n: u32 = t
            .trim()
            .parse()
            .map_err(|_| format!("`{text}`: the {what} `{t}` is not a whole number of pixels"))?;
        if !(16..=u32::from(Viewport::MAX_SIDE)).contains(&n) {
            return Err(format!(
                "`{text}`: the {what} must be from 16 to {} pixels",
                Viewport::MAX_SIDE
            ));
        }
        Ok(n)
    };
    let (w, h) = (side(w, "width")?, side(h, "height")?);
    Viewport::new(w, h).ok_or_else(|| format!("`{text}`: not a frame size"))
}

/// A point light's position `X,Y,Z` in bounding-sphere radii from the sphere's centre (a value
/// parser for `--light-pos`).
///
/// # Errors
/// When it is not three finite numbers, or it is the centre itself.
pub fn light_pos(text: &str) -> Result<[f64; 3], String> {
    let p = numbers::<3>(text)?;
    if p == [0.0; 3] {
        return Err("the light cannot be at the model's centre".into());
    }
    Ok(p)
}

/// A view of the pack by name, a standard view, `AZ,EL,DIST`, or `path@T` (the camera path at `T`
/// seconds).
///
/// # Errors
/// When it is none of these.
pub fn parse_pack_view(pack: &Pack<'_>, text: &str) -> Result<View> {
    if let Some(v) = pack.view_named(text) {
        return Ok(v);
    }
    if let Some(t) = text.strip_prefix("path@") {
        let t: f64 = t
            .parse()
            .map_err(|e| anyhow!("--view {text:?}: {t:?} is not a time in seconds ({e})"))?;
        return pack
            .path_view(t)
            .ok_or_else(|| anyhow!("--view {text:?}: the pack has no camera path"));
    }
    parse_view(text).map_err(|e| {
        let names: Vec<&str> = (0..pack.view_count())
            .filter_map(|v| pack.view(v).map(|(n, _)| n))
            .collect();
        anyhow!("{e} (the pack's views: {})", names.join(", "))
    })
}

/// A `clap` value parser for a size or count from `lo` to `hi` (inclusive), suffixes allowed.
pub fn size<T>(lo: u64, hi: u64) -> impl Fn(&str) -> Result<T, String> + Clone + Send + Sync
where
    T: TryFrom<u64>,
{
    move |text| {
        let n = parse_size(text).map_err(|e| e.to_string())?;
        if !(lo..=hi).contains(&n) {
            return Err(format!(
                "must be from {} to {}",
                format_size(lo),
                format_size(hi)
            ));
        }
        T::try_from(n).map_err(|_| format!("too large for this machine (at most {hi})"))
    }
}

/// A `clap` value parser for a whole number from `lo` to `hi` (inclusive), without suffixes in the
/// message (depths, ρ, scales).
pub fn int<T>(lo: u64, hi: u64) -> impl Fn(&str) -> Result<T, String> + Clone + Send + Sync
where
    T: TryFrom<u64>,
{
    move |text| {
        let n = parse_size(text).map_err(|e| e.to_string())?;
        if !(lo..=hi).contains(&n) {
            return Err(format!("must be from {lo} to {hi}"));
        }
        T::try_from(n).map_err(|_| format!("must be from {lo} to {hi}"))
    }
}

/// A `clap` value parser for a block size: a power of two from 512 to 64K.
pub fn block_size(text: &str) -> Result<u32, String> {
    let n: u32 = size(512, 1 << 16)(text)?;
    if n.is_power_of_two() {
        Ok(n)
    } else {
        Err("must be a power of two from 512 to 64K".into())
    }
}

/// Which ends of a float range are excluded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ends {
    /// `lo <= x <= hi`.
    Closed,
    /// `lo < x < hi`.
    Open,
    /// `lo < x <= hi`.
    OpenLow,
}

/// A `clap` value parser for a finite float in the range `lo`..`hi` (ends as `ends` says).
pub fn float<T>(lo: f64, hi: f64, ends: Ends) -> impl Fn(&str) -> Result<T, String> + Clone
where
    T: FromF64,
{
    move |text| {
        let parsed = parse_float(text).map_err(|e| e.to_string())?;
        // The range is checked on the value as stored: `1e-50` is above 0 but 0 as an `f32`.
        let t = T::from_f64(parsed).ok_or_else(|| format!("too large (at most {hi})"))?;
        let v = t.to_f64();
        let ok = match ends {
            Ends::Closed => lo <= v && v <= hi,
            Ends::Open => lo < v && v < hi,
            Ends::OpenLow => lo < v && v <= hi,
        };
        if !ok {
            return Err(match ends {
                Ends::Closed => format!("must be from {lo} to {hi}"),
                Ends::Open => format!("must be between {lo} and {hi}, both excluded"),
                Ends::OpenLow => format!("must be above {lo} and at most {hi}"),
            });
        }
        Ok(t)
    }
}

/// `f64` and `f32` for [`float`].
pub trait FromF64: Sized {
    /// The value (rounded), or `None` when it does not fit.
    fn from_f64(v: f64) -> Option<Self>;
    /// Back, exactly.
    fn to_f64(&self) -> f64;
}

impl FromF64 for f64 {
    fn from_f64(v: f64) -> Option<Self> {
        Some(v)
    }
    fn to_f64(&self) -> f64 {
        *self
    }
}

impl FromF64 for f32 {
    fn from_f64(v: f64) -> Option<Self> {
        let f = v as f32;
        f.is_finite().then_some(f)
    }
    fn to_f64(&self) -> f64 {
        f64::from(*self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes() {
        assert_eq!(parse_size("0"), Ok(0));
        assert_eq!(parse_size(" 64K "), Ok(65536));
        assert_eq!(parse_size("16m"), Ok(16 << 20));
        assert_eq!(parse_size("1G"), Ok(1 << 30));
        assert_eq!(parse_size("18446744073709551615"), Ok(u64::MAX));
        assert_eq!(
            parse_size("18446744073709551616"),
            Err(NumberError::Overflow)
        );
        assert_eq!(parse_size("17179869184G"), Err(NumberError::Overflow));
        assert_eq!(parse_size("16777215G"), Ok(16_777_215 << 30));
        for bad in [
            "", " ", "K", "-1", "+1", "1.5G", "1e9", "1KB", "1T", "0x10", "1 K",
        ] {
            assert!(parse_size(bad).is_err(), "{bad:?}");
        }
        assert_eq!(format_size(4096), "4K");
        assert_eq!(format_size(1 << 30), "1G");
        assert_eq!(format_size(1000), "1000");
        assert_eq!(format_size(0), "0");
    }

    #[test]
    fn ranges_name_the_bounds() {
        let cache = size::<usize>(4 << 10, 1 << 30);
        assert_eq!(cache("1G"), Ok(1 << 30));
        assert_eq!(cache("100000M").unwrap_err(), "must be from 4K to 1G");
        assert!(cache("18446744073709551615").is_err());
        assert!(cache("18446744073709551616")
            .unwrap_err()
            .contains("too large"));
        assert_eq!(block_size("4K"), Ok(4096));
        assert!(block_size("3000").is_err());
        assert!(block_size("0").is_err());
        let depth = int::<u8>(0, 10);
        assert_eq!(depth("11").unwrap_err(), "must be from 0 to 10");
        assert_eq!(depth("10"), Ok(10));
        let fov = float::<f64>(0.0, 180.0, Ends::Open);
        assert!(fov("180").is_err() && fov("0").is_err() && fov("nan").is_err());
        assert_eq!(fov("45"), Ok(45.0));
        let cutoff = float::<f32>(0.0, f64::from(f32::MAX), Ends::OpenLow);
        assert!(cutoff("1e300").is_err() && cutoff("inf").is_err());
        // Above 0 as an f64, 0 as an f32 (found by fuzz/fuzz_targets/cli_numbers.rs).
        assert!(cutoff("1e-50").is_err());
        assert_eq!(cutoff("2"), Ok(2.0));
    }

    #[test]
    fn number_lists() {
        assert_eq!(
            parse_numbers::<2>("--light", "-40, 60").unwrap(),
            [-40.0, 60.0]
        );
        for bad in ["1", "1,2,3", "nan,1", "1e999,0", "a,b", ""] {
            assert!(parse_numbers::<2>("--light", bad).is_err(), "{bad:?}");
        }
        assert_eq!(
            parse_numbers::<2>("--light", "1").unwrap_err().to_string(),
            "--light \"1\": expected 2 comma-separated numbers"
        );
        assert_eq!(light_az_el("-40,60"), Ok((-40.0, 60.0)));
        assert_eq!(
            light_az_el("1").unwrap_err(),
            "expected 2 comma-separated numbers"
        );
        assert_eq!(light_pos("0, 2, -1"), Ok([0.0, 2.0, -1.0]));
        assert!(light_pos("0,0,0").unwrap_err().contains("centre"));
        assert!(light_pos("1,nan,0").unwrap_err().contains("not finite"));
    }
}
