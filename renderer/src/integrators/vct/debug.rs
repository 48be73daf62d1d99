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

/// The octree's occupancy mask read back beside its attributes ([`DebugVolume::occupancy`]):
/// level-0 voxel coordinates, each list sorted.
#[derive(Debug, PartialEq, Eq)]
pub struct Occupancy {
    /// The voxels whose opacity is 1 (from the leaf-parent nodes and their attributes).
    pub occupied: Vec<[u32; 3]>,
    /// The voxels whose mask bit is set.
    pub marked: Vec<[u32; 3]>,
}

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

    /// The octree's occupancy mask against its attributes (shaders/vct/common.glsl,
    /// `occupancy_place`); None without a mask (dense storage, or a resolution above
    /// [`build::MASK_MAX_RESOLUTION`]).
    pub fn occupancy(&self) -> Result<Option<Occupancy>, RenderError> {
        let v = &self.volume;
        let base = v.params.caps[3] as usize;
        if base == 0 {
            return Ok(None);
        }
        let r = v.resolution;
        let n4 = (r / 4) as usize;
        let words = (v.nodes.size / 8) as usize;
        let nodes: Vec<[u32; 2]> = self.ctx.download_vec(&v.nodes, words)?;
        let k = (v.levels - 1) as usize;
        let (start, end) = (v.info.level_start[k] as usize, v.info.level_end[k] as usize);
        let attr: Vec<[u32; 4]> = self.ctx.download_vec(&v.attr, 8 * (end - start))?;
        // Step 1: occupied voxels from the leaf-parent nodes' packed cells and their slots.
        let mut occupied = Vec::new();
        for (i, node) in nodes[start..end].iter().enumerate() {
            let c = [
                node[1] & 1023,
                (node[1] >> 10) & 1023,
                (node[1] >> 20) & 1023,
            ];
            for o in 0..8u32 {
                if attr[8 * i + o as usize][0] >> 24 > 127 {
                    occupied.push([
                        2 * c[0] + (o & 1),
                        2 * c[1] + ((o >> 1) & 1),
                        2 * c[2] + (o >> 2),
                    ]);
                }
            }
        }
        occupied.sort_unstable();
        // Step 2: the mask's set bits, 4×4×4 bricks of 64 bits.
        let mut marked = Vec::new();
        for (b, w) in nodes[base..base + n4 * n4 * n4].iter().enumerate() {
            let bits = w[0] as u64 | (w[1] as u64) << 32;
            let brick = [b % n4, (b / n4) % n4, b / (n4 * n4)].map(|x| 4 * x as u32);
            for i in (0..64u32).filter(|i| bits >> i & 1 == 1) {
                marked.push([
                    brick[0] + (i & 3),
                    brick[1] + ((i >> 2) & 3),
                    brick[2] + (i >> 4),
                ]);
            }
        }
        marked.sort_unstable();
        Ok(Some(Occupancy { occupied, marked }))
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
