//! Every metric of an image against a reference in one call: [`Metrics`], with the definitions
//! ([`METRIC_NOTES`]) that reports print beside the figures.

use serde::{Deserialize, Serialize};

use super::{
    check_pair, flip_map, mse, nan_fraction, psnr, rel_mse, ssim, Display, DisplaySettings,
    FlipMap, MetricError, FLIP_NOTE, MSE_FORMULA, PSNR_NOTE, REL_MSE_FORMULA, RMSE_FORMULA,
    SSIM_NOTE,
};
use crate::film::Image;

/// What [`Metrics::nan_fraction`] counts.
pub const NAN_NOTE: &str = "fraction of pixels with a NaN or +-Inf channel; MSE, RMSE and \
    relMSE skip pixels non-finite in either image, PSNR, SSIM and FLIP see them as black";

/// All metrics of a test image against a reference. Linear-radiance metrics (MSE, RMSE, relMSE)
/// use the EXR values; display metrics (PSNR, SSIM, FLIP) use both images after `display`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Metrics {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Mean squared error, linear radiance ([`MSE_FORMULA`]).
    pub mse: f64,
    /// `sqrt(mse)`.
    pub rmse: f64,
    /// Relative MSE ([`REL_MSE_FORMULA`]).
    pub rel_mse: f64,
    /// PSNR in dB of the display images; `None` (JSON null) when they are identical ([`PSNR_NOTE`]).
    pub psnr_db: Option<f64>,
    /// Mean SSIM of the display luma; `None` (JSON null) below 11×11 ([`SSIM_NOTE`]).
    pub ssim: Option<f64>,
    /// Mean LDR-FLIP error of the display images ([`FLIP_NOTE`]).
    pub flip: f64,
    /// Fraction of the test image's pixels with a NaN or ±Inf channel ([`NAN_NOTE`]).
    pub nan_fraction: f64,
    /// The same for the reference.
    pub reference_nan_fraction: f64,
    /// The display transform PSNR, SSIM and FLIP were computed on.
    pub display: DisplaySettings,
}

impl Metrics {
    /// Every metric of `img` against `reference`, PSNR, SSIM and FLIP on their `display` images.
    /// Errors when the sizes differ, an image is malformed or empty, or no pixel is finite in
    /// both; SSIM alone is left out (`None`) for images under 11×11.
    pub fn compute(img: &Image, reference: &Image, display: Display) -> Result<Self, MetricError> {
        Ok(Self::compute_with_map(img, reference, display)?.0)
    }

    /// [`Metrics::compute`], also returning the FLIP error map (for a heatmap).
    pub fn compute_with_map(
        img: &Image,
        reference: &Image,
        display: Display,
    ) -> Result<(Self, FlipMap), MetricError> {
        check_pair(img, reference)?;
        let mse = mse(img, reference)?;
        let map = flip_map(img, reference, display.exposure_ev, display.tonemap)?;
        let ssim = match ssim(img, reference, display) {
            Ok(v) => Some(v),
            Err(MetricError::TooSmall { .. }) => None,
            Err(e) => return Err(e),
        };
        let metrics = Metrics {
            width: img.width,
            height: img.height,
            mse,
            rmse: mse.sqrt(),
            rel_mse: rel_mse(img, reference)?,
            psnr_db: psnr(img, reference, display)?,
            ssim,
            flip: map.mean(),
            nan_fraction: nan_fraction(img),
            reference_nan_fraction: nan_fraction(reference),
            display: display.into(),
        };
        Ok((metrics, map))
    }
}

/// The definition of every field of [`Metrics`], for reports (`candela compare --json`,
/// `results.json`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct MetricNotes {
    /// [`MSE_FORMULA`].
    pub mse: &'static str,
    /// [`RMSE_FORMULA`].
    pub rmse: &'static str,
    /// [`REL_MSE_FORMULA`].
    pub rel_mse: &'static str,
    /// [`PSNR_NOTE`].
    pub psnr_db: &'static str,
    /// [`SSIM_NOTE`].
    pub ssim: &'static str,
    /// [`FLIP_NOTE`].
    pub flip: &'static str,
    /// [`NAN_NOTE`].
    pub nan_fraction: &'static str,
}

/// The definitions of all metrics.
pub const METRIC_NOTES: MetricNotes = MetricNotes {
    mse: MSE_FORMULA,
    rmse: RMSE_FORMULA,
    rel_mse: REL_MSE_FORMULA,
    psnr_db: PSNR_NOTE,
    ssim: SSIM_NOTE,
    flip: FLIP_NOTE,
    nan_fraction: NAN_NOTE,
};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Tonemap;

    fn pattern(w: u32, h: u32) -> Image {
        Image::from_fn(w, h, |x, y| {
            [
                x as f32 / w as f32,
                ((x * 3 + y * 5) % 7) as f32 / 7.0,
                y as f32 / h as f32 * 0.5,
            ]
        })
    }

    #[test]
    fn identical_images() {
        let img = pattern(16, 12);
        let m = Metrics::compute(&img, &img, Display::default()).unwrap();
        assert_eq!((m.mse, m.rmse, m.rel_mse, m.flip), (0.0, 0.0, 0.0, 0.0));
        assert_eq!((m.psnr_db, m.ssim), (None, Some(1.0)));
        assert_eq!((m.nan_fraction, m.reference_nan_fraction), (0.0, 0.0));
        assert_eq!((m.width, m.height), (16, 12));
        assert_eq!(m.display.tonemap, "clamp");
    }

    #[test]
    fn small_images_have_no_ssim_and_json_round_trips() {
        let reference = pattern(8, 8);
        let mut img = reference.clone();
        img.set(1, 1, [f32::NAN, 0.0, 0.0]);
        let d = Display {
            exposure_ev: 1.0,
            tonemap: Tonemap::Aces,
        };
        let m = Metrics::compute(&img, &reference, d).unwrap();
        assert_eq!(m.ssim, None);
        assert_eq!(m.nan_fraction, 1.0 / 64.0);
        assert!(m.flip > 0.0 && m.psnr_db.is_some());
        let json = serde_json::to_string(&m).unwrap();
        assert!(json.contains("\"ssim\":null"), "{json}");
        let back: Metrics = serde_json::from_str(&json).unwrap();
        assert_eq!(back, m);
        let notes = serde_json::to_value(METRIC_NOTES).unwrap();
        assert_eq!(notes["rel_mse"], REL_MSE_FORMULA);
    }

    #[test]
    fn errors_propagate() {
        let d = Display::default();
        assert!(matches!(
            Metrics::compute(&pattern(4, 4), &pattern(4, 5), d),
            Err(MetricError::SizeMismatch { .. })
        ));
        let nan = Image::from_fn(12, 12, |_, _| [f32::NAN; 3]);
        assert!(matches!(
            Metrics::compute(&nan, &pattern(12, 12), d),
            Err(MetricError::NoFinitePixels { .. })
        ));
    }
}
