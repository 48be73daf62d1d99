//! SSIM against scikit-image: `ssim_gray` must reproduce
//! `skimage.metrics.structural_similarity(x, y, gaussian_weights=True, sigma=1.5,
//! use_sample_covariance=False, data_range=1)` on small deterministic images.
//!
//! The expected values were computed once, offline, with scikit-image 0.26.0 (scipy 1.17.1,
//! numpy 2.4.6, Python 3.11) by building the same images in float64 with the same formulas:
//!
//! ```python
//! def u(i, j, w, mul=2654435761, add=12345):
//!     return ((i * w + j) * mul + add) % 2**32 / 2**32
//! def stripes(i, j):
//!     return ((i * 7 + j * 13) % 17) / 16
//! x = np.array([[fx(i, j) for j in range(w)] for i in range(h)])    # i = row, j = column
//! y = np.array([[fy(i, j, x[i, j]) for j in range(w)] for i in range(h)])
//! structural_similarity(x, y, gaussian_weights=True, sigma=1.5,
//!                       use_sample_covariance=False, data_range=1)
//! ```
//! with `fx`, `fy` as in each case below. No Python is needed to run these tests.

use renderer::metrics::ssim_gray;

/// `((i·w + j)·mul + add) mod 2³²` scaled to [0, 1), as in the Python above.
fn u(i: u64, j: u64, w: u64, mul: u64, add: u64) -> f64 {
    (((i * w + j) * mul + add) % (1u64 << 32)) as f64 / 4294967296.0
}

fn hash(i: u64, j: u64, w: u64) -> f64 {
    u(i, j, w, 2654435761, 12345)
}

fn stripes(i: u64, j: u64) -> f64 {
    ((i * 7 + j * 13) % 17) as f64 / 16.0
}

/// Builds `x` and `y` (h rows, w columns) and returns ssim_gray(x, y).
fn ssim_of(h: u64, w: u64, fx: impl Fn(u64, u64) -> f64, fy: impl Fn(u64, u64, f64) -> f64) -> f64 {
    let mut x = Vec::new();
    let mut y = Vec::new();
    for i in 0..h {
        for j in 0..w {
            let v = fx(i, j);
            x.push(v);
            y.push(fy(i, j, v));
        }
    }
    ssim_gray(&x, &y, w as u32, h as u32).unwrap()
}

fn assert_matches(name: &str, got: f64, skimage: f64) {
    let diff = (got - skimage).abs();
    eprintln!("{name}: candela {got:.16}, scikit-image {skimage:.16}, |diff| {diff:.1e}");
    assert!(
        (got - skimage).abs() < 1e-12,
        "{name}: candela {got:.17} vs scikit-image {skimage:.17}"
    );
}

#[test]
fn stripes_with_clipped_noise_20x24() {
    // fx = stripes; fy = min(max(x + 0.2 * (u(i, j, 24) - 0.5), 0), 1)
    let got = ssim_of(20, 24, stripes, |i, j, x| {
        (x + 0.2 * (hash(i, j, 24) - 0.5)).clamp(0.0, 1.0)
    });
    assert_matches("stripes_noise_20x24", got, 0.983437460313427);
}

#[test]
fn mixed_noise_at_the_minimum_size_11x13() {
    // fx = u(i, j, 13); fy = (x + u(i, j, 13, 40503, 777)) / 2
    let got = ssim_of(
        11,
        13,
        |i, j| hash(i, j, 13),
        |i, j, x| (x + u(i, j, 13, 40503, 777)) / 2.0,
    );
    assert_matches("noise_mix_11x13", got, 0.6419732879740955);
}

#[test]
fn smooth_contrast_change_32x32() {
    // fx = 0.5 + 0.4 sin(0.3 i) cos(0.2 j); fy = 0.5 x + 0.25
    let got = ssim_of(
        32,
        32,
        |i, j| 0.5 + 0.4 * (0.3 * i as f64).sin() * (0.2 * j as f64).cos(),
        |_, _, x| 0.5 * x + 0.25,
    );
    assert_matches("smooth_contrast_32x32", got, 0.800834853268715);
}

#[test]
fn noise_with_clipped_offset_16x16() {
    // fx = u(i, j, 16); fy = min(x + 0.05, 1)
    let got = ssim_of(16, 16, |i, j| hash(i, j, 16), |_, _, x| (x + 0.05).min(1.0));
    assert_matches("noise_offset_clipped_16x16", got, 0.9953248108918635);
}

#[test]
fn stripes_with_constant_offset_14x19() {
    // fx = 0.5 stripes + 0.25; fy = x + 0.1
    let got = ssim_of(14, 19, |i, j| stripes(i, j) * 0.5 + 0.25, |_, _, x| x + 0.1);
    assert_matches("stripes_offset_14x19", got, 0.983570681878186);
}

#[test]
fn symmetric_and_bounded() {
    let x: Vec<f64> = (0..15 * 17).map(|k| hash(k / 17, k % 17, 17)).collect();
    let y: Vec<f64> = x.iter().map(|v| 1.0 - v).collect();
    let a = ssim_gray(&x, &y, 17, 15).unwrap();
    let b = ssim_gray(&y, &x, 17, 15).unwrap();
    assert_eq!(a, b);
    assert!((-1.0..1.0).contains(&a), "{a}");
}
