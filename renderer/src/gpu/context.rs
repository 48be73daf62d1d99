//! The Vulkan instance, the chosen physical device, its logical device, compute queue and memory
//! allocator. The Khronos validation layer is enabled on request (tests enable it whenever it is
//! installed); every message it emits is collected and turned into an error by `check_validation`.

use std::ffi::{c_void, CStr, CString};
use std::sync::{Arc, Mutex};

use ash::vk;
use gpu_allocator::vulkan::{Allocator, AllocatorCreateDesc};

use super::kernel_cache::{compile_kernels, kernel_spirv, DriverKey, PipelineCache};
use super::pipeline::PipelineObjects;
use super::ShaderDefines;
use super::{GpuError, GpuResult};

/// How to create a context.
#[derive(Debug, Clone, Default)]
pub struct GpuOptions {
    /// Pick the first device whose name contains this text (case-insensitive); `None`: prefer a
    /// discrete GPU, then integrated, then anything (lavapipe).
    pub device: Option<String>,
    /// Pick the device at this position of [`list_devices`] (`candela devices` prints them in
    /// that order; `--devices 0,1`); takes precedence over `device`.
    pub index: Option<usize>,
    /// Enable the Khronos validation layer if installed; its messages become errors.
    pub validation: bool,
    /// The kernel cache folder (compiled SPIR-V and the driver's pipeline cache, see
    /// kernel_cache.rs); `None`: compile in memory only.
    pub kernel_cache: Option<std::path::PathBuf>,
}

/// What a device is, for logs, stats and `--device` matching.
#[derive(Debug, Clone, serde::Serialize)]
pub struct DeviceInfo {
    pub name: String,
    pub kind: String,
    pub api_version: String,
    pub driver: String,
}

/// Messages collected from the validation layer.
type MessageSink = Arc<Mutex<Vec<String>>>;

/// Owns the Vulkan objects; dropped in the right order.
pub struct GpuContext {
    pub(crate) entry: ash::Entry,
    pub(crate) instance: ash::Instance,
    #[allow(dead_code)] // kept for feature queries by later stages
    pub(crate) physical: vk::PhysicalDevice,
    pub(crate) device: ash::Device,
    pub(crate) queue: vk::Queue,
    /// Vulkan requires external synchronisation of queue submission; held while submitting.
    pub(crate) queue_lock: Mutex<()>,
    pub(crate) queue_family: u32,
    pub(crate) allocator: Mutex<Option<Allocator>>,
    pub(crate) debug_utils: Option<ash::ext::debug_utils::Device>,
    debug_messenger: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    messages: Option<MessageSink>,
    _sink_box: Option<Box<MessageSink>>,
    pub(crate) timestamp_period_ns: f64,
    pub(crate) timestamps_supported: bool,
    pub info: DeviceInfo,
    /// The largest storage buffer and device-local heap (crate::memory checks scenes against
    /// them before uploading).
    pub limits: super::DeviceLimits,
    pub validation_enabled: bool,
    /// The driver's pipeline cache, loaded from and saved to `kernel_dir`.
    pub(crate) pipelines: PipelineCache,
    /// Pipelines made on this device, shared by every session that uses them.
    pub(crate) pipeline_objects: PipelineObjects,
    /// The kernel cache folder, if any.
    pub kernel_dir: Option<std::path::PathBuf>,
    /// When the host last saw a pass of any session complete: a pass queued behind another
    /// is charged only from there (render/inflight.rs).
    pub(crate) last_completion: Mutex<Option<std::time::Instant>>,
    /// `shaderBufferFloat32AtomicAdd` (VK_EXT_shader_atomic_float) is enabled: kernels may
    /// `atomicAdd` floats in storage buffers (bdpt's light-tracing splats; without it they use
    /// an integer fixed-point fallback).
    pub float_atomics: bool,
    /// VK_KHR_pipeline_executable_properties is enabled: pipelines report their compiled
    /// statistics (registers, shared memory, ... as the driver names them).
    pub(crate) executable_properties: Option<ash::khr::pipeline_executable_properties::Device>,
    /// Reused staging memory for uploads and readbacks (staging.rs).
    pub(crate) staging: super::staging::StagingPool,
}

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

fn load_entry() -> GpuResult<ash::Entry> {
    // SAFETY: loading the system Vulkan loader library; the returned entry keeps it alive.
    unsafe { ash::Entry::load() }.map_err(|e| GpuError::Loader(e.to_string()))
}

