//! Compile step 6: the camera, film and pixel filter, and the scene-wide figures the kernels read,
//! packed into `GpuGlobals`.

use glam::DVec3;

use crate::layout::GpuGlobals;
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
}

/// The globals of `scene` for a `width` × `height` film.
pub(super) fn globals(scene: &Scene, width: u32, height: u32, facts: SceneFacts) -> GpuGlobals {
    let cam = &scene.camera;
    let forward = (cam.look_at - cam.position).normalize();
    let right = forward.cross(cam.up).normalize();
    let up = right.cross(forward);
    let tan_half = (cam.fov_y.to_radians() * 0.5).tan();
    let (filter_kind, stddev) = match scene.film.filter {
        Filter::Box => (0, 0.5),
        Filter::Gaussian { stddev } => (1, stddev),
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
        filter: [stddev, 4.0 * stddev, 0.0, 0.0],
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
    }
}
