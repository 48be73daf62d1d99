//! Image metrics for measured correctness: MSE, relative MSE, FLIP, the fraction of non-finite
//! pixels, and box downsampling (compare noisy renders at a lower resolution).
//!
//! Non-finite pixels: [`mse`] and [`rel_mse`] skip every pixel where either image has a NaN or
//! ±Inf channel (the whole pixel, all three channels) and average over the rest; report
//! [`nan_fraction`] beside them so skipped pixels are never silent. [`flip`] sees them as black,
//! as the PNG encoder does.

mod downsample;
mod error;
mod flip;
mod pixelwise;

pub use downsample::downsample_box;
pub use error::MetricError;
pub use flip::{flip, FLIP_NOTE};
pub use pixelwise::{mse, nan_fraction, rel_mse, REL_MSE_FORMULA};

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
