//! One render split across several devices by sample index. Every sample of every integrator is
//! keyed by its index (the counter-based RNG, `rng_init(pixel, sample_index, seed)`), and the
//! integrators' setup stages (vct's voxels, deferred's light culling) depend on the scene only,
//! so sessions of the same scene, integrator and seed that render disjoint sets of sample
//! indices have sums that add up to the sums of one session that rendered them all.
//!
//! The devices take sample indices from one shared counter ([`SampleDispenser`]): each claims
//! the next block the size of its next pass, so a faster device takes more blocks and every
//! index from 0 to the total is rendered exactly once, whether the budget is a sample count
//! (split over the devices as they go) or a time (each device renders for that long). The
//! shards' accumulations are then summed ([`merge_accumulation`]: the radiance sums and sample
//! counts as floats, bdpt's fixed-point splats as 64-bit integers) and resolved once with the
//! total spp. The image equals the single-device render of the same seed and spp up to the
//! order of float additions.

use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::time::{Duration, Instant};

use super::inflight::PIPELINE_DEPTH;
use super::{Budget, PassSizer, RenderError, RenderSession, RenderStats};
use crate::film::Image;
use crate::integrators::ExtraBuffer;

/// Hands out consecutive blocks of sample indices, up to a limit (an spp budget) or without
/// one (a time budget), until stopped (a device failed).
#[derive(Debug)]
pub struct SampleDispenser {
    next: AtomicU32,
    limit: u32,
    /// Claimants: near the limit, a block is at most an even share of what is left, so that
    /// one device does not take a large last pass while the others idle.
    shares: u32,
    stopped: AtomicBool,
}

impl SampleDispenser {
    /// Indices `0..limit` (`u32::MAX`: as many as are asked for).
    pub fn new(limit: u32) -> Self {
        SampleDispenser {
            next: AtomicU32::new(0),
            limit,
            shares: 1,
            stopped: AtomicBool::new(false),
        }
    }

    /// Limits each block to an even share of the indices left among `n` claimants.
    pub fn shared_by(mut self, n: u32) -> Self {
        self.shares = n.max(1);
        self
    }

    /// The next block of at most `want` indices: (first, count); None when all are given out
    /// or the dispenser was stopped.
    pub fn claim(&self, want: u32) -> Option<(u32, u32)> {
        if self.stopped.load(Ordering::Acquire) {
            return None;
        }
        let mut first = self.next.load(Ordering::Acquire);
        loop {
            let left = self.limit.saturating_sub(first);
            let n = want.max(1).min(left.div_ceil(self.shares)).min(left);
            if n == 0 {
                return None;
            }
            match self.next.compare_exchange_weak(
                first,
                first + n,
                Ordering::AcqRel,
                Ordering::Acquire,
            ) {
                Ok(_) => return Some((first, n)),
                Err(now) => first = now,
            }
        }
    }

    /// Indices given out so far.
    pub fn given(&self) -> u32 {
        self.next.load(Ordering::Acquire)
    }

    /// Gives out nothing more.
    pub fn stop(&self) {
        self.stopped.store(true, Ordering::Release);
    }
}

/// What a split render did: the image, the total spp, and each device's own statistics (its
/// spp, passes, time and Msamples/s).
#[derive(Debug, Clone)]
pub struct SplitRender {
    pub image: Image,
    pub spp: u32,
    /// Wall time from the first pass queued to the last shard's sums downloaded.
    pub wall: Duration,
    pub shards: Vec<RenderStats>,
    /// The merged image's estimated relMSE (both halves summed over the shards).
    pub rel_mse_estimate: Option<f64>,
}

