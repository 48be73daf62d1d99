//! Handing completed passes back: [`RenderSession::complete_oldest`] waits for the oldest queued
//! pass (its counters, timings and GPU error estimate), and passes the session waited for on its
//! own (to read the accumulation between passes) are kept and handed back first, in order, so no
//! caller loses a pass's stats or a check pass's estimate.

use std::time::{Duration, Instant};

use super::{charge, RenderSession};
use crate::render::estimate_gpu::ESTIMATE_LABELS;
use crate::render::inflight::CompletedPass;
use crate::render::{PassStats, RenderError};

impl RenderSession {
    /// The oldest pass not yet handed back: one the session already waited for, else the
    /// oldest queued one, waited for and added to the counters; None when none is left.
    pub fn complete_oldest(&mut self) -> Result<Option<CompletedPass>, RenderError> {
        if let Some(p) = self.completed.pop_front() {
            return Ok(Some(p));
        }
        self.wait_oldest()
    }

    /// Waits for every queued pass, keeping them for [`Self::complete_oldest`].
    pub(super) fn settle(&mut self) -> Result<(), RenderError> {
        while let Some(p) = self.wait_oldest()? {
            self.completed.push_back(p);
        }
        Ok(())
    }

    /// Waits for the oldest queued pass and adds it to the counters; None when none is queued.
    pub(super) fn wait_oldest(&mut self) -> Result<Option<CompletedPass>, RenderError> {
        let Some(mut p) = self.ring.in_flight.pop_front() else {
            return Ok(None);
        };
        let waited = p.slot.frame.wait();
        let now = Instant::now();
        let timings = match waited {
            Ok(t) => t,
            Err(e) => {
                self.ring.spare.push(p.slot);
                return Err(e.into());
            }
        };
        // The integrator sees its own dispatches only (the error estimate's are the checks'
        // cost, counted in `estimates`).
        let own: Vec<_> = timings
            .iter()
            .filter(|t| !ESTIMATE_LABELS.contains(&t.label.as_str()))
            .cloned()
            .collect();
        self.integrator.observe_timings(&own);
        let estimate = p
            .estimate
            .as_ref()
            .map(|t| self.estimates.complete(t, &timings))
            .transpose();
        let estimate = match estimate {
            Ok(e) => e,
            Err(e) => {
                self.ring.spare.push(p.slot);
                return Err(e);
            }
        };
        let s = p.slot.read_counters();
        self.ring.spare.push(p.slot);
        let s = s?;
        self.ctx.check_validation()?;
        let gpu = Duration::from_secs_f64(timings.iter().map(|t| t.gpu_ms).sum::<f64>() * 1e-3);
        let wall = charge(&self.ctx, p.submitted, now);
        self.rays += ((s.rays_hi as u64) << 32) | s.rays_lo as u64;
        self.dropped += s.dropped_samples as u64;
        self.spp += p.spp;
        self.passes += 1;
        self.elapsed += wall;
        self.gpu_time += gpu;
        let stats = PassStats {
            spp: p.spp,
            wall,
            gpu,
        };
        self.first_pass.get_or_insert(stats);
        Ok(Some(CompletedPass {
            stats,
            snapshot: p.snapshot,
            estimate,
        }))
    }

    /// Waits for every queued pass; returns them and those not yet handed back, oldest first.
    pub fn drain(&mut self) -> Result<Vec<CompletedPass>, RenderError> {
        let mut done: Vec<CompletedPass> = self.completed.drain(..).collect();
        while let Some(p) = self.wait_oldest()? {
            done.push(p);
        }
        Ok(done)
    }
}
