//! Progressive rendering: a `RenderSession` owns the uploaded scene, the accumulation buffer and
//! the integrator's pipeline, and runs passes of N samples per pixel, queued back to back
//! (inflight.rs) and cut into dispatches sized to the GPU (dispatch.rs). Sample indices are the
//! RNG key, so the image depends only on (seed, total spp), never on the pass split or the
//! dispatch shape. `render` drives a session to an spp or wall-time budget; `render_split`
//! drives several sessions (devices) on disjoint sample indices and merges their sums.

mod dispatch;
mod estimate_gpu;
mod halves;
mod inflight;
mod session;
mod shards;
mod until;

pub use crate::error::RenderError;
pub use dispatch::{DispatchShape, MAX_LANES, TILED_MIN_PIXELS};
pub use estimate_gpu::{ESTIMATE_KERNEL, ESTIMATE_LABELS};
pub use inflight::{AccumSnapshot, CompletedPass, PassEstimate, PassStats, PIPELINE_DEPTH};
pub use session::{HostAccumulation, Progress, RenderSession, LLVMPIPE_MAX_DISPATCHES};
pub use shards::{merge_accumulation, render_split, SampleDispenser, SplitRender};
pub use until::{
    is_check_point, next_check, target_reached, UntilChecks, UNTIL_CHECK_GROWTH, UNTIL_MIN_SPP,
};

use std::time::Duration;

use serde::Serialize;

use crate::film::Image;
use crate::gpu::DeviceInfo;
use crate::integrators::IntegratorOptions;

/// What to render and for how long.
#[derive(Debug, Clone)]
pub struct RenderSettings {
    pub integrator: IntegratorOptions,
    pub budget: Budget,
    pub seed: u64,
    /// Film size override (None: the scene's film).
    pub width: Option<u32>,
    pub height: Option<u32>,
}

/// When a render stops.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Budget {
    Spp(u32),
    /// Wall-clock seconds; at least one pass runs.
    Time(f64),
}

/// What a render did.
#[derive(Debug, Clone, Serialize)]
pub struct RenderStats {
    pub device: DeviceInfo,
    pub integrator: String,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub passes: u32,
    pub max_depth: i32,
    pub seed: u64,
    /// Wall time of the passes (excluding scene load and kernel compilation).
    pub time_s: f64,
    /// GPU time of the passes from timestamp queries.
    pub gpu_time_s: f64,
    pub msamples_per_s: f64,
    pub rays_per_s: f64,
    pub rays: u64,
    pub dropped_samples: u64,
    pub triangles: usize,
    pub primitives: usize,
    pub lights: usize,
    /// Nodes and depth of the BVH, or of the CWBVH with accel "cwbvh" (0 with the grid).
    pub bvh_nodes: usize,
    pub bvh_depth: usize,
    pub bvh_build_s: f64,
    pub setup_s: f64,
    /// Of `setup_s`: building the pass kernel (compiling it, or the in-process cache, and the
    /// pipeline).
    pub kernel_s: f64,
    /// The pass kernel as the driver compiled it (VK_KHR_pipeline_executable_properties, e.g.
    /// NVIDIA's "Register Count"); empty where the driver does not report it.
    #[serde(skip_serializing_if = "std::collections::BTreeMap::is_empty")]
    pub kernel_stats: std::collections::BTreeMap<String, f64>,
    /// The features the kernels were compiled for (`spheres`, `mat_diffuse`, ...).
    pub features: Vec<&'static str>,
    /// "specialized" (to the scene's features) or "generic" (every feature).
    pub kernels: crate::compile::KernelMode,
    /// The pass kernel's defines (`NAME=VALUE`): features, accel variant (`CWBVH_SPARSE`, ...),
    /// light sampler, the integrator's, and any of the measuring knob `CANDELA_SHADER_DEFINES`,
    /// so that a report names the variant that ran.
    pub kernel_defines: Vec<String>,
    /// The acceleration structure: "bvh", "cwbvh" or "grid".
    pub accel: String,
    /// Seconds to obtain it: its build, or loading it from the cache on a hit.
    pub accel_build_s: f64,
    /// Bytes of its GPU buffers (BVH nodes and parent pointers, or the grid's buffers).
    pub accel_bytes: u64,
    /// Seconds of each step of its build, in order (`[name, seconds]` pairs: cache key, the
    /// builder's steps, cache write), between `gather_prims` and `reorder_prims`, the compile
    /// steps around the build (outside `accel_build_s`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub accel_phases: Vec<(String, f64)>,
    /// Both BVHs' estimated costs per ray (`{"bvh", "cwbvh"}`, in binary node fetches) when
    /// "auto" chose between them by those estimates (accel/estimate.rs); absent otherwise.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub accel_estimate: Option<crate::accel::estimate::Costs>,
    /// GPU bytes of the geometry: primitives and per-triangle shading data.
    pub geometry_bytes: u64,
    /// GPU bytes of every scene buffer (geometry, accel, materials, textures, lights, ...).
    pub scene_gpu_bytes: u64,
    /// (geometry_bytes + accel_bytes) / triangles (0 without triangles). Triangles count once
    /// however many instances place them.
    pub gpu_bytes_per_triangle: f64,
    /// Instances (`instance` objects; 0 without), the triangles they render (each instance
    /// counts its prototype's), and the GPU bytes each costs (its record and its share of the
    /// top-level BVH; included in accel_bytes).
    pub instances: u64,
    pub instanced_triangles: u64,
    pub gpu_bytes_per_instance: f64,
    /// The host process's peak resident memory so far (VmHWM; absent where unknown). In the
    /// server it covers every job the process has run.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub peak_rss_bytes: Option<u64>,
    /// Seconds to load the scene (parse, read meshes and textures); 0 when not measured.
    pub load_s: f64,
    /// Seconds to compile it for the GPU, including `accel_build_s`.
    pub compile_s: f64,
    /// "hit", "miss" (built and stored) or "off" (no cache).
    pub accel_cache: crate::accel::CacheStatus,
    /// Grid only: cells along x, y, z.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub grid_resolution: Option<[u32; 3]>,
    /// Grid only: primitive references over all cells.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub grid_refs: Option<u64>,
    /// What building the session's kernels took: compiles, kernel-cache hits, pipelines and
    /// their milliseconds.
    pub kernel_build: crate::gpu::KernelStats,
    /// The session's first pass (None before one, or after a restore).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub first_pass: Option<FirstPass>,
    /// The integrator's own statistics (stage timings, memory), where it has any.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub details: Option<serde_json::Value>,
    /// The image's relMSE against the converged image, estimated without a reference from the
    /// even and odd halves of its samples ([`crate::metrics::rel_mse_estimate`]); set by
    /// [`render`] and the server (None before both halves have samples).
    pub rel_mse_estimate: Option<f64>,
    /// The error estimates computed on the GPU for a quality target (until.rs): how many and
    /// what they took (absent without any).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub estimate_checks: Option<EstimateChecks>,
    /// How light sampling picked lights: "power" or "bvh" (`render.light_sampler`, for the
    /// integrators whose registry entry takes the BVH, `IntegratorInfo::light_bvh`; bdpt's
    /// light subpaths start ∝ power whatever it says).
    pub light_sampler: &'static str,
    /// Why the render stopped (set by [`render`] and the server).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stopped_by: Option<StopReason>,
    /// `auto` only: the integrator chosen and the pilots' figures (renderer::auto).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub auto: Option<AutoChoice>,
}

