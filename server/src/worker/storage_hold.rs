//! Storage faults: a job whose checkpoint, image or state could not be written for lack of space
//! is held — its session dropped (its last checkpoint kept), `paused` in the store with `hold`
//! naming the reason — and queued again once free space is above the minimum and a probe write
//! succeeds. When the store cannot be written either, the space reserve is deleted to make room
//! (storage.rs), and made again before the jobs resume. If even that fails, the job stays out of the active set all the
//! same (the worker remembers it) and the pause is written as soon as the store accepts it; a
//! job whose pause never reached the store is simply re-admitted from its checkpoint. Jobs held
//! before a restart are found by their `hold`.

use std::time::Instant;

use tracing::{info, warn};

use super::Worker;
use crate::jobs::model::{JobId, JobState};
use crate::storage;
use crate::store::Transition;

/// Whether an I/O error is a storage fault (by its code or, once wrapped, its text).
pub(super) fn is_storage_fault(e: &std::io::Error) -> bool {
    storage::is_storage_error(e) || storage::is_storage_message(&e.to_string())
}

impl Worker {
    /// Holds job `id` after `what` failed with `error` for lack of space.
    pub(super) fn hold_for_storage(&mut self, id: JobId, what: &str, error: String) {
        self.sched.remove(id);
        self.queued.retain(|j| *j != id);
        if let Some(job) = self.active.remove(&id) {
            job.flush_metrics();
        }
        self.shared.forget(id);
        let reason = format!("disk full: {what}: {error}");
        warn!(job = id, %reason, "holding the job until space returns");
        self.held.insert(id, reason);
        self.write_hold_or_release(id);
        self.publish_held();
    }

    /// Writes job `id`'s hold to the store (paused, `hold` set) if it is not there yet; false
    /// when the store refused.
    fn write_hold(&mut self, id: JobId) -> bool {
        let Some(reason) = self.held.get(&id).cloned() else {
            return true;
        };
        match self.store.job_state(id) {
            Ok(Some(JobState::Queued | JobState::Running)) => {
                let t = Transition {
                    verb: "pause",
                    reason: Some(reason),
                    hold: true,
                    ..Default::default()
                };
                self.store.transition(id, JobState::Paused, t).is_ok()
            }
            Ok(Some(JobState::Paused)) => true,
            // Ended or deleted meanwhile: nothing to hold.
            Ok(_) => {
                self.held.remove(&id);
                true
            }
            Err(_) => false,
        }
    }

    /// [`Self::write_hold`]; if the store refused, deletes the space reserve and tries again.
    fn write_hold_or_release(&mut self, id: JobId) {
        if !self.write_hold(id) && storage::release_reserve(&self.config.data_dir) {
            warn!(job = id, "released the space reserve to record the pause");
            self.write_hold(id);
        }
    }

    fn publish_held(&self) {
        let mut s = self.shared.storage();
        s.held_jobs = self.held.len() as u64;
        self.shared.set_storage(s);
    }

    /// Every `storage_check_interval`: measures free space; with held jobs, resumes them if
    /// space is back (above the minimum, and a probe write succeeds), else retries writing
    /// their pause.
    pub(super) fn check_storage(&mut self) {
        let every = self.config.storage_check_interval;
        if self.last_storage_check.is_some_and(|t| t.elapsed() < every) {
            return;
        }
        self.last_storage_check = Some(Instant::now());
        let data_dir = self.config.data_dir.clone();
        let mut status = storage::status(&data_dir, self.config.min_free_space);
        // Step 1: the held jobs: the worker's, and those the store says are held (a restart).
        let stored = self.store.held_jobs().unwrap_or_default();
        for id in &stored {
            self.held
                .entry(*id)
                .or_insert_with(|| "disk full (before a restart)".into());
        }
        status.held_jobs = self.held.len() as u64;
        if self.held.is_empty() {
            return self.shared.set_storage(status);
        }
        // Step 2: space still short (below the minimum, or too little to make the reserve again,
        // or the probe write fails): write the pauses the store refused before.
        let reserve = if storage::has_reserve(&data_dir) {
            0
        } else {
            2 * storage::RESERVE_BYTES
        };
        let short = status.low
            || status.free_bytes < status.min_free_bytes.saturating_add(reserve)
            || storage::make_reserve(&data_dir).is_err()
            || storage::probe(&data_dir).is_err();
        if short {
            let ids: Vec<JobId> = self.held.keys().copied().collect();
            for id in ids {
                self.write_hold_or_release(id);
            }
            status.held_jobs = self.held.len() as u64;
            return self.shared.set_storage(status);
        }
        // Step 3: space is back: queue the held jobs again (a job whose pause never reached the
        // store is still running there, and is re-admitted from its checkpoint).
        let ids: Vec<JobId> = std::mem::take(&mut self.held).into_keys().collect();
        for id in ids {
            if self.store.job_state(id).ok().flatten() == Some(JobState::Paused)
                && self.store.get_job(id).is_ok_and(|r| r.hold.is_some())
            {
                let t = Transition {
                    verb: "resume",
                    reason: Some("space available again".into()),
                    ..Default::default()
                };
                if let Err(e) = self.store.transition(id, JobState::Queued, t) {
                    warn!(job = id, error = %e, "resuming a held job");
                    continue;
                }
            }
            info!(job = id, "space available again: resuming");
        }
        self.dirty = true;
        status.held_jobs = 0;
        self.shared.set_storage(status);
    }
}
