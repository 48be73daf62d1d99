//! `bdpt`: bidirectional path tracing (Veach 1997, ch. 10), with pbrt-v3's `BDPTIntegrator` as
//! the model: a camera subpath and a light subpath per sample, every connection strategy (s, t)
//! allowed by max_depth (Mitsuba's meaning: paths of at most max_depth segments), multiple
//! importance sampling with the power heuristic, light tracing (t = 1) splatted into the film.
//! Kernels: shaders/bdpt/bdpt.comp and light.comp (vertex.glsl, paths.glsl, subpath.glsl,
//! connect.glsl, strategies.glsl, splat.glsl, store.glsl).
//!
//! # GPU designs (option `design`): the same estimator, two layouts
//! - **per_pixel**: each thread owns one pixel and, per sample, traces one camera subpath (at
//!   most max_depth + 1 vertices) and one light subpath (at most max_depth) into one private
//!   array, then evaluates every (s, t) connection: one dispatch per pass. It is pbrt's
//!   estimator strategy by strategy, which the tests check one by one: the reference.
//! - **split** (default): per sample and band of rows, a light pass (light.comp) traces every
//!   pixel's light subpath, splats its light tracing (t = 1) and writes its vertices to a buffer
//!   (store.glsl, [`LIGHT_VERTEX_BYTES`] per vertex); then a camera pass (bdpt.comp with
//!   BDPT_SPLIT) traces the pixel's camera subpath and joins it to the vertices of the same
//!   pixel's light subpath (t ≥ 2). Same subpaths (the same random numbers: each subpath and
//!   each strategy has its own dimensions), same strategies and weights, so the same image up to
//!   the order of floating-point operations; but each kernel holds one subpath instead of two in
//!   its private array, and light walks no longer run in lock-step with camera walks. Why not
//!   Davidovič et al. 2014's light-vertex *cache* (each camera vertex joined to a few random
//!   cached vertices): it changes the estimator; this keeps pbrt's and still separates the
//!   walks. The buffer holds a band of at most [`LIGHT_BUFFER_BYTES`] (less on a device with
//!   under 32 GB); a pass is two dispatches per sample and band (and, with float
//!   splats, their merge). On an H100 (Cornell box,
//!   1280×720, max_depth 6) it renders about 1.3× the per-pixel design's samples per second
//!   (bench/RESULTS.md).
//!
//! # Shared light subpaths (option `light_share`, split design)
//! With `light_share` K > 1 the light pass traces one light subpath per block of K neighbouring
//! pixels of a row (the blocks shifted by the sample index mod K, so their edges move from
//! sample to sample), and each pixel of the block joins its camera subpath to that one light
//! subpath: the light pass costs about 1/K, the camera pass the same. Per camera sample there
//! are then 1/K light subpaths, which the estimator counts (as a light-vertex cache does,
//! Davidovič et al. 2014): a light subpath's light-tracing splats count for its block's pixels
//! (K, fewer at a row's ends), and light tracing's density enters the MIS weights 1/K times
//! (shaders/bdpt/connect.glsl), so the image converges to the same one. Light tracing gets 1/K
//! of its samples, so its paths (caustics seen through a diffuse bounce, small lights) turn
//! noisier. Measured on an H200 at 1280×720 (bench/RESULTS.md): K = 4 renders 1.28–1.71× the
//! samples per second, and the error at equal time is lower on mirror_glass (−17% relMSE at 1
//! s), higher on the Cornell box (+21%), shade (+11%) and lights (+4%); so the default stays 1.
//!
//! Per-thread state is bounded by the array's capacity, compiled in as `BDPT_DEPTH_CAP`:
//! [`SMALL_DEPTH_CAP`] segments for max_depth up to that (one kernel for the usual depths), else
//! [`DEPTH_CAP`]. max_depth −1 and larger values are capped at [`DEPTH_CAP`] segments, so an
//! "unbounded" render does not sample longer paths; with Russian roulette from rr_depth they
//! carry little energy, but a closed white furnace would lose some.
//!
//! # The film
//! Strategies with t ≥ 2 belong to the thread's pixel and accumulate in ACCUM like pt/nee's
//! samples: bit-identical whatever the pass split. Light tracing lands on arbitrary pixels and is
//! added atomically to a splat buffer (binding SPLAT): with float atomics where the device has
//! `shaderBufferFloat32AtomicAdd` (the order of float additions varies between runs, so that
//! part of the image is reproducible only to rounding), else — or with the debug option
//! `fixed_point_splats` — as 64-bit fixed point from 32-bit integer atomics, which is exact and
//! order-independent. The image is accum.rgb / accum.w + splat / (pixels · spp): one light path
//! is traced per pixel and sample (or one per K pixels, each counting K times: `light_share`).
//! A splat covers every pixel whose filter reaches it (a Gaussian's radius is 4σ: 16–25 pixels
//! at Mitsuba's σ = 0.5), but pixels of filter weight below 0.05 (`SPLAT_RR_WEIGHT`,
//! shaders/bdpt/splat.glsl) are Russian-rouletted: 0.05's share with probability w / 0.05, so
//! each pixel's expectation is unchanged while most of the faint rim's atomics go. On the
//! Cornell box (H200, 1280×720) that rendered 4.8% more samples per second at 4.2% lower relMSE
//! at equal time (bench/RESULTS.md, "bdpt's splats"). Splats of odd sample index are also
//! added to a second buffer (binding SPLAT_ODD, same format), so that both halves of the error
//! estimate carry their own light tracing (render/halves.rs). Checkpoints carry both splat
//! buffers after the accumulation.
//!
//! # Options
//! `{"type": "bdpt", "max_depth", "rr_depth", "mis": true|false, "strategy": [s, t],
//! "weighted": true|false, "fixed_point_splats": true|false, "design": "split"|"per_pixel",
//! "light_share": 1|2|4|8}`. `mis: false` gives every strategy
//! that could make a path the same weight. `strategy` renders one technique alone (the Veach
//! pyramid), multiplied by its MIS weight unless `weighted` is false; unweighted, each technique
//! of a path length is an unbiased estimate of that length's image wherever it can sample every
//! path (no delta lights or specular connections).
//!
//! # Report
//! `details`: `{"design", "light_share", "timings_ms": {"light_passes", "camera_passes", "other"}}`, the GPU
//! time of the split design's two kernels summed over the session's passes since its start,
//! `reset()` or `restore()` (per_pixel: its kernel in `camera_passes`); the float splats' merge
//! counts with the light passes; `other` is any dispatch of the pass not named here (0 today).
//! The three add up to those passes' GPU time less the error estimate's (after a restore the
//! session's `gpu_time_s` also holds the checkpoint's).