impl SplitRender {
    /// The statistics of the whole render: the first shard's description (scene, integrator,
    /// setup) with the totals: spp, passes, rays, dropped samples, GPU time summed; time the
    /// longest shard's pass time (the shards run at once); Msamples/s and rays/s the totals
    /// over that time. The integrator's `details` are each shard's own (in [`Self::shards`]),
    /// none here when there are several: they are not one render's to add up.
    pub fn total(&self) -> RenderStats {
        let mut t = self.shards[0].clone();
        t.spp = self.spp;
        t.passes = self.shards.iter().map(|s| s.passes).sum();
        t.rays = self.shards.iter().map(|s| s.rays).sum();
        t.dropped_samples = self.shards.iter().map(|s| s.dropped_samples).sum();
        t.gpu_time_s = self.shards.iter().map(|s| s.gpu_time_s).sum();
        t.time_s = self.shards.iter().map(|s| s.time_s).fold(0.0, f64::max);
        let samples = t.spp as f64 * t.width as f64 * t.height as f64;
        let per_s = |n: f64| if t.time_s > 0.0 { n / t.time_s } else { 0.0 };
        t.msamples_per_s = per_s(samples) * 1e-6;
        t.rays_per_s = per_s(t.rays as f64);
        t.setup_s = self.shards.iter().map(|s| s.setup_s).fold(0.0, f64::max);
        t.first_pass = None;
        t.rel_mse_estimate = self.rel_mse_estimate;
        if self.shards.len() > 1 {
            t.details = None;
        }
        t
    }
}

/// Adds `from` to `into`, two [`RenderSession::accumulation`]s of one layout: `pixels` entries
/// of (Σr, Σg, Σb, samples kept) added as floats, then each extra buffer as its
/// [`ExtraSum`](crate::integrators::ExtraSum) says, then the odd half (`pixels` entries, floats: the error estimate's).
pub fn merge_accumulation(
    into: &mut [[f32; 4]],
    from: &[[f32; 4]],
    pixels: usize,
    extra: &[ExtraBuffer],
) -> Result<(), RenderError> {
    let want = 2 * pixels
        + extra
            .iter()
            .map(|e| pixels * e.entries_per_pixel as usize)
            .sum::<usize>();
    if into.len() != want || from.len() != want {
        return Err(RenderError::Invalid(format!(
            "merging accumulations of {} and {} entries, the layout has {want}",
            into.len(),
            from.len()
        )));
    }
    // (Element by element, so the pieces' threads do not change the sums.)
    let add_floats = |a: &mut [[f32; 4]], b: &[[f32; 4]]| {
        a.par_chunks_mut(1 << 16)
            .zip(b.par_chunks(1 << 16))
            .for_each(|(a, b)| {
                for (x, y) in a.iter_mut().zip(b) {
                    for c in 0..4 {
                        x[c] += y[c];
                    }
                }
            });
    };
    // Step 1: the radiance sums and sample counts.
    add_floats(&mut into[..pixels], &from[..pixels]);
    // Step 2: the extra buffers, in order.
    let mut at = pixels;
    for e in extra {
        let len = pixels * e.entries_per_pixel as usize;
        let (a, b) = (&mut into[at..at + len], &from[at..at + len]);
        e.sum.combine(a, b, 1);
        at += len;
    }
    // Step 3: the odd-indexed samples' share (sample indices, not devices, decide the parity).
    add_floats(&mut into[at..], &from[at..]);
    Ok(())
}

