//! One path from a loaded scene to a render, used by `candela render`, the server's worker and
//! `candela bench` alike, so that a new step (a cache, instancing, a farm shard) is added here
//! once:
//!
//! 1. the film size: the scene's film or an override, checked against [`FilmLimits`];
//! 2. the acceleration structure: the request's kind (else the scene's `render.accel`), built or
//!    taken from the cache;
//! 3. the compiled scene ([`crate::compile`]): camera-relative buffers, lights, feature set;
//! 4. sessions ([`PreparedScene::session`]) for any integrator, sharing that compiled scene.

use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::accel::{AccelOptions, AccelRequest};
use crate::compile::{compile_with, CompileError, CompileOptions, CompiledScene, KernelMode};
use crate::error::RenderError;
use crate::gpu::GpuContext;
use crate::integrators::IntegratorOptions;
use crate::render::RenderSession;
use crate::scene::Scene;

/// The largest film a render accepts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FilmLimits {
    pub max_side: u32,
    pub max_pixels: u64,
}

impl Default for FilmLimits {
    /// 16384 pixels per side, 64 Mpixels.
    fn default() -> Self {
        FilmLimits {
            max_side: 16384,
            max_pixels: 64 * 1024 * 1024,
        }
    }
}

impl FilmLimits {
    /// Checks a film size, naming the side (`width`, `height`) or the product that is too large.
    pub fn check(&self, width: u32, height: u32) -> Result<(), PrepareError> {
        for (field, v) in [("width", width), ("height", height)] {
            if v == 0 || v > self.max_side {
                return Err(PrepareError::Film {
                    field,
                    message: format!("must be in 1..={}, got {v}", self.max_side),
                });
            }
        }
        if width as u64 * height as u64 > self.max_pixels {
            return Err(PrepareError::Film {
                field: "size",
                message: format!("{width}x{height} is more than {} pixels", self.max_pixels),
            });
        }
        Ok(())
    }
}

/// How to prepare a scene; every field falls back on the scene's own settings.
#[derive(Debug, Clone, Copy, Default)]
pub struct PrepareOptions<'a> {
    /// Film size overrides (None: the scene's film).
    pub width: Option<u32>,
    pub height: Option<u32>,
    pub limits: FilmLimits,
    /// The acceleration structure asked for (falls back on the scene's `render` block).
    pub accel: AccelRequest<'a>,
    /// Directory of the acceleration-structure cache (None: always build).
    pub cache: Option<&'a Path>,
    /// Kernels specialised to the scene (default) or generic.
    pub kernels: KernelMode,
    /// How long the caller took to load the scene (reported as `load_s`; zero: unknown).
    pub load_time: Duration,
    /// Every instance written out as a mesh: set for an integrator without a second level
    /// (`IntegratorInfo::instances` false; [`expands_instances`]).
    pub expand_instances: bool,
    /// The most triangles once instances are written out (the caller's scene limits; None:
    /// the loader's default).
    pub max_triangles: Option<u64>,
}

/// Whether a scene prepared for `integrator` must have its instances written out as meshes
/// (vct and deferred read primitives by index: they have no second level to trace).
pub fn expands_instances(integrator: &IntegratorOptions) -> bool {
    !integrator.info().instances
}

/// Why a scene could not be prepared; each names the setting at fault.
#[derive(Debug, thiserror::Error)]
pub enum PrepareError {
    #[error("film {field}: {message}")]
    Film {
        field: &'static str,
        message: String,
    },
    #[error("accel: {0}")]
    Accel(String),
    #[error("compiling the scene: {0}")]
    Compile(#[from] CompileError),
}

/// A scene compiled for one film size and acceleration structure: what every render of it
/// shares.
pub struct PreparedScene {
    pub compiled: CompiledScene,
    /// The scene's `render.max_depth`: every integrator's default max_depth.
    pub scene_max_depth: Option<i32>,
    /// Wall time of steps 1-3.
    pub prepare_time: Duration,
    /// The kernels its sessions compile.
    pub kernels: KernelMode,
}

/// Steps 1-3: film size, acceleration structure, compiled scene.
pub fn prepare(scene: &Scene, o: &PrepareOptions<'_>) -> Result<PreparedScene, PrepareError> {
    let start = Instant::now();
    // Step 1: the film.
    let width = o.width.unwrap_or(scene.film.width);
    let height = o.height.unwrap_or(scene.film.height);
    o.limits.check(width, height)?;
    // Step 2: which acceleration structure, from the request, else the scene.
    let accel = AccelOptions::resolve(o.accel, scene.render.accel_request(), scene.accel_size())
        .map_err(PrepareError::Accel)?;
    // Step 3: compile (the structure is built here, or read from the cache).
    let mut compiled = compile_with(
        scene,
        width,
        height,
        &CompileOptions {
            accel,
            cache: o.cache,
            expand_instances: o.expand_instances,
            max_triangles: o.max_triangles,
        },
    )?;
    compiled.load_time = o.load_time;
    Ok(PreparedScene {
        compiled,
        scene_max_depth: scene.render.max_depth,
        prepare_time: start.elapsed(),
        kernels: o.kernels,
    })
}

impl PreparedScene {
    /// Step 4: a render session of this scene with `integrator` and `seed` (uploads the scene,
    /// builds the kernels).
    pub fn session(
        &self,
        ctx: &Arc<GpuContext>,
        integrator: &IntegratorOptions,
        seed: u64,
    ) -> Result<RenderSession, RenderError> {
        RenderSession::with_kernels(
            ctx,
            &self.compiled,
            integrator,
            self.scene_max_depth,
            seed,
            self.kernels,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn film_limits_name_the_side() {
        let l = FilmLimits::default();
        assert!(l.check(16384, 4096).is_ok());
        let e = l.check(0, 10).unwrap_err().to_string();
        assert_eq!(e, "film width: must be in 1..=16384, got 0");
        let e = l.check(10, 20000).unwrap_err().to_string();
        assert!(e.starts_with("film height:"), "{e}");
        let e = l.check(16384, 16384).unwrap_err().to_string();
        assert_eq!(e, "film size: 16384x16384 is more than 67108864 pixels");
    }
}