fn device_kind(t: vk::PhysicalDeviceType) -> &'static str {
    match t {
        vk::PhysicalDeviceType::DISCRETE_GPU => "discrete",
        vk::PhysicalDeviceType::INTEGRATED_GPU => "integrated",
        vk::PhysicalDeviceType::VIRTUAL_GPU => "virtual",
        vk::PhysicalDeviceType::CPU => "cpu",
        _ => "other",
    }
}

fn describe(
    instance: &ash::Instance,
    pd: vk::PhysicalDevice,
) -> (DeviceInfo, vk::PhysicalDeviceProperties) {
    // SAFETY: `pd` was enumerated from this instance.
    let props = unsafe { instance.get_physical_device_properties(pd) };
    let mut driver_props = vk::PhysicalDeviceDriverProperties::default();
    let mut props2 = vk::PhysicalDeviceProperties2::default().push_next(&mut driver_props);
    // SAFETY: as above; the chain holds a valid driver-properties struct.
    unsafe { instance.get_physical_device_properties2(pd, &mut props2) };
    let name = props
        .device_name_as_c_str()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let driver = format!(
        "{} {}",
        driver_props
            .driver_name_as_c_str()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default(),
        driver_props
            .driver_info_as_c_str()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default()
    );
    let v = props.api_version;
    let info = DeviceInfo {
        name,
        kind: device_kind(props.device_type).to_string(),
        api_version: format!(
            "{}.{}.{}",
            vk::api_version_major(v),
            vk::api_version_minor(v),
            vk::api_version_patch(v)
        ),
        driver: driver.trim().to_string(),
    };
    (info, props)
}

/// Lists the Vulkan 1.2+ devices with a compute queue (for `--device` and error messages).
pub fn list_devices() -> GpuResult<Vec<DeviceInfo>> {
    let entry = load_entry()?;
    let app = vk::ApplicationInfo::default().api_version(vk::API_VERSION_1_2);
    let ci = vk::InstanceCreateInfo::default().application_info(&app);
    // SAFETY: valid create info; the instance is destroyed below.
    let instance =
        unsafe { entry.create_instance(&ci, None) }.map_err(GpuError::vk("create instance"))?;
    let out = candidates(&instance).map(|c| c.into_iter().map(|(_, _, info, _)| info).collect());
    // SAFETY: no child objects were created.
    unsafe { instance.destroy_instance(None) };
    out
}

type Candidate = (
    vk::PhysicalDevice,
    u32,
    DeviceInfo,
    vk::PhysicalDeviceProperties,
);

fn candidates(instance: &ash::Instance) -> GpuResult<Vec<Candidate>> {
    // SAFETY: valid instance.
    let pds = unsafe { instance.enumerate_physical_devices() }
        .map_err(GpuError::vk("enumerate devices"))?;
    let mut out = Vec::new();
    for pd in pds {
        let (info, props) = describe(instance, pd);
        if props.api_version < vk::API_VERSION_1_2 {
            continue;
        }
        // SAFETY: valid physical device.
        let families = unsafe { instance.get_physical_device_queue_family_properties(pd) };
        if let Some(q) = families
            .iter()
            .position(|f| f.queue_flags.contains(vk::QueueFlags::COMPUTE))
        {
            out.push((pd, q as u32, info, props));
        }
    }
    Ok(out)
}

unsafe extern "system" fn debug_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user: *mut c_void,
) -> vk::Bool32 {
    if data.is_null() || user.is_null() {
        return vk::FALSE;
    }
    // SAFETY: the layer passes a valid callback-data pointer; `user` is the boxed sink we
    // registered, alive as long as the messenger.
    let (msg, sink) = unsafe {
        let d = &*data;
        let msg = d
            .message_as_c_str()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        (msg, &*(user as *const MessageSink))
    };
    if severity.intersects(
        vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
            | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
    ) {
        if let Ok(mut v) = sink.lock() {
            v.push(msg);
        }
    }
    vk::FALSE
}

/// The Vulkan instance and, with validation, the debug messenger collecting its messages.
struct InstanceParts {
    instance: ash::Instance,
    validation: bool,
    has_debug_utils: bool,
    messages: Option<MessageSink>,
    sink_box: Option<Box<MessageSink>>,
    debug_messenger: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
}

