//! The worker's side of jobs split over workers by sample index (store/shards.rs): a shard is
//! rendered like a job of its own sample count whose passes start at the shard's first sample
//! index; its checkpoint (`shard-<k>.bin`) holds its sums, and the job's image on disk, written
//! with a shard checkpoint at most once per checkpoint interval (live_merge.rs), is the merge of
//! that shard's sums with every other shard's latest checkpoint. A finished shard's final
//! checkpoint is written, and the shard marked done, off the render thread (shard_write.rs).
//! The claim that finds every shard done merges their sums into one accumulation
//! (renderer::render::merge_accumulation, exact up to float addition order): those this process
//! kept in memory as they landed (shard_sums.rs) and the other shards' checkpoints; it restores
//! it into a
//! session of the whole job, and finishes the job as a whole render. A worker keeps the
//! session of the shard it finished last, and reuses it (reset) when its next claim
//! is another part of the same job.

use std::sync::Arc;

use renderer::render::{merge_accumulation, Progress, RenderSession};
use serde_json::json;
use tracing::{info, warn};

use super::active::ActiveJob;
use super::checkpoint;
use super::shard_sums;
use super::Worker;
use crate::jobs::model::{JobId, JobSettings};
use crate::store::{sum_progress, JobPaths, Part, ShardRange, Store};

/// The shard a job's session renders.
#[derive(Debug, Clone, Copy)]
pub struct ShardRun {
    pub range: ShardRange,
    /// The job's shards, and its whole sample count.
    pub count: u32,
    pub job_spp: u32,
    /// The other shards' samples at the last look (for the job's progress).
    pub others_spp: u32,
    /// The least time between two rebuilds of the job's live image (live_merge.rs).
    pub merge_every: std::time::Duration,
    /// Whether the last checkpoint rebuilt the live image (then a `snapshot` event tells).
    pub image_written: bool,
}

/// Adds to `into` (an accumulation of `session`'s layout) the checkpoints of the job's shards
/// `shards`; returns each one's progress, or why it is unusable. The files are added in the
/// order given (the sum does not depend on the thread count; shards kept in memory were added
/// in the order they landed, shard_sums.rs), each read into one buffer kept
/// for all of them by up to eight threads of its own (checkpoint::read_into), then added on all
/// cores.
pub fn add_shards(
    session: &RenderSession,
    settings: &JobSettings,
    paths: &JobPaths,
    shards: impl Iterator<Item = u32>,
    into: &mut [[f32; 4]],
) -> Vec<(u32, Result<Progress, String>)> {
    let (w, h) = (settings.width, settings.height);
    let (len, extra) = (session.accumulation_len(), session.extra_buffers());
    let mut buf = Vec::new();
    shards
        .map(|k| {
            let path = paths.shard_checkpoint(k);
            let added =
                checkpoint::read_into(&path, w, h, settings.seed, len, &mut buf).and_then(|p| {
                    merge_accumulation(into, &buf, (w * h) as usize, &extra)
                        .map(|_| p)
                        .map_err(|e| e.to_string())
                });
            (k, added)
        })
        .collect()
}

/// Shards' summed accumulation and progress.
type Merged = (Vec<[f32; 4]>, Progress);

/// Times a shard may be reopened because its file was unusable at the merge before the job
/// fails: files that keep coming out unusable (a shared folder that hosts see differently, a
/// disk that corrupts them) would otherwise have the shard rendered forever.
pub const MAX_REOPENS: u32 = 3;

/// Why a merge did not happen.
#[derive(Debug)]
pub enum MergeError {
    /// The store could not be read or written (the merge is tried again).
    Store(String),
    /// A shard's file was unusable more than [`MAX_REOPENS`] times: the job fails.
    Unusable(String),
}

