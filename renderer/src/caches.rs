//! What the in-memory caches held across renders hold, for the server's `/metrics` and for
//! tests: the SPIR-V of kernel variants (process-wide), a device's pipeline objects and the
//! driver's pipeline cache, and vct's voxel volumes. Their bounds are
//! [`crate::gpu::CacheLimits`] (set once per process with [`crate::gpu::set_cache_limits`]).
//!
//! The acceleration-structure cache is on disk only (accel/cache.rs): a prepared scene's BVH
//! lives as long as its render.

use serde::Serialize;

use crate::gpu::{
    cache_limits, kernel_variants_seen, live_pipelines, spirv_memory, CacheLimits, GpuContext,
};

/// Sizes of the in-memory caches.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct CacheStats {
    /// SPIR-V modules kept in memory, their bytes, and evictions so far.
    pub kernels: usize,
    pub kernel_bytes: u64,
    pub kernel_evictions: u64,
    /// The device's cached pipeline objects and evictions so far (0 without a device).
    pub pipelines: usize,
    pub pipeline_evictions: u64,
    /// Pipeline objects alive in the process (cached, or held by live sessions).
    pub pipelines_live: u64,
    /// Distinct kernel variants made into pipelines since the process started (kept or not).
    pub kernel_variants: u64,
    /// The driver's pipeline cache data, bytes, as last saved (None without a cache folder).
    pub pipeline_cache_bytes: Option<u64>,
    /// vct volumes kept and their GPU bytes.
    pub volumes: usize,
    pub volume_bytes: u64,
    /// The bounds in force.
    pub limits: CacheLimits,
}

/// The caches' sizes now; the device's part from `ctx` when given.
pub fn stats(ctx: Option<&GpuContext>) -> CacheStats {
    let (kernels, kernel_bytes, kernel_evictions) = spirv_memory();
    let (pipelines, pipeline_evictions) = ctx.map_or((0, 0), |c| c.pipeline_usage());
    let (volumes, volume_bytes) = crate::integrators::vct::cache::usage();
    CacheStats {
        kernels,
        kernel_bytes,
        kernel_evictions,
        pipelines,
        pipeline_evictions,
        pipelines_live: live_pipelines(),
        kernel_variants: kernel_variants_seen(),
        pipeline_cache_bytes: ctx.and_then(|c| c.pipeline_cache_bytes()),
        volumes,
        volume_bytes,
        limits: cache_limits(),
    }
}
