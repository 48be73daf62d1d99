//! The error of a progressive render without a reference: an estimate of the relMSE of the
//! current image against the converged one, from two independent halves of its samples.
//!
//! Every kernel sums each pixel's samples (Σr, Σg, Σb, samples kept) and, separately, those of
//! odd sample index (shaders/common/film.glsl). The counter-based RNG makes samples independent,
//! so the even half's mean A (n_a samples) and the odd half's mean B (n_b samples) are two
//! independent estimates of the pixel's value μ, and for the full mean F (N = n_a + n_b samples,
//! per-sample variance σ²):
//!
//! ```text
//! E[(A − B)²] = σ² (1/n_a + 1/n_b) = σ² N / (n_a n_b),   Var(F) = σ² / N
//!   ⇒  Var(F) ≈ (A − B)² · n_a n_b / N²                  (= (A − B)² / 4 for equal halves)
//! ```
//!
//! The estimate is this variance over the pixel's value squared with the same ε as
//! [`rel_mse`](super::rel_mse), averaged over pixels and channels like it:
//! `mean((A − B)² n_a n_b / N² / (min(F², F̄²) + 0.01))`, F the resolved image (bdpt: with its
//! light-tracing splats) and F̄ its 3×3 box mean. The true relMSE divides by the converged
//! value μ², which is unknown: F² is correlated with the numerator and saturates a firefly's
//! term near 1 (on the Cornell box with pt at 16 spp the F² form read 0.08× the true relMSE),
//! while F̄² alone blurs bright edges into dark neighbours (0.2–0.4× at 256 spp). The smaller of
//! the two keeps both in check: measured on the Cornell box at 32×32 (16–256 spp, pt, nee and
//! bdpt, against 4096 spp) it read 0.72–1.0× the true relMSE. It measures the variance only: a
//! biased integrator's bias (whitted, deferred, vct) is invisible to it. bdpt's light-tracing
//! splats are split by parity too (binding SPLAT_ODD), so each half carries its own
//! (renderer/src/render/halves.rs forms the halves' images). It is meant for ≥ 8 spp.

use rayon::prelude::*;

use crate::film::Image;

/// Pixels per parallel chunk of the estimate's sum (a fixed size, so the sum's order, and so its
/// value, does not depend on the number of threads).
const CHUNK: usize = 1 << 14;

/// How [`rel_mse_estimate`] is computed, for reports.
pub const REL_MSE_ESTIMATE_FORMULA: &str = "mean over pixels and RGB channels of \
    (A-B)^2 n_a n_b / N^2 / (min(F^2, Fb^2)+0.01): A, B the means of the even- and odd-indexed \
    samples (n_a, n_b of them), F the image (N samples), Fb its 3x3 box mean; estimates relMSE \
    against the converged image (variance only: bias is not seen)";

/// Added to F² in the denominator, as in [`rel_mse`](super::rel_mse).
const EPSILON: f64 = 0.01;

/// The relMSE estimate (see the [module docs](self)) from a session's accumulation `total`
/// (per pixel Σr, Σg, Σb, samples kept), its odd half `odd` (the same for odd-indexed samples)
/// and the resolved `image`, for integrators whose image is the accumulation's mean. Pixels
/// where a half has no sample, or a value is not finite, are skipped; None when no pixel is
/// left or the sizes disagree.
pub fn rel_mse_estimate(total: &[[f32; 4]], odd: &[[f32; 4]], image: &Image) -> Option<f64> {
    if total.len() != odd.len() {
        return None;
    }
    let mean = |s: [f64; 3], n: f64| s.map(|x| if n > 0.0 { x / n } else { 0.0 });
    let (even_means, odd_means): (Vec<_>, Vec<_>) = total
        .par_iter()
        .zip(odd)
        .map(|(t, o)| {
            let (n, n_b) = (f64::from(t[3]), f64::from(o[3]));
            let d = |c: usize| f64::from(t[c]) - f64::from(o[c]);
            let b = |c: usize| f64::from(o[c]);
            (
                mean([d(0), d(1), d(2)], n - n_b),
                mean([b(0), b(1), b(2)], n_b),
            )
        })
        .unzip();
    rel_mse_estimate_of_halves(total, odd, &even_means, &odd_means, image)
}