/// Creates the instance, with the validation layer and debug utils when asked for and available.
fn create_instance(entry: &ash::Entry, want_validation: bool) -> GpuResult<InstanceParts> {
    // Step 1: instance, with validation and debug utils when available.
    // SAFETY: plain enumeration calls on a loaded entry.
    let layers = unsafe { entry.enumerate_instance_layer_properties() }.unwrap_or_default();
    let has_validation = layers.iter().any(|l| {
        l.layer_name_as_c_str()
            .map(|n| n == VALIDATION_LAYER)
            .unwrap_or(false)
    });
    // SAFETY: as above.
    let exts = unsafe { entry.enumerate_instance_extension_properties(None) }.unwrap_or_default();
    let has_debug_utils = exts.iter().any(|e| {
        e.extension_name_as_c_str()
            .map(|n| n == ash::ext::debug_utils::NAME)
            .unwrap_or(false)
    });
    let validation = want_validation && has_validation && has_debug_utils;
    let app_name = CString::new("candela").unwrap_or_default();
    let app = vk::ApplicationInfo::default()
        .application_name(&app_name)
        .engine_name(&app_name)
        .api_version(vk::API_VERSION_1_2);
    let layer_ptrs: Vec<*const i8> = if validation {
        vec![VALIDATION_LAYER.as_ptr()]
    } else {
        vec![]
    };
    let ext_ptrs: Vec<*const i8> = if has_debug_utils {
        vec![ash::ext::debug_utils::NAME.as_ptr()]
    } else {
        vec![]
    };
    let ci = vk::InstanceCreateInfo::default()
        .application_info(&app)
        .enabled_layer_names(&layer_ptrs)
        .enabled_extension_names(&ext_ptrs);
    // SAFETY: all pointers in `ci` outlive the call.
    let instance =
        unsafe { entry.create_instance(&ci, None) }.map_err(GpuError::vk("create instance"))?;

    let (messages, sink_box, debug_messenger) = if validation {
        let sink: MessageSink = Arc::new(Mutex::new(Vec::new()));
        let boxed = Box::new(sink.clone());
        let loader = ash::ext::debug_utils::Instance::new(entry, &instance);
        let mci = vk::DebugUtilsMessengerCreateInfoEXT::default()
            .message_severity(
                vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
                    | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
            )
            .message_type(
                vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                    | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                    | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
            )
            .pfn_user_callback(Some(debug_callback))
            .user_data(&*boxed as *const MessageSink as *mut c_void);
        // SAFETY: the boxed sink lives in the context as long as the messenger.
        let m = unsafe { loader.create_debug_utils_messenger(&mci, None) }
            .map_err(GpuError::vk("create debug messenger"))?;
        (Some(sink), Some(boxed), Some((loader, m)))
    } else {
        (None, None, None)
    };

    Ok(InstanceParts {
        instance,
        validation,
        has_debug_utils,
        messages,
        sink_box,
        debug_messenger,
    })
}

/// The physical device: the one at `index` of the candidates, else the first whose name
/// contains `filter`, else the best by kind (discrete, integrated, virtual, other).
fn pick_device(
    instance: &ash::Instance,
    index: Option<usize>,
    filter: Option<&str>,
) -> GpuResult<Candidate> {
    let cands = candidates(instance)?;
    let pick = match (index, filter) {
        (Some(i), _) => {
            if i >= cands.len() {
                let names: Vec<_> = cands.iter().map(|c| c.2.name.clone()).collect();
                return Err(GpuError::NoDevice(format!(
                    " at index {i} ({} available: {})",
                    cands.len(),
                    names.join(", ")
                )));
            }
            i
        }
        (None, Some(want)) => {
            let w = want.to_lowercase();
            cands
                .iter()
                .position(|c| c.2.name.to_lowercase().contains(&w))
                .ok_or_else(|| {
                    let names: Vec<_> = cands.iter().map(|c| c.2.name.clone()).collect();
                    GpuError::NoDevice(format!(
                        " matching \"{want}\" (available: {})",
                        names.join(", ")
                    ))
                })?
        }
        (None, None) => {
            let rank = |c: &Candidate| match c.3.device_type {
                vk::PhysicalDeviceType::DISCRETE_GPU => 0,
                vk::PhysicalDeviceType::INTEGRATED_GPU => 1,
                vk::PhysicalDeviceType::VIRTUAL_GPU => 2,
                _ => 3,
            };
            (0..cands.len()).min_by_key(|&i| rank(&cands[i])).ok_or_else(|| {
                GpuError::NoDevice(" (install a Vulkan driver, e.g. apt-get install mesa-vulkan-drivers libvulkan1)".into())
            })?
        }
    };
    Ok(cands[pick].clone())
}

