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
        .iter()
        .zip(odd)
        .map(|(t, o)| [t[0] - o[0], t[1] - o[1], t[2] - o[2], t[3] - o[3]])
        .collect();
    let resolve = |sums: &[[f32; 4]], extra: &[Vec<[f32; 4]>], spp: u32| -> Vec<[f64; 3]> {
        let parts: Vec<&[[f32; 4]]> = extra.iter().map(|v| v.as_slice()).collect();
        resolver(sums, &parts, spp)
            .into_iter()
            .map(|p| p.map(f64::from))
            .collect()
    };
    let (n_odd, n_even) = (spp / 2, spp - spp / 2);
    let even = resolve(&even_sums, &even_extra, n_even);
    let odd_values = resolve(odd, &odd_extra, n_odd);
    crate::metrics::rel_mse_estimate_of_halves(total, odd, &even, &odd_values, image)
}
