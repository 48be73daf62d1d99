//! The GPU side of `deferred`: its buffers (bindings 30–35 next to the session's scene
//! bindings), the three stage pipelines, and the recording of a pass. A pass runs in batches of
//! up to `batch` samples ([`super::batch`]); each batch runs the stages in order, each stage one
//! dispatch over all the batch's samples — `deferred gbuffer` (shaders/deferred/gbuffer.comp,
//! the dispatch's z = the sample within the batch), `deferred cull` (cull.comp, one workgroup
//! per 16×16 tile and sample) and `deferred shade` (shade.comp, one workgroup per tile whose
//! threads shade their pixel's samples in sample order) — so the G-buffer, the tile counts and
//! the tile lists hold one slice per sample of a batch, and their memory is bounded by the batch
//! size, not by the samples per pass.

use std::sync::Arc;

use bytemuck::{Pod, Zeroable};

use super::batch::{batch_size, batches, counter_cap};
use super::lights::{DeferredLight, LightSet};
use crate::error::RenderError;
use crate::gpu::{Binding, Buffer, BufferUsage, ComputePipeline, GpuContext};
use crate::gpu::{GpuResult, Recorder, ShaderDefines};
use crate::layout::GpuPush;

/// Binding indices of the stages' own buffers (B_* in shaders/deferred/common.glsl).
pub mod binding {
    pub const PARAMS: u32 = 30;
    pub const LIGHTS: u32 = 31;
    pub const GBUFFER: u32 = 32;
    pub const TILE_COUNTS: u32 = 33;
    pub const TILE_LIGHTS: u32 = 34;
    /// Shading counters (lights tested, lights shaded, pixels lit; 64-bit each).
    pub const COUNTERS: u32 = 35;
}

/// Screen tile side in pixels (TILE in common.glsl).
pub const TILE: u32 = 16;

/// Tile count marking an overflowed list (TILE_OVERFLOW in common.glsl).
pub const TILE_OVERFLOW: u32 = u32::MAX;

/// The stages' parameters (DParams in common.glsl, 48 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq, Default)]
pub struct DeferredParams {
    pub n_cull: u32,
    pub n_dir: u32,
    pub tiles_x: u32,
    pub tiles_y: u32,
    pub tile_capacity: u32,
    pub max_per_pixel: u32,
    pub shadows: u32,
    pub cull: u32,
    pub debug: u32,
    pub env_ambient: u32,
    pub pad: [u32; 2],
}

/// Sizes of what the stages allocate, bytes (G-buffer, tile counts and tile lists: `batch`
/// slices).
#[derive(Debug, Clone, Copy, Default, serde::Serialize)]
pub struct Memory {
    /// Samples per batch: slices of the per-sample buffers.
    pub batch: u32,
    pub gbuffer: u64,
    pub lights: u64,
    pub tile_counts: u64,
    pub tile_lists: u64,
    pub counters: u64,
    pub total: u64,
}

/// Buffers and pipelines built once per session by `setup`.
pub struct Stages {
    ctx: Arc<GpuContext>,
    pub params: DeferredParams,
    pub memory: Memory,
    gbuffer: ComputePipeline,
    cull: ComputePipeline,
    shade: ComputePipeline,
    _buffers: Vec<Buffer>,
    tile_counts: usize,
    width: u32,
    height: u32,
    /// Samples per batch (at most: a pass of spp samples is cut into ceil(spp / batch) even
    /// batches, [`batches`]).
    pub batch: u32,
}

/// The label of a stage's dispatch over `n` samples, e.g. "deferred gbuffer ×4".
pub fn stage_label(stage: &str, n: u32) -> String {
    format!("deferred {stage} ×{n}")
}

/// The stage and sample count of a [`stage_label`]; None for other labels.
pub fn parse_stage_label(label: &str) -> Option<(&str, u32)> {
    let (stage, n) = label.strip_prefix("deferred ")?.split_once(" ×")?;
    Some((stage, n.parse().ok()?))
}

