//! `deferred`: deferred many-light shading (after the "optimised deferred shading for many
//! dynamic lights" seed; tiled culling after Olsson & Assarsson 2011 and Harada et al. 2012).
//! Direct lighting only, computed in three compute stages, each one dispatch over a batch of
//! samples ([`batch`]: enough pixel-samples to keep the GPU busy between the barriers):
//!
//! 1. **G-buffer** (shaders/deferred/gbuffer.comp): the jittered camera ray of each pixel is cast
//!    through the BVH; the surface is packed into 16 bytes per pixel and sample ([`gbuffer`]).
//! 2. **Cull** (cull.comp): per 16×16 tile and sample, the bounding box of the tile's reconstructed surface
//!    points is tested against every light's influence sphere and cone; survivors form the
//!    tile's light list.
//! 3. **Shade** (shade.comp): each pixel evaluates its material's BSDF for the lights of its tile
//!    that reach it (optionally only the strongest few, optionally with shadow rays), plus
//!    directional lights, the environment as an ambient term, and emitters seen directly.
//!
//! The host light manager ([`lights`]) turns the scene's lights into point-like records with
//! influence radii from an irradiance `cutoff`, approximates area emitters, and can merge small
//! point lights. At max_depth ≤ 1 only the emitters seen directly are rendered, by the single
//! kernel deferred/deferred.comp. max_depth above 2 (or −1) is treated as 2: `deferred` has no
//! indirect light. docs/deferred.md describes the options and the error bounds.

pub mod batch;
pub mod gbuffer;
pub mod lights;
pub mod stages;

use std::sync::Arc;

use serde::{Deserialize, Serialize};
use serde_json::json;

use super::{Integrator, OptionField, OptionsInfo};
use crate::compile::{CompiledScene, SceneConstants};
use crate::error::RenderError;
use crate::gpu::{
    Binding, ComputePipeline, Constant, DispatchTiming, GpuContext, GpuResult, Recorder,
    ShaderDefines,
};
use crate::layout::GpuPush;
use lights::{LightSet, ManagerOptions};
use stages::{parse_stage_label, DeferredParams, Stages, TILE_OVERFLOW};

/// Default irradiance cutoff (W/m² in the scene's units): a light is ignored where it would
/// deliver less than this to a surface facing it.
pub const DEFAULT_CUTOFF: f32 = 1e-3;
/// Default capacity of a tile's light list; a fuller tile is shaded against every light.
pub const DEFAULT_TILE_CAPACITY: u32 = 1024;
/// Largest `max_lights_per_pixel` (the shade stage's fixed-size selection array).
pub const MAX_LIGHTS_PER_PIXEL: u32 = 32;
/// Most samples one pass may hold.
pub const MAX_SPP_PER_PASS: u32 = 1024;

/// What the debug views show instead of radiance (per pixel, averaged over samples).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DeferredDebug {
    /// The decoded shading normal (x, y, z).
    Normal,
    /// The stored depth (distance along the camera ray) in every channel.
    Depth,
    /// Against a fresh ray cast: (normal angle error in radians, position error / depth,
    /// 1 where hit, material or side disagree).
    GbufferError,
    /// (lights in the tile's list, lights that reach the pixel, 1 for an overflowed tile).
    TileLights,
}

impl DeferredDebug {
    fn code(self) -> u32 {
        match self {
            DeferredDebug::Normal => 1,
            DeferredDebug::Depth => 2,
            DeferredDebug::GbufferError => 3,
            DeferredDebug::TileLights => 4,
        }
    }
}

