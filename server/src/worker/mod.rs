//! The GPU worker: one `std::thread` that owns the Vulkan context and every render session, so
//! the async side never touches Vulkan. It reads what to render from the store (queued and
//! running jobs), keeps up to `max_active` sessions on the device, and runs one pass at a time
//! for the job the stride scheduler picks (scheduler.rs), publishing snapshots, progress events
//! and checkpoints at their intervals.
//!
//! Failures: a write that fails for lack of space holds the job paused until space returns
//! (storage_hold.rs); a scene or shader error fails that job; a lost device fails no job: every
//! session is dropped, the device rebuilt and every job resumed from its checkpoint, exactly
//! (device_loss.rs); another device error (a Vulkan call failing, or a panic inside the
//! renderer) fails the job whose pass it was, then the same rebuild resumes the others. A pass
//! far past its expected time shrinks its job's passes, or stops the job (watchdog.rs). On
//! shutdown every active job is checkpointed and stays `running` in the store, to be resumed at
//! the next start.
//!
//! Several workers (processes) may share one store: each job is rendered under a lease the
//! worker claims and renews by heartbeats (store/leases.rs); a job whose lease was lost is
//! dropped unsaved, and the store is looked at every second for changes other processes made.

mod active;
mod auto;
mod checkpoint;
mod device_loss;
mod live_merge;
mod metrics_lane;
mod outcome;
mod reconcile;
mod report;
mod scheduler;
mod shard;
mod shard_sums;
mod shard_write;
mod storage_hold;
mod test_hooks;
mod warmup;
mod watchdog;

use std::collections::{BTreeMap, VecDeque};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;
use std::sync::{mpsc, Arc};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use renderer::accel::AccelRequest;
use renderer::gpu::{GpuContext, GpuError, GpuOptions};
use renderer::prepare::{prepare, PrepareOptions};
use renderer::render::{CompletedPass, RenderError, RenderSession, PIPELINE_DEPTH};
use tracing::{error, info, warn};

use crate::config::ServerConfig;
use crate::jobs::model::{now_s, JobId, JobRecord, JobState, SceneSource};
use crate::shared::{GpuStatus, Shared};
use crate::store::{Claim, JobPaths, Part, Store, StoreError, Transition};
use active::{ActiveJob, CheckpointError};
use metrics_lane::SnapshotImage;
use scheduler::Scheduler;

/// A message to the worker.
enum Msg {
    /// Jobs changed in the store: look again.
    Wake,
    /// Checkpoint everything and stop.
    Shutdown,
}

/// The async side's handle on the worker.
#[derive(Clone)]
pub struct WorkerHandle {
    tx: mpsc::Sender<Msg>,
}

impl WorkerHandle {
    /// Tells the worker that jobs changed (submitted, paused, resumed, canceled, reprioritised).
    pub fn wake(&self) {
        let _ = self.tx.send(Msg::Wake);
    }

    /// Asks the worker to checkpoint its jobs and stop.
    pub fn shutdown(&self) {
        let _ = self.tx.send(Msg::Shutdown);
    }
}

/// A handle on no worker (`candela serve --workers 0`): its messages go nowhere.
pub fn detached() -> WorkerHandle {
    let (tx, _) = mpsc::channel();
    WorkerHandle { tx }
}

/// Starts the worker thread.
pub fn spawn(
    store: Arc<Store>,
    shared: Arc<Shared>,
    config: Arc<ServerConfig>,
) -> std::io::Result<(WorkerHandle, JoinHandle<()>)> {
    let (tx, rx) = mpsc::channel();
    let thread = std::thread::Builder::new()
        .name("gpu-worker".into())
        .spawn(move || {
            let mut worker = Worker {
                store,
                shared,
                config,
                rx,
                ctx: None,
                active: BTreeMap::new(),
                queued: VecDeque::new(),
                sched: Scheduler::default(),
                dirty: true,
                claim_now: false,
                spare: None,
                writes: Vec::new(),
                spare_sums: None,
                device_epoch: Default::default(),
                last_open: None,
                open_failures: 0,
                held: BTreeMap::new(),
                last_storage_check: None,
                loss_trigger: device_loss::trigger_from_env(),
                losses: BTreeMap::new(),
                pipelines_seen: 0,
                last_heartbeat: Instant::now(),
                last_reconcile: Instant::now(),
                started_at: now_s(),
                last_report: None,
            };
            // A panic outside a pass (which is caught where it happens) restarts the loop with
            // a fresh device rather than ending the thread.
            loop {
                match catch_unwind(AssertUnwindSafe(|| worker.run())) {
                    Ok(()) => return,
                    Err(_) => {
                        error!("the GPU worker panicked; rebuilding the device");
                        worker.reset_device("the worker panicked");
                    }
                }
            }
        })?;
    Ok((WorkerHandle { tx }, thread))
}

