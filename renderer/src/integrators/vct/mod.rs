//! `vct`: voxel cone tracing (Crassin, Neyret, Sainz, Green & Eisemann 2011, "Interactive
//! Indirect Illumination Using Voxel Cone Tracing"), in Vulkan compute, over a sparse voxel
//! octree or a dense grid. Kernels: shaders/vct/. Documentation: docs/vct.md.
//!
//! # Stages (all on the GPU; `setup` runs the first four once per geometry)
//! 1. **voxelize** (build.rs, voxelize.comp): conservative voxelization of every triangle and
//!    sphere into a fragment list; the grid is a cube fitted to the scene, 2^6..2^10 per axis.
//! 2. **build** (build.rs, octree.comp / attributes.comp / normalize.comp): the octree level by
//!    level (flag, allocate with an atomic counter, mark; no CPU round trip per level) or the
//!    dense grid, then per-voxel albedo, opacity, normal, mean surface point and emission.
//! 3. **inject** (light.rs, inject.comp): direct light from every light of the scene into every
//!    voxel: L = albedo/π · E, E from light samples with BVH shadow rays, in the path tracers'
//!    units; the two sides of each voxel's surface are kept apart (front/back radiance).
//! 4. **filter** (light.rs, dense_mip.comp / brick.comp): six directional values per cell on
//!    every level above 0 (Crassin's anisotropic voxels; level 0 shows the side facing the cone
//!    with the surface's coverage |n·e| as opacity); octree values live in 3×3×3 bricks with
//!    border transfer, at exactly the dense grid's sample positions. `bounces: 2` gathers the
//!    first bounce per voxel, adds it and filters again (bounce.comp).
//! 5. **trace** (vct.comp, every pass): primary ray through the BVH; emission and exact direct
//!    light at the hit (as `nee`'s first vertex); indirect light from cones.
//!
//! # max_depth
//! 1: emitters seen directly; 2: + direct light (no volume is built unless `ao` or shadow
//! cones ask for one); ≥ 3 or −1: + the cones'
//! indirect light: voxel radiance of `bounces` bounces, capped at max_depth − 2.
//!
//! Volumes are cached per device and world-space geometry (cache.rs): another camera (placed
//! with `Volume::place`), film or sample count reuses the built volume; other lights re-inject
//! and refilter only.

mod build;
pub mod cache;
mod debug;
mod gpu;
mod light;
mod options;
mod volume;

pub use debug::{DebugVolume, Occupancy};
pub use options::{Settings, VctOptions, VctShadows, VctStorage, DENSE_MAX_RESOLUTION};
pub use volume::StageTimes;

use std::sync::{Arc, Mutex};

use super::Integrator;
use crate::compile::{CompiledScene, SceneConstants};
use crate::error::RenderError;
use crate::gpu::{
    Binding, ComputePipeline, Constant, GpuContext, GpuResult, Recorder, ShaderDefines,
};
use crate::layout::GpuPush;
use volume::Volume;

/// The volume a session renders with and its gather pipeline.
struct State {
    volume: Arc<Mutex<Volume>>,
    gather: ComputePipeline,
    /// How the volume was obtained: "built", "cached" or "relit" (cached, lights changed).
    origin: &'static str,
    defines: ShaderDefines,
}

pub struct VctIntegrator {
    /// GPU milliseconds of the trace dispatches so far, and their number.
    trace_ms: f64,
    trace_passes: u32,
    options: VctOptions,
    max_depth: i32,
    state: Option<State>,
    settings: Option<Settings>,
}

pub fn new(o: &VctOptions, scene_max_depth: Option<i32>) -> VctIntegrator {
    VctIntegrator {
        trace_ms: 0.0,
        trace_passes: 0,
        options: *o,
        max_depth: o.max_depth.or(scene_max_depth).unwrap_or(6),
        state: None,
        settings: None,
    }
}

impl VctIntegrator {
    /// Whether this render needs the voxel volume (indirect light or AO).
    fn needs_volume(&self, s: &Settings) -> bool {
        s.ao || s.shadows == VctShadows::Cone || self.max_depth < 0 || self.max_depth >= 3
    }

