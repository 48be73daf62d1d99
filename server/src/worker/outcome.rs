//! What a job's render produces, as seen from the worker: snapshots (image + `progress` and
//! `snapshot` events), the end (final image on disk, `done` with the stats), and failures
//! (`error`, and a device rebuild when the device itself is in doubt; a hold when the disk is
//! full).

use renderer::render::RenderError;

use super::metrics_lane::SnapshotImage;
use serde_json::json;
use tracing::{error, info, warn};

use super::active::{ActiveJob, CheckpointError};
use super::device_loss::is_device_lost;
use super::storage_hold::is_storage_fault;
use super::{is_device_error, Worker};
use crate::jobs::model::{JobId, JobState};
use crate::storage::is_storage_message;
use crate::store::{JobPaths, StoreError, Transition};

impl Worker {
    /// Hands the accumulation a pass copied out (`snap`) to the job's report lane, which
    /// resolves and publishes the image and appends a progress + snapshot event.
    pub(super) fn snapshot(&mut self, id: JobId, snap: SnapshotImage) {
        let Some(job) = self.active.get_mut(&id) else {
            return;
        };
        let spp = snap.spp();
        let _ = self.store.set_progress(id, &job.session.progress());
        let data = snapshot_data(id, spp);
        job.report_snapshot(&self.store, &self.shared, id, snap, spp, data);
    }

    /// The budget is reached: final image on disk, final events, state done.
    pub(super) fn finish(&mut self, id: JobId) {
        self.sched.remove(id);
        self.queued.retain(|j| *j != id);
        let Some(mut job) = self.active.remove(&id) else {
            return;
        };
        if job.shard.is_some() {
            return self.finish_shard(id, job);
        }
        let t0 = std::time::Instant::now();
        // Step 1: the final sums (merged shards: the sums the session was given, if it holds
        // just them) and their image.
        let spp_now = job.session.progress().spp;
        let sums = match job.merged_sums.take().filter(|(spp, _)| *spp == spp_now) {
            Some((_, sums)) => sums,
            None => match job.session.accumulation() {
                Ok(sums) => sums,
                Err(e) => return self.render_failed(id, e, "reading the final image"),
            },
        };
        let image = job.session.resolve(&sums);
        let t_resolve = t0.elapsed();
        // Step 2: the image file, and meanwhile the error estimate (for the stats).
        let paths = &job.paths;
        let (written, estimate) = std::thread::scope(|scope| {
            let file = std::thread::Builder::new()
                .name("final-exr".into())
                .spawn_scoped(scope, || ActiveJob::write_image_to(paths, &image));
            let estimate = job.session.estimate_spp(&sums, spp_now, &image);
            let written = match file {
                Ok(h) => h.join().unwrap_or_else(|_| {
                    Err(CheckpointError::Io(std::io::Error::other(
                        "the EXR writer panicked",
                    )))
                }),
                // (No thread to be had: written here, after the estimate.)
                Err(_) => ActiveJob::write_image_to(paths, &image),
            };
            (written, estimate)
        });
        drop(sums);
        job.estimate = estimate;
        if let Err(e) = written {
            let msg = match e {
                CheckpointError::Io(e) if is_storage_fault(&e) => {
                    // Back in the active set only to be held: it resumes from its checkpoint.
                    self.active.insert(id, job);
                    return self.hold_for_storage(id, "writing the final image", e.to_string());
                }
                CheckpointError::Io(e) => e.to_string(),
                CheckpointError::Render(e) => e.to_string(),
            };
            return self.fail(id, format!("writing the final image: {msg}"));
        }
        let t_image = t0.elapsed();
        let mut stats = job.session.stats();
        stats.rel_mse_estimate = job.estimate;
        stats.stopped_by = job.stop_reason();
        let progress = job.session.progress();
        let spp = progress.spp;
        let data = snapshot_data(id, spp);
        job.report_snapshot(
            &self.store,
            &self.shared,
            id,
            SnapshotImage::Image(image, spp),
            spp,
            data,
        );
        // The final progress and snapshot events come before `done`.
        job.flush_metrics();
        let t_report = t0.elapsed();
        let mut stats_json = serde_json::to_value(&stats).unwrap_or_default();
        if let Some(run) = &job.auto {
            stats_json["auto"] = run.report.clone();
        }
        let t = Transition {
            verb: "finish",
            stats: Some(stats_json.clone()),
            progress: Some(progress),
            extra_events: vec![("done", json!({"spp": spp, "stats": stats_json}))],
            ..Default::default()
        };
        match self.store.transition(id, JobState::Done, t) {
            Ok(_) => {
                let t_state = t0.elapsed();
                job.remove_checkpoints();
                info!(
                    job = id,
                    spp,
                    time_s = stats.time_s,
                    resolve_ms = super::shard::ms(t_resolve),
                    exr_ms = super::shard::ms(t_image - t_resolve),
                    report_ms = super::shard::ms(t_report - t_image),
                    state_ms = super::shard::ms(t_state - t_report),
                    cleanup_ms = super::shard::ms(t0.elapsed() - t_state),
                    "done"
                );
            }
            // Paused at the last moment (and perhaps resumed already: queued): keep the
            // checkpoint so the resume ends at once instead of rendering from an older one.
            Err(StoreError::Conflict {
                state: JobState::Paused | JobState::Queued,
                ..
            }) => {
                if let Err(e) = job.write_checkpoint() {
                    self.checkpoint_failed(id, e);
                }
            }
            // The store is full: held, to finish again from the checkpoint when space returns.
            Err(StoreError::Db(m)) if is_storage_message(&m) => {
                self.active.insert(id, job);
                return self.hold_for_storage(id, "recording the end", m);
            }
            Err(e) => warn!(job = id, error = %e, "finishing job"),
        }
        super::live_merge::forget(&job.paths.dir);
        drop(job);
        self.shared.forget(id);
        self.publish_caches();
    }

