//! The integrator shared by `pt` and `nee`: both run the path-tracing megakernel
//! (shaders/common/path.glsl), compiled with or without next-event estimation.

use super::{Integrator, PathOptions};
use crate::gpu::{ComputePipeline, GpuResult, Recorder, ShaderDefines};
use crate::layout::GpuPush;

/// Benchmark knob for issue 19's "max_depth and rr_depth as constants" experiment:
/// `CANDELA_DEPTH_CONSTANTS=1` compiles both depths into the kernel instead of reading them from
/// the push constants (one variant per depth pair). Not kept as the default: see docs/kernels.md.
fn depth_constants() -> bool {
    std::env::var("CANDELA_DEPTH_CONSTANTS").is_ok_and(|v| v == "1")
}

pub struct PathIntegrator {
    label: &'static str,
    max_depth: i32,
    rr_depth: i32,
}

impl PathIntegrator {
    /// `max_depth` and `rr_depth` take their defaults here: the scene's max_depth, else 6; 5.
    pub(super) fn new(label: &'static str, o: &PathOptions, scene_max_depth: Option<i32>) -> Self {
        PathIntegrator {
            label,
            max_depth: o.max_depth.or(scene_max_depth).unwrap_or(6),
            rr_depth: o.rr_depth.unwrap_or(5),
        }
    }
}

impl Integrator for PathIntegrator {
    fn max_depth(&self) -> i32 {
        self.max_depth
    }
    fn defines(&self) -> ShaderDefines {
        if !depth_constants() {
            return Vec::new();
        }
        vec![
            ("PATH_MAX_DEPTH".into(), self.max_depth.to_string()),
            ("PATH_RR_DEPTH".into(), self.rr_depth.to_string()),
        ]
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
        rec.dispatch(pipeline, bytemuck::bytes_of(&push), groups, self.label)
    }
}
