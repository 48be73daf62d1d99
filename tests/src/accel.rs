//! Helpers of the acceleration-structure tests (accel_cwbvh, accel_grid): compile a scene with
//! given accel options, compare two images pixel by pixel, move a scene far from the origin.

use std::path::Path;

use glam::DVec3;
use renderer::accel::AccelOptions;
use renderer::compile::{compile_with, CompileOptions, CompiledScene};
use renderer::film::Image;
use renderer::metrics::rel_mse;
use renderer::scene::{Light, Scene};

/// `scene` compiled for a `w`×`w` film with `accel`, its structures cached under `cache`.
pub fn compiled(scene: &Scene, w: u32, accel: AccelOptions, cache: Option<&Path>) -> CompiledScene {
    let opts = CompileOptions {
        accel,
        cache,
        expand_instances: false,
        max_triangles: None,
    };
    compile_with(scene, w, w, &opts).expect("compile")
}

/// Pixels whose colour differs at all, and the relMSE of `a` against `b`.
pub fn diff(a: &Image, b: &Image) -> (usize, f64) {
    let n = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .filter(|(x, y)| x != y)
        .count();
    (n, rel_mse(a, b).unwrap())
}

/// The project scene `name` (scenes/NAME.json).
pub fn load(name: &str) -> Scene {
    renderer::scene::load_file(&crate::scene_path(name)).unwrap()
}

/// `scene` with everything that has a position (camera, mesh vertices, spheres, instances,
/// point and spot lights) moved by `t`: the same picture, far from the origin.
pub fn translated(scene: &Scene, t: DVec3) -> Scene {
    let mut far = scene.clone();
    far.camera.position += t;
    far.camera.look_at += t;
    for m in &mut far.meshes {
        for p in &mut m.positions {
            *p += t;
        }
    }
    for s in &mut far.spheres {
        s.center += t;
    }
    for i in &mut far.instances {
        i.to_world = glam::DMat4::from_translation(t) * i.to_world;
    }
    for l in &mut far.lights {
        if let Light::Point { position, .. } | Light::Spot { position, .. } = l {
            *position += t;
        }
    }
    far
}