struct Worker {
    store: Arc<Store>,
    shared: Arc<Shared>,
    config: Arc<ServerConfig>,
    rx: mpsc::Receiver<Msg>,
    ctx: Option<Arc<GpuContext>>,
    active: BTreeMap<JobId, ActiveJob>,
    /// The job of every pass queued on the GPU, oldest first (all sessions share the queue:
    /// passes complete in this order).
    queued: VecDeque<JobId>,
    sched: Scheduler,
    /// The store may hold changes the worker has not looked at.
    dirty: bool,
    /// Look at the store without waiting for a message (a shard just finished: claim more).
    claim_now: bool,
    /// The session of the shard this worker finished last, for the job's next part (shard.rs).
    spare: Option<(JobId, RenderSession)>,
    /// Finished shards' final checkpoints being written (shard_write.rs).
    writes: Vec<shard_write::ShardWrite>,
    /// The host-visible buffer of the last finished write, for the next shard's sums.
    spare_sums: Option<renderer::render::HostAccumulation>,
    /// Bumped at each device reset: a shard write under way then does not trust its sums
    /// (shard_write.rs).
    device_epoch: Arc<std::sync::atomic::AtomicU64>,
    /// The last attempt to create the device, and failures in a row.
    last_open: Option<Instant>,
    open_failures: u32,
    /// Jobs held for a storage fault, with the reason (storage_hold.rs).
    held: BTreeMap<JobId, String>,
    last_storage_check: Option<Instant>,
    /// Test hook: lose the device when this file exists (device_loss.rs).
    loss_trigger: Option<PathBuf>,
    /// Device losses in a row during each job's work (device_loss.rs).
    losses: BTreeMap<JobId, u32>,
    /// Pipeline objects alive at the last [`Worker::publish_caches`].
    pipelines_seen: u64,
    /// When the leases were last renewed (store/leases.rs).
    last_heartbeat: Instant,
    /// When the worker last looked at the store (other processes change it unannounced).
    last_reconcile: Instant,
    /// Unix seconds at the start, and the counters at the last report (report.rs).
    started_at: f64,
    last_report: Option<report::LastReport>,
}

/// How often a busy worker looks at the store for jobs other processes submitted, paused or
/// canceled (an idle one looks every half second).
const RECONCILE_EVERY: Duration = Duration::from_secs(1);

/// Whether an error means the device itself is in doubt (rebuild it).
fn is_device_error(e: &RenderError) -> bool {
    matches!(
        e,
        RenderError::Gpu(GpuError::Vk { .. } | GpuError::Other(_) | GpuError::DeviceLost { .. })
    )
}