impl Stages {
    /// Uploads the light set and builds the stage pipelines, binding the stages' buffers next to
    /// the session's `shared` ones; `batch`: the `samples_per_batch` option (None: automatic).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        ctx: &Arc<GpuContext>,
        width: u32,
        height: u32,
        set: &LightSet,
        mut params: DeferredParams,
        batch: Option<u32>,
        shared: &[Binding<'_>],
        defines: &ShaderDefines,
    ) -> Result<Stages, RenderError> {
        // Step 1: tile grid and list capacity (never more than the lights to cull).
        params.tiles_x = width.div_ceil(TILE);
        params.tiles_y = height.div_ceil(TILE);
        params.n_cull = set.n_cull;
        params.n_dir = set.n_dir;
        params.tile_capacity = params.tile_capacity.min(set.n_cull).max(1);
        let tiles = params.tiles_x as u64 * params.tiles_y as u64;
        let pixels = width as u64 * height as u64;
        // Step 2: samples per batch, each with its slice of the per-sample buffers.
        let llvmpipe = ctx.info.name.contains("llvmpipe");
        let batch = batch_size(pixels, tiles, params.tile_capacity, batch, llvmpipe)
            .min(counter_cap(set.n_cull.saturating_add(set.n_dir)));
        let slices = batch as u64;
        // Step 3: buffers.
        let lights: &[DeferredLight] = &set.lights;
        let buffers = vec![
            Buffer::from_slice(ctx, "deferred params", std::slice::from_ref(&params))?,
            Buffer::from_slice(ctx, "deferred lights", lights)?,
            Buffer::new(
                ctx,
                "deferred gbuffer",
                slices * pixels * super::gbuffer::BYTES_PER_PIXEL as u64,
                BufferUsage::Storage,
            )?,
            Buffer::new(
                ctx,
                "deferred tile counts",
                slices * tiles * 4,
                BufferUsage::Storage,
            )?,
            Buffer::new(
                ctx,
                "deferred tile lists",
                slices * tiles * params.tile_capacity as u64 * 4,
                BufferUsage::Storage,
            )?,
            Buffer::new(ctx, "deferred counters", 24, BufferUsage::Storage)?,
        ];
        for b in &buffers[2..] {
            ctx.fill_zero(b)?;
        }
        let memory = Memory {
            batch,
            gbuffer: buffers[2].size,
            lights: buffers[1].size,
            tile_counts: buffers[3].size,
            tile_lists: buffers[4].size,
            counters: buffers[5].size,
            total: buffers.iter().map(|b| b.size).sum(),
        };
        let own = [
            binding::PARAMS,
            binding::LIGHTS,
            binding::GBUFFER,
            binding::TILE_COUNTS,
            binding::TILE_LIGHTS,
            binding::COUNTERS,
        ];
        let mut bindings: Vec<Binding<'_>> = shared
            .iter()
            .map(|b| Binding {
                index: b.index,
                buffer: b.buffer,
            })
            .collect();
        for (index, buffer) in own.into_iter().zip(&buffers) {
            bindings.push(Binding { index, buffer });
        }
        // Step 4: the stage pipelines, for the scene's feature set.
        let push = std::mem::size_of::<GpuPush>() as u32;
        let build = |kernel: &str| -> Result<ComputePipeline, RenderError> {
            let spirv = ctx.kernel(kernel, defines)?;
            Ok(ComputePipeline::new(ctx, kernel, &spirv, &bindings, push)?)
        };
        let gbuffer = build("deferred/gbuffer.comp")?;
        let cull = build("deferred/cull.comp")?;
        let shade = build("deferred/shade.comp")?;
        drop(bindings);
        Ok(Stages {
            ctx: ctx.clone(),
            params,
            memory,
            gbuffer,
            cull,
            shade,
            _buffers: buffers,
            tile_counts: tiles as usize,
            width,
            height,
            batch,
        })
    }

    /// The dispatches a pass of `spp` samples records: three per batch.
    pub fn dispatches(&self, spp: u32) -> u32 {
        3 * spp.div_ceil(self.batch)
    }

    /// Records the three stages for each batch of the pass's `push.spp` samples: the batch's
    /// push constants name its first sample (`sample_base`) and its size (`spp`).
    pub fn record(&self, rec: &mut Recorder<'_>, push: GpuPush) -> GpuResult<()> {
        for (first, n) in batches(push.spp, self.batch) {
            let p = GpuPush {
                sample_base: push.sample_base + first,
                spp: n,
                ..push
            };
            let bytes = bytemuck::bytes_of(&p);
            let pixel_groups = [self.width.div_ceil(8), self.height.div_ceil(8), n];
            let cull_groups = [self.params.tiles_x, self.params.tiles_y, n];
            let shade_groups = [self.params.tiles_x, self.params.tiles_y, 1];
            rec.dispatch(
                &self.gbuffer,
                bytes,
                pixel_groups,
                &stage_label("gbuffer", n),
            )?;
            rec.dispatch(&self.cull, bytes, cull_groups, &stage_label("cull", n))?;
            rec.dispatch(&self.shade, bytes, shade_groups, &stage_label("shade", n))?;
        }
        Ok(())
    }

    /// Reads the shading counters: (candidate lights tested, lights that reached their pixel,
    /// pixel samples shaded with direct light) since the stages were made. They are 64-bit
    /// (the shader carries into the high word), so they are never cleared, and read only when
    /// the statistics are asked for: a read waits for the queued passes, and one per pass
    /// (with a clear) drained the pass queue, the GPU idle while the next pass was recorded.
    pub fn counters(&self) -> GpuResult<[u64; 3]> {
        let c: Vec<[u32; 2]> = self.ctx.download_vec(&self._buffers[5], 3)?;
        Ok([0, 1, 2].map(|i| ((c[i][1] as u64) << 32) | c[i][0] as u64))
    }

    /// The light counts of the tile lists of the first sample of the last batch rendered (slice
    /// 0, which every batch writes; TILE_OVERFLOW for an overflowed tile).
    pub fn tile_counts(&self) -> GpuResult<Vec<u32>> {
        self.ctx.download_vec(&self._buffers[3], self.tile_counts)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stage_labels_carry_the_batch() {
        assert_eq!(
            parse_stage_label(&stage_label("gbuffer", 12)),
            Some(("gbuffer", 12))
        );
        assert_eq!(parse_stage_label("deferred emitters"), None);
        assert_eq!(parse_stage_label("nee"), None);
    }
}
