//! `nee`: path tracing with next-event estimation: at every non-specular vertex one light is
//! picked (∝ power) and sampled, and its contribution is combined with BSDF sampling by multiple
//! importance sampling (power heuristic, Veach 1997). Kernel: shaders/nee/nee.comp.

use super::path::PathIntegrator;
use super::PathOptions;

pub fn new(o: &PathOptions, scene_max_depth: Option<i32>) -> PathIntegrator {
    PathIntegrator::new("nee pass", o, scene_max_depth)
}
