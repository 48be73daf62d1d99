//! The pass watchdog: a pass that runs far past its expected time shrinks its job's passes, and a
//! job whose smallest pass (one sample per pixel) still runs past the limit is stopped, so one
//! pathological scene cannot hold the GPU for long stretches while other jobs wait.
//!
//! A pass cannot be interrupted once queued (Vulkan has no preemption of a submitted dispatch),
//! so the watchdog acts when an over-long pass completes: from then on the job's passes are
//! capped at a size expected to fit in half the limit, and at one sample per pixel over the
//! limit the job fails with a reason that names the pass time and the limit.
//!
//! The limit of a job's pass is `--pass-timeout` when set, else
//! max(`--pass-timeout-floor`, 10 × the median of the job's recent passes).

use std::collections::VecDeque;

use serde_json::json;
use tracing::warn;

use super::Worker;
use crate::config::PassLimits;
use crate::jobs::model::JobId;

/// How many recent pass times the median is taken over.
const RECENT: usize = 15;
/// A pass is "far past its expected time" at this many times the median.
const FACTOR: f64 = 10.0;

/// What the watchdog decided about a completed pass.
#[derive(Debug, Clone, PartialEq)]
pub enum Verdict {
    /// Within the limit.
    Ok,
    /// Over the limit: passes are capped at `cap` samples per pixel from now on.
    Shrink { cap: u32, message: String },
    /// Over the limit at one sample per pixel: stop the job with this reason.
    Stop { reason: String },
}

/// One job's pass history and cap.
#[derive(Debug, Default)]
pub struct PassWatch {
    recent: VecDeque<f64>,
    /// Most samples per pixel of one pass (None: as the sizer wants).
    pub cap: Option<u32>,
}

impl PassWatch {
    /// The limit of this job's next pass, seconds.
    pub fn limit(&self, limits: &PassLimits) -> f64 {
        if let Some(t) = limits.timeout {
            return t.as_secs_f64();
        }
        let mut v: Vec<f64> = self.recent.iter().copied().collect();
        v.sort_by(f64::total_cmp);
        let median = v.get(v.len() / 2).copied().unwrap_or(0.0);
        limits.floor.as_secs_f64().max(FACTOR * median)
    }

    /// Notes a pass of `spp` samples per pixel that took `seconds` and says what to do.
    pub fn observe(&mut self, spp: u32, seconds: f64, limits: &PassLimits) -> Verdict {
        // Step 1: the limit from the passes before this one.
        let limit = self.limit(limits);
        if self.recent.len() == RECENT {
            self.recent.pop_front();
        }
        self.recent.push_back(seconds);
        if seconds <= limit {
            return Verdict::Ok;
        }
        // Step 2: over at one sample per pixel: nothing smaller to try.
        if spp <= 1 {
            return Verdict::Stop {
                reason: format!(
                    "pass watchdog: one pass of 1 sample per pixel took {seconds:.2} s, over the \
                     pass limit of {limit:.2} s; this scene is too heavy to share the GPU at this \
                     film size (render it smaller, or raise --pass-timeout)"
                ),
            };
        }
        // Step 3: a cap expected to fit in half the limit (at least halving the pass).
        let per_sample = seconds / spp as f64;
        let fit = (0.5 * limit / per_sample).floor() as u32;
        let cap = fit.clamp(1, (spp / 2).max(1));
        self.cap = Some(self.cap.map_or(cap, |c| c.min(cap)));
        Verdict::Shrink {
            cap,
            message: format!(
                "pass watchdog: a pass of {spp} samples per pixel took {seconds:.2} s, over the \
                 pass limit of {limit:.2} s; passes are capped at {cap} samples per pixel"
            ),
        }
    }
}

impl Worker {
    /// Acts on the watchdog's verdict on a pass of job `id`: a cap is logged and appended as a
    /// `warning` event; a stop fails the job. False when the job was stopped.
    pub(super) fn watchdog(&mut self, id: JobId, verdict: Verdict) -> bool {
        match verdict {
            Verdict::Ok => true,
            Verdict::Shrink { message, .. } => {
                warn!(job = id, "{message}");
                let _ = self
                    .store
                    .append_event(id, "warning", json!({ "message": message }));
                true
            }
            Verdict::Stop { reason } => {
                self.fail(id, reason);
                false
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    fn relative() -> PassLimits {
        PassLimits {
            timeout: None,
            floor: Duration::from_secs(2),
        }
    }

    #[test]
    fn relative_limit_is_ten_medians_above_the_floor() {
        let mut w = PassWatch::default();
        assert_eq!(w.limit(&relative()), 2.0);
        for _ in 0..5 {
            assert_eq!(w.observe(8, 0.5, &relative()), Verdict::Ok);
        }
        assert_eq!(w.limit(&relative()), 5.0);
        // 4 s is within 10 × 0.5 s; 6 s is not.
        assert_eq!(w.observe(8, 4.0, &relative()), Verdict::Ok);
        match w.observe(8, 6.0, &relative()) {
            Verdict::Shrink { cap, .. } => assert_eq!(cap, 3), // 0.5·5 s / 0.75 s per sample
            v => panic!("{v:?}"),
        }
        assert_eq!(w.cap, Some(3));
    }

    #[test]
    fn a_minimal_pass_over_the_limit_stops_the_job() {
        let limits = PassLimits {
            timeout: Some(Duration::from_millis(100)),
            floor: Duration::from_secs(2),
        };
        let mut w = PassWatch::default();
        assert_eq!(w.observe(1, 0.05, &limits), Verdict::Ok);
        match w.observe(16, 0.8, &limits) {
            Verdict::Shrink { cap, .. } => assert_eq!(cap, 1),
            v => panic!("{v:?}"),
        }
        match w.observe(1, 0.3, &limits) {
            Verdict::Stop { reason } => {
                assert!(
                    reason.contains("0.30 s") && reason.contains("0.10 s"),
                    "{reason}"
                )
            }
            v => panic!("{v:?}"),
        }
    }
}
