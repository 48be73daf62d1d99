//! Integrators: one module each, all with the same interface: created from typed options
//! (`IntegratorOptions`, a serde enum tagged by `type`, unknown fields rejected), they record
//! one pass of `spp` samples per pixel into the accumulation buffer and name their kernel.
//! Kernels live in `shaders/<name>/`, mirroring these modules.

pub mod bdpt;
pub mod deferred;
mod nee;
mod path;
mod pt;
pub mod vct;
pub mod whitted;

use serde::{Deserialize, Serialize};

use std::sync::Arc;

use crate::compile::layout::GpuPush;
use crate::compile::CompiledScene;
use crate::gpu::{
    Binding, ComputePipeline, DispatchTiming, GpuContext, GpuResult, Recorder, ShaderDefines,
};
use crate::render::RenderError;

/// Options of the path tracers (`pt`, `nee`).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PathOptions {
    /// Mitsuba's max_depth: 1 = emitters seen directly, 2 = + direct light, −1 = unbounded.
    /// Default: the scene's `render.max_depth`, else 6.
    pub max_depth: Option<i32>,
    /// Depth at which Russian roulette starts (default 5, as Mitsuba).
    pub rr_depth: Option<i32>,
}

/// Options of bidirectional path tracing (`bdpt`; see [`bdpt`] for their meaning).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BdptOptions {
    /// Mitsuba's max_depth (paths of at most this many segments; −1 = unbounded, capped at
    /// [`bdpt::DEPTH_CAP`]). Default: the scene's `render.max_depth`, else 6.
    pub max_depth: Option<i32>,
    /// Subpath length (segments) at which Russian roulette starts (default 5).
    pub rr_depth: Option<i32>,
    /// Multiple importance sampling with the power heuristic (default true); false: every
    /// strategy that can make a path gets the same weight.
    pub mis: Option<bool>,
    /// Debug: render strategy [s, t] alone (s light vertices, t camera vertices).
    pub strategy: Option<[u32; 2]>,
    /// Debug, with `strategy`: multiply by the strategy's MIS weight (default true).
    pub weighted: Option<bool>,
    /// Debug: integer fixed-point light-tracing splats even where float atomics exist
    /// (bit-reproducible; the fallback for devices without float atomics).
    pub fixed_point_splats: Option<bool>,
}

/// Which integrator, with its options.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub enum IntegratorOptions {
    /// Path tracing with BSDF sampling only.
    Pt(PathOptions),
    /// Path tracing with next-event estimation and MIS.
    Nee(PathOptions),
    /// Bidirectional path tracing with MIS and light-tracing splats.
    Bdpt(BdptOptions),
    /// Whitted ray tracing: mirror/refraction recursion, shadow rays.
    Whitted(whitted::WhittedOptions),
    /// Deferred many-light shading: packed G-buffer, culled lights.
    Deferred(deferred::DeferredOptions),
    /// Voxel cone tracing over a sparse voxel octree.
    Vct(vct::VctOptions),
}

/// Names accepted on the command line and in `render.integrator`.
pub const NAMES: &[&str] = &["pt", "nee", "bdpt", "deferred", "whitted", "vct"];