/// The merge of every shard of job `id`: their summed accumulation, their progress, and how
/// many came from this process's memory (shard_sums.rs) rather than their files. None when a
/// shard was reopened since the claim, or when a shard's checkpoint is missing, unusable or
/// short of its samples: that shard is reopened (to be rendered again) and its file removed.
pub fn merged(
    store: &Store,
    session: &RenderSession,
    settings: &JobSettings,
    paths: &JobPaths,
    id: JobId,
) -> Result<Option<(Merged, usize)>, MergeError> {
    let store_error = |e: crate::store::StoreError| MergeError::Store(e.to_string());
    let rows = store.shards(id).map_err(store_error)?;
    if rows.iter().any(|r| !r.done) {
        return Ok(None); // reopened since the claim
    }
    // Step 1: the shards this process kept in memory, where they match the rows.
    let layout = shard_sums::Layout::of(settings, session, rows.len() as u32);
    let kept = shard_sums::take(&paths.dir).filter(|k| {
        k.layout == layout
            && k.shards.iter().all(|(i, (r, p))| {
                let row = rows.get(*i as usize);
                row.is_some_and(|row| row.range == *r && p.spp == r.samples)
            })
    });
    let (mut sums, kept) = match kept {
        Some(k) => (k.sum, k.shards),
        None => (
            vec![[0.0f32; 4]; session.accumulation_len()],
            Default::default(),
        ),
    };
    let mut parts: Vec<Progress> = kept.values().map(|(_, p)| *p).collect();
    // Step 2: the others' files, in index order.
    let others = (0..rows.len() as u32).filter(|k| !kept.contains_key(k));
    for (k, read) in add_shards(session, settings, paths, others, &mut sums) {
        let row = &rows[k as usize];
        match read {
            Ok(p) if p.spp == row.range.samples => parts.push(p),
            bad => {
                let why =
                    bad.map_or_else(|e| e, |p| format!("{} of {} spp", p.spp, row.range.samples));
                warn!(job = id, shard = k, %why, "a done shard's checkpoint is unusable; rendering it again");
                let _ = std::fs::remove_file(paths.shard_checkpoint(k));
                return match store
                    .reopen_shard(id, k, MAX_REOPENS)
                    .map_err(store_error)?
                {
                    Some(_) => Ok(None),
                    None => Err(MergeError::Unusable(format!(
                        "shard {k}'s checkpoint was unusable at the merge {} times (last: \
                         {why}); is the data directory shared consistently by every host?",
                        MAX_REOPENS + 1
                    ))),
                };
            }
        }
    }
    Ok(Some(((sums, sum_progress(&parts)), kept.len())))
}

/// Records a checkpoint's progress `p` of job `id`: the job's own, or its shard's (the job's
/// progress then the shards' sum, announced in a `progress` event and a `snapshot` event of
/// the merged image on disk).
pub fn record_progress(
    store: &Arc<Store>,
    worker: &str,
    id: JobId,
    job: &mut ActiveJob,
    p: &Progress,
) {
    let Some(sh) = job.shard else {
        let _ = store.set_progress(id, p);
        return;
    };
    match store.shard_checkpointed(id, sh.range.idx, worker, p) {
        Ok(Some(total)) => {
            if let Some(s) = &mut job.shard {
                s.others_spp = total.spp.saturating_sub(p.spp);
            }
            let _ = store.append_event(id, "progress", job.progress_json());
            if sh.image_written {
                let data = super::outcome::snapshot_data(id, total.spp);
                let _ = store.append_event(id, "snapshot", data);
            }
        }
        // Lost: the next heartbeat drops the shard.
        Ok(None) => {}
        Err(e) => warn!(job = id, error = %e, "recording a shard's progress"),
    }
}

impl Worker {
    /// The spare session (of the shard this worker finished last), reset, when `part` is
    /// another part of the same job `id`: no scene to load and prepare again.
    pub(super) fn take_spare(&mut self, id: JobId, part: Part, seed: u64) -> Option<RenderSession> {
        let (job, mut session) = self.spare.take()?;
        if job != id || part == Part::Whole {
            return None;
        }
        match session.reset(seed) {
            Ok(()) => {
                info!(job = id, "reusing the session of the job's last shard");
                Some(session)
            }
            Err(e) => {
                warn!(job = id, error = %e, "resetting the spare session; making a new one");
                None
            }
        }
    }

    /// Writes job `id`'s checkpoint and records its progress; None (handled) on failure.
    pub(super) fn save_checkpoint(&mut self, id: JobId) -> Option<Progress> {
        let job = self.active.get_mut(&id)?;
        match job.write_checkpoint() {
            Ok(p) => {
                record_progress(&self.store, &self.config.worker_id, id, job, &p);
                Some(p)
            }
            Err(e) => {
                self.checkpoint_failed(id, e);
                None
            }
        }
    }

