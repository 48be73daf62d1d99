//! The in-memory film: a linear-radiance RGB image in `f32`, row-major, row 0 at the top.

/// A linear-radiance RGB image, row 0 at the top.
///
/// `pixels` is row-major and holds `width * height` entries; the functions of [`crate::film`]
/// and [`crate::metrics`] check that length and report a malformed image instead of panicking.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Linear RGB radiance, row-major, `pixels[y * width + x]`.
    pub pixels: Vec<[f32; 3]>,
}

impl Image {
    /// A black image of `width × height` pixels.
    pub fn new(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            pixels: vec![[0.0; 3]; pixel_count(width, height)],
        }
    }

    /// An image whose pixel `(x, y)` is `f(x, y)`.
    pub fn from_fn(width: u32, height: u32, mut f: impl FnMut(u32, u32) -> [f32; 3]) -> Self {
        let mut pixels = Vec::with_capacity(pixel_count(width, height));
        for y in 0..height {
            for x in 0..width {
                pixels.push(f(x, y));
            }
        }
        Self {
            width,
            height,
            pixels,
        }
    }

    /// The pixel at column `x`, row `y` (row 0 at the top).
    ///
    /// # Panics
    /// If `(x, y)` lies outside the image.
    pub fn get(&self, x: u32, y: u32) -> [f32; 3] {
        self.pixels[self.index(x, y)]
    }

    /// Sets the pixel at column `x`, row `y` (row 0 at the top).
    ///
    /// # Panics
    /// If `(x, y)` lies outside the image.
    pub fn set(&mut self, x: u32, y: u32, rgb: [f32; 3]) {
        let i = self.index(x, y);
        self.pixels[i] = rgb;
    }

    /// Per-channel mean over all pixels, summed in `f64`.
    ///
    /// Non-finite pixels are not skipped: a NaN or Inf anywhere shows in the result, which is
    /// what analytic tests (white furnace: the mean must be 1) want. An empty image gives 0.
    pub fn mean(&self) -> [f64; 3] {
        if self.pixels.is_empty() {
            return [0.0; 3];
        }
        let mut sum = [0.0f64; 3];
        for p in &self.pixels {
            for c in 0..3 {
                sum[c] += f64::from(p[c]);
            }
        }
        let n = self.pixels.len() as f64;
        sum.map(|s| s / n)
    }

    /// Whether `pixels` holds exactly `width * height` entries.
    pub fn is_well_formed(&self) -> bool {
        self.pixels.len() == pixel_count(self.width, self.height)
    }

    fn index(&self, x: u32, y: u32) -> usize {
        assert!(
            x < self.width && y < self.height,
            "pixel ({x}, {y}) outside a {}x{} image",
            self.width,
            self.height
        );
        y as usize * self.width as usize + x as usize
    }
}

/// `width * height` without overflowing `u32`.
pub(crate) fn pixel_count(width: u32, height: u32) -> usize {
    width as usize * height as usize
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn new_get_set_mean() {
        let mut img = Image::new(3, 2);
        assert_eq!(img.pixels.len(), 6);
        assert!(img.is_well_formed());
        img.set(2, 1, [6.0, 0.0, -6.0]);
        assert_eq!(img.get(2, 1), [6.0, 0.0, -6.0]);
        assert_eq!(img.pixels[5], [6.0, 0.0, -6.0]);
        assert_eq!(img.mean(), [1.0, 0.0, -1.0]);
        assert_eq!(Image::new(0, 0).mean(), [0.0; 3]);
    }

    #[test]
    fn from_fn_is_row_major_top_down() {
        let img = Image::from_fn(2, 2, |x, y| [x as f32, y as f32, 0.0]);
        assert_eq!(img.pixels[1], [1.0, 0.0, 0.0]);
        assert_eq!(img.pixels[2], [0.0, 1.0, 0.0]);
    }

    #[test]
    fn mean_shows_nan() {
        let mut img = Image::new(2, 1);
        img.set(0, 0, [f32::NAN, 1.0, 1.0]);
        assert!(img.mean()[0].is_nan());
        assert_eq!(img.mean()[1], 0.5);
    }
}
