//! One render in progress: uploaded scene buffers, accumulation buffer, pipeline and counters.
//! Integrators may declare extra per-pixel buffers (bdpt: light-tracing splats) and how the image
//! is formed from them; checkpoints carry them after the accumulation.

use std::sync::Arc;
use std::time::{Duration, Instant};

use super::{RenderError, RenderStats};
use crate::compile::{CompiledScene, KernelMode};
use crate::film::Image;
use crate::gpu::{compile_glsl, Binding, Buffer, BufferUsage, ComputePipeline, GpuContext};
use crate::integrators::{ExtraBuffer, Integrator, IntegratorInfo, IntegratorOptions};
use crate::layout::{binding, GpuPush, GpuStats};
use crate::upload::{as_bindings, upload_scene};

/// Timing of one pass.
#[derive(Debug, Clone, Copy)]
pub struct PassStats {
    pub spp: u32,
    pub wall: Duration,
    pub gpu: Duration,
}

/// The counters of a render, saved with a checkpoint so a resumed render reports the same
/// statistics as an uninterrupted one.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct Progress {
    pub spp: u32,
    pub passes: u32,
    pub rays: u64,
    pub dropped_samples: u64,
    /// Wall and GPU time spent in passes so far, seconds.
    pub time_s: f64,
    pub gpu_time_s: f64,
}

/// Mesa's llvmpipe (lavapipe) silently ends every loop of a shader invocation once 65,535 loop
/// iterations have run in it (`LP_MAX_TGSI_LOOP_ITERATIONS`), so a dispatch of many samples per
/// pixel comes out truncated (darker) without an error. There each pass is split into dispatches
/// of one sample each, up to this many dispatches (beyond, the samples are spread evenly). The
/// image is the same whatever the split: samples are keyed by index.
pub const LLVMPIPE_MAX_DISPATCHES: u32 = 64;

/// The pass `push` (samples `sample_base..sample_base + spp`) as up to `limit` consecutive
/// dispatches of as even a size as possible, in sample order.
fn pass_chunks(push: &GpuPush, limit: u32) -> Vec<GpuPush> {
    let n = push.spp.min(limit).max(1);
    let (base, extra) = (push.spp / n, push.spp % n);
    let mut first = push.sample_base;
    (0..n)
        .map(|i| {
            let mut p = *push;
            p.sample_base = first;
            p.spp = base + u32::from(i < extra);
            first += p.spp;
            p
        })
        .collect()
}

/// A progressive render on one device.
pub struct RenderSession {
    ctx: Arc<GpuContext>,
    /// The integrator's registry entry (name, pass kernel).
    entry: &'static IntegratorInfo,
    integrator: Box<dyn Integrator>,
    pipeline: ComputePipeline,
    // Scene buffers are kept alive for the pipeline's descriptor set.
    _scene: Vec<Buffer>,
    accum: Buffer,
    /// The integrator's extra per-pixel buffers, in `extra_buffers()` order.
    extra: Vec<(ExtraBuffer, Buffer)>,
    stats_buf: Buffer,
    width: u32,
    height: u32,
    seed: u64,
    spp: u32,
    passes: u32,
    rays: u64,
    dropped: u64,
    elapsed: Duration,
    gpu_time: Duration,
    setup: Duration,
    /// Building the pass kernel: GLSL → SPIR-V (or the in-process cache) and the pipeline.
    kernel_time: Duration,
    info: SceneInfo,
    flags: u32,
    /// Most dispatches a pass is split into ([`LLVMPIPE_MAX_DISPATCHES`] on llvmpipe, else 1).
    split_limit: u32,
}

struct SceneInfo {
    triangles: usize,
    primitives: usize,
    lights: usize,
    bvh_nodes: usize,
    bvh_depth: usize,
    bvh_build: Duration,
    features: crate::compile::FeatureSet,
    kernels: KernelMode,
    accel: crate::accel::AccelInfo,
}

impl RenderSession {
    /// Uploads the compiled scene and builds the integrator's kernel for its feature set.
    pub fn new(
        ctx: &Arc<GpuContext>,
        scene: &CompiledScene,
        options: &IntegratorOptions,
        scene_max_depth: Option<i32>,
        seed: u64,
    ) -> Result<Self, RenderError> {
        Self::with_kernels(
            ctx,
            scene,
            options,
            scene_max_depth,
            seed,
            KernelMode::Specialized,
        )
    }

