//! Bidirectional path tracing (`bdpt`), measured: it converges to the same images as `nee` and
//! `pt` (compared after 4×4 block averaging against the measured seed-to-seed noise of both, as
//! tests/tests/correctness.rs does for pt vs nee), matches Mitsuba 3 on the Cornell box, each of
//! its strategies alone is an unbiased estimate (Veach's pyramid), its MIS-weighted strategies
//! add up to the full image, the white furnace is exactly 1, and its film (light-tracing splats)
//! survives pass splits and checkpoints.
//!
//! Noise: for two renders a, b of one integrator with different seeds, relMSE(a, b) ≈ 2σ²
//! (σ² each render's relative variance), so σ² ≈ relMSE(a, b) / 2; two independent estimates of
//! one image are then expected at relMSE σ₁² + σ₂². Every threshold below is 3× that plus a small
//! floor; relMSE is `REL_MSE_FORMULA` on 4×4 blocks. Images are tiny (lavapipe is a CPU).

use candela_tests::{gpu, mitsuba_available, render_mitsuba, scene_path, scratch};
use renderer::compile::compile;
use renderer::film::Image;
use renderer::integrators::IntegratorOptions;
use renderer::metrics::{downsample_box, rel_mse, REL_MSE_FORMULA};
use renderer::render::{render, Budget, RenderSession, RenderStats};
use renderer::scene::Scene;

/// Film side of most tests: 16×16, i.e. 4×4 blocks of 4×4 pixels.
const W: u32 = 16;

