//! The worker's bond with the store: [`Worker::reconcile`] brings the active jobs in line with
//! the runnable ones and claims work for free slots (store/leases.rs), and
//! [`Worker::heartbeat`] renews the leases of the jobs it holds and drops those it lost to
//! another worker.

use std::time::Instant;

use tracing::{error, warn};

use super::{JobId, Worker};

impl Worker {
    /// Brings the active set in line with the store: retires sessions of jobs that are no
    /// longer runnable, updates weights, and admits jobs while there are free slots.
    pub(super) fn reconcile(&mut self) {
        let runnable = match self.store.runnable_jobs() {
            Ok(v) => v,
            Err(e) => {
                error!(error = %e, "reading runnable jobs");
                self.dirty = true;
                return;
            }
        };
        // Shard sums kept in memory for jobs no longer runnable (merged elsewhere, canceled,
        // deleted, paused): their merge, if any, reads the files (shard_sums.rs).
        for (dir, id) in super::shard_sums::kept_jobs() {
            if !runnable.iter().any(|(r, _, _)| *r == id) {
                super::shard_sums::forget(&dir);
            }
        }
        let gone: Vec<JobId> = self
            .active
            .keys()
            .filter(|id| !runnable.iter().any(|(r, _, _)| r == *id))
            .copied()
            .collect();
        for id in gone {
            self.retire(id);
        }
        for (id, _, priority) in runnable {
            if self.active.contains_key(&id) {
                self.sched.set_weight(id, priority);
            }
        }
        // Free slots: claim runnable jobs (store/leases.rs) — none another worker holds, none
        // held for a storage fault (storage_hold.rs).
        let mut skip: Vec<JobId> = self.held.keys().copied().collect();
        while self.active.len() < self.config.max_active.max(1) && self.ctx.is_some() {
            let exclude: Vec<JobId> = self.active.keys().chain(&skip).copied().collect();
            let claim = self.store.claim_job(
                &self.config.worker_id,
                self.config.lease,
                &exclude,
                self.config.shard_spp,
                self.active.is_empty(),
            );
            match claim {
                Ok(Some(claim)) => {
                    let id = claim.id;
                    self.admit(claim);
                    // Admitting may take long (kernels to build): renew at once, and let the
                    // job go if another worker took it meanwhile.
                    self.heartbeat();
                    // Not admitted (failed, or paused meanwhile): its lease goes at the next
                    // heartbeat; not again in this round.
                    skip.push(id);
                }
                Ok(None) => break,
                Err(e) => {
                    error!(error = %e, "claiming a job");
                    self.dirty = true;
                    break;
                }
            }
        }
        // A spare session no claim took: its device memory goes, and the host buffer kept for
        // its next shard's sums with it (the worker moved on to other work).
        if self.spare.take().is_some() {
            self.spare_sums = None;
        }
    }

    /// Renews the leases of the active jobs and gives up the others; drops, unsaved, every job
    /// whose lease was lost (it expired and another worker took the job over).
    pub(super) fn heartbeat(&mut self) {
        self.heartbeat_keeping(None);
    }

    /// [`Self::heartbeat`] that also renews the lease of `also`, a job (or shard) that has left
    /// the active set but is still this worker's (a shard whose sums wait for a writer).
    pub(super) fn heartbeat_keeping(&mut self, also: Option<JobId>) {
        self.last_heartbeat = Instant::now();
        self.report(false);
        self.renew_write_leases();
        let held: Vec<JobId> = self.active.keys().copied().chain(also).collect();
        let kept = match self
            .store
            .renew_leases(&self.config.worker_id, &held, self.config.lease)
        {
            Ok(k) => k,
            Err(e) => return error!(error = %e, "renewing the render leases"),
        };
        for id in held
            .into_iter()
            .filter(|id| !kept.contains(id) && Some(*id) != also)
        {
            warn!(
                job = id,
                "lost the job's lease to another worker; stopping it"
            );
            self.sched.remove(id);
            self.queued.retain(|j| *j != id);
            if let Some(job) = self.active.remove(&id) {
                job.flush_metrics();
            }
            self.shared.forget(id);
        }
    }
}
