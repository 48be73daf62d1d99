//! `Metrics::compute` on images with known answers: identical images, a constant offset in
//! linear radiance (MSE, RMSE, relMSE by hand), and constant images whose display values are
//! known bytes (PSNR and SSIM by hand).

use renderer::film::Image;
use renderer::metrics::{Display, Metrics};
use renderer::scene::Tonemap;

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * b.abs().max(1.0)
}

fn pattern(w: u32, h: u32) -> Image {
    // Multiples of 1/8: exact in f32, so x − r is exactly the offset below.
    Image::from_fn(w, h, |x, y| {
        [
            (x % 8) as f32 / 8.0,
            (y % 8) as f32 / 8.0,
            ((x + y) % 5) as f32 / 8.0,
        ]
    })
}

#[test]
fn identical_images_are_perfect() {
    let img = pattern(24, 16);
    for tonemap in [Tonemap::Clamp, Tonemap::Reinhard, Tonemap::Aces] {
        let d = Display {
            exposure_ev: 0.7,
            tonemap,
        };
        let m = Metrics::compute(&img, &img, d).unwrap();
        assert_eq!(m.mse, 0.0);
        assert_eq!(m.rmse, 0.0);
        assert_eq!(m.rel_mse, 0.0);
        assert_eq!(m.psnr_db, None, "identical display images: infinite PSNR");
        assert_eq!(m.ssim, Some(1.0));
        assert_eq!(m.flip, 0.0);
        assert_eq!(m.nan_fraction, 0.0);
    }
}

#[test]
fn constant_linear_offset() {
    let reference = pattern(24, 16);
    let c = 0.25f64;
    let img = Image::from_fn(24, 16, |x, y| reference.get(x, y).map(|v| v + c as f32));
    let m = Metrics::compute(&img, &reference, Display::default()).unwrap();
    assert!(close(m.mse, c * c, 1e-15), "{}", m.mse);
    assert!(close(m.rmse, c, 1e-15), "{}", m.rmse);
    // relMSE = mean of c² / (r² + 0.01) over every channel value r.
    let mut sum = 0.0;
    for p in &reference.pixels {
        for &r in p {
            sum += c * c / (f64::from(r) * f64::from(r) + 0.01);
        }
    }
    let expected = sum / (reference.pixels.len() * 3) as f64;
    assert!(
        close(m.rel_mse, expected, 1e-12),
        "{} vs {expected}",
        m.rel_mse
    );
    let ssim = m.ssim.unwrap();
    assert!(ssim > 0.5 && ssim < 1.0, "{ssim}");
    assert!(m.flip > 0.0 && m.flip < 1.0);
}

#[test]
fn constant_display_offset() {
    // Clamp at 0 EV: 0.18 → sRGB8 118, 0.5 → 188 in every channel, so the display images differ
    // by 70/255 everywhere and their luma is 118/255 and 188/255 (the weights sum to 1).
    let reference = Image::from_fn(16, 16, |_, _| [0.5; 3]);
    let img = Image::from_fn(16, 16, |_, _| [0.18; 3]);
    let m = Metrics::compute(&img, &reference, Display::default()).unwrap();
    let psnr = 20.0 * (255.0f64 / 70.0).log10();
    assert!(close(m.psnr_db.unwrap(), psnr, 1e-12), "{:?}", m.psnr_db);
    // Constant images: zero variance, so SSIM = (2ab + C1) / (a² + b² + C1), C1 = 1e-4.
    let (a, b) = (118.0 / 255.0, 188.0 / 255.0);
    let ssim = (2.0 * a * b + 1e-4) / (a * a + b * b + 1e-4);
    assert!(
        close(m.ssim.unwrap(), ssim, 1e-12),
        "{:?} vs {ssim}",
        m.ssim
    );
    let d = f64::from(0.5f32) - f64::from(0.18f32);
    assert!(close(m.mse, d * d, 1e-13));
    let r = f64::from(0.5f32);
    assert!(close(m.rel_mse, d * d / (r * r + 0.01), 1e-13));
}

#[test]
fn non_finite_pixels_are_counted() {
    let reference = pattern(12, 12);
    let mut img = reference.clone();
    img.set(0, 0, [f32::NAN, 0.0, 0.0]);
    img.set(5, 5, [0.0, f32::INFINITY, 0.0]);
    img.set(6, 5, [0.0, 0.0, f32::NEG_INFINITY]);
    let m = Metrics::compute(&img, &reference, Display::default()).unwrap();
    assert_eq!(m.nan_fraction, 3.0 / 144.0);
    assert_eq!(m.reference_nan_fraction, 0.0);
    // The non-finite pixels are skipped by MSE, so the rest matches exactly.
    assert_eq!(m.mse, 0.0);
    // But the display metrics see them as black.
    assert!(m.flip > 0.0);
}
