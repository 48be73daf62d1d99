//! Integrators: one module each, all with the same interface: created from typed options
//! (`IntegratorOptions`, a serde enum tagged by `type`, unknown fields rejected), they record
//! one pass of `spp` samples per pixel into the accumulation buffer. The list of integrators,
//! with their kernels and capabilities, is declared once, in `registry`. Kernels live in
//! `shaders/<name>/`, mirroring these modules.

pub mod bdpt;
pub mod deferred;
mod nee;
mod path;
mod pt;
mod registry;
pub mod vct;
pub mod whitted;

pub use registry::{
    info, names, IntegratorInfo, IntegratorOptions, OptionField, OptionsError, OptionsInfo,
    DEFAULT_INTEGRATOR, INTEGRATORS,
};

use serde::{Deserialize, Serialize};

use std::sync::Arc;

use crate::compile::{CompiledScene, SceneConstants};
use crate::error::RenderError;
use crate::gpu::{
    Binding, ComputePipeline, DispatchTiming, GpuContext, GpuResult, Recorder, ShaderDefines,
};
use crate::layout::GpuPush;

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
    /// How the GPU runs it (see [`bdpt`]): "split" (default: light subpaths in one pass, kept in
    /// a buffer, camera subpaths in another) or "per_pixel" (both in one thread, the reference).
    /// The same estimator either way.
    pub design: Option<BdptDesign>,
    /// Split design: how many neighbouring pixels share one light subpath per sample (1, 2, 4
    /// or 8; default [`bdpt::DEFAULT_LIGHT_SHARE`]): the light pass traces one light subpath
    /// per `light_share` pixels, each pixel's camera subpath joins the shared one, and light
    /// tracing's splats and MIS weights count the fewer light subpaths.
    pub light_share: Option<u32>,
}

/// How bdpt's passes are laid out on the GPU ([`bdpt`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BdptDesign {
    /// A light pass writes every pixel's light subpath to a buffer and splats its light
    /// tracing; a camera pass traces the camera subpaths and joins them to those vertices.
    #[default]
    Split,
    /// One thread per pixel traces both subpaths into private arrays and joins them.
    PerPixel,
}

const MAX_DEPTH_HELP: &str =
    "Mitsuba's max_depth: 1 = emitters seen directly, 2 = + direct light, -1 = unbounded (default: the scene's render.max_depth, else 6)";

impl OptionsInfo for PathOptions {
    const FIELDS: &'static [OptionField] = &[
        OptionField {
            name: "max_depth",
            kind: "integer",
            help: MAX_DEPTH_HELP,
        },
        OptionField {
            name: "rr_depth",
            kind: "integer",
            help: "depth at which Russian roulette starts (default 5)",
        },
    ];
    fn max_depth(&self) -> Option<i32> {
        self.max_depth
    }
    fn set_max_depth(&mut self, d: i32) {
        self.max_depth = Some(d);
    }
}

