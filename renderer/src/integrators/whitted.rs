//! `whitted`: classic Whitted ray tracing (work in progress: being built for issue 6).
//! Kernel: shaders/whitted/whitted.comp.

use super::Integrator;
use crate::compile::layout::GpuPush;
use crate::gpu::{ComputePipeline, GpuResult, Recorder};
use serde::{Deserialize, Serialize};

/// Options of `whitted`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WhittedOptions {
    /// Most mirror/refraction bounces (Mitsuba's max_depth meaning). Default: the scene's
    /// `render.max_depth`, else 6.
    pub max_depth: Option<i32>,
}

pub struct WhittedIntegrator {
    max_depth: i32,
}

pub fn new(o: &WhittedOptions, scene_max_depth: Option<i32>) -> WhittedIntegrator {
    WhittedIntegrator {
        max_depth: o.max_depth.or(scene_max_depth).unwrap_or(6),
    }
}

impl Integrator for WhittedIntegrator {
    fn name(&self) -> &'static str {
        "whitted"
    }
    fn kernel(&self) -> &'static str {
        "whitted/whitted.comp"
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
        rec.dispatch(pipeline, bytemuck::bytes_of(&push), groups, "whitted pass")
    }
}
