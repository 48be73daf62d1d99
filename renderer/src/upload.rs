//! The compiled scene on the device: one storage buffer per scene array at its named binding
//! (compile::layout::binding), the uniform grid's and the CWBVH's only when the scene uses them. Shared by the
//! render session and by tools that run an integrator's stages on their own (vct's debug volume).

use std::sync::Arc;

use crate::compile::CompiledScene;
use crate::gpu::{Binding, Buffer, GpuContext, GpuResult};
use crate::layout::{binding, NONE};

/// Uploads every scene buffer; returns (binding, buffer) pairs. A scene that does not fit the
/// device (a buffer over maxStorageBufferRange, or more than its memory) is refused first, with
/// an error naming the limit (crate::memory).
pub fn upload_scene(ctx: &Arc<GpuContext>, scene: &CompiledScene) -> GpuResult<Vec<(u32, Buffer)>> {
    crate::memory::check_fits(&crate::memory::scene_buffers(scene), &ctx.limits)?;
    let up = |name: &str, bytes: &[u8]| Buffer::from_slice(ctx, name, bytes);
    // The parent pointers exist only for trees deeper than the traversal's stack.
    let parents: &[u32] = if scene.bvh_parents.is_empty() {
        &[NONE]
    } else {
        &scene.bvh_parents
    };
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
            binding::BVH_PARENTS,
            up("bvh parents", bytemuck::cast_slice(parents))?,
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
    // The instances and their top-level BVH exist only when the scene has instances.
    if !scene.instances.is_empty() {
        buffers.push((
            binding::INSTANCES,
            up("instances", bytemuck::cast_slice(&scene.instances))?,
        ));
        buffers.push((
            binding::TLAS_NODES,
            up("tlas nodes", bytemuck::cast_slice(&scene.tlas_nodes))?,
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
    // The compressed wide BVH's buffers exist only when the scene uses it.
    if let Some(c) = &scene.cwbvh {
        buffers.push((
            binding::CWBVH_NODES,
            up("cwbvh nodes", bytemuck::cast_slice(&c.nodes))?,
        ));
        if !c.prims.is_empty() {
            buffers.push((
                binding::CWBVH_PRIMS,
                up("cwbvh prims", bytemuck::cast_slice(&c.prims))?,
            ));
        }
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
