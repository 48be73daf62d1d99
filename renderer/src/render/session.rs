//! One render in progress: uploaded scene buffers, accumulation buffer, pipeline and counters.
//! Integrators may declare extra per-pixel buffers (bdpt: light-tracing splats) and how the image
//! is formed from them; checkpoints carry them after the accumulation, and after those the odd
//! half (the odd-indexed samples' share of the accumulation, for the error estimate).
//!
//! Passes are queued without waiting ([`RenderSession::submit_pass`], up to
//! [`PIPELINE_DEPTH`] at once, inflight.rs) and cut into dispatches sized to the GPU
//! (dispatch.rs); [`RenderSession::run_pass`] is the one-pass-and-wait form.

mod completion;
mod host_accum;
mod stats;

pub use host_accum::HostAccumulation;

use std::collections::VecDeque;
use std::sync::Arc;
use std::time::{Duration, Instant};

use super::dispatch::DispatchShape;
use super::estimate_gpu::{Film, SessionEstimates};
use super::inflight::{
    charge, snapshot_target, CompletedPass, InFlight, PassRing, PassStats, PIPELINE_DEPTH,
};
use super::RenderError;
use crate::compile::{CompiledScene, KernelMode};
use crate::film::Image;
use crate::gpu::{
    kernel_stats, Binding, Buffer, BufferUsage, ComputePipeline, GpuContext, KernelStats,
    ShaderDefines,
};
use crate::integrators::{ExtraBuffer, Integrator, IntegratorInfo, IntegratorOptions};
use crate::layout::{binding, GpuPush, GpuStats};
use crate::upload::{as_bindings, upload_scene};

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

