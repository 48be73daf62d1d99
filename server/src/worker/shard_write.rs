//! A finished shard's final checkpoint, written off the render thread: the device copies the
//! shard's sums into host-visible memory (the only part on the render thread; one device copy,
//! `RenderSession::accumulation_to_host`), the shard's lease is handed to a name of the
//! worker's own for writers (`NAME#write`, store/shards.rs `hand_shard`) and a thread writes
//! `shard-<k>.bin` straight from that memory (whole, renamed into place), adds them to the
//! job's sums kept in this process for its merge (shard_sums.rs) and only then marks the shard
//! done, while the device renders the worker's next shard; the buffer then serves
//! the worker's next shard. The worker loop collects finished writes
//! ([`Worker::collect_writes`]), announces them (`progress` event) and claims again (the merge,
//! once every shard is done).
//!
//! Crash safety: the shard is done only once its file is whole; a worker killed while
//! the file is written leaves the writer's lease to expire (`--lease`), and the shard to be
//! rendered again from its last checkpoint by whichever worker claims it; a writer that finds
//! its lease taken over meanwhile records nothing (the new owner finishes the shard), so no
//! samples are counted twice. The file is not fsync'd (on a local disk that took most of a
//! shard's write: four workers' 265 MB files at once, 0.55–0.65 s each): a power loss that
//! takes the file with it after the shard was marked done is found by the merge, which checks
//! every file's checksum and sample count and renders a shard again when its file is missing
//! or unusable (shard.rs `merged`). What a lost file costs is one shard's render, never a
//! wrong image.

use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use renderer::render::{HostAccumulation, Progress};
use serde_json::Value;
use tracing::{debug, info, warn};

use super::checkpoint;
use super::shard::ms;
use super::shard_sums;
use super::storage_hold::is_storage_fault;
use super::Worker;
use crate::jobs::model::{JobId, JobSettings, JobState};
use crate::store::{JobPaths, ShardRange, Store, StoreError};

/// Why a shard's background write failed.
#[derive(Debug)]
enum WriteError {
    Io(std::io::Error),
    Store(StoreError),
    /// The device was reset (lost, or another device error) while the file was written:
    /// Vulkan leaves the contents of a lost device's mapped memory undefined, so the file is
    /// not trusted (removed if the shard is still the writer's, the shard freed). A loss the
    /// worker notices only after the write ended is not caught here.
    DeviceReset,
}

/// What a writer thread reports: how long the file and the status update took, and the job's
/// total (None: the lease was lost).
struct Written {
    file: Duration,
    status: Duration,
    result: Result<Option<Progress>, WriteError>,
    /// The sums' buffer, for the worker's next shard.
    sums: Option<HostAccumulation>,
}

/// A shard's final checkpoint being written.
pub struct ShardWrite {
    id: JobId,
    idx: u32,
    /// The name the shard is leased to while it is written.
    owner: String,
    /// The job's sample budget; the shard's progress event before the job's total is known.
    job_spp: u32,
    progress_json: Value,
    /// Time from the shard's admission to its end, and of the copy to host-visible memory.
    rendering: Duration,
    readback: Duration,
    gpu_s: f64,
    handle: JoinHandle<Written>,
}

/// Writes a device thread lets run at once (each holds a copy of a film-size accumulation);
/// a shard that ends with this many under way waits for the oldest, before its own lease is
/// handed (so that its writer's lease runs from the start of its write).
pub const MAX_PENDING: usize = 2;

/// How long a shard's hand-off or done mark that hit a database error waits before its one
/// more try.
pub const RETRY_AFTER: Duration = Duration::from_millis(200);

/// The name a worker's shard writes hold their leases under.
pub fn writer_name(worker: &str) -> String {
    format!("{worker}#write")
}

/// What [`start`] needs of a finished shard.
pub struct Finished {
    pub id: JobId,
    pub idx: u32,
    pub settings: JobSettings,
    pub path: std::path::PathBuf,
    pub progress: Progress,
    /// The shard's sums, in host-visible memory the device copied them to.
    pub accumulation: HostAccumulation,
    pub job_spp: u32,
    pub progress_json: Value,
    pub rendering: Duration,
    pub readback: Duration,
    /// The worker's device generation (bumped at each device reset) and its value when the
    /// sums were copied.
    pub device_epoch: (std::sync::Arc<std::sync::atomic::AtomicU64>, u64),
    /// Where the sums are kept in memory for the merge (shard_sums.rs): the job's folder, its
    /// layout and the shard's range.
    pub job_dir: std::path::PathBuf,
    pub layout: shard_sums::Layout,
    pub range: ShardRange,
}

