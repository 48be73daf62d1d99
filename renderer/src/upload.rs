//! The compiled scene on the device: one storage buffer per scene array at its named binding
//! (compile::layout::binding), the uniform grid's only when the scene uses it. Shared by the
//! render session and by tools that run an integrator's stages on their own (vct's debug volume).

use std::sync::Arc;

use crate::compile::CompiledScene;
use crate::gpu::{Binding, Buffer, GpuContext, GpuResult};
use crate::layout::binding;

/// Uploads every scene buffer; returns (binding, buffer) pairs.
pub fn upload_scene(ctx: &Arc<GpuContext>, scene: &CompiledScene) -> GpuResult<Vec<(u32, Buffer)>> {
    let up = |name: &str, bytes: &[u8]| Buffer::from_slice(ctx, name, bytes);
    let mut buffers = vec![
        (
            binding::GLOBALS,
            up("globals", bytemuck::bytes_of(&scene.globals))?,
        ),
        (
            binding::BVH_NODES,
            up("bvh nodes", bytemuck::cast_slice(&scene.nodes))?,
        ),
        (
            binding::PRIMS,
            up("prims", bytemuck::cast_slice(&scene.prims))?,
        ),
        (
            binding::TRI_SHADING,
            up("tri shading", bytemuck::cast_slice(&scene.tri_shading))?,
        ),
        (
            binding::MATERIALS,
            up("materials", bytemuck::cast_slice(&scene.materials))?,
        ),
        (
            binding::TEXTURES,
            up("textures", bytemuck::cast_slice(&scene.textures))?,
        ),
        (
            binding::TEXELS,
            up("texels", bytemuck::cast_slice(&scene.texels))?,
        ),
        (
            binding::LIGHTS,
            up("lights", bytemuck::cast_slice(&scene.lights))?,
        ),
        (
            binding::LIGHT_ALIAS,
            up("light alias", bytemuck::cast_slice(&scene.alias))?,
        ),
        (
            binding::ENV_DIST,
            up("env distribution", bytemuck::cast_slice(&scene.env_dist))?,
        ),
    ];
    // The light BVH exists only with the BVH light sampler.
    if !scene.light_bvh.is_empty() {
        buffers.push((
            binding::LIGHT_BVH,
            up("light bvh", bytemuck::cast_slice(&scene.light_bvh))?,
        ));
    }
    // The uniform grid's buffers exist only when the scene uses it.
    if let Some(grid) = &scene.grid {
        buffers.push((binding::GRID, up("grid", bytemuck::bytes_of(&grid.info))?));
        buffers.push((
            binding::GRID_CELLS,
            up("grid cells", bytemuck::cast_slice(&grid.cells))?,
        ));
        buffers.push((
            binding::GRID_PRIMS,
            up("grid prims", bytemuck::cast_slice(&grid.prims))?,
        ));
    }
    Ok(buffers)
}

/// The (binding, buffer) pairs as pipeline bindings.
pub fn as_bindings(buffers: &[(u32, Buffer)]) -> Vec<Binding<'_>> {
    buffers
        .iter()
        .map(|(i, b)| Binding {
            index: *i,
            buffer: b,
        })
        .collect()
}