impl Worker {
    fn run(&mut self) {
        loop {
            // Step 1: messages; block only when there is nothing to render.
            // (Shard writes under way: look at them often, to claim as soon as one ends.)
            let idle_wait = if self.writes.is_empty() { 500 } else { 10 };
            let first = if self.sched.len() == 0 && !std::mem::take(&mut self.claim_now) {
                match self.rx.recv_timeout(Duration::from_millis(idle_wait)) {
                    Ok(m) => Some(m),
                    Err(mpsc::RecvTimeoutError::Timeout) => {
                        self.dirty |= self.writes.is_empty();
                        None
                    }
                    Err(mpsc::RecvTimeoutError::Disconnected) => Some(Msg::Shutdown),
                }
            } else {
                self.rx.try_recv().ok()
            };
            let msgs: Vec<Msg> = first.into_iter().chain(self.rx.try_iter()).collect();
            for msg in msgs {
                match msg {
                    Msg::Wake => self.dirty = true,
                    Msg::Shutdown => {
                        self.shutdown();
                        return;
                    }
                }
            }
            // Shards whose final checkpoint is now on disk: done (shard_write.rs).
            self.collect_writes(0);
            // Step 2: the leases renewed; jobs taken over by another worker dropped.
            if self.last_heartbeat.elapsed() >= self.config.heartbeat {
                self.heartbeat();
            }
            if self.last_reconcile.elapsed() >= RECONCILE_EVERY {
                self.dirty = true;
            }
            // Step 3: free space (and held jobs resumed when it returns).
            self.check_storage();
            // Step 4: a device.
            if self.ctx.is_none() && !self.open_device() {
                continue;
            }
            // Step 5: which jobs to render.
            if self.dirty {
                self.dirty = false;
                self.last_reconcile = Instant::now();
                self.reconcile();
            }
            // Step 6: one pass of the job the scheduler picks.
            if let Some(id) = self.sched.pick() {
                self.step(id);
            }
        }
    }

    /// Creates the device; after failures, retries with exponential backoff (2 s to 60 s).
    fn open_device(&mut self) -> bool {
        let wait = Duration::from_secs((2u64 << self.open_failures.min(5)).min(60));
        if self.last_open.is_some_and(|t| t.elapsed() < wait) {
            return false;
        }
        self.last_open = Some(Instant::now());
        let opts = GpuOptions {
            device: self.config.device.clone(),
            index: self.config.device_index,
            validation: self.config.validation,
            kernel_cache: self.config.kernel_cache.clone(),
        };
        match catch_unwind(|| GpuContext::new(&opts)) {
            Ok(Ok(ctx)) => {
                info!(device = %ctx.info.name, driver = %ctx.info.driver, "GPU ready");
                self.shared.set_gpu(GpuStatus {
                    state: "ready",
                    device: Some(ctx.info.clone()),
                    error: None,
                });
                let ctx = Arc::new(ctx);
                warmup::start(&ctx, &self.config, &self.shared);
                self.ctx = Some(ctx);
                self.publish_caches();
                self.report(false);
                self.dirty = true;
                self.open_failures = 0;
                true
            }
            Ok(Err(e)) => {
                error!(error = %e, "no GPU; retrying");
                self.set_unavailable(e.to_string());
                self.open_failures += 1;
                false
            }
            Err(_) => {
                error!("creating the GPU context panicked; retrying");
                self.set_unavailable("creating the GPU context panicked".into());
                self.open_failures += 1;
                false
            }
        }
    }

    fn set_unavailable(&self, error: String) {
        self.shared.set_gpu(GpuStatus {
            state: "unavailable",
            device: None,
            error: Some(error),
        });
    }

    /// Drops every session and the device; the jobs stay running and resume from checkpoints.
    fn reset_device(&mut self, why: &str) {
        warn!(why, "resetting the GPU device");
        self.queued.clear();
        self.active.clear();
        self.sched.clear();
        self.spare = None;
        self.spare_sums = None;
        self.device_epoch
            .fetch_add(1, std::sync::atomic::Ordering::SeqCst);
        self.ctx = None;
        self.last_open = None;
        self.dirty = true;
        self.set_unavailable(format!("restarting after: {why}"));
        self.publish_caches();
    }

    /// Publishes the renderer's cache sizes for /metrics (after they may have changed); when
    /// pipelines were destroyed since the last look (evicted, and no job holds them), hands
    /// the heap pages they freed back to the system.
    fn publish_caches(&mut self) {
        let stats = renderer::caches::stats(self.ctx.as_deref());
        if stats.pipelines_live < self.pipelines_seen {
            crate::process_memory::release_free_heap();
        }
        self.pipelines_seen = stats.pipelines_live;
        self.shared.set_caches(stats);
    }

