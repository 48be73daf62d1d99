//! One job being rendered by the worker: its [`RenderSession`], the pass sizing, and what it
//! reports — progress (with an ETA that accounts for sharing the GPU), checkpoints and images.

use std::sync::Arc;
use std::time::{Duration, Instant};

use renderer::film::Image;
use renderer::metrics::{tonemap_from_name, Display};
use renderer::render::{
    Budget, PassSizer, PassStats, Progress, RenderError, RenderSession, StopReason, UntilChecks,
};
use renderer::scene::Tonemap;
use serde_json::{json, Value};

use super::checkpoint;
use super::metrics_lane::{LaneTargets, MetricsLane, SnapshotImage};
use super::shard::ShardRun;
use super::watchdog::PassWatch;
use crate::jobs::model::{JobId, JobSettings};
use crate::shared::Shared;
use crate::store::{JobPaths, Store};

/// Why writing a checkpoint failed.
#[derive(Debug)]
pub enum CheckpointError {
    /// Reading the accumulation back from the device.
    Render(RenderError),
    /// Writing the files.
    Io(std::io::Error),
}

/// A job with a live render session.
pub struct ActiveJob {
    pub session: RenderSession,
    pub settings: JobSettings,
    pub paths: JobPaths,
    /// Sizes the passes from the cost of the last one.
    sizer: PassSizer,
    /// Pass times against the watchdog's limit, and the cap it set (watchdog.rs).
    pub watch: PassWatch,
    /// When the last snapshot was asked for (None: with the next pass).
    pub last_snapshot: Option<Instant>,
    pub last_checkpoint: Instant,
    /// When the session was created, and the counters then (for the ETA).
    admitted: Instant,
    spp_at_admit: u32,
    time_at_admit: f64,
    /// The reference image of the progress metrics (None: no reference, or it is unreadable).
    reference: Option<Arc<Image>>,
    /// The thread reporting snapshots (started with the first snapshot).
    lane: Option<MetricsLane>,
    /// The latest relMSE estimate (no reference): an `until` job's latest check, and the
    /// final one.
    pub estimate: Option<f64>,
    /// The quality target (`until`) and its checks (renderer::render::UntilChecks): passes
    /// end at its check points, which compute the estimate on the GPU.
    checks: Option<UntilChecks>,
    /// For each queued pass, oldest first: whether its snapshot is to be reported.
    pub report_flags: std::collections::VecDeque<bool>,
    /// An `auto` job's choice (auto.rs), for its stats.
    pub auto: Option<super::auto::AutoRun>,
    /// The shard this session renders, for a job split over workers (its `settings.spp` is
    /// then the shard's sample count; shard.rs).
    pub shard: Option<ShardRun>,
    /// A split job whose shards this session merged: how many (their files go at the end).
    pub merged_shards: Option<u32>,
    /// The merged shards' sums as restored, and their spp: the final image is resolved from
    /// them (no read-back) while the session still holds exactly them.
    pub merged_sums: Option<(u32, Vec<[f32; 4]>)>,
}

impl ActiveJob {
    /// Wraps a session (fresh or restored).
    pub fn new(session: RenderSession, settings: JobSettings, paths: JobPaths) -> Self {
        let p = session.progress();
        let reference = settings.reference.as_ref().and_then(|path| {
            renderer::film::read_exr(std::path::Path::new(path))
                .map_err(|e| tracing::warn!(path, error = %e, "reading the reference image"))
                .ok()
                .map(Arc::new)
        });
        ActiveJob {
            reference,
            lane: None,
            estimate: None,
            checks: settings.until_rel_mse.map(UntilChecks::new),
            report_flags: Default::default(),
            auto: None,
            shard: None,
            merged_shards: None,
            merged_sums: None,
            session,
            settings,
            paths,
            sizer: PassSizer::default(),
            watch: PassWatch::default(),
            last_snapshot: None,
            last_checkpoint: Instant::now(),
            admitted: Instant::now(),
            spp_at_admit: p.spp,
            time_at_admit: p.time_s,
        }
    }

    /// Makes this an `auto` job with the choice `run`: a time budget loses the other pilots'
    /// time (the winner's own pilot time is in its session).
    pub fn set_auto(&mut self, run: super::auto::AutoRun) {
        if let Some(t) = &mut self.settings.time_s {
            *t = (*t - run.spent_elsewhere_s).max(0.0);
        }
        self.auto = Some(run);
    }