/// Renders one image on every session at once (one thread each), taking sample indices from a
/// shared [`SampleDispenser`]: [`Budget::Spp`] is the total over the sessions, [`Budget::Time`]
/// each session's time. The sessions must be of the same prepared scene, integrator options and
/// seed, freshly made (or reset). Their sums are merged and resolved once.
pub fn render_split(
    sessions: &mut [RenderSession],
    budget: Budget,
) -> Result<SplitRender, RenderError> {
    let Some(first) = sessions.first() else {
        return Err(RenderError::Invalid(
            "a split render needs a session".into(),
        ));
    };
    // Step 1: every shard must sum in the same layout (bdpt's splats are floats on devices with
    // float atomics, fixed point elsewhere).
    let (len, extra) = (first.accumulation_len(), first.extra_buffers());
    if let Some(other) = sessions
        .iter()
        .find(|s| s.accumulation_len() != len || s.extra_buffers() != extra)
    {
        return Err(RenderError::Invalid(format!(
            "the devices keep different accumulation formats ({} and {}: {:?} vs {:?}); \
             render on devices of one kind",
            first.stats().device.name,
            other.stats().device.name,
            extra,
            other.extra_buffers()
        )));
    }
    let dispenser = SampleDispenser::new(match budget {
        Budget::Spp(n) => n,
        Budget::Time(_) => u32::MAX,
    })
    .shared_by(sessions.len() as u32);
    // Step 2: drive every shard on its own thread.
    let start = Instant::now();
    let results: Vec<Result<Vec<[f32; 4]>, RenderError>> = std::thread::scope(|scope| {
        let handles: Vec<_> = sessions
            .iter_mut()
            .map(|s| {
                let d = &dispenser;
                scope.spawn(move || {
                    let r = drive_shard(s, budget, d).and_then(|_| s.accumulation());
                    if r.is_err() {
                        d.stop();
                    }
                    r
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| {
                h.join().unwrap_or_else(|_| {
                    Err(RenderError::Invalid("a device thread panicked".into()))
                })
            })
            .collect()
    });
    let wall = start.elapsed();
    // Step 3: sum the shards' accumulations and resolve once with the total spp.
    let mut sums: Option<Vec<[f32; 4]>> = None;
    for r in results {
        let acc = r?;
        match &mut sums {
            None => sums = Some(acc),
            Some(into) => merge_accumulation(into, &acc, pixels_in(len, &extra), &extra)?,
        }
    }
    let spp: u32 = sessions.iter().map(|s| s.spp()).sum();
    if spp != dispenser.given() {
        return Err(RenderError::Invalid(format!(
            "the shards rendered {spp} spp of the {} given out",
            dispenser.given()
        )));
    }
    let sums = sums.unwrap_or_default();
    let image = sessions[0].resolve_spp(&sums, spp);
    let rel_mse_estimate = sessions[0].estimate_spp(&sums, spp, &image);
    Ok(SplitRender {
        image,
        spp,
        wall,
        shards: sessions.iter().map(|s| s.stats()).collect(),
        rel_mse_estimate,
    })
}

/// The pixels of an accumulation of `len` entries with `extra` buffers.
fn pixels_in(len: usize, extra: &[ExtraBuffer]) -> usize {
    // The accumulation, the extra buffers and the odd half.
    len / (2 + extra
        .iter()
        .map(|e| e.entries_per_pixel as usize)
        .sum::<usize>())
}

/// One shard's loop, as [`super::render`]'s, but each pass starts at the block of indices it
/// claims from `dispenser`.
fn drive_shard(
    session: &mut RenderSession,
    budget: Budget,
    dispenser: &SampleDispenser,
) -> Result<(), RenderError> {
    let target = Duration::from_millis(250);
    let mut sizer = PassSizer::default();
    loop {
        // Step 1: keep the queue full while the budget has room.
        while session.in_flight() < PIPELINE_DEPTH
            && (sizer.knows_cost() || session.in_flight() == 0)
        {
            let want = match budget {
                Budget::Spp(_) => sizer.next(target),
                Budget::Time(seconds) => {
                    let committed = session.elapsed().as_secs_f64()
                        + sizer.seconds(session.submitted_spp() - session.spp());
                    let left = seconds.max(0.0) - committed;
                    if left <= 0.0 && session.submitted_spp() > 0 {
                        break;
                    }
                    sizer.next(target.min(Duration::from_secs_f64(left.max(0.0))))
                }
            };
            let Some((first, n)) = dispenser.claim(want) else {
                break;
            };
            session.set_next_sample(first);
            for p in session.submit_pass(n, false)? {
                sizer.observe(&p.stats);
            }
        }
        // Step 2: the oldest pass; done when none is left.
        match session.complete_oldest()? {
            Some(p) => sizer.observe(&p.stats),
            None => return Ok(()),
        }
    }
}