    /// Fails job `id` with `message` (no effect on the device).
    pub(super) fn fail(&mut self, id: JobId, message: String) {
        self.sched.remove(id);
        self.queued.retain(|j| *j != id);
        if let Some(job) = self.active.remove(&id) {
            job.flush_metrics();
            super::live_merge::forget(&job.paths.dir);
        }
        // Its checkpoints: a split job's every shard's too (it failed as a whole).
        let shards = self.store.shards(id).map_or(0, |s| s.len() as u32);
        JobPaths::new(&self.config.data_dir, id).remove_checkpoints(shards);
        self.shared.forget(id);
        error!(job = id, error = %message, "job failed");
        let t = Transition {
            verb: "fail",
            error: Some(message.clone()),
            extra_events: vec![("error", json!({ "message": message }))],
            ..Default::default()
        };
        if let Err(e) = self.store.transition(id, JobState::Failed, t) {
            warn!(job = id, error = %e, "marking job failed");
            // Not recorded for lack of space: kept out of the active set until space returns,
            // then admitted (and failed) again.
            if matches!(&e, StoreError::Db(m) if is_storage_message(m)) {
                self.held
                    .insert(id, format!("disk full: recording the failure: {e}"));
            }
        }
    }

    /// A renderer error: fail the job; rebuild the device if the error was the device's. A lost
    /// device fails no job (device_loss.rs).
    pub(super) fn render_failed(&mut self, id: JobId, e: RenderError, stage: &str) {
        if is_device_lost(&e) {
            return self.device_lost(id, &format!("{stage}: {e}"));
        }
        let device = is_device_error(&e);
        self.fail(id, format!("{stage}: {e}"));
        if device {
            self.reset_device(&format!("{stage}: {e}"));
        }
    }

    /// The renderer panicked: fail the job and rebuild the device.
    pub(super) fn panicked(&mut self, id: JobId, stage: &str) {
        self.fail(id, format!("{stage}: internal renderer error (panic)"));
        self.reset_device(&format!("{stage} panicked"));
    }

    pub(super) fn checkpoint_failed(&mut self, id: JobId, e: CheckpointError) {
        match e {
            CheckpointError::Render(e) => self.render_failed(id, e, "reading the checkpoint"),
            // A full disk is not the job's fault: held until space returns.
            CheckpointError::Io(e) if is_storage_fault(&e) => {
                self.hold_for_storage(id, "writing the checkpoint", e.to_string())
            }
            // Other trouble: keep rendering, try again next interval.
            CheckpointError::Io(e) => warn!(job = id, error = %e, "writing checkpoint"),
        }
    }
}

/// The data of a `snapshot` event.
pub(super) fn snapshot_data(id: JobId, spp: u32) -> serde_json::Value {
    json!({
        "url": format!("/api/jobs/{id}/image.png?spp={spp}"),
        "exr_url": format!("/api/jobs/{id}/image.exr?spp={spp}"),
        "spp": spp,
    })
}