    /// Whether the budget (or the quality target) is reached and every queued pass has
    /// completed.
    pub fn finished(&self) -> bool {
        self.stop_reason().is_some() && self.session.in_flight() == 0
    }

    /// Why the job stops, once it does: its quality target, else its spp or time cap.
    pub fn stop_reason(&self) -> Option<StopReason> {
        if self.checks.as_ref().is_some_and(|c| c.reached) {
            return Some(StopReason::RelMse);
        }
        match self.settings.budget() {
            Budget::Spp(n) => (self.session.spp() >= n).then_some(StopReason::Spp),
            Budget::Time(t) => {
                (self.session.elapsed().as_secs_f64() >= t).then_some(StopReason::Time)
            }
        }
    }

    /// Notes the estimate a pass computed at `spp` samples per pixel (a check point), and
    /// whether it reaches the job's quality target ([`renderer::render::target_reached`]).
    pub fn observe_estimate(&mut self, spp: u32, estimate: Option<f64>) {
        self.estimate = estimate;
        if let Some(c) = &mut self.checks {
            c.observe(spp, estimate);
        }
    }

    /// A job resumed from a checkpoint that ends exactly at a check point of its quality target
    /// makes that check now, from the restored sums `acc`: the interrupted render may have
    /// stopped before it saw the check's result, and without it the resumed job would render
    /// on to the next check point, past where an uninterrupted one stops.
    pub fn check_restored(&mut self, acc: &[[f32; 4]]) {
        let spp = self.session.spp();
        if self.checks.is_none() || !renderer::render::is_check_point(spp) {
            return;
        }
        let image = self.session.resolve(acc);
        let estimate = self.session.estimate_spp(acc, spp, &image);
        self.observe_estimate(spp, estimate);
    }

    /// Whether the next pass, of `spp` samples, ends at a check point of the quality target
    /// (it is then queued with the estimate: [`Self::check_queued`]).
    pub fn check_due(&self, spp: u32) -> bool {
        let submitted = self.session.submitted_spp();
        self.checks
            .as_ref()
            .is_some_and(|c| c.is_check(submitted, spp))
    }

    /// Notes that a pass computing the estimate at check point `spp` was queued: nothing more
    /// is queued until its result.
    pub fn check_queued(&mut self, spp: u32) {
        if let Some(c) = &mut self.checks {
            c.queued(spp);
        }
    }

    /// Samples per pixel of the next pass, sized from the last one to take about `target` and
    /// never past the budget, counting the passes still queued; 0 when no more should be
    /// queued (yet: the first pass is queued alone, until it shows what a sample costs).
    /// Never above the watchdog's cap.
    pub fn next_pass_spp(&mut self, target: Duration) -> u32 {
        let n = self.sized_pass_spp(target);
        self.watch.cap.map_or(n, |cap| n.min(cap))
    }

    fn sized_pass_spp(&mut self, target: Duration) -> u32 {
        let submitted = self.session.submitted_spp();
        if !self.sizer.knows_cost() && self.session.in_flight() > 0 {
            return 0; // the first pass's cost first
        }
        // A quality target: no pass past its next check point, none while one is awaited, and
        // none once it is reached.
        let limit = self.checks.as_ref().map(|c| c.pass_limit(submitted));
        if limit == Some(0) {
            return 0;
        }
        let n = self.budget_pass_spp(target, submitted);
        limit.map_or(n, |c| n.min(c))
    }

    /// [`Self::next_pass_spp`] from the budget alone.
    fn budget_pass_spp(&mut self, target: Duration, submitted: u32) -> u32 {
        match self.settings.budget() {
            Budget::Spp(total) => match total.saturating_sub(submitted) {
                0 => 0,
                left => self.sizer.next(target).min(left),
            },
            Budget::Time(t) => {
                let queued = self.sizer.seconds(submitted - self.session.spp());
                let left = t - self.session.elapsed().as_secs_f64() - queued;
                if left <= 0.0 && submitted > 0 {
                    0
                } else {
                    self.sizer
                        .next(target.min(Duration::from_secs_f64(left.max(0.0))))
                }
            }
        }
    }

