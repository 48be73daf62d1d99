//! Compute pipelines with their descriptor set. Every binding is a storage buffer in set 0 at an
//! explicit, named binding index (the constants live next to the GLSL mirror of each layout);
//! push constants carry per-dispatch values.
//!
//! The pipeline itself (and its layouts) depends only on the SPIR-V, the binding indices and
//! the push-constant size, so it is made once per device and shared ([`PipelineObjects`]): a
//! second session of the same kernel only allocates its descriptor set. Pipelines are created
//! through the device's pipeline cache (kernel_cache.rs), so even the first one after a restart
//! is quick where the driver cached it.

use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

use ash::vk;

use super::{Buffer, GpuContext, GpuError, GpuResult};
use crate::cache_file::Hasher128;

/// A storage buffer bound at `index` in set 0.
pub struct Binding<'a> {
    pub index: u32,
    pub buffer: &'a Buffer,
}

/// The shareable part of a compute pipeline (destroyed with the device).
#[derive(Clone, Copy)]
pub(crate) struct PipelineObject {
    pipeline: vk::Pipeline,
    layout: vk::PipelineLayout,
    set_layout: vk::DescriptorSetLayout,
}

/// What a pipeline object depends on: a hash of the SPIR-V, the binding indices, the push size.
type PipelineKey = ([u64; 2], Vec<u32>, u32);
type PipelineSlot = Arc<OnceLock<Result<PipelineObject, GpuError>>>;

/// Every pipeline object of a device, one slot per key (filled by the first caller, which the
/// others wait for).
#[derive(Default)]
pub(crate) struct PipelineObjects(Mutex<HashMap<PipelineKey, PipelineSlot>>);

impl PipelineObjects {
    /// Destroys every object (the device is idle and about to go).
    pub(crate) fn destroy_all(&self, dev: &ash::Device) {
        let map = std::mem::take(&mut *self.0.lock().unwrap_or_else(|e| e.into_inner()));
        for slot in map.values() {
            if let Some(Ok(o)) = slot.get() {
                // SAFETY: nothing uses the objects any more (the device is idle).
                unsafe {
                    dev.destroy_pipeline(o.pipeline, None);
                    dev.destroy_pipeline_layout(o.layout, None);
                    dev.destroy_descriptor_set_layout(o.set_layout, None);
                }
            }
        }
    }
}

/// A compute pipeline and the one descriptor set it is used with.
pub struct ComputePipeline {
    ctx: Arc<GpuContext>,
    pub(crate) pipeline: vk::Pipeline,
    pub(crate) layout: vk::PipelineLayout,
    pool: vk::DescriptorPool,
    pub(crate) set: vk::DescriptorSet,
    pub name: String,
}

/// Creates the pipeline object of `spirv` with a set layout of `indices` (storage buffers).
fn create_object(
    ctx: &GpuContext,
    name: &str,
    spirv: &[u32],
    indices: &[u32],
    push_size: u32,
) -> GpuResult<PipelineObject> {
    let dev = &ctx.device;
    let mut o = PipelineObject {
        pipeline: vk::Pipeline::null(),
        layout: vk::PipelineLayout::null(),
        set_layout: vk::DescriptorSetLayout::null(),
    };
    let dsl: Vec<_> = indices
        .iter()
        .map(|&i| {
            vk::DescriptorSetLayoutBinding::default()
                .binding(i)
                .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                .descriptor_count(1)
                .stage_flags(vk::ShaderStageFlags::COMPUTE)
        })
        .collect();
    // SAFETY: valid device and create infos; on failure the objects made so far are destroyed
    // below (null handles are ignored).
    let made = unsafe {
        (|| -> GpuResult<()> {
            // Step 1: descriptor set layout and pipeline layout.
            o.set_layout = dev
                .create_descriptor_set_layout(
                    &vk::DescriptorSetLayoutCreateInfo::default().bindings(&dsl),
                    None,
                )
                .map_err(GpuError::vk("create descriptor set layout"))?;
            let ranges = [vk::PushConstantRange::default()
                .stage_flags(vk::ShaderStageFlags::COMPUTE)
                .offset(0)
                .size(push_size)];
            let layouts = [o.set_layout];
            let mut lci = vk::PipelineLayoutCreateInfo::default().set_layouts(&layouts);
            if push_size > 0 {
                lci = lci.push_constant_ranges(&ranges);
            }
            o.layout = dev
                .create_pipeline_layout(&lci, None)
                .map_err(GpuError::vk("create pipeline layout"))?;
            // Step 2: the pipeline, through the device's pipeline cache.
            let module = dev
                .create_shader_module(&vk::ShaderModuleCreateInfo::default().code(spirv), None)
                .map_err(GpuError::vk("create shader module"))?;
            let stage = vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::COMPUTE)
                .module(module)
                .name(c"main");
            // With VK_KHR_pipeline_executable_properties the driver keeps the compiled code's
            // statistics (registers, ...) for `statistics()`.
            let flags = if ctx.executable_properties.is_some() {
                vk::PipelineCreateFlags::CAPTURE_STATISTICS_KHR
            } else {
                vk::PipelineCreateFlags::empty()
            };
            let ci = [vk::ComputePipelineCreateInfo::default()
                .flags(flags)
                .stage(stage)
                .layout(o.layout)];
            let start = std::time::Instant::now();
            let r = dev.create_compute_pipelines(ctx.pipelines.raw, &ci, None);
            dev.destroy_shader_module(module, None);
            super::kernel_cache::note_pipeline(start.elapsed().as_secs_f64() * 1e3);
            ctx.pipelines.note_created();
            o.pipeline = r.map_err(|(_, e)| GpuError::vk("create compute pipeline")(e))?[0];
            ctx.set_name(o.pipeline, name);
            Ok(())
        })()
    };
    if let Err(e) = made {
        // SAFETY: the partially made objects are not in use.
        unsafe {
            dev.destroy_pipeline_layout(o.layout, None);
            dev.destroy_descriptor_set_layout(o.set_layout, None);
        }
        return Err(e);
    }
    Ok(o)
}

