//! LDR-FLIP (Andersson et al. 2020, "FLIP: A Difference Evaluator for Alternating Images";
//! NVIDIA's implementation through the `nv-flip` bindings) of two tonemapped images.

use crate::film::{tonemap_srgb8, Image};
use crate::scene::Tonemap;

use super::{check_pair, MetricError};

/// What [`flip`] measures, for reports and result tables.
pub const FLIP_NOTE: &str = "mean LDR-FLIP (NVIDIA FLIP via nv-flip, 67 pixels per degree) of \
    both images converted to sRGB8 by candela's film tonemapper (film::tonemap_srgb8) with the \
    given exposure and tonemap: scale by 2^EV, per-channel clamp | Reinhard x/(1+x) | ACES \
    (Narkowicz 2015 fit, no 0.6 pre-scale), clamp to [0,1], sRGB OETF, round; NaN/Inf pixels \
    black";

/// The mean LDR-FLIP error, in [0, 1], of `img` against `reference` after both go through
/// [`tonemap_srgb8`] with `exposure_ev` and `tonemap`, at nv-flip's default 67 pixels per degree
/// (see [`FLIP_NOTE`]). Identical images give 0.
pub fn flip(
    img: &Image,
    reference: &Image,
    exposure_ev: f32,
    tonemap: Tonemap,
) -> Result<f64, MetricError> {
    Ok(flip_map(img, reference, exposure_ev, tonemap)?.mean())
}

/// The per-pixel LDR-FLIP error map of `img` against `reference` (see [`flip`]).
pub fn flip_map(
    img: &Image,
    reference: &Image,
    exposure_ev: f32,
    tonemap: Tonemap,
) -> Result<FlipMap, MetricError> {
    check_pair(img, reference)?;
    let (width, height) = (img.width, img.height);
    if width == 0 || height == 0 {
        return Err(MetricError::NoFinitePixels { width, height });
    }
    let to_flip = |image: &Image| {
        nv_flip::FlipImageRgb8::with_data(
            width,
            height,
            &tonemap_srgb8(image, exposure_ev, tonemap),
        )
    };
    let error_map = nv_flip::flip(
        to_flip(reference),
        to_flip(img),
        nv_flip::DEFAULT_PIXELS_PER_DEGREE,
    );
    Ok(FlipMap {
        width,
        height,
        errors: error_map.to_vec(),
    })
}

/// A FLIP error map: one error in [0, 1] per pixel, row-major, row 0 at the top.
#[derive(Debug, Clone, PartialEq)]
pub struct FlipMap {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Per-pixel FLIP error, `errors[y * width + x]`.
    pub errors: Vec<f32>,
}

impl FlipMap {
    /// The plain mean of the map, summed in f64 (nv-flip's FlipPool mean is f32 and histogram
    /// based).
    pub fn mean(&self) -> f64 {
        let sum: f64 = self.errors.iter().map(|&e| f64::from(e)).sum();
        sum / self.errors.len().max(1) as f64
    }

    /// The map through FLIP's magma colour map (0 black-purple, 1 pale yellow), tightly packed
    /// RGB8, row 0 first.
    pub fn magma_rgb8(&self) -> Vec<u8> {
        let map = nv_flip::FlipImageFloat::with_data(self.width, self.height, &self.errors);
        map.apply_color_lut(&nv_flip::magma_lut()).to_vec()
    }

    /// The magma-coloured map encoded as an 8-bit RGB PNG in memory.
    pub fn encode_png(&self) -> Result<Vec<u8>, MetricError> {
        use image::codecs::png::PngEncoder;
        use image::{ExtendedColorType, ImageEncoder};
        let mut bytes = Vec::new();
        PngEncoder::new(&mut bytes)
            .write_image(
                &self.magma_rgb8(),
                self.width,
                self.height,
                ExtendedColorType::Rgb8,
            )
            .map_err(|e| MetricError::Encode {
                message: e.to_string().replace('\n', " "),
            })?;
        Ok(bytes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gradient(w: u32, h: u32) -> Image {
        Image::from_fn(w, h, |x, y| {
            [
                x as f32 / w as f32,
                y as f32 / h as f32,
                ((x + y) % 3) as f32,
            ]
        })
    }

    #[test]
    fn identical_is_zero() {
        let img = gradient(32, 24);
        for t in [Tonemap::Clamp, Tonemap::Reinhard, Tonemap::Aces] {
            assert_eq!(flip(&img, &img, 0.0, t).unwrap(), 0.0);
        }
    }

    #[test]
    fn black_vs_white_is_large() {
        let black = Image::new(16, 16);
        let white = Image::from_fn(16, 16, |_, _| [1.0; 3]);
        let e = flip(&black, &white, 0.0, Tonemap::Clamp).unwrap();
        assert!(e > 0.5 && e <= 1.0, "{e}");
    }

    #[test]
    fn small_noise_is_small_and_ordered() {
        let reference = gradient(32, 32);
        let noisy = |amp: f32| {
            Image::from_fn(32, 32, |x, y| {
                let n = (((x * 7919 + y * 104729) % 17) as f32 / 16.0 - 0.5) * amp;
                reference.get(x, y).map(|v| v + n)
            })
        };
        let small = flip(&noisy(0.02), &reference, 0.0, Tonemap::Aces).unwrap();
        let large = flip(&noisy(0.4), &reference, 0.0, Tonemap::Aces).unwrap();
        assert!(
            0.0 < small && small < large && large < 1.0,
            "{small} {large}"
        );
    }

    #[test]
    fn map_mean_heatmap() {
        let reference = gradient(16, 8);
        let mut img = reference.clone();
        img.set(3, 2, [5.0, 5.0, 5.0]);
        let map = flip_map(&img, &reference, 0.0, Tonemap::Clamp).unwrap();
        assert_eq!((map.width, map.height, map.errors.len()), (16, 8, 128));
        assert_eq!(
            map.mean(),
            flip(&img, &reference, 0.0, Tonemap::Clamp).unwrap()
        );
        // The changed pixel carries the largest error.
        let max = map.errors.iter().cloned().fold(0.0f32, f32::max);
        assert_eq!(map.errors[2 * 16 + 3], max);
        let rgb = map.magma_rgb8();
        assert_eq!(rgb.len(), 16 * 8 * 3);
        let png = map.encode_png().unwrap();
        let back = image::load_from_memory(&png).unwrap().to_rgb8();
        assert_eq!(back.dimensions(), (16, 8));
        assert_eq!(back.into_raw(), rgb);
    }

    #[test]
    fn size_mismatch_and_empty() {
        let err = flip(&Image::new(8, 8), &Image::new(8, 9), 0.0, Tonemap::Clamp).unwrap_err();
        assert!(err.to_string().contains("8x8") && err.to_string().contains("8x9"));
        assert!(flip(&Image::new(0, 0), &Image::new(0, 0), 0.0, Tonemap::Clamp).is_err());
    }
}
