//! Kernels compile once per machine: a two-tier cache of SPIR-V (in memory per process, and on
//! disk in the kernel cache folder) and the Vulkan pipeline cache (`VkPipelineCache`, loaded
//! when the device opens and saved after new pipelines are made).
//!
//! # Keys
//! - SPIR-V, `DIR/spirv-{key}.bin`: a 128-bit hash of the kernel's path, its defines, the
//!   text of every file it may include (the closure of its `#include`s over the embedded
//!   sources and the generated `common/constants.glsl`) and [`super::shader::COMPILER_ID`]
//!   (glslang's version and the target). Changing any included file, a define or the compiler
//!   makes another key; old files are left alone (they are small).
//! - Pipelines, `DIR/pipelines-{vendor}-{device}-{driver version}-{pipelineCacheUUID}.bin`:
//!   one file per driver build. Its payload is the driver's own cache data, whose header
//!   (vendor, device, pipelineCacheUUID) is checked again before the driver sees it.
//!
//! Files are [`crate::cache_file`]'s checked files: a truncated or corrupt one is reported with
//! a warning and rebuilt (recompiled, or started empty and saved again).
//!
//! In memory each (path, defines) has one slot that the first caller fills: concurrent callers
//! of one kernel wait for that compile instead of repeating it, and [`compile_kernels`]
//! compiles a list on several threads (see shader.rs for why glslang may run in parallel). The
//! memory tier is bounded ([`super::CacheLimits`]: modules and bytes, least recently used out
//! first); the disk tier keeps every module.

use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::Instant;

use ash::vk;

use super::lru::{cache_limits, Lru};
use super::shader::{glslang_compile, resolve_include, shader_source, ShaderDefines, COMPILER_ID};
use super::{GpuError, GpuResult};
use crate::cache_file::{read_checked, write_checked, FileKind, Hasher128};

const SPIRV_FILE: FileKind = FileKind {
    magic: b"CNDLSPIR",
    version: 1,
    kind: 0,
};
const PIPELINE_FILE: FileKind = FileKind {
    magic: b"CNDLPIPE",
    version: 1,
    kind: 0,
};
/// The first word of every SPIR-V module.
const SPIRV_MAGIC: u32 = 0x0723_0203;

/// Counters of the kernel cache since the process started (for stats and logs).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct KernelStats {
    /// Kernels compiled by glslang, and the milliseconds they took (summed over threads).
    pub compiled: u64,
    pub compile_ms: f64,
    /// Kernels read from the disk cache.
    pub disk_hits: u64,
    /// Requests answered from memory (compiled or read earlier in this process).
    pub memory_hits: u64,
    /// Pipelines created, and the milliseconds the driver took (hits in its cache are fast).
    pub pipelines: u64,
    pub pipeline_ms: f64,
}

impl KernelStats {
    /// What happened between `earlier` and `self`.
    pub fn since(&self, earlier: &KernelStats) -> KernelStats {
        KernelStats {
            compiled: self.compiled - earlier.compiled,
            compile_ms: self.compile_ms - earlier.compile_ms,
            disk_hits: self.disk_hits - earlier.disk_hits,
            memory_hits: self.memory_hits - earlier.memory_hits,
            pipelines: self.pipelines - earlier.pipelines,
            pipeline_ms: self.pipeline_ms - earlier.pipeline_ms,
        }
    }
}

fn stats_cell() -> &'static Mutex<KernelStats> {
    static STATS: Mutex<KernelStats> = Mutex::new(KernelStats {
        compiled: 0,
        compile_ms: 0.0,
        disk_hits: 0,
        memory_hits: 0,
        pipelines: 0,
        pipeline_ms: 0.0,
    });
    &STATS
}

fn count(f: impl FnOnce(&mut KernelStats)) {
    f(&mut stats_cell().lock().unwrap_or_else(|e| e.into_inner()));
}

/// The counters so far.
pub fn kernel_stats() -> KernelStats {
    *stats_cell().lock().unwrap_or_else(|e| e.into_inner())
}

pub(crate) fn note_pipeline(ms: f64) {
    count(|s| {
        s.pipelines += 1;
        s.pipeline_ms += ms;
    });
}