/// The logical device, its queue, and the optional features enabled.
struct DeviceParts {
    device: ash::Device,
    queue: vk::Queue,
    float_atomics: bool,
    /// VK_KHR_pipeline_executable_properties with `pipelineExecutableInfo`.
    executable_properties: bool,
}

/// Creates the logical device with the features the kernels use: scalar block layout (required),
/// host query reset, 64-bit integers, buffer float atomics and the subgroup clock where available.
fn create_device(
    instance: &ash::Instance,
    physical: vk::PhysicalDevice,
    queue_family: u32,
    info: &DeviceInfo,
) -> GpuResult<DeviceParts> {
    let prio = [1.0f32];
    let qci = [vk::DeviceQueueCreateInfo::default()
        .queue_family_index(queue_family)
        .queue_priorities(&prio)];
    let mut f12 = vk::PhysicalDeviceVulkan12Features::default();
    // Float atomics (optional): the extension must be present and the feature reported.
    // SAFETY: valid physical device.
    let device_exts =
        unsafe { instance.enumerate_device_extension_properties(physical) }.unwrap_or_default();
    let has_ext = |name: &std::ffi::CStr| {
        device_exts
            .iter()
            .any(|e| e.extension_name_as_c_str() == Ok(name))
    };
    let has_atomic_float_ext = has_ext(ash::ext::shader_atomic_float::NAME);
    let has_executable_properties_ext = has_ext(ash::khr::pipeline_executable_properties::NAME);
    // The subgroup clock, for the measuring define COUNT_CLOCK (common/bindings.glsl).
    let has_clock_ext = has_ext(ash::khr::shader_clock::NAME);
    let mut executable_info = vk::PhysicalDevicePipelineExecutablePropertiesFeaturesKHR::default();
    let mut atomic_float = vk::PhysicalDeviceShaderAtomicFloatFeaturesEXT::default();
    let mut clock = vk::PhysicalDeviceShaderClockFeaturesKHR::default();
    let base_features = {
        let mut f2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut f12);
        if has_atomic_float_ext {
            f2 = f2.push_next(&mut atomic_float);
        }
        if has_executable_properties_ext {
            f2 = f2.push_next(&mut executable_info);
        }
        if has_clock_ext {
            f2 = f2.push_next(&mut clock);
        }
        // SAFETY: valid physical device and feature chain.
        unsafe { instance.get_physical_device_features2(physical, &mut f2) };
        f2.features
    };
    let scalar_layout = f12.scalar_block_layout == vk::TRUE;
    let host_query_reset = f12.host_query_reset == vk::TRUE;
    if !scalar_layout {
        return Err(GpuError::NoDevice(format!(
            ": {} lacks scalarBlockLayout",
            info.name
        )));
    }
    let mut en12 = vk::PhysicalDeviceVulkan12Features::default()
        .scalar_block_layout(true)
        .host_query_reset(host_query_reset);
    let base =
        vk::PhysicalDeviceFeatures::default().shader_int64(base_features.shader_int64 == vk::TRUE);
    let float_atomics =
        has_atomic_float_ext && atomic_float.shader_buffer_float32_atomic_add == vk::TRUE;
    let mut en_atomic_float = vk::PhysicalDeviceShaderAtomicFloatFeaturesEXT::default()
        .shader_buffer_float32_atomic_add(true);
    let executable_properties =
        has_executable_properties_ext && executable_info.pipeline_executable_info == vk::TRUE;
    let mut en_executable_info =
        vk::PhysicalDevicePipelineExecutablePropertiesFeaturesKHR::default()
            .pipeline_executable_info(true);
    let subgroup_clock = has_clock_ext && clock.shader_subgroup_clock == vk::TRUE;
    let mut en_clock =
        vk::PhysicalDeviceShaderClockFeaturesKHR::default().shader_subgroup_clock(true);
    let mut device_ext_ptrs: Vec<*const i8> = Vec::new();
    if subgroup_clock {
        device_ext_ptrs.push(ash::khr::shader_clock::NAME.as_ptr());
    }
    if float_atomics {
        device_ext_ptrs.push(ash::ext::shader_atomic_float::NAME.as_ptr());
    }
    if executable_properties {
        device_ext_ptrs.push(ash::khr::pipeline_executable_properties::NAME.as_ptr());
    }
    let mut dci = vk::DeviceCreateInfo::default()
        .queue_create_infos(&qci)
        .enabled_features(&base)
        .enabled_extension_names(&device_ext_ptrs)
        .push_next(&mut en12);
    if float_atomics {
        dci = dci.push_next(&mut en_atomic_float);
    }
    if executable_properties {
        dci = dci.push_next(&mut en_executable_info);
    }
    if subgroup_clock {
        dci = dci.push_next(&mut en_clock);
    }
    // SAFETY: valid create info referencing live locals.
    let device = unsafe { instance.create_device(physical, &dci, None) }
        .map_err(GpuError::vk("create device"))?;
    // SAFETY: queue 0 of the family we requested.
    let queue = unsafe { device.get_device_queue(queue_family, 0) };
    Ok(DeviceParts {
        device,
        queue,
        float_atomics,
        executable_properties,
    })
}

