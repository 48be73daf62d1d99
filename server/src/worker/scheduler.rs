//! Sharing one GPU between the active jobs: stride scheduling (Waldspurger & Weihl, "Stride
//! Scheduling: Deterministic Proportional-Share Resource Management", 1995) with measured GPU
//! time as the currency, which is weighted fair queuing at pass granularity.
//!
//! Each job j has a weight w_j (its priority) and a *pass* value p_j, the virtual time it has
//! consumed. The next pass always goes to the job with the smallest p_j; after a pass that took
//! t seconds, p_j += t / w_j. Over any interval where the set of jobs is fixed, job j therefore
//! receives a share w_j / Σw of GPU time, whatever its pass length, and a short job submitted
//! behind a long one starts at once and finishes after about (its own time) · Σw / w_j, rather
//! than after the long one.
//!
//! A job that joins (new, resumed, or re-admitted after a restart) starts at the current global
//! virtual time (the smallest p among the others), so it neither owes for time it was away nor
//! carries credit that would let it monopolise the GPU.

use std::collections::BTreeMap;

use crate::jobs::model::JobId;

#[derive(Debug, Clone, Copy)]
struct Entry {
    weight: f64,
    /// Virtual time consumed: Σ seconds / weight.
    pass: f64,
    /// When it last ran (a pass counter; 0: never). Breaks ties: least recently run first.
    last_run: u64,
}

/// The stride scheduler's state.
#[derive(Debug, Default)]
pub struct Scheduler {
    entries: BTreeMap<JobId, Entry>,
    /// Virtual time of the last pass charged (for jobs joining an empty scheduler).
    global: f64,
    /// Passes charged so far.
    tick: u64,
}

impl Scheduler {
    /// The current global virtual time: the smallest pass among the jobs, else the last known.
    fn virtual_time(&self) -> f64 {
        self.entries
            .values()
            .map(|e| e.pass)
            .reduce(f64::min)
            .unwrap_or(self.global)
    }

    /// Adds job `id` with `weight` (≥ 1) at the current virtual time; no-op if present.
    pub fn add(&mut self, id: JobId, weight: u32) {
        let pass = self.virtual_time();
        self.entries.entry(id).or_insert(Entry {
            weight: weight.max(1) as f64,
            pass,
            last_run: 0,
        });
    }

    /// Removes job `id`.
    pub fn remove(&mut self, id: JobId) {
        self.entries.remove(&id);
    }

    /// Removes every job.
    pub fn clear(&mut self) {
        self.entries.clear();
    }

    /// Number of scheduled jobs.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Changes a job's weight; from now on it accrues virtual time at the new rate.
    pub fn set_weight(&mut self, id: JobId, weight: u32) {
        if let Some(e) = self.entries.get_mut(&id) {
            e.weight = weight.max(1) as f64;
        }
    }

    /// The job to run next: the smallest pass; ties go to the least recently run (so a
    /// newcomer runs at once), then to the older (smaller) id.
    pub fn pick(&self) -> Option<JobId> {
        self.entries
            .iter()
            .min_by(|a, b| {
                (a.1.pass.total_cmp(&b.1.pass))
                    .then(a.1.last_run.cmp(&b.1.last_run))
                    .then(a.0.cmp(b.0))
            })
            .map(|(id, _)| *id)
    }

    /// Charges `seconds` of GPU time to job `id`.
    pub fn charge(&mut self, id: JobId, seconds: f64) {
        if let Some(e) = self.entries.get_mut(&id) {
            // p_j += t / w_j
            e.pass += seconds.max(0.0) / e.weight;
            self.tick += 1;
            e.last_run = self.tick;
            self.global = self.global.max(self.virtual_time());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Runs `n` passes where job id's pass takes `cost(id)` seconds; returns time per job.
    fn simulate(s: &mut Scheduler, n: usize, cost: impl Fn(JobId) -> f64) -> BTreeMap<JobId, f64> {
        let mut used = BTreeMap::new();
        for _ in 0..n {
            let id = s.pick().unwrap();
            *used.entry(id).or_insert(0.0) += cost(id);
            s.charge(id, cost(id));
        }
        used
    }

    #[test]
    fn equal_weights_share_equally_whatever_the_pass_length() {
        let mut s = Scheduler::default();
        s.add(1, 10);
        s.add(2, 10);
        let used = simulate(&mut s, 1000, |id| if id == 1 { 0.25 } else { 0.05 });
        let ratio = used[&1] / used[&2];
        assert!((ratio - 1.0).abs() < 0.05, "{used:?}");
    }

    #[test]
    fn weights_set_the_share() {
        let mut s = Scheduler::default();
        s.add(1, 30);
        s.add(2, 10);
        let used = simulate(&mut s, 1000, |_| 0.1);
        let ratio = used[&1] / used[&2];
        assert!((ratio - 3.0).abs() < 0.1, "{used:?}");
        s.set_weight(1, 10);
        let used = simulate(&mut s, 1000, |_| 0.1);
        assert!((used[&1] / used[&2] - 1.0).abs() < 0.1, "{used:?}");
    }

    #[test]
    fn a_newcomer_runs_at_once_without_monopolising() {
        let mut s = Scheduler::default();
        s.add(1, 10);
        simulate(&mut s, 100, |_| 0.2);
        s.add(2, 10);
        assert_eq!(s.pick(), Some(2));
        let used = simulate(&mut s, 100, |_| 0.2);
        assert!((used[&1] - used[&2]).abs() <= 0.2 + 1e-9, "{used:?}");
        s.remove(1);
        s.remove(2);
        s.add(3, 1);
        assert_eq!(s.pick(), Some(3));
        assert_eq!(s.len(), 1);
    }
}