/// Every file `path` may include (itself first, then the others by name), with its text, from
/// `lookup`; `#include`s are followed whatever `#if` surrounds them.
pub fn source_closure(
    path: &str,
    lookup: &dyn Fn(&str) -> Option<String>,
) -> Vec<(String, String)> {
    let mut seen = HashSet::from([path.to_string()]);
    let mut todo = vec![path.to_string()];
    let mut out = Vec::new();
    while let Some(p) = todo.pop() {
        let Some(text) = lookup(&p) else { continue };
        for line in text.lines() {
            let Some(rest) = line.trim_start().strip_prefix("#include") else {
                continue;
            };
            let Some(header) = rest
                .trim()
                .strip_prefix('"')
                .and_then(|r| r.split('"').next())
            else {
                continue;
            };
            if let Some(q) = resolve_include(header, &p, |q| lookup(q).is_some()) {
                if seen.insert(q.clone()) {
                    todo.push(q);
                }
            }
        }
        out.push((p, text));
    }
    if out.len() > 1 {
        out[1..].sort();
    }
    out
}

/// The disk key of kernel `path` with `defines`, its sources read through `lookup`.
pub fn spirv_key(
    path: &str,
    defines: &ShaderDefines,
    lookup: &dyn Fn(&str) -> Option<String>,
) -> [u64; 2] {
    let mut h = Hasher128::default();
    h.update(SPIRV_FILE.magic);
    h.update_str(COMPILER_ID);
    h.update_str(path);
    h.update(&(defines.len() as u64).to_le_bytes());
    for (k, v) in defines {
        h.update_str(k);
        h.update_str(v);
    }
    for (name, text) in source_closure(path, lookup) {
        h.update_str(&name);
        h.update_str(&text);
    }
    h.finish()
}

fn embedded_lookup(p: &str) -> Option<String> {
    shader_source(p).map(String::from)
}

/// The file of a SPIR-V key.
pub fn spirv_path(dir: &Path, key: [u64; 2]) -> PathBuf {
    dir.join(format!("spirv-{:016x}{:016x}.bin", key[0], key[1]))
}

type Compiled = Result<Arc<Vec<u32>>, String>;
type Slot = Arc<OnceLock<Compiled>>;
type Memory = Lru<(String, ShaderDefines), Slot>;

fn memory() -> &'static Mutex<Memory> {
    static MEMORY: OnceLock<Mutex<Memory>> = OnceLock::new();
    MEMORY.get_or_init(|| Mutex::new(Lru::new()))
}

/// Bytes of SPIR-V a slot holds (0 while it is being compiled, or for a failed compile).
fn slot_bytes(slot: &Slot) -> u64 {
    match slot.get() {
        Some(Ok(words)) => 4 * words.len() as u64,
        _ => 0,
    }
}

/// What the in-memory SPIR-V tier holds: (modules, bytes, evictions so far).
pub fn spirv_memory() -> (usize, u64, u64) {
    let m = memory().lock().unwrap_or_else(|e| e.into_inner());
    (m.len(), m.values().map(slot_bytes).sum(), m.evictions)
}

/// Empties the in-memory SPIR-V tier (tests).
pub fn clear_spirv_memory() {
    let gone = memory().lock().unwrap_or_else(|e| e.into_inner()).drain();
    drop(gone);
}

/// Compiles the compute shader `path` (relative to shaders/) with `defines`, cached in memory
/// (no disk cache: see [`kernel_spirv`]).
pub fn compile_glsl(path: &str, defines: &ShaderDefines) -> GpuResult<Arc<Vec<u32>>> {
    kernel_spirv(path, defines, None)
}

/// The SPIR-V of kernel `path` with `defines`: from memory, else from the disk cache in `dir`,
/// else compiled (and stored there).
pub fn kernel_spirv(
    path: &str,
    defines: &ShaderDefines,
    dir: Option<&Path>,
) -> GpuResult<Arc<Vec<u32>>> {
    let slot = memory()
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .get_or_insert_with((path.to_string(), defines.clone()), Slot::default);
    if slot.get().is_some() {
        count(|s| s.memory_hits += 1);
    } else {
        slot.get_or_init(|| load_or_compile(path, defines, dir));
        // A new module: keep the tier within its bounds (the least recently used go; the disk
        // tier still has them). Slots still being compiled stay.
        let limits = cache_limits();
        let gone = memory().lock().unwrap_or_else(|e| e.into_inner()).trim(
            limits.kernels,
            limits.kernel_bytes,
            slot_bytes,
            |s| s.get().is_some(),
        );
        drop(gone);
    }
    slot.get_or_init(|| load_or_compile(path, defines, dir))
        .clone()
        .map_err(|log| GpuError::Shader {
            name: path.to_string(),
            log,
        })
}

