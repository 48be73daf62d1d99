//! The BVH cache key does not follow the camera: the tree is built in the scene frame and moved
//! to the camera when the scene is compiled, so a moved camera loads the cached tree, and the
//! moved tree renders exactly like one built for that camera. Through the library and through
//! `candela render --json` (its `accel_cache` field).

use candela_tests::*;
use glam::DVec3;
use renderer::accel::{AccelOptions, CacheStatus};
use renderer::compile::{compile_with, CompileOptions, CompiledScene};
use renderer::film::Image;
use renderer::scene::Scene;

fn compiled(scene: &Scene, cache: Option<&std::path::Path>) -> CompiledScene {
    let opts = CompileOptions {
        accel: AccelOptions::default(),
        cache,
        expand_instances: false,
        max_triangles: None,
    };
    compile_with(scene, 16, 16, &opts).expect("compile")
}

fn image(scene: &Scene, c: &CompiledScene) -> Image {
    render_compiled(scene, c, "nee", 2, 9, None).0
}

#[test]
fn a_moved_camera_hits_the_bvh_cache() {
    let dir = scratch("accel-camera");
    let scene = renderer::scene::load_file(&scene_path("textured_mesh.json")).unwrap();
    assert_eq!(compiled(&scene, Some(&dir)).accel.cache, CacheStatus::Miss);
    // Moved and turned, near and far (1e4 units away, looking back at the scene).
    let moves = [
        (DVec3::new(0.3, -0.2, 0.5), DVec3::new(0.1, 0.0, 0.0)),
        (DVec3::new(1e4, 2e3, -5e3), DVec3::ZERO),
    ];
    for (shift, look) in moves {
        let mut moved = scene.clone();
        moved.camera.position += shift;
        moved.camera.look_at += look;
        let hit = compiled(&moved, Some(&dir));
        assert_eq!(hit.accel.cache, CacheStatus::Hit, "camera moved by {shift}");
        let fresh = compiled(&moved, None);
        assert_eq!(format!("{:?}", hit.nodes), format!("{:?}", fresh.nodes));
        let (a, b) = (image(&moved, &hit), image(&moved, &fresh));
        assert!(a.pixels == b.pixels, "camera moved by {shift}");
        let lit = a.pixels.iter().filter(|p| p[0] > 0.0).count();
        println!(
            "camera moved by {shift}: cache hit, {lit} lit pixels, same image as a fresh build"
        );
        assert!(lit > 0 || shift.length() > 1e3);
    }
    // The geometry is still the key: a moved vertex is another tree.
    let mut edited = scene.clone();
    edited.meshes[0].positions[0].x += 0.01;
    assert_eq!(compiled(&edited, Some(&dir)).accel.cache, CacheStatus::Miss);
}

#[test]
fn cli_reports_a_cache_hit_after_a_camera_move() {
    let dir = scratch("accel-camera-cli");
    let cache = dir.join("cache");
    let out = dir.join("o.exr");
    let base = std::fs::read_to_string(scene_path("cornell.json")).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&base).unwrap();
    let render = |v: &serde_json::Value, name: &str| -> serde_json::Value {
        let path = dir.join(format!("{name}.json"));
        std::fs::write(&path, v.to_string()).unwrap();
        run_json(&[
            "render",
            path.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--width",
            "8",
            "--height",
            "8",
            "--spp",
            "1",
            "--json",
            "--accel-cache",
            cache.to_str().unwrap(),
        ])
    };
    assert_eq!(render(&v, "first")["accel_cache"], "miss");
    v["camera"]["position"] = serde_json::json!([0.4, 0.2, 3.5]);
    assert_eq!(render(&v, "moved")["accel_cache"], "hit");
}
