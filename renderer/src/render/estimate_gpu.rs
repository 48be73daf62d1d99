//! The error estimate computed on the GPU, inside a pass's own command buffer: after the pass's
//! dispatches, two small dispatches of shaders/estimate/estimate.comp reduce the accumulation,
//! its odd half and (bdpt) the split splats to one sum and count, which the pass copies to a
//! 16-byte host-visible buffer. A quality target (`until`) reads that instead of copying the
//! film out and computing [`crate::metrics::rel_mse_estimate`] on the CPU.
//!
//! What it replaces (issue 14 deliver 3; docs/error-estimate.md has the figures): after every
//! pass of an until-render, a readback of 2·W·H·16 bytes (accumulation and odd half; bdpt's
//! splats and their odd share add 2·W·H·16 as floats, 4·W·H·16 as fixed point): 29.5 MB at
//! 1280×720; then on the host the image and both halves resolved and the estimate with its 3×3
//! box mean, in f64: 100–160 ms at 1280×720 on the 2-core dev machine (the mean resolver;
//! `metrics::rel_mse_estimate` alone). The GPU version reads the film once (plus the 3×3
//! neighbourhood, from cache) and the host reads 16 bytes, at each check point only.
//!
//! The CPU estimate stays the one definition (metrics/estimate.rs, render/halves.rs); the
//! kernel mirrors it for the resolvers of [`GpuResolve`], and tests/tests/until.rs checks that
//! the two agree on real renders. Terms are formed and summed in f32 (the CPU sums in f64):
//! they agree to about 1e-5 relative.

use std::sync::Arc;
use std::time::Duration;

use super::inflight::PassEstimate;
use super::{EstimateChecks, RenderError};
use crate::gpu::DispatchTiming;
use crate::gpu::{Binding, Buffer, BufferUsage, ComputePipeline, GpuContext, GpuResult, Recorder};
use crate::integrators::{ExtraBuffer, GpuResolve};
use crate::layout::{binding, GpuEstimatePush, GpuEstimateResult};

/// The kernel (relative to shaders/).
pub const ESTIMATE_KERNEL: &str = "estimate/estimate.comp";
/// The labels of its two dispatches (their GPU time is the checks' cost in the report).
pub const ESTIMATE_LABELS: [&str; 2] = ["error estimate (pixels)", "error estimate (sum)"];
/// Pixels per workgroup side (local_size 16×16 in the kernel).
const TILE: u32 = 16;

/// A session's GPU estimator: the pipeline bound to its film buffers, and the partial sums.
pub(super) struct GpuEstimator {
    pipeline: ComputePipeline,
    _partials: Buffer,
    result: Buffer,
    groups: [u32; 2],
    width: u32,
    height: u32,
}

impl GpuEstimator {
    /// The defines of the kernel for an integrator resolving its image as `resolve`.
    pub fn defines(resolve: GpuResolve) -> Vec<(String, String)> {
        match resolve {
            GpuResolve::Mean => Vec::new(),
            GpuResolve::MeanPlusSplats {
                fixed_point,
                frac_bits,
            } => {
                let mut d = vec![("ESTIMATE_SPLATS".to_string(), "1".to_string())];
                if fixed_point {
                    d.push(("ESTIMATE_FIXED_SPLATS".to_string(), "1".to_string()));
                    d.push(("ESTIMATE_FRAC_BITS".to_string(), frac_bits.to_string()));
                }
                d
            }
        }
    }

    /// Builds the estimator of a `width`×`height` film held in `accum` and `accum_odd`, with
    /// the integrator's `extra` buffers (bound at their bindings: bdpt's splats and their odd
    /// share).
    pub fn new(
        ctx: &Arc<GpuContext>,
        resolve: GpuResolve,
        width: u32,
        height: u32,
        accum: &Buffer,
        accum_odd: &Buffer,
        extra: &[(ExtraBuffer, Buffer)],
    ) -> Result<Self, RenderError> {
        let groups = [width.div_ceil(TILE), height.div_ceil(TILE)];
        let partials = Buffer::new(
            ctx,
            "error estimate partials",
            groups[0] as u64 * groups[1] as u64 * 8,
            BufferUsage::Storage,
        )?;
        let result = Buffer::new(
            ctx,
            "error estimate",
            std::mem::size_of::<GpuEstimateResult>() as u64,
            BufferUsage::Storage,
        )?;
        let spirv = ctx.kernel(ESTIMATE_KERNEL, &Self::defines(resolve))?;
        let mut bindings = vec![
            Binding {
                index: binding::ACCUM,
                buffer: accum,
            },
            Binding {
                index: binding::ACCUM_ODD,
                buffer: accum_odd,
            },
            Binding {
                index: binding::ESTIMATE_PARTIALS,
                buffer: &partials,
            },
            Binding {
                index: binding::ESTIMATE_RESULT,
                buffer: &result,
            },
        ];
        if matches!(resolve, GpuResolve::MeanPlusSplats { .. }) {
            for (e, b) in extra {
                if e.binding == binding::SPLAT || e.binding == binding::SPLAT_ODD {
                    bindings.push(Binding {
                        index: e.binding,
                        buffer: b,
                    });
                }
            }
        }
        let pipeline = ComputePipeline::new(
            ctx,
            ESTIMATE_KERNEL,
            &spirv,
            &bindings,
            std::mem::size_of::<GpuEstimatePush>() as u32,
        )?;
        drop(bindings);
        Ok(GpuEstimator {
            pipeline,
            _partials: partials,
            result,
            groups,
            width,
            height,
        })
    }

