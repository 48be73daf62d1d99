//! `vct` (work in progress: being built). Kernels: shaders/vct/.

use super::Integrator;
use crate::compile::layout::GpuPush;
use crate::gpu::{ComputePipeline, GpuResult, Recorder};
use serde::{Deserialize, Serialize};

/// Options of `vct`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VctOptions {
    /// Default: the scene's `render.max_depth`, else 6.
    pub max_depth: Option<i32>,
}

pub struct VctIntegrator {
    max_depth: i32,
}

pub fn new(o: &VctOptions, scene_max_depth: Option<i32>) -> VctIntegrator {
    VctIntegrator {
        max_depth: o.max_depth.or(scene_max_depth).unwrap_or(6),
    }
}

impl Integrator for VctIntegrator {
    fn name(&self) -> &'static str {
        "vct"
    }
    fn kernel(&self) -> &'static str {
        "vct/vct.comp"
    }
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
        rec.dispatch(pipeline, bytemuck::bytes_of(&push), groups, "vct pass")
    }
}
