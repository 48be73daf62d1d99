//! Quality targets (`candela render --until-rel-mse X`, a job's `"until": {"rel_mse": X}`):
//! when the error estimate is checked and when the render stops. One place for the rule, used
//! by [`super::render_until`] and the server's worker.
//!
//! The estimate is checked at fixed sample counts, the check points c₀ = [`UNTIL_MIN_SPP`],
//! c₍ₖ₊₁₎ = max(c_k + 1, ⌈c_k · (1 + [`UNTIL_CHECK_GROWTH`])⌉): 8, 9, 11, 13, 15, 17, 20, 23, 26,
//! 30, 34, 39, 44, 50, … (about 8.5 · ln(N/8) checks up to N spp: 53 to 4096). Passes are sized as without a
//! target (to fill the GPU) but cut so one ends exactly at each check point; that pass computes
//! the estimate on the GPU (estimate_gpu.rs), and nothing past the check point is queued until
//! its result is known. So:
//!
//! - the render stops at the first check point whose estimate is at most the target: the same
//!   spp for the same seed, target and device, whatever the passes' timing (the image too, up to
//!   the float summation order of passes split differently: dispatch shapes follow pass sizes);
//! - overshoot is bounded: the check point before the stop had an estimate above the target,
//!   and the stop is at most ⌈(1 + growth) ×⌉ (12.5%, at least 1 spp) past it;
//! - the cost is one estimate (two small dispatches, 16 bytes read back) and one wait for the
//!   host per check point, instead of a film readback and a CPU estimate after every pass.

/// Fewest samples per pixel before a quality target may stop a render: below it the estimate
/// rests on too few samples per half to trust ([`crate::metrics::rel_mse_estimate`]). The
/// first check point.
pub const UNTIL_MIN_SPP: u32 = 8;

/// Each check point has at least this fraction more samples than the one before (the bound on
/// overshoot past the last check above the target).
pub const UNTIL_CHECK_GROWTH: f64 = 0.125;

/// Whether a render with the estimate `estimate` at `spp` samples per pixel has reached the
/// target `rel_mse`.
pub fn target_reached(rel_mse: f64, spp: u32, estimate: Option<f64>) -> bool {
    spp >= UNTIL_MIN_SPP && estimate.is_some_and(|e| e <= rel_mse)
}

/// The first check point above `spp` (see the module docs).
pub fn next_check(spp: u32) -> u32 {
    let mut c = UNTIL_MIN_SPP;
    while c <= spp {
        let grown = (c as f64 * (1.0 + UNTIL_CHECK_GROWTH)).ceil();
        c = (grown.min(u32::MAX as f64) as u32).max(c.saturating_add(1));
        if c == u32::MAX {
            break;
        }
    }
    c
}

/// Whether `spp` is itself a check point (a render resumed there checks its target before it
/// renders on: an uninterrupted one would have stopped there if the target was reached).
pub fn is_check_point(spp: u32) -> bool {
    spp >= UNTIL_MIN_SPP && next_check(spp - 1) == spp
}

/// A render's quality target and the state of its checks.
#[derive(Debug, Clone)]
pub struct UntilChecks {
    /// The target relMSE estimate.
    pub goal: f64,
    /// The check point of a queued pass whose estimate is not known yet.
    pending: Option<u32>,
    /// Whether a check has reached the target.
    pub reached: bool,
    /// The latest check: its spp and estimate.
    pub last: Option<(u32, Option<f64>)>,
}

impl UntilChecks {
    pub fn new(goal: f64) -> Self {
        UntilChecks {
            goal,
            pending: None,
            reached: false,
            last: None,
        }
    }

    /// Most samples per pixel the next pass may have with `submitted` queued or done so far: 0
    /// once the target is reached or while a check's result is awaited, else up to the next
    /// check point.
    pub fn pass_limit(&self, submitted: u32) -> u32 {
        if self.reached || self.pending.is_some() {
            return 0;
        }
        next_check(submitted) - submitted
    }

    /// Whether a pass of `spp` samples after `submitted` ends at a check point (it then
    /// computes the estimate: [`Self::queued`]).
    pub fn is_check(&self, submitted: u32, spp: u32) -> bool {
        submitted.checked_add(spp) == Some(next_check(submitted))
    }

    /// Notes that a pass ending at check point `spp` was queued with the estimate.
    pub fn queued(&mut self, spp: u32) {
        self.pending = Some(spp);
    }

    /// Notes a check's result: the estimate at `spp` samples per pixel.
    pub fn observe(&mut self, spp: u32, estimate: Option<f64>) {
        if self.pending == Some(spp) {
            self.pending = None;
        }
        self.reached |= target_reached(self.goal, spp, estimate);
        self.last = Some((spp, estimate));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn check_points_grow_geometrically_from_the_minimum() {
        let mut points = vec![next_check(0)];
        while points.len() < 14 {
            points.push(next_check(*points.last().unwrap()));
        }
        assert_eq!(
            points,
            [8, 9, 11, 13, 15, 17, 20, 23, 26, 30, 34, 39, 44, 50]
        );
        assert_eq!(next_check(7), 8);
        assert_eq!(next_check(8), 9);
        assert_eq!(next_check(10), 11);
        // Far out, each is 12.5% (rounded up) past the one before.
        let c = next_check(100_000);
        let after = next_check(c);
        assert!(after as f64 >= c as f64 * 1.125 && (after as f64) < c as f64 * 1.125 + 1.0);
        assert_eq!(next_check(u32::MAX - 1), u32::MAX);
    }

    #[test]
    fn check_points_are_recognised() {
        let points: Vec<u32> = (0..60).filter(|&s| is_check_point(s)).collect();
        assert_eq!(
            points,
            [8, 9, 11, 13, 15, 17, 20, 23, 26, 30, 34, 39, 44, 50, 57]
        );
        assert!(is_check_point(next_check(100_000)));
        assert!(!is_check_point(next_check(100_000) - 1));
    }

    #[test]
    fn passes_stop_at_check_points_and_wait_for_them() {
        let mut u = UntilChecks::new(0.01);
        assert_eq!(u.pass_limit(0), 8);
        assert!(u.is_check(0, 8) && !u.is_check(0, 7));
        assert!(u.is_check(5, 3));
        u.queued(8);
        assert_eq!(u.pass_limit(8), 0, "waits for the check");
        u.observe(8, Some(0.02));
        assert!(!u.reached);
        assert_eq!(u.pass_limit(8), 1);
        u.queued(9);
        u.observe(9, Some(0.009));
        assert!(u.reached);
        assert_eq!(u.pass_limit(9), 0);
        // Below the minimum spp a low estimate does not count.
        assert!(!target_reached(1.0, 7, Some(0.0)));
        assert!(!target_reached(1.0, 8, None));
    }
}