    /// Creates the session of a runnable job (restoring its checkpoint) and schedules it; of
    /// one shard of it, or of the merge of its shards, when the claim says so (shard.rs).
    fn admit(&mut self, claim: Claim) {
        let Claim {
            id,
            state,
            priority,
            part,
        } = claim;
        let Some(ctx) = self.ctx.clone() else { return };
        let (rec, text) = match (self.store.get_job(id), self.store.get_scene(id)) {
            (Ok(r), Ok(t)) => (r, t),
            (Err(e), _) | (_, Err(e)) => return error!(job = id, error = %e, "reading job"),
        };
        let paths = JobPaths::new(&self.config.data_dir, id);
        let s = rec.settings.clone();
        // Steps 1-2: the session (of the job's last shard this worker rendered, reset, when this
        // is another part of that job: shard.rs).
        let (mut session, auto_run) = match self.take_spare(id, part, s.seed) {
            Some(session) => (session, None),
            None => match self.make_session(id, &rec, &text, &paths, &ctx) {
                Some(made) => made,
                None => return,
            },
        };
        let ckpt = match part {
            Part::Shard { range, .. } => paths.shard_checkpoint(range.idx),
            _ => paths.checkpoint(),
        };
        let mut merged_sums = None;
        // (A job with a quality target keeps its restored sums for one check: check_restored.)
        let mut restored = None;
        if let Part::Merge { count } = part {
            let t0 = std::time::Instant::now();
            match shard::merged(&self.store, &session, &s, &paths, id) {
                Ok(Some(((acc, progress), from_memory))) => {
                    let t_read = t0.elapsed();
                    if let Err(e) = session.restore(&acc, progress) {
                        return self.render_failed(id, e, "restoring the merged shards");
                    }
                    info!(
                        job = id,
                        shards = count,
                        from_memory,
                        spp = progress.spp,
                        read_add_ms = shard::ms(t_read),
                        restore_ms = shard::ms(t0.elapsed() - t_read),
                        "merged the shards"
                    );
                    merged_sums = Some((progress.spp, acc));
                }
                // A shard to render again: the merge's lease goes at the next heartbeat.
                Ok(None) => return,
                Err(shard::MergeError::Store(e)) => {
                    return error!(job = id, error = %e, "merging the shards")
                }
                Err(shard::MergeError::Unusable(why)) => return self.fail(id, why),
            }
        } else if ckpt.exists() {
            let entries = session.accumulation_len();
            match checkpoint::read(&ckpt, s.width, s.height, s.seed, entries) {
                Ok((progress, acc)) => {
                    if let Err(e) = session.restore(&acc, progress) {
                        return self.render_failed(id, e, "restoring the checkpoint");
                    }
                    info!(job = id, spp = progress.spp, "resumed from checkpoint");
                    if s.until_rel_mse.is_some() {
                        restored = Some(acc);
                    }
                }
                Err(e) => warn!(job = id, error = %e, "ignoring unusable checkpoint"),
            }
        }
        // Step 3: mark it running (it may have been paused or canceled meanwhile).
        if state == JobState::Queued {
            let t = Transition {
                verb: "start",
                ..Default::default()
            };
            match self.store.transition(id, JobState::Running, t) {
                Ok(_) => {
                    if rec.started_at.is_none() {
                        self.shared.observe_queue_wait(now_s() - rec.created_at);
                    }
                }
                // Another shard's worker started it first.
                Err(StoreError::Conflict {
                    state: JobState::Running,
                    ..
                }) if matches!(part, Part::Shard { .. }) => {}
                Err(StoreError::Conflict { .. }) | Err(StoreError::NotFound(_)) => return,
                Err(e) => return error!(job = id, error = %e, "starting job"),
            }
        }
        info!(job = id, name = %rec.name, "rendering");
        // New pipelines go to the kernel cache folder, off this thread.
        ctx.save_pipeline_cache_later();
        let job_spp = s.spp.unwrap_or(1);
        let mut job = ActiveJob::new(session, s, paths);
        if let Some(acc) = restored {
            job.check_restored(&acc);
        }
        match part {
            Part::Shard { range, count } => {
                info!(
                    job = id,
                    shard = range.idx,
                    first = range.first,
                    samples = range.samples,
                    "rendering a shard"
                );
                job.settings.spp = Some(range.samples);
                job.shard = Some(shard::ShardRun {
                    range,
                    count,
                    job_spp,
                    others_spp: 0,
                    merge_every: self.config.checkpoint_interval,
                    image_written: false,
                });
            }
            Part::Merge { count } => {
                job.merged_shards = Some(count);
                job.merged_sums = merged_sums;
            }
            Part::Whole => {}
        }
        if let Some((run, fresh)) = auto_run {
            if fresh {
                info!(job = id, choice = %run.report["choice"], "auto: pilot done");
                let _ = self.store.append_event(id, "auto", run.report.clone());
            }
            job.set_auto(run);
        }
        self.active.insert(id, job);
        self.sched.add(id, priority);
        self.publish_caches();
    }