fn load(name: &str) -> Scene {
    let path = scene_path(name);
    renderer::scene::load_file(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn options(json: &str) -> IntegratorOptions {
    serde_json::from_str(json).unwrap_or_else(|e| panic!("{json}: {e}"))
}

/// Renders `scene` at w×w with integrator options given as JSON.
fn render_with(scene: &Scene, json: &str, spp: u32, w: u32, seed: u64) -> (Image, RenderStats) {
    let ctx = gpu();
    let compiled = compile(scene, w, w).expect("compile");
    let o = options(json);
    let mut s =
        RenderSession::new(&ctx, &compiled, &o, scene.render.max_depth, seed).expect("session");
    let out = render(&mut s, Budget::Spp(spp)).expect("render");
    ctx.check_validation().expect("validation layer messages");
    out
}

/// relMSE after 4×4 block averaging.
fn blocks(a: &Image, reference: &Image) -> f64 {
    rel_mse(&downsample_box(a, 4), &downsample_box(reference, 4)).unwrap()
}

/// Two renders (seeds `seed`, `seed + 1`) as one estimate: their average, and its relative
/// variance on blocks (relMSE(a, b) / 4: half of it is one render's, halved again by averaging).
fn estimate(scene: &Scene, json: &str, spp: u32, seed: u64) -> (Image, f64, RenderStats) {
    estimate_at(scene, json, spp, W, seed, 0)
}

/// `estimate` at w×w, with `crop` pixels cut from every side before anything is measured.
fn estimate_at(
    scene: &Scene,
    json: &str,
    spp: u32,
    w: u32,
    seed: u64,
    crop: u32,
) -> (Image, f64, RenderStats) {
    let (a, stats) = render_with(scene, json, spp, w, seed);
    let (b, _) = render_with(scene, json, spp, w, seed + 1);
    let (a, b) = (cropped(&a, crop), cropped(&b, crop));
    let noise = blocks(&a, &b) / 4.0;
    (combine(&a, &b, 0.5, 0.5), noise, stats)
}

/// `img` without `c` pixels on every side.
fn cropped(img: &Image, c: u32) -> Image {
    Image::from_fn(img.width - 2 * c, img.height - 2 * c, |x, y| img.get(x + c, y + c))
}

/// Tolerance for the ratio of two image means: 3%, widened to three standard deviations of the
/// mean when the estimates are noisier than that (noise: their summed block relative variance,
/// over the 16 blocks).
fn mean_tolerance(noise: f64) -> f64 {
    0.03f64.max(3.0 * (noise / 16.0).sqrt())
}

/// x·a + y·b, pixel by pixel.
fn combine(a: &Image, b: &Image, x: f32, y: f32) -> Image {
    Image::from_fn(a.width, a.height, |i, j| {
        let (p, q) = (a.get(i, j), b.get(i, j));
        [0, 1, 2].map(|c| x * p[c] + y * q[c])
    })
}

/// bdpt, nee and (unless the scene has delta lights, which pt cannot hit) pt converge to the
/// same image: means as nee's (`mean_tolerance`) and block relMSE within 3× the expected noise.
fn agree(name: &str, spp_bdpt: u32, spp_nee: u32, spp_pt: Option<u32>) {
    let scene = load(&format!("{name}.json"));
    let (bdpt, n_bdpt, stats) = estimate(&scene, r#"{"type":"bdpt"}"#, spp_bdpt, 1);
    let (nee, n_nee, _) = estimate(&scene, r#"{"type":"nee"}"#, spp_nee, 3);
    let e = blocks(&bdpt, &nee);
    let (mb, mn) = (bdpt.mean(), nee.mean());
    println!(
        "{name} {W}x{W}: bdpt {spp_bdpt} spp ({:.3} Msamples/s, {} dropped) vs nee {spp_nee} spp: \
         4x4-block relMSE {e:.3e}, expected noise {:.3e} (bdpt {n_bdpt:.3e}, nee {n_nee:.3e}); \
         means bdpt {mb:.4?} nee {mn:.4?}",
        stats.msamples_per_s,
        stats.dropped_samples,
        n_bdpt + n_nee
    );
    assert_eq!(stats.dropped_samples, 0, "{name}: bdpt dropped samples");
    let tol = mean_tolerance(n_bdpt + n_nee);
    for c in 0..3 {
        assert!(
            (mb[c] / mn[c] - 1.0).abs() < tol,
            "{name}: means differ by more than {tol:.3}: bdpt {mb:?} nee {mn:?}"
        );
    }
    assert!(
        e < 3.0 * (n_bdpt + n_nee) + 1e-4,
        "{name}: bdpt vs nee {e:.3e}, noise {:.3e}",
        n_bdpt + n_nee
    );
    let Some(spp_pt) = spp_pt else {
        println!("{name}: pt skipped: it cannot reach point, spot or directional lights");
        return;
    };
    let (pt, n_pt, _) = estimate(&scene, r#"{"type":"pt"}"#, spp_pt, 5);
    let e = blocks(&bdpt, &pt);
    println!(
        "{name} {W}x{W}: bdpt vs pt {spp_pt} spp: 4x4-block relMSE {e:.3e}, expected noise {:.3e} \
         (pt {n_pt:.3e}); mean pt {:.4?}",
        n_bdpt + n_pt,
        pt.mean()
    );
    assert!(
        e < 3.0 * (n_bdpt + n_pt) + 1e-4,
        "{name}: bdpt vs pt {e:.3e}, noise {:.3e}",
        n_bdpt + n_pt
    );
}

#[test]
fn cornell_box_agrees_with_nee_and_pt() {
    agree("cornell", 128, 256, Some(1024));
}

#[test]
fn mirror_and_glass_agree_with_nee_and_pt() {
    agree("mirror_glass", 64, 256, Some(1024));
}

/// The hard case: a tiny sphere light inside an open-bottom lamp shade.
#[test]
fn tiny_light_in_a_shade_agrees_with_nee_and_pt() {
    agree("shade", 32, 256, Some(1024));
}

/// Thin lens (aperture 0.12, focus 3.5): t = 1 connections sample the lens.
#[test]
fn thin_lens_agrees_with_nee_and_pt() {
    agree("thinlens", 128, 256, Some(1024));
}

#[test]
fn point_spot_directional_lights_agree_with_nee() {
    agree("lights", 64, 256, None);
}

/// An independent reference: Mitsuba 3's `path` integrator on the Cornell box. Rendered at 20×20
/// and compared on the central 16×16: at the film's edge Mitsuba's Gaussian filter renormalises
/// over samples inside the film only, candela's importance-sampled filter also looks outside, and
/// at this size the two-pixel border would dominate.
#[test]
fn cornell_box_matches_mitsuba() {
    assert!(
        mitsuba_available(),
        "Mitsuba 3 is not installed: run scripts/setup.sh (pip install mitsuba)"
    );
    let path = scene_path("cornell.json");
    let dir = scratch("bdpt_mitsuba_cornell");
    let mi = |seed: u64| {
        let out = dir.join(format!("mitsuba{seed}.exr"));
        let img = render_mitsuba(&path, &out, 1024, W + 4, W + 4, seed, None).expect("mitsuba");
        cropped(&img, 2)
    };
    let (m1, m2) = (mi(1), mi(2));
    let n_mi = blocks(&m1, &m2) / 4.0;
    let mitsuba = combine(&m1, &m2, 0.5, 0.5);
    let scene = load("cornell.json");
    let (bdpt, n_bdpt, _) = estimate_at(&scene, r#"{"type":"bdpt"}"#, 96, W + 4, 11, 2);
    let e = blocks(&bdpt, &mitsuba);
    let (mb, mm) = (bdpt.mean(), mitsuba.mean());
    println!(
        "cornell {W}x{W} (cropped): bdpt 2x96 spp vs Mitsuba 3 path 2x1024 spp: 4x4-block relMSE {e:.3e}, \
         expected noise {:.3e}; means bdpt {mb:.4?} mitsuba {mm:.4?}; relMSE = {REL_MSE_FORMULA}",
        n_bdpt + n_mi
    );
    for c in 0..3 {
        assert!(
            (mb[c] / mm[c] - 1.0).abs() < 0.02,
            "means differ: bdpt {mb:?} mitsuba {mm:?}"
        );
    }
    assert!(e < 3.0 * (n_bdpt + n_mi) + 2e-4, "bdpt vs Mitsuba {e:.3e}");
}

/// Veach's pyramid: for paths of k segments, each strategy (s, t) with s + t = k + 1 (all but
/// (1, 1)) rendered alone, unweighted, is an unbiased estimate of the image made by paths of
/// exactly k segments; so is their average. The reference is independent: nee at max_depth k
/// minus max_depth k − 1. The Cornell box has no delta lights or specular surfaces, so every
/// strategy can make every path.
#[test]
fn each_strategy_alone_is_unbiased() {
    let scene = load("cornell.json");
    let spp = 64;
    let nee = |d: i32| estimate(&scene, &format!(r#"{{"type":"nee","max_depth":{d}}}"#), 1024, 21);
    let mut lower = nee(1);
    for k in 2..=3 {
        let upper = nee(k);
        let exact = combine(&upper.0, &lower.0, 1.0, -1.0);
        let n_exact = upper.1 + lower.1;
        let strategies: Vec<(i32, i32)> = (1..=k + 1).map(|t| (k + 1 - t, t)).collect();
        let (mut sum, mut n_sum) = (Image::new(W, W), 0.0);
        for &(s, t) in &strategies {
            let json = format!(
                r#"{{"type":"bdpt","max_depth":{k},"mis":false,"strategy":[{s},{t}],"weighted":false}}"#
            );
            let (img, n, _) = estimate(&scene, &json, spp, 31 + 2 * t as u64);
            let e = blocks(&img, &exact);
            println!(
                "k = {k}: strategy ({s},{t}) alone, unweighted, 2x{spp} spp: 4x4-block relMSE \
                 {e:.3e} against exactly-{k} nee, expected noise {:.3e}; means {:.4?} vs {:.4?}",
                n + n_exact,
                img.mean(),
                exact.mean()
            );
            assert!(
                e < 3.0 * (n + n_exact) + 1e-4,
                "k = {k}, ({s},{t}): {e:.3e} vs noise {:.3e}",
                n + n_exact
            );
            sum = combine(&sum, &img, 1.0, 1.0);
            n_sum += n;
        }
        let count = strategies.len() as f32;
        let average = combine(&sum, &sum, 0.5 / count, 0.5 / count);
        let n_avg = n_sum / (count * count) as f64;
        let e = blocks(&average, &exact);
        println!(
            "k = {k}: average of the {count} unweighted strategies: 4x4-block relMSE {e:.3e}, \
             expected noise {:.3e}; means {:.4?} vs exactly-{k} {:.4?}",
            n_avg + n_exact,
            average.mean(),
            exact.mean()
        );
        assert!(e < 3.0 * (n_avg + n_exact) + 1e-4, "k = {k}: average {e:.3e}");
        lower = upper;
    }
}

/// The MIS-weighted strategies of one path length add up to the full image of that length, to
/// rounding: same seed, same subpaths, only the bookkeeping differs.
#[test]
fn weighted_strategies_add_up_to_the_full_image() {
    let scene = load("cornell.json");
    let fixed = r#""fixed_point_splats":true"#;
    let img = |json: String| render_with(&scene, &json, 8, W, 7).0;
    let full = combine(
        &img(format!(r#"{{"type":"bdpt","max_depth":3,{fixed}}}"#)),
        &img(format!(r#"{{"type":"bdpt","max_depth":2,{fixed}}}"#)),
        1.0,
        -1.0,
    );
    let mut sum = Image::new(W, W);
    for t in 1..=4 {
        let s = 4 - t;
        let json = format!(r#"{{"type":"bdpt","max_depth":3,"strategy":[{s},{t}],{fixed}}}"#);
        let part = img(json);
        println!("strategy ({s},{t}) weighted: mean {:.5?}", part.mean());
        sum = combine(&sum, &part, 1.0, 1.0);
    }
    let worst = sum
        .pixels
        .iter()
        .zip(&full.pixels)
        .flat_map(|(a, b)| (0..3).map(move |c| (a[c] - b[c]).abs() / (b[c].abs() + 1e-3)))
        .fold(0f32, f32::max);
    println!(
        "k = 3: sum of weighted strategies {:.5?} vs full {:.5?}, worst pixel difference {worst:.2e}",
        sum.mean(),
        full.mean()
    );
    assert!(worst < 1e-4, "weighted strategies do not add up: {worst}");
}

/// A white diffuse sphere under constant radiance 1 is exactly 1: environment emission through
/// every strategy, at unbounded depth.
#[test]
fn white_furnace_is_exactly_one() {
    let (img, stats) = render_with(&load("furnace.json"), r#"{"type":"bdpt"}"#, 32, W, 1);
    let m = img.mean();
    println!("furnace bdpt: mean {m:?}, {} dropped", stats.dropped_samples);
    for c in m {
        assert!((c - 1.0).abs() < 5e-3, "furnace mean {m:?}");
    }
    assert_eq!(stats.dropped_samples, 0);
}

/// Pass splits and checkpoints. With fixed-point splats the image is bit-identical whatever the
/// split and after a checkpoint/restore; with float atomics the camera-side accumulation is
/// bit-identical and the splats (summed in a varying order) agree to rounding; the two splat
/// encodings agree to rounding.
#[test]
fn pass_split_and_checkpoint() {
    let scene = load("cornell.json");
    let compiled = compile(&scene, W, W).unwrap();
    let ctx = gpu();
    let session = |json: &str, seed: u64| {
        RenderSession::new(&ctx, &compiled, &options(json), None, seed).unwrap()
    };
    let n = (W * W) as usize;
    for json in [
        r#"{"type":"bdpt","fixed_point_splats":true}"#,
        r#"{"type":"bdpt"}"#,
    ] {
        let exact = json.contains("fixed");
        let mut one = session(json, 42);
        one.run_pass(8).unwrap();
        let mut many = session(json, 42);
        for k in [1, 2, 1, 4] {
            many.run_pass(k).unwrap();
        }
        let (a, b) = (one.image().unwrap(), many.image().unwrap());
        let (acc_a, acc_b) = (one.accumulation().unwrap(), many.accumulation().unwrap());
        assert_eq!(acc_a.len(), one.accumulation_len());
        assert_eq!(acc_a.len(), n * if exact || !ctx.float_atomics { 3 } else { 2 });
        assert_eq!(acc_a[..n], acc_b[..n], "{json}: camera-side accumulation changed");
        let e = rel_mse(&a, &b).unwrap();
        println!("{json}: pass split relMSE {e:.2e} (float atomics on device: {})", ctx.float_atomics);
        if exact {
            assert_eq!(a.pixels, b.pixels, "{json}: pass split changed the image");
        } else {
            assert!(e < 1e-10, "{json}: pass split relMSE {e}");
        }
        let mut other = session(json, 43);
        other.run_pass(8).unwrap();
        assert_ne!(a.pixels, other.image().unwrap().pixels, "seed must matter");
        // Checkpoint after 5 spp, restore into a fresh session, finish: as if never stopped.
        let mut first = session(json, 42);
        first.run_pass(5).unwrap();
        let (acc, progress) = (first.accumulation().unwrap(), first.progress());
        drop(first);
        let mut resumed = session(json, 42);
        resumed.restore(&acc, progress).unwrap();
        resumed.run_pass(3).unwrap();
        let r = resumed.image().unwrap();
        if exact {
            assert_eq!(a.pixels, r.pixels, "{json}: checkpoint changed the image");
        } else {
            assert!(rel_mse(&r, &a).unwrap() < 1e-10, "{json}: checkpoint");
        }
        assert!(resumed.restore(&acc[..n], progress).is_err(), "short checkpoint accepted");
    }
    // Float and fixed-point splats: the same estimate to rounding.
    let mut f = session(r#"{"type":"bdpt"}"#, 5);
    let mut x = session(r#"{"type":"bdpt","fixed_point_splats":true}"#, 5);
    f.run_pass(4).unwrap();
    x.run_pass(4).unwrap();
    let e = rel_mse(&f.image().unwrap(), &x.image().unwrap()).unwrap();
    println!("float vs fixed-point splats: relMSE {e:.2e}");
    assert!(e < 1e-9, "splat encodings differ: {e}");
}