impl ComputePipeline {
    /// Creates the pipeline from SPIR-V (or reuses the device's, made earlier for the same
    /// SPIR-V, binding indices and push size) and binds `bindings` to its descriptor set.
    pub fn new(
        ctx: &Arc<GpuContext>,
        name: &str,
        spirv: &[u32],
        bindings: &[Binding<'_>],
        push_size: u32,
    ) -> GpuResult<Self> {
        let dev = &ctx.device;
        // Step 1: the shared pipeline object.
        let indices: Vec<u32> = bindings.iter().map(|b| b.index).collect();
        let mut h = Hasher128::default();
        h.update(bytemuck::cast_slice(spirv));
        let key = (h.finish(), indices.clone(), push_size);
        let slot = ctx
            .pipeline_objects
            .0
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .entry(key)
            .or_default()
            .clone();
        let object = match slot.get_or_init(|| create_object(ctx, name, spirv, &indices, push_size))
        {
            Ok(o) => *o,
            Err(e) => return Err(GpuError::Other(format!("{name}: {e}"))),
        };
        let mut p = ComputePipeline {
            ctx: ctx.clone(),
            pipeline: object.pipeline,
            layout: object.layout,
            pool: vk::DescriptorPool::null(),
            set: vk::DescriptorSet::null(),
            name: name.to_string(),
        };
        // Step 2: descriptor pool and set, written once.
        let count = bindings.len().max(1) as u32;
        let sizes = [vk::DescriptorPoolSize {
            ty: vk::DescriptorType::STORAGE_BUFFER,
            descriptor_count: count,
        }];
        let layouts = [object.set_layout];
        // SAFETY: valid device; the pool is destroyed in Drop (a null one is ignored).
        unsafe {
            p.pool = dev
                .create_descriptor_pool(
                    &vk::DescriptorPoolCreateInfo::default()
                        .max_sets(1)
                        .pool_sizes(&sizes),
                    None,
                )
                .map_err(GpuError::vk("create descriptor pool"))?;
            p.set = dev
                .allocate_descriptor_sets(
                    &vk::DescriptorSetAllocateInfo::default()
                        .descriptor_pool(p.pool)
                        .set_layouts(&layouts),
                )
                .map_err(GpuError::vk("allocate descriptor set"))?[0];
            let infos: Vec<[vk::DescriptorBufferInfo; 1]> = bindings
                .iter()
                .map(|b| {
                    [vk::DescriptorBufferInfo {
                        buffer: b.buffer.raw,
                        offset: 0,
                        range: vk::WHOLE_SIZE,
                    }]
                })
                .collect();
            let writes: Vec<_> = bindings
                .iter()
                .zip(&infos)
                .map(|(b, info)| {
                    vk::WriteDescriptorSet::default()
                        .dst_set(p.set)
                        .dst_binding(b.index)
                        .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                        .buffer_info(info)
                })
                .collect();
            dev.update_descriptor_sets(&writes, &[]);
        }
        Ok(p)
    }
}

impl ComputePipeline {
    /// What the driver reports about the compiled kernel (VK_KHR_pipeline_executable_properties:
    /// on NVIDIA e.g. "Register Count", "Shared Memory Size", ...), as (name, value) pairs in the
    /// driver's order; empty where the extension is missing.
    pub fn statistics(&self) -> Vec<(String, f64)> {
        let Some(ext) = &self.ctx.executable_properties else {
            return Vec::new();
        };
        let info = vk::PipelineInfoKHR::default().pipeline(self.pipeline);
        // SAFETY: a live pipeline created with CAPTURE_STATISTICS; the returned structs are
        // plain data read immediately.
        let Ok(executables) = (unsafe { ext.get_pipeline_executable_properties(&info) }) else {
            return Vec::new();
        };
        let mut out = Vec::new();
        for index in 0..executables.len() as u32 {
            let ei = vk::PipelineExecutableInfoKHR::default()
                .pipeline(self.pipeline)
                .executable_index(index);
            // SAFETY: as above.
            let Ok(stats) = (unsafe { ext.get_pipeline_executable_statistics(&ei) }) else {
                continue;
            };
            for st in stats {
                let name = st
                    .name_as_c_str()
                    .map(|c| c.to_string_lossy().into_owned())
                    .unwrap_or_default();
                // SAFETY: `format` says which member of the union is set.
                let value = unsafe {
                    match st.format {
                        vk::PipelineExecutableStatisticFormatKHR::BOOL32 => st.value.b32 as f64,
                        vk::PipelineExecutableStatisticFormatKHR::INT64 => st.value.i64 as f64,
                        vk::PipelineExecutableStatisticFormatKHR::UINT64 => st.value.u64 as f64,
                        vk::PipelineExecutableStatisticFormatKHR::FLOAT64 => st.value.f64,
                        _ => continue,
                    }
                };
                out.push((name, value));
            }
        }
        out
    }
}

impl Drop for ComputePipeline {
    fn drop(&mut self) {
        // SAFETY: submissions using the set are waited on before pipelines are dropped; the
        // shared pipeline object lives on with the device.
        unsafe { self.ctx.device.destroy_descriptor_pool(self.pool, None) };
    }
}
