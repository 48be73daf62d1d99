//! `deferred` (work in progress: being built). Kernels: shaders/deferred/.

use super::Integrator;
use crate::compile::layout::GpuPush;
use crate::gpu::{ComputePipeline, GpuResult, Recorder};
use serde::{Deserialize, Serialize};

/// Options of `deferred`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DeferredOptions {
    /// Default: the scene's `render.max_depth`, else 6.
    pub max_depth: Option<i32>,
}

pub struct DeferredIntegrator {
    max_depth: i32,
}

pub fn new(o: &DeferredOptions, scene_max_depth: Option<i32>) -> DeferredIntegrator {
    DeferredIntegrator {
        max_depth: o.max_depth.or(scene_max_depth).unwrap_or(6),
    }
}

impl Integrator for DeferredIntegrator {
    fn name(&self) -> &'static str {
        "deferred"
    }
    fn kernel(&self) -> &'static str {
        "deferred/deferred.comp"
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
        rec.dispatch(pipeline, bytemuck::bytes_of(&push), groups, "deferred pass")
    }
}