/// Starts the write of a finished shard whose lease was handed to `owner`.
pub fn start(
    store: std::sync::Arc<Store>,
    owner: String,
    f: Finished,
) -> std::io::Result<ShardWrite> {
    let (id, idx, p) = (f.id, f.idx, f.progress);
    let (w, h, seed) = (f.settings.width, f.settings.height, f.settings.seed);
    let (path, acc, thread_owner) = (f.path, f.accumulation, owner.clone());
    let (epoch, at_copy) = f.device_epoch;
    let handle = std::thread::Builder::new()
        .name(format!("shard-write-{id}-{idx}"))
        .spawn(move || {
            let t0 = Instant::now();
            let wrote = crate::storage::injected_fault()
                .and_then(|_| checkpoint::write(&path, w, h, seed, &p, acc.as_slice(), false));
            let file = t0.elapsed();
            if wrote.is_ok() {
                hold_for_test(id, idx);
            }
            let reset_at = || epoch.load(std::sync::atomic::Ordering::SeqCst) != at_copy;
            // The sums kept for the merge too, before the shard is done (shard_sums.rs).
            let mut kept = false;
            if wrote.is_ok() && !reset_at() {
                let (layout, range) = (f.layout, f.range);
                kept = shard_sums::add(&f.job_dir, id, layout, range, p, acc.as_slice());
                if !kept {
                    debug!(
                        job = id,
                        shard = idx,
                        "shard sums not kept in memory (see shard_sums.rs)"
                    );
                }
            }
            // (Checked after the add too: a reset noticed meanwhile leaves the kept sum in
            // doubt, so the job's kept sums go and its merge reads the files.)
            let reset = reset_at();
            if reset && kept {
                shard_sums::forget(&f.job_dir);
            }
            let result = match wrote {
                Err(e) => Err(WriteError::Io(e)),
                Ok(()) if reset => Err(WriteError::DeviceReset),
                // Done only now that the file is whole. (A database error is tried
                // once more, a moment later: else the shard waits for the lease to run out
                // and is rendered again.)
                Ok(()) => store
                    .shard_done(id, idx, &thread_owner, &p)
                    .or_else(|e| {
                        warn!(job = id, shard = idx, error = %e,
                              "recording a shard done; trying again");
                        std::thread::sleep(RETRY_AFTER);
                        store.shard_done(id, idx, &thread_owner, &p)
                    })
                    .map_err(WriteError::Store),
            };
            Written {
                file,
                status: t0.elapsed() - file,
                result,
                sums: Some(acc),
            }
        })?;
    Ok(ShardWrite {
        id,
        idx,
        owner,
        job_spp: f.job_spp,
        progress_json: f.progress_json,
        rendering: f.rendering,
        readback: f.readback,
        gpu_s: p.gpu_time_s,
        handle,
    })
}

/// Test hook: while the file `CANDELA_TEST_SHARD_WRITE_HOLD_FILE` names exists, a shard
/// whose file is written waits before it is marked done (a worker killed then must lose
/// nothing and count nothing twice: tests/tests/server_farm.rs).
fn hold_for_test(id: JobId, idx: u32) {
    let what = format!("job {id} shard {idx}: shard written; held before done");
    super::test_hooks::hold("CANDELA_TEST_SHARD_WRITE_HOLD_FILE", &what);
}

impl ShardWrite {
    /// Whether the write (and its done mark) has ended.
    pub fn is_finished(&self) -> bool {
        self.handle.is_finished()
    }
}

impl Worker {
    /// Renews the writers' leases of the writes under way (with the worker's heartbeat): a
    /// write slower than `--lease` (a slow disk, writes queued ahead of it) keeps its shard.
    pub(super) fn renew_write_leases(&self) {
        for w in &self.writes {
            let renewed = self
                .store
                .renew_shard_lease(w.id, w.idx, &w.owner, self.config.lease);
            if let Err(e) = renewed {
                warn!(job = w.id, shard = w.idx, error = %e, "renewing a shard writer's lease");
            }
        }
    }

