//! Compute pipelines with their descriptor set. Every binding is a storage buffer in set 0 at an
//! explicit, named binding index (the constants live next to the GLSL mirror of each layout);
//! push constants carry per-dispatch values.
//!
//! The pipeline itself (and its layouts) depends only on the SPIR-V, the binding indices and
//! the push-constant size, so it is made once per device and shared ([`PipelineObjects`]): a
//! second session of the same kernel only allocates its descriptor set. The device keeps at most
//! [`super::CacheLimits::pipelines`] of them (least recently used out first); an object
//! evicted while sessions use it lives until the last of them is dropped. Pipelines are created
//! through the device's pipeline cache (kernel_cache.rs), so even the first one after a restart
//! is quick where the driver cached it.

use std::collections::BTreeSet;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, OnceLock};

use ash::vk;

use super::lru::{cache_limits, Lru};
use super::{Buffer, GpuContext, GpuError, GpuResult};
use crate::cache_file::Hasher128;

/// A storage buffer bound at `index` in set 0.
pub struct Binding<'a> {
    pub index: u32,
    pub buffer: &'a Buffer,
}

/// The shareable part of a compute pipeline, destroyed when the last session using it and the
/// device's cache have let go of it.
pub(crate) struct PipelineObject {
    device: ash::Device,
    pipeline: vk::Pipeline,
    layout: vk::PipelineLayout,
    set_layout: vk::DescriptorSetLayout,
}

/// Pipeline objects alive in this process (in a cache, a session, or both).
static LIVE: AtomicU64 = AtomicU64::new(0);

/// Pipeline objects alive in this process, on every device.
pub fn live_pipelines() -> u64 {
    LIVE.load(Ordering::Relaxed)
}

/// The SPIR-V hashes of every kernel variant a pipeline was made of in this process (16 bytes
/// each, never dropped: they count what was seen, not what is kept).
static VARIANTS: Mutex<BTreeSet<[u64; 2]>> = Mutex::new(BTreeSet::new());

/// Distinct kernel variants (SPIR-V) this process has made pipelines of since it started, on
/// any device, whether or not a cache still keeps them: it stops rising once every feature set
/// and integrator a workload uses has been rendered once.
pub fn kernel_variants_seen() -> u64 {
    VARIANTS.lock().unwrap_or_else(|e| e.into_inner()).len() as u64
}

fn note_variant(hash: [u64; 2]) {
    VARIANTS
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .insert(hash);
}

impl Drop for PipelineObject {
    fn drop(&mut self) {
        // SAFETY: the last holder is gone: no session records or submits with the pipeline any
        // more (a session waits for its submissions before its pipelines are dropped), and the
        // device outlives its objects (GpuContext's Drop empties the cache first).
        unsafe {
            self.device.destroy_pipeline(self.pipeline, None);
            self.device.destroy_pipeline_layout(self.layout, None);
            self.device
                .destroy_descriptor_set_layout(self.set_layout, None);
        }
        LIVE.fetch_sub(1, Ordering::Relaxed);
    }
}

/// What a pipeline object depends on: a hash of the SPIR-V, the binding indices, the push size.
type PipelineKey = ([u64; 2], Vec<u32>, u32);
type PipelineSlot = Arc<OnceLock<Result<Arc<PipelineObject>, GpuError>>>;

/// The pipeline objects of a device, one slot per key (filled by the first caller, which the
/// others wait for), at most [`super::CacheLimits::pipelines`] of them, the least recently
/// used dropped first (destroyed once no session holds them).
pub(crate) struct PipelineObjects(Mutex<Lru<PipelineKey, PipelineSlot>>);

impl Default for PipelineObjects {
    fn default() -> Self {
        PipelineObjects(Mutex::new(Lru::new()))
    }
}

impl PipelineObjects {
    fn lock(&self) -> std::sync::MutexGuard<'_, Lru<PipelineKey, PipelineSlot>> {
        self.0.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Lets go of every object (the device is idle and about to go; sessions are gone).
    pub(crate) fn destroy_all(&self) {
        let gone = self.lock().drain();
        drop(gone);
    }

    /// (objects kept, evictions so far).
    pub(crate) fn usage(&self) -> (usize, u64) {
        let m = self.lock();
        (m.len(), m.evictions)
    }

    /// Drops the least recently used beyond the limit (slots being filled stay).
    fn trim(&self) {
        let max = cache_limits().pipelines;
        let gone = self
            .lock()
            .trim(max, u64::MAX, |_| 0, |s| s.get().is_some());
        drop(gone); // outside the lock: destroying calls the driver
    }
}

/// A compute pipeline and the one descriptor set it is used with.
pub struct ComputePipeline {
    /// Keeps `pipeline` and `layout` alive while this session may use them. Declared before
    /// `ctx` so that it is dropped first: where this holds the context's last reference, the
    /// object is destroyed before the device.
    _object: Arc<PipelineObject>,
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
) -> GpuResult<Arc<PipelineObject>> {
    let dev = &ctx.device;
    let mut o = PipelineObject {
        device: dev.clone(),
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
    // Counted from here: dropping `o` (on failure too) destroys what was made (null handles
    // are ignored).
    LIVE.fetch_add(1, Ordering::Relaxed);
    made.map(|()| Arc::new(o))
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
        let key_hash = h.finish();
        let key = (key_hash, indices.clone(), push_size);
        let slot = ctx
            .pipeline_objects
            .lock()
            .get_or_insert_with(key, PipelineSlot::default);
        let fresh = slot.get().is_none();
        let object = match slot.get_or_init(|| create_object(ctx, name, spirv, &indices, push_size))
        {
            Ok(o) => o.clone(),
            Err(e) => return Err(GpuError::Other(format!("{name}: {e}"))),
        };
        if fresh {
            note_variant(key_hash);
            ctx.pipeline_objects.trim();
        }
        let mut p = ComputePipeline {
            ctx: ctx.clone(),
            pipeline: object.pipeline,
            layout: object.layout,
            _object: object.clone(),
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
        // shared pipeline object goes with its last holder (`object`, dropped after this).
        unsafe { self.ctx.device.destroy_descriptor_pool(self.pool, None) };
    }
}