impl GpuContext {
    /// Creates the instance and device. Fails with a clear message when no loader or device exists.
    pub fn new(opts: &GpuOptions) -> GpuResult<GpuContext> {
        let entry = load_entry()?;
        // Step 1: instance, with validation and debug utils when available.
        let InstanceParts {
            instance,
            validation,
            has_debug_utils,
            messages,
            sink_box,
            debug_messenger,
        } = create_instance(&entry, opts.validation)?;
        // Step 2: the physical device.
        let (physical, queue_family, info, props) =
            pick_device(&instance, opts.index, opts.device.as_deref())?;
        // Step 3: the logical device with the features the kernels use.
        let DeviceParts {
            device,
            queue,
            float_atomics,
            executable_properties,
        } = create_device(&instance, physical, queue_family, &info)?;
        let executable_properties = executable_properties
            .then(|| ash::khr::pipeline_executable_properties::Device::new(&instance, &device));
        // Step 4: the allocator, debug labels and timestamp support.
        let allocator = Allocator::new(&AllocatorCreateDesc {
            instance: instance.clone(),
            device: device.clone(),
            physical_device: physical,
            debug_settings: Default::default(),
            buffer_device_address: false,
            allocation_sizes: Default::default(),
        })
        .map_err(|e| GpuError::Alloc {
            name: "allocator".into(),
            message: e.to_string(),
        })?;
        let debug_utils =
            has_debug_utils.then(|| ash::ext::debug_utils::Device::new(&instance, &device));
        // SAFETY: valid physical device.
        let families = unsafe { instance.get_physical_device_queue_family_properties(physical) };
        let timestamps_supported = families[queue_family as usize].timestamp_valid_bits > 0
            && props.limits.timestamp_compute_and_graphics == vk::TRUE;
        let pipelines =
            PipelineCache::open(&device, DriverKey::of(&props), opts.kernel_cache.as_deref())?;
        // SAFETY: valid physical device.
        let mem = unsafe { instance.get_physical_device_memory_properties(physical) };
        let heap = mem.memory_heaps[..mem.memory_heap_count as usize]
            .iter()
            .filter(|h| h.flags.contains(vk::MemoryHeapFlags::DEVICE_LOCAL))
            .map(|h| h.size)
            .max()
            .unwrap_or(0);
        let l = &props.limits;
        let tiles =
            (l.max_compute_work_group_invocations / 64).min(l.max_compute_work_group_size[2]);
        let limits = super::DeviceLimits::new(l.max_storage_buffer_range as u64, heap, tiles);
        tracing::info!(device = %info.name, driver = %info.driver, validation, float_atomics, "Vulkan device ready");
        Ok(GpuContext {
            entry,
            instance,
            physical,
            device,
            queue,
            queue_lock: Mutex::new(()),
            queue_family,
            allocator: Mutex::new(Some(allocator)),
            debug_utils,
            debug_messenger,
            messages,
            _sink_box: sink_box,
            timestamp_period_ns: props.limits.timestamp_period as f64,
            timestamps_supported,
            info,
            limits,
            validation_enabled: validation,
            pipelines,
            pipeline_objects: PipelineObjects::default(),
            kernel_dir: opts.kernel_cache.clone(),
            last_completion: Mutex::new(None),
            float_atomics,
            executable_properties,
            staging: Default::default(),
        })
    }

