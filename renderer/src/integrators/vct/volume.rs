//! The built voxel volume: its GPU buffers (kept after the build: octree nodes, per-voxel
//! attributes, emission, injected radiance, the filtered levels), what it holds (fragments,
//! nodes, voxels, level ranges) and what each stage cost. Fragments and the build-time sums are
//! freed once the attributes are averaged; re-injection needs only the attributes.

use super::gpu::{VctInfo, VctParams};
use super::options::VctStorage;
use crate::compile::CompiledScene;
use crate::gpu::Buffer;

/// GPU milliseconds per stage (timestamp queries; 0 where the device has none).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct StageTimes {
    pub voxelize_ms: f64,
    pub build_ms: f64,
    pub inject_ms: f64,
    pub filter_ms: f64,
    pub bounce_ms: f64,
}

/// A voxel volume on one device.
pub struct Volume {
    pub params: VctParams,
    pub params_buf: Buffer,
    pub info_buf: Buffer,
    pub dummy: Buffer,
    /// Octree node pool (a placeholder for dense storage).
    pub nodes: Buffer,
    pub attr: Buffer,
    pub emit: Buffer,
    pub rad: Buffer,
    /// Dense: mip levels ≥ 1; octree: the brick pool of inner nodes (6 directions per sample).
    pub mip: Buffer,
    /// Octree: the brick pool of leaf-parent nodes (level 0); a placeholder for dense storage.
    pub leaf: Buffer,
    /// Second-bounce radiance per slot (allocated for `bounces: 2`).
    pub bounce: Option<Buffer>,
    pub storage: VctStorage,
    pub resolution: u32,
    pub levels: u32,
    pub fragments: u32,
    pub nodes_used: u32,
    pub slots: u32,
    pub voxels: u32,
    pub info: VctInfo,
    /// Bytes of the fragment list and build sums while they existed.
    pub build_peak_bytes: u64,
    pub build_times: StageTimes,
    /// Injection, filtering and bounce timings of the last lighting.
    pub light_times: StageTimes,
    /// Key of the lights (and lighting options) the radiance was injected for.
    pub lights_key: Option<u64>,
    /// The grid's minimum corner in world space (f64): `params.grid.xyz` is it relative to the
    /// camera of the render that uses the volume (see [`Volume::place`]).
    pub world_min: [f64; 3],
}

impl Volume {
    /// Bytes per kept buffer.
    pub fn memory(&self) -> Vec<(&'static str, u64)> {
        let mut m = vec![
            ("params", self.params_buf.size + self.info_buf.size),
            (
                "nodes",
                if self.storage == VctStorage::Octree {
                    self.nodes.size
                } else {
                    0
                },
            ),
            ("attributes", self.attr.size),
            ("emission", self.emit.size),
            ("radiance", self.rad.size),
            ("mip", self.mip.size),
            (
                "leaf_bricks",
                if self.storage == VctStorage::Octree {
                    self.leaf.size
                } else {
                    0
                },
            ),
        ];
        if let Some(b) = &self.bounce {
            m.push(("bounce", b.size));
        }
        m
    }

    /// Places the volume for a render whose camera is at `camera` (world space): its corner
    /// relative to that camera, computed in f64 like the rest of the scene. Voxel contents are
    /// grid-relative, so nothing else moves.
    pub fn place(
        &mut self,
        ctx: &std::sync::Arc<crate::gpu::GpuContext>,
        camera: [f64; 3],
    ) -> crate::gpu::GpuResult<()> {
        let rel = [0, 1, 2].map(|i| (self.world_min[i] - camera[i]) as f32);
        if rel
            != [
                self.params.grid[0],
                self.params.grid[1],
                self.params.grid[2],
            ]
        {
            self.params.grid[..3].copy_from_slice(&rel);
            ctx.upload(&self.params_buf, 0, bytemuck::bytes_of(&self.params))?;
        }
        Ok(())
    }

    pub fn total_bytes(&self) -> u64 {
        self.memory().iter().map(|(_, b)| b).sum()
    }
}

/// The cube the volume covers, fitted to the scene's primitives (camera-relative): their
/// bounding box's longest side plus two voxels of margin on every side, centred on the box.
/// Returns (minimum corner, voxel size).
pub fn fit_grid(scene: &CompiledScene, resolution: u32) -> ([f32; 3], f32) {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for p in &scene.prims {
        let sphere = p.a[3].to_bits() & crate::layout::PRIM_SPHERE != 0;
        if sphere {
            for i in 0..3 {
                lo[i] = lo[i].min(p.a[i] - p.b[0]);
                hi[i] = hi[i].max(p.a[i] + p.b[0]);
            }
        } else {
            for v in [&p.a, &p.b, &p.c] {
                for i in 0..3 {
                    lo[i] = lo[i].min(v[i]);
                    hi[i] = hi[i].max(v[i]);
                }
            }
        }
    }
    if !lo.iter().chain(hi.iter()).all(|x| x.is_finite()) {
        // No geometry: a unit cube around the origin (nothing will be voxelized).
        return ([-0.5; 3], 1.0 / resolution as f32);
    }
    let ext = (0..3).map(|i| hi[i] - lo[i]).fold(0f32, f32::max).max(1e-6);
    let r = resolution as f32;
    let side = ext * r / (r - 4.0);
    let voxel = side / r;
    let min = [0, 1, 2].map(|i| 0.5 * (lo[i] + hi[i]) - 0.5 * side);
    (min, voxel)
}