impl OptionsInfo for BdptOptions {
    const FIELDS: &'static [OptionField] = &[
        OptionField {
            name: "max_depth",
            kind: "integer",
            help: MAX_DEPTH_HELP,
        },
        OptionField {
            name: "rr_depth",
            kind: "integer",
            help: "subpath length at which Russian roulette starts (default 5)",
        },
        OptionField {
            name: "mis",
            kind: "boolean",
            help: "multiple importance sampling, power heuristic (default true); false weighs every strategy equally",
        },
        OptionField {
            name: "strategy",
            kind: "[s, t]",
            help: "debug: render strategy (s light vertices, t camera vertices) alone",
        },
        OptionField {
            name: "weighted",
            kind: "boolean",
            help: "debug, with strategy: multiply by its MIS weight (default true)",
        },
        OptionField {
            name: "fixed_point_splats",
            kind: "boolean",
            help: "debug: integer fixed-point light-tracing splats even where float atomics exist (default false)",
        },
        OptionField {
            name: "design",
            kind: "\"split\" | \"per_pixel\"",
            help: "GPU layout: split (default: a light pass and a camera pass) or per_pixel (one thread per pixel traces both subpaths); the same estimator",
        },
        OptionField {
            name: "light_share",
            kind: "1 | 2 | 4 | 8",
            help: "split design: pixels sharing one light subpath per sample (default 1: one per pixel); 2, 4, 8 render more samples per second with noisier light tracing",
        },
    ];
    fn max_depth(&self) -> Option<i32> {
        self.max_depth
    }
    fn set_max_depth(&mut self, d: i32) {
        self.max_depth = Some(d);
    }
    fn validate(&self) -> Result<(), RenderError> {
        match self.light_share {
            Some(k) if !bdpt::LIGHT_SHARES.contains(&k) => Err(RenderError::Invalid(format!(
                "light_share: must be one of {:?}, got {k}",
                bdpt::LIGHT_SHARES
            ))),
            Some(k) if k > 1 && self.design == Some(BdptDesign::PerPixel) => {
                Err(RenderError::Invalid(format!(
                    "light_share: {k} needs the split design (per_pixel traces one light subpath per pixel)"
                )))
            }
            _ => Ok(()),
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
    /// How two such buffers (of shards of one render) add up.
    pub sum: ExtraSum,
    /// Some(i): this buffer holds the odd-indexed samples' share of extra buffer i (same
    /// format), so that both halves of the error estimate carry it (render/halves.rs). An
    /// extra buffer without such a share is left out of both halves.
    pub odd_share_of: Option<usize>,
}

/// The number format of an [`ExtraBuffer`], which says how the buffers of the shards of a
/// render split across devices are summed (render/shards.rs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExtraSum {
    /// Every word is an f32 sum: added as floats.
    Float,
    /// Per pixel two entries, the low and high 32 bits of a 64-bit unsigned fixed-point sum
    /// per channel (entry 2i holds the low words of pixel i, 2i+1 the high words): added as
    /// 64-bit integers, exactly.
    Fixed64,
}

impl ExtraSum {
    /// `a += b` (`sign` 1) or `a -= b` (`sign` −1), entry by entry, in this format.
    pub fn combine(self, a: &mut [[f32; 4]], b: &[[f32; 4]], sign: i8) {
        match self {
            ExtraSum::Float => {
                for (x, y) in a.iter_mut().zip(b) {
                    for c in 0..4 {
                        x[c] += f32::from(sign) * y[c];
                    }
                }
            }
            ExtraSum::Fixed64 => {
                for (pa, pb) in a.chunks_exact_mut(2).zip(b.chunks_exact(2)) {
                    for c in 0..4 {
                        let word = |p: &[[f32; 4]]| {
                            ((p[1][c].to_bits() as u64) << 32) | p[0][c].to_bits() as u64
                        };
                        let r = if sign >= 0 {
                            word(pa).wrapping_add(word(pb))
                        } else {
                            word(pa).wrapping_sub(word(pb))
                        };
                        pa[0][c] = f32::from_bits(r as u32);
                        pa[1][c] = f32::from_bits((r >> 32) as u32);
                    }
                }
            }
        }
    }
}

/// Forms the image from an integrator's raw buffers: `accum` per pixel (Σr, Σg, Σb, samples
/// kept), `extra[i]` the contents of `extra_buffers()[i]`, and the samples per pixel rendered.
/// Shareable, so snapshots can be resolved away from the thread that renders.
pub type Resolver = Arc<dyn Fn(&[[f32; 4]], &[&[[f32; 4]]], u32) -> Vec<[f32; 3]> + Send + Sync>;

/// How an integrator's image is formed from its raw buffers, for the GPU error estimate (the
/// [`Resolver`] is the CPU's definition; each variant mirrors one).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GpuResolve {
    /// [`mean_of_accumulation`].
    Mean,
    /// The mean plus the first extra buffer (light-tracing splats, split by parity in the
    /// buffer whose `odd_share_of` is 0) over pixels · spp, the splats as floats or as 64-bit
    /// fixed point with `frac_bits` fractional bits (bdpt).
    MeanPlusSplats { fixed_point: bool, frac_bits: u32 },
}

/// A device buffer an integrator's kernels use as scratch (not carried in checkpoints, not part
/// of the image): the session allocates it zeroed and binds it next to ACCUM and STATS.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ScratchBuffer {
    pub binding: u32,
    pub name: &'static str,
    pub bytes: u64,
}

/// The plain estimate: accumulated radiance divided by the samples kept per pixel.
pub fn mean_of_accumulation(accum: &[[f32; 4]]) -> Vec<[f32; 3]> {
    use rayon::prelude::*;
    accum
        .par_iter()
        .map(|a| {
            if a[3] > 0.0 {
                [a[0] / a[3], a[1] / a[3], a[2] / a[3]]
            } else {
                [0.0; 3]
            }
        })
        .collect()
}