/// Options of `deferred` (every field optional; see docs/deferred.md).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DeferredOptions {
    /// Mitsuba's max_depth: 1 = emitters seen directly, ≥ 2 (or −1) = + direct light.
    /// Default: the scene's `render.max_depth`, else 6 (i.e. direct light).
    pub max_depth: Option<i32>,
    /// Irradiance below which a light is ignored; sets each light's influence radius
    /// sqrt(I_max / cutoff). 0: unbounded radii. Default [`DEFAULT_CUTOFF`].
    pub cutoff: Option<f32>,
    /// Shade at most this many lights per pixel, the strongest by estimated irradiance
    /// (1 ..= 32). Default: every light that reaches the pixel.
    pub max_lights_per_pixel: Option<u32>,
    /// Merge isotropic point lights whose influence radius is below this into one per grid
    /// cell of this width (see [`lights`]). Default 0: no merging.
    pub merge_radius: Option<f32>,
    /// Shadow rays through the BVH (any hit). Default false.
    pub shadows: Option<bool>,
    /// Light indices per tile list (≥ 1). Default [`DEFAULT_TILE_CAPACITY`].
    pub tile_capacity: Option<u32>,
    /// Tile culling and influence radii (default true); false shades every light at every
    /// pixel: the unculled reference of the tests.
    pub cull: Option<bool>,
    /// The environment lights surfaces as an ambient term (default true).
    pub env_ambient: Option<bool>,
    /// Samples per dispatch of each stage (1 ..= [`batch::MAX_BATCH`]). Default: automatic
    /// ([`batch::batch_size`]). The image does not depend on it.
    pub samples_per_batch: Option<u32>,
    /// A debug view instead of radiance.
    pub debug: Option<DeferredDebug>,
}

impl OptionsInfo for DeferredOptions {
    const FIELDS: &'static [OptionField] = &[
        OptionField {
            name: "max_depth",
            kind: "integer",
            help: "1 = emitters seen directly, >= 2 or -1 = + direct light (default: the scene's render.max_depth, else 6)",
        },
        OptionField {
            name: "cutoff",
            kind: "number",
            help: "irradiance below which a light is ignored; sets influence radii (default 1e-3; 0: unbounded)",
        },
        OptionField {
            name: "max_lights_per_pixel",
            kind: "integer",
            help: "shade at most this many lights per pixel, the strongest, 1..=32 (default: all)",
        },
        OptionField {
            name: "merge_radius",
            kind: "number",
            help: "merge small point lights per grid cell of this width (default 0: no merging)",
        },
        OptionField {
            name: "shadows",
            kind: "boolean",
            help: "shadow rays through the BVH (default false)",
        },
        OptionField {
            name: "tile_capacity",
            kind: "integer",
            help: "light indices per tile list (default 1024)",
        },
        OptionField {
            name: "cull",
            kind: "boolean",
            help: "tile culling and influence radii (default true); false shades every light everywhere",
        },
        OptionField {
            name: "env_ambient",
            kind: "boolean",
            help: "the environment lights surfaces as an ambient term (default true)",
        },
        OptionField {
            name: "samples_per_batch",
            kind: "integer",
            help: "samples per dispatch of each stage, 1..=64 (default: automatic, ~8M pixel-samples within 256 MiB); does not change the image",
        },
        OptionField {
            name: "debug",
            kind: "\"normal\" | \"depth\" | \"gbuffer_error\" | \"tile_lights\"",
            help: "a debug view instead of radiance",
        },
    ];
    fn max_depth(&self) -> Option<i32> {
        self.max_depth
    }
    fn set_max_depth(&mut self, d: i32) {
        self.max_depth = Some(d);
    }
    fn validate(&self) -> Result<(), RenderError> {
        validate(self)
    }
}

/// Stage times accumulated over the passes, milliseconds.
#[derive(Debug, Clone, Copy, Default)]
struct StageTimes {
    gbuffer: f64,
    cull: f64,
    shade: f64,
    emitters: f64,
    samples: u64,
    /// Batches run (G-buffer dispatches).
    batches: u64,
}

pub struct DeferredIntegrator {
    options: DeferredOptions,
    max_depth: i32,
    stages: Option<Stages>,
    lights: LightSet,
    times: StageTimes,
    /// The shading counters (which the GPU never clears) at the last `reset_timings`: the
    /// details report the counts since, like the stage times.
    counters_base: [u64; 3],
}

