//! Per-pixel error metrics (MSE, relative MSE) and the non-finite pixel fraction, summed in f64.
//!
//! Relative MSE follows the usual rendering-literature form (e.g. Rousselle et al. 2011,
//! Bitterli's benchmark): the squared error divided by the squared reference plus a small
//! constant so dark pixels do not dominate.

use super::{check_pair, finite, MetricError};
use crate::film::Image;

/// How [`mse`] is computed, for reports and result tables.
pub const MSE_FORMULA: &str =
    "mean over pixels and RGB channels of (x-r)^2, linear radiance, pixels finite in both";

/// How [`rmse`] is computed, for reports and result tables.
pub const RMSE_FORMULA: &str = "sqrt(MSE), linear radiance";

/// How [`rel_mse`] is computed, for reports and result tables.
pub const REL_MSE_FORMULA: &str = "mean over pixels and RGB channels of (x-r)^2/(r^2+0.01)";

/// Added to r² in the denominator of [`rel_mse`].
const REL_MSE_EPSILON: f64 = 0.01;

/// Mean squared error over pixels and RGB channels, skipping pixels where either image is
/// non-finite (see the [module docs](crate::metrics)).
pub fn mse(img: &Image, reference: &Image) -> Result<f64, MetricError> {
    mean_error(img, reference, |x, r| (x - r) * (x - r))
}

/// Root mean squared error: `sqrt(`[`mse`]`)`.
pub fn rmse(img: &Image, reference: &Image) -> Result<f64, MetricError> {
    Ok(mse(img, reference)?.sqrt())
}

/// Relative MSE: the mean over pixels and RGB channels of `(x−r)² / (r² + 0.01)`
/// ([`REL_MSE_FORMULA`]), skipping pixels where either image is non-finite.
pub fn rel_mse(img: &Image, reference: &Image) -> Result<f64, MetricError> {
    mean_error(img, reference, |x, r| {
        (x - r) * (x - r) / (r * r + REL_MSE_EPSILON)
    })
}

/// The fraction of pixels with at least one NaN or ±Inf channel (0 for an empty image).
pub fn nan_fraction(img: &Image) -> f64 {
    if img.pixels.is_empty() {
        return 0.0;
    }
    let bad = img.pixels.iter().filter(|p| !finite(p)).count();
    bad as f64 / img.pixels.len() as f64
}

/// The mean of `error(x, r)` over channels of pixels finite in both images.
fn mean_error(
    img: &Image,
    reference: &Image,
    error: impl Fn(f64, f64) -> f64,
) -> Result<f64, MetricError> {
    check_pair(img, reference)?;
    let mut sum = 0.0f64;
    let mut count = 0usize;
    for (x, r) in img.pixels.iter().zip(&reference.pixels) {
        if !finite(x) || !finite(r) {
            continue;
        }
        for c in 0..3 {
            sum += error(f64::from(x[c]), f64::from(r[c]));
        }
        count += 3;
    }
    if count == 0 {
        return Err(MetricError::NoFinitePixels {
            width: img.width,
            height: img.height,
        });
    }
    Ok(sum / count as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-12 * b.abs().max(1.0)
    }

    #[test]
    fn identical_is_zero() {
        let img = Image::from_fn(4, 3, |x, y| [x as f32, y as f32, 0.3]);
        assert_eq!(mse(&img, &img).unwrap(), 0.0);
        assert_eq!(rel_mse(&img, &img).unwrap(), 0.0);
    }

    #[test]
    fn constant_offset() {
        let reference = Image::from_fn(5, 4, |x, y| [x as f32 * 0.5, y as f32, 2.0]);
        let c = 0.25f32; // exact in binary, so x − r is exactly c
        let img = Image::from_fn(5, 4, |x, y| reference.get(x, y).map(|v| v + c));
        assert!(close(mse(&img, &reference).unwrap(), 0.0625));
        assert!(close(rmse(&img, &reference).unwrap(), 0.25));
    }

    #[test]
    fn two_pixel_by_hand() {
        // Reference pixels (1, 0, 0.5) and (0.1, 2, 0); test pixels differ by
        // (0.5, 0.25, −0.5) and (0, 1, 0.25). Per channel (x−r)²/(r²+0.01):
        //   0.25/1.01, 0.0625/0.01, 0.25/0.26, 0/0.02, 1/4.01, 0.0625/0.01
        let reference = Image {
            width: 2,
            height: 1,
            pixels: vec![[1.0, 0.0, 0.5], [0.1, 2.0, 0.0]],
        };
        let img = Image {
            width: 2,
            height: 1,
            pixels: vec![[1.5, 0.25, 0.0], [0.1, 3.0, 0.25]],
        };
        let expected_rel =
            (0.25 / 1.01 + 0.0625 / 0.01 + 0.25 / 0.26 + 0.0 + 1.0 / 4.01 + 0.0625 / 0.01) / 6.0;
        let expected_mse = (0.25 + 0.0625 + 0.25 + 0.0 + 1.0 + 0.0625) / 6.0;
        // 0.1 is not exact in f32; its error shows only in the 0/0.02 term, which stays 0.
        assert!(close(rel_mse(&img, &reference).unwrap(), expected_rel));
        assert!(close(mse(&img, &reference).unwrap(), expected_mse));
    }

    #[test]
    fn non_finite_pixels_are_skipped_and_counted() {
        let reference = Image::from_fn(4, 1, |_, _| [1.0; 3]);
        let mut img = Image::from_fn(4, 1, |_, _| [2.0; 3]);
        img.set(0, 0, [f32::NAN, 2.0, 2.0]);
        img.set(1, 0, [2.0, f32::INFINITY, 2.0]);
        assert_eq!(mse(&img, &reference).unwrap(), 1.0);
        assert_eq!(nan_fraction(&img), 0.5);
        assert_eq!(nan_fraction(&reference), 0.0);
        assert_eq!(nan_fraction(&Image::new(0, 0)), 0.0);
        let all_bad = Image::from_fn(2, 1, |_, _| [f32::NAN; 3]);
        assert!(matches!(
            mse(&all_bad, &Image::new(2, 1)),
            Err(MetricError::NoFinitePixels { .. })
        ));
        assert!(rel_mse(&Image::new(0, 0), &Image::new(0, 0)).is_err());
    }

    #[test]
    fn size_mismatch_names_both_sizes() {
        let err = mse(&Image::new(4, 3), &Image::new(3, 4)).unwrap_err();
        assert_eq!(err.to_string(), "image is 4x3 but the reference is 3x4");
        assert!(rel_mse(&Image::new(4, 3), &Image::new(4, 2)).is_err());
        let bad = Image {
            width: 2,
            height: 2,
            pixels: vec![[0.0; 3]],
        };
        assert!(matches!(
            mse(&Image::new(2, 2), &bad),
            Err(MetricError::Malformed {
                which: "reference",
                ..
            })
        ));
    }
}
