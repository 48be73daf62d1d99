//! State shared between the GPU worker thread and the HTTP side: the latest snapshot of each
//! active job (served by the image endpoints), the device status (health), and the counters
//! behind `/metrics`. Plain mutexes and atomics: the worker never awaits, handlers never block
//! for long.

use std::collections::HashMap;
use std::fmt::Write;
use std::sync::atomic::{AtomicI64, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};

use renderer::film::Image;
use renderer::gpu::DeviceInfo;
use serde::Serialize;

use crate::jobs::model::JobId;

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// The PNG parameters a cached encoding was made with: (exposure as f32 bits, tonemap name).
pub type PngKey = (u32, String);

/// A rendered estimate of a job at some sample count, with cached encodings.
pub struct Snapshot {
    pub image: Image,
    pub spp: u32,
    /// Last PNG encoded: ((exposure bits, tonemap), bytes).
    pub png: Mutex<Option<(PngKey, Vec<u8>)>>,
    /// The EXR encoding, made on first request.
    pub exr: Mutex<Option<Vec<u8>>>,
}

impl Snapshot {
    /// A snapshot without cached encodings.
    pub fn new(image: Image, spp: u32) -> Self {
        Snapshot {
            image,
            spp,
            png: Mutex::new(None),
            exr: Mutex::new(None),
        }
    }
}

/// Whether the worker has a device.
#[derive(Debug, Clone, Serialize)]
pub struct GpuStatus {
    /// "starting", "ready" or "unavailable".
    pub state: &'static str,
    pub device: Option<DeviceInfo>,
    pub error: Option<String>,
}

/// How far the server is with building its common kernels (worker/warmup.rs).
#[derive(Debug, Clone, Default, Serialize)]
pub struct KernelWarmup {
    /// "off", "warming" or "ready".
    pub state: &'static str,
    /// Distinct (integrator, feature set) variants to build, and those built.
    pub variants: usize,
    pub built: usize,
    /// Kernels compiled and read from the disk cache, and seconds so far.
    pub compiled: u64,
    pub disk_hits: u64,
    pub seconds: f64,
}

/// Fixed histogram buckets (seconds) of the queue wait.
const WAIT_BUCKETS: [f64; 12] = [
    0.01, 0.05, 0.1, 0.5, 1.0, 5.0, 10.0, 30.0, 60.0, 300.0, 1800.0, 3600.0,
];

#[derive(Debug, Default)]
struct Histogram {
    counts: [u64; WAIT_BUCKETS.len()],
    sum: f64,
    count: u64,
}

/// Everything shared.
pub struct Shared {
    snapshots: Mutex<HashMap<JobId, Arc<Snapshot>>>,
    gpu: Mutex<GpuStatus>,
    kernels: Mutex<KernelWarmup>,
    /// Pixel samples rendered since start.
    pub samples_total: AtomicU64,
    /// GPU time of passes since start, nanoseconds.
    pub gpu_busy_ns: AtomicU64,
    /// Passes since start.
    pub passes_total: AtomicU64,
    /// Jobs accepted since start.
    pub jobs_submitted: AtomicU64,
    /// Open SSE streams.
    pub sse_clients: AtomicI64,
    queue_wait: Mutex<Histogram>,
    storage: Mutex<crate::storage::StorageStatus>,
    started: std::time::Instant,
}

impl Default for Shared {
    fn default() -> Self {
        Shared {
            snapshots: Mutex::new(HashMap::new()),
            gpu: Mutex::new(GpuStatus {
                state: "starting",
                device: None,
                error: None,
            }),
            kernels: Mutex::new(KernelWarmup {
                state: "off",
                ..Default::default()
            }),
            samples_total: AtomicU64::new(0),
            gpu_busy_ns: AtomicU64::new(0),
            passes_total: AtomicU64::new(0),
            jobs_submitted: AtomicU64::new(0),
            sse_clients: AtomicI64::new(0),
            queue_wait: Mutex::new(Histogram::default()),
            storage: Mutex::new(Default::default()),
            started: std::time::Instant::now(),
        }
    }
}

impl Shared {
    /// Publishes a job's latest image.
    pub fn publish(&self, id: JobId, image: Image, spp: u32) {
        lock(&self.snapshots).insert(id, Arc::new(Snapshot::new(image, spp)));
    }

    /// A job's latest image, if one was published since start.
    pub fn snapshot(&self, id: JobId) -> Option<Arc<Snapshot>> {
        lock(&self.snapshots).get(&id).cloned()
    }

    /// Forgets a job's image (it is on disk).
    pub fn forget(&self, id: JobId) {
        lock(&self.snapshots).remove(&id);
    }

    /// The device status.
    pub fn gpu(&self) -> GpuStatus {
        lock(&self.gpu).clone()
    }

    /// Sets the device status.
    pub fn set_gpu(&self, status: GpuStatus) {
        *lock(&self.gpu) = status;
    }

