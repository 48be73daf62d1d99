//! What the device can hold: its largest storage buffer and device-local heap (and its largest
//! workgroup, which bounds the film kernels' `WG_TILES`), read when the
//! device opens, optionally lowered by environment variables (for tests, and to leave room on a
//! shared GPU). `crate::memory` checks scenes against them before uploading.

use serde::Serialize;

/// Environment variable lowering the device memory available to a scene (bytes).
pub const MEMORY_LIMIT_ENV: &str = "CANDELA_GPU_MEMORY_LIMIT";
/// Environment variable lowering the largest storage buffer (bytes).
pub const BUFFER_LIMIT_ENV: &str = "CANDELA_GPU_BUFFER_LIMIT";

/// What the device can hold.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct DeviceLimits {
    /// `maxStorageBufferRange`: the largest storage buffer a kernel can address.
    pub max_buffer_bytes: u64,
    /// The largest device-local memory heap.
    pub memory_bytes: u64,
    /// Whether an environment variable lowered either figure.
    pub lowered: bool,
    /// The most 8 × 8-thread tiles one workgroup may hold (its z size):
    /// `maxComputeWorkGroupInvocations` / 64, at most `maxComputeWorkGroupSize[2]`
    /// (render/dispatch.rs, `workgroup_tiles`, lowers an integrator's tiles to it).
    pub max_workgroup_tiles: u32,
}

impl DeviceLimits {
    /// The device's limits, lowered by [`MEMORY_LIMIT_ENV`] / [`BUFFER_LIMIT_ENV`] when set.
    pub fn new(max_buffer_bytes: u64, memory_bytes: u64, max_workgroup_tiles: u32) -> DeviceLimits {
        let env = |name: &str| {
            std::env::var(name)
                .ok()
                .and_then(|v| v.trim().parse::<u64>().ok())
        };
        let (mem, buf) = (env(MEMORY_LIMIT_ENV), env(BUFFER_LIMIT_ENV));
        DeviceLimits {
            max_buffer_bytes: buf.map_or(max_buffer_bytes, |b| b.min(max_buffer_bytes)),
            memory_bytes: mem.map_or(memory_bytes, |m| m.min(memory_bytes)),
            lowered: mem.is_some() || buf.is_some(),
            max_workgroup_tiles: max_workgroup_tiles.max(1),
        }
    }
}