/// The cost of a quality target's checks (until.rs): each is an error estimate computed on the
/// GPU at the end of the pass reaching a check point, and a wait for its result before the
/// next pass is queued.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct EstimateChecks {
    pub checks: u32,
    /// GPU time of the estimates' dispatches (timestamps; 0 where the queue has none). Part of
    /// the passes' time.
    pub gpu_ms: f64,
    /// Host time from a check's pass completing to the next pass being queued (the GPU has
    /// no work meanwhile): measured by [`render_until`], absent elsewhere.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wait_ms: Option<f64>,
}

/// One integrator's pilot of `auto` (renderer::auto).
#[derive(Debug, Clone, Serialize)]
pub struct Pilot {
    pub integrator: &'static str,
    pub spp: u32,
    pub time_s: f64,
    pub rel_mse_estimate: Option<f64>,
    /// rel_mse_estimate × time_s: lower is better (None without an estimate).
    pub cost: Option<f64>,
}

/// What `auto` chose and why (renderer::auto).
#[derive(Debug, Clone, Serialize)]
pub struct AutoChoice {
    pub choice: &'static str,
    pub pilots: Vec<Pilot>,
}

/// Why a render stopped: its spp or time cap, or its quality target (`until`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    Spp,
    Time,
    RelMse,
}

impl StopReason {
    /// The name in reports: "spp", "time" or "rel_mse".
    pub fn name(self) -> &'static str {
        match self {
            StopReason::Spp => "spp",
            StopReason::Time => "time",
            StopReason::RelMse => "rel_mse",
        }
    }
}

/// Size and times of a session's first pass.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct FirstPass {
    pub spp: u32,
    pub gpu_ms: f64,
    pub wall_ms: f64,
}

/// Renders to the budget and returns the image (radiance per pixel) and what happened. Up to
/// [`PIPELINE_DEPTH`] passes are queued at once; each is sized by [`PassSizer`] to about a
/// quarter second (less where the time budget has less left).
pub fn render(
    session: &mut RenderSession,
    budget: Budget,
) -> Result<(Image, RenderStats), RenderError> {
    render_until(session, budget, None)
}