    /// Records the estimate of the accumulation at `spp` samples per pixel (after the pass's
    /// dispatches) and its copy into `readback` (a [`readback`] buffer).
    pub fn record(&self, rec: &mut Recorder<'_>, spp: u32, readback: &Buffer) -> GpuResult<()> {
        let mut push = GpuEstimatePush {
            width: self.width,
            height: self.height,
            spp,
            stage: 0,
            partials: self.groups[0] * self.groups[1],
            ..Default::default()
        };
        let groups = [self.groups[0], self.groups[1], 1];
        rec.dispatch(
            &self.pipeline,
            bytemuck::bytes_of(&push),
            groups,
            ESTIMATE_LABELS[0],
        )?;
        push.stage = 1;
        rec.dispatch(
            &self.pipeline,
            bytemuck::bytes_of(&push),
            [1, 1, 1],
            ESTIMATE_LABELS[1],
        )?;
        rec.copy(&self.result, 0, readback, 0, self.result.size);
        Ok(())
    }
}

/// A host-visible buffer for one estimate.
fn readback(ctx: &Arc<GpuContext>) -> Result<Buffer, RenderError> {
    Ok(Buffer::new(
        ctx,
        "error estimate readback",
        std::mem::size_of::<GpuEstimateResult>() as u64,
        BufferUsage::Readback,
    )?)
}

/// The estimate a pass copied into `readback` (after its fence): sum / count, None when no
/// pixel had samples in both halves (as [`crate::metrics::rel_mse_estimate`]).
fn read(readback: &Buffer) -> Result<Option<f64>, RenderError> {
    let bytes = readback
        .mapped()
        .ok_or_else(|| RenderError::Invalid("estimate buffer not mapped".into()))?;
    let r: GpuEstimateResult =
        bytemuck::pod_read_unaligned(&bytes[..std::mem::size_of::<GpuEstimateResult>()]);
    Ok((r.count > 0).then(|| f64::from(r.sum) / f64::from(r.count)))
}

/// A session's GPU estimates: the estimator (built by the first pass that asks for one), how
/// many passes computed one, and their GPU time.
#[derive(Default)]
pub(super) struct SessionEstimates {
    estimator: Option<GpuEstimator>,
    checks: u32,
    gpu: Duration,
}

/// A session's film buffers, as the estimator binds them.
pub(super) struct Film<'a> {
    pub resolve: GpuResolve,
    pub width: u32,
    pub height: u32,
    pub accum: &'a Buffer,
    pub accum_odd: &'a Buffer,
    pub extra: &'a [(ExtraBuffer, Buffer)],
}

impl SessionEstimates {
    /// Before a pass that computes the estimate at `spp` samples per pixel: the estimator
    /// (built for `film` the first time) and the readback it copies to.
    pub fn prepare(
        &mut self,
        ctx: &Arc<GpuContext>,
        film: Film<'_>,
        spp: u32,
    ) -> Result<(u32, Buffer), RenderError> {
        if self.estimator.is_none() {
            self.estimator = Some(GpuEstimator::new(
                ctx,
                film.resolve,
                film.width,
                film.height,
                film.accum,
                film.accum_odd,
                film.extra,
            )?);
        }
        Ok((spp, readback(ctx)?))
    }

    /// Records the estimate into a pass ([`Self::prepare`] first; `target` what it returned).
    pub fn record(&self, rec: &mut Recorder<'_>, target: &(u32, Buffer)) -> GpuResult<()> {
        match &self.estimator {
            Some(e) => e.record(rec, target.0, &target.1),
            None => Err(crate::gpu::GpuError::Other("no estimator prepared".into())),
        }
    }

    /// The estimate of a completed pass, counted with its dispatches' GPU time.
    pub fn complete(
        &mut self,
        target: &(u32, Buffer),
        timings: &[DispatchTiming],
    ) -> Result<PassEstimate, RenderError> {
        let rel_mse = read(&target.1)?;
        self.checks += 1;
        let ms: f64 = timings
            .iter()
            .filter(|t| ESTIMATE_LABELS.contains(&t.label.as_str()))
            .map(|t| t.gpu_ms)
            .sum();
        self.gpu += Duration::from_secs_f64(ms * 1e-3);
        Ok(PassEstimate {
            spp: target.0,
            rel_mse,
        })
    }

    /// Forgets the counts (a session reset).
    pub fn reset_counts(&mut self) {
        self.checks = 0;
        self.gpu = Duration::ZERO;
    }

    /// The report's figures (None before any estimate).
    pub fn report(&self) -> Option<EstimateChecks> {
        (self.checks > 0).then_some(EstimateChecks {
            checks: self.checks,
            gpu_ms: self.gpu.as_secs_f64() * 1e3,
            wait_ms: None,
        })
    }
}
