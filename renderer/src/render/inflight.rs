//! Passes in flight: a session queues up to [`PIPELINE_DEPTH`] passes on the GPU without waiting,
//! so the next pass is already queued when one ends and the GPU does not wait for the host
//! between passes. Each pass's command buffer also copies the pass's counters (and, when asked,
//! the raw accumulation for a snapshot) into host-visible memory and clears the counters, so a
//! pass costs no extra round trip: the host reads what it needs once the pass's fence signals.
//!
//! Wall time: a pass is charged from when it was submitted, or from when the host saw the
//! previous pass on the device complete if that was later (it waited in the queue behind it),
//! to when the host saw it complete. Summed over passes this is the time the session had work
//! on the GPU, whichever session's pass ran before it.

use std::collections::VecDeque;
use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::error::RenderError;
use crate::film::Image;
use crate::gpu::{Buffer, BufferUsage, Frame, GpuContext};
use crate::integrators::{ExtraBuffer, Resolver};
use crate::layout::GpuStats;

/// Most passes a session keeps queued on the GPU.
pub const PIPELINE_DEPTH: usize = 2;

/// Timing of one pass.
#[derive(Debug, Clone, Copy)]
pub struct PassStats {
    pub spp: u32,
    /// Wall time charged to the pass (see the module documentation).
    pub wall: Duration,
    /// GPU time of its dispatches (timestamps).
    pub gpu: Duration,
}

/// A pass that has completed, with the snapshot and the error estimate it was asked for.
pub struct CompletedPass {
    pub stats: PassStats,
    pub snapshot: Option<AccumSnapshot>,
    pub estimate: Option<PassEstimate>,
}

/// The error estimate a pass computed on the GPU after its samples (estimate_gpu.rs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PassEstimate {
    /// Samples per pixel of the accumulation it measured.
    pub spp: u32,
    /// The estimated relMSE (None before both halves have samples).
    pub rel_mse: Option<f64>,
}

/// The raw accumulation as it was after a pass (host-visible copy made by the pass itself),
/// and how to resolve it into an image. It may be resolved on any thread.
pub struct AccumSnapshot {
    buffer: Buffer,
    width: u32,
    height: u32,
    /// Entries (`[f32; 4]`) of the accumulation and of each extra buffer, in order.
    parts: Vec<usize>,
    /// Whether the odd half (one entry per pixel) was copied after the parts; not when no
    /// sample of the snapshot has an odd index (the half is empty; [`Self::entries`] gives
    /// zeros for it).
    has_odd: bool,
    /// The integrator's extra buffers (their layout, for the estimate's halves).
    extra: Vec<ExtraBuffer>,
    spp: u32,
    resolver: Resolver,
}

impl AccumSnapshot {
    /// Samples per pixel in the snapshot.
    pub fn spp(&self) -> u32 {
        self.spp
    }

    /// Every entry: the accumulation followed by the integrator's extra buffers and the odd half
    /// (the layout of `RenderSession::accumulation`; an odd half that was not copied, being
    /// empty, as zeros).
    pub fn entries(&self) -> Result<Vec<[f32; 4]>, RenderError> {
        let parts: usize = self.parts.iter().sum();
        let copied = parts + if self.has_odd { self.pixels() } else { 0 };
        let bytes = self
            .buffer
            .mapped()
            .ok_or_else(|| RenderError::Invalid("snapshot buffer not mapped".into()))?;
        let mut all: Vec<[f32; 4]> = bytemuck::pod_collect_to_vec(&bytes[..copied * 16]);
        all.resize(parts + self.pixels(), [0.0; 4]);
        Ok(all)
    }

    /// The image and the estimate of its relMSE against the converged image
    /// ([`crate::metrics::rel_mse_estimate`]; None before both halves have samples).
    pub fn image_and_estimate(&self) -> Result<(Image, Option<f64>), RenderError> {
        let all = self.entries()?;
        let n: usize = self.parts.iter().sum();
        let image = self.resolve(&all[..n]);
        let estimate = super::halves::estimate(
            &all,
            self.pixels(),
            &self.extra,
            &self.resolver,
            self.spp,
            &image,
        );
        Ok((image, estimate))
    }

    /// The image, as the integrator resolves it (read in place where the mapping is aligned).
    pub fn image(&self) -> Result<Image, RenderError> {
        let n: usize = self.parts.iter().sum();
        let copy;
        let all: &[[f32; 4]] = match self
            .buffer
            .mapped()
            .and_then(|b| bytemuck::try_cast_slice(&b[..n * 16]).ok())
        {
            Some(words) => words,
            None => {
                copy = self.entries()?;
                &copy
            }
        };
        Ok(self.resolve(&all[..n]))
    }

