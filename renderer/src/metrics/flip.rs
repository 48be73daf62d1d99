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
    // The plain mean of the error map, summed in f64 (FlipPool's mean is f32 and histogram based).
    let errors = error_map.to_vec();
    let sum: f64 = errors.iter().map(|&e| f64::from(e)).sum();
    Ok(sum / errors.len() as f64)
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
    fn size_mismatch_and_empty() {
        let err = flip(&Image::new(8, 8), &Image::new(8, 9), 0.0, Tonemap::Clamp).unwrap_err();
        assert!(err.to_string().contains("8x8") && err.to_string().contains("8x9"));
        assert!(flip(&Image::new(0, 0), &Image::new(0, 0), 0.0, Tonemap::Clamp).is_err());
    }
}
