//! The display transform the perceptual metrics (PSNR, SSIM, FLIP) see: candela's film tonemapper
//! ([`tonemap_srgb8`]) with an exposure and a tone curve, and the luma of its output.

use serde::{Deserialize, Serialize};

use crate::film::{tonemap_srgb8, Image};
use crate::scene::Tonemap;

/// Rec. 709 / sRGB luma weights for R', G', B'.
pub const LUMA_WEIGHTS: [f64; 3] = [0.2126, 0.7152, 0.0722];

/// How linear radiance becomes a display image before PSNR, SSIM and FLIP: `2^exposure_ev`, then
/// the tone curve, then sRGB8 exactly as a PNG from `candela render` (see [`tonemap_srgb8`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Display {
    /// Exposure in EV (stops): radiance is scaled by `2^exposure_ev`.
    pub exposure_ev: f32,
    /// The per-channel tone curve.
    pub tonemap: Tonemap,
}

impl Default for Display {
    /// 0 EV and `clamp`, the scene format's film defaults.
    fn default() -> Self {
        Display {
            exposure_ev: 0.0,
            tonemap: Tonemap::Clamp,
        }
    }
}

impl Display {
    /// The display image as RGB in [0, 1]: the sRGB8 bytes of [`tonemap_srgb8`] divided by 255,
    /// three values per pixel, row 0 first.
    pub fn rgb(&self, img: &Image) -> Vec<f64> {
        tonemap_srgb8(img, self.exposure_ev, self.tonemap)
            .into_iter()
            .map(|b| f64::from(b) / 255.0)
            .collect()
    }

    /// The display image's luma `Y' = 0.2126 R' + 0.7152 G' + 0.0722 B'` in [0, 1], one value
    /// per pixel, where R', G', B' are the sRGB-encoded channels of [`Display::rgb`].
    pub fn luma(&self, img: &Image) -> Vec<f64> {
        self.rgb(img)
            .chunks_exact(3)
            .map(|p| LUMA_WEIGHTS[0] * p[0] + LUMA_WEIGHTS[1] * p[1] + LUMA_WEIGHTS[2] * p[2])
            .collect()
    }
}

/// The scene format's name of a tone curve: "clamp", "reinhard" or "aces".
pub fn tonemap_name(tonemap: Tonemap) -> &'static str {
    match tonemap {
        Tonemap::Clamp => "clamp",
        Tonemap::Reinhard => "reinhard",
        Tonemap::Aces => "aces",
    }
}

/// The tone curve called `name` ("clamp", "reinhard" or "aces"); `None` for anything else.
pub fn tonemap_from_name(name: &str) -> Option<Tonemap> {
    match name {
        "clamp" => Some(Tonemap::Clamp),
        "reinhard" => Some(Tonemap::Reinhard),
        "aces" => Some(Tonemap::Aces),
        _ => None,
    }
}

/// [`Display`] as it is written into reports: the tone curve by name.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DisplaySettings {
    /// Exposure in EV.
    pub exposure_ev: f32,
    /// "clamp", "reinhard" or "aces".
    pub tonemap: String,
}

impl From<Display> for DisplaySettings {
    fn from(d: Display) -> Self {
        DisplaySettings {
            exposure_ev: d.exposure_ev,
            tonemap: tonemap_name(d.tonemap).to_string(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn luma_of_primaries_and_white() {
        let img = Image::from_fn(4, 1, |x, _| match x {
            0 => [1.0, 0.0, 0.0],
            1 => [0.0, 1.0, 0.0],
            2 => [0.0, 0.0, 1.0],
            _ => [1.0, 1.0, 1.0],
        });
        let y = Display::default().luma(&img);
        assert_eq!(y[..3], LUMA_WEIGHTS);
        assert!((y[3] - 1.0).abs() < 1e-15);
    }

    #[test]
    fn rgb_is_srgb8_over_255() {
        // 0.18 linear → sRGB 118; 0.5 at −1 EV → 0.25 → 137; NaN → black.
        let img = Image::from_fn(3, 1, |x, _| [[0.36, 0.5, f32::NAN][x as usize]; 3]);
        let d = Display {
            exposure_ev: -1.0,
            tonemap: Tonemap::Clamp,
        };
        let rgb = d.rgb(&img);
        assert_eq!(rgb[0], 118.0 / 255.0);
        assert_eq!(rgb[3], 137.0 / 255.0);
        assert_eq!(rgb[6], 0.0);
    }

    #[test]
    fn names_round_trip() {
        for t in [Tonemap::Clamp, Tonemap::Reinhard, Tonemap::Aces] {
            assert_eq!(tonemap_from_name(tonemap_name(t)), Some(t));
        }
        assert_eq!(tonemap_from_name("filmic"), None);
    }
}