    /// Debug: samples the session's volume at (grid position, level, direction) probes (see
    /// shaders/vct/probe.comp: level −(m+1) reads exactly level m). None without a volume.
    pub fn probe(
        &self,
        ctx: &Arc<GpuContext>,
        shared: &[Binding<'_>],
        probes: &[([f32; 4], [f32; 4])],
    ) -> Option<Result<Vec<[f32; 4]>, RenderError>> {
        let st = self.state.as_ref()?;
        let v = st.volume.lock().ok()?;
        Some(v.probe(ctx, shared, &st.defines, probes))
    }
}

impl Integrator for VctIntegrator {
    fn max_depth(&self) -> i32 {
        self.max_depth
    }

    /// The volume's depth (log2 of the resolution; the octree walks' trip counts) is compiled
    /// in; the resolution itself and the march's step, aperture and coarsest level are not
    /// (each alone moved either scene by at most 2.7%, and the resolution with the depth cost
    /// textured_mesh 0.9%; bench/RESULTS.md, "Read-only buffers, the tangent only where a BSDF
    /// reads it"). Nor is `cones_per_sample`: compiled in, it cost the Cornell box 9% on an
    /// H200 (and gained textured_mesh 3%; bench/RESULTS.md, "The render's constants").
    fn constants(&self, scene: &SceneConstants) -> ShaderDefines {
        let mut c = scene.all();
        c.push(Constant::Int(self.max_depth).define("PASS_MAX_DEPTH"));
        // (Invalid options have none: setup reports them.)
        if let Ok(s) = self.options.settings() {
            c.extend([
                Constant::Bool(s.storage == VctStorage::Octree).define("VCT_OCTREE"),
                Constant::Bool(s.ao).define("VCT_AO"),
                Constant::Bool(s.shadows == VctShadows::Cone).define("VCT_SHADOW_CONE"),
                Constant::Uint(s.cones.max(1)).define("VCT_CONES"),
                Constant::Uint(s.resolution.trailing_zeros()).define("VCT_LEVELS"),
            ]);
        }
        c
    }

    fn kernels(&self, defines: &ShaderDefines) -> Vec<(String, ShaderDefines)> {
        let Ok(s) = self.options.settings() else {
            return Vec::new();
        };
        if !self.needs_volume(&s) {
            return Vec::new();
        }
        let mut list = vec![
            "vct/voxelize.comp",
            "vct/attributes.comp",
            "vct/normalize.comp",
            "vct/inject.comp",
        ];
        match s.storage {
            VctStorage::Octree => list.extend(["vct/octree.comp", "vct/brick.comp"]),
            VctStorage::Dense => list.push("vct/dense_mip.comp"),
        }
        if s.bounces >= 2 && (self.max_depth < 0 || self.max_depth >= 4) {
            list.push("vct/bounce.comp");
        }
        let mut out: Vec<(String, ShaderDefines)> = list
            .into_iter()
            .map(|k| (k.to_string(), defines.clone()))
            .collect();
        let mut volume = defines.clone();
        volume.push(("VCT_VOLUME".into(), "1".into()));
        out.push(("vct/vct.comp".into(), volume));
        out
    }