    /// A new session of job `rec` (scene `text`): the scene loaded and prepared for the job's
    /// film, the session made (`auto`: by the pilot, auto.rs). None: the job failed.
    fn make_session(
        &mut self,
        id: JobId,
        rec: &JobRecord,
        text: &str,
        paths: &JobPaths,
        ctx: &Arc<GpuContext>,
    ) -> Option<(RenderSession, Option<(auto::AutoRun, bool)>)> {
        let s = &rec.settings;
        // Step 1: scene, compiled for this film.
        let base = match rec.source {
            SceneSource::Inline => None,
            SceneSource::Builtin => Some(self.config.builtin_dir()),
            SceneSource::Upload => Some(paths.assets()),
        };
        let limits = self.config.limits.scene_limits();
        let load_start = std::time::Instant::now();
        let scene = match renderer::scene::load_str_with_limits(text, base.as_deref(), &limits) {
            Ok(s) => s,
            Err(e) => {
                self.fail(id, format!("scene: {e}"));
                return None;
            }
        };
        // The request's film and accel (else the scene's); structures built once per scene in
        // the data dir's cache.
        let cache = self.config.data_dir.join("accel-cache");
        let options = PrepareOptions {
            width: Some(s.width),
            height: Some(s.height),
            limits: self.config.limits.film,
            accel: AccelRequest {
                kind: s.accel.as_ref().map(|a| a.kind.as_str()),
                grid_resolution: s.accel.as_ref().and_then(|a| a.grid_resolution),
            },
            cache: Some(&cache),
            kernels: s.kernels,
            load_time: load_start.elapsed(),
            expand_instances: !s.auto && renderer::prepare::expands_instances(&s.integrator),
            max_triangles: Some(limits.max_triangles as u64),
        };
        let prepared = match prepare(&scene, &options) {
            Ok(p) => p,
            Err(e) => {
                self.fail(id, e.to_string());
                return None;
            }
        };
        drop(scene);
        // Step 2: the session.
        // (`auto`: the saved choice's integrator, else the pilot's winner; auto.rs.)
        let made = catch_unwind(AssertUnwindSafe(|| {
            if s.auto {
                auto::session(&prepared, ctx, s, paths)
                    .map(|(x, run, fresh)| (x, Some((run, fresh))))
            } else {
                prepared
                    .session(ctx, &s.integrator, s.seed)
                    .map(|x| (x, None))
            }
        }));
        match made {
            Ok(Ok(made)) => Some(made),
            Ok(Err(e)) => {
                self.render_failed(id, e, "creating the render session");
                None
            }
            Err(_) => {
                self.panicked(id, "creating the render session");
                None
            }
        }
    }