    /// Notes a pass that completed.
    pub fn record_pass(&mut self, stats: &PassStats) {
        self.sizer.observe(stats);
    }

    /// The session, the job done with (its metrics flushed first).
    pub fn into_session(self) -> RenderSession {
        self.session
    }

    /// Seconds since the job was admitted (about since its lease was claimed).
    pub fn held_s(&self) -> f64 {
        self.admitted.elapsed().as_secs_f64()
    }

    /// Whether a snapshot is due.
    pub fn snapshot_due(&self, interval: Duration) -> bool {
        self.last_snapshot.is_none_or(|t| t.elapsed() >= interval)
    }

    /// Whether a checkpoint is due.
    pub fn checkpoint_due(&self, interval: Duration) -> bool {
        self.last_checkpoint.elapsed() >= interval
    }

    /// The data of a `progress` event.
    pub fn progress_json(&self) -> Value {
        // (Not the session's whole stats: see `rates`.)
        let (msamples_per_s, rays_per_s) = self.session.rates();
        let p = self.session.progress();
        // Wall-clock seconds per unit of work since admission: includes the time other jobs
        // held the GPU, so the ETA reflects the current share.
        let wall = self.admitted.elapsed().as_secs_f64();
        let (target_spp, eta_s, fraction) = match self.settings.budget() {
            Budget::Spp(n) => {
                let done = p.spp.saturating_sub(self.spp_at_admit);
                let left = n.saturating_sub(p.spp) as f64;
                let eta = (done > 0).then(|| left * wall / done as f64);
                (Some(n), eta, p.spp as f64 / n.max(1) as f64)
            }
            Budget::Time(t) => {
                let own = p.time_s - self.time_at_admit;
                let left = (t - p.time_s).max(0.0);
                let eta = (own > 0.0).then(|| left * wall / own);
                (None, eta, p.time_s / t.max(1e-9))
            }
        };
        // A shard reports the job's figures: every shard's samples, of the job's.
        let (spp, target_spp, fraction) = match &self.shard {
            Some(sh) => {
                let all = sh.others_spp + p.spp;
                (all, Some(sh.job_spp), all as f64 / sh.job_spp.max(1) as f64)
            }
            None => (p.spp, target_spp, fraction),
        };
        json!({
            "spp": spp,
            "shard": self.shard.as_ref().map(|sh| super::shard::shard_json(sh, p.spp)),
            "target_spp": target_spp,
            "time_s": self.settings.time_s,
            "elapsed_s": p.time_s,
            "passes": p.passes,
            "msamples_per_s": msamples_per_s,
            "rays_per_s": rays_per_s,
            "eta_s": eta_s,
            "fraction": fraction.min(1.0),
            "dropped_samples": p.dropped_samples,
            "rel_mse_estimate": self.estimate,
            "until_rel_mse": self.settings.until_rel_mse,
        })
    }

    /// How the reference and the snapshots are compared (the job's exposure and tonemap).
    fn display(&self) -> Display {
        Display {
            exposure_ev: self.settings.exposure,
            tonemap: tonemap_from_name(&self.settings.tonemap).unwrap_or(Tonemap::Clamp),
        }
    }

    /// Reports a snapshot of `spp` samples per pixel: its image is resolved and published, and
    /// its `progress` event ([`Self::progress_json`], plus `metrics` against the reference and
    /// `metrics_note` the first time) and `snapshot` event appended, on the job's
    /// [`MetricsLane`] (inline if its thread could not start); call [`Self::flush_metrics`]
    /// before events that must come after them, and before forgetting the published image.
    pub fn report_snapshot(
        &mut self,
        store: &Arc<Store>,
        shared: &Arc<Shared>,
        id: JobId,
        image: SnapshotImage,
        spp: u32,
        snapshot: Value,
    ) {
        let progress = self.progress_json();
        let reference = self.reference.clone().map(|r| (r, self.display()));
        let lane = self.lane.get_or_insert_with(|| {
            MetricsLane::start(
                id,
                LaneTargets {
                    store: store.clone(),
                    shared: shared.clone(),
                    reference,
                },
            )
        });
        lane.submit(image, spp, progress, snapshot);
    }

