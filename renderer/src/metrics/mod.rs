//! Image metrics for measured correctness and the speed/accuracy trade: MSE, RMSE, relative MSE
//! on linear radiance; PSNR, SSIM (Wang et al. 2004) and FLIP on display images ([`Display`]:
//! exposure, tone curve, sRGB8, as the PNG output); the fraction of non-finite pixels; all at once
//! in [`Metrics`] with their definitions in [`METRIC_NOTES`]; box downsampling (compare noisy
//! renders at a lower resolution); and the relMSE estimated without a reference from two halves
//! of the samples ([`rel_mse_estimate`]).
//!
//! Non-finite pixels: [`mse`] and [`rel_mse`] skip every pixel where either image has a NaN or
//! ±Inf channel (the whole pixel, all three channels) and average over the rest; report
//! [`nan_fraction`] beside them so skipped pixels are never silent. [`flip`] sees them as black,
//! as the PNG encoder does.

mod all;
mod display;
mod downsample;
mod error;
mod estimate;
mod flip;
mod pixelwise;
mod psnr;
mod ssim;

pub use all::{MetricNotes, Metrics, METRIC_NOTES, NAN_NOTE};
pub use display::{tonemap_from_name, tonemap_name, Display, DisplaySettings, LUMA_WEIGHTS};
pub use downsample::downsample_box;
pub use error::MetricError;
pub use estimate::{rel_mse_estimate, rel_mse_estimate_of_halves, REL_MSE_ESTIMATE_FORMULA};
pub use flip::{flip, flip_map, FlipMap, FLIP_NOTE};
pub use pixelwise::{mse, nan_fraction, rel_mse, rmse, MSE_FORMULA, REL_MSE_FORMULA, RMSE_FORMULA};
pub use psnr::{psnr, PSNR_NOTE};
pub use ssim::{
    ssim, ssim_gray, SSIM_K1, SSIM_K2, SSIM_MIN_SIDE, SSIM_NOTE, SSIM_RADIUS, SSIM_SIGMA,
};

use crate::film::Image;

/// Checks that both images are well formed and of the same size.
fn check_pair(img: &Image, reference: &Image) -> Result<(), MetricError> {
    for (which, image) in [("test", img), ("reference", reference)] {
        if !image.is_well_formed() {
            return Err(MetricError::Malformed {
                which,
                width: image.width,
                height: image.height,
                len: image.pixels.len(),
            });
        }
    }
    if (img.width, img.height) != (reference.width, reference.height) {
        return Err(MetricError::SizeMismatch {
            width: img.width,
            height: img.height,
            reference_width: reference.width,
            reference_height: reference.height,
        });
    }
    Ok(())
}

/// Whether all three channels are finite.
fn finite(p: &[f32; 3]) -> bool {
    p.iter().all(|c| c.is_finite())
}
