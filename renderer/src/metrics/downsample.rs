//! Box downsampling: average `factor × factor` blocks, so noisy renders can be compared with a
//! reference at a lower resolution where their variance is `factor²` times smaller.

use crate::film::Image;

/// Averages `factor × factor` blocks into one pixel. The result is
/// `ceil(width / factor) × ceil(height / factor)`; blocks cut by the right or bottom edge average
/// the pixels they have. Non-finite values propagate into their block (so [`super::nan_fraction`]
/// of the result still sees them). `factor` 0 or 1 returns a copy.
///
/// # Panics
/// If `img.pixels.len()` is not `width * height`.
pub fn downsample_box(img: &Image, factor: u32) -> Image {
    assert!(
        img.is_well_formed(),
        "malformed image: {} pixels for {}x{}",
        img.pixels.len(),
        img.width,
        img.height
    );
    if factor <= 1 {
        return img.clone();
    }
    let out_w = img.width.div_ceil(factor);
    let out_h = img.height.div_ceil(factor);
    Image::from_fn(out_w, out_h, |bx, by| {
        let (x0, y0) = (bx * factor, by * factor);
        let (x1, y1) = ((x0 + factor).min(img.width), (y0 + factor).min(img.height));
        let mut sum = [0.0f64; 3];
        for y in y0..y1 {
            for x in x0..x1 {
                let p = img.get(x, y);
                for c in 0..3 {
                    sum[c] += f64::from(p[c]);
                }
            }
        }
        let n = f64::from((x1 - x0) * (y1 - y0));
        sum.map(|s| (s / n) as f32)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn averages_blocks_and_edges() {
        let img = Image::from_fn(5, 3, |x, y| [(x + 10 * y) as f32, 1.0, 0.0]);
        let small = downsample_box(&img, 2);
        assert_eq!((small.width, small.height), (3, 2));
        // Block (0,0): 0, 1, 10, 11.
        assert_eq!(small.get(0, 0), [5.5, 1.0, 0.0]);
        // Right edge block (2,0): x = 4, y = 0..2 → 4, 14.
        assert_eq!(small.get(2, 0), [9.0, 1.0, 0.0]);
        // Corner block (2,1): the single pixel (4, 2) = 24.
        assert_eq!(small.get(2, 1), [24.0, 1.0, 0.0]);
        assert_eq!(downsample_box(&img, 1), img);
        assert_eq!(downsample_box(&img, 0), img);
        assert_eq!(downsample_box(&img, 8).pixels.len(), 1);
    }

    #[test]
    fn preserves_mean_when_divisible() {
        let img = Image::from_fn(8, 4, |x, y| [(x * y) as f32, x as f32, y as f32]);
        assert_eq!(downsample_box(&img, 4).mean(), img.mean());
    }

    #[test]
    fn nan_propagates() {
        let mut img = Image::new(4, 4);
        img.set(3, 3, [f32::NAN, 0.0, 0.0]);
        let small = downsample_box(&img, 2);
        assert!(small.get(1, 1)[0].is_nan());
        assert_eq!(super::super::nan_fraction(&small), 0.25);
    }
}