/// The disk tier and the compiler behind [`kernel_spirv`].
fn load_or_compile(path: &str, defines: &ShaderDefines, dir: Option<&Path>) -> Compiled {
    let key = dir.map(|_| spirv_key(path, defines, &embedded_lookup));
    let file = dir.zip(key).map(|(d, k)| spirv_path(d, k));
    if let (Some(file), Some(key)) = (&file, key) {
        match read_checked(file, SPIRV_FILE, key) {
            Ok(Some(bytes)) => match spirv_words(&bytes) {
                Some(words) => {
                    count(|s| s.disk_hits += 1);
                    return Ok(Arc::new(words));
                }
                None => tracing::warn!("kernel cache {}: not SPIR-V; recompiling", file.display()),
            },
            Ok(None) => {}
            Err(why) => tracing::warn!("kernel cache {}: {why}; recompiling", file.display()),
        }
    }
    let start = Instant::now();
    let words = glslang_compile(path, defines)?;
    let ms = start.elapsed().as_secs_f64() * 1e3;
    count(|s| {
        s.compiled += 1;
        s.compile_ms += ms;
    });
    tracing::debug!(kernel = path, ms, "compiled");
    if let (Some(file), Some(key)) = (&file, key) {
        if let Err(e) = write_checked(file, SPIRV_FILE, key, bytemuck::cast_slice(&words)) {
            tracing::warn!("kernel cache {}: not written: {e}", file.display());
        }
    }
    Ok(Arc::new(words))
}

fn spirv_words(bytes: &[u8]) -> Option<Vec<u32>> {
    if !bytes.len().is_multiple_of(4) || bytes.len() < 20 {
        return None;
    }
    let words: Vec<u32> = bytemuck::pod_collect_to_vec(bytes);
    (words[0] == SPIRV_MAGIC).then_some(words)
}

/// Compiles kernel `path` with `defines` with glslang, bypassing every cache (tests compare it
/// across threads); the error is glslang's log.
pub fn compile_uncached(path: &str, defines: &ShaderDefines) -> Result<Vec<u32>, String> {
    glslang_compile(path, defines)
}

/// Compiles every kernel of `list` (missing from memory) on up to 8 threads at once, through
/// the same tiers as [`kernel_spirv`]; the results are in `list`'s order.
pub fn compile_kernels(
    list: &[(String, ShaderDefines)],
    dir: Option<&Path>,
) -> Vec<GpuResult<Arc<Vec<u32>>>> {
    let threads = std::thread::available_parallelism()
        .map_or(2, |n| n.get())
        .clamp(1, 8)
        .min(list.len());
    if threads <= 1 {
        return list.iter().map(|(p, d)| kernel_spirv(p, d, dir)).collect();
    }
    let next = AtomicUsize::new(0);
    type Done = Mutex<Option<GpuResult<Arc<Vec<u32>>>>>;
    let results: Vec<Done> = list.iter().map(|_| Mutex::new(None)).collect();
    std::thread::scope(|scope| {
        for _ in 0..threads {
            let _ = std::thread::Builder::new()
                .name("kernel-compile".into())
                .stack_size(8 << 20)
                .spawn_scoped(scope, || loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some((p, d)) = list.get(i) else { break };
                    let r = kernel_spirv(p, d, dir);
                    *results[i].lock().unwrap_or_else(|e| e.into_inner()) = Some(r);
                });
        }
    });
    // A thread that could not start left its share: compile it here.
    list.iter()
        .zip(results)
        .map(|((p, d), r)| {
            r.into_inner()
                .unwrap_or_else(|e| e.into_inner())
                .unwrap_or_else(|| kernel_spirv(p, d, dir))
        })
        .collect()
}

/// Which driver build a pipeline cache belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DriverKey {
    pub vendor_id: u32,
    pub device_id: u32,
    pub driver_version: u32,
    pub pipeline_cache_uuid: [u8; 16],
}

impl DriverKey {
    pub(crate) fn of(props: &vk::PhysicalDeviceProperties) -> Self {
        DriverKey {
            vendor_id: props.vendor_id,
            device_id: props.device_id,
            driver_version: props.driver_version,
            pipeline_cache_uuid: props.pipeline_cache_uuid,
        }
    }