/// [`render`], stopping early once the estimated relMSE ([`RenderStats::rel_mse_estimate`])
/// reaches `until` ([`target_reached`]), the budget being the cap. With a target the estimate
/// is computed on the GPU by the pass ending at each check point ([`UntilChecks`], until.rs),
/// and nothing past a check point is queued before its result: the render stops at the first
/// check point that reaches the target (the same spp and image for the same seed and device).
pub fn render_until(
    session: &mut RenderSession,
    budget: Budget,
    until: Option<f64>,
) -> Result<(Image, RenderStats), RenderError> {
    let target = Duration::from_millis(250);
    let mut sizer = PassSizer::default();
    let mut checks = until.map(UntilChecks::new);
    // When the latest check's result came (the GPU has nothing of this render queued until
    // the next pass), and the time so spent.
    let mut check_seen: Option<std::time::Instant> = None;
    let mut wait = Duration::ZERO;
    // A completed pass: its cost, and a check's result.
    let observe = |p: CompletedPass,
                   sizer: &mut PassSizer,
                   checks: &mut Option<UntilChecks>,
                   check_seen: &mut Option<std::time::Instant>| {
        sizer.observe(&p.stats);
        if let (Some(c), Some(e)) = (checks.as_mut(), p.estimate) {
            c.observe(e.spp, e.rel_mse);
            *check_seen = Some(std::time::Instant::now());
        }
    };
    let reached = |checks: &Option<UntilChecks>| checks.as_ref().is_some_and(|c| c.reached);
    loop {
        // Step 1: keep the queue full while the budget has room (one pass at a time until a
        // pass has shown what a sample costs; none past a check point awaiting its result).
        while session.in_flight() < PIPELINE_DEPTH
            && (sizer.knows_cost() || session.in_flight() == 0)
        {
            let submitted = session.submitted_spp();
            let n = match budget {
                Budget::Spp(total) => {
                    let left = total.saturating_sub(submitted);
                    if left == 0 {
                        break;
                    }
                    sizer.next(target).min(left)
                }
                Budget::Time(seconds) => {
                    let committed =
                        session.elapsed().as_secs_f64() + sizer.seconds(submitted - session.spp());
                    let left = seconds.max(0.0) - committed;
                    if left <= 0.0 && submitted > 0 {
                        break;
                    }
                    sizer.next(target.min(Duration::from_secs_f64(left.max(0.0))))
                }
            };
            let n = checks
                .as_ref()
                .map_or(n, |c| n.min(c.pass_limit(submitted)));
            if n == 0 {
                break;
            }
            let check = checks.as_ref().is_some_and(|c| c.is_check(submitted, n));
            if let Some(c) = checks.as_mut().filter(|_| check) {
                c.queued(submitted + n);
            }
            if let Some(t) = check_seen.take() {
                wait += t.elapsed();
            }
            for p in session.submit_pass_with(n, false, check)? {
                observe(p, &mut sizer, &mut checks, &mut check_seen);
            }
        }
        // Step 2: the oldest pass; done when none is left.
        match session.complete_oldest()? {
            Some(p) => observe(p, &mut sizer, &mut checks, &mut check_seen),
            None => break,
        }
    }
    // Step 3: the image, its estimated error, and why the render stopped.
    let (image, estimate) = session.image_and_estimate()?;
    let mut stats = session.stats();
    stats.rel_mse_estimate = estimate;
    if let Some(e) = &mut stats.estimate_checks {
        e.wait_ms = Some(wait.as_secs_f64() * 1e3);
    }
    stats.stopped_by = Some(match (reached(&checks), budget) {
        (true, _) => StopReason::RelMse,
        (false, Budget::Spp(_)) => StopReason::Spp,
        (false, Budget::Time(_)) => StopReason::Time,
    });
    Ok((image, stats))
}

/// Sizes passes from the measured cost of a sample per pixel (GPU time where the device has
/// timestamps, else wall time): a pass of about the target time, at most 4× the previous pass
/// (a first measurement may be off: a GPU starting from idle runs at low clocks) and at most
/// 1024 samples per pixel. Until a pass has completed, passes are one sample (and callers
/// queue only one: [`PassSizer::knows_cost`]).
#[derive(Debug, Clone, Copy, Default)]
pub struct PassSizer {
    /// Seconds per sample per pixel, from the last completed pass.
    cost: Option<f64>,
    last: u32,
}

impl PassSizer {
    /// Notes a completed pass.
    pub fn observe(&mut self, p: &PassStats) {
        let t = if p.gpu.is_zero() { p.wall } else { p.gpu };
        self.cost = Some(t.as_secs_f64() / p.spp.max(1) as f64);
    }

    /// Samples per pixel for the next pass, to take about `target`.
    pub fn next(&mut self, target: Duration) -> u32 {
        let n = match self.cost {
            None => 1,
            Some(c) if c <= 0.0 => (self.last * 2).clamp(1, 1024),
            Some(c) => ((target.as_secs_f64() / c) as u32)
                .clamp(1, (self.last * 4).max(1))
                .min(1024),
        };
        self.last = n;
        n
    }

    /// Whether a pass has completed (before, passes are one sample and queued one at a time,
    /// so a slow first pass does not make a short budget overrun by a second one).
    pub fn knows_cost(&self) -> bool {
        self.cost.is_some()
    }

    /// The expected time of `spp` samples per pixel (0 before any measurement).
    pub fn seconds(&self, spp: u32) -> f64 {
        self.cost.unwrap_or(0.0) * spp as f64
    }
}
