//! GPU-side structs of `vct`, mirrored field for field in shaders/vct/common.glsl (scalar
//! layout), the binding indices of its buffers, and small dispatch helpers.

use std::sync::Arc;

use bytemuck::{Pod, Zeroable};

use crate::error::RenderError;
use crate::gpu::{Binding, Buffer, ComputePipeline, GpuContext, ShaderDefines};
use crate::layout::GpuPush;

/// Binding indices of vct's buffers (after the session's, which end at 12), as `B_VCT_*`.
pub mod binding {
    pub const PARAMS: u32 = 16;
    pub const INFO: u32 = 17;
    pub const FRAGS: u32 = 18;
    pub const NODES: u32 = 19;
    pub const ACC: u32 = 20;
    pub const ATTR: u32 = 21;
    pub const EMIT: u32 = 22;
    pub const RAD: u32 = 23;
    pub const MIP: u32 = 24;
    pub const LEAF: u32 = 25;
    pub const BOUNCE: u32 = 26;
    pub const PROBE: u32 = 27;
    pub const TILES: u32 = 28;
}

/// Most levels (VCT_LEVELS_MAX).
pub const LEVELS_MAX: usize = 16;
/// u32 words per slot while building (ACC_WORDS).
pub const ACC_WORDS: u64 = 14;

/// The volume's parameters (binding PARAMS).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct VctParams {
    /// Grid minimum corner (camera-relative) and voxel size.
    pub grid: [f32; 4],
    /// Resolution R, levels D = log2 R, storage (0 dense, 1 octree), coarsest level cones read.
    pub dims: [u32; 4],
    /// tan of the diffuse cones' half-angle, diffuse cone count, step factor, AO distance (voxels).
    pub cone: [f32; 4],
    /// AO output, shadow cones, injection samples, diffuse cones traced per sample.
    pub mode: [u32; 4],
    /// Fragment, node and slot capacities; the first node-pool word of the octree's occupancy
    /// mask (0: none; dense storage, or resolution above `build::MASK_MAX_RESOLUTION`).
    pub caps: [u32; 4],
    /// Dense storage: first cell of level m in the mip buffer.
    pub mip_offset: [u32; LEVELS_MAX],
}

/// Counters and level ranges the build kernels write (binding INFO).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct VctInfo {
    pub frag_count: u32,
    pub node_count: u32,
    pub overflow: u32,
    pub voxel_count: u32,
    pub level_start: [u32; LEVELS_MAX],
    pub level_end: [u32; LEVELS_MAX],
}

/// Push constants of the build kernels: the session's block with level, count and mode in
/// sample_base, spp and flags (VP_LEVEL, VP_COUNT, VP_MODE).
pub fn push(level: u32, count: u32, mode: u32) -> GpuPush {
    GpuPush {
        sample_base: level,
        spp: count,
        flags: mode,
        ..Default::default()
    }
}

/// Workgroups (of 64) for `threads` threads in a 1D launch spread over x and y (LINEAR_GID).
pub fn groups_1d(threads: u64) -> [u32; 3] {
    let g = threads.div_ceil(64).max(1);
    let x = g.min(65535);
    [x as u32, g.div_ceil(x) as u32, 1]
}

/// Compiles `kernel` (shaders/vct/…) and binds `bindings`.
pub fn pipeline(
    ctx: &Arc<GpuContext>,
    kernel: &str,
    defines: &ShaderDefines,
    bindings: &[Binding<'_>],
) -> Result<ComputePipeline, RenderError> {
    let spirv = ctx.kernel(kernel, defines)?;
    Ok(ComputePipeline::new(
        ctx,
        kernel,
        &spirv,
        bindings,
        std::mem::size_of::<GpuPush>() as u32,
    )?)
}

/// The buffers a vct kernel may bind; absent ones get a tiny placeholder.
#[derive(Default, Clone, Copy)]
pub struct Set<'a> {
    pub frags: Option<&'a Buffer>,
    pub nodes: Option<&'a Buffer>,
    pub acc: Option<&'a Buffer>,
    pub attr: Option<&'a Buffer>,
    pub emit: Option<&'a Buffer>,
    pub rad: Option<&'a Buffer>,
    pub mip: Option<&'a Buffer>,
    pub leaf: Option<&'a Buffer>,
    pub bounce: Option<&'a Buffer>,
    pub probe: Option<&'a Buffer>,
    pub tiles: Option<&'a Buffer>,
}

/// The session's bindings plus vct's: params, info and the buffers of `set`.
pub fn bindings<'a>(
    shared: &[Binding<'a>],
    params: &'a Buffer,
    info: &'a Buffer,
    dummy: &'a Buffer,
    set: &Set<'a>,
) -> Vec<Binding<'a>> {
    let mut out: Vec<Binding<'a>> = shared
        .iter()
        .map(|b| Binding {
            index: b.index,
            buffer: b.buffer,
        })
        .collect();
    let mut add = |index: u32, b: Option<&'a Buffer>| {
        out.push(Binding {
            index,
            buffer: b.unwrap_or(dummy),
        })
    };
    add(binding::PARAMS, Some(params));
    add(binding::INFO, Some(info));
    add(binding::FRAGS, set.frags);
    add(binding::NODES, set.nodes);
    add(binding::ACC, set.acc);
    add(binding::ATTR, set.attr);
    add(binding::EMIT, set.emit);
    add(binding::RAD, set.rad);
    add(binding::MIP, set.mip);
    add(binding::LEAF, set.leaf);
    add(binding::BOUNCE, set.bounce);
    add(binding::PROBE, set.probe);
    add(binding::TILES, set.tiles);
    out
}

#[cfg(test)]
mod tests {
    #[test]
    fn sizes_match_the_glsl_mirror() {
        assert_eq!(std::mem::size_of::<super::VctParams>(), 144);
        assert_eq!(std::mem::size_of::<super::VctInfo>(), 144);
    }
}
