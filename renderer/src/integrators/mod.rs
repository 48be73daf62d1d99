//! Integrators: one module each, all with the same interface: created from typed options
//! (`IntegratorOptions`, a serde enum tagged by `type`, unknown fields rejected), they record
//! one pass of `spp` samples per pixel into the accumulation buffer and name their kernel.
//! Kernels live in `shaders/<name>/`, mirroring these modules.

mod nee;
mod path;
mod pt;

use serde::{Deserialize, Serialize};

use crate::compile::layout::GpuPush;
use crate::gpu::{ComputePipeline, GpuResult, Recorder};

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

/// Which integrator, with its options.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub enum IntegratorOptions {
    /// Path tracing with BSDF sampling only.
    Pt(PathOptions),
    /// Path tracing with next-event estimation and MIS.
    Nee(PathOptions),
}

/// Names accepted on the command line and in `render.integrator`.
pub const NAMES: &[&str] = &["pt", "nee"];

impl IntegratorOptions {
    /// Default options for an integrator name; None for unknown or not-yet-built integrators.
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "pt" => Some(IntegratorOptions::Pt(PathOptions::default())),
            "nee" => Some(IntegratorOptions::Nee(PathOptions::default())),
            _ => None,
        }
    }

    pub fn name(&self) -> &'static str {
        match self {
            IntegratorOptions::Pt(_) => "pt",
            IntegratorOptions::Nee(_) => "nee",
        }
    }

    /// Overrides max_depth (e.g. from `--max-depth`).
    pub fn set_max_depth(&mut self, d: i32) {
        match self {
            IntegratorOptions::Pt(o) | IntegratorOptions::Nee(o) => o.max_depth = Some(d),
        }
    }

    pub fn max_depth(&self) -> Option<i32> {
        match self {
            IntegratorOptions::Pt(o) | IntegratorOptions::Nee(o) => o.max_depth,
        }
    }

    /// Builds the integrator for these options.
    pub fn build(&self, scene_max_depth: Option<i32>) -> Box<dyn Integrator> {
        match self {
            IntegratorOptions::Pt(o) => Box::new(pt::new(o, scene_max_depth)),
            IntegratorOptions::Nee(o) => Box::new(nee::new(o, scene_max_depth)),
        }
    }
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
}
