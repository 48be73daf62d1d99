//! How a pass is cut into dispatches, sized to the GPU rather than to the image:
//! - **lanes**: on a small film one thread per pixel leaves most of a large GPU idle, so up to
//!   [`MAX_LANES`] threads share a pixel's samples (lane k takes samples k, k + L, ...), and
//!   after each round lane 0 adds the round's results in sample order (common/dispatch.glsl),
//!   so the sum is the one a single thread would make, bit for bit;
//! - **bands**: a huge film is split into bands of rows, one dispatch each, so a dispatch (and
//!   per-dispatch scratch memory, such as bdpt's light vertices) stays bounded;
//! - on llvmpipe, samples are split into dispatches of their own (`pass_chunks`, see
//!   [`super::LLVMPIPE_MAX_DISPATCHES`]).
//!
//! `GpuPush::dispatch` carries the shape to the kernel: bits 0–3 log2 of the lanes, bits 8–31
//! the first row of the band. Workgroups are `tiles` tiles of 64 threads, each over 8 × (8 /
//! lanes) pixels, side by side in x (so a workgroup never reaches into the next band; the
//! kernels' `WG_TILES`, common/dispatch.glsl): the integrator's
//! [`crate::integrators::IntegratorInfo::workgroup_tiles`].

use crate::layout::GpuPush;

pub use crate::layout::MAX_LANES;
/// Threads a dispatch should have to fill a large GPU (an H100 holds ~270k resident threads;
/// path tracers run at a fraction of full occupancy, so a few times more than that helps).
pub const TARGET_THREADS: u64 = 1 << 20;
/// Most pixels in one band.
pub const MAX_BAND_PIXELS: u64 = 1 << 22;
/// Pixel columns of a tile of 64 threads (and the granularity of bands, in rows).
const TILE: u32 = 8;
/// Smallest film whose kernels take their integrator's workgroups of several tiles
/// ([`crate::integrators::IntegratorInfo::workgroup_tiles`]); smaller films keep one tile. Large
/// workgroups are few: 256×256 pixels make 102 of bdpt's 640 threads for an H100's 132 SMs, and
/// there bdpt lost up to 26% with them while gaining at 1280×720 (bench/RESULTS.md, "Register
/// caps through the workgroup size"). 2^19 pixels make ~820 such workgroups, ~6 per SM. Measured
/// at five sizes between (bench/RESULTS.md, "bdpt's tiles: the film-size threshold measured"),
/// the four scenes' ratios are all ≥ 0.95 from 614,400 pixels on; at 480,000 one scene (the
/// furnace) is at 0.946, so the threshold lies between them.
pub const TILED_MIN_PIXELS: u64 = 1 << 19;

/// Tiles per workgroup of a session's film kernels: the integrator's `wanted` on films of at
/// least [`TILED_MIN_PIXELS`], else 1; at most `max_tiles` (the device's workgroup limits).
pub fn workgroup_tiles(wanted: u32, pixels: u64, max_tiles: u32) -> u32 {
    match pixels >= TILED_MIN_PIXELS {
        true => wanted.min(max_tiles).max(1),
        false => 1,
    }
}

/// Lanes per pixel and rows per band of a pass.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DispatchShape {
    /// Threads per pixel: 1, 2, 4 or 8.
    pub lanes: u32,
    /// Rows per dispatch: a multiple of 8 (the last band may be shorter).
    pub band_rows: u32,
    /// Tiles of 8 × 8 threads per workgroup: what the kernels were compiled with (`WG_TILES`),
    /// set by the session whatever shape a test asks for.
    pub tiles: u32,
}

impl DispatchShape {
    /// One thread per pixel, the whole film in one dispatch.
    pub fn single(height: u32) -> Self {
        DispatchShape {
            lanes: 1,
            band_rows: height.next_multiple_of(TILE).max(TILE),
            tiles: 1,
        }
    }

