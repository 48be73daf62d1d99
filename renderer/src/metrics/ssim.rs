//! SSIM, the structural similarity index of Wang, Bovik, Sheikh & Simoncelli 2004 ("Image Quality
//! Assessment: From Error Visibility to Structural Similarity", IEEE TIP 13(4)), computed as
//! scikit-image's `structural_similarity(x, y, gaussian_weights=True, sigma=1.5,
//! use_sample_covariance=False, data_range=1)` does, so the numbers match it.
//!
//! Per pixel, with Gaussian-weighted local means μ, variances σ² and covariance σxy:
//! `SSIM = (2 μx μy + C1)(2 σxy + C2) / ((μx² + μy² + C1)(σx² + σy² + C2))`,
//! `C1 = (0.01 L)²`, `C2 = (0.03 L)²`, `L = 1`. The window is the normalised Gaussian of σ = 1.5
//! truncated at 3.5σ (radius 5, 11 × 11 taps), separable; variances are population ones
//! (`E[x²] − E[x]²`). The mean SSIM averages only pixels whose window lies wholly inside the image
//! (scikit-image filters with `mode="reflect"` and then crops a 5-pixel border, so the border mode
//! never reaches the mean); images must be at least 11 × 11.

use super::{check_pair, Display, MetricError};
use crate::film::Image;

/// Gaussian window standard deviation, pixels.
pub const SSIM_SIGMA: f64 = 1.5;
/// Window radius: `int(3.5 σ + 0.5)`, as scipy.ndimage truncates the Gaussian.
pub const SSIM_RADIUS: usize = 5;
/// The smallest image side SSIM accepts (the window, 11).
pub const SSIM_MIN_SIDE: u32 = 2 * SSIM_RADIUS as u32 + 1;
/// Stabilising constants `K1`, `K2` of Wang et al. 2004, with dynamic range `L = 1`.
pub const SSIM_K1: f64 = 0.01;
/// See [`SSIM_K1`].
pub const SSIM_K2: f64 = 0.03;

/// What [`ssim`] measures, for reports and result tables.
pub const SSIM_NOTE: &str = "mean SSIM (Wang et al. 2004; Gaussian window sigma 1.5, 11x11, \
    K1 0.01, K2 0.03, L 1, population covariances; mean over pixels whose window lies inside the \
    image, as scikit-image structural_similarity with gaussian_weights=True) of the luma \
    Y' = 0.2126 R' + 0.7152 G' + 0.0722 B' of both images' sRGB8 display images (exposure, \
    tonemap, sRGB OETF, /255); 1 = identical; absent below 11x11";

/// The mean SSIM of `img` against `reference` on the luma of their display images (see
/// [`Display::luma`] and [`SSIM_NOTE`]). Symmetric in its arguments; identical images give 1.
pub fn ssim(img: &Image, reference: &Image, display: Display) -> Result<f64, MetricError> {
    check_pair(img, reference)?;
    ssim_gray(
        &display.luma(img),
        &display.luma(reference),
        img.width,
        img.height,
    )
}

/// The mean SSIM of two grayscale images in [0, 1] (`L = 1`), row-major, `width × height`.
///
/// This is the core of [`ssim`], exposed so it can be checked against scikit-image on the same
/// numbers. Errors if either slice is not `width · height` long or a side is below 11.
pub fn ssim_gray(x: &[f64], y: &[f64], width: u32, height: u32) -> Result<f64, MetricError> {
    let (w, h) = (width as usize, height as usize);
    for (which, plane) in [("test", x), ("reference", y)] {
        if plane.len() != w * h {
            return Err(MetricError::Malformed {
                which,
                width,
                height,
                len: plane.len(),
            });
        }
    }
    if width < SSIM_MIN_SIDE || height < SSIM_MIN_SIDE {
        return Err(MetricError::TooSmall {
            metric: "SSIM",
            width,
            height,
            min_side: SSIM_MIN_SIDE,
        });
    }
    let weights = gaussian_window();
    // Step 1: the five local moments E[x], E[y], E[x²], E[y²], E[xy] at interior pixels.
    let moments = |f: &dyn Fn(usize) -> f64| filter_interior(w, h, &weights, f);
    let ux = moments(&|i| x[i]);
    let uy = moments(&|i| y[i]);
    let uxx = moments(&|i| x[i] * x[i]);
    let uyy = moments(&|i| y[i] * y[i]);
    let uxy = moments(&|i| x[i] * y[i]);
    // Step 2: SSIM per interior pixel, then the mean.
    let c1 = (SSIM_K1 * 1.0f64).powi(2);
    let c2 = (SSIM_K2 * 1.0f64).powi(2);
    let mut sum = 0.0f64;
    for k in 0..ux.len() {
        let (mx, my) = (ux[k], uy[k]);
        let vx = uxx[k] - mx * mx;
        let vy = uyy[k] - my * my;
        let vxy = uxy[k] - mx * my;
        let a1 = 2.0 * mx * my + c1;
        let a2 = 2.0 * vxy + c2;
        let b1 = mx * mx + my * my + c1;
        let b2 = vx + vy + c2;
        sum += (a1 * a2) / (b1 * b2);
    }
    Ok(sum / ux.len() as f64)
}

