//! Progressive rendering: a `RenderSession` owns the uploaded scene, the accumulation buffer and
//! the integrator's pipeline, and runs passes of N samples per pixel. Sample indices are the RNG
//! key, so the image depends only on (seed, total spp), never on the pass split.
//! `render` drives a session to an spp or wall-time budget.

mod session;

pub use crate::error::RenderError;
pub use session::{PassStats, Progress, RenderSession, LLVMPIPE_MAX_DISPATCHES};

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
    /// The integrator's own statistics (stage timings, memory), where it has any.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub details: Option<serde_json::Value>,
}

/// Renders to the budget and returns the image (radiance per pixel) and what happened.
pub fn render(
    session: &mut RenderSession,
    budget: Budget,
) -> Result<(Image, RenderStats), RenderError> {
    match budget {
        Budget::Spp(total) => {
            // Passes sized to about a quarter second each after the first, so long renders
            // report progress and the device is never held for long by one dispatch.
            let mut per_pass = 1u32;
            while session.spp() < total {
                let n = per_pass.min(total - session.spp());
                let s = session.run_pass(n)?;
                per_pass = next_pass_size(n, s.wall, Duration::from_millis(250));
            }
        }
        Budget::Time(seconds) => {
            let limit = Duration::from_secs_f64(seconds.max(0.0));
            let mut per_pass = 1u32;
            loop {
                let s = session.run_pass(per_pass)?;
                let left = limit.saturating_sub(session.elapsed());
                if left.is_zero() {
                    break;
                }
                per_pass = next_pass_size(per_pass, s.wall, Duration::from_millis(250).min(left));
            }
        }
    }
    let image = session.image()?;
    Ok((image, session.stats()))
}

/// Samples per pixel for the next pass so that it takes about `target`.
pub fn next_pass_size(last_spp: u32, last_wall: Duration, target: Duration) -> u32 {
    let per_sample = last_wall.as_secs_f64() / last_spp.max(1) as f64;
    if per_sample <= 0.0 {
        return (last_spp * 2).clamp(1, 1024);
    }
    ((target.as_secs_f64() / per_sample) as u32)
        .clamp(1, (last_spp * 4).max(1))
        .min(1024)
}