    /// The shape for a pass of `spp` samples on a `width`×`height` film: lanes up to
    /// [`TARGET_THREADS`] threads (never more lanes than samples or `max_lanes`; none on a CPU
    /// device, whose few cores any film fills), bands of at most [`MAX_BAND_PIXELS`] (and
    /// `max_band_pixels`) pixels.
    pub fn auto(
        width: u32,
        height: u32,
        spp: u32,
        cpu: bool,
        max_lanes: u32,
        max_band_pixels: u64,
    ) -> Self {
        let pixels = (width as u64 * height as u64).max(1);
        let lanes = if cpu {
            1
        } else {
            let want =
                (TARGET_THREADS / pixels).clamp(1, MAX_LANES.min(max_lanes.max(1)) as u64) as u32;
            prev_power_of_two(want).min(prev_power_of_two(spp.max(1)))
        };
        let band_pixels = MAX_BAND_PIXELS.min(max_band_pixels);
        let band_rows = if pixels > band_pixels {
            ((band_pixels / width.max(1) as u64) as u32 / TILE * TILE).max(TILE)
        } else {
            height
        };
        DispatchShape {
            lanes,
            band_rows: band_rows.next_multiple_of(TILE).max(TILE),
            tiles: 1,
        }
    }

    /// A shape given by hand (tests): lanes a power of two up to [`MAX_LANES`], band rows a
    /// positive multiple of 8.
    pub fn new(lanes: u32, band_rows: u32) -> Result<Self, String> {
        if !lanes.is_power_of_two() || lanes > MAX_LANES {
            return Err(format!("lanes must be 1, 2, 4 or 8, got {lanes}"));
        }
        if band_rows == 0 || !band_rows.is_multiple_of(TILE) {
            return Err(format!(
                "band rows must be a positive multiple of 8, got {band_rows}"
            ));
        }
        Ok(DispatchShape {
            lanes,
            band_rows,
            tiles: 1,
        })
    }

    /// The bands of a film `height` rows high: (first row, rows).
    pub fn bands(&self, height: u32) -> Vec<(u32, u32)> {
        (0..height.max(1))
            .step_by(self.band_rows as usize)
            .map(|y| (y, self.band_rows.min(height - y)))
            .collect()
    }

    /// Workgroups covering `rows` rows of a film `width` pixels wide.
    pub fn groups(&self, width: u32, rows: u32) -> [u32; 3] {
        let tile_cols = width.div_ceil(TILE);
        [
            tile_cols.div_ceil(self.tiles.max(1)),
            rows.div_ceil(TILE / self.lanes),
            1,
        ]
    }

    /// The `GpuPush::dispatch` word of the band starting at `first_row`.
    pub fn encode(&self, first_row: u32) -> u32 {
        self.lanes.trailing_zeros() | (first_row << 8)
    }

    /// Every dispatch of the pass `push`: its sample chunks (at most `chunk_limit`) times the
    /// bands of the film, each with its push constants and workgroups, in sample order.
    pub fn dispatches(
        &self,
        push: &GpuPush,
        chunk_limit: u32,
        width: u32,
        height: u32,
    ) -> Vec<(GpuPush, [u32; 3])> {
        let bands = self.bands(height);
        pass_chunks(push, chunk_limit)
            .into_iter()
            .flat_map(|c| {
                bands.iter().map(move |&(y, rows)| {
                    let mut p = c;
                    p.dispatch = self.encode(y);
                    (p, self.groups(width, rows))
                })
            })
            .collect()
    }
}

fn prev_power_of_two(n: u32) -> u32 {
    1 << (31 - n.max(1).leading_zeros())
}