use std::sync::Arc;

use super::{
    BdptDesign, BdptOptions, ExtraBuffer, ExtraSum, GpuResolve, Integrator, Resolver, ScratchBuffer,
};
use crate::compile::{CompiledScene, SceneConstants};
use crate::error::RenderError;
use crate::gpu::{
    Binding, ComputePipeline, Constant, DispatchTiming, GpuContext, GpuResult, Recorder,
    ShaderDefines,
};
use crate::layout::{
    binding, GpuPush, PUSH_FLAG_BDPT_NO_MIS, PUSH_FLAG_BDPT_SHARE_SHIFT, PUSH_FLAG_BDPT_STRATEGY,
    PUSH_FLAG_BDPT_S_SHIFT, PUSH_FLAG_BDPT_T_SHIFT, PUSH_FLAG_BDPT_UNWEIGHTED,
};

/// Most segments a bdpt path may have: the private vertex arrays hold 2·DEPTH_CAP + 1 vertices
/// (5.9 KB per thread). NVIDIA's driver (580, H200) fails to create the pipeline at 32.
pub const DEPTH_CAP: i32 = 24;
/// The capacity for max_depth 0..=SMALL_DEPTH_CAP (17 vertices, 1.9 KB per thread).
pub const SMALL_DEPTH_CAP: i32 = 8;

/// Bytes per light vertex in the split design's buffer (7 vec4, shaders/bdpt/store.glsl).
pub const LIGHT_VERTEX_BYTES: u64 = 7 * 16;
/// Most bytes of the split design's light-vertex buffer (one band of pixels, one sample): a
/// 1280×720 film in one band at the usual depths (826 MB). Bands of 192 MB (five at 1280×720)
/// rendered 5–8% fewer samples per second on an H100 than 400 MB–1 GB (bench/RESULTS.md): every
/// band's two dispatches end in a barrier, where the GPU drains.
pub const LIGHT_BUFFER_BYTES: u64 = 1 << 30;
/// The share of the device's memory the light-vertex buffer may take (1/32: 256 MB on an 8 GB
/// GPU), within [`LIGHT_BUFFER_BYTES`] and the device's largest buffer.
const LIGHT_BUFFER_SHARE: u64 = 32;

