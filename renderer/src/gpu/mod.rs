//! The Vulkan compute layer, on ash: device selection, buffers, shader compilation, compute
//! pipelines and timed, labelled dispatches. One concept per file (after kajiya's wrappers):
//! `context` (instance, device, queue, validation), `buffer`, `shader` (GLSL → SPIR-V with
//! glslang, in-process), `kernel_cache` (compiled kernels in memory and on disk, the driver's
//! pipeline cache, parallel compiles), `pipeline` (compute pipelines and their descriptor
//! sets), `lru` (the bounds of the in-memory caches), `commands` (recording, submission,
//! timestamps), `staging` (the reused host-visible memory of uploads and readbacks).
//!
//! Everything is Vulkan 1.2 compute, so the same code runs on Mesa lavapipe (tests, CI) and on
//! NVIDIA GPUs.

mod buffer;
mod commands;
mod context;
mod kernel_cache;
mod limits;
mod lru;
mod pipeline;
mod shader;
mod staging;

pub use buffer::{Buffer, BufferUsage};
pub use commands::{DispatchTiming, Frame, Recorder};
pub use context::{list_devices, DeviceInfo, GpuContext, GpuOptions};
pub use kernel_cache::{
    clear_spirv_memory, compile_glsl, compile_kernels, compile_uncached, kernel_spirv,
    kernel_stats, source_closure, spirv_key, spirv_memory, spirv_path, DriverKey, KernelStats,
};
pub use limits::{DeviceLimits, BUFFER_LIMIT_ENV, MEMORY_LIMIT_ENV};
pub use lru::{cache_limits, set_cache_limits, CacheLimits};
pub use pipeline::{kernel_variants_seen, live_pipelines, Binding, ComputePipeline};
pub use shader::{shader_source, Constant, ShaderDefines, COMPILER_ID};
pub(crate) use staging::host_read_barrier;

/// Errors of the GPU layer. Messages name the stage that failed.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error("Vulkan loader not found ({0}); install a Vulkan driver (e.g. apt-get install mesa-vulkan-drivers libvulkan1)")]
    Loader(String),
    #[error("no Vulkan 1.2 device found{0}")]
    NoDevice(String),
    /// `VK_ERROR_DEVICE_LOST` from any call: the device and everything made on it must be
    /// dropped and created again (the server's worker does, resuming jobs from checkpoints).
    #[error("{stage}: device lost (VK_ERROR_DEVICE_LOST)")]
    DeviceLost { stage: &'static str },
    #[error("{stage}: {result}")]
    Vk {
        stage: &'static str,
        result: ash::vk::Result,
    },
    #[error("GPU memory allocation for {name} failed: {message}")]
    Alloc { name: String, message: String },
    #[error("shader {name} failed to compile: {log}")]
    Shader { name: String, log: String },
    /// A render larger than the device allows (renderer::memory::check_fits: the scene's
    /// buffers with the film's and the integrator's), found before anything was allocated; the
    /// message names the buffer or total and the limit.
    #[error("render does not fit the device: {0}")]
    TooLarge(String),
    #[error("validation layer reported: {0}")]
    Validation(String),
    #[error("{0}")]
    Other(String),
}

impl GpuError {
    /// Maps a Vulkan result of `stage`; `VK_ERROR_DEVICE_LOST` becomes [`GpuError::DeviceLost`].
    pub(crate) fn vk(stage: &'static str) -> impl FnOnce(ash::vk::Result) -> GpuError {
        move |result| match result {
            ash::vk::Result::ERROR_DEVICE_LOST => GpuError::DeviceLost { stage },
            result => GpuError::Vk { stage, result },
        }
    }

    /// Whether the device was lost (drop it and everything made on it, then start again).
    pub fn is_device_lost(&self) -> bool {
        matches!(self, GpuError::DeviceLost { .. })
    }
}

pub type GpuResult<T> = Result<T, GpuError>;
