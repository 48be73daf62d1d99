//! How many samples one dispatch of each `deferred` stage handles (the batch size B), and what
//! that costs in memory. One place for the decision.
//!
//! A pass of spp samples records ceil(spp / B) batches of at most B samples (as even as
//! possible), each three dispatches (G-buffer, cull, shade) over all its samples: the G-buffer,
//! the tile counts and the tile lists hold B slices, one per sample of a batch. A sample's work
//! at small films is a few microseconds of GPU time per dispatch, shorter than the drain and
//! refill between barrier-separated dispatches (on an H100 at 256×256 one sample per dispatch
//! kept the GPU busy 53% of the time, at 1280×720 63%), so a batch should hold enough
//! pixel-samples to dwarf that gap:
//!
//!   B = clamp(ceil(TARGET_PIXEL_SAMPLES / (width · height)), 1, MAX_BATCH), then lowered until
//!   B slices fit in MAX_BATCH_BYTES (never below 1), and below the shade stage's counter bound
//!   ([`counter_cap`]: from about 262,000 lights).
//!
//! Why these figures. The H100 measurements of the one-sample-per-dispatch version
//! (bench/results/h100-i13-call3) give per sample, summed over the three stages, about 30 µs of
//! GPU time and 27 µs of gaps at 256×256, 115 µs and 69 µs at 1280×720. If the gaps stay per
//! dispatch, a busy fraction ≥ 0.9 needs B ≥ 9 at 256×256 and B ≥ 6 at 1280×720; the target of
//! 8 M pixel-samples per dispatch gives B = 64 (the cap) and 9, and B = 1 from 3840×2160 up
//! (a single sample of such a film fills the GPU on its own). MAX_BATCH keeps a batch's shade
//! dispatch (whose threads loop over the batch's samples) around a millisecond at small films;
//! MAX_BATCH_BYTES bounds the slices: 133 MB of G-buffer at 1280×720 (9 slices), 67 MB at
//! 256×256 (64), 133 MB at 3840×2160 (1), plus the tile lists (4 bytes × tiles × capacity per
//! slice, small unless thousands of lights fill large lists). `samples_per_batch` overrides B.
//!
//! On llvmpipe (lavapipe) the automatic B is at most LLVMPIPE_MAX_BATCH: llvmpipe ends every loop
//! of an invocation once 65,535 loop iterations have run in it, counted over all its loops
//! (render/session.rs, LLVMPIPE_MAX_DISPATCHES), and a shade thread runs the light and
//! shadow-ray loops of every sample of its batch.

/// Pixel-samples one dispatch aims at.
pub const TARGET_PIXEL_SAMPLES: u64 = 8_000_000;
/// Most samples per batch.
pub const MAX_BATCH: u32 = 64;
/// Most samples per automatic batch on llvmpipe.
pub const LLVMPIPE_MAX_BATCH: u32 = 4;
/// Most bytes of the per-sample slices (G-buffer, tile counts, tile lists) together, unless a
/// single slice is larger.
pub const MAX_BATCH_BYTES: u64 = 256 << 20;

/// Bytes of one sample's slice: its G-buffer, tile counts and tile lists.
pub fn slice_bytes(pixels: u64, tiles: u64, tile_capacity: u32) -> u64 {
    pixels * super::gbuffer::BYTES_PER_PIXEL as u64 + tiles * 4 + tiles * tile_capacity as u64 * 4
}

/// The batch size to allocate for a film of `pixels` in `tiles` tiles: `requested` (the
/// `samples_per_batch` option, already validated to 1 ..= MAX_BATCH) or the rule above
/// (`llvmpipe`: the device is llvmpipe).
pub fn batch_size(
    pixels: u64,
    tiles: u64,
    tile_capacity: u32,
    requested: Option<u32>,
    llvmpipe: bool,
) -> u32 {
    if let Some(b) = requested {
        return b.clamp(1, MAX_BATCH);
    }
    let fill = TARGET_PIXEL_SAMPLES.div_ceil(pixels.max(1));
    let fit = MAX_BATCH_BYTES / slice_bytes(pixels, tiles, tile_capacity).max(1);
    let most = if llvmpipe {
        LLVMPIPE_MAX_BATCH
    } else {
        MAX_BATCH
    };
    fill.min(fit).clamp(1, most as u64) as u32
}

