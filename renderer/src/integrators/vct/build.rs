//! Building the volume on the GPU: (1) conservative voxelization into a fragment list (a
//! counting pass, one readback of the count, the emitting pass), (2) the storage: the sparse
//! voxel octree level by level (flag / alloc / mark per depth, all recorded in one submission:
//! no CPU round trip per level; one readback of the level ranges at the end, repeated with a
//! larger pool in the rare case the node-pool estimate was too small) or the dense grid,
//! (3) per-voxel attributes averaged from the fragments. Lighting (injection, filtering,
//! bounces) is in light.rs.

use std::sync::Arc;

use super::gpu::{self, bindings, groups_1d, pipeline, push, Set, VctInfo, VctParams, ACC_WORDS};
use super::options::{Settings, VctStorage};
use super::volume::{fit_grid, StageTimes, Volume};
use crate::compile::CompiledScene;
use crate::error::RenderError;
use crate::gpu::{Binding, Buffer, BufferUsage, GpuContext, ShaderDefines};

fn storage_buffer(ctx: &Arc<GpuContext>, name: &str, bytes: u64) -> Result<Buffer, RenderError> {
    Ok(Buffer::new(ctx, name, bytes, BufferUsage::Storage)?)
}

fn sum_ms(t: &[crate::gpu::DispatchTiming]) -> f64 {
    t.iter().map(|d| d.gpu_ms).sum()
}

/// Octree node-pool estimate for `frags` fragments: depth k+1 gets a tile of 8 per flagged
/// depth-k node, and a surface touches about a quarter as many cells per level up.
fn node_capacity(frags: u64, levels: u32) -> u64 {
    let mut cap = 1u64;
    for k in 0..levels.saturating_sub(1) {
        let full = 8u64.saturating_pow(k);
        let surface = (frags >> (2 * (levels - 1 - k))).max(1) * 2;
        cap += 8 * full.min(surface).min(frags.max(1));
    }
    cap
}