    /// The pipeline cache data stored for this driver in `dir`: `Ok(None)` without a file,
    /// `Err(why)` for an unusable one (truncated, corrupt, or made by another driver).
    pub fn read_file(&self, dir: &Path) -> Result<Option<Vec<u8>>, String> {
        let Some(data) = read_checked(&self.file(dir), PIPELINE_FILE, self.hash())? else {
            return Ok(None);
        };
        self.check_payload(&data)?;
        Ok(Some(data))
    }

    /// Stores pipeline cache `data` for this driver in `dir` (atomically).
    pub fn write_file(&self, dir: &Path, data: &[u8]) -> std::io::Result<()> {
        write_checked(&self.file(dir), PIPELINE_FILE, self.hash(), data)
    }

    fn hash(&self) -> [u64; 2] {
        let mut h = Hasher128::default();
        h.update(PIPELINE_FILE.magic);
        for w in [self.vendor_id, self.device_id, self.driver_version] {
            h.update(&w.to_le_bytes());
        }
        h.update(&self.pipeline_cache_uuid);
        h.finish()
    }

    /// The pipeline cache file of this driver in `dir`.
    pub fn file(&self, dir: &Path) -> PathBuf {
        let uuid: String = self
            .pipeline_cache_uuid
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect();
        dir.join(format!(
            "pipelines-{:04x}-{:04x}-{:08x}-{uuid}.bin",
            self.vendor_id, self.device_id, self.driver_version
        ))
    }

    /// Checks that `data` (VkPipelineCache data) carries this driver's header
    /// (VkPipelineCacheHeaderVersionOne: size, version 1, vendor, device, UUID).
    pub fn check_payload(&self, data: &[u8]) -> Result<(), String> {
        if data.len() < 32 {
            return Err(format!("truncated ({} bytes)", data.len()));
        }
        let word = |i: usize| u32::from_le_bytes(data[4 * i..4 * i + 4].try_into().unwrap());
        if word(0) < 32 || word(1) != 1 {
            return Err("not a version-one pipeline cache".into());
        }
        if word(2) != self.vendor_id
            || word(3) != self.device_id
            || data[16..32] != self.pipeline_cache_uuid
        {
            return Err("made by another device or driver".into());
        }
        Ok(())
    }
}

/// The device's `VkPipelineCache` and where it is kept.
pub struct PipelineCache {
    pub(crate) raw: vk::PipelineCache,
    /// The kernel cache folder it is saved to.
    dir: Option<PathBuf>,
    pub(crate) driver: DriverKey,
    /// Pipelines created since the cache was last checked, the data size last saved (or
    /// loaded), and whether a save is running.
    unsaved: AtomicU64,
    saved_bytes: AtomicU64,
    saving: AtomicBool,
}

impl PipelineCache {
    /// Creates the cache, from `dir`'s file for this driver when there is a valid one.
    pub(crate) fn open(
        device: &ash::Device,
        driver: DriverKey,
        dir: Option<&Path>,
    ) -> GpuResult<Self> {
        let file = dir.map(|d| driver.file(d));
        let mut initial = Vec::new();
        if let Some(f) = &file {
            match read_checked(f, PIPELINE_FILE, driver.hash()) {
                Ok(Some(data)) => match driver.check_payload(&data) {
                    Ok(()) => initial = data,
                    Err(why) => {
                        tracing::warn!("pipeline cache {}: {why}; starting empty", f.display())
                    }
                },
                Ok(None) => {}
                Err(why) => tracing::warn!("pipeline cache {}: {why}; starting empty", f.display()),
            }
        }
        let ci = vk::PipelineCacheCreateInfo::default().initial_data(&initial);
        // SAFETY: valid device; the data was produced by this driver (header checked above).
        let raw = unsafe { device.create_pipeline_cache(&ci, None) }
            .map_err(GpuError::vk("create pipeline cache"))?;
        Ok(PipelineCache {
            raw,
            dir: dir.map(Path::to_path_buf),
            driver,
            unsaved: AtomicU64::new(0),
            saved_bytes: AtomicU64::new(initial.len() as u64),
            saving: AtomicBool::new(false),
        })
    }

    /// The data size last saved or loaded.
    pub(crate) fn saved_bytes(&self) -> u64 {
        self.saved_bytes.load(Ordering::Relaxed)
    }