/// The relMSE estimate from the two halves' resolved values: `even` and `odd` per pixel (A and
/// B of the module docs, as the integrator forms them: bdpt adds each half's own splats), with
/// the sample counts n_a, n_b taken from `total` and `odd_accum` (samples kept), and `image` the
/// full resolved image. Pixels where a half has no sample, or a value is not finite, are
/// skipped; None when no pixel is left or the sizes disagree.
pub fn rel_mse_estimate_of_halves(
    total: &[[f32; 4]],
    odd_accum: &[[f32; 4]],
    even: &[[f64; 3]],
    odd: &[[f64; 3]],
    image: &Image,
) -> Option<f64> {
    let n = total.len();
    if odd_accum.len() != n
        || even.len() != n
        || odd.len() != n
        || !image.is_well_formed()
        || image.pixels.len() != n
    {
        return None;
    }
    let blurred = box3(image);
    // Each chunk's sum and count in parallel, then the chunks' in order.
    let pixel_term = |i: usize| -> Option<f64> {
        // Step 1: the sample counts of the halves.
        let n = f64::from(total[i][3]);
        let n_b = f64::from(odd_accum[i][3]);
        let n_a = n - n_b;
        if !(n_a >= 1.0 && n_b >= 1.0) {
            return None;
        }
        let weight = n_a * n_b / (n * n);
        // Step 2: per channel, the squared difference of the half means, scaled to the
        // variance of the full mean, over the smaller of the pixel's and its neighbourhood's
        // value squared.
        let mut pixel = [0.0f64; 3];
        for c in 0..3 {
            let (a, b) = (even[i][c], odd[i][c]);
            let v = f64::from(image.pixels[i][c]);
            let mu2 = (v * v).min(blurred[i][c] * blurred[i][c]);
            pixel[c] = (a - b) * (a - b) * weight / (mu2 + EPSILON);
        }
        pixel
            .iter()
            .all(|x| x.is_finite())
            .then(|| pixel.iter().sum::<f64>())
    };
    let chunks: Vec<(f64, usize)> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|k| {
            (k * CHUNK..((k + 1) * CHUNK).min(n))
                .filter_map(pixel_term)
                .fold((0.0, 0), |(s, c), x| (s + x, c + 3))
        })
        .collect();
    let (sum, count) = chunks
        .iter()
        .fold((0.0f64, 0usize), |(s, c), &(x, k)| (s + x, c + k));
    (count > 0).then(|| sum / count as f64)
}