    /// The image of the snapshot's parts (`all`: the accumulation and the extra buffers).
    fn resolve(&self, all: &[[f32; 4]]) -> Image {
        let mut parts = Vec::with_capacity(self.parts.len());
        let mut at = 0;
        for &len in &self.parts {
            parts.push(&all[at..at + len]);
            at += len;
        }
        let pixels = (self.resolver)(parts[0], &parts[1..], self.spp);
        Image {
            width: self.width,
            height: self.height,
            pixels,
        }
    }
}

/// A reusable frame and the host-visible copy of its pass's counters.
pub(super) struct PassFrame {
    pub frame: Frame,
    pub counters: Buffer,
}

impl PassFrame {
    pub fn new(ctx: &Arc<GpuContext>) -> Result<Self, RenderError> {
        Ok(PassFrame {
            frame: Frame::new(ctx)?,
            counters: Buffer::new(
                ctx,
                "pass counters",
                std::mem::size_of::<GpuStats>() as u64,
                BufferUsage::Readback,
            )?,
        })
    }

    /// The counters the pass copied (after its fence).
    pub fn read_counters(&self) -> Result<GpuStats, RenderError> {
        let bytes = self
            .counters
            .mapped()
            .ok_or_else(|| RenderError::Invalid("counter buffer not mapped".into()))?;
        Ok(bytemuck::pod_read_unaligned(
            &bytes[..std::mem::size_of::<GpuStats>()],
        ))
    }
}

/// A submitted pass.
pub(super) struct InFlight {
    pub slot: PassFrame,
    pub spp: u32,
    pub submitted: Instant,
    pub snapshot: Option<AccumSnapshot>,
    /// With an estimate: the spp it measures and the buffer it is copied to.
    pub estimate: Option<(u32, Buffer)>,
}

/// The session's frames: those in flight, oldest first, and spare ones.
#[derive(Default)]
pub(super) struct PassRing {
    pub in_flight: VecDeque<InFlight>,
    pub spare: Vec<PassFrame>,
}

impl PassRing {
    /// A frame to record into (a spare one, else a new one).
    pub fn take(&mut self, ctx: &Arc<GpuContext>) -> Result<PassFrame, RenderError> {
        match self.spare.pop() {
            Some(f) => Ok(f),
            None => PassFrame::new(ctx),
        }
    }

    /// Samples per pixel queued and not yet completed.
    pub fn spp(&self) -> u32 {
        self.in_flight.iter().map(|p| p.spp).sum()
    }
}

/// A host-visible buffer for a snapshot of an accumulation of `width`·`height` pixels with the
/// integrator's `extra` buffers and, when `has_odd` (a sample of the snapshot has an odd index),
/// the odd half. (Else that half is empty: a first snapshot of one sample of even index copies
/// half the bytes; at 1280×720 the copy to host memory is most of a 1-spp pass's wall time
/// beyond its dispatches.)
pub(super) fn snapshot_target(
    ctx: &Arc<GpuContext>,
    width: u32,
    height: u32,
    extra: Vec<ExtraBuffer>,
    spp: u32,
    has_odd: bool,
    resolver: Resolver,
) -> Result<AccumSnapshot, RenderError> {
    let pixels = (width * height) as usize;
    let odd = if has_odd { pixels } else { 0 };
    let mut parts = vec![pixels];
    parts.extend(extra.iter().map(|e| pixels * e.entries_per_pixel as usize));
    let n: usize = parts.iter().sum::<usize>() + odd;
    Ok(AccumSnapshot {
        buffer: Buffer::new(
            ctx,
            "snapshot readback",
            n as u64 * 16,
            BufferUsage::Readback,
        )?,
        width,
        height,
        parts,
        has_odd,
        extra,
        spp,
        resolver,
    })
}

impl AccumSnapshot {
    pub(super) fn buffer(&self) -> &Buffer {
        &self.buffer
    }

    /// Whether the pass copied the odd half too (false: it was empty).
    pub fn has_odd(&self) -> bool {
        self.has_odd
    }

    fn pixels(&self) -> usize {
        (self.width * self.height) as usize
    }
}

/// The wall time to charge a pass the host just saw complete, and the new "last completion".
pub(super) fn charge(ctx: &GpuContext, submitted: Instant, now: Instant) -> Duration {
    let mut last = ctx
        .last_completion
        .lock()
        .unwrap_or_else(|e| e.into_inner());
    let from = match *last {
        Some(t) if t > submitted => t,
        _ => submitted,
    };
    *last = Some(now);
    now.saturating_duration_since(from)
}
