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
    /// "starting", "ready", "unavailable", or "none" (`serve --workers 0`: renders nothing).
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
    /// Device losses since start (each one rebuilt the device).
    pub device_losses: AtomicU64,
    /// Jobs accepted since start.
    pub jobs_submitted: AtomicU64,
    /// Open SSE streams.
    pub sse_clients: AtomicI64,
    queue_wait: Mutex<Histogram>,
    storage: Mutex<crate::storage::StorageStatus>,
    /// The renderer's in-memory caches, as the worker last published them.
    caches: Mutex<renderer::caches::CacheStats>,
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
            device_losses: AtomicU64::new(0),
            jobs_submitted: AtomicU64::new(0),
            sse_clients: AtomicI64::new(0),
            queue_wait: Mutex::new(Histogram::default()),
            storage: Mutex::new(Default::default()),
            caches: Mutex::new(renderer::caches::stats(None)),
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

    /// Records the renderer's cache sizes (the worker, after admitting or retiring a job).
    pub fn set_caches(&self, stats: renderer::caches::CacheStats) {
        *lock(&self.caches) = stats;
    }

    /// The renderer's cache sizes as last published.
    pub fn caches(&self) -> renderer::caches::CacheStats {
        *lock(&self.caches)
    }

    /// (snapshots kept, their bytes: images and cached encodings).
    fn snapshot_usage(&self) -> (usize, u64) {
        let m = lock(&self.snapshots);
        let bytes = m
            .values()
            .map(|s| {
                let png = lock(&s.png).as_ref().map_or(0, |(_, b)| b.len());
                let exr = lock(&s.exr).as_ref().map_or(0, Vec::len);
                (std::mem::size_of_val(s.image.pixels.as_slice()) + png + exr) as u64
            })
            .sum();
        (m.len(), bytes)
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
            "candela_gpu_device_losses_total",
            "counter",
            "Times the GPU device was lost and rebuilt (jobs resumed from checkpoints).",
            self.device_losses.load(Ordering::Relaxed).to_string(),
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
        self.prometheus_memory(&mut out);
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

    /// The memory part of the exposition: the process (resident, malloc), the renderer's
    /// in-memory caches (with their limits) and the snapshots kept for the image endpoints.
    fn prometheus_memory(&self, out: &mut String) {
        let mut family = |name: &str, kind: &str, help: &str, rows: &[(&str, Option<u64>)]| {
            let _ = writeln!(out, "# HELP {name} {help}\n# TYPE {name} {kind}");
            for (label, v) in rows {
                let Some(v) = v else { continue };
                let _ = if label.is_empty() {
                    writeln!(out, "{name} {v}")
                } else {
                    writeln!(out, "{name}{{{label}}} {v}")
                };
            }
        };
        let heap = crate::process_memory::heap();
        family(
            "process_resident_memory_bytes",
            "gauge",
            "Resident memory of the server process.",
            &[("", crate::process_memory::resident_bytes())],
        );
        family(
            "candela_heap_bytes",
            "gauge",
            "glibc malloc: bytes allocated (of which mmapped) and free inside its arenas.",
            &[
                ("kind=\"allocated\"", heap.map(|h| h.allocated)),
                ("kind=\"mmapped\"", heap.map(|h| h.mmapped)),
                ("kind=\"free\"", heap.map(|h| h.free)),
            ],
        );
        let c = self.caches();
        let n = |v: usize| Some(v as u64);
        family(
            "candela_cache_entries",
            "gauge",
            "Entries of the in-memory caches: kernels (SPIR-V), pipelines (per device), volumes (vct).",
            &[
                ("cache=\"kernels\"", n(c.kernels)),
                ("cache=\"pipelines\"", n(c.pipelines)),
                ("cache=\"volumes\"", n(c.volumes)),
            ],
        );
        family(
            "candela_cache_limit_entries",
            "gauge",
            "Most entries each in-memory cache keeps (--cache-kernels, --cache-pipelines, --cache-volumes).",
            &[
                ("cache=\"kernels\"", n(c.limits.kernels)),
                ("cache=\"pipelines\"", n(c.limits.pipelines)),
                ("cache=\"volumes\"", n(c.limits.volumes)),
            ],
        );
        family(
            "candela_cache_bytes",
            "gauge",
            "Bytes of the in-memory caches: kernels (SPIR-V, host), volumes (GPU), pipeline_data (the driver's pipeline cache as last saved).",
            &[
                ("cache=\"kernels\"", Some(c.kernel_bytes)),
                ("cache=\"volumes\"", Some(c.volume_bytes)),
                ("cache=\"pipeline_data\"", c.pipeline_cache_bytes),
            ],
        );
        family(
            "candela_cache_limit_bytes",
            "gauge",
            "Most bytes the kernel cache keeps in memory (--cache-kernel-bytes).",
            &[("cache=\"kernels\"", Some(c.limits.kernel_bytes))],
        );
        family(
            "candela_cache_evictions_total",
            "counter",
            "Entries dropped from the in-memory caches to stay within their limits.",
            &[
                ("cache=\"kernels\"", Some(c.kernel_evictions)),
                ("cache=\"pipelines\"", Some(c.pipeline_evictions)),
            ],
        );
        family(
            "candela_pipelines_live",
            "gauge",
            "Pipeline objects alive (cached, or held by rendering jobs).",
            &[("", Some(c.pipelines_live))],
        );
        family(
            "candela_kernel_variants_seen_total",
            "counter",
            "Distinct kernel variants made into pipelines since the process started (kept in a cache or not).",
            &[("", Some(c.kernel_variants))],
        );
        let (snapshots, snapshot_bytes) = self.snapshot_usage();
        family(
            "candela_snapshots",
            "gauge",
            "Latest images kept in memory for the image endpoints (one per rendering job).",
            &[("", n(snapshots))],
        );
        family(
            "candela_snapshot_bytes",
            "gauge",
            "Bytes of those images and their cached PNG/EXR encodings.",
            &[("", Some(snapshot_bytes))],
        );
    }
}