/// The common interface. Its name and pass kernel are its registry entry's
/// ([`IntegratorInfo`]).
pub trait Integrator: Send {
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
    /// What this render holds constant that the kernels otherwise read at run time, compiled in
    /// where the kernels are specialised ([`crate::compile::KernelMode::Specialized`]) so that
    /// the tests on them fold away (the generic kernel reads them): the scene's filter and
    /// camera model (`scene`), the depths (`PASS_MAX_DEPTH`, `PASS_RR_DEPTH`:
    /// shaders/common/types.glsl) and the options that pick code paths, each the value the
    /// integrator passes at run time. Each integrator lists those measured to pay for its
    /// kernels (docs/kernels.md). Default: the scene's.
    fn constants(&self, scene: &SceneConstants) -> ShaderDefines {
        scene.all()
    }
    /// The kernels (path, defines) [`Integrator::setup`] builds besides the pass kernel, for
    /// `defines` (the session's: the scene's feature set plus [`Integrator::defines`]), so that
    /// they can be compiled ahead and in parallel. Default: none.
    fn kernels(&self, _defines: &ShaderDefines) -> Vec<(String, ShaderDefines)> {
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
    /// Forgets what [`Integrator::observe_timings`] gathered: the session was reset or restored
    /// from a checkpoint, and `details` speak of the passes from then on. Default: nothing.
    fn reset_timings(&mut self) {}
    /// Integrator-specific statistics reported with the render's (a JSON object: stage
    /// timings, memory, options in effect). Default: none.
    fn details(&self) -> Option<serde_json::Value> {
        None
    }
    /// Per-pixel buffers besides ACCUM and STATS. Default: none.
    fn extra_buffers(&self) -> Vec<ExtraBuffer> {
        Vec::new()
    }
    /// How the image is formed from the raw buffers. Default: [`mean_of_accumulation`].
    /// An integrator that changes it says how in [`Integrator::gpu_resolve`] too.
    fn resolver(&self) -> Resolver {
        Arc::new(|accum, _, _| mean_of_accumulation(accum))
    }
    /// [`Integrator::resolver`] as the GPU error estimate forms pixel values
    /// (renderer/src/render/estimate_gpu.rs; tests/tests/until.rs checks it against the CPU
    /// estimate). Default: [`GpuResolve::Mean`].
    fn gpu_resolve(&self) -> GpuResolve {
        GpuResolve::Mean
    }
    /// Whether the pass kernel reads `GpuPush::dispatch` (common/dispatch.glsl), so the
    /// session may give a pass several threads per pixel and split it into bands. Default:
    /// true; integrators whose passes are made of per-sample stages say false.
    fn shapes_dispatch(&self) -> bool {
        true
    }
    /// Most threads per pixel a pass may use (with [`Integrator::shapes_dispatch`]). Default:
    /// [`crate::layout::MAX_LANES`].
    fn max_lanes(&self) -> u32 {
        crate::layout::MAX_LANES
    }
    /// Most pixels one band (dispatch) of a `width`×`height` film may cover, e.g. what a
    /// per-band scratch buffer holds. Default: no limit of its own.
    fn max_band_pixels(&self, _width: u32, _height: u32) -> u64 {
        u64::MAX
    }
    /// Scratch buffers for a `width`×`height` film. Default: none.
    fn scratch_buffers(&self, _width: u32, _height: u32) -> Vec<ScratchBuffer> {
        Vec::new()
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
                design: None,
                light_share: None,
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

    #[test]
    fn bdpt_light_share_is_checked() {
        let parse = |json: &str| {
            IntegratorOptions::parse(&serde_json::from_str(json).unwrap(), "bdpt")
                .map_err(|e| e.to_string())
        };
        for k in bdpt::LIGHT_SHARES {
            parse(&format!(r#"{{"type":"bdpt","light_share":{k}}}"#)).unwrap();
        }
        let e = parse(r#"{"type":"bdpt","light_share":3}"#).unwrap_err();
        assert!(
            e.contains("light_share: must be one of [1, 2, 4, 8], got 3"),
            "{e}"
        );
        let e = parse(r#"{"type":"bdpt","light_share":4,"design":"per_pixel"}"#).unwrap_err();
        assert!(e.contains("needs the split design"), "{e}");
        parse(r#"{"type":"bdpt","light_share":1,"design":"per_pixel"}"#).unwrap();
    }
}