pub fn new(o: &DeferredOptions, scene_max_depth: Option<i32>) -> DeferredIntegrator {
    let m = o.max_depth.or(scene_max_depth).unwrap_or(6);
    DeferredIntegrator {
        options: *o,
        max_depth: if (0..=2).contains(&m) { m } else { 2 },
        stages: None,
        lights: LightSet::default(),
        times: StageTimes::default(),
        counters_base: [0; 3],
    }
}

/// Checks the options, naming the offending field.
pub(crate) fn validate(o: &DeferredOptions) -> Result<(), RenderError> {
    let bad = |m: String| Err(RenderError::Invalid(format!("deferred.{m}")));
    if let Some(c) = o.cutoff {
        if !(c >= 0.0 && c.is_finite()) {
            return bad(format!("cutoff: must be a finite number ≥ 0, got {c}"));
        }
    }
    if let Some(k) = o.max_lights_per_pixel {
        if k == 0 || k > MAX_LIGHTS_PER_PIXEL {
            return bad(format!(
                "max_lights_per_pixel: must be 1 ..= {MAX_LIGHTS_PER_PIXEL}, got {k}"
            ));
        }
    }
    if let Some(r) = o.merge_radius {
        if !(r >= 0.0 && r.is_finite()) {
            return bad(format!(
                "merge_radius: must be a finite number ≥ 0, got {r}"
            ));
        }
    }
    if o.tile_capacity == Some(0) {
        return bad("tile_capacity: must be at least 1".into());
    }
    if let Some(b) = o.samples_per_batch {
        if b == 0 || b > batch::MAX_BATCH {
            return bad(format!(
                "samples_per_batch: must be 1 ..= {}, got {b}",
                batch::MAX_BATCH
            ));
        }
    }
    Ok(())
}

impl DeferredIntegrator {
    /// The parameters the options set (the stages fill in the lights and tiles).
    fn option_params(&self) -> DeferredParams {
        let o = &self.options;
        DeferredParams {
            tile_capacity: o.tile_capacity.unwrap_or(DEFAULT_TILE_CAPACITY),
            max_per_pixel: o.max_lights_per_pixel.unwrap_or(0),
            shadows: o.shadows.unwrap_or(false) as u32,
            cull: o.cull.unwrap_or(true) as u32,
            debug: o.debug.map_or(0, DeferredDebug::code),
            env_ambient: o.env_ambient.unwrap_or(true) as u32,
            ..Default::default()
        }
    }

    fn cutoff(&self) -> f32 {
        if self.options.cull == Some(false) {
            0.0
        } else {
            self.options.cutoff.unwrap_or(DEFAULT_CUTOFF)
        }
    }
}

impl Integrator for DeferredIntegrator {
    fn max_depth(&self) -> i32 {
        self.max_depth
    }

    fn constants(&self, scene: &SceneConstants) -> ShaderDefines {
        let p = self.option_params();
        let mut c = scene.all();
        c.extend([
            Constant::Int(self.max_depth).define("PASS_MAX_DEPTH"),
            Constant::Bool(p.shadows != 0).define("DEFERRED_SHADOWS"),
            Constant::Bool(p.cull != 0).define("DEFERRED_CULL"),
            Constant::Uint(p.max_per_pixel).define("DEFERRED_CAP"),
            Constant::Uint(p.debug).define("DEFERRED_DEBUG"),
            Constant::Bool(p.env_ambient != 0).define("DEFERRED_ENV_AMBIENT"),
        ]);
        c
    }

    fn kernels(&self, defines: &ShaderDefines) -> Vec<(String, ShaderDefines)> {
        [
            "deferred/gbuffer.comp",
            "deferred/cull.comp",
            "deferred/shade.comp",
        ]
        .into_iter()
        .map(|k| (k.to_string(), defines.clone()))
        .collect()
    }