impl IntegratorOptions {
    /// Default options for an integrator name; None for unknown or not-yet-built integrators.
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "pt" => Some(IntegratorOptions::Pt(PathOptions::default())),
            "nee" => Some(IntegratorOptions::Nee(PathOptions::default())),
            "bdpt" => Some(IntegratorOptions::Bdpt(BdptOptions::default())),
            "deferred" => Some(IntegratorOptions::Deferred(
                deferred::DeferredOptions::default(),
            )),
            "vct" => Some(IntegratorOptions::Vct(vct::VctOptions::default())),
            "whitted" => Some(IntegratorOptions::Whitted(
                whitted::WhittedOptions::default(),
            )),
            _ => None,
        }
    }

    pub fn name(&self) -> &'static str {
        match self {
            IntegratorOptions::Pt(_) => "pt",
            IntegratorOptions::Nee(_) => "nee",
            IntegratorOptions::Bdpt(_) => "bdpt",
            IntegratorOptions::Whitted(_) => "whitted",
            IntegratorOptions::Deferred(_) => "deferred",
            IntegratorOptions::Vct(_) => "vct",
        }
    }

    /// Overrides max_depth (e.g. from `--max-depth`).
    pub fn set_max_depth(&mut self, d: i32) {
        match self {
            IntegratorOptions::Pt(o) | IntegratorOptions::Nee(o) => o.max_depth = Some(d),
            IntegratorOptions::Bdpt(o) => o.max_depth = Some(d),
            IntegratorOptions::Whitted(o) => o.max_depth = Some(d),
            IntegratorOptions::Deferred(o) => o.max_depth = Some(d),
            IntegratorOptions::Vct(o) => o.max_depth = Some(d),
        }
    }

    pub fn max_depth(&self) -> Option<i32> {
        match self {
            IntegratorOptions::Pt(o) | IntegratorOptions::Nee(o) => o.max_depth,
            IntegratorOptions::Bdpt(o) => o.max_depth,
            IntegratorOptions::Whitted(o) => o.max_depth,
            IntegratorOptions::Deferred(o) => o.max_depth,
            IntegratorOptions::Vct(o) => o.max_depth,
        }
    }

    /// Checks the options' values (ranges, combinations) without a device, naming the field, so
    /// that a server can refuse a job when it is submitted instead of failing it when it starts.
    /// `RenderSession::new` checks them again.
    pub fn validate(&self) -> Result<(), RenderError> {
        match self {
            IntegratorOptions::Whitted(o) => whitted::new(o, None).validate(),
            IntegratorOptions::Deferred(o) => deferred::validate(o),
            IntegratorOptions::Vct(o) => o.settings().map(|_| ()),
            IntegratorOptions::Pt(_) | IntegratorOptions::Nee(_) | IntegratorOptions::Bdpt(_) => {
                Ok(())
            }
        }
    }

    /// Builds the integrator for these options.
    pub fn build(&self, scene_max_depth: Option<i32>) -> Box<dyn Integrator> {
        match self {
            IntegratorOptions::Pt(o) => Box::new(pt::new(o, scene_max_depth)),
            IntegratorOptions::Nee(o) => Box::new(nee::new(o, scene_max_depth)),
            IntegratorOptions::Bdpt(o) => Box::new(bdpt::new(o, scene_max_depth)),
            IntegratorOptions::Whitted(o) => Box::new(whitted::new(o, scene_max_depth)),
            IntegratorOptions::Deferred(o) => Box::new(deferred::new(o, scene_max_depth)),
            IntegratorOptions::Vct(o) => Box::new(vct::new(o, scene_max_depth)),
        }
    }
}

/// A per-pixel storage buffer that an integrator's kernel binds besides ACCUM and STATS (e.g.
/// bdpt's light-tracing splats). The session allocates it zeroed, binds it at `binding`, hands
/// its contents to [`Integrator::resolve`] and carries it in checkpoints.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ExtraBuffer {
    pub binding: u32,
    pub name: &'static str,
    /// Size per pixel in 16-byte entries (checkpoints carry them as `[f32; 4]` words).
    pub entries_per_pixel: u32,
}

/// The plain estimate: accumulated radiance divided by the samples kept per pixel.
pub fn mean_of_accumulation(accum: &[[f32; 4]]) -> Vec<[f32; 3]> {
    accum
        .iter()
        .map(|a| {
            if a[3] > 0.0 {
                [a[0] / a[3], a[1] / a[3], a[2] / a[3]]
            } else {
                [0.0; 3]
            }
        })
        .collect()
}