    /// Waits until the metrics lane has appended every snapshot's events.
    pub fn flush_metrics(&self) {
        if let Some(lane) = &self.lane {
            lane.flush();
        }
    }

    /// The job's shards (of its split: the one rendered, or the ones merged), or 0.
    pub fn shard_count(&self) -> u32 {
        self.shard
            .map_or(self.merged_shards.unwrap_or(0), |sh| sh.count)
    }

    /// Removes the job's checkpoint files: its own and every shard's (a job that ended).
    pub fn remove_checkpoints(&self) {
        self.paths.remove_checkpoints(self.shard_count());
    }

    /// The checkpoint file: the job's, or its shard's.
    pub fn checkpoint_path(&self) -> std::path::PathBuf {
        match &self.shard {
            Some(sh) => self.paths.shard_checkpoint(sh.range.idx),
            None => self.paths.checkpoint(),
        }
    }

    /// Writes the checkpoint and the image it implies (a shard's: merged with the other
    /// shards' latest checkpoints, at live_merge's cadence); returns the progress saved.
    pub fn write_checkpoint(&mut self) -> Result<Progress, CheckpointError> {
        crate::storage::injected_fault().map_err(CheckpointError::Io)?;
        let t0 = Instant::now();
        // (Waits for the job's queued passes.)
        let mut acc = self
            .session
            .accumulation()
            .map_err(CheckpointError::Render)?;
        let progress = self.session.progress();
        let (w, h) = (self.settings.width, self.settings.height);
        let t_readback = t0.elapsed();
        checkpoint::write(
            &self.checkpoint_path(),
            w,
            h,
            self.settings.seed,
            &progress,
            &acc,
            true,
        )
        .map_err(CheckpointError::Io)?;
        let t_file = t0.elapsed();
        match self.shard {
            None => {
                let image = self.session.resolve(&acc);
                self.write_image(&image)?;
            }
            Some(sh) => {
                // (Rebuilt only at live_merge's cadence: it reads every other shard's file.)
                // (The shards this process finished come from its memory, shard_sums.rs.)
                let ticket = super::live_merge::try_begin(&self.paths.dir, sh.merge_every);
                if ticket.is_some() {
                    let layout =
                        super::shard_sums::Layout::of(&self.settings, &self.session, sh.count);
                    let (kept, kept_spp) = super::shard_sums::add_kept_into(
                        &self.paths.dir,
                        &layout,
                        sh.range.idx,
                        &mut acc,
                    )
                    .unwrap_or_default();
                    let others = super::shard::add_shards(
                        &self.session,
                        &self.settings,
                        &self.paths,
                        (0..sh.count).filter(|k| *k != sh.range.idx && !kept.contains(k)),
                        &mut acc,
                    );
                    let spp = progress.spp
                        + kept_spp
                        + others
                            .iter()
                            .filter_map(|(_, r)| r.as_ref().ok().map(|p| p.spp))
                            .sum::<u32>();
                    let image = self.session.resolve_spp(&acc, spp);
                    self.write_image(&image)?;
                }
                if let Some(s) = &mut self.shard {
                    s.image_written = ticket.is_some();
                }
            }
        }
        self.last_checkpoint = Instant::now();
        tracing::debug!(
            readback_ms = super::shard::ms(t_readback),
            file_ms = super::shard::ms(t_file - t_readback),
            image_ms = super::shard::ms(t0.elapsed() - t_file),
            "checkpoint"
        );
        Ok(progress)
    }

    /// Time since this session was admitted (created or reused for this part of the job).
    pub fn since_admit(&self) -> Duration {
        self.admitted.elapsed()
    }

    /// Writes `image` as the job's on-disk image (EXR, atomically).
    pub fn write_image(&self, image: &Image) -> Result<(), CheckpointError> {
        Self::write_image_to(&self.paths, image)
    }

    /// [`Self::write_image`] for the job of `paths` (from another thread).
    pub fn write_image_to(paths: &JobPaths, image: &Image) -> Result<(), CheckpointError> {
        crate::storage::injected_fault().map_err(CheckpointError::Io)?;
        std::fs::create_dir_all(&paths.dir).map_err(CheckpointError::Io)?;
        renderer::film::write_exr(&paths.image(), image)
            .map_err(|e| CheckpointError::Io(std::io::Error::other(e.to_string())))
    }
}
