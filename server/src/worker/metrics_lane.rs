//! Snapshots reported off the worker thread. Each job gets one small thread (its "lane") that
//! resolves a snapshot's raw accumulation into the image (the pass copied it to host memory),
//! publishes it for the image endpoints, estimates its relMSE without a reference (from the two
//! halves of its samples: `rel_mse_estimate`), computes relMSE/FLIP/SSIM/PSNR/MSE against the
//! job's reference when it has one, and then appends the snapshot's `progress` (with `metrics`) and
//! `snapshot` events, so the GPU worker queues the next pass at once and never waits on a large
//! film's resolve or FLIP. Order is kept: the lane holds at most one pending snapshot (a newer
//! one replaces it, so a slow metric drops intermediate events rather than falling behind), the
//! worker [`MetricsLane::flush`]es it before the job's final events (and before it forgets the
//! job's published image), and dropping the lane reports what is pending and joins the thread.

use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::thread::JoinHandle;

use renderer::film::Image;
use renderer::metrics::{Display, Metrics, METRIC_NOTES};
use renderer::render::AccumSnapshot;
use serde_json::{json, Value};

use crate::jobs::model::JobId;
use crate::shared::Shared;
use crate::store::Store;

/// A snapshot's image: resolved already (with its samples per pixel), or the raw accumulation a
/// pass copied out.
pub enum SnapshotImage {
    Image(Image, u32),
    Accum(AccumSnapshot),
}

impl SnapshotImage {
    /// Samples per pixel in the snapshot.
    pub fn spp(&self) -> u32 {
        match self {
            SnapshotImage::Image(_, spp) => *spp,
            SnapshotImage::Accum(a) => a.spp(),
        }
    }
}

/// One snapshot to report: its image and sample count, the `progress` data without metrics,
/// and the `snapshot` event's data.
struct Work {
    image: SnapshotImage,
    spp: u32,
    progress: Value,
    snapshot: Value,
}

/// What the lane of a job reports to and measures against.
pub struct LaneTargets {
    pub store: Arc<Store>,
    pub shared: Arc<Shared>,
    /// The reference of the progress metrics and how images are compared (None: no metrics).
    pub reference: Option<(Arc<Image>, Display)>,
}

/// Resolves, publishes, measures and reports one snapshot (on the lane, or inline).
fn report(id: JobId, w: Work, t: &LaneTargets, noted: &mut bool) {
    let Work {
        image,
        spp,
        mut progress,
        snapshot,
    } = w;
    let image = match image {
        SnapshotImage::Image(i, _) => i,
        SnapshotImage::Accum(a) => match a.image_and_estimate() {
            Ok((i, estimate)) => {
                progress["rel_mse_estimate"] = json!(estimate);
                i
            }
            Err(e) => return tracing::warn!(job = id, error = %e, "resolving a snapshot"),
        },
    };
    // Published first, so the snapshot event never announces an older image.
    match &t.reference {
        Some((reference, display)) => {
            add_metrics(&mut progress, &image, reference, *display, noted);
            t.shared.publish(id, image, spp);
        }
        None => t.shared.publish(id, image, spp),
    }
    let _ = t.store.append_event(id, "progress", progress);
    let _ = t.store.append_event(id, "snapshot", snapshot);
}

#[derive(Default)]
struct LaneState {
    pending: Option<Work>,
    busy: bool,
    stop: bool,
}

struct Inner {
    state: Mutex<LaneState>,
    changed: Condvar,
}

impl Inner {
    fn lock(&self) -> MutexGuard<'_, LaneState> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// The report thread of one job (see the module docs).
pub struct MetricsLane {
    inner: Arc<Inner>,
    thread: Option<JoinHandle<()>>,
    /// For reporting inline when the thread could not start.
    targets: Arc<LaneTargets>,
    noted: Mutex<bool>,
    id: JobId,
}

/// Adds `metrics` of `image` against `reference` to `progress` (and `metrics_note` the first
/// time, tracked by `noted`); a failure is logged and leaves `progress` without metrics.
pub fn add_metrics(
    progress: &mut Value,
    image: &Image,
    reference: &Image,
    display: Display,
    noted: &mut bool,
) {
    match Metrics::compute(image, reference, display) {
        Ok(m) => {
            progress["metrics"] = json!({
                "rel_mse": m.rel_mse,
                "flip": m.flip,
                "ssim": m.ssim,
                "psnr_db": m.psnr_db,
                "mse": m.mse,
            });
            if !*noted {
                *noted = true;
                progress["metrics_note"] = json!({
                    "rel_mse": METRIC_NOTES.rel_mse,
                    "flip": METRIC_NOTES.flip,
                    "ssim": METRIC_NOTES.ssim,
                    "psnr_db": METRIC_NOTES.psnr_db,
                    "mse": METRIC_NOTES.mse,
                });
            }
        }
        Err(e) => tracing::warn!(error = %e, "progress metrics"),
    }
}

impl MetricsLane {
    /// Starts the lane of job `id`, reporting to `targets`.
    pub fn start(id: JobId, targets: LaneTargets) -> Self {
        let inner = Arc::new(Inner {
            state: Mutex::new(LaneState::default()),
            changed: Condvar::new(),
        });
        let lane = inner.clone();
        let targets = Arc::new(targets);
        let on_lane = targets.clone();
        let thread = std::thread::Builder::new()
            .name(format!("report-{id}"))
            .spawn(move || {
                let mut noted = false;
                loop {
                    // Wait for work (or the end), and mark the lane busy while reporting it.
                    let work = {
                        let mut s = lane.lock();
                        while s.pending.is_none() && !s.stop {
                            s = lane.changed.wait(s).unwrap_or_else(|e| e.into_inner());
                        }
                        match s.pending.take() {
                            Some(w) => {
                                s.busy = true;
                                w
                            }
                            None => return,
                        }
                    };
                    report(id, work, &on_lane, &mut noted);
                    lane.lock().busy = false;
                    lane.changed.notify_all();
                }
            });
        let thread = match thread {
            Ok(t) => Some(t),
            Err(e) => {
                tracing::warn!(job = id, error = %e, "starting the report thread");
                None
            }
        };
        MetricsLane {
            inner,
            thread,
            targets,
            noted: Mutex::new(false),
            id,
        }
    }