/// The split design's light-pass and camera-pass dispatches, and the per-pixel design's one
/// kernel (their GPU times are reported apart).
const LIGHT_PASS_LABEL: &str = "bdpt light pass";
const CAMERA_PASS_LABEL: &str = "bdpt camera pass";
const PASS_LABEL: &str = "bdpt pass";
/// The float splats' end-of-pass merge (reported with the light passes: it is light tracing's).
const SPLAT_MERGE_LABEL: &str = "bdpt splat merge";
/// The merge kernel (shaders/bdpt/splat_merge.comp) and its most workgroups (of 256 threads, in
/// a grid-stride loop over the film: enough to fill a large GPU).
const SPLAT_MERGE_KERNEL: &str = "bdpt/splat_merge.comp";
const SPLAT_MERGE_GROUPS: u32 = 1024;

/// The values of the option `light_share` (pixels sharing one light subpath per sample, split
/// design), and its default.
pub const LIGHT_SHARES: [u32; 4] = [1, 2, 4, 8];
pub const DEFAULT_LIGHT_SHARE: u32 = 1;

/// Fractional bits of the fixed-point splats (mirrors SPLAT_FRAC_BITS in shaders/bdpt/splat.glsl).
const SPLAT_FRAC_BITS: i32 = 20;

pub struct BdptIntegrator {
    max_depth: i32,
    rr_depth: i32,
    mis: bool,
    strategy: Option<[u32; 2]>,
    weighted: bool,
    force_fixed_point: bool,
    design: BdptDesign,
    /// Pixels sharing one light subpath per sample (1 in the per-pixel design).
    light_share: u32,
    /// Decided in `prepare` from the device.
    float_splats: bool,
    /// Split design: the light pass (made in `setup`).
    light_pass: Option<ComputePipeline>,
    /// Tiles of 8 × 8 threads per workgroup its kernels were built with (`WG_TILES`, read in
    /// `setup`; render/dispatch.rs): the light pass sizes its workgroups with it.
    workgroup_tiles: u32,
    /// Bytes the light-vertex buffer may take on this device (set in `prepare`).
    light_buffer_bytes: u64,
    /// Float splats: the end-of-pass merge of the odd samples' splats (made in `setup`).
    splat_merge: Option<ComputePipeline>,
    /// GPU milliseconds of the passes observed since the session's start, reset or restore: (light
    /// passes, camera or per-pixel passes, any other dispatch), reported in `details`.
    pass_ms: (f64, f64, f64),
}

pub fn new(o: &BdptOptions, scene_max_depth: Option<i32>) -> BdptIntegrator {
    BdptIntegrator {
        max_depth: o.max_depth.or(scene_max_depth).unwrap_or(6),
        rr_depth: o.rr_depth.unwrap_or(5),
        mis: o.mis.unwrap_or(true),
        strategy: o.strategy,
        weighted: o.weighted.unwrap_or(true),
        force_fixed_point: o.fixed_point_splats.unwrap_or(false),
        design: o.design.unwrap_or_default(),
        light_share: match o.design.unwrap_or_default() {
            BdptDesign::Split => o.light_share.unwrap_or(DEFAULT_LIGHT_SHARE),
            BdptDesign::PerPixel => 1,
        },
        float_splats: false,
        light_pass: None,
        workgroup_tiles: 1,
        light_buffer_bytes: LIGHT_BUFFER_BYTES / LIGHT_BUFFER_SHARE,
        splat_merge: None,
        pass_ms: (0.0, 0.0, 0.0),
    }
}

impl BdptIntegrator {
    /// The vertex-array capacity the kernel is compiled for, in segments: [`SMALL_DEPTH_CAP`]
    /// for the usual depths, so that they all share one kernel (compiling one takes seconds on
    /// lavapipe), else [`DEPTH_CAP`].
    fn depth_cap(&self) -> i32 {
        if (0..=SMALL_DEPTH_CAP).contains(&self.max_depth) {
            SMALL_DEPTH_CAP
        } else {
            DEPTH_CAP
        }
    }