    fn setup(
        &mut self,
        ctx: &Arc<GpuContext>,
        scene: &CompiledScene,
        shared: &[Binding<'_>],
        defines: &ShaderDefines,
    ) -> Result<(), RenderError> {
        validate(&self.options)?;
        let o = &self.options;
        // Step 1: the light manager.
        self.lights = lights::manage(
            &scene.lights,
            &ManagerOptions {
                cutoff: self.cutoff(),
                merge_radius: o.merge_radius.unwrap_or(0.0),
            },
        );
        // Step 2: the stages' buffers and pipelines.
        self.stages = Some(Stages::new(
            ctx,
            scene.width,
            scene.height,
            &self.lights,
            self.option_params(),
            o.samples_per_batch,
            shared,
            defines,
        )?);
        Ok(())
    }

    fn dispatches_per_pass(&self, spp: u32) -> u32 {
        let spp = spp.min(MAX_SPP_PER_PASS);
        self.stages.as_ref().map_or(3 * spp, |s| s.dispatches(spp))
    }

    /// Passes are batched stage chains over 16×16 culling tiles: no lanes, no bands.
    fn shapes_dispatch(&self) -> bool {
        false
    }

    fn record_pass(
        &self,
        rec: &mut Recorder<'_>,
        pipeline: &ComputePipeline,
        mut push: GpuPush,
        groups: [u32; 3],
    ) -> GpuResult<()> {
        push.max_depth = self.max_depth;
        // Emitters alone (max_depth ≤ 1, without a debug view) need no stages.
        if self.max_depth <= 1 && self.options.debug.is_none() {
            return rec.dispatch(
                pipeline,
                bytemuck::bytes_of(&push),
                groups,
                "deferred emitters",
            );
        }
        let stages = self.stages.as_ref().ok_or_else(|| {
            crate::gpu::GpuError::Other("deferred: record_pass before setup".into())
        })?;
        if push.spp > MAX_SPP_PER_PASS {
            return Err(crate::gpu::GpuError::Other(format!(
                "deferred: a pass holds at most {MAX_SPP_PER_PASS} samples, got {}",
                push.spp
            )));
        }
        stages.record(rec, push)
    }

    fn observe_timings(&mut self, timings: &[DispatchTiming]) {
        for t in timings {
            if t.label == "deferred emitters" {
                self.times.emitters += t.gpu_ms;
                continue;
            }
            match parse_stage_label(&t.label) {
                Some(("gbuffer", n)) => {
                    self.times.gbuffer += t.gpu_ms;
                    self.times.samples += n as u64;
                    self.times.batches += 1;
                }
                Some(("cull", _)) => self.times.cull += t.gpu_ms,
                Some(("shade", _)) => self.times.shade += t.gpu_ms,
                _ => {}
            }
        }
    }

    fn reset_timings(&mut self) {
        self.times = StageTimes::default();
        // (The session has drained: the read waits for nothing.)
        if let Some(c) = self.stages.as_ref().and_then(|s| s.counters().ok()) {
            self.counters_base = c;
        }
    }

    fn details(&self) -> Option<serde_json::Value> {
        let t = &self.times;
        // (The counters since the last reset_timings; a read waits for the queued passes.)
        let now = (self.stages.as_ref())
            .and_then(|s| s.counters().ok())
            .unwrap_or_default();
        let [tested, shaded, lit] = [0, 1, 2].map(|i| now[i].saturating_sub(self.counters_base[i]));
        let per = |ms: f64| {
            if t.samples > 0 {
                ms / t.samples as f64
            } else {
                0.0
            }
        };
        let mut d = json!({
            "gbuffer_bytes_per_pixel": gbuffer::BYTES_PER_PIXEL,
            "stage_ms": {"gbuffer": t.gbuffer, "cull": t.cull, "shade": t.shade,
                         "emitters": t.emitters},
            "stage_ms_per_sample": {"gbuffer": per(t.gbuffer), "cull": per(t.cull),
                                    "shade": per(t.shade)},
            "lights": self.lights.stats,
            "lights_per_pixel": {
                "tested": tested as f64 / lit.max(1) as f64,
                "shaded": shaded as f64 / lit.max(1) as f64,
                "pixel_samples": lit,
            },
            "cutoff": self.cutoff(),
            "options": self.options,
        });
        if let Some(s) = &self.stages {
            d["memory_bytes"] = json!(s.memory);
            d["tile_capacity"] = json!(s.params.tile_capacity);
            d["tiles"] = json!([s.params.tiles_x, s.params.tiles_y]);
            d["samples_per_batch"] = json!(s.batch);
            d["batches"] = json!(t.batches);
            // The light lists of the first sample of the last batch rendered.
            if t.samples > 0 {
                if let Ok(counts) = s.tile_counts() {
                    let over = counts.iter().filter(|&&c| c == TILE_OVERFLOW).count();
                    let fine: Vec<u32> = counts
                        .iter()
                        .copied()
                        .filter(|&c| c != TILE_OVERFLOW)
                        .collect();
                    let mean =
                        fine.iter().map(|&c| c as f64).sum::<f64>() / fine.len().max(1) as f64;
                    d["tile_lists"] = json!({
                        "mean_lights": mean,
                        "max_lights": fine.iter().copied().max().unwrap_or(0),
                        "overflowed_tiles": over,
                    });
                }
            }
        }
        Some(d)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrators::IntegratorOptions;

    #[test]
    fn options_parse_and_reject_unknown_fields() {
        let o: IntegratorOptions = serde_json::from_str(
            r#"{"type":"deferred","cutoff":0.01,"max_lights_per_pixel":8,"shadows":true,
                "merge_radius":0.5,"tile_capacity":64,"cull":false,"debug":"gbuffer_error"}"#,
        )
        .unwrap();
        let IntegratorOptions::Deferred(d) = o else {
            panic!("{o:?}")
        };
        assert_eq!(d.cutoff, Some(0.01));
        assert_eq!(d.debug, Some(DeferredDebug::GbufferError));
        let e = serde_json::from_str::<IntegratorOptions>(r#"{"type":"deferred","shadow":true}"#)
            .unwrap_err();
        assert!(e.to_string().contains("shadow"), "{e}");
    }

    #[test]
    fn bad_values_name_the_field() {
        for (o, field) in [
            (
                DeferredOptions {
                    cutoff: Some(-1.0),
                    ..Default::default()
                },
                "cutoff",
            ),
            (
                DeferredOptions {
                    max_lights_per_pixel: Some(33),
                    ..Default::default()
                },
                "max_lights_per_pixel",
            ),
            (
                DeferredOptions {
                    merge_radius: Some(f32::NAN),
                    ..Default::default()
                },
                "merge_radius",
            ),
            (
                DeferredOptions {
                    tile_capacity: Some(0),
                    ..Default::default()
                },
                "tile_capacity",
            ),
            (
                DeferredOptions {
                    samples_per_batch: Some(0),
                    ..Default::default()
                },
                "samples_per_batch",
            ),
            (
                DeferredOptions {
                    samples_per_batch: Some(batch::MAX_BATCH + 1),
                    ..Default::default()
                },
                "samples_per_batch",
            ),
        ] {
            let e = validate(&o).unwrap_err().to_string();
            assert!(e.contains(&format!("deferred.{field}")), "{e}");
        }
        assert!(validate(&DeferredOptions::default()).is_ok());
    }

    #[test]
    fn max_depth_is_direct_light_at_most() {
        assert_eq!(new(&DeferredOptions::default(), None).max_depth, 2);
        assert_eq!(new(&DeferredOptions::default(), Some(-1)).max_depth, 2);
        assert_eq!(new(&DeferredOptions::default(), Some(1)).max_depth, 1);
    }
}