    fn setup(
        &mut self,
        ctx: &Arc<GpuContext>,
        scene: &CompiledScene,
        shared: &[Binding<'_>],
        defines: &ShaderDefines,
    ) -> Result<(), RenderError> {
        let mut s = self.options.settings()?;
        self.settings = Some(s);
        if !self.needs_volume(&s) {
            return Ok(());
        }
        // Voxel bounces beyond max_depth − 2 would add paths longer than max_depth.
        if self.max_depth >= 0 {
            s.bounces = s.bounces.min((self.max_depth - 2).max(1) as u32);
        }
        self.settings = Some(s);
        // Step 1: a cached volume of this geometry, else a new one.
        let key = cache::geometry_key(scene, &s);
        let lights = cache::lights_key(scene, &s);
        let (volume, mut origin) = match cache::lookup(ctx, key) {
            cache::Lookup::Hit(v) => (v, "cached"),
            cache::Lookup::Miss => {
                let v = Arc::new(Mutex::new(build::build(ctx, scene, shared, defines, &s)?));
                cache::store(ctx, key, v.clone());
                (v, "built")
            }
        };
        let mut vdefines = defines.clone();
        vdefines.push(("VCT_VOLUME".into(), "1".into()));
        let gather = {
            let mut v = volume
                .lock()
                .map_err(|_| RenderError::Invalid("vct: volume lock poisoned".into()))?;
            // Step 2: place it relative to this render's camera, light it (again, where the
            // lights changed) and apply this render's options.
            v.place(ctx, scene.camera_position)?;
            if v.lights_key != Some(lights) {
                v.light(ctx, shared, defines, &s, lights)?;
                if origin == "cached" {
                    origin = "relit";
                }
            } else {
                v.apply_options(ctx, &s)?;
            }
            // Step 3: the gather kernel, bound to the session's buffers and the volume's.
            let set = v.set();
            let b = gpu::bindings(shared, &v.params_buf, &v.info_buf, &v.dummy, &set);
            gpu::pipeline(ctx, "vct/vct.comp", &vdefines, &b)?
        };
        self.state = Some(State {
            volume,
            gather,
            origin,
            defines: defines.clone(),
        });
        Ok(())
    }

    fn record_pass(
        &self,
        rec: &mut Recorder<'_>,
        pipeline: &ComputePipeline,
        mut push: GpuPush,
        groups: [u32; 3],
    ) -> GpuResult<()> {
        push.max_depth = self.max_depth;
        match &self.state {
            Some(st) => rec.dispatch(&st.gather, bytemuck::bytes_of(&push), groups, "vct trace"),
            None => rec.dispatch(
                pipeline,
                bytemuck::bytes_of(&push),
                groups,
                "vct trace (direct)",
            ),
        }
    }

    fn observe_timings(&mut self, timings: &[crate::gpu::DispatchTiming]) {
        self.trace_ms += timings.iter().map(|t| t.gpu_ms).sum::<f64>();
        self.trace_passes += 1;
    }

    fn reset_timings(&mut self) {
        self.trace_ms = 0.0;
        self.trace_passes = 0;
    }

    fn details(&self) -> Option<serde_json::Value> {
        let s = self.settings?;
        let Some(st) = &self.state else {
            return Some(serde_json::json!({
                "volume": "none (max_depth <= 2: emission and direct light only)",
                "resolution": s.resolution,
                "storage": s.storage,
                "timings_ms": { "trace": self.trace_ms },
            }));
        };
        let v = st.volume.lock().ok()?;
        let memory: serde_json::Map<String, serde_json::Value> = v
            .memory()
            .into_iter()
            .map(|(k, b)| (k.to_string(), b.into()))
            .collect();
        let (b, l) = (v.build_times, v.light_times);
        let built = st.origin == "built";
        Some(serde_json::json!({
            "volume": st.origin,
            "storage": v.storage,
            "resolution": v.resolution,
            "levels": v.levels,
            "bounces": s.bounces,
            "shadows": s.shadows,
            "cones": s.cones,
            "cone_aperture_deg": s.cone_aperture_deg,
            "max_level": s.max_level,
            "voxels": v.voxels,
            "fragments": v.fragments,
            "nodes": v.nodes_used,
            "slots": v.slots,
            "voxel_size": v.params.grid[3],
            "timings_ms": {
                "voxelize": if built { b.voxelize_ms } else { 0.0 },
                "build": if built { b.build_ms } else { 0.0 },
                "inject": if st.origin != "cached" { l.inject_ms } else { 0.0 },
                "filter": if st.origin != "cached" { l.filter_ms } else { 0.0 },
                "bounce": if st.origin != "cached" { l.bounce_ms } else { 0.0 },
                "trace": self.trace_ms,
            },
            "trace_passes": self.trace_passes,
            "first_build_timings_ms": b,
            "memory_bytes": memory,
            "memory_total_bytes": v.total_bytes(),
            "build_peak_extra_bytes": v.build_peak_bytes,
        }))
    }
}
