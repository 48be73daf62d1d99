//! GLSL → SPIR-V in-process with glslang, from the sources embedded at build time (build.rs), so
//! no shader compiler is needed on the machine. `#include "common/x.glsl"` resolves against the
//! `shaders/` root; `common/constants.glsl` is generated from renderer/src/layout.rs. Kernels are
//! specialised per scene feature set with `#define`s ("model only what a scene requires"); each
//! (entry file, define set) is compiled once per process and, with a cache folder, once per
//! machine (kernel_cache.rs).
//!
//! # Compiling in parallel
//! Independent kernels compile on several threads at once ([`super::compile_kernels`]): the
//! driver's part (pipeline creation) runs in parallel, but the GLSL → SPIR-V step is one
//! glslang compilation at a time in a process. glslang is meant to allow concurrent
//! compilations (since its 2023 releases every compilation allocates from a `thread_local` pool,
//! the built-in symbol tables are built under a global mutex, the bison parser is pure), and
//! tests/tests/kernel_cache.rs compiles on 4 threads and checks the SPIR-V against a serial
//! compile. Yet test processes that compile several large kernels at once have died: once with
//! a foreign C++ exception, and on 2026-11-26 twice with SIGSEGV in CI (the bdpt and
//! error_estimate test binaries, each while two tests compiled bdpt kernels), never reproduced
//! on demand. Until that is understood, glslang runs serially; `CANDELA_PARALLEL_GLSLANG=1`
//! lifts the lock (for measuring or for hunting the crash). What was checked since (2026-11-26):
//! 12 runs of the bdpt test binary with the lock lifted, and 9,600 parallel compiles of every
//! kernel in a separate harness (release and debug glslang, SPIR-V equal to serial compiles),
//! none crashed; glslang 16.6's process setup runs once under its own lock and each compile
//! allocates from its own pool. The other C++ that runs on several test threads at once is the
//! driver's pipeline creation (lavapipe and the validation layer in CI), the next suspect.

use std::sync::{Mutex, OnceLock};

use glslang::include::{IncludeHandler, IncludeResult, IncludeType};
use glslang::{
    CompilerOptions, ShaderInput, ShaderSource, ShaderStage, SourceLanguage, SpirvVersion, Target,
    VulkanVersion,
};

mod embedded {
    include!(concat!(env!("OUT_DIR"), "/shaders.rs"));
}

/// `#define NAME VALUE` pairs, in a stable order (they are part of the cache key).
pub type ShaderDefines = Vec<(String, String)>;

/// A value the host compiles into a kernel in place of a run-time read (the render's constants:
/// shaders/common/types.glsl), spelled as GLSL reads it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Constant {
    Bool(bool),
    Int(i32),
    Uint(u32),
}

impl Constant {
    /// `NAME` defined as this value: `true`, `6`, `(-1)` (parenthesised, so that no operator
    /// before it merges with the sign), `6u`.
    pub fn define(self, name: &str) -> (String, String) {
        let value = match self {
            Constant::Bool(b) => b.to_string(),
            Constant::Int(i) if i < 0 => format!("({i})"),
            Constant::Int(i) => i.to_string(),
            Constant::Uint(u) => format!("{u}u"),
        };
        (name.to_string(), value)
    }
}

/// What the SPIR-V depends on besides the sources and defines: the glslang version (from
/// Cargo.lock) and the target environment. Part of every kernel cache key.
pub const COMPILER_ID: &str = concat!(
    "glslang ",
    env!("CANDELA_GLSLANG_VERSION"),
    "; vulkan1.2 spirv1.5 compute"
);

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

/// Where `#include "header"` in `includer` points: root-relative first, then relative to the
/// including file's folder (the first that `exists`).
pub fn resolve_include(
    header: &str,
    includer: &str,
    exists: impl Fn(&str) -> bool,
) -> Option<String> {
    let rel = includer
        .rsplit_once('/')
        .map(|(dir, _)| format!("{dir}/{header}"));
    std::iter::once(header.to_string())
        .chain(rel)
        .find(|p| exists(p))
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
        let name = resolve_include(header, includer, |p| shader_source(p).is_some())?;
        let data = shader_source(&name)?.to_string();
        Some(IncludeResult { name, data })
    }
}

/// Compiles the compute shader `path` (relative to shaders/) with `defines`, uncached; the
/// error is glslang's log.
pub(crate) fn glslang_compile(path: &str, defines: &ShaderDefines) -> Result<Vec<u32>, String> {
    let text = shader_source(path).ok_or("no such embedded shader")?;
    // One glslang compilation at a time unless lifted (see the top of this file).
    static SERIAL: Mutex<()> = Mutex::new(());
    let parallel = std::env::var_os("CANDELA_PARALLEL_GLSLANG").is_some_and(|v| v != "0");
    let _serial = (!parallel).then(|| SERIAL.lock().unwrap_or_else(|e| e.into_inner()));
    let compiler = glslang::Compiler::acquire().ok_or("glslang failed to initialise")?;
    let source = ShaderSource::from(text.to_string());
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
    .map_err(|e| e.to_string())?;
    let shader = glslang::Shader::new(compiler, input)
        .parse()
        .map_err(|e| e.to_string())?;
    shader.compile().map_err(|e| e.to_string())
}
