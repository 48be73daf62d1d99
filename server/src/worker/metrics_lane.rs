//! Progress metrics off the worker thread. A job with a reference gets one small thread (its
//! "lane") that computes relMSE/FLIP/SSIM/PSNR/MSE of each snapshot against the reference and
//! then appends the snapshot's `progress` (with `metrics`) and `snapshot` events, so the GPU
//! worker never waits on a large film's FLIP. Order is kept: the lane holds at most one pending
//! snapshot (a newer one replaces it, so a slow metric drops intermediate events rather than
//! falling behind), the worker [`MetricsLane::flush`]es it before the job's final events, and
//! dropping the lane reports what is pending and joins the thread.

use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::thread::JoinHandle;

use renderer::film::Image;
use renderer::metrics::{Display, Metrics, METRIC_NOTES};
use serde_json::{json, Value};

use crate::jobs::model::JobId;
use crate::store::Store;

/// One snapshot to report: its image, the `progress` data without metrics, and the `snapshot`
/// event's data.
struct Work {
    image: Image,
    progress: Value,
    snapshot: Value,
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

/// The metrics thread of one job (see the module docs).
pub struct MetricsLane {
    inner: Arc<Inner>,
    thread: Option<JoinHandle<()>>,
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
    /// Starts the lane of job `id`, measuring against `reference` as shown through `display`.
    pub fn start(id: JobId, reference: Arc<Image>, display: Display, store: Arc<Store>) -> Self {
        let inner = Arc::new(Inner {
            state: Mutex::new(LaneState::default()),
            changed: Condvar::new(),
        });
        let lane = inner.clone();
        let thread = std::thread::Builder::new()
            .name(format!("metrics-{id}"))
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
                    let Work {
                        image,
                        mut progress,
                        snapshot,
                    } = work;
                    add_metrics(&mut progress, &image, &reference, display, &mut noted);
                    let _ = store.append_event(id, "progress", progress);
                    let _ = store.append_event(id, "snapshot", snapshot);
                    lane.lock().busy = false;
                    lane.changed.notify_all();
                }
            });
        let thread = match thread {
            Ok(t) => Some(t),
            Err(e) => {
                tracing::warn!(job = id, error = %e, "starting the metrics thread");
                None
            }
        };
        MetricsLane { inner, thread }
    }

    /// Whether the thread runs (if it could not be started, the caller reports inline).
    pub fn running(&self) -> bool {
        self.thread.is_some()
    }

    /// Queues a snapshot's events (replacing a pending older one, which is then not reported).
    pub fn submit(&self, image: Image, progress: Value, snapshot: Value) {
        self.inner.lock().pending = Some(Work {
            image,
            progress,
            snapshot,
        });
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
        };
        let id = store.insert_job(&job, |_| Ok(())).unwrap().id;
        let display = Display {
            exposure_ev: 0.0,
            tonemap: Tonemap::Clamp,
        };
        let lane = MetricsLane::start(id, Arc::new(image(0.5, 0.0)), display, store.clone());
        assert!(lane.running());
        // Errors falling with k; submitted faster than measured, so some may be replaced.
        for k in 1..=6u32 {
            let bump = 0.4 / k as f32;
            lane.submit(image(0.5, bump), json!({"spp": k}), json!({"spp": k}));
        }
        lane.flush();
        let events = store.events_after(id, 0).unwrap();
        let kinds: Vec<&str> = events.iter().map(|e| e.kind.as_str()).collect();
        // The insert's `state`, then progress/snapshot pairs in submission order.
        assert_eq!(kinds[0], "state");
        let rest = &events[1..];
        assert!(!rest.is_empty() && rest.len() % 2 == 0, "{kinds:?}");
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
        lane.submit(image(0.5, 0.01), json!({"spp": 7}), json!({"spp": 7}));
        drop(lane);
        let events = store.events_after(id, 0).unwrap();
        assert_eq!(events.last().unwrap().data["spp"].as_u64(), Some(7));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
