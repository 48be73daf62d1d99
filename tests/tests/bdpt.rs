//! scratch
use candela_tests::{gpu, scene_path};
use renderer::compile::compile;
use renderer::integrators::IntegratorOptions;
use renderer::render::{render, Budget, RenderSession};

fn run(scene: &str, json: &str, spp: u32, w: u32, seed: u64) -> renderer::film::Image {
    let s = renderer::scene::load_file(&scene_path(scene)).unwrap();
    let c = compile(&s, w, w).unwrap();
    let o: IntegratorOptions = serde_json::from_str(json).unwrap();
    let ctx = gpu();
    let mut sess = RenderSession::new(&ctx, &c, &o, s.render.max_depth, seed).unwrap();
    let t = std::time::Instant::now();
    let (img, st) = render(&mut sess, Budget::Spp(spp)).unwrap();
    ctx.check_validation().unwrap();
    println!("{scene} {json}: mean {:?} {:.2}s dropped {}", img.mean(), t.elapsed().as_secs_f64(), st.dropped_samples);
    img
}

#[test]
fn smoke() {
    run("cornell.json", r#"{"type":"nee"}"#, 64, 16, 1);
    run("cornell.json", r#"{"type":"bdpt"}"#, 64, 16, 1);
}