    /// [`Self::new`] with a choice of kernels: specialised to the scene's features, or generic.
    pub fn with_kernels(
        ctx: &Arc<GpuContext>,
        scene: &CompiledScene,
        options: &IntegratorOptions,
        scene_max_depth: Option<i32>,
        seed: u64,
        kernels: KernelMode,
    ) -> Result<Self, RenderError> {
        let start = Instant::now();
        let mut integrator = options.build(scene_max_depth);
        integrator.prepare(ctx);
        let (w, h) = (scene.width, scene.height);
        let pixels = w as u64 * h as u64;
        // Step 1: scene buffers, each at its named binding.
        let scene_buffers = upload_scene(ctx, scene)?;
        // Step 2: accumulation (rgb sum, sample count per pixel) and counters, zeroed.
        let accum = Buffer::new(ctx, "accumulation", pixels * 16, BufferUsage::Storage)?;
        ctx.fill_zero(&accum)?;
        let stats_buf = Buffer::new(
            ctx,
            "stats",
            std::mem::size_of::<GpuStats>() as u64,
            BufferUsage::Storage,
        )?;
        ctx.fill_zero(&stats_buf)?;
        let mut extra = Vec::new();
        for e in integrator.extra_buffers() {
            let bytes = pixels * 16 * e.entries_per_pixel as u64;
            let b = Buffer::new(ctx, e.name, bytes, BufferUsage::Storage)?;
            ctx.fill_zero(&b)?;
            extra.push((e, b));
        }
        // Step 3: the kernel, specialised for the scene's features (or generic), and the
        // integrator's own defines.
        let features = scene.features.for_mode(kernels);
        let mut defines = features.defines();
        if scene.grid.is_some() {
            defines.push(("ACCEL_GRID".to_string(), "1".to_string()));
        }
        defines.extend(integrator.defines());
        let kernel_start = Instant::now();
        let spirv = compile_glsl(options.info().kernel, &defines)?;
        let mut bindings = as_bindings(&scene_buffers);
        bindings.push(Binding {
            index: binding::ACCUM,
            buffer: &accum,
        });
        bindings.push(Binding {
            index: binding::STATS,
            buffer: &stats_buf,
        });
        for (e, b) in &extra {
            bindings.push(Binding {
                index: e.binding,
                buffer: b,
            });
        }
        let pipeline = ComputePipeline::new(
            ctx,
            options.info().kernel,
            &spirv,
            &bindings,
            std::mem::size_of::<GpuPush>() as u32,
        )?;
        let kernel_time = kernel_start.elapsed();
        // Step 4: the integrator's own stages (buffers, pipelines, scene-only work).
        integrator.setup(ctx, scene, &bindings, &defines)?;
        drop(bindings);
        ctx.check_validation()?;
        Ok(RenderSession {
            ctx: ctx.clone(),
            entry: options.info(),
            integrator,
            pipeline,
            _scene: scene_buffers.into_iter().map(|(_, b)| b).collect(),
            accum,
            extra,
            stats_buf,
            width: w,
            height: h,
            seed,
            spp: 0,
            passes: 0,
            rays: 0,
            dropped: 0,
            elapsed: Duration::ZERO,
            gpu_time: Duration::ZERO,
            setup: start.elapsed(),
            kernel_time,
            flags: 0,
            split_limit: if ctx.info.name.contains("llvmpipe") {
                LLVMPIPE_MAX_DISPATCHES
            } else {
                1
            },
            info: SceneInfo {
                triangles: scene.triangle_count,
                primitives: scene.prims.len(),
                lights: scene.lights.len(),
                bvh_nodes: scene.nodes.len(),
                bvh_depth: scene.bvh_depth,
                bvh_build: scene.bvh_build_time,
                features,
                kernels,
                accel: scene.accel.clone(),
            },
        })
    }

    /// Sets `GpuPush::flags` (testing aids such as `PUSH_FLAG_INJECT_NAN`).
    pub fn set_debug_flags(&mut self, flags: u32) {
        self.flags = flags;
    }