    /// Handles the shard writes that ended, after waiting for the oldest `wait` of them (0:
    /// none, `usize::MAX`: all): a shard done is announced and the worker claims again; a
    /// failed write frees the shard (rendered again) and, unless the disk is full, fails the
    /// job as a failed checkpoint does.
    pub(super) fn collect_writes(&mut self, wait: usize) {
        let (mut i, mut seen) = (0, 0);
        while i < self.writes.len() {
            let must = seen < wait;
            seen += 1;
            if !must && !self.writes[i].handle.is_finished() {
                i += 1;
                continue;
            }
            // (In start order: `writes[0]` is the oldest.)
            let w = self.writes.remove(i);
            let (id, idx) = (w.id, w.idx);
            let mut written = w.handle.join().unwrap_or_else(|_| Written {
                file: Duration::ZERO,
                status: Duration::ZERO,
                result: Err(WriteError::Io(std::io::Error::other("the writer panicked"))),
                sums: None,
            });
            // (Kept for the next shard only if made on the device the worker has now.)
            if let Some(sums) = written.sums.take() {
                if self.ctx.as_ref().is_some_and(|c| sums.is_of(c)) {
                    self.spare_sums = Some(sums);
                }
            }
            match written.result {
                Ok(Some(total)) => {
                    info!(
                        job = id,
                        shard = idx,
                        job_spp = total.spp,
                        admit_to_done_ms = ms(w.rendering),
                        gpu_ms = (w.gpu_s * 1e3) as u64,
                        readback_ms = ms(w.readback),
                        file_ms = ms(written.file),
                        status_ms = ms(written.status),
                        "shard done"
                    );
                    let mut data = w.progress_json;
                    data["spp"] = total.spp.into();
                    data["fraction"] = (total.spp as f64 / w.job_spp.max(1) as f64).min(1.0).into();
                    let _ = self.store.append_event(id, "progress", data);
                    self.claim_now = true;
                    self.dirty = true;
                }
                Ok(None) => warn!(
                    job = id,
                    shard = idx,
                    "lost the shard's lease before recording it done"
                ),
                Err(WriteError::Store(e)) => {
                    warn!(job = id, shard = idx, error = %e, "recording a shard done")
                }
                Err(WriteError::DeviceReset) => {
                    // (Only a file still this writer's: a new owner's may be there by now.)
                    if self.store.holds_shard(id, idx, &w.owner).unwrap_or(false) {
                        let paths = JobPaths::new(&self.config.data_dir, id);
                        let _ = std::fs::remove_file(paths.shard_checkpoint(idx));
                    }
                    let _ = self.store.release_shard(id, idx, &w.owner);
                    warn!(job = id, shard = idx,
                          "the device was reset while the shard's sums were written; it renders again");
                }
                Err(WriteError::Io(e)) => {
                    let held = self.store.holds_shard(id, idx, &w.owner).unwrap_or(true);
                    let _ = self.store.release_shard(id, idx, &w.owner);
                    // (A cancel removes the writer's temp file too: its rename then fails, and
                    // the job is not this write's to fail. `discard_if_ended` cleans up.)
                    let ended = match self.store.job_state(id) {
                        Ok(Some(state)) => state.is_terminal(),
                        Ok(None) => true,
                        Err(_) => false,
                    };
                    if ended {
                        info!(job = id, shard = idx, error = %e,
                              "the job ended while its shard was written; dropping the write");
                    } else if !held {
                        warn!(job = id, shard = idx, error = %e,
                              "lost the shard's lease; its last checkpoint failed");
                    } else if is_storage_fault(&e) {
                        self.hold_for_storage(id, "writing a shard's checkpoint", e.to_string());
                    } else {
                        self.fail(id, format!("writing a shard's checkpoint: {e}"));
                    }
                }
            }
            self.discard_if_ended(id, idx);
        }
    }

    /// Removes shard `idx`'s file (and the job's sums kept in memory) when job `id` ended (done,
    /// canceled or failed) or was deleted while it was written: the cleanups at the cancel or
    /// the merge passed it by. (A late writer, slower than its lease, renames after another
    /// worker finished the shard and the merge, which had read every shard file, removed them.)
    fn discard_if_ended(&mut self, id: JobId, idx: u32) {
        let paths = JobPaths::new(&self.config.data_dir, id);
        match self.store.job_state(id) {
            Ok(Some(JobState::Done | JobState::Canceled | JobState::Failed)) => {
                let _ = std::fs::remove_file(paths.shard_checkpoint(idx));
                shard_sums::forget(&paths.dir);
            }
            Ok(None) => {
                let _ = std::fs::remove_dir_all(&paths.dir);
                shard_sums::forget(&paths.dir);
            }
            _ => {}
        }
    }
}