    /// Light vertices one path may hold in the buffer (the light array's capacity).
    fn light_capacity(&self) -> u64 {
        self.depth_cap().max(2) as u64
    }

    /// The options that travel in `GpuPush::flags`.
    fn flags(&self) -> u32 {
        let mut f = 0;
        if !self.mis {
            f |= PUSH_FLAG_BDPT_NO_MIS;
        }
        if let Some([s, t]) = self.strategy {
            f |= PUSH_FLAG_BDPT_STRATEGY
                | (s.min(255) << PUSH_FLAG_BDPT_S_SHIFT)
                | (t.min(255) << PUSH_FLAG_BDPT_T_SHIFT);
            if !self.weighted {
                f |= PUSH_FLAG_BDPT_UNWEIGHTED;
            }
        }
        f | (self.light_share.trailing_zeros() << PUSH_FLAG_BDPT_SHARE_SHIFT)
    }
}

impl BdptIntegrator {
    /// Light subpaths per row of a band in the split design: one per pixel, or with
    /// `light_share` K > 1 one per block of K pixels, the blocks shifted by the sample index
    /// mod K (so their edges move from sample to sample): ⌊(width − 1 + K − 1) / K⌋ + 1 blocks
    /// cover a row whatever the shift (shaders/bdpt/store.glsl, `lv_cols`).
    fn light_cols(&self, width: u32) -> u64 {
        let (w, k) = (width as u64, self.light_share as u64);
        if k == 1 {
            w
        } else {
            (w.max(1) + k - 2) / k + 1
        }
    }

    /// Rows per band of the split design: what the light-vertex buffer holds, at least 8 rows,
    /// at most the film.
    fn band_rows(&self, width: u32, height: u32) -> u64 {
        let per_path = self.light_capacity() * LIGHT_VERTEX_BYTES;
        (self.light_buffer_bytes / per_path / self.light_cols(width))
            .max(8)
            .min(height as u64)
    }

    /// Light subpaths per band (the light-vertex buffer's capacity in paths).
    fn band_paths(&self, width: u32, height: u32) -> u64 {
        self.band_rows(width, height) * self.light_cols(width)
    }

    /// The light pass's defines: the session's, without the camera pass's BDPT_SPLIT.
    fn light_defines(&self, defines: &ShaderDefines) -> ShaderDefines {
        defines
            .iter()
            .filter(|(k, _)| k != "BDPT_SPLIT")
            .cloned()
            .collect()
    }
}