    /// Drops the session of a job that left the runnable states, saving what it rendered.
    fn retire(&mut self, id: JobId) {
        self.sched.remove(id);
        self.queued.retain(|j| *j != id);
        let Some(mut job) = self.active.remove(&id) else {
            return;
        };
        // (Test hook: the job may be resumed meanwhile, as between two looks at the store.)
        test_hooks::hold("CANDELA_TEST_RETIRE_HOLD_FILE", "retire held");
        match self.store.get_job(id).map(|r| r.state) {
            // Paused, or paused and already resumed (queued again) since the runnable jobs
            // were read: either way it runs again from this checkpoint.
            Ok(state @ (JobState::Paused | JobState::Queued)) => match job.write_checkpoint() {
                Ok(p) => {
                    shard::record_progress(&self.store, &self.config.worker_id, id, &mut job, &p);
                    info!(
                        job = id,
                        spp = p.spp,
                        state = state.as_str(),
                        "paused and checkpointed"
                    );
                }
                Err(e) => self.checkpoint_failed(id, e),
            },
            Ok(JobState::Canceled) => {
                if let Ok(img) = job.session.image() {
                    let _ = job.write_image(&img);
                }
                if job.shard.is_none() {
                    let _ = self.store.set_progress(id, &job.session.progress());
                }
                // (Every shard's: the job ended, and the other shards' files are of no use.)
                job.remove_checkpoints();
                info!(job = id, "canceled");
            }
            // Failed by another worker (a shard of it): its files are of no use.
            Ok(JobState::Failed) => job.remove_checkpoints(),
            _ => {}
        }
        // Canceled and deleted before (or while) the worker let go of it: a checkpoint or image
        // it wrote meanwhile would be left in a folder of no job (found by bench/soak.py).
        if matches!(self.store.get_job(id), Err(StoreError::NotFound(_))) {
            if let Err(e) = std::fs::remove_dir_all(&job.paths.dir) {
                if e.kind() != std::io::ErrorKind::NotFound {
                    warn!(job = id, error = %e, "removing a deleted job's files");
                }
            }
            info!(
                job = id,
                "deleted while the worker held it; its files removed"
            );
        }
        job.flush_metrics();
        self.shared.forget(id);
        live_merge::forget(&job.paths.dir);
        drop(job);
        self.publish_caches();
    }

    /// Queues the next pass of job `id` behind the passes in flight (after completing the
    /// oldest when [`PIPELINE_DEPTH`] are queued), so the GPU always has the next pass; a job
    /// with nothing left to queue waits for its queued passes and finishes.
    fn step(&mut self, id: JobId) {
        // Step 1: room in the queue, by completing the oldest pass (whichever job's).
        while self.queued.len() >= PIPELINE_DEPTH {
            self.complete_oldest();
        }
        // Passes of a third of the snapshot interval at most, and a snapshot asked for with the
        // pass that starts closest to the interval after the last: the cadence is honoured
        // whatever the pass size.
        let interval = self.config.snapshot_interval;
        let target = self.config.pass_target.min(interval / 3);
        let Some(job) = self.active.get_mut(&id) else {
            return self.sched.remove(id);
        };
        // Step 2: the pass's size; nothing left to queue: complete this job's passes.
        let spp = job.next_pass_spp(target);
        if spp == 0 {
            while self
                .active
                .get(&id)
                .is_some_and(|j| j.session.in_flight() > 0)
                && !self.queued.is_empty()
            {
                self.complete_oldest();
            }
            if self.active.get(&id).is_some_and(|j| j.finished()) {
                self.finish(id);
            }
            return;
        }
        // Step 3: queue it, with a copy of the accumulation when a snapshot is due, and the
        // error estimate computed on the GPU when it ends at a check point of the job's quality
        // target (renderer/src/render/until.rs). (A shard has no live snapshots: its
        // checkpoints write the merged image.)
        let snapshot = job.shard.is_none() && job.snapshot_due(interval.saturating_sub(target / 2));
        let check = job.check_due(spp);
        let end = job.session.submitted_spp() + spp;
        if let Some(sh) = &job.shard {
            // A shard's passes take the next indices of its range.
            let next = sh.range.first + job.session.submitted_spp();
            job.session.set_next_sample(next);
        }
        let result = catch_unwind(AssertUnwindSafe(|| {
            job.session.submit_pass_with(spp, snapshot, check)
        }));
        let done = match result {
            Ok(Ok(done)) => done,
            Ok(Err(e)) => return self.render_failed(id, e, "render pass"),
            Err(_) => return self.panicked(id, "render pass"),
        };
        if check {
            job.check_queued(end);
        }
        if snapshot {
            job.last_snapshot = Some(Instant::now());
        }
        job.report_flags.push_back(snapshot);
        self.queued.push_back(id);
        for p in done {
            self.after_pass(id, p);
        }
    }

