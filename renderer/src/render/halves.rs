//! The error estimate of an accumulation (metrics/estimate.rs) in one place for every holder of
//! one: a session, a pass's snapshot, the merged shards of a multi-device render.
//!
//! An accumulation ([`super::RenderSession::accumulation`]'s layout) holds the radiance sums of
//! all samples, the integrator's extra buffers, and the odd-indexed samples' share of the sums.
//! An extra buffer may have its own odd share (bdpt's light-tracing splats: binding SPLAT_ODD,
//! [`ExtraBuffer::odd_share_of`]). The halves are formed as accumulations of their own and
//! resolved by the integrator like the image, so each half's value includes its share of every
//! split extra buffer:
//!
//! - odd half: the odd sums; each split extra buffer's odd share; spp/2 samples per pixel;
//! - even half: the total minus the odd half (extra buffers in their number format, e.g. 64-bit
//!   fixed point); spp − spp/2 samples per pixel.
//!
//! Sample indices run from 0 (a session, or the shards of one render together), so spp/2 of
//! them are odd. Extra buffers without an odd share are left out of both halves: their
//! variance is not seen, but they do not bias the difference of the halves either.

use rayon::prelude::*;

use crate::film::Image;
use crate::integrators::{ExtraBuffer, Resolver};

/// The estimated relMSE of `image`, the resolved `all` (an accumulation of `pixels` pixels with
/// the `extra` buffers, `spp` samples per pixel), against the converged image; None before
/// both halves have samples or when the layout does not match.
pub fn estimate(
    all: &[[f32; 4]],
    pixels: usize,
    extra: &[ExtraBuffer],
    resolver: &Resolver,
    spp: u32,
    image: &Image,
) -> Option<f64> {
    let extra_len: usize = extra
        .iter()
        .map(|e| pixels * e.entries_per_pixel as usize)
        .sum();
    if all.len() != 2 * pixels + extra_len {
        return None;
    }
    let total = &all[..pixels];
    let odd = &all[pixels + extra_len..];
    // Step 1: where each extra buffer lies.
    let mut ranges = Vec::with_capacity(extra.len());
    let mut at = pixels;
    for e in extra {
        let len = pixels * e.entries_per_pixel as usize;
        ranges.push(at..at + len);
        at += len;
    }
    // Step 2: each half's extra buffers: a split buffer's odd share and the rest; zeros for
    // the others (and for the shares themselves, which resolvers do not read).
    let mut even_extra: Vec<Vec<[f32; 4]>> =
        ranges.iter().map(|r| vec![[0.0; 4]; r.len()]).collect();
    let mut odd_extra = even_extra.clone();
    for (k, e) in extra.iter().enumerate() {
        let Some(j) = e.odd_share_of else { continue };
        let (Some(full), Some(share)) = (ranges.get(j), ranges.get(k)) else {
            return None;
        };
        if full.len() != share.len() {
            return None;
        }
        odd_extra[j] = all[share.clone()].to_vec();
        even_extra[j] = all[full.clone()].to_vec();
        extra[j]
            .sum
            .combine(&mut even_extra[j], &all[share.clone()], -1);
    }
    // Step 3: each half's sums, resolved as the integrator resolves the image.
    let even_sums: Vec<[f32; 4]> = total
        .par_iter()
        .zip(odd)
        .map(|(t, o)| [t[0] - o[0], t[1] - o[1], t[2] - o[2], t[3] - o[3]])
        .collect();
    let resolve = |sums: &[[f32; 4]], extra: &[Vec<[f32; 4]>], spp: u32| -> Vec<[f64; 3]> {
        let parts: Vec<&[[f32; 4]]> = extra.iter().map(|v| v.as_slice()).collect();
        resolver(sums, &parts, spp)
            .into_par_iter()
            .map(|p| p.map(f64::from))
            .collect()
    };
    let (n_odd, n_even) = (spp / 2, spp - spp / 2);
    let even = resolve(&even_sums, &even_extra, n_even);
    let odd_values = resolve(odd, &odd_extra, n_odd);
    crate::metrics::rel_mse_estimate_of_halves(total, odd, &even, &odd_values, image)
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::*;
    use crate::integrators::ExtraSum;

    /// Two 64-bit fixed-point words of `v` in every channel, as an accumulation stores them.
    fn fixed(v: u64) -> [[f32; 4]; 2] {
        [
            [f32::from_bits(v as u32); 4],
            [f32::from_bits((v >> 32) as u32); 4],
        ]
    }

    #[test]
    fn each_half_carries_its_share_of_a_split_fixed_point_buffer() {
        // One pixel, 4 samples: camera sums even 1 + 1, odd 3 + 3; splats (units of 2^-32)
        // even 2^32 − 16, odd 2^32 + 32, so the total's low word wrapped: taking the odd share
        // off needs a borrow from the high word.
        let resolver: Resolver = Arc::new(|accum, extra, spp| {
            let split = |i: usize, c: usize| {
                let (lo, hi) = (
                    extra[0][2 * i][c].to_bits(),
                    extra[0][2 * i + 1][c].to_bits(),
                );
                (((hi as u64) << 32) | lo as u64) as f64 / (4294967296.0 * spp as f64)
            };
            let mean = |a: &[f32; 4], c: usize| (a[c] / a[3]) as f64;
            let px =
                |(i, a): (usize, &[f32; 4])| [0, 1, 2].map(|c| (mean(a, c) + split(i, c)) as f32);
            accum.iter().enumerate().map(px).collect()
        });
        let (even, odd) = ((1u64 << 32) - 16, (1u64 << 32) + 32);
        let [lo, hi] = fixed(even + odd);
        let [olo, ohi] = fixed(odd);
        let all = [[8.0, 8.0, 8.0, 4.0], lo, hi, olo, ohi, [6.0, 6.0, 6.0, 2.0]];
        let buffer = |odd_share_of| ExtraBuffer {
            binding: 0,
            name: "splats",
            entries_per_pixel: 2,
            sum: ExtraSum::Fixed64,
            odd_share_of,
        };
        let extra = [buffer(None), buffer(Some(0))];
        let image = Image {
            width: 1,
            height: 1,
            pixels: resolver(&all[..1], &[&all[1..3]], 4),
        };
        // A = 1 + (2^32 − 16)/2^33, B = 3 + (2^32 + 32)/2^33, F = 2 + (2^33 + 16)/2^34 ≈ 2.5;
        // n_a n_b / N² = 1/4.
        let e = estimate(&all, 1, &extra, &resolver, 4, &image).unwrap();
        let (a, b) = (
            1.0 + even as f64 / 2f64.powi(33),
            3.0 + odd as f64 / 2f64.powi(33),
        );
        let f = f64::from(image.pixels[0][0]);
        let expected = (a - b) * (a - b) / 4.0 / (f * f + 0.01);
        assert!((e - expected).abs() < 1e-6 * expected, "{e} vs {expected}");
        // Unsplit (no odd share), the splats are left out of both halves: A − B = −2.
        let e = estimate(
            &all[..3]
                .iter()
                .chain(&all[5..])
                .copied()
                .collect::<Vec<_>>(),
            1,
            &extra[..1],
            &resolver,
            4,
            &image,
        )
        .unwrap();
        let expected = 4.0 / 4.0 / (f * f + 0.01);
        assert!((e - expected).abs() < 1e-6 * expected, "{e} vs {expected}");
    }
}