/// Most samples per batch with `lights` lights: the shade stage's per-workgroup counters are
/// 32-bit (256 threads, each counting the lights it tests and the rays it traces over its
/// batch's samples: at most `lights` + 2 per sample, the camera ray, a shadow ray per light and
/// the ambient one), so B·256·(lights + 2) must stay below 2³². It binds from about 262,000
/// lights (B < 64); `samples_per_batch` is held to it too.
pub fn counter_cap(lights: u32) -> u32 {
    (u32::MAX as u64 / (256 * (lights as u64 + 2))).clamp(1, MAX_BATCH as u64) as u32
}

/// The batches of a pass of `spp` samples with batch size `b`: ceil(spp / b) batches of as even
/// a size as possible (so no short one trails a pass), as (first sample within the pass,
/// samples), in order.
pub fn batches(spp: u32, b: u32) -> impl Iterator<Item = (u32, u32)> {
    let n = spp.div_ceil(b.max(1)).max(1);
    let (base, extra) = (spp / n, spp % n);
    (0..n)
        .map(move |k| (k * base + k.min(extra), base + u32::from(k < extra)))
        .filter(|&(_, m)| m > 0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn size(w: u64, h: u64, cap: u32) -> (u32, u64) {
        let tiles = w.div_ceil(16) * h.div_ceil(16);
        let b = batch_size(w * h, tiles, cap, None, false);
        (b, b as u64 * slice_bytes(w * h, tiles, cap))
    }

    #[test]
    fn batches_fill_the_gpu_within_the_byte_cap() {
        assert_eq!(size(256, 256, 2), (64, 64 * (1 << 20) + 64 * 256 * 12));
        assert_eq!(size(1280, 720, 2).0, 9);
        assert_eq!(size(1920, 1080, 2).0, 4);
        assert_eq!(size(3840, 2160, 2).0, 1);
        // Full lists of 2048 lights triple a 1280×720 slice: the byte cap lowers B.
        let (b, bytes) = size(1280, 720, 2048);
        assert_eq!(b, 6);
        assert!(bytes <= MAX_BATCH_BYTES);
        // A slice above the cap still renders, one sample at a time.
        assert_eq!(size(7680, 4320, 1024).0, 1);
        // The option overrides the rule.
        assert_eq!(batch_size(1 << 20, 4096, 8, Some(3), false), 3);
        assert_eq!(batch_size(1 << 16, 256, 8, None, true), LLVMPIPE_MAX_BATCH);
        assert_eq!(batch_size(1 << 16, 256, 8, Some(9), true), 9);
        // The counters' bound: (2^32 - 1) / (256 (lights + 2)) samples, at least one.
        assert_eq!(counter_cap(10), MAX_BATCH);
        assert_eq!(counter_cap(1 << 20), 15);
        assert_eq!(counter_cap((1 << 18) - 2), 63, "exactly 2^32 would wrap");
        assert_eq!(counter_cap(u32::MAX), 1);
    }

    #[test]
    fn batches_cover_the_pass_in_order() {
        let v: Vec<_> = batches(7, 3).collect();
        assert_eq!(v, [(0, 3), (3, 2), (5, 2)]);
        assert_eq!(batches(4, 64).collect::<Vec<_>>(), [(0, 4)]);
        assert_eq!(batches(68, 64).collect::<Vec<_>>(), [(0, 34), (34, 34)]);
        assert_eq!(batches(0, 5).count(), 0);
        for (spp, b) in [(1, 1), (9, 2), (130, 64), (1024, 9)] {
            let v: Vec<_> = batches(spp, b).collect();
            assert_eq!(v.len() as u32, spp.div_ceil(b));
            assert!(v.iter().all(|&(_, m)| m >= 1 && m <= b));
            let mut next = 0;
            for (first, m) in v {
                assert_eq!(first, next);
                next += m;
            }
            assert_eq!(next, spp);
        }
    }
}