    pub(crate) fn note_created(&self) {
        self.unsaved.fetch_add(1, Ordering::Relaxed);
    }

    /// Whether pipelines were made since the last save (and there is a file to save to).
    pub(crate) fn dirty(&self) -> bool {
        self.dir.is_some() && self.unsaved.load(Ordering::Relaxed) > 0
    }

    /// Writes the cache's data to its file (no-op without a folder, without new pipelines or
    /// when the driver's data did not grow (pipelines found in the cache), or while another
    /// save runs).
    pub(crate) fn save(&self, device: &ash::Device) {
        let Some(dir) = &self.dir else { return };
        if !self.dirty() || self.saving.swap(true, Ordering::AcqRel) {
            return;
        }
        let pending = self.unsaved.swap(0, Ordering::AcqRel);
        // SAFETY: the cache is internally synchronised (created without the externally
        // synchronised flag), so this may run beside pipeline creation.
        let r = unsafe { device.get_pipeline_cache_data(self.raw) }
            .map_err(|e| e.to_string())
            .and_then(|data| {
                if data.len() as u64 == self.saved_bytes.load(Ordering::Acquire) {
                    return Ok(()); // nothing new
                }
                self.driver
                    .write_file(dir, &data)
                    .map_err(|e| e.to_string())?;
                self.saved_bytes.store(data.len() as u64, Ordering::Release);
                Ok(())
            });
        if let Err(e) = r {
            self.unsaved.fetch_add(pending, Ordering::Relaxed);
            let file = self.driver.file(dir);
            tracing::warn!("pipeline cache {}: not saved: {e}", file.display());
        }
        self.saving.store(false, Ordering::Release);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_key_follows_includes_defines_and_the_compiler() {
        let base = spirv_key("nee/nee.comp", &vec![], &embedded_lookup);
        assert_eq!(base, spirv_key("nee/nee.comp", &vec![], &embedded_lookup));
        let with = vec![("HAS_SPHERES".to_string(), "1".to_string())];
        assert_ne!(base, spirv_key("nee/nee.comp", &with, &embedded_lookup));
        // A change in a file included three levels down changes the key ...
        let closure = source_closure("nee/nee.comp", &embedded_lookup);
        let names: Vec<&str> = closure.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names[0], "nee/nee.comp");
        for f in [
            "common/path.glsl",
            "common/bsdf/microfacet.glsl",
            "common/constants.glsl",
        ] {
            assert!(names.contains(&f), "{f} missing from {names:?}");
        }
        let edited = |p: &str| {
            embedded_lookup(p).map(|t| {
                if p == "common/bsdf/microfacet.glsl" {
                    t + "\n// edited\n"
                } else {
                    t
                }
            })
        };
        assert_ne!(base, spirv_key("nee/nee.comp", &vec![], &edited));
        // ... and one in a file it does not include does not.
        assert!(!names.contains(&"vct/inject.comp"));
        let unrelated =
            |p: &str| embedded_lookup(p).map(|t| if p == "vct/inject.comp" { t + "//" } else { t });
        assert_eq!(base, spirv_key("nee/nee.comp", &vec![], &unrelated));
    }

    #[test]
    fn driver_headers_are_checked() {
        let key = DriverKey {
            vendor_id: 0x10de,
            device_id: 0x2335,
            driver_version: 7,
            pipeline_cache_uuid: [9; 16],
        };
        let mut data = vec![0u8; 40];
        data[0..4].copy_from_slice(&32u32.to_le_bytes());
        data[4..8].copy_from_slice(&1u32.to_le_bytes());
        data[8..12].copy_from_slice(&0x10deu32.to_le_bytes());
        data[12..16].copy_from_slice(&0x2335u32.to_le_bytes());
        data[16..32].copy_from_slice(&[9; 16]);
        assert_eq!(key.check_payload(&data), Ok(()));
        let other_driver = DriverKey {
            pipeline_cache_uuid: [8; 16],
            ..key
        };
        assert!(other_driver.check_payload(&data).is_err());
        assert!(key.check_payload(&data[..20]).is_err());
        let newer = DriverKey {
            driver_version: 8,
            ..key
        };
        assert_ne!(key.file(Path::new("d")), newer.file(Path::new("d")));
        assert_ne!(key.hash(), newer.hash());
    }
}
