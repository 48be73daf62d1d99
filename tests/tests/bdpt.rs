//! scratch
use candela_tests::{gpu, scene_path};
use renderer::compile::compile;
use renderer::integrators::IntegratorOptions;
use renderer::metrics::{downsample_box, rel_mse};
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
    println!("{scene} {json} {spp}spp: mean {:.4?} {:.2}s dropped {}", img.mean(), t.elapsed().as_secs_f64(), st.dropped_samples);
    img
}

fn cmp(scene: &str, a: &str, sa: u32, b: &str, sb: u32, w: u32) {
    let a1 = run(scene, a, sa, w, 1);
    let a2 = run(scene, a, sa, w, 2);
    let b1 = run(scene, b, sb, w, 3);
    let b2 = run(scene, b, sb, w, 4);
    let d = |x, y| rel_mse(&downsample_box(x, 4), &downsample_box(y, 4)).unwrap();
    let e = d(&a1, &b1);
    let noise = d(&a1, &a2) / 2.0 + d(&b1, &b2) / 2.0;
    println!("full-res seed relMSE: A {:.3e} B {:.3e}", rel_mse(&a1,&a2).unwrap(), rel_mse(&b1,&b2).unwrap());
    println!("==> {scene}: {a} vs {b}: block relMSE {e:.3e} noise {noise:.3e} ratio {:.2}", e / noise);
}

#[test]
fn exp() {
    let sc = std::env::var("SC").unwrap_or("cornell.json".into());
    let a = std::env::var("A").unwrap_or(r#"{"type":"bdpt"}"#.into());
    let b = std::env::var("B").unwrap_or(r#"{"type":"nee"}"#.into());
    let sa: u32 = std::env::var("SA").map(|s| s.parse().unwrap()).unwrap_or(64);
    let sb: u32 = std::env::var("SB").map(|s| s.parse().unwrap()).unwrap_or(256);
    let w: u32 = std::env::var("W").map(|s| s.parse().unwrap()).unwrap_or(32);
    cmp(&sc, &a, sa, &b, sb, w);
}

fn sub(a: &renderer::film::Image, b: &renderer::film::Image) -> renderer::film::Image {
    let mut o = a.clone();
    for (p, q) in o.pixels.iter_mut().zip(&b.pixels) { for c in 0..3 { p[c] -= q[c]; } }
    o
}

#[test]
fn techniques() {
    let sc = std::env::var("SC").unwrap_or("cornell.json".into());
    let k: i32 = std::env::var("K").map(|s| s.parse().unwrap()).unwrap_or(2);
    let spp: u32 = std::env::var("SA").map(|s| s.parse().unwrap()).unwrap_or(256);
    let w: u32 = std::env::var("W").map(|s| s.parse().unwrap()).unwrap_or(16);
    let hi = run(&sc, &format!(r#"{{"type":"nee","max_depth":{k}}}"#), 2048, w, 1);
    let lo = run(&sc, &format!(r#"{{"type":"nee","max_depth":{}}}"#, k - 1), 2048, w, 1);
    let r = sub(&hi, &lo);
    println!("ref exactly {k}: {:.4?}", r.mean());
    let full_hi = run(&sc, &format!(r#"{{"type":"bdpt","max_depth":{k}}}"#), spp, w, 5);
    let full_lo = run(&sc, &format!(r#"{{"type":"bdpt","max_depth":{}}}"#, k - 1), spp, w, 5);
    println!("bdpt exactly {k}: {:.4?}", sub(&full_hi, &full_lo).mean());
    let mut wsum = [0f64; 3];
    for t in 1..=(k + 1) {
        let s = k + 1 - t;
        if s == 1 && t == 1 { continue; }
        let img = run(&sc, &format!(r#"{{"type":"bdpt","max_depth":{k},"mis":false,"strategy":[{s},{t}],"weighted":false}}"#), spp, w, 7);
        let wimg = run(&sc, &format!(r#"{{"type":"bdpt","max_depth":{k},"strategy":[{s},{t}]}}"#), spp, w, 7);
        for c in 0..3 { wsum[c] += wimg.mean()[c]; }
        let m = img.mean(); let rm = r.mean();
        println!("  ({s},{t}) unweighted mean ratio {:.4?}", [m[0]/rm[0], m[1]/rm[1], m[2]/rm[2]]);
    }
    println!("sum of weighted: {:.4?}", wsum);
}
