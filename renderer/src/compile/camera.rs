//! Compile step 6: the camera, film and pixel filter, and the scene-wide figures the kernels read,
//! packed into `GpuGlobals`.

use glam::DVec3;

use super::lights::alias_table;
use crate::gpu::{Constant, ShaderDefines};
use crate::layout::{GpuGlobals, SCENE_TANGENTS};
use crate::scene::{Filter, Scene};

/// What the earlier steps found that the globals carry.
pub(super) struct SceneFacts {
    /// The camera-relative bounding sphere.
    pub center: DVec3,
    pub radius: f64,
    pub light_count: u32,
    pub env: [u32; 4],
    pub env_params: [f32; 4],
    pub prim_count: u32,
    pub node_count: u32,
    /// The light BVH's node count and infinite-light count (zero with the power sampler).
    pub light_nodes: [u32; 2],
    /// The instance count and the top-level BVH's node count (zero without instances).
    pub instances: [u32; 2],
    /// A material the primitives use may read the tangent's direction (GpuGlobals'
    /// SCENE_TANGENTS).
    pub tangents: bool,
}

/// The globals of `scene` for a `width` × `height` film.
pub(super) fn globals(scene: &Scene, width: u32, height: u32, facts: SceneFacts) -> GpuGlobals {
    let cam = &scene.camera;
    let forward = (cam.look_at - cam.position).normalize();
    let right = forward.cross(cam.up).normalize();
    let up = right.cross(forward);
    let tan_half = (cam.fov_y.to_radians() * 0.5).tan();
    // The box filter reads none of the Gaussian's parameters or tables: zeros.
    let (filter_kind, filter_params, tables) = match scene.film.filter {
        Filter::Box => (0, [0.0; 4], ([0.0; 32], [0; 32])),
        Filter::Gaussian { stddev } => {
            (1, gaussian_filter_params(stddev), gaussian_filter_tables())
        }
    };
    let v4 = |v: DVec3| [v.x as f32, v.y as f32, v.z as f32, 0.0];
    let c = facts.center;
    GpuGlobals {
        cam_forward: v4(forward),
        cam_right: v4(right),
        cam_up: v4(up),
        lens: [
            tan_half as f32,
            width as f32 / height as f32,
            cam.aperture_radius as f32,
            cam.focus_distance as f32,
        ],
        film: [width, height, filter_kind, facts.light_count],
        filter: filter_params,
        filter_c: tables.0,
        filter_alias: tables.1,
        scene_sphere: [c.x as f32, c.y as f32, c.z as f32, facts.radius as f32],
        env: facts.env,
        env_params: facts.env_params,
        counts: [
            facts.prim_count,
            facts.node_count,
            facts.light_nodes[0],
            facts.light_nodes[1],
        ],
        instances: [facts.instances[0], facts.instances[1], 0, 0],
        scene_flags: [if facts.tangents { SCENE_TANGENTS } else { 0 }, 0, 0, 0],
    }
}

/// What a scene holds constant that kernels otherwise test at run time (shaders/common/types.glsl),
/// for specialised kernels: the pixel filter, the camera model and whether surfaces need their
/// tangent's direction. Each integrator takes those that pay for it
/// ([`crate::integrators::Integrator::constants`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SceneConstants {
    /// The Gaussian pixel filter (else the box).
    pub gaussian_filter: bool,
    /// A thin lens (else a pinhole).
    pub thin_lens: bool,
    /// Some surface's BSDF may read the tangent's direction (else surfaces take any frame about
    /// the shading normal: shaders/common/surface.glsl).
    pub tangents: bool,
}

impl SceneConstants {
    pub(super) fn of(g: &GpuGlobals) -> Self {
        SceneConstants {
            gaussian_filter: g.film[2] == 1,
            thin_lens: g.lens[2] > 0.0,
            tangents: g.scene_flags[0] & SCENE_TANGENTS != 0,
        }
    }

    pub fn filter(&self) -> (String, String) {
        Constant::Bool(self.gaussian_filter).define("FILTER_GAUSSIAN")
    }