    /// Starts over with another seed, keeping the uploaded scene and the compiled pipeline: the
    /// accumulation, extra buffers and counters are cleared. Much cheaper than a new session
    /// (benchmarks run many short renders of one scene).
    pub fn reset(&mut self, seed: u64) -> Result<(), RenderError> {
        self.ctx.fill_zero(&self.accum)?;
        self.ctx.fill_zero(&self.stats_buf)?;
        for (_, b) in &self.extra {
            self.ctx.fill_zero(b)?;
        }
        self.seed = seed;
        self.spp = 0;
        self.passes = 0;
        self.rays = 0;
        self.dropped = 0;
        self.elapsed = Duration::ZERO;
        self.gpu_time = Duration::ZERO;
        Ok(())
    }

    /// Samples per pixel rendered so far.
    pub fn spp(&self) -> u32 {
        self.spp
    }

    /// Wall time spent in passes.
    pub fn elapsed(&self) -> Duration {
        self.elapsed
    }

    /// Renders `spp` more samples per pixel.
    pub fn run_pass(&mut self, spp: u32) -> Result<PassStats, RenderError> {
        if spp == 0 {
            return Err(RenderError::Invalid(
                "a pass needs at least one sample".into(),
            ));
        }
        let start = Instant::now();
        let push = GpuPush {
            seed_lo: self.seed as u32,
            seed_hi: (self.seed >> 32) as u32,
            sample_base: self.spp,
            spp,
            flags: self.flags,
            ..Default::default()
        };
        let groups = [self.width.div_ceil(8), self.height.div_ceil(8), 1];
        let chunks = pass_chunks(&push, self.split_limit);
        let (integrator, pipeline) = (&self.integrator, &self.pipeline);
        let most: u32 = chunks
            .iter()
            .map(|c| integrator.dispatches_per_pass(c.spp))
            .sum();
        let timings = self.ctx.record(most, |rec| {
            chunks
                .iter()
                .try_for_each(|c| integrator.record_pass(rec, pipeline, *c, groups))
        })?;
        self.integrator.observe_timings(&timings);
        // Counters: read and reset (u32 on the GPU, u64 here).
        let s: Vec<GpuStats> = self.ctx.download_vec(&self.stats_buf, 1)?;
        self.ctx.fill_zero(&self.stats_buf)?;
        self.ctx.check_validation()?;
        let gpu = Duration::from_secs_f64(timings.iter().map(|t| t.gpu_ms).sum::<f64>() * 1e-3);
        let wall = start.elapsed();
        self.rays += ((s[0].rays_hi as u64) << 32) | s[0].rays_lo as u64;
        self.dropped += s[0].dropped_samples as u64;
        self.spp += spp;
        self.passes += 1;
        self.elapsed += wall;
        self.gpu_time += gpu;
        Ok(PassStats { spp, wall, gpu })
    }

    /// The counters so far (to store with a checkpoint).
    pub fn progress(&self) -> Progress {
        Progress {
            spp: self.spp,
            passes: self.passes,
            rays: self.rays,
            dropped_samples: self.dropped,
            time_s: self.elapsed.as_secs_f64(),
            gpu_time_s: self.gpu_time.as_secs_f64(),
        }
    }

    /// Entries (`[f32; 4]`) in [`Self::accumulation`]: width·height, plus the integrator's extra
    /// buffers (bdpt: one or two per pixel).
    pub fn accumulation_len(&self) -> usize {
        let n = (self.width * self.height) as usize;
        n + self
            .extra
            .iter()
            .map(|(e, _)| n * e.entries_per_pixel as usize)
            .sum::<usize>()
    }

    /// The raw accumulation buffer: per pixel (Σr, Σg, Σb, samples kept), row 0 at the top,
    /// followed by the raw words of the integrator's extra buffers (bdpt: the light-tracing
    /// splats), [`Self::accumulation_len`] entries in all. Restore it as a whole.
    pub fn accumulation(&self) -> Result<Vec<[f32; 4]>, RenderError> {
        let n = (self.width * self.height) as usize;
        let mut out: Vec<[f32; 4]> = self.ctx.download_vec(&self.accum, n)?;
        for (e, b) in &self.extra {
            out.extend(
                self.ctx
                    .download_vec::<[f32; 4]>(b, n * e.entries_per_pixel as usize)?,
            );
        }
        Ok(out)
    }