    /// The kernel warm-up's progress.
    pub fn kernels(&self) -> KernelWarmup {
        lock(&self.kernels).clone()
    }

    /// Sets the kernel warm-up's progress.
    pub fn set_kernels(&self, k: KernelWarmup) {
        *lock(&self.kernels) = k;
    }

    /// The data directory's storage as last measured.
    pub fn storage(&self) -> crate::storage::StorageStatus {
        lock(&self.storage).clone()
    }

    /// Records a measurement of the storage.
    pub fn set_storage(&self, s: crate::storage::StorageStatus) {
        *lock(&self.storage) = s;
    }

    /// Records a fresh free-space measurement, keeping the held-job count.
    pub fn update_free_space(&self, free_bytes: u64, low: bool) {
        let mut s = lock(&self.storage);
        s.free_bytes = free_bytes;
        s.low = low;
    }

    /// Seconds since start.
    pub fn uptime_s(&self) -> f64 {
        self.started.elapsed().as_secs_f64()
    }

    /// Records how long a job waited between submission and its first pass.
    pub fn observe_queue_wait(&self, seconds: f64) {
        let mut h = lock(&self.queue_wait);
        for (i, bound) in WAIT_BUCKETS.iter().enumerate() {
            if seconds <= *bound {
                h.counts[i] += 1;
            }
        }
        h.sum += seconds.max(0.0);
        h.count += 1;
    }

    /// Prometheus text exposition (version 0.0.4) of the counters and `jobs` by state.
    pub fn prometheus(
        &self,
        jobs: &std::collections::BTreeMap<crate::jobs::model::JobState, u64>,
    ) -> String {
        let mut out = String::new();
        let _ = writeln!(
            out,
            "# HELP candela_jobs Jobs in the store by state.\n# TYPE candela_jobs gauge"
        );
        for (state, n) in jobs {
            let _ = writeln!(out, "candela_jobs{{state=\"{}\"}} {n}", state.as_str());
        }
        let mut line = |name: &str, kind: &str, help: &str, value: String| {
            let _ = writeln!(
                out,
                "# HELP {name} {help}\n# TYPE {name} {kind}\n{name} {value}"
            );
        };
        line(
            "candela_samples_rendered_total",
            "counter",
            "Pixel samples rendered since the server started.",
            self.samples_total.load(Ordering::Relaxed).to_string(),
        );
        line(
            "candela_gpu_busy_seconds_total",
            "counter",
            "GPU time spent in render passes since the server started.",
            format!(
                "{:.6}",
                self.gpu_busy_ns.load(Ordering::Relaxed) as f64 * 1e-9
            ),
        );
        line(
            "candela_passes_total",
            "counter",
            "Render passes run since the server started.",
            self.passes_total.load(Ordering::Relaxed).to_string(),
        );
        line(
            "candela_jobs_submitted_total",
            "counter",
            "Jobs accepted since the server started.",
            self.jobs_submitted.load(Ordering::Relaxed).to_string(),
        );
        line(
            "candela_sse_clients",
            "gauge",
            "Open event streams.",
            self.sse_clients.load(Ordering::Relaxed).to_string(),
        );
        line(
            "candela_gpu_up",
            "gauge",
            "1 when the render device is ready.",
            u8::from(self.gpu().state == "ready").to_string(),
        );
        line(
            "candela_uptime_seconds",
            "gauge",
            "Seconds since the server started.",
            format!("{:.3}", self.uptime_s()),
        );
        let storage = self.storage();
        line(
            "candela_storage_free_bytes",
            "gauge",
            "Free bytes on the data directory's filesystem.",
            storage.free_bytes.to_string(),
        );
        line(
            "candela_storage_min_free_bytes",
            "gauge",
            "Free space below which new jobs are refused (--min-free-space).",
            storage.min_free_bytes.to_string(),
        );
        line(
            "candela_storage_low",
            "gauge",
            "1 while free space is below the minimum (new jobs get 507).",
            u8::from(storage.low).to_string(),
        );
        line(
            "candela_jobs_held_for_storage",
            "gauge",
            "Jobs paused by the server after a write failed for lack of space.",
            storage.held_jobs.to_string(),
        );
        let h = lock(&self.queue_wait);
        let _ = writeln!(
            out,
            "# HELP candela_queue_wait_seconds Time from submission to a job's first pass.\n\
             # TYPE candela_queue_wait_seconds histogram"
        );
        for (bound, n) in WAIT_BUCKETS.iter().zip(h.counts) {
            let _ = writeln!(
                out,
                "candela_queue_wait_seconds_bucket{{le=\"{bound}\"}} {n}"
            );
        }
        let _ = writeln!(
            out,
            "candela_queue_wait_seconds_bucket{{le=\"+Inf\"}} {}\n\
             candela_queue_wait_seconds_sum {:.6}\ncandela_queue_wait_seconds_count {}",
            h.count, h.sum, h.count
        );
        out
    }
}