/// The common interface.
pub trait Integrator: Send {
    fn name(&self) -> &'static str;
    /// The compute kernel (path relative to shaders/).
    fn kernel(&self) -> &'static str;
    /// The effective max_depth.
    fn max_depth(&self) -> i32;
    /// Records one pass: `spp` samples per pixel starting at sample index `sample_base`.
    fn record_pass(
        &self,
        rec: &mut Recorder<'_>,
        pipeline: &ComputePipeline,
        push: GpuPush,
        groups: [u32; 3],
    ) -> GpuResult<()>;
    /// Adapts to the device before the kernel is built (e.g. bdpt picks float-atomic or
    /// fixed-point splats). Default: nothing.
    fn prepare(&mut self, _ctx: &GpuContext) {}
    /// Kernel defines besides the scene's feature set. Default: none.
    fn defines(&self) -> ShaderDefines {
        Vec::new()
    }
    /// Integrators with stages besides the per-pass kernel (vct's voxel structure, deferred's
    /// G-buffer and light culling) build their own buffers and pipelines here, once, after the
    /// scene is on the device. `shared` holds the session's bindings (scene buffers, ACCUM,
    /// STATS, extra buffers) to bind next to their own; `defines` the scene's feature set plus
    /// [`Integrator::defines`]. Work that depends only on the scene (not on the seed or the
    /// samples) may run here; its timings belong in [`Integrator::details`]. Default: nothing.
    fn setup(
        &mut self,
        _ctx: &Arc<GpuContext>,
        _scene: &CompiledScene,
        _shared: &[Binding<'_>],
        _defines: &ShaderDefines,
    ) -> Result<(), RenderError> {
        Ok(())
    }
    /// Most dispatches `record_pass` records for a pass of `spp` samples (sizes the timestamp
    /// pool). Default: 1.
    fn dispatches_per_pass(&self, _spp: u32) -> u32 {
        1
    }
    /// The GPU timings of the dispatches `record_pass` just recorded (their labels as given),
    /// so that integrators with several stages can report per-stage times in
    /// [`Integrator::details`]. Default: ignored.
    fn observe_timings(&mut self, _timings: &[DispatchTiming]) {}
    /// Integrator-specific statistics reported with the render's (a JSON object: stage
    /// timings, memory, options in effect). Default: none.
    fn details(&self) -> Option<serde_json::Value> {
        None
    }
    /// Per-pixel buffers besides ACCUM and STATS. Default: none.
    fn extra_buffers(&self) -> Vec<ExtraBuffer> {
        Vec::new()
    }
    /// The image from the raw buffers: `accum` per pixel (Σr, Σg, Σb, samples kept), `extra[i]`
    /// the contents of `extra_buffers()[i]`, `spp` the samples per pixel rendered so far.
    /// Default: [`mean_of_accumulation`].
    fn resolve(&self, accum: &[[f32; 4]], _extra: &[Vec<[f32; 4]>], _spp: u32) -> Vec<[f32; 3]> {
        mean_of_accumulation(accum)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn options_parse_and_reject_unknown_fields() {
        let o: IntegratorOptions = serde_json::from_str(r#"{"type":"nee","max_depth":3}"#).unwrap();
        assert_eq!(
            o,
            IntegratorOptions::Nee(PathOptions {
                max_depth: Some(3),
                rr_depth: None
            })
        );
        let e = serde_json::from_str::<IntegratorOptions>(r#"{"type":"pt","max_dpeth":3}"#)
            .unwrap_err();
        assert!(e.to_string().contains("max_dpeth"), "{e}");
        assert!(serde_json::from_str::<IntegratorOptions>(r#"{"type":"xyz"}"#).is_err());
    }

    #[test]
    fn bdpt_options_parse_and_reject_unknown_fields() {
        let o: IntegratorOptions = serde_json::from_str(
            r#"{"type":"bdpt","max_depth":4,"rr_depth":3,"mis":false,"strategy":[2,1],"weighted":false}"#,
        )
        .unwrap();
        assert_eq!(
            o,
            IntegratorOptions::Bdpt(BdptOptions {
                max_depth: Some(4),
                rr_depth: Some(3),
                mis: Some(false),
                strategy: Some([2, 1]),
                weighted: Some(false),
                fixed_point_splats: None,
            })
        );
        assert_eq!(o.name(), "bdpt");
        assert_eq!(
            IntegratorOptions::from_name("bdpt").map(|o| o.name()),
            Some("bdpt")
        );
        let e = serde_json::from_str::<IntegratorOptions>(r#"{"type":"bdpt","mis_off":true}"#)
            .unwrap_err();
        assert!(e.to_string().contains("mis_off"), "{e}");
    }
}
