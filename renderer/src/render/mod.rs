//! Progressive rendering: a `RenderSession` owns the uploaded scene, the accumulation buffer and
//! the integrator's pipeline, and runs passes of N samples per pixel, queued back to back
//! (inflight.rs) and cut into dispatches sized to the GPU (dispatch.rs). Sample indices are the
//! RNG key, so the image depends only on (seed, total spp), never on the pass split or the
//! dispatch shape. `render` drives a session to an spp or wall-time budget; `render_split`
//! drives several sessions (devices) on disjoint sample indices and merges their sums.

mod dispatch;
mod inflight;
mod session;
mod shards;

pub use crate::error::RenderError;
pub use dispatch::{DispatchShape, MAX_LANES};
pub use inflight::{AccumSnapshot, CompletedPass, PassStats, PIPELINE_DEPTH};
pub use session::{Progress, RenderSession, LLVMPIPE_MAX_DISPATCHES};
pub use shards::{merge_accumulation, render_split, SampleDispenser, SplitRender};

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
    /// The acceleration structure: "bvh" or "grid".
    pub accel: String,
    /// Seconds to obtain it: its build, or loading it from the cache on a hit.
    pub accel_build_s: f64,
    /// Bytes of its GPU buffers.
    pub accel_bytes: u64,
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
    let target = Duration::from_millis(250);
    let mut sizer = PassSizer::default();
    loop {
        // Step 1: keep the queue full while the budget has room (one pass at a time until a
        // pass has shown what a sample costs).
        while session.in_flight() < PIPELINE_DEPTH
            && (sizer.knows_cost() || session.in_flight() == 0)
        {
            let n = match budget {
                Budget::Spp(total) => {
                    let left = total.saturating_sub(session.submitted_spp());
                    if left == 0 {
                        break;
                    }
                    sizer.next(target).min(left)
                }
                Budget::Time(seconds) => {
                    let committed = session.elapsed().as_secs_f64()
                        + sizer.seconds(session.submitted_spp() - session.spp());
                    let left = seconds.max(0.0) - committed;
                    if left <= 0.0 && session.submitted_spp() > 0 {
                        break;
                    }
                    sizer.next(target.min(Duration::from_secs_f64(left.max(0.0))))
                }
            };
            for p in session.submit_pass(n, false)? {
                sizer.observe(&p.stats);
            }
        }
        // Step 2: the oldest pass; done when none is left.
        match session.complete_oldest()? {
            Some(p) => sizer.observe(&p.stats),
            None => break,
        }
    }
    let image = session.image()?;
    Ok((image, session.stats()))
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
