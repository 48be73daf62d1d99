//! The integrator shared by `pt` and `nee`: both run the path-tracing megakernel
//! (shaders/common/path.glsl), compiled with or without next-event estimation.

use super::{Integrator, PathOptions};
use crate::compile::SceneConstants;
use crate::gpu::{ComputePipeline, Constant, GpuResult, Recorder, ShaderDefines};
use crate::layout::GpuPush;

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
    /// The depths, the camera model and the tangents; not the filter: compiled in, it cost pt
    /// 3.5% on the box-filtered textured_mesh on an H200 (bench/RESULTS.md, "The render's
    /// constants"), and nee runs the same megakernel.
    fn constants(&self, scene: &SceneConstants) -> ShaderDefines {
        vec![
            Constant::Int(self.max_depth).define("PASS_MAX_DEPTH"),
            Constant::Int(self.rr_depth).define("PASS_RR_DEPTH"),
            scene.lens(),
            scene.tangents(),
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
