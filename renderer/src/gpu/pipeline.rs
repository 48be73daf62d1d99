//! Compute pipelines with their descriptor set. Every binding is a storage buffer in set 0 at an
//! explicit, named binding index (the constants live next to the GLSL mirror of each layout);
//! push constants carry per-dispatch values.

use std::sync::Arc;

use ash::vk;

use super::{Buffer, GpuContext, GpuError, GpuResult};

/// A storage buffer bound at `index` in set 0.
pub struct Binding<'a> {
    pub index: u32,
    pub buffer: &'a Buffer,
}

/// A compute pipeline and the one descriptor set it is used with.
pub struct ComputePipeline {
    ctx: Arc<GpuContext>,
    pub(crate) pipeline: vk::Pipeline,
    pub(crate) layout: vk::PipelineLayout,
    set_layout: vk::DescriptorSetLayout,
    pool: vk::DescriptorPool,
    pub(crate) set: vk::DescriptorSet,
    pub name: String,
}

impl ComputePipeline {
    /// Creates the pipeline from SPIR-V and binds `bindings` to its descriptor set.
    pub fn new(
        ctx: &Arc<GpuContext>,
        name: &str,
        spirv: &[u32],
        bindings: &[Binding<'_>],
        push_size: u32,
    ) -> GpuResult<Self> {
        let dev = &ctx.device;
        let mut p = ComputePipeline {
            ctx: ctx.clone(),
            pipeline: vk::Pipeline::null(),
            layout: vk::PipelineLayout::null(),
            set_layout: vk::DescriptorSetLayout::null(),
            pool: vk::DescriptorPool::null(),
            set: vk::DescriptorSet::null(),
            name: name.to_string(),
        };
        // Step 1: descriptor set layout and pipeline layout.
        let dsl: Vec<_> = bindings
            .iter()
            .map(|b| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(b.index)
                    .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                    .descriptor_count(1)
                    .stage_flags(vk::ShaderStageFlags::COMPUTE)
            })
            .collect();
        // SAFETY: valid device; every handle created here is destroyed in Drop (null handles
        // are ignored by the destroy calls).
        unsafe {
            p.set_layout = dev
                .create_descriptor_set_layout(
                    &vk::DescriptorSetLayoutCreateInfo::default().bindings(&dsl),
                    None,
                )
                .map_err(GpuError::vk("create descriptor set layout"))?;
            let ranges = [vk::PushConstantRange::default()
                .stage_flags(vk::ShaderStageFlags::COMPUTE)
                .offset(0)
                .size(push_size)];
            let layouts = [p.set_layout];
            let mut lci = vk::PipelineLayoutCreateInfo::default().set_layouts(&layouts);
            if push_size > 0 {
                lci = lci.push_constant_ranges(&ranges);
            }
            p.layout = dev
                .create_pipeline_layout(&lci, None)
                .map_err(GpuError::vk("create pipeline layout"))?;

            // Step 2: the pipeline.
            let module = dev
                .create_shader_module(&vk::ShaderModuleCreateInfo::default().code(spirv), None)
                .map_err(GpuError::vk("create shader module"))?;
            let stage = vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::COMPUTE)
                .module(module)
                .name(c"main");
            let ci = [vk::ComputePipelineCreateInfo::default()
                .stage(stage)
                .layout(p.layout)];
            let start = std::time::Instant::now();
            let r = dev.create_compute_pipelines(ctx.pipelines.raw, &ci, None);
            dev.destroy_shader_module(module, None);
            super::kernel_cache::note_pipeline(start.elapsed().as_secs_f64() * 1e3);
            ctx.pipelines.note_created();
            p.pipeline = r.map_err(|(_, e)| GpuError::Vk {
                stage: "create compute pipeline",
                result: e,
            })?[0];
            ctx.set_name(p.pipeline, name);

            // Step 3: descriptor pool and set, written once.
            let count = bindings.len().max(1) as u32;
            let sizes = [vk::DescriptorPoolSize {
                ty: vk::DescriptorType::STORAGE_BUFFER,
                descriptor_count: count,
            }];
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

impl Drop for ComputePipeline {
    fn drop(&mut self) {
        let dev = &self.ctx.device;
        // SAFETY: submissions are waited on before returning, so nothing uses these objects.
        unsafe {
            dev.destroy_pipeline(self.pipeline, None);
            dev.destroy_pipeline_layout(self.layout, None);
            dev.destroy_descriptor_pool(self.pool, None);
            dev.destroy_descriptor_set_layout(self.set_layout, None);
        }
    }
}