/// The 3×3 box mean of each pixel (over the neighbours inside the image), in f64; non-finite
/// values count as 0.
fn box3(image: &Image) -> Vec<[f64; 3]> {
    let (w, h) = (image.width as i64, image.height as i64);
    let value = |x: i64, y: i64, c: usize| {
        let v = f64::from(image.pixels[(y * w + x) as usize][c]);
        if v.is_finite() {
            v
        } else {
            0.0
        }
    };
    (0..image.pixels.len())
        .into_par_iter()
        .map(|i| {
            let (x, y) = (i as i64 % w, i as i64 / w);
            let mut sum = [0.0f64; 3];
            let mut k = 0.0;
            for yy in (y - 1).max(0)..=(y + 1).min(h - 1) {
                for xx in (x - 1).max(0)..=(x + 1).min(w - 1) {
                    for (c, s) in sum.iter_mut().enumerate() {
                        *s += value(xx, yy, c);
                    }
                    k += 1.0;
                }
            }
            sum.map(|s| s / k)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(pixels: Vec<[f32; 3]>) -> Image {
        Image {
            width: pixels.len() as u32,
            height: 1,
            pixels,
        }
    }

    #[test]
    fn equal_halves_give_zero_and_unequal_ones_the_variance() {
        // One pixel, 4 samples: even ones 1 and 1 (A = 1), odd ones 3 and 3 (B = 3); F = 2.
        // Var(F) ≈ (A − B)² / 4 = 1; relMSE ≈ 1 / (4 + 0.01).
        let total = [[8.0, 8.0, 8.0, 4.0]];
        let odd = [[6.0, 6.0, 6.0, 2.0]];
        let e = rel_mse_estimate(&total, &odd, &image(vec![[2.0; 3]])).unwrap();
        assert!((e - 1.0 / 4.01).abs() < 1e-12, "{e}");
        let same = [[4.0, 4.0, 4.0, 2.0]];
        let e = rel_mse_estimate(&total, &same, &image(vec![[2.0; 3]])).unwrap();
        assert_eq!(e, 0.0);
    }

    #[test]
    fn unequal_halves_are_weighted_and_empty_halves_skipped() {
        // 3 samples: even 0 and 0 (A = 0, n_a = 2), odd 3 (B = 3, n_b = 1); F = 1.
        // Var(F) ≈ 9 · 2 / 9 = 2 per channel, over 1.01. The second pixel has no odd sample.
        let total = [[3.0, 3.0, 3.0, 3.0], [1.0, 1.0, 1.0, 1.0]];
        let odd = [[3.0, 3.0, 3.0, 1.0], [0.0; 4]];
        let e = rel_mse_estimate(&total, &odd, &image(vec![[1.0; 3], [1.0; 3]])).unwrap();
        assert!((e - 2.0 / 1.01).abs() < 1e-12, "{e}");
        assert_eq!(
            rel_mse_estimate(&total[1..], &odd[1..], &image(vec![[1.0; 3]])),
            None
        );
        assert_eq!(
            rel_mse_estimate(&total, &odd[1..], &image(vec![[1.0; 3]])),
            None
        );
    }

    #[test]
    fn a_firefly_is_measured_against_its_neighbourhood() {
        // 3×3 pixels of value 1 (4 samples each, halves equal) but the centre, whose one odd
        // sample is 33 instead of 1: F = 9, A = 1, B = 17. Against F² the centre's term would be
        // 64/81.01; against its neighbourhood's mean (17/9) it is 64/((17/9)² + 0.01).
        let mut total = vec![[4.0, 4.0, 4.0, 4.0]; 9];
        let mut odd = vec![[2.0, 2.0, 2.0, 2.0]; 9];
        total[4] = [36.0, 36.0, 36.0, 4.0];
        odd[4] = [34.0, 34.0, 34.0, 2.0];
        let mut img = Image {
            width: 3,
            height: 3,
            pixels: vec![[1.0; 3]; 9],
        };
        img.pixels[4] = [9.0; 3];
        let e = rel_mse_estimate(&total, &odd, &img).unwrap();
        let fb = 17.0f64 / 9.0;
        let expected = 64.0 / (fb * fb + EPSILON) / 9.0;
        assert!((e - expected).abs() < 1e-9 * expected, "{e} vs {expected}");
    }

    #[test]
    fn matches_the_true_rel_mse_of_simulated_noise_in_expectation() {
        // Pixels of value μ with uniform noise; the estimate over many pixels must approach the
        // true relMSE of the mean of N samples, σ²/N / (μ² + ε) (F² in the denominator makes it
        // a little biased for few samples: loose bounds).
        let mut state = 0x853c_49e6_748f_ea9bu64;
        let mut uniform = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 40) as f64) / (1u64 << 24) as f64
        };
        let (mu, n, pixels) = (1.0f64, 32usize, 4000usize);
        let sigma2 = 1.0 / 12.0 * 4.0; // uniform on [μ − 1, μ + 1]
        let mut total = Vec::new();
        let mut odd = Vec::new();
        let mut img = Vec::new();
        let mut true_sum = 0.0;
        for _ in 0..pixels {
            let (mut t, mut o) = (0.0f64, 0.0f64);
            for i in 0..n {
                let x = mu + 2.0 * uniform() - 1.0;
                t += x;
                if i % 2 == 1 {
                    o += x;
                }
            }
            let f = t / n as f64;
            true_sum += (f - mu) * (f - mu) / (mu * mu + EPSILON);
            total.push([t as f32, t as f32, t as f32, n as f32]);
            odd.push([o as f32, o as f32, o as f32, (n / 2) as f32]);
            img.push([f as f32; 3]);
        }
        let e = rel_mse_estimate(&total, &odd, &image(img)).unwrap();
        let expected = sigma2 / n as f64 / (mu * mu + EPSILON);
        let actual = true_sum / pixels as f64;
        assert!((e / expected - 1.0).abs() < 0.1, "{e} vs {expected}");
        assert!((e / actual - 1.0).abs() < 0.15, "{e} vs {actual}");
    }
}