    /// Returns an error carrying every validation message seen since the last call.
    pub fn check_validation(&self) -> GpuResult<()> {
        let Some(sink) = &self.messages else {
            return Ok(());
        };
        let mut v = sink
            .lock()
            .map_err(|_| GpuError::Other("validation sink poisoned".into()))?;
        if v.is_empty() {
            return Ok(());
        }
        let all = v.join("\n");
        v.clear();
        Err(GpuError::Validation(all))
    }

    /// The SPIR-V of kernel `path` (relative to shaders/) with `defines`, through the kernel
    /// cache (memory, then this context's cache folder, then glslang).
    pub fn kernel(&self, path: &str, defines: &ShaderDefines) -> GpuResult<Arc<Vec<u32>>> {
        kernel_spirv(path, defines, self.kernel_dir.as_deref())
    }

    /// Compiles the kernels of `list` that are in no cache yet, on several threads at once.
    pub fn compile_kernels(&self, list: &[(String, ShaderDefines)]) -> GpuResult<()> {
        compile_kernels(list, self.kernel_dir.as_deref())
            .into_iter()
            .try_for_each(|r| r.map(|_| ()))
    }

    /// The pipeline objects this device keeps (at most [`super::CacheLimits::pipelines`]) and
    /// how many it has evicted.
    pub fn pipeline_usage(&self) -> (usize, u64) {
        self.pipeline_objects.usage()
    }

    /// Bytes of the driver's pipeline cache data when it was last saved or loaded (None
    /// without a kernel cache folder).
    pub fn pipeline_cache_bytes(&self) -> Option<u64> {
        self.kernel_dir
            .as_ref()
            .map(|_| self.pipelines.saved_bytes())
    }

    /// Which driver build this device is (the pipeline cache's key).
    pub fn driver_key(&self) -> DriverKey {
        self.pipelines.driver
    }

    /// Saves the pipeline cache to the kernel cache folder if pipelines were made since the
    /// last save.
    pub fn save_pipeline_cache(&self) {
        self.pipelines.save(&self.device);
    }

    /// [`Self::save_pipeline_cache`] on a background thread (when there is anything to save).
    pub fn save_pipeline_cache_later(self: &Arc<Self>) {
        if self.pipelines.dirty() {
            let ctx = self.clone();
            let _ = std::thread::Builder::new()
                .name("pipeline-cache".into())
                .spawn(move || ctx.save_pipeline_cache());
        }
    }

    /// Blocks until the device is idle.
    pub fn wait_idle(&self) -> GpuResult<()> {
        // SAFETY: valid device.
        unsafe { self.device.device_wait_idle() }.map_err(GpuError::vk("wait idle"))
    }

    /// Names a Vulkan object for debuggers and validation messages.
    pub(crate) fn set_name<H: vk::Handle>(&self, handle: H, name: &str) {
        if let (Some(du), Ok(cname)) = (&self.debug_utils, CString::new(name)) {
            let info = vk::DebugUtilsObjectNameInfoEXT::default()
                .object_handle(handle)
                .object_name(&cname);
            // SAFETY: the handle belongs to this device.
            let _ = unsafe { du.set_debug_utils_object_name(&info) };
        }
    }
}

impl Drop for GpuContext {
    fn drop(&mut self) {
        // SAFETY: teardown in reverse creation order after the device is idle; every child
        // object (buffers, pipelines) holds an Arc to the context and is gone by now.
        unsafe {
            let _ = self.device.device_wait_idle();
            self.pipelines.save(&self.device);
            self.pipeline_objects.destroy_all();
            self.staging.release(self);
            self.device.destroy_pipeline_cache(self.pipelines.raw, None);
            if let Ok(mut a) = self.allocator.lock() {
                a.take();
            }
            self.device.destroy_device(None);
            if let Some((loader, m)) = self.debug_messenger.take() {
                loader.destroy_debug_utils_messenger(m, None);
            }
            self.instance.destroy_instance(None);
        }
        let _ = &self.entry;
    }
}
