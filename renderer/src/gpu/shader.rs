//! GLSL → SPIR-V in-process with glslang, from the sources embedded at build time (build.rs), so
//! no shader compiler is needed on the machine. `#include "common/x.glsl"` resolves against the
//! `shaders/` root; `common/constants.glsl` is generated from renderer/src/layout.rs. Each (entry file, define set) is compiled once per process and cached: kernels
//! are specialised per scene feature set with `#define`s ("model only what a scene requires").

use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

use glslang::include::{IncludeHandler, IncludeResult, IncludeType};
use glslang::{
    CompilerOptions, ShaderInput, ShaderSource, ShaderStage, SourceLanguage, SpirvVersion, Target,
    VulkanVersion,
};

use super::{GpuError, GpuResult};

mod embedded {
    include!(concat!(env!("OUT_DIR"), "/shaders.rs"));
}

/// `#define NAME VALUE` pairs, in a stable order (they are part of the cache key).
pub type ShaderDefines = Vec<(String, String)>;

/// Returns the source of `path` (relative to shaders/): an embedded file, or the generated
/// constants (`common/constants.glsl`, from [`crate::layout::glsl_constants`]).
pub fn shader_source(path: &str) -> Option<&'static str> {
    if path == crate::layout::GLSL_CONSTANTS_PATH {
        static CONSTANTS: OnceLock<String> = OnceLock::new();
        return Some(
            CONSTANTS
                .get_or_init(crate::layout::glsl_constants)
                .as_str(),
        );
    }
    embedded::SHADERS
        .iter()
        .find(|(p, _)| *p == path)
        .map(|(_, s)| *s)
}

struct EmbeddedIncludes;

impl IncludeHandler for EmbeddedIncludes {
    fn include(
        &mut self,
        _ty: IncludeType,
        header: &str,
        includer: &str,
        _depth: usize,
    ) -> Option<IncludeResult> {
        // Root-relative first, then relative to the including file's folder.
        let rel = includer
            .rsplit_once('/')
            .map(|(dir, _)| format!("{dir}/{header}"));
        let (name, data) = std::iter::once(header.to_string())
            .chain(rel)
            .find_map(|p| shader_source(&p).map(|s| (p, s)))?;
        Some(IncludeResult {
            name,
            data: data.to_string(),
        })
    }
}

type Cache = Mutex<HashMap<(String, ShaderDefines), Arc<Vec<u32>>>>;

fn cache() -> &'static Cache {
    static CACHE: OnceLock<Cache> = OnceLock::new();
    CACHE.get_or_init(|| Mutex::new(HashMap::new()))
}

/// Compiles the compute shader `path` (relative to shaders/) with `defines`; cached.
pub fn compile_glsl(path: &str, defines: &ShaderDefines) -> GpuResult<Arc<Vec<u32>>> {
    let key = (path.to_string(), defines.clone());
    if let Some(hit) = cache().lock().ok().and_then(|c| c.get(&key).cloned()) {
        return Ok(hit);
    }
    let err = |log: String| GpuError::Shader {
        name: path.to_string(),
        log,
    };
    let text = shader_source(path).ok_or_else(|| err("no such embedded shader".into()))?;
    // One compilation at a time: glslang is C++ and its thread safety is not documented by the
    // binding; a C++ exception crossing into Rust aborts the process. A test binary once
    // aborted so ("Rust cannot catch foreign exceptions") while two threads built kernels; the
    // cause was not pinned down, and serialising glslang rules it out. Compiles are cached, so
    // this costs little.
    static COMPILING: Mutex<()> = Mutex::new(());
    let _one_at_a_time = COMPILING.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(hit) = cache().lock().ok().and_then(|c| c.get(&key).cloned()) {
        return Ok(hit);
    }
    let compiler =
        glslang::Compiler::acquire().ok_or_else(|| err("glslang failed to initialise".into()))?;
    let source = ShaderSource::try_from(text.to_string()).map_err(|e| err(e.to_string()))?;
    let options = CompilerOptions {
        source_language: SourceLanguage::GLSL,
        target: Target::Vulkan {
            version: VulkanVersion::Vulkan1_2,
            spirv_version: SpirvVersion::SPIRV1_5,
        },
        version_profile: None,
        messages: glslang::ShaderMessage::DEFAULT,
    };
    let defs: Vec<(&str, Option<&str>)> = defines
        .iter()
        .map(|(k, v)| (k.as_str(), Some(v.as_str())))
        .collect();
    let mut includes = EmbeddedIncludes;
    let input = ShaderInput::new(
        &source,
        ShaderStage::Compute,
        &options,
        Some(&defs[..]),
        Some(&mut includes),
    )
    .map_err(|e| err(e.to_string()))?;
    let shader = glslang::Shader::new(compiler, input)
        .parse()
        .map_err(|e| err(e.to_string()))?;
    let spirv = shader.compile().map_err(|e| err(e.to_string()))?;
    let spirv = Arc::new(spirv);
    if let Ok(mut c) = cache().lock() {
        c.insert(key, spirv.clone());
    }
    Ok(spirv)
}