    /// Queues a snapshot (replacing a pending older one, which is then not reported).
    pub fn submit(&self, image: SnapshotImage, spp: u32, progress: Value, snapshot: Value) {
        let work = Work {
            image,
            spp,
            progress,
            snapshot,
        };
        if self.thread.is_none() {
            let mut noted = self.noted.lock().unwrap_or_else(|e| e.into_inner());
            return report(self.id, work, &self.targets, &mut noted);
        }
        self.inner.lock().pending = Some(work);
        self.inner.changed.notify_all();
    }

    /// Waits until everything submitted has been reported.
    pub fn flush(&self) {
        if self.thread.is_none() {
            return;
        }
        let mut s = self.inner.lock();
        while s.pending.is_some() || s.busy {
            s = self
                .inner
                .changed
                .wait(s)
                .unwrap_or_else(|e| e.into_inner());
        }
    }
}

impl Drop for MetricsLane {
    fn drop(&mut self) {
        self.inner.lock().stop = true;
        self.inner.changed.notify_all();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::jobs::model::NewJob;
    use crate::jobs::model::{JobSettings, SceneSource};
    use renderer::scene::Tonemap;

    /// A 4×2 image of `v` everywhere, plus `bump` on the first pixel.
    fn image(v: f32, bump: f32) -> Image {
        let mut img = Image::new(4, 2);
        for p in &mut img.pixels {
            *p = [v; 3];
        }
        img.pixels[0] = [v + bump; 3];
        img
    }

    #[test]
    fn events_in_order_with_metrics_and_flushed() {
        let dir = std::env::temp_dir().join(format!("candela-lane-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let store = Arc::new(Store::open(&dir.join("db.sqlite")).unwrap());
        let settings: JobSettings = serde_json::from_value(json!({
            "integrator": {"type": "nee"}, "spp": 4, "time_s": null, "seed": 0, "width": 4,
            "height": 2, "scene_max_depth": null, "exposure": 0.0, "tonemap": "clamp"
        }))
        .unwrap();
        let job = NewJob {
            name: "lane".into(),
            priority: 10,
            settings,
            scene: "{}".into(),
            scene_name: None,
            source: SceneSource::Inline,
            owner: None,
        };
        let id = store.insert_job(&job, |_| Ok(())).unwrap().id;
        let display = Display {
            exposure_ev: 0.0,
            tonemap: Tonemap::Clamp,
        };
        let shared = Arc::new(Shared::default());
        let lane = MetricsLane::start(
            id,
            LaneTargets {
                store: store.clone(),
                shared: shared.clone(),
                reference: Some((Arc::new(image(0.5, 0.0)), display)),
            },
        );
        assert!(lane.thread.is_some());
        // Errors falling with k; submitted faster than measured, so some may be replaced.
        for k in 1..=6u32 {
            let bump = 0.4 / k as f32;
            let img = SnapshotImage::Image(image(0.5, bump), 1);
            lane.submit(img, k, json!({"spp": k}), json!({"spp": k}));
        }
        lane.flush();
        let events = store.events_after(id, 0).unwrap();
        let kinds: Vec<&str> = events.iter().map(|e| e.kind.as_str()).collect();
        // The insert's `state`, then progress/snapshot pairs in submission order.
        assert_eq!(kinds[0], "state");
        let rest = &events[1..];
        assert!(
            !rest.is_empty() && rest.len().is_multiple_of(2),
            "{kinds:?}"
        );
        let mut last_spp = 0;
        let mut last_rel = f64::INFINITY;
        for pair in rest.chunks(2) {
            assert_eq!(
                (pair[0].kind.as_str(), pair[1].kind.as_str()),
                ("progress", "snapshot")
            );
            let spp = pair[0].data["spp"].as_u64().unwrap();
            assert_eq!(pair[1].data["spp"].as_u64(), Some(spp));
            assert!(spp > last_spp, "out of order: {kinds:?}");
            last_spp = spp;
            let rel = pair[0].data["metrics"]["rel_mse"].as_f64().unwrap();
            assert!(rel > 0.0 && rel < last_rel, "relMSE {rel} after {last_rel}");
            last_rel = rel;
        }
        // The newest submission is never dropped, and the note comes once, first.
        assert_eq!(last_spp, 6);
        assert!(rest[0].data.get("metrics_note").is_some());
        let notes = rest
            .iter()
            .filter(|e| e.data.get("metrics_note").is_some())
            .count();
        assert_eq!(notes, 1);
        // Dropping reports what is pending, then joins.
        assert_eq!(shared.snapshot(id).map(|s| s.spp), Some(6));
        let img = SnapshotImage::Image(image(0.5, 0.01), 1);
        lane.submit(img, 7, json!({"spp": 7}), json!({"spp": 7}));
        drop(lane);
        assert_eq!(shared.snapshot(id).map(|s| s.spp), Some(7));
        let events = store.events_after(id, 0).unwrap();
        assert_eq!(events.last().unwrap().data["spp"].as_u64(), Some(7));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