impl Integrator for BdptIntegrator {
    fn max_depth(&self) -> i32 {
        self.max_depth
    }
    fn record_pass(
        &self,
        rec: &mut Recorder<'_>,
        pipeline: &ComputePipeline,
        mut push: GpuPush,
        groups: [u32; 3],
    ) -> GpuResult<()> {
        push.max_depth = self.max_depth;
        push.rr_depth = self.rr_depth;
        push.flags |= self.flags();
        match &self.light_pass {
            None => rec.dispatch(pipeline, bytemuck::bytes_of(&push), groups, PASS_LABEL)?,
            Some(light) => {
                // Split: per sample, the band's light subpaths, then its camera subpaths.
                // The light pass covers the band's light subpaths: `light_cols` per row (the
                // groups' columns, `workgroup_tiles` tiles of 8 each, cover at least the film's
                // width).
                let tile = 8 * self.workgroup_tiles;
                let cols = self.light_cols(groups[0] * tile) as u32;
                let light_groups = [cols.div_ceil(tile), groups[1], groups[2]];
                let (base, spp) = (push.sample_base, push.spp);
                for i in 0..spp {
                    push.sample_base = base + i;
                    push.spp = 1;
                    rec.dispatch(
                        light,
                        bytemuck::bytes_of(&push),
                        light_groups,
                        LIGHT_PASS_LABEL,
                    )?;
                    rec.dispatch(
                        pipeline,
                        bytemuck::bytes_of(&push),
                        groups,
                        CAMERA_PASS_LABEL,
                    )?;
                }
            }
        }
        if let Some(merge) = &self.splat_merge {
            // About one thread per pixel of the band (8×8 per workgroup there, 256 here), at most
            // SPLAT_MERGE_GROUPS workgroups; the merge's loop covers the whole film either way.
            let threads: u64 = groups.iter().map(|&g| g as u64).product::<u64>() * 64;
            let merge_groups = threads.div_ceil(256).clamp(1, SPLAT_MERGE_GROUPS as u64) as u32;
            rec.dispatch(
                merge,
                bytemuck::bytes_of(&push),
                [merge_groups, 1, 1],
                SPLAT_MERGE_LABEL,
            )?;
        }
        Ok(())
    }
    fn dispatches_per_pass(&self, spp: u32) -> u32 {
        let passes = match self.design {
            BdptDesign::Split => 2 * spp,
            BdptDesign::PerPixel => 1,
        };
        passes + u32::from(self.float_splats)
    }
    fn max_lanes(&self) -> u32 {
        match self.design {
            // One sample's light subpaths per light pass.
            BdptDesign::Split => 1,
            BdptDesign::PerPixel => crate::layout::MAX_LANES,
        }
    }
    fn max_band_pixels(&self, width: u32, height: u32) -> u64 {
        match self.design {
            BdptDesign::Split => self.band_rows(width, height) * width as u64,
            BdptDesign::PerPixel => u64::MAX,
        }
    }
    fn scratch_buffers(&self, width: u32, height: u32) -> Vec<ScratchBuffer> {
        let mut out = Vec::new();
        if self.float_splats {
            out.push(ScratchBuffer {
                binding: binding::BDPT_SPLAT_NEW,
                name: "bdpt splats of the pass (odd)",
                bytes: width as u64 * height as u64 * 16,
            });
        }
        if self.design != BdptDesign::Split {
            return out;
        }
        let paths = self.band_paths(width, height);
        out.extend([
            ScratchBuffer {
                binding: binding::BDPT_LIGHT_VERTICES,
                name: "bdpt light vertices",
                bytes: paths * self.light_capacity() * LIGHT_VERTEX_BYTES,
            },
            ScratchBuffer {
                binding: binding::BDPT_LIGHT_COUNTS,
                name: "bdpt light vertex counts",
                bytes: paths * 4,
            },
        ]);
        out
    }
    fn kernels(&self, defines: &ShaderDefines) -> Vec<(String, ShaderDefines)> {
        let mut out = Vec::new();
        if self.design == BdptDesign::Split {
            out.push(("bdpt/light.comp".into(), self.light_defines(defines)));
        }
        if self.float_splats {
            // (It reads no scene: one variant for every session.)
            out.push((SPLAT_MERGE_KERNEL.into(), ShaderDefines::new()));
        }
        out
    }
    fn setup(
        &mut self,
        ctx: &Arc<GpuContext>,
        _scene: &CompiledScene,
        shared: &[Binding<'_>],
        defines: &ShaderDefines,
    ) -> Result<(), RenderError> {
        let push = std::mem::size_of::<GpuPush>() as u32;
        self.workgroup_tiles = ctx
            .limits
            .workgroup_tiles_of(defines)
            .map_err(RenderError::Invalid)?;
        if self.design == BdptDesign::Split {
            let d = self.light_defines(defines);
            let spirv = ctx.kernel("bdpt/light.comp", &d)?;
            self.light_pass = Some(ComputePipeline::new(
                ctx,
                "bdpt/light.comp",
                &spirv,
                shared,
                push,
            )?);
        }
        if self.float_splats {
            let spirv = ctx.kernel(SPLAT_MERGE_KERNEL, &ShaderDefines::new())?;
            self.splat_merge = Some(ComputePipeline::new(
                ctx,
                SPLAT_MERGE_KERNEL,
                &spirv,
                shared,
                push,
            )?);
        }
        Ok(())
    }
    fn prepare(&mut self, ctx: &GpuContext) {
        self.float_splats = ctx.float_atomics && !self.force_fixed_point;
        let l = ctx.limits;
        self.light_buffer_bytes = (l.memory_bytes / LIGHT_BUFFER_SHARE)
            .min(l.max_buffer_bytes)
            .min(LIGHT_BUFFER_BYTES);
    }
    fn constants(&self, scene: &SceneConstants) -> ShaderDefines {
        let mut c = scene.all();
        c.push(Constant::Int(self.max_depth).define("PASS_MAX_DEPTH"));
        c.push(Constant::Int(self.rr_depth).define("PASS_RR_DEPTH"));
        c
    }
    fn defines(&self) -> ShaderDefines {
        let mut d: ShaderDefines = vec![("BDPT_DEPTH_CAP".into(), self.depth_cap().to_string())];
        if self.float_splats {
            d.push(("BDPT_FLOAT_SPLATS".into(), "1".into()));
        }
        if self.design == BdptDesign::Split {
            d.push(("BDPT_SPLIT".into(), "1".into()));
        }
        d
    }
    fn observe_timings(&mut self, timings: &[DispatchTiming]) {
        for t in timings {
            match t.label.as_str() {
                LIGHT_PASS_LABEL | SPLAT_MERGE_LABEL => self.pass_ms.0 += t.gpu_ms,
                CAMERA_PASS_LABEL | PASS_LABEL => self.pass_ms.1 += t.gpu_ms,
                _ => self.pass_ms.2 += t.gpu_ms,
            }
        }
    }
    fn reset_timings(&mut self) {
        self.pass_ms = (0.0, 0.0, 0.0);
    }
    fn details(&self) -> Option<serde_json::Value> {
        let design = match self.design {
            BdptDesign::Split => "split",
            BdptDesign::PerPixel => "per_pixel",
        };
        Some(serde_json::json!({
            "design": design,
            "light_share": self.light_share,
            "timings_ms": {
                "light_passes": self.pass_ms.0,
                "camera_passes": self.pass_ms.1,
                "other": self.pass_ms.2,
            },
        }))
    }
    fn extra_buffers(&self) -> Vec<ExtraBuffer> {
        // The splats, then their odd-indexed samples' share (the error estimate's halves).
        let splats = |binding, name, odd_share_of| ExtraBuffer {
            binding,
            name,
            entries_per_pixel: if self.float_splats { 1 } else { 2 },
            sum: if self.float_splats {
                ExtraSum::Float
            } else {
                ExtraSum::Fixed64
            },
            odd_share_of,
        };
        vec![
            splats(binding::SPLAT, "bdpt splats", None),
            splats(binding::SPLAT_ODD, "bdpt splats (odd)", Some(0)),
        ]
    }
    fn gpu_resolve(&self) -> GpuResolve {
        GpuResolve::MeanPlusSplats {
            fixed_point: !self.float_splats,
            frac_bits: SPLAT_FRAC_BITS as u32,
        }
    }
    fn resolver(&self) -> Resolver {
        let float_splats = self.float_splats;
        Arc::new(move |accum, extra, spp| resolve(float_splats, accum, extra, spp))
    }
}

/// The image: accum.rgb / accum.w + splat / (pixels · spp), the splats as floats or as 64-bit
/// fixed point (two words per pixel).
fn resolve(
    float_splats: bool,
    accum: &[[f32; 4]],
    extra: &[&[[f32; 4]]],
    spp: u32,
) -> Vec<[f32; 3]> {
    let n = accum.len();
    let paths = n as f64 * spp as f64;
    let splat = |i: usize, c: usize| -> f64 {
        let Some(buf) = extra.first() else {
            return 0.0;
        };
        if float_splats {
            buf.get(i).map_or(0.0, |e| e[c] as f64)
        } else {
            let (lo, hi) = match (buf.get(2 * i), buf.get(2 * i + 1)) {
                (Some(lo), Some(hi)) => (lo[c].to_bits() as u64, hi[c].to_bits() as u64),
                _ => return 0.0,
            };
            ((hi << 32) | lo) as f64 / (1u64 << SPLAT_FRAC_BITS) as f64
        }
    };
    use rayon::prelude::*;
    accum
        .par_iter()
        .enumerate()
        .map(|(i, a)| {
            let mut px = [0f32; 3];
            for (c, v) in px.iter_mut().enumerate() {
                let camera = if a[3] > 0.0 {
                    a[c] as f64 / a[3] as f64
                } else {
                    0.0
                };
                let light = if paths > 0.0 {
                    splat(i, c) / paths
                } else {
                    0.0
                };
                *v = (camera + light) as f32;
            }
            px
        })
        .collect()
}