    /// Waits for the oldest queued pass and handles it.
    fn complete_oldest(&mut self) {
        let Some(id) = self.queued.pop_front() else {
            return;
        };
        let Some(job) = self.active.get_mut(&id) else {
            return;
        };
        let result = catch_unwind(AssertUnwindSafe(|| job.session.complete_oldest()))
            .map(|r| self.injected_loss(r));
        match result {
            Ok(Ok(Some(p))) => self.after_pass(id, p),
            Ok(Ok(None)) => {}
            Ok(Err(e)) => self.render_failed(id, e, "render pass"),
            Err(_) => self.panicked(id, "render pass"),
        }
    }

    /// A pass of job `id` completed: counters, scheduling, its snapshot, and whatever falls
    /// due (the end, a checkpoint).
    fn after_pass(&mut self, id: JobId, p: CompletedPass) {
        let Some(job) = self.active.get_mut(&id) else {
            return;
        };
        let stats = p.stats;
        job.record_pass(&stats);
        let report = job.report_flags.pop_front().unwrap_or(true);
        let pixels = job.settings.width as u64 * job.settings.height as u64;
        let busy = if stats.gpu.is_zero() {
            stats.wall
        } else {
            stats.gpu
        };
        // GPU time where known: a pass's wall time may include another job's pass ahead of it.
        self.sched.charge(id, busy.as_secs_f64());
        let verdict = job
            .watch
            .observe(stats.spp, busy.as_secs_f64(), &self.config.pass_limits);
        // Its losses in a row end (device_loss.rs).
        self.losses.remove(&id);
        use std::sync::atomic::Ordering::Relaxed;
        self.shared
            .samples_total
            .fetch_add(stats.spp as u64 * pixels, Relaxed);
        self.shared
            .gpu_busy_ns
            .fetch_add(busy.as_nanos() as u64, Relaxed);
        self.shared.passes_total.fetch_add(1, Relaxed);
        if !self.watchdog(id, verdict) {
            return;
        }
        let Some(job) = self.active.get_mut(&id) else {
            return;
        };
        // A quality target's check: the estimate the pass computed on the GPU.
        if let Some(e) = p.estimate {
            job.observe_estimate(e.spp, e.rel_mse);
        }
        let snapshot = p.snapshot.map(SnapshotImage::Accum);
        // The last pass's image is the final one, which `finish` reports.
        if job.finished() {
            return self.finish(id);
        }
        if let Some(snap) = snapshot.filter(|_| report) {
            self.snapshot(id, snap);
        }
        let Some(job) = self.active.get_mut(&id) else {
            return;
        };
        if job.checkpoint_due(self.config.checkpoint_interval) {
            self.save_checkpoint(id);
        }
    }

    /// Checkpoints every active job (they stay `running` and resume at the next start).
    fn shutdown(&mut self) {
        // Finished shards are recorded done before the leases go.
        self.collect_writes(usize::MAX);
        let ids: Vec<JobId> = self.active.keys().copied().collect();
        for id in ids {
            if let Some(job) = self.active.get_mut(&id) {
                match job.write_checkpoint() {
                    Ok(p) => {
                        shard::record_progress(&self.store, &self.config.worker_id, id, job, &p);
                        info!(job = id, spp = p.spp, "checkpointed for shutdown");
                    }
                    Err(CheckpointError::Io(e)) => error!(job = id, error = %e, "checkpoint"),
                    Err(CheckpointError::Render(e)) => error!(job = id, error = %e, "checkpoint"),
                }
            }
        }
        self.queued.clear();
        self.active.clear();
        self.sched.clear();
        self.report(true);
        self.spare = None;
        self.spare_sums = None;
        self.ctx = None;
        // Checkpointed: another worker (or this one, restarted) may take the jobs at once.
        if let Err(e) = self
            .store
            .renew_leases(&self.config.worker_id, &[], self.config.lease)
        {
            warn!(error = %e, "giving up the render leases");
        }
    }
}