/// The pass `push` (samples `sample_base..sample_base + spp`) as up to `limit` consecutive
/// chunks of as even a size as possible, in sample order.
pub(super) fn pass_chunks(push: &GpuPush, limit: u32) -> Vec<GpuPush> {
    let n = push.spp.min(limit).max(1);
    let (base, extra) = (push.spp / n, push.spp % n);
    let mut first = push.sample_base;
    (0..n)
        .map(|i| {
            let mut p = *push;
            p.sample_base = first;
            p.spp = base + u32::from(i < extra);
            first += p.spp;
            p
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pass_chunks_cover_the_samples_in_order() {
        for (spp, limit) in [
            (1, 64),
            (5, 64),
            (64, 64),
            (100, 64),
            (1000, 64),
            (7, 1),
            (3, 2),
        ] {
            let push = GpuPush {
                sample_base: 11,
                spp,
                flags: 5,
                ..Default::default()
            };
            let c = pass_chunks(&push, limit);
            assert_eq!(c.len() as u32, spp.min(limit));
            let mut next = 11;
            for p in &c {
                assert_eq!(p.sample_base, next);
                assert!(p.spp >= spp / limit && p.spp <= spp.div_ceil(limit).max(1));
                assert_eq!(p.flags, 5);
                next += p.spp;
            }
            assert_eq!(next, 11 + spp);
        }
    }

    #[test]
    fn shapes_fill_the_gpu_and_bound_the_bands() {
        // A 1280x720 film fills the GPU with one thread per pixel; 256x256 takes 8 lanes (but
        // never more than the pass has samples); a CPU device always one.
        assert_eq!(
            DispatchShape::auto(1280, 720, 64, false, 8, u64::MAX).lanes,
            1
        );
        assert_eq!(
            DispatchShape::auto(256, 256, 64, false, 8, u64::MAX).lanes,
            8
        );
        assert_eq!(
            DispatchShape::auto(256, 256, 3, false, 8, u64::MAX).lanes,
            2
        );
        assert_eq!(
            DispatchShape::auto(512, 512, 64, false, 8, u64::MAX).lanes,
            4
        );
        assert_eq!(
            DispatchShape::auto(256, 256, 64, true, 8, u64::MAX).lanes,
            1
        );
        assert_eq!(
            DispatchShape::auto(256, 256, 64, false, 2, u64::MAX).lanes,
            2
        );
        // An integrator's own band limit (bdpt's light-vertex buffer): 100 rows -> 96.
        assert_eq!(
            DispatchShape::auto(1000, 500, 1, false, 1, 100_000).band_rows,
            96
        );
        let small = DispatchShape::auto(1280, 720, 1, false, 8, u64::MAX);
        assert_eq!(small.bands(720), vec![(0, 720)]);
        // 8K: bands of at most 4 Mpixels, multiples of 8 rows, covering every row once.
        let huge = DispatchShape::auto(7680, 4320, 1, false, 8, u64::MAX);
        let bands = huge.bands(4320);
        assert!(bands.len() >= 8, "{bands:?}");
        let mut next = 0;
        for (y, rows) in &bands {
            assert_eq!(*y, next);
            assert!(*rows as u64 * 7680 <= MAX_BAND_PIXELS && y % 8 == 0);
            next += rows;
        }
        assert_eq!(next, 4320);
        // Workgroups cover the band: 8 columns by 8/lanes rows each.
        let s = DispatchShape::new(4, 16).unwrap();
        assert_eq!(s.groups(30, 16), [4, 8, 1]);
        // Workgroups of 10 tiles side by side: 4 tile columns in one workgroup, 22 in three;
        // rows as before, so a band's workgroups stay within its rows.
        let t = DispatchShape { tiles: 10, ..s };
        assert_eq!(t.groups(30, 16), [1, 8, 1]);
        assert_eq!(t.groups(170, 16), [3, 8, 1]);
        // Several tiles only on large films, within the device's limits.
        assert_eq!(workgroup_tiles(10, 1280 * 720, 16), 10);
        assert_eq!(workgroup_tiles(10, 1280 * 720, 4), 4);
        assert_eq!(workgroup_tiles(10, 256 * 256, 16), 1);
        assert_eq!(workgroup_tiles(1, 1280 * 720, 16), 1);
        assert_eq!(s.encode(16), 2 | (16 << 8));
        assert!(DispatchShape::new(3, 16).is_err() && DispatchShape::new(2, 12).is_err());
        let push = GpuPush {
            spp: 3,
            ..Default::default()
        };
        let d = s.dispatches(&push, 64, 30, 40);
        // 3 sample chunks (llvmpipe) x 3 bands (16, 16, 8 rows).
        assert_eq!(d.len(), 9);
        assert_eq!(d[2].0.dispatch >> 8, 32);
        assert_eq!(d[2].1, [4, 4, 1]);
    }
}