/// The normalised 1-D Gaussian `exp(−k² / 2σ²)`, `k = −5..=5`, as scipy's `_gaussian_kernel1d`.
fn gaussian_window() -> [f64; 2 * SSIM_RADIUS + 1] {
    let mut w = [0.0; 2 * SSIM_RADIUS + 1];
    for (i, wi) in w.iter_mut().enumerate() {
        let k = i as f64 - SSIM_RADIUS as f64;
        *wi = (-0.5 / (SSIM_SIGMA * SSIM_SIGMA) * k * k).exp();
    }
    let total: f64 = w.iter().sum();
    w.map(|v| v / total)
}

/// The separable Gaussian filter of the plane `value(index)` at the pixels at least
/// [`SSIM_RADIUS`] from every edge, row-major, `(w − 10) × (h − 10)` values.
fn filter_interior(
    w: usize,
    h: usize,
    weights: &[f64; 2 * SSIM_RADIUS + 1],
    value: &dyn Fn(usize) -> f64,
) -> Vec<f64> {
    let r = SSIM_RADIUS;
    let (iw, ih) = (w - 2 * r, h - 2 * r);
    // Along columns first (scipy filters axis 0, the rows' direction, first), every column.
    let mut vertical = vec![0.0f64; ih * w];
    for oy in 0..ih {
        for x in 0..w {
            let mut s = 0.0;
            for (k, wk) in weights.iter().enumerate() {
                s += wk * value((oy + k) * w + x);
            }
            vertical[oy * w + x] = s;
        }
    }
    // Then along rows, interior columns only.
    let mut out = vec![0.0f64; ih * iw];
    for oy in 0..ih {
        let row = &vertical[oy * w..(oy + 1) * w];
        for ox in 0..iw {
            let mut s = 0.0;
            for (k, wk) in weights.iter().enumerate() {
                s += wk * row[ox + k];
            }
            out[oy * iw + ox] = s;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Tonemap;

    #[test]
    fn window_is_normalised_and_symmetric() {
        let w = gaussian_window();
        assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-15);
        for k in 0..5 {
            assert_eq!(w[k], w[10 - k]);
        }
        // exp(−0.5·25/2.25) relative to the centre.
        assert!((w[0] / w[5] - (-25.0f64 / 4.5).exp()).abs() < 1e-15);
    }

    #[test]
    fn identical_is_one() {
        let x: Vec<f64> = (0..16 * 12)
            .map(|i| ((i * 37) % 23) as f64 / 22.0)
            .collect();
        assert_eq!(ssim_gray(&x, &x, 16, 12).unwrap(), 1.0);
    }

    #[test]
    fn constant_images_follow_the_luminance_term() {
        // Constant a against constant b: σ = 0, so SSIM = (2ab + C1) / (a² + b² + C1).
        let (a, b) = (0.25, 0.5);
        let x = vec![a; 14 * 11];
        let y = vec![b; 14 * 11];
        let expected = (2.0 * a * b + 1e-4) / (a * a + b * b + 1e-4);
        let got = ssim_gray(&x, &y, 14, 11).unwrap();
        assert!((got - expected).abs() < 1e-12, "{got} vs {expected}");
    }

    #[test]
    fn too_small_and_malformed() {
        let x = vec![0.5; 10 * 20];
        let err = ssim_gray(&x, &x, 10, 20).unwrap_err();
        assert!(err.to_string().contains("10x20"), "{err}");
        assert!(matches!(
            ssim_gray(&x, &x[1..], 10, 20),
            Err(MetricError::Malformed {
                which: "reference",
                ..
            })
        ));
    }

    #[test]
    fn on_images_uses_display_luma() {
        let img = Image::from_fn(12, 12, |x, y| [x as f32 / 12.0, y as f32 / 12.0, 0.3]);
        let reference = Image::from_fn(12, 12, |x, _| [x as f32 / 12.0, 0.2, 0.3]);
        let d = Display {
            exposure_ev: 0.5,
            tonemap: Tonemap::Reinhard,
        };
        let direct = ssim_gray(&d.luma(&img), &d.luma(&reference), 12, 12).unwrap();
        assert_eq!(ssim(&img, &reference, d).unwrap(), direct);
        assert!(direct < 1.0);
        assert_eq!(ssim(&img, &img, d).unwrap(), 1.0);
    }
}
