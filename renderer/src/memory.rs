//! Memory figures of a scene and the check that it fits the device, before anything is
//! allocated:
//!
//! - [`SceneBytes`]: the GPU bytes of a compiled scene's buffers, split into geometry
//!   (primitives and per-triangle shading data), acceleration structure (BVH nodes and parent
//!   pointers, the CWBVH's nodes and leaf primitive indices, or the grid) and the rest (materials, textures, lights, ...);
//! - [`peak_rss_bytes`]: the host process's peak resident memory (`VmHWM` of
//!   /proc/self/status; None where there is no /proc);
//! - [`check_fits`]: every buffer within the device's `maxStorageBufferRange` and all of them
//!   (a render session checks the scene's with its film's and its integrator's scratch and
//!   per-pixel buffers) within its largest device-local heap, else an error naming the buffer,
//!   its size and the limit (a render too large for the device is refused with that message
//!   instead of failing in the driver). The limits can be lowered for tests and for sharing a GPU with
//!   `CANDELA_GPU_MEMORY_LIMIT` and `CANDELA_GPU_BUFFER_LIMIT` (bytes; see `gpu::DeviceLimits`).

use serde::Serialize;

use crate::compile::CompiledScene;
use crate::gpu::GpuError;
pub use crate::gpu::{DeviceLimits, BUFFER_LIMIT_ENV, MEMORY_LIMIT_ENV};

/// GPU bytes of a compiled scene's buffers.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct SceneBytes {
    /// Primitives and per-triangle shading data (normals, uvs).
    pub geometry: u64,
    /// BVH nodes and parent pointers, the CWBVH's nodes and leaf indices, or the grid's buffers;
    /// with instances also their records and the top-level BVH.
    pub accel: u64,
    /// Everything else the scene uploads: materials, textures, lights, globals.
    pub other: u64,
}

impl SceneBytes {
    pub fn total(&self) -> u64 {
        self.geometry + self.accel + self.other
    }
}

/// Bytes of a slice as uploaded.
fn size<T>(v: &[T]) -> u64 {
    std::mem::size_of_val(v) as u64
}

/// The scene's buffers as (name, bytes as allocated); the names are the upload's.
pub fn scene_buffers(s: &CompiledScene) -> Vec<(&'static str, u64)> {
    let mut v = vec![
        ("globals", std::mem::size_of_val(&s.globals) as u64),
        ("bvh nodes", size(&s.nodes)),
        ("bvh parents", size(&s.bvh_parents)),
        ("prims", size(&s.prims)),
        ("tri shading", size(&s.tri_shading)),
        ("materials", size(&s.materials)),
        ("textures", size(&s.textures)),
        ("texels", size(&s.texels)),
        ("lights", size(&s.lights)),
        ("light alias", size(&s.alias)),
        ("env distribution", size(&s.env_dist)),
    ];
    if !s.instances.is_empty() {
        v.push(("instances", size(&s.instances)));
        v.push(("tlas nodes", size(&s.tlas_nodes)));
    }
    if let Some(g) = &s.grid {
        v.push(("grid", std::mem::size_of_val(&g.info) as u64));
        v.push(("grid cells", size(&g.cells)));
        v.push(("grid prims", size(&g.prims)));
    }
    if let Some(c) = &s.cwbvh {
        v.push(("cwbvh nodes", size(&c.nodes)));
        if !c.prims.is_empty() {
            v.push(("cwbvh prims", size(&c.prims)));
        }
    }
    // As allocated: Vulkan has no empty buffers (gpu::Buffer rounds up to 16 bytes).
    v.into_iter()
        .map(|(n, b)| (n, b.max(16).next_multiple_of(4)))
        .collect()
}

/// The scene's GPU bytes by kind.
pub fn scene_bytes(s: &CompiledScene) -> SceneBytes {
    let mut b = SceneBytes::default();
    for (name, bytes) in scene_buffers(s) {
        match name {
            "prims" | "tri shading" => b.geometry += bytes,
            "bvh nodes" | "bvh parents" | "grid" | "grid cells" | "grid prims" | "cwbvh nodes"
            | "cwbvh prims" | "instances" | "tlas nodes" => b.accel += bytes,
            _ => b.other += bytes,
        }
    }
    b
}

fn mib(bytes: u64) -> String {
    format!("{:.1} MiB", bytes as f64 / (1024.0 * 1024.0))
}

/// Checks that `buffers` fit `limits`: each within the largest storage buffer, all together
/// within device memory. The error names the buffer or the total and the limit.
pub fn check_fits(buffers: &[(&str, u64)], limits: &DeviceLimits) -> Result<(), GpuError> {
    let how = if limits.lowered {
        format!(" (lowered by {MEMORY_LIMIT_ENV} / {BUFFER_LIMIT_ENV})")
    } else {
        String::new()
    };
    for &(name, bytes) in buffers {
        if bytes > limits.max_buffer_bytes {
            return Err(GpuError::TooLarge(format!(
                "the {name} buffer needs {} ({bytes} bytes), more than the device's \
                 largest storage buffer, maxStorageBufferRange = {} ({} bytes){how}",
                mib(bytes),
                mib(limits.max_buffer_bytes),
                limits.max_buffer_bytes
            )));
        }
    }
    let total: u64 = buffers.iter().map(|b| b.1).sum();
    if total > limits.memory_bytes {
        let (name, most) = buffers
            .iter()
            .max_by_key(|b| b.1)
            .copied()
            .unwrap_or(("", 0));
        return Err(GpuError::TooLarge(format!(
            "the render needs {} of GPU memory ({total} bytes; the largest buffer, {name}, {}), \
             more than the device's memory, {} ({} bytes){how}",
            mib(total),
            mib(most),
            mib(limits.memory_bytes),
            limits.memory_bytes
        )));
    }
    Ok(())
}

/// The process's peak resident memory in bytes (Linux `VmHWM`), None where unknown.
pub fn peak_rss_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_check_names_the_buffer_and_the_limit() {
        let limits = DeviceLimits {
            max_buffer_bytes: 1000,
            memory_bytes: 1500,
            lowered: false,
            max_workgroup_tiles: 16,
        };
        assert!(check_fits(&[("prims", 1000), ("bvh nodes", 500)], &limits).is_ok());
        let e = check_fits(&[("prims", 1001)], &limits)
            .unwrap_err()
            .to_string();
        assert!(e.contains("prims") && e.contains("maxStorageBufferRange") && e.contains("1000"));
        let e = check_fits(&[("prims", 900), ("bvh nodes", 700)], &limits)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("1600 bytes") && e.contains("1500 bytes") && e.contains("prims"),
            "{e}"
        );
    }

    #[test]
    fn peak_rss_is_read_on_linux() {
        let rss = peak_rss_bytes();
        if cfg!(target_os = "linux") {
            assert!(rss.unwrap() > 1 << 20, "{rss:?}");
        }
    }
}
