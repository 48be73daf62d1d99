//! PSNR of the display images: `10 log10(1 / MSE)` where the MSE is over the RGB channels of
//! both images' sRGB8 display encodings scaled to [0, 1] (peak 1).
//!
//! Linear radiance has no natural peak, so PSNR is taken where it has one: on what a viewer sees.

use super::{check_pair, Display, MetricError};
use crate::film::Image;

/// What [`psnr`] measures, for reports and result tables.
pub const PSNR_NOTE: &str = "10*log10(1/MSE) in dB, the MSE over pixels and RGB channels of \
    both images' sRGB8 display images (exposure, tonemap, sRGB OETF) divided by 255, peak 1; \
    absent (null) when the display images are identical (infinite PSNR)";

/// The PSNR in dB of the display images of `img` against `reference` (see [`PSNR_NOTE`]);
/// `None` when they are identical (MSE 0, infinite PSNR).
pub fn psnr(img: &Image, reference: &Image, display: Display) -> Result<Option<f64>, MetricError> {
    check_pair(img, reference)?;
    if img.pixels.is_empty() {
        return Err(MetricError::NoFinitePixels {
            width: img.width,
            height: img.height,
        });
    }
    let (a, b) = (display.rgb(img), display.rgb(reference));
    let sum: f64 = a.iter().zip(&b).map(|(x, r)| (x - r) * (x - r)).sum();
    let mse = sum / a.len() as f64;
    Ok((mse > 0.0).then(|| -10.0 * mse.log10()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identical_is_none_and_known_offsets() {
        let d = Display::default();
        let white = Image::from_fn(3, 2, |_, _| [1.0; 3]);
        let black = Image::new(3, 2);
        assert_eq!(psnr(&white, &white, d).unwrap(), None);
        // Black against white: MSE 1, 0 dB.
        assert_eq!(psnr(&black, &white, d).unwrap(), Some(0.0));
        // 0.18 → sRGB 118 against 0.5 → 188: every channel differs by 70/255.
        let a = Image::from_fn(3, 2, |_, _| [0.18; 3]);
        let b = Image::from_fn(3, 2, |_, _| [0.5; 3]);
        let expected = 20.0 * (255.0f64 / 70.0).log10();
        let got = psnr(&a, &b, d).unwrap().unwrap();
        assert!((got - expected).abs() < 1e-12, "{got} vs {expected}");
    }

    #[test]
    fn empty_and_mismatch() {
        let d = Display::default();
        assert!(psnr(&Image::new(0, 0), &Image::new(0, 0), d).is_err());
        assert!(psnr(&Image::new(2, 2), &Image::new(2, 3), d).is_err());
    }
}
