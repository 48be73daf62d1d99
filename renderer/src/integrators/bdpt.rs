//! `bdpt`: bidirectional path tracing (Veach 1997, ch. 10), with pbrt-v3's `BDPTIntegrator` as
//! the model: a camera subpath and a light subpath per sample, every connection strategy (s, t)
//! allowed by max_depth (Mitsuba's meaning: paths of at most max_depth segments), multiple
//! importance sampling with the power heuristic, light tracing (t = 1) splatted into the film.
//! Kernel: shaders/bdpt/bdpt.comp (vertex.glsl, subpath.glsl, connect.glsl, splat.glsl).
//!
//! # GPU design: per-pixel light subpaths
//! Each thread owns one pixel and, per sample, traces one camera subpath (at most max_depth + 1
//! vertices) and one light subpath (at most max_depth) into a fixed-size private array, then
//! evaluates every (s, t) connection: no recursion, no shared state, one dispatch per pass.
//! Per-thread state is bounded by the array's capacity, compiled in as `BDPT_DEPTH_CAP`:
//! [`SMALL_DEPTH_CAP`] segments for max_depth up to that (one kernel for the usual depths), else
//! [`DEPTH_CAP`]. max_depth −1 and larger values are capped at [`DEPTH_CAP`] segments, so an
//! "unbounded" render does not sample longer paths; with Russian roulette from rr_depth they
//! carry little energy, but a closed white furnace would lose some.
//! Why not a light-vertex cache (Davidovič et al. 2014, faster): it shares one buffer of light
//! vertices between pixels, needs a second dispatch and resamples connections. The per-pixel
//! design is pbrt's estimator strategy by strategy, which the tests check one by one, so it is
//! the reference that a faster design can be checked against.
//!
//! # The film
//! Strategies with t ≥ 2 belong to the thread's pixel and accumulate in ACCUM like pt/nee's
//! samples: bit-identical whatever the pass split. Light tracing lands on arbitrary pixels and is
//! added atomically to a splat buffer (binding SPLAT): with float atomics where the device has
//! `shaderBufferFloat32AtomicAdd` (the order of float additions varies between runs, so that
//! part of the image is reproducible only to rounding), else — or with the debug option
//! `fixed_point_splats` — as 64-bit fixed point from 32-bit integer atomics, which is exact and
//! order-independent. The image is accum.rgb / accum.w + splat / (pixels · spp): one light path
//! is traced per pixel and sample. Checkpoints carry the splat buffer after the accumulation.
//!
//! # Options
//! `{"type": "bdpt", "max_depth", "rr_depth", "mis": true|false, "strategy": [s, t],
//! "weighted": true|false, "fixed_point_splats": true|false}`. `mis: false` gives every strategy
//! that could make a path the same weight. `strategy` renders one technique alone (the Veach
//! pyramid), multiplied by its MIS weight unless `weighted` is false; unweighted, each technique
//! of a path length is an unbiased estimate of that length's image wherever it can sample every
//! path (no delta lights or specular connections).

use std::sync::Arc;

use super::{BdptOptions, ExtraBuffer, Integrator, Resolver};
use crate::gpu::{ComputePipeline, GpuContext, GpuResult, Recorder, ShaderDefines};
use crate::layout::{
    binding, GpuPush, PUSH_FLAG_BDPT_NO_MIS, PUSH_FLAG_BDPT_STRATEGY, PUSH_FLAG_BDPT_S_SHIFT,
    PUSH_FLAG_BDPT_T_SHIFT, PUSH_FLAG_BDPT_UNWEIGHTED,
};

/// Most segments a bdpt path may have: the private vertex arrays hold 2·DEPTH_CAP + 1 vertices
/// (5.9 KB per thread). NVIDIA's driver (580, H200) fails to create the pipeline at 32.
pub const DEPTH_CAP: i32 = 24;
/// The capacity for max_depth 0..=SMALL_DEPTH_CAP (17 vertices, 1.9 KB per thread).
pub const SMALL_DEPTH_CAP: i32 = 8;

/// Fractional bits of the fixed-point splats (mirrors SPLAT_FRAC_BITS in shaders/bdpt/splat.glsl).
const SPLAT_FRAC_BITS: i32 = 20;

pub struct BdptIntegrator {
    max_depth: i32,
    rr_depth: i32,
    mis: bool,
    strategy: Option<[u32; 2]>,
    weighted: bool,
    force_fixed_point: bool,
    /// Decided in `prepare` from the device.
    float_splats: bool,
}

pub fn new(o: &BdptOptions, scene_max_depth: Option<i32>) -> BdptIntegrator {
    BdptIntegrator {
        max_depth: o.max_depth.or(scene_max_depth).unwrap_or(6),
        rr_depth: o.rr_depth.unwrap_or(5),
        mis: o.mis.unwrap_or(true),
        strategy: o.strategy,
        weighted: o.weighted.unwrap_or(true),
        force_fixed_point: o.fixed_point_splats.unwrap_or(false),
        float_splats: false,
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
        f
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
        rec.dispatch(pipeline, bytemuck::bytes_of(&push), groups, "bdpt pass")
    }
    fn prepare(&mut self, ctx: &GpuContext) {
        self.float_splats = ctx.float_atomics && !self.force_fixed_point;
    }
    fn defines(&self) -> ShaderDefines {
        let mut d: ShaderDefines = vec![("BDPT_DEPTH_CAP".into(), self.depth_cap().to_string())];
        if self.float_splats {
            d.push(("BDPT_FLOAT_SPLATS".into(), "1".into()));
        }
        d
    }
    fn extra_buffers(&self) -> Vec<ExtraBuffer> {
        vec![ExtraBuffer {
            binding: binding::SPLAT,
            name: "bdpt splats",
            entries_per_pixel: if self.float_splats { 1 } else { 2 },
        }]
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
    accum
        .iter()
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