    pub fn lens(&self) -> (String, String) {
        Constant::Bool(self.thin_lens).define("CAMERA_THIN_LENS")
    }

    pub fn tangents(&self) -> (String, String) {
        Constant::Bool(self.tangents).define("SURFACE_TANGENTS")
    }

    /// All three.
    pub fn all(&self) -> ShaderDefines {
        vec![self.filter(), self.lens(), self.tangents()]
    }
}

/// The Gaussian filter's parameters as shaders/common/filter.glsl reads them: σ, the radius
/// r = 4σ (Mitsuba's) and the width r/31 of one step of Mitsuba's discretised filter.
fn gaussian_filter_params(stddev: f32) -> [f32; 4] {
    let r = 4.0 * stddev;
    [stddev, r, r / 31.0, 0.0]
}

/// The value of Mitsuba's discretised Gaussian on step k (rfilter.h `init_discretization`: the
/// filter at r·k/31, k = 0..30, then 0), which does not depend on σ once r = 4σ:
/// v_k = max(0, e^{−8k²/961} − e^{−8}). shaders/common/filter.glsl computes the same.
fn filter_step(k: usize) -> f64 {
    if k >= 31 {
        return 0.0;
    }
    let x = 4.0 * k as f64 / 31.0;
    ((-0.5 * x * x).exp() - (-8.0f64).exp()).max(0.0)
}

/// The tables of shaders/common/filter.glsl: the running sums C_k = Σ_{i<k} v_i (C_31: one side's
/// mass, in steps) and an alias table over the 31 steps of one side (`alias_table`, the lights'),
/// each entry the probability of keeping its own step in fixed point with 24 fractional bits
/// (bits 0..26; exact in an f32) and the step it otherwise takes (bits 27..31).
fn gaussian_filter_tables() -> ([f32; 32], [u32; 32]) {
    let mut c = [0.0f32; 32];
    let mut sum = 0.0f64;
    for (k, ck) in c.iter_mut().enumerate() {
        *ck = sum as f32;
        sum += filter_step(k);
    }
    let pmf: Vec<f64> = (0..31).map(|k| filter_step(k) / sum).collect();
    let mut packed = [0u32; 32];
    for (slot, entry) in packed.iter_mut().zip(alias_table(&pmf)) {
        let keep = (entry.prob.clamp(0.0, 1.0) as f64 * FILTER_KEEP_ONE as f64).round() as u32;
        *slot = keep | entry.alias << 27;
    }
    (c, packed)
}

/// A keep probability of 1 in the filter's alias entries (shaders/common/filter.glsl divides by it).
const FILTER_KEEP_ONE: u32 = 1 << 24;

#[cfg(test)]
mod tests {
    use super::{filter_step, gaussian_filter_tables, FILTER_KEEP_ONE};

    #[test]
    fn gaussian_filter_tables_are_mitsubas_steps() {
        // Mitsuba 3.9.1 scalar_rgb, gaussian stddev 0.5: eval_discretized(0.3) = 0.87498 (step 4),
        // eval_discretized(1.9) = 0.000575 (step 29), and nothing past the radius.
        assert!((filter_step(4) - 0.87498).abs() < 1e-4);
        assert!((filter_step(29) - 0.000575).abs() < 2e-6 && filter_step(31) == 0.0);
        let (c, alias) = gaussian_filter_tables();
        assert_eq!(c[0], 0.0);
        assert!((c[31] - 10.201988).abs() < 1e-5, "{}", c[31]);
        // The alias table reproduces each step's probability v_k / C_31.
        let mut mass = [0.0f64; 31];
        for (k, &e) in alias[..31].iter().enumerate() {
            let keep = (e & ((1 << 27) - 1)) as f32 as f64 / FILTER_KEEP_ONE as f64;
            mass[k] += keep / 31.0;
            mass[(e >> 27) as usize] += (1.0 - keep) / 31.0;
        }
        for (k, m) in mass.iter().enumerate() {
            let want = filter_step(k) / c[31] as f64;
            assert!((m - want).abs() < 1e-7, "step {k}: {m} vs {want}");
        }
    }
}