/// Builds the volume for `scene` (everything but the lighting).
pub fn build(
    ctx: &Arc<GpuContext>,
    scene: &CompiledScene,
    shared: &[Binding<'_>],
    defines: &ShaderDefines,
    s: &Settings,
) -> Result<Volume, RenderError> {
    let r = s.resolution;
    let levels = r.trailing_zeros();
    let octree = s.storage == VctStorage::Octree;
    let mut times = StageTimes::default();
    // Step 1: parameters.
    let (min, voxel) = fit_grid(scene, r);
    let tan_half = (0.5 * s.cone_aperture_deg).to_radians().tan();
    let side = voxel * r as f32;
    let ao_voxels = s.ao_distance.unwrap_or(side / 8.0) / voxel;
    let mut params = VctParams {
        grid: [min[0], min[1], min[2], voxel],
        dims: [r, levels, octree as u32, s.max_level],
        cone: [tan_half, s.cones as f32, s.step, ao_voxels],
        mode: [
            s.ao as u32,
            (s.shadows == super::VctShadows::Cone) as u32,
            s.inject_samples,
            0,
        ],
        caps: [0; 4],
        mip_offset: [0; gpu::LEVELS_MAX],
    };
    let params_buf = storage_buffer(ctx, "vct params", std::mem::size_of::<VctParams>() as u64)?;
    ctx.upload(&params_buf, 0, bytemuck::bytes_of(&params))?;
    let info_buf = storage_buffer(ctx, "vct info", std::mem::size_of::<VctInfo>() as u64)?;
    ctx.fill_zero(&info_buf)?;
    let dummy = storage_buffer(ctx, "vct placeholder", 16)?;
    ctx.fill_zero(&dummy)?;
    let read_info = |ctx: &Arc<GpuContext>| -> Result<VctInfo, RenderError> {
        Ok(ctx.download_vec::<VctInfo>(&info_buf, 1)?[0])
    };

    // Step 2: voxelization, counting then emitting (thread = primitive × slice of its box).
    let nprims = scene.prims.len() as u64;
    let slices = max_slices(scene, min, voxel, r);
    let vox_groups = [(nprims.div_ceil(64).max(1)) as u32, slices, 1];
    let mut frag_count = 0u32;
    if nprims > 0 {
        let b = bindings(shared, &params_buf, &info_buf, &dummy, &Set::default());
        let count_pipe = pipeline(ctx, "vct/voxelize.comp", defines, &b)?;
        let t = ctx.record(1, |rec| {
            rec.dispatch(
                &count_pipe,
                bytemuck::bytes_of(&push(0, 0, 0)),
                vox_groups,
                "vct voxelize count",
            )
        })?;
        times.voxelize_ms += sum_ms(&t);
        frag_count = read_info(ctx)?.frag_count;
    }
    let frags = storage_buffer(ctx, "vct fragments", frag_count as u64 * 8)?;
    if frag_count > 0 {
        ctx.fill_zero(&info_buf)?;
        params.caps[0] = frag_count;
        ctx.upload(&params_buf, 0, bytemuck::bytes_of(&params))?;
        let set = Set {
            frags: Some(&frags),
            ..Default::default()
        };
        let b = bindings(shared, &params_buf, &info_buf, &dummy, &set);
        let emit_pipe = pipeline(ctx, "vct/voxelize.comp", defines, &b)?;
        let t = ctx.record(1, |rec| {
            rec.dispatch(
                &emit_pipe,
                bytemuck::bytes_of(&push(0, 0, 0)),
                vox_groups,
                "vct voxelize",
            )
        })?;
        times.voxelize_ms += sum_ms(&t);
    }

    // Step 3: the storage. Octree: level by level on the GPU.
    let mut node_cap = if octree {
        node_capacity(frag_count as u64, levels)
    } else {
        0
    };
    let (nodes, info, slots) = if octree {
        loop {
            if node_cap > u32::MAX as u64 / 2 {
                return Err(RenderError::Invalid(format!(
                    "vct: the octree needs more than {} nodes; lower integrator.resolution",
                    u32::MAX / 2
                )));
            }
            let nodes = storage_buffer(ctx, "vct nodes", node_cap * 8)?;
            ctx.fill_zero(&nodes)?;
            params.caps[1] = node_cap as u32;
            ctx.upload(&params_buf, 0, bytemuck::bytes_of(&params))?;
            let set = Set {
                frags: Some(&frags),
                nodes: Some(&nodes),
                ..Default::default()
            };
            let b = bindings(shared, &params_buf, &info_buf, &dummy, &set);
            let pipe = pipeline(ctx, "vct/octree.comp", defines, &b)?;
            let t = ctx.record(1 + 3 * levels, |rec| {
                rec.dispatch(
                    &pipe,
                    bytemuck::bytes_of(&push(0, 0, 0)),
                    [1, 1, 1],
                    "vct octree init",
                )?;
                for k in 0..levels - 1 {
                    let p = push(k, frag_count, 1);
                    rec.dispatch(
                        &pipe,
                        bytemuck::bytes_of(&p),
                        groups_1d(frag_count as u64),
                        "vct octree flag",
                    )?;
                    let n = 8u64.saturating_pow(k).min(node_cap);
                    rec.dispatch(
                        &pipe,
                        bytemuck::bytes_of(&push(k, 0, 2)),
                        groups_1d(n),
                        "vct octree alloc",
                    )?;
                    rec.dispatch(
                        &pipe,
                        bytemuck::bytes_of(&push(k, 0, 3)),
                        [1, 1, 1],
                        "vct octree mark",
                    )?;
                }
                Ok(())
            })?;
            times.build_ms += sum_ms(&t);
            let info = read_info(ctx)?;
            if info.overflow != 0 {
                node_cap *= 4;
                continue;
            }
            let k = (levels - 1) as usize;
            let slots = 8 * (info.level_end[k] - info.level_start[k]);
            break (nodes, info, slots);
        }
    } else {
        (
            storage_buffer(ctx, "vct nodes (unused)", 16)?,
            read_info(ctx)?,
            r * r * r,
        )
    };

    // Step 4: per-voxel attributes: fixed-point sums from the fragments, then averages.
    let slots_u = slots as u64;
    let acc = storage_buffer(ctx, "vct build sums", slots_u * ACC_WORDS * 4)?;
    ctx.fill_zero(&acc)?;
    let attr = storage_buffer(ctx, "vct attributes", slots_u * 16)?;
    let emit = storage_buffer(ctx, "vct emission", slots_u * 8)?;
    let rad = storage_buffer(ctx, "vct radiance", slots_u * 16)?;
    ctx.fill_zero(&rad)?;
    params.caps[2] = slots;
    ctx.upload(&params_buf, 0, bytemuck::bytes_of(&params))?;
    {
        let set = Set {
            frags: Some(&frags),
            nodes: Some(&nodes),
            acc: Some(&acc),
            attr: Some(&attr),
            emit: Some(&emit),
            ..Default::default()
        };
        let b = bindings(shared, &params_buf, &info_buf, &dummy, &set);
        let attributes = pipeline(ctx, "vct/attributes.comp", defines, &b)?;
        let normalize = pipeline(ctx, "vct/normalize.comp", defines, &b)?;
        let t = ctx.record(2, |rec| {
            if frag_count > 0 {
                let p = push(0, frag_count, 0);
                rec.dispatch(
                    &attributes,
                    bytemuck::bytes_of(&p),
                    groups_1d(frag_count as u64),
                    "vct attributes",
                )?;
            }
            rec.dispatch(
                &normalize,
                bytemuck::bytes_of(&push(0, slots, 0)),
                groups_1d(slots_u),
                "vct normalize",
            )
        })?;
        times.build_ms += sum_ms(&t);
    }
    let info_after = read_info(ctx)?;
    let build_peak_bytes = frags.size + acc.size;
    drop(acc);
    drop(frags);

    // Step 5: the filtered levels' storage.
    let (mip, leaf) = if octree {
        let k = (levels - 1) as usize;
        let inner = info.level_start[k] as u64;
        let leaves = (info.level_end[k] - info.level_start[k]) as u64;
        (
            storage_buffer(ctx, "vct brick pool", inner * 27 * 6 * 8)?,
            storage_buffer(ctx, "vct leaf bricks", leaves * 27 * 4)?,
        )
    } else {
        let mut off = 0u32;
        for m in 1..levels {
            params.mip_offset[m as usize] = off;
            off += (r >> m).pow(3);
        }
        ctx.upload(&params_buf, 0, bytemuck::bytes_of(&params))?;
        (
            storage_buffer(ctx, "vct mip levels", off as u64 * 6 * 8)?,
            storage_buffer(ctx, "vct leaf bricks (unused)", 16)?,
        )
    };
    Ok(Volume {
        params,
        params_buf,
        info_buf,
        dummy,
        nodes,
        attr,
        emit,
        rad,
        mip,
        leaf,
        bounce: None,
        storage: s.storage,
        resolution: r,
        levels,
        fragments: frag_count,
        nodes_used: if octree {
            info.node_count.min(node_cap as u32)
        } else {
            0
        },
        slots,
        voxels: info_after.voxel_count,
        info: info_after,
        build_peak_bytes,
        build_times: times,
        light_times: StageTimes::default(),
        lights_key: None,
        world_min: [0, 1, 2].map(|i| params.grid[i] as f64 + scene.camera_position[i]),
    })
}

/// Threads per primitive the voxelizer needs: the longest side of any primitive's voxel box.
fn max_slices(scene: &CompiledScene, min: [f32; 3], voxel: f32, r: u32) -> u32 {
    let mut most = 1u32;
    for p in &scene.prims {
        let sphere = p.a[3].to_bits() & crate::layout::PRIM_SPHERE != 0;
        let (lo, hi) = if sphere {
            (
                [0, 1, 2].map(|i| p.a[i] - p.b[0]),
                [0, 1, 2].map(|i| p.a[i] + p.b[0]),
            )
        } else {
            (
                [0, 1, 2].map(|i| p.a[i].min(p.b[i]).min(p.c[i])),
                [0, 1, 2].map(|i| p.a[i].max(p.b[i]).max(p.c[i])),
            )
        };
        for i in 0..3 {
            let a = ((lo[i] - min[i]) / voxel)
                .floor()
                .clamp(0.0, (r - 1) as f32);
            let b = ((hi[i] - min[i]) / voxel)
                .floor()
                .clamp(0.0, (r - 1) as f32);
            most = most.max((b - a) as u32 + 2);
        }
    }
    most.min(r + 1)
}
