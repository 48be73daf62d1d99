//! Debugging and testing aids: build a scene's volume outside a render session and sample it
//! (the tests compare the octree with the dense storage this way), or read its statistics.

use std::sync::Arc;

use super::options::VctOptions;
use super::{build, cache, volume::Volume};
use crate::compile::CompiledScene;
use crate::error::RenderError;
use crate::gpu::{Buffer, GpuContext};
use crate::layout::{binding, GpuStats};
use crate::upload::{as_bindings, upload_scene};

/// A built and lit volume with the scene buffers its kernels bind.
pub struct DebugVolume {
    ctx: Arc<GpuContext>,
    scene_buffers: Vec<(u32, Buffer)>,
    volume: Volume,
    defines: crate::gpu::ShaderDefines,
}

impl DebugVolume {
    /// Uploads `scene` and builds and lights its volume with `options` (never cached).
    pub fn new(
        ctx: &Arc<GpuContext>,
        scene: &CompiledScene,
        options: &VctOptions,
    ) -> Result<Self, RenderError> {
        let s = options.settings()?;
        let up = |name: &str, bytes: &[u8]| Buffer::from_slice(ctx, name, bytes);
        let mut scene_buffers = upload_scene(ctx, scene)?;
        scene_buffers.push((binding::ACCUM, up("accum (unused)", &[0u8; 16])?));
        let stats = [0u8; std::mem::size_of::<GpuStats>()];
        scene_buffers.push((binding::STATS, up("stats (unused)", &stats)?));
        let defines = scene.features.defines();
        let shared = as_bindings(&scene_buffers);
        let mut volume = build::build(ctx, scene, &shared, &defines, &s)?;
        volume.light(ctx, &shared, &defines, &s, cache::lights_key(scene, &s))?;
        drop(shared);
        ctx.check_validation()?;
        Ok(DebugVolume {
            ctx: ctx.clone(),
            scene_buffers,
            volume,
            defines,
        })
    }

    /// Samples the filtered volume: each probe is ((grid x, y, z, level), (direction, 0)); a
    /// level −(m+1) reads exactly level m (no blend between levels). Grid units: level-0
    /// voxels, corners at integers.
    pub fn probe(&self, probes: &[([f32; 4], [f32; 4])]) -> Result<Vec<[f32; 4]>, RenderError> {
        let shared = as_bindings(&self.scene_buffers);
        let out = self
            .volume
            .probe(&self.ctx, &shared, &self.defines, probes)?;
        self.ctx.check_validation()?;
        Ok(out)
    }

    /// Voxels per axis and levels.
    pub fn resolution(&self) -> (u32, u32) {
        (self.volume.resolution, self.volume.levels)
    }

    /// Occupied voxels, fragments, octree nodes used.
    pub fn counts(&self) -> (u32, u32, u32) {
        (
            self.volume.voxels,
            self.volume.fragments,
            self.volume.nodes_used,
        )
    }

    /// Bytes of the kept buffers.
    pub fn memory_bytes(&self) -> u64 {
        self.volume.total_bytes()
    }

    /// Timings of the build and of the lighting.
    pub fn timings(&self) -> (super::StageTimes, super::StageTimes) {
        (self.volume.build_times, self.volume.light_times)
    }
}
