//! [`MetricError`]: why two images could not be compared.

/// Two images could not be compared. Messages are one line.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum MetricError {
    /// The images differ in size.
    #[error("image is {width}x{height} but the reference is {reference_width}x{reference_height}")]
    SizeMismatch {
        /// Test image width.
        width: u32,
        /// Test image height.
        height: u32,
        /// Reference image width.
        reference_width: u32,
        /// Reference image height.
        reference_height: u32,
    },
    /// `pixels.len()` is not `width * height`.
    #[error("malformed {which} image: {len} pixels for {width}x{height}")]
    Malformed {
        /// "test" or "reference".
        which: &'static str,
        /// Declared width.
        width: u32,
        /// Declared height.
        height: u32,
        /// Actual number of pixels.
        len: usize,
    },
    /// Nothing to average: the images are empty or every pixel is non-finite in one of them.
    #[error("no pixel of the {width}x{height} images is finite in both")]
    NoFinitePixels {
        /// Image width.
        width: u32,
        /// Image height.
        height: u32,
    },
    /// The images are smaller than a metric's window.
    #[error("{metric} needs images of at least {min_side}x{min_side}, these are {width}x{height}")]
    TooSmall {
        /// The metric ("SSIM").
        metric: &'static str,
        /// Image width.
        width: u32,
        /// Image height.
        height: u32,
        /// The smallest side the metric accepts.
        min_side: u32,
    },
    /// An error map could not be encoded as PNG.
    #[error("cannot encode the error map: {message}")]
    Encode {
        /// What the encoder said, one line.
        message: String,
    },
}