    /// A shard rendered all its samples: its sums are read back, and its final checkpoint is
    /// written and the shard marked done off this thread (shard_write.rs), if this worker still
    /// holds it, while the worker looks for more work (the next shard, or the merge).
    pub(super) fn finish_shard(&mut self, id: JobId, mut job: ActiveJob) {
        let Some(sh) = job.shard else { return };
        let worker = self.config.worker_id.clone();
        let t0 = std::time::Instant::now();
        let rendering = job.since_admit();
        // Step 1: the sums copied to host-visible memory (after the job's queued passes; the
        // writer's thread reads them from there).
        let accumulation = match job.session.accumulation_to_host(self.spare_sums.take()) {
            Ok(acc) => acc,
            // Taken over meanwhile (its new owner renders it): lost, not a failure of the job.
            Err(e)
                if !self
                    .store
                    .holds_shard(id, sh.range.idx, &worker)
                    .unwrap_or(true) =>
            {
                warn!(job = id, shard = sh.range.idx, error = %e,
                      "lost the shard's lease; reading its sums back failed");
                return self.keep_spare(id, job);
            }
            // (A lost device fails no job: outcome.rs `render_failed`.)
            Err(e) => {
                self.active.insert(id, job);
                return self.render_failed(id, e, "reading a shard's sums back");
            }
        };
        let readback = t0.elapsed();
        // (The device generation the sums were copied under: shard_write.rs.)
        let epoch_at_copy = self.device_epoch.load(std::sync::atomic::Ordering::SeqCst);
        // Step 2: the lease to the writer's name, then the write on its thread. (A film-size
        // buffer each: writes slower than the renders wait here, for the oldest, before the
        // lease's clock starts.)
        // (The wait renews this worker's leases, this shard's and the writers' among them, as
        // its heartbeats would: a slow disk must not let another worker take them over.)
        if self.writes.len() >= super::shard_write::MAX_PENDING {
            info!(
                job = id,
                shard = sh.range.idx,
                "waiting for the oldest shard write"
            );
        }
        while self.writes.len() >= super::shard_write::MAX_PENDING {
            if self.writes[0].is_finished() {
                self.collect_writes(1);
                continue;
            }
            std::thread::sleep(std::time::Duration::from_millis(10));
            if self.last_heartbeat.elapsed() >= self.config.heartbeat {
                self.heartbeat_keeping(Some(id));
            }
        }
        let owner = super::shard_write::writer_name(&worker);
        // (A database error is tried once more, a moment later: else the sums are lost and
        // the shard rendered again from its last checkpoint.)
        let lease = self.config.lease;
        let handed = self
            .store
            .hand_shard(id, sh.range.idx, &worker, &owner, lease)
            .or_else(|e| {
                warn!(job = id, shard = sh.range.idx, error = %e,
                      "handing a shard to its writer; trying again");
                std::thread::sleep(super::shard_write::RETRY_AFTER);
                self.store
                    .hand_shard(id, sh.range.idx, &worker, &owner, lease)
            });
        match handed {
            Ok(true) => {
                let finished = super::shard_write::Finished {
                    id,
                    idx: sh.range.idx,
                    settings: job.settings.clone(),
                    path: job.paths.shard_checkpoint(sh.range.idx),
                    progress: job.session.progress(),
                    accumulation,
                    job_spp: sh.job_spp,
                    progress_json: job.progress_json(),
                    rendering,
                    readback,
                    device_epoch: (self.device_epoch.clone(), epoch_at_copy),
                    job_dir: job.paths.dir.clone(),
                    layout: shard_sums::Layout::of(&job.settings, &job.session, sh.count),
                    range: sh.range,
                };
                match super::shard_write::start(self.store.clone(), owner.clone(), finished) {
                    Ok(w) => self.writes.push(w),
                    Err(e) => {
                        // (No thread: the shard goes back to be rendered again.)
                        let _ = self.store.release_shard(id, sh.range.idx, &owner);
                        warn!(job = id, shard = sh.range.idx, error = %e,
                              "starting a shard's write");
                    }
                }
            }
            Ok(false) => {
                warn!(
                    job = id,
                    shard = sh.range.idx,
                    "lost the shard's lease before recording it done"
                );
                self.spare_sums = Some(accumulation);
            }
            Err(e) => {
                warn!(job = id, shard = sh.range.idx, error = %e, "handing a shard to its writer");
                self.spare_sums = Some(accumulation);
            }
        }
        self.keep_spare(id, job);
    }

    /// Keeps the session of the shard `job` ended for the job's next shard (or merge), if this
    /// worker claims one next, and looks for more work.
    fn keep_spare(&mut self, id: JobId, job: ActiveJob) {
        job.flush_metrics();
        self.spare = Some((id, job.into_session()));
        self.shared.forget(id);
        self.dirty = true;
        self.claim_now = true;
        self.publish_caches();
    }
}

/// Whole milliseconds of `d` (for timing logs).
pub fn ms(d: std::time::Duration) -> u64 {
    d.as_millis() as u64
}

/// The data of a `shard` object in a progress event.
pub fn shard_json(sh: &ShardRun, spp: u32) -> serde_json::Value {
    json!({"index": sh.range.idx, "count": sh.count, "first": sh.range.first,
           "samples": sh.range.samples, "spp": spp})
}
