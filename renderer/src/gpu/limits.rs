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
    /// The tiles per workgroup a kernel's defines ask for (`WG_TILES`; 1 where absent): the one
    /// reading of that define, for the render session (which checks it once) and for
    /// integrators that size passes of their own with it (bdpt's light pass). An error names
    /// the value and this device's limit.
    pub fn workgroup_tiles_of(&self, defines: &super::ShaderDefines) -> Result<u32, String> {
        let Some((_, v)) = defines.iter().find(|(name, _)| name == "WG_TILES") else {
            return Ok(1);
        };
        let max = self.max_workgroup_tiles;
        match v.parse::<u32>() {
            Ok(n) if (1..=max).contains(&n) => Ok(n),
            _ => Err(format!(
                "WG_TILES must be 1 to {max} tiles of 64 threads on this device, got {v:?}"
            )),
        }
    }

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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_workgroup_tiles_define_is_read_and_bounded() {
        let limits = DeviceLimits {
            max_buffer_bytes: 1 << 30,
            memory_bytes: 1 << 32,
            lowered: false,
            max_workgroup_tiles: 16,
        };
        let d = |v: &str| {
            vec![
                ("A".to_string(), "1".to_string()),
                ("WG_TILES".to_string(), v.to_string()),
            ]
        };
        assert_eq!(limits.workgroup_tiles_of(&vec![]), Ok(1));
        assert_eq!(limits.workgroup_tiles_of(&d("10")), Ok(10));
        assert_eq!(limits.workgroup_tiles_of(&d("16")), Ok(16));
        for bad in ["0", "17", "ten", ""] {
            let e = limits.workgroup_tiles_of(&d(bad)).unwrap_err();
            assert!(
                e.contains("1 to 16") && e.contains(&format!("{bad:?}")),
                "{e}"
            );
        }
    }
}
