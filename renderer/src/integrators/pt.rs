//! `pt`: unidirectional path tracing with BSDF sampling only; emitters count only when a path
//! hits them. The simplest unbiased estimator, which `nee` must agree with.
//! Kernel: shaders/pt/pt.comp.

use super::path::PathIntegrator;
use super::PathOptions;

pub fn new(o: &PathOptions, scene_max_depth: Option<i32>) -> PathIntegrator {
    PathIntegrator::new("pt pass", o, scene_max_depth)
}