    /// Resumes from a checkpoint: the accumulation and counters of an earlier session of the same
    /// scene, integrator and seed. Because samples are keyed by index, the render then continues
    /// exactly as if it had never stopped.
    pub fn restore(
        &mut self,
        accumulation: &[[f32; 4]],
        progress: Progress,
    ) -> Result<(), RenderError> {
        let n = (self.width * self.height) as usize;
        let want = self.accumulation_len();
        if accumulation.len() != want {
            return Err(RenderError::Invalid(format!(
                "checkpoint has {} entries, this film and integrator {want}",
                accumulation.len()
            )));
        }
        self.ctx
            .upload(&self.accum, 0, bytemuck::cast_slice(&accumulation[..n]))?;
        let mut at = n;
        for (e, b) in &self.extra {
            let len = n * e.entries_per_pixel as usize;
            self.ctx
                .upload(b, 0, bytemuck::cast_slice(&accumulation[at..at + len]))?;
            at += len;
        }
        self.spp = progress.spp;
        self.passes = progress.passes;
        self.rays = progress.rays;
        self.dropped = progress.dropped_samples;
        self.elapsed = Duration::from_secs_f64(progress.time_s.max(0.0));
        self.gpu_time = Duration::from_secs_f64(progress.gpu_time_s.max(0.0));
        Ok(())
    }

    /// The current estimate: accumulated radiance divided by the samples kept per pixel, as the
    /// integrator resolves it (bdpt adds its light-tracing splats).
    pub fn image(&self) -> Result<Image, RenderError> {
        let n = (self.width * self.height) as usize;
        let acc: Vec<[f32; 4]> = self.ctx.download_vec(&self.accum, n)?;
        let mut extra = Vec::with_capacity(self.extra.len());
        for (e, b) in &self.extra {
            extra.push(
                self.ctx
                    .download_vec::<[f32; 4]>(b, n * e.entries_per_pixel as usize)?,
            );
        }
        let pixels = self.integrator.resolve(&acc, &extra, self.spp);
        Ok(Image {
            width: self.width,
            height: self.height,
            pixels,
        })
    }

    pub fn stats(&self) -> RenderStats {
        let t = self.elapsed.as_secs_f64();
        let samples = self.spp as f64 * self.width as f64 * self.height as f64;
        RenderStats {
            device: self.ctx.info.clone(),
            integrator: self.entry.name.to_string(),
            width: self.width,
            height: self.height,
            spp: self.spp,
            passes: self.passes,
            max_depth: self.integrator.max_depth(),
            seed: self.seed,
            time_s: t,
            gpu_time_s: self.gpu_time.as_secs_f64(),
            msamples_per_s: if t > 0.0 { samples / t * 1e-6 } else { 0.0 },
            rays_per_s: if t > 0.0 { self.rays as f64 / t } else { 0.0 },
            rays: self.rays,
            dropped_samples: self.dropped,
            triangles: self.info.triangles,
            primitives: self.info.primitives,
            lights: self.info.lights,
            bvh_nodes: self.info.bvh_nodes,
            bvh_depth: self.info.bvh_depth,
            bvh_build_s: self.info.bvh_build.as_secs_f64(),
            setup_s: self.setup.as_secs_f64(),
            kernel_s: self.kernel_time.as_secs_f64(),
            kernel_stats: self.pipeline.statistics().into_iter().collect(),
            features: self.info.features.names(),
            kernels: self.info.kernels,
            accel: self.info.accel.kind.name().to_string(),
            accel_build_s: self.info.accel.build_time.as_secs_f64(),
            accel_bytes: self.info.accel.bytes,
            accel_cache: self.info.accel.cache,
            grid_resolution: self.info.accel.grid_resolution,
            grid_refs: self.info.accel.grid_refs,
            details: self.integrator.details(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pass_chunks_cover_the_samples_in_order() {
        for (spp, limit) in [
            (1, 64),
            (5, 64),
            (64, 64),
            (100, 64),
            (1000, 64),
            (7, 1),
            (3, 2),
        ] {
            let push = GpuPush {
                sample_base: 11,
                spp,
                flags: 5,
                ..Default::default()
            };
            let c = pass_chunks(&push, limit);
            assert_eq!(c.len() as u32, spp.min(limit));
            let mut next = 11;
            for p in &c {
                assert_eq!(p.sample_base, next);
                assert!(p.spp >= spp / limit && p.spp <= spp.div_ceil(limit).max(1));
                assert_eq!(p.flags, 5);
                next += p.spp;
            }
            assert_eq!(next, 11 + spp);
        }
    }
}