/// A progressive render on one device.
pub struct RenderSession {
    ctx: Arc<GpuContext>,
    /// The integrator's registry entry (name, pass kernel).
    entry: &'static IntegratorInfo,
    integrator: Box<dyn Integrator>,
    pipeline: ComputePipeline,
    // Scene and scratch buffers are kept alive for the pipelines' descriptor sets.
    _scene: Vec<Buffer>,
    accum: Buffer,
    /// The odd-indexed samples' share of `accum` (binding ACCUM_ODD; metrics/estimate.rs).
    accum_odd: Buffer,
    /// The integrator's extra per-pixel buffers, in `extra_buffers()` order.
    extra: Vec<(ExtraBuffer, Buffer)>,
    stats_buf: Buffer,
    width: u32,
    height: u32,
    seed: u64,
    spp: u32,
    /// The sample index the next pass starts at: the samples submitted so far, unless
    /// [`RenderSession::set_next_sample`] moved it (a shard of a multi-device render).
    next_sample: u32,
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
    /// A dispatch shape given by hand (tests); None: [`DispatchShape::auto`].
    shape: Option<DispatchShape>,
    /// Tiles of 8 × 8 threads per workgroup the kernels were built with (`WG_TILES`).
    workgroup_tiles: u32,
    /// Passes queued on the GPU and spare frames.
    ring: PassRing,
    /// Passes waited for by the session itself (for an [`Self::accumulation`], an image) and not
    /// yet handed to the caller: [`Self::complete_oldest`] returns them first, so a caller that
    /// reads the accumulation between passes still receives every pass, its stats and its GPU
    /// error estimate (an until-check lost here would stall the render at its check point).
    completed: VecDeque<CompletedPass>,
    /// What building the kernels took (compiles, cache hits, pipelines).
    kernel_build: KernelStats,
    /// The first pass this session ran (a GPU coming from idle runs it at low clocks).
    first_pass: Option<PassStats>,
    /// The error estimates computed on the GPU by passes (estimate_gpu.rs).
    estimates: SessionEstimates,
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
    bytes: crate::memory::SceneBytes,
    load_time: Duration,
    compile_time: Duration,
    light_sampler: &'static str,
    /// The pass kernel's defines, `NAME=VALUE`.
    kernel_defines: Vec<String>,
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
        // Options built without `IntegratorOptions::parse` (a library caller's struct, JSON read
        // with serde alone) are checked here too.
        options.validate()?;
        if !scene.instances.is_empty() && !options.info().instances {
            return Err(RenderError::Invalid(format!(
                "integrator \"{}\" does not trace instances (objects of type \"instance\"): \
                 prepare the scene with expand_instances (prepare::expands_instances) or use \
                 one of {}",
                options.name(),
                crate::integrators::INTEGRATORS
                    .iter()
                    .filter(|i| i.instances)
                    .map(|i| i.name)
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        }
        let kernels_before = kernel_stats();
        let mut integrator = options.build(scene_max_depth);
        integrator.prepare(ctx);
        // Step 0: the scene's buffers and the session's own (the film's, the counters', the
        // integrator's scratch and per-pixel buffers) checked against the device's limits before
        // anything is compiled or allocated.
        let (w, h) = (scene.width, scene.height);
        let pixels = w as u64 * h as u64;
        // Bytes of a film-sized buffer of `entries` vec4 per pixel (check and allocation alike).
        let film_bytes = |entries: u32| pixels * 16 * entries as u64;
        let (scratch_list, extra_list) =
            (integrator.scratch_buffers(w, h), integrator.extra_buffers());
        let mut needed = crate::memory::scene_buffers(scene);
        needed.extend([
            ("accumulation", film_bytes(1)),
            ("accumulation (odd)", film_bytes(1)),
            ("stats", std::mem::size_of::<GpuStats>() as u64),
        ]);
        needed.extend(scratch_list.iter().map(|b| (b.name, b.bytes)));
        needed.extend(
            extra_list
                .iter()
                .map(|e| (e.name, film_bytes(e.entries_per_pixel))),
        );
        crate::memory::check_fits(&needed, &ctx.limits)?;
        // Step 1: every kernel the session will build (specialised for the scene's features,
        // or generic, and the integrator's own defines), compiled in parallel where not cached.
        let defines = Self::defines(
            scene,
            options.info(),
            integrator.as_ref(),
            kernels,
            ctx.limits.max_workgroup_tiles,
        );
        let workgroup_tiles = ctx
            .limits
            .workgroup_tiles_of(&defines)
            .map_err(RenderError::Invalid)?;
        let mut list = vec![(options.info().kernel.to_string(), defines.clone())];
        list.extend(integrator.kernels(&defines));
        ctx.compile_kernels(&list)?;
        // Step 2: the scene's buffers, each at its named binding.
        let scene_buffers = upload_scene(ctx, scene)?;
        // Step 3: accumulation (rgb sum, sample count per pixel) and counters, zeroed.
        let accum = Buffer::new(ctx, "accumulation", film_bytes(1), BufferUsage::Storage)?;
        ctx.fill_zero(&accum)?;
        let accum_odd = Buffer::new(
            ctx,
            "accumulation (odd)",
            film_bytes(1),
            BufferUsage::Storage,
        )?;
        ctx.fill_zero(&accum_odd)?;
        let stats_buf = Buffer::new(
            ctx,
            "stats",
            std::mem::size_of::<GpuStats>() as u64,
            BufferUsage::Storage,
        )?;
        ctx.fill_zero(&stats_buf)?;
        let mut scratch = Vec::new();
        for b in scratch_list {
            let buf = Buffer::new(ctx, b.name, b.bytes, BufferUsage::Storage)?;
            ctx.fill_zero(&buf)?;
            scratch.push((b, buf));
        }
        let mut extra = Vec::new();
        for e in extra_list {
            let bytes = film_bytes(e.entries_per_pixel);
            let b = Buffer::new(ctx, e.name, bytes, BufferUsage::Storage)?;
            ctx.fill_zero(&b)?;
            extra.push((e, b));
        }
        // Step 4: the pass kernel.
        let features = scene.features.for_mode(kernels);
        let kernel_start = Instant::now();
        let spirv = ctx.kernel(options.info().kernel, &defines)?;
        let mut bindings = as_bindings(&scene_buffers);
        bindings.push(Binding {
            index: binding::ACCUM,
            buffer: &accum,
        });
        bindings.push(Binding {
            index: binding::STATS,
            buffer: &stats_buf,
        });
        bindings.push(Binding {
            index: binding::ACCUM_ODD,
            buffer: &accum_odd,
        });
        for (e, b) in &extra {
            bindings.push(Binding {
                index: e.binding,
                buffer: b,
            });
        }
        for (s, b) in &scratch {
            bindings.push(Binding {
                index: s.binding,
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
        // Step 5: the integrator's own stages (buffers, pipelines, scene-only work).
        integrator.setup(ctx, scene, &bindings, &defines)?;
        drop(bindings);
        ctx.check_validation()?;
        Ok(RenderSession {
            ctx: ctx.clone(),
            entry: options.info(),
            integrator,
            pipeline,
            _scene: scene_buffers
                .into_iter()
                .map(|(_, b)| b)
                .chain(scratch.into_iter().map(|(_, b)| b))
                .collect(),
            accum,
            accum_odd,
            extra,
            stats_buf,
            width: w,
            height: h,
            seed,
            spp: 0,
            next_sample: 0,
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
            shape: None,
            workgroup_tiles,
            ring: PassRing::default(),
            completed: VecDeque::new(),
            kernel_build: kernel_stats().since(&kernels_before),
            first_pass: None,
            estimates: SessionEstimates::default(),
            info: SceneInfo {
                triangles: scene.triangle_count,
                primitives: scene.prims.len(),
                lights: scene.lights.len(),
                bvh_nodes: scene
                    .cwbvh
                    .as_ref()
                    .map_or(scene.nodes.len(), |c| c.nodes.len()),
                bvh_depth: scene.bvh_depth,
                bvh_build: scene.bvh_build_time,
                features,
                kernels,
                accel: scene.accel.clone(),
                bytes: crate::memory::scene_bytes(scene),
                load_time: scene.load_time,
                compile_time: scene.compile_time,
                light_sampler: if Self::uses_light_bvh(scene, options.info()) {
                    "bvh"
                } else {
                    "power"
                },
                kernel_defines: defines.iter().map(|(n, v)| format!("{n}={v}")).collect(),
            },
        })
    }

    /// The defines of the session's kernels: the scene's feature set (for `mode`), the accel
    /// kind and its variants (`CWBVH_INDIRECT`, `CWBVH_SPARSE`), the light sampler (the light
    /// BVH where the scene has one and the integrator's registry entry takes it), the tiles per
    /// workgroup (`WG_TILES`: the entry's on films of at least
    /// [`super::dispatch::TILED_MIN_PIXELS`], at most `max_tiles`), the integrator's own, for
    /// specialised kernels the render's constants (the scene's filter and camera model, the
    /// integrator's depths and options), and the measuring knob's (`CANDELA_SHADER_DEFINES`, which replace
    /// defines of the same name).
    fn defines(
        scene: &CompiledScene,
        entry: &IntegratorInfo,
        integrator: &dyn Integrator,
        mode: KernelMode,
        max_tiles: u32,
    ) -> ShaderDefines {
        let mut defines = scene.features.for_mode(mode).defines();
        if scene.grid.is_some() {
            defines.push(("ACCEL_GRID".to_string(), "1".to_string()));
        }
        if let Some(c) = &scene.cwbvh {
            defines.push(("ACCEL_CWBVH".to_string(), "1".to_string()));
            if !c.prims.is_empty() {
                defines.push(("CWBVH_INDIRECT".to_string(), "1".to_string()));
            }
            if c.sparse() {
                defines.push(("CWBVH_SPARSE".to_string(), "1".to_string()));
            }
        }
        if scene.traversal_stack < crate::accel::STACK_DEPTH {
            let n = scene.traversal_stack.to_string();
            defines.push(("TEST_BVH_STACK".to_string(), n));
        }
        if Self::uses_light_bvh(scene, entry) {
            defines.push(("LIGHT_BVH".to_string(), "1".to_string()));
        }
        let film = scene.width as u64 * scene.height as u64;
        let tiles = super::dispatch::workgroup_tiles(entry.workgroup_tiles, film, max_tiles);
        if tiles > 1 {
            defines.push(("WG_TILES".to_string(), tiles.to_string()));
        }
        defines.extend(integrator.defines());
        if mode == KernelMode::Specialized {
            defines.extend(integrator.constants(&scene.constants()));
        }
        let extra = parse_defines(&std::env::var("CANDELA_SHADER_DEFINES").unwrap_or_default());
        defines.retain(|(name, _)| extra.iter().all(|(n, _)| n != name));
        defines.extend(extra);
        defines
    }

    /// Whether the session's kernels pick lights with the light BVH: the scene has one
    /// (`render.light_sampler: "bvh"`) and the integrator takes it ([`IntegratorInfo::light_bvh`]).
    fn uses_light_bvh(scene: &CompiledScene, entry: &IntegratorInfo) -> bool {
        !scene.light_bvh.is_empty() && entry.light_bvh
    }

    /// Every kernel (path, defines) a session of `options` on `scene` builds with `mode`: the
    /// pass kernel and the integrator's stages (to compile ahead, e.g. when a server warms up).
    pub fn kernels(
        ctx: &GpuContext,
        scene: &CompiledScene,
        options: &IntegratorOptions,
        scene_max_depth: Option<i32>,
        mode: KernelMode,
    ) -> Vec<(String, ShaderDefines)> {
        let mut integrator = options.build(scene_max_depth);
        integrator.prepare(ctx);
        let defines = Self::defines(
            scene,
            options.info(),
            integrator.as_ref(),
            mode,
            ctx.limits.max_workgroup_tiles,
        );
        let mut out = vec![(options.info().kernel.to_string(), defines.clone())];
        out.extend(integrator.kernels(&defines));
        out
    }

    /// What building this session's kernels took.
    pub fn kernel_build(&self) -> KernelStats {
        self.kernel_build
    }

    /// Cuts passes into dispatches of this shape instead of the automatic one (tests).
    pub fn set_dispatch_shape(&mut self, shape: Option<DispatchShape>) {
        self.shape = shape;
    }

    /// The shape of a pass of `spp` samples.
    fn shape_for(&self, spp: u32) -> DispatchShape {
        if !self.integrator.shapes_dispatch() {
            // Its kernels declare their own workgroups (deferred): WG_TILES does not apply.
            return DispatchShape::single(self.height);
        }
        let limited = |mut s: DispatchShape| {
            // A shape given by hand still respects the integrator's own limits.
            let max_rows =
                self.integrator.max_band_pixels(self.width, self.height) / self.width as u64;
            s.lanes = s.lanes.min(self.integrator.max_lanes().max(1));
            if (s.band_rows as u64) > max_rows {
                s.band_rows = ((max_rows as u32) / 8 * 8).max(8);
            }
            s.tiles = self.workgroup_tiles;
            s
        };
        // Benchmark knob: CANDELA_MAX_LANES caps the lanes (bench/gpu_first100ms.sh sweeps it).
        let max_lanes = std::env::var("CANDELA_MAX_LANES")
            .ok()
            .and_then(|v| v.parse::<u32>().ok())
            .map_or(self.integrator.max_lanes(), |m| {
                m.min(self.integrator.max_lanes())
            });
        limited(self.shape.unwrap_or_else(|| {
            DispatchShape::auto(
                self.width,
                self.height,
                spp,
                self.ctx.info.kind == "cpu",
                max_lanes,
                self.integrator.max_band_pixels(self.width, self.height),
            )
        }))
    }

    /// Sets `GpuPush::flags` (testing aids such as `PUSH_FLAG_INJECT_NAN`).
    pub fn set_debug_flags(&mut self, flags: u32) {
        self.flags = flags;
    }

    /// Starts over with another seed, keeping the uploaded scene and the compiled pipeline: the
    /// accumulation, extra buffers and counters are cleared. Much cheaper than a new session
    /// (benchmarks run many short renders of one scene).
    pub fn reset(&mut self, seed: u64) -> Result<(), RenderError> {
        self.drain()?;
        self.ctx.fill_zero(&self.accum)?;
        self.ctx.fill_zero(&self.accum_odd)?;
        self.ctx.fill_zero(&self.stats_buf)?;
        for (_, b) in &self.extra {
            self.ctx.fill_zero(b)?;
        }
        self.seed = seed;
        self.spp = 0;
        self.next_sample = 0;
        self.first_pass = None;
        self.passes = 0;
        self.rays = 0;
        self.dropped = 0;
        self.elapsed = Duration::ZERO;
        self.gpu_time = Duration::ZERO;
        self.estimates.reset_counts();
        self.integrator.reset_timings();
        Ok(())
    }

    /// Starts the next pass at sample index `first` instead of right after the samples
    /// submitted so far. A render split over devices (shards.rs) gives each session disjoint
    /// ranges of sample indices this way; since samples are keyed by index, the sessions' sums
    /// add up to the accumulation of one session that rendered every index.
    pub fn set_next_sample(&mut self, first: u32) {
        self.next_sample = first;
    }

    /// Samples per pixel rendered so far.
    pub fn spp(&self) -> u32 {
        self.spp
    }

    /// Wall time spent in passes.
    pub fn elapsed(&self) -> Duration {
        self.elapsed
    }

    /// Samples per pixel queued, completed or not.
    pub fn submitted_spp(&self) -> u32 {
        self.spp + self.ring.spp()
    }

    /// Passes queued and not yet handed back by [`Self::complete_oldest`].
    pub fn in_flight(&self) -> usize {
        self.ring.in_flight.len() + self.completed.len()
    }

    /// Renders `spp` more samples per pixel and waits for them (after any queued passes).
    pub fn run_pass(&mut self, spp: u32) -> Result<PassStats, RenderError> {
        self.drain()?;
        self.submit_pass(spp, false)?;
        let done = self.drain()?;
        done.last()
            .map(|p| p.stats)
            .ok_or_else(|| RenderError::Invalid("the pass did not complete".into()))
    }

    /// Queues a pass of `spp` more samples per pixel without waiting for it, after waiting for
    /// the oldest queued pass when [`PIPELINE_DEPTH`] are queued already (those completed
    /// passes are returned). With `snapshot`, the pass also copies the accumulation for the
    /// image after it ([`CompletedPass::snapshot`]).
    pub fn submit_pass(
        &mut self,
        spp: u32,
        snapshot: bool,
    ) -> Result<Vec<CompletedPass>, RenderError> {
        self.submit_pass_with(spp, snapshot, false)
    }

    /// [`Self::submit_pass`]; with `estimate`, the pass also computes the error estimate of
    /// the accumulation after it on the GPU ([`CompletedPass::estimate`], estimate_gpu.rs).
    pub fn submit_pass_with(
        &mut self,
        spp: u32,
        snapshot: bool,
        estimate: bool,
    ) -> Result<Vec<CompletedPass>, RenderError> {
        if spp == 0 {
            return Err(RenderError::Invalid(
                "a pass needs at least one sample".into(),
            ));
        }
        let mut waited = false;
        while self.ring.in_flight.len() >= PIPELINE_DEPTH {
            let p = self.wait_oldest()?;
            self.completed.extend(p);
            waited = true;
        }
        // Passes the session waited for earlier come back first, in order.
        let done: Vec<CompletedPass> = if waited {
            self.completed.drain(..).collect()
        } else {
            Vec::new()
        };
        let push = GpuPush {
            seed_lo: self.seed as u32,
            seed_hi: (self.seed >> 32) as u32,
            sample_base: self.next_sample,
            spp,
            flags: self.flags,
            ..Default::default()
        };
        let dispatches =
            self.shape_for(spp)
                .dispatches(&push, self.split_limit, self.width, self.height);
        let target = if snapshot {
            // The odd half holds something once a sample of odd index is in: with two samples,
            // or with one whose index (this pass's first) is odd.
            let total = self.submitted_spp() + spp;
            let has_odd = total >= 2 || self.next_sample % 2 == 1;
            Some(snapshot_target(
                &self.ctx,
                self.width,
                self.height,
                self.extra_buffers(),
                total,
                has_odd,
                self.integrator.resolver(),
            )?)
        } else {
            None
        };
        let estimate_target = match estimate {
            true => {
                let film = Film {
                    resolve: self.integrator.gpu_resolve(),
                    width: self.width,
                    height: self.height,
                    accum: &self.accum,
                    accum_odd: &self.accum_odd,
                    extra: &self.extra,
                };
                let spp = self.submitted_spp() + spp;
                Some(self.estimates.prepare(&self.ctx, film, spp)?)
            }
            false => None,
        };
        let mut slot = self.ring.take(&self.ctx)?;
        let (integrator, pipeline) = (&self.integrator, &self.pipeline);
        let most: u32 = dispatches
            .iter()
            .map(|(c, _)| integrator.dispatches_per_pass(c.spp))
            .sum::<u32>()
            + 2 * estimate as u32;
        let estimates = &self.estimates;
        let (stats_buf, accum, extra) = (&self.stats_buf, &self.accum, &self.extra);
        let accum_odd = &self.accum_odd;
        let counters = &slot.counters;
        let recorded = slot.frame.submit(most, |rec| {
            for (push, groups) in &dispatches {
                integrator.record_pass(rec, pipeline, *push, *groups)?;
            }
            // The pass's counters to the host, cleared for the next pass.
            rec.copy(stats_buf, 0, counters, 0, stats_buf.size.min(counters.size));
            rec.fill_zero(stats_buf);
            if let Some(t) = &target {
                let mut at = 0;
                let odd = std::iter::once(accum_odd).filter(|_| t.has_odd());
                for b in std::iter::once(accum)
                    .chain(extra.iter().map(|(_, b)| b))
                    .chain(odd)
                {
                    rec.copy(b, 0, t.buffer(), at, b.size);
                    at += b.size;
                }
            }
            if let Some(t) = &estimate_target {
                estimates.record(rec, t)?;
            }
            Ok(())
        });
        if let Err(e) = recorded {
            self.ring.spare.push(slot);
            return Err(e.into());
        }
        self.next_sample = self.next_sample.wrapping_add(spp);
        self.ring.in_flight.push_back(InFlight {
            slot,
            spp,
            submitted: Instant::now(),
            snapshot: target,
            estimate: estimate_target,
        });
        Ok(done)
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

    /// The integrator's extra per-pixel buffers, in [`Self::accumulation`] order.
    pub fn extra_buffers(&self) -> Vec<ExtraBuffer> {
        self.extra.iter().map(|(e, _)| *e).collect()
    }

    /// Entries (`[f32; 4]`) in [`Self::accumulation`]: width·height, plus the integrator's extra
    /// buffers (bdpt: one or two per pixel), plus width·height of the odd half.
    pub fn accumulation_len(&self) -> usize {
        let n = (self.width * self.height) as usize;
        2 * n
            + self
                .extra
                .iter()
                .map(|(e, _)| n * e.entries_per_pixel as usize)
                .sum::<usize>()
    }

    /// The raw accumulation buffer: per pixel (Σr, Σg, Σb, samples kept), row 0 at the top,
    /// followed by the raw words of the integrator's extra buffers (bdpt: the light-tracing
    /// splats), then the odd half (the odd-indexed samples' share of the accumulation),
    /// [`Self::accumulation_len`] entries in all. Restore it as a whole.
    pub fn accumulation(&mut self) -> Result<Vec<[f32; 4]>, RenderError> {
        self.settle()?;
        // Each buffer straight into its place in one vector.
        let n = (self.width * self.height) as usize;
        let mut out = vec![[0f32; 4]; self.accumulation_len()];
        let (first, rest) = out.split_at_mut(n);
        self.ctx.download_into(&self.accum, first)?;
        let mut rest = rest;
        for (e, b) in &self.extra {
            let (part, tail) = rest.split_at_mut(n * e.entries_per_pixel as usize);
            self.ctx.download_into(b, part)?;
            rest = tail;
        }
        self.ctx.download_into(&self.accum_odd, rest)?;
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
        self.drain()?;
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
        self.ctx.upload(
            &self.accum_odd,
            0,
            bytemuck::cast_slice(&accumulation[at..]),
        )?;
        self.spp = progress.spp;
        self.next_sample = progress.spp;
        self.passes = progress.passes;
        self.rays = progress.rays;
        self.dropped = progress.dropped_samples;
        self.elapsed = Duration::from_secs_f64(progress.time_s.max(0.0));
        self.gpu_time = Duration::from_secs_f64(progress.gpu_time_s.max(0.0));
        self.integrator.reset_timings();
        Ok(())
    }

    /// The current estimate (after every queued pass): accumulated radiance divided by the
    /// samples kept per pixel, as the integrator resolves it (bdpt adds its light-tracing
    /// splats).
    pub fn image(&mut self) -> Result<Image, RenderError> {
        let all = self.accumulation()?;
        Ok(self.resolve(&all))
    }

    /// The estimate of the current image's relMSE against the converged image, from its even
    /// and odd halves (after every queued pass; [`crate::metrics::rel_mse_estimate`]); None
    /// before both halves have samples.
    pub fn rel_mse_estimate(&mut self) -> Result<Option<f64>, RenderError> {
        Ok(self.image_and_estimate()?.1)
    }

    /// [`Self::image`] and [`Self::rel_mse_estimate`] from one download.
    pub fn image_and_estimate(&mut self) -> Result<(Image, Option<f64>), RenderError> {
        let all = self.accumulation()?;
        let image = self.resolve(&all);
        let estimate = self.estimate_spp(&all, self.spp, &image);
        Ok((image, estimate))
    }

    /// The estimated relMSE of `image`, the resolved `all` (an accumulation of this session's
    /// layout holding `spp` samples per pixel, e.g. merged shards), from its halves (halves.rs).
    pub fn estimate_spp(&self, all: &[[f32; 4]], spp: u32, image: &Image) -> Option<f64> {
        let n = (self.width * self.height) as usize;
        let extra = self.extra_buffers();
        super::halves::estimate(all, n, &extra, &self.integrator.resolver(), spp, image)
    }

    /// The image of `all`, an [`Self::accumulation`] of this session (at its current spp).
    pub fn resolve(&self, all: &[[f32; 4]]) -> Image {
        self.resolve_spp(all, self.spp)
    }

    /// The image of `all`, an accumulation of this session's layout holding `spp` samples per
    /// pixel (e.g. the merged sums of several shards, shards.rs).
    pub fn resolve_spp(&self, all: &[[f32; 4]], spp: u32) -> Image {
        let n = (self.width * self.height) as usize;
        let mut parts = vec![&all[..n.min(all.len())]];
        let mut at = n;
        for (e, _) in &self.extra {
            let len = n * e.entries_per_pixel as usize;
            parts.push(all.get(at..at + len).unwrap_or(&[]));
            at += len;
        }
        let pixels = (self.integrator.resolver())(parts[0], &parts[1..], spp);
        Image {
            width: self.width,
            height: self.height,
            pixels,
        }
    }
}

impl Drop for RenderSession {
    fn drop(&mut self) {
        // Queued passes use the session's buffers: let them finish before the buffers go.
        for p in &mut self.ring.in_flight {
            let _ = p.slot.frame.wait();
        }
    }
}

/// The measuring knob `CANDELA_SHADER_DEFINES="NAME[=VALUE] ..."` (whitespace-separated; VALUE
/// defaults to 1): defines added to every kernel of a session, replacing any the session sets
/// under the same name (a define cannot be removed), and part of the kernel cache's key, so that
/// one binary can time shader variants side by side (bench/RESULTS.md). Not for production use.
fn parse_defines(v: &str) -> ShaderDefines {
    v.split_whitespace()
        .map(|d| match d.split_once('=') {
            Some((k, v)) => (k.to_string(), v.to_string()),
            None => (d.to_string(), "1".to_string()),
        })
        .collect()
}

#[cfg(test)]
mod knob_tests {
    use super::parse_defines;

    #[test]
    fn shader_defines_knob_parses_names_and_values() {
        let d = |n: &str, v: &str| (n.to_string(), v.to_string());
        assert!(parse_defines("").is_empty());
        assert!(parse_defines("   ").is_empty());
        assert_eq!(parse_defines("A"), vec![d("A", "1")]);
        assert_eq!(parse_defines("A="), vec![d("A", "")]);
        assert_eq!(parse_defines("A=B=C"), vec![d("A", "B=C")]);
        assert_eq!(parse_defines("  X=8\tY  "), vec![d("X", "8"), d("Y", "1")]);
    }
}
