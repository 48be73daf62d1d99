//! The renderer's error for everything past scene loading (compiling, the device, an
//! integrator's options or stages). It sits below `integrators` and `render` so that both can
//! return it without depending on each other.

use crate::compile::CompileError;
use crate::gpu::GpuError;

/// Why a render could not be prepared or run.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error(transparent)]
    Compile(#[from] CompileError),
    #[error("{0}")]
    Invalid(String),
}
