//! Deferred many-light shading (`deferred`), measured on lavapipe at tiny films:
//!
//! - with shadows off it matches `nee` at max_depth 2 on a scene where nothing can be shadowed
//!   (a floor of diffuse and principled halves under point, spot and directional lights and a
//!   constant environment): block relMSE within 3× the seed-to-seed noise of the two estimates
//!   plus 1e-3, and the same means within 1% plus three standard errors (noise measured from four
//!   seeds each, as tests/tests/bdpt.rs does);
//! - the packed G-buffer round-trips: normals within `NORMAL_ERROR_BOUND` (1e-4 rad) and
//!   positions within 1e-5 of the depth against a fresh ray cast with the full surface on the
//!   GPU, the same material and side everywhere, and the stored depth of a floor matches a host
//!   ray cast integrated over each pixel;
//! - culling never drops more than the cutoff allows: with ~1000 lights, per pixel, the unculled
//!   image minus the culled one lies in [−ε, n_dropped · cutoff · ρ/π + ε] (n_dropped: lights
//!   outside their influence radius at that pixel, ρ the floor's reflectance, ε = 1e-5 relative
//!   for summation order), no light reaching a pixel is missing from its tile list, and overflowed
//!   tiles (shaded against every light) give the same image;
//! - the per-pixel cap keeps the strongest light; the white furnace renders 1;
//! - batches of 1, 3 and all samples per dispatch accumulate the same sums bit for bit;
//! - shadows on against `nee` max_depth 2 on a scene with an occluder, and the Cornell box
//!   (whose area light `deferred` approximates by point-like lights), are reported (printed)
//!   with loose sanity bounds.

use candela_tests::{gpu, scene_path, seed_average};
use renderer::compile::compile;
use renderer::film::Image;
use renderer::integrators::IntegratorOptions;
use renderer::metrics::{downsample_box, rel_mse, REL_MSE_FORMULA};
use renderer::render::{render, Budget, RenderSession, RenderStats};
use renderer::scene::Scene;

fn load(name: &str) -> Scene {
    let path = scene_path(name);
    renderer::scene::load_file(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn parse(json: &str) -> Scene {
    renderer::scene::load_str(json, None).unwrap_or_else(|e| panic!("scene: {e}\n{json}"))
}

fn options(json: &str) -> IntegratorOptions {
    serde_json::from_str(json).unwrap_or_else(|e| panic!("{json}: {e}"))
}

/// Serialises this binary's GPU work: tests/tests/whitted.rs observed a render on the shared
/// lavapipe context come out slightly different while other tests of the process rendered
/// concurrently, and several tests here compare images bit for bit.
static GPU_LOCK: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn gpu_lock() -> std::sync::MutexGuard<'static, ()> {
    GPU_LOCK.lock().unwrap_or_else(|e| e.into_inner())
}

/// Renders `scene` at `size` with integrator options given as JSON, in passes of `pass` samples.
fn render_passes(
    scene: &Scene,
    json: &str,
    spp: u32,
    size: (u32, u32),
    seed: u64,
    pass: Option<u32>,
) -> (Image, RenderStats) {
    let compiled = compile(scene, size.0, size.1).expect("compile");
    let o = options(json);
    let _serial = gpu_lock();
    let ctx = gpu();
    let mut s =
        RenderSession::new(&ctx, &compiled, &o, scene.render.max_depth, seed).expect("session");
    let out = match pass {
        None => render(&mut s, Budget::Spp(spp)).expect("render"),
        Some(p) => {
            while s.spp() < spp {
                s.run_pass(p.min(spp - s.spp())).expect("pass");
            }
            (s.image().expect("image"), s.stats())
        }
    };
    ctx.check_validation().expect("validation layer messages");
    out
}

fn render_with(
    scene: &Scene,
    json: &str,
    spp: u32,
    size: (u32, u32),
    seed: u64,
) -> (Image, RenderStats) {
    render_passes(scene, json, spp, size, seed, None)
}

/// An estimate from four seeds: their mean and its relative variance on 4×4 blocks
/// (`candela_tests::seed_average`), so two independent estimates are expected at relMSE
/// noise₁ + noise₂.
struct Estimate {
    img: Image,
    parts: Vec<Image>,
    noise: f64,
}

const PARTS: usize = 4;

fn estimate(scene: &Scene, json: &str, spp: u32, size: (u32, u32)) -> Estimate {
    let parts: Vec<Image> = (0..PARTS as u64)
        .map(|i| render_with(scene, json, spp, size, 7 + 1000 * i).0)
        .collect();
    let (img, noise) = seed_average(&parts, 4);
    Estimate { img, parts, noise }
}

/// Mean over all pixels per channel and its standard error from the parts.
fn mean_se(e: &Estimate) -> ([f64; 3], [f64; 3]) {
    let mean_of = |img: &Image| {
        let mut m = [0f64; 3];
        for p in &img.pixels {
            for c in 0..3 {
                m[c] += p[c] as f64 / img.pixels.len() as f64;
            }
        }
        m
    };
    let m = mean_of(&e.img);
    let parts: Vec<[f64; 3]> = e.parts.iter().map(mean_of).collect();
    let se = [0, 1, 2].map(|c| {
        let var = parts.iter().map(|p| (p[c] - m[c]).powi(2)).sum::<f64>() / (PARTS as f64 - 1.0);
        (var / PARTS as f64).sqrt()
    });
    (m, se)
}

/// Block relMSE of `a` against `b` and the threshold 3·(noise_a + noise_b) + floor; asserts
/// it when `strict`, and the means within 1% + 3 standard errors. Returns (relMSE, threshold).
fn compare(what: &str, a: &Estimate, b: &Estimate, floor: f64, strict: bool) -> (f64, f64) {
    let r = rel_mse(&downsample_box(&a.img, 4), &downsample_box(&b.img, 4)).unwrap();
    let limit = 3.0 * (a.noise + b.noise) + floor;
    let (ma, sa) = mean_se(a);
    let (mb, sb) = mean_se(b);
    println!(
        "{what}: block relMSE {r:.3e} (threshold {limit:.3e}; noise {:.2e} + {:.2e}); means {ma:.4?} vs {mb:.4?} (SE {:.1e}, {:.1e}) [{REL_MSE_FORMULA}]",
        a.noise, b.noise, sa[1], sb[1]
    );
    if strict {
        assert!(r < limit, "{what}: relMSE {r} ≥ {limit}");
        for c in 0..3 {
            let tol = 0.01 * mb[c] + 3.0 * (sa[c] * sa[c] + sb[c] * sb[c]).sqrt();
            assert!(
                (ma[c] - mb[c]).abs() < tol,
                "{what}: means differ: {ma:?} ± {sa:?} vs {mb:?} ± {sb:?}"
            );
        }
    }
    (r, limit)
}

/// A floor (diffuse left half, principled right half, facing +y) seen from above, lit by the
/// given lights JSON; optional extra objects (occluders) and environment.
fn floor_scene(lights: &str, extra_objects: &str, environment: &str) -> String {
    format!(
        r#"{{"version": 1,
  "camera": {{"position": [0, 3, 3.2], "look_at": [0, 0, 0], "fov_y": 50}},
  "film": {{"width": 16, "height": 16}},
  "materials": {{
    "matte": {{"type": "diffuse", "reflectance": [0.7, 0.6, 0.5]}},
    "plastic": {{"type": "principled", "base_color": [0.3, 0.5, 0.8], "roughness": 0.4}},
    "grey": {{"type": "diffuse", "reflectance": 0.5}}
  }},
  "objects": [
    {{"type": "quad", "origin": [-2, 0, -2], "edge_u": [0, 0, 4], "edge_v": [2, 0, 0], "material": "matte"}},
    {{"type": "quad", "origin": [0, 0, -2], "edge_u": [0, 0, 4], "edge_v": [2, 0, 0], "material": "plastic"}}
    {extra_objects}
  ],
  "lights": [{lights}]
  {environment}
}}"#
    )
}

const FEW_LIGHTS: &str = r#"
    {"type": "point", "position": [-0.8, 1.2, 0.3], "intensity": [2, 1.5, 1]},
    {"type": "point", "position": [1.1, 0.6, -0.7], "intensity": [0.5, 0.8, 1.2]},
    {"type": "spot", "position": [0.2, 1.5, 0.5], "look_at": [0.6, 0, 0.2], "intensity": [4, 4, 3],
     "cutoff_angle": 30, "beam_width": 15},
    {"type": "spot", "position": [-1.0, 1.0, -1.0], "look_at": [-0.4, 0, -0.2], "intensity": [1, 3, 1],
     "cutoff_angle": 25},
    {"type": "directional", "direction": [0.3, -1, -0.2], "irradiance": [0.3, 0.3, 0.35]}"#;

/// A constant environment (the ambient term's test: unoccluded on the floor).
const SKY: &str = r#", "environment": {"type": "constant", "radiance": [0.2, 0.25, 0.3]}"#;

#[test]
fn matches_nee_at_max_depth_2_without_occluders() {
    // Every light lies above a single plane: nothing can be shadowed, so shadow rays change
    // nothing and nee at max_depth 2 (direct light) is the exact reference. The constant
    // environment checks the ambient term (unoccluded on a plane, hence exact).
    let scene = parse(&floor_scene(FEW_LIGHTS, "", SKY));
    let size = (16, 16);
    let nee = estimate(&scene, r#"{"type":"nee","max_depth":2}"#, 128, size);
    let def = estimate(
        &scene,
        r#"{"type":"deferred","max_depth":2,"cutoff":0}"#,
        16,
        size,
    );
    compare("deferred (cutoff 0) vs nee", &def, &nee, 1e-3, true);
    // The default cutoff (1e-3) drops nothing visible here (shadows are tested with an
    // occluder below and on lights.json).
    let def_cut = estimate(&scene, r#"{"type":"deferred","max_depth":2}"#, 16, size);
    compare(
        "deferred (default cutoff) vs nee",
        &def_cut,
        &nee,
        1e-3,
        true,
    );
}

#[test]
fn gbuffer_round_trips_normals_and_positions() {
    use renderer::integrators::deferred::gbuffer::NORMAL_ERROR_BOUND;
    // Spheres, meshes with interpolated normals and textures, boxes, a thin-lens camera (rays
    // from different origins), an environment map.
    for name in [
        "lights.json",
        "cornell.json",
        "thinlens.json",
        "textured_mesh.json",
        "envmap.json",
    ] {
        let scene = load(name);
        let mut worst = [0f32; 3];
        let mut hits = 0;
        for seed in 0..2 {
            let (img, _) = render_with(
                &scene,
                r#"{"type":"deferred","max_depth":2,"debug":"gbuffer_error"}"#,
                1,
                (16, 16),
                seed,
            );
            for p in &img.pixels {
                for c in 0..3 {
                    worst[c] = worst[c].max(p[c]);
                }
            }
            hits += img.pixels.len();
        }
        println!(
            "{name}: G-buffer against a fresh ray cast over {hits} samples: worst normal angle {:.2e} rad, worst position error {:.2e} × depth, mismatches {}",
            worst[0], worst[1], worst[2]
        );
        assert!(
            worst[0] <= NORMAL_ERROR_BOUND,
            "{name}: normal error {}",
            worst[0]
        );
        assert!(worst[1] <= 1e-5, "{name}: position error {}", worst[1]);
        assert_eq!(worst[2], 0.0, "{name}: hit/material/side mismatch");
    }
}

#[test]
fn gbuffer_depth_and_normal_match_a_host_ray_cast() {
    use glam::DVec3;
    // The floor seen from above: the debug views average the stored depth and the decoded
    // normal over the pixel (box filter); the host integrates the same over 16×16 sub-pixels.
    let scene = parse(&floor_scene(FEW_LIGHTS, "", ""));
    let (w, h) = (16u32, 16u32);
    let spp = 64;
    let (depth, _) = render_with(
        &scene,
        r#"{"type":"deferred","debug":"depth"}"#,
        spp,
        (w, h),
        3,
    );
    let (normal, _) = render_with(
        &scene,
        r#"{"type":"deferred","debug":"normal"}"#,
        spp,
        (w, h),
        3,
    );
    let eye = DVec3::new(0.0, 3.0, 3.2);
    let forward = (DVec3::ZERO - eye).normalize();
    let right = forward.cross(DVec3::Y).normalize();
    let up = right.cross(forward);
    let tan_half = (50f64.to_radians() * 0.5).tan();
    let (mut worst_d, mut worst_z, mut worst_n, mut compared) = (0f64, 0f64, 0f64, 0);
    for y in 0..h {
        for x in 0..w {
            // Host ray cast against y = 0 inside the floor's square, 16×16 sub-pixels.
            let (mut sum, mut sum2, mut n) = (0.0, 0.0, 0);
            for j in 0..16 {
                for i in 0..16 {
                    let fx = x as f64 + (i as f64 + 0.5) / 16.0;
                    let fy = y as f64 + (j as f64 + 0.5) / 16.0;
                    let sx = (2.0 * fx / w as f64 - 1.0) * tan_half;
                    let sy = (1.0 - 2.0 * fy / h as f64) * tan_half;
                    let d = (forward + sx * right + sy * up).normalize();
                    let t = -eye.y / d.y;
                    let p = eye + t * d;
                    if t > 0.0 && p.x.abs() < 2.0 && p.z.abs() < 2.0 {
                        sum += t;
                        sum2 += t * t;
                        n += 1;
                    }
                }
            }
            if n < 256 {
                continue; // pixels on the floor's edge
            }
            let host = sum / 256.0;
            let sigma = (sum2 / 256.0 - host * host).max(0.0).sqrt();
            let gpu_d = depth.get(x, y)[0] as f64;
            // The GPU's `spp` jittered samples estimate the pixel mean with standard error
            // σ/√spp, σ the depth's spread over the pixel (from the host's sub-pixels): allow
            // 4.5 standard errors plus f32 rounding.
            let z = (gpu_d - host).abs() / (sigma / (spp as f64).sqrt() + 1e-6 * host);
            worst_d = worst_d.max((gpu_d - host).abs() / host);
            worst_z = worst_z.max(z);
            let nv = normal.get(x, y);
            worst_n = worst_n.max(
                ((nv[0] as f64).powi(2) + (nv[1] as f64 - 1.0).powi(2) + (nv[2] as f64).powi(2))
                    .sqrt(),
            );
            compared += 1;
        }
    }
    println!("floor: {compared} pixels; depth vs host ray cast worst relative error {worst_d:.2e} ({worst_z:.2} standard errors), normal worst |n − (0,1,0)| {worst_n:.2e}");
    assert!(compared > 100, "{compared}");
    assert!(
        worst_z < 4.5,
        "depth off by {worst_z} standard errors ({worst_d} relative)"
    );
    assert!(worst_n < 1e-4, "normal {worst_n}");
}

/// A floor lit by `n` lights (¾ points, ¼ spots pointing down) scattered above it with a fixed
/// pseudo-random generator (the Rust twin of scenes/make_many_lights.py), total intensity
/// `total` split evenly.
fn many_lights_scene(n: usize, total: f32) -> String {
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut rnd = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let each = total / n as f32;
    let lights: Vec<String> = (0..n)
        .map(|i| {
            let (x, z, y) = (rnd() * 4.0 - 2.0, rnd() * 4.0 - 2.0, 0.05 + rnd() * 0.6);
            let c = [0.5 + rnd(), 0.5 + rnd(), 0.5 + rnd()].map(|v| v as f32 * each);
            if i % 4 == 3 {
                format!(
                    r#"{{"type":"spot","position":[{x},{y},{z}],"look_at":[{},0,{}],"intensity":[{},{},{}],"cutoff_angle":40}}"#,
                    x + 0.2,
                    z,
                    c[0],
                    c[1],
                    c[2]
                )
            } else {
                format!(
                    r#"{{"type":"point","position":[{x},{y},{z}],"intensity":[{},{},{}]}}"#,
                    c[0], c[1], c[2]
                )
            }
        })
        .collect();
    // One diffuse floor (reflectance ρ = 0.7) for the bound n_dropped · cutoff · ρ/π.
    floor_scene(&lights.join(",\n"), "", "")
        .replace(r#""material": "plastic""#, r#""material": "matte""#)
}

#[test]
fn culling_of_1000_lights_stays_within_the_cutoff_bound() {
    let n = 1024;
    let scene = parse(&many_lights_scene(n, 40.0));
    let size = (48, 48);
    let cutoff = 0.2f32;
    let rho = 0.7f32;
    let culled_json = format!(r#"{{"type":"deferred","max_depth":2,"cutoff":{cutoff}}}"#);
    // One sample, same seed: the same jittered rays in every render, so the images differ
    // only by the lights culling skipped.
    let (culled, st) = render_with(&scene, &culled_json, 1, size, 5);
    let (unculled, _) = render_with(
        &scene,
        r#"{"type":"deferred","max_depth":2,"cull":false}"#,
        1,
        size,
        5,
    );
    let (counts, _) = render_with(
        &scene,
        &format!(r#"{{"type":"deferred","max_depth":2,"cutoff":{cutoff},"debug":"tile_lights"}}"#),
        1,
        size,
        5,
    );
    let details = st.details.clone().expect("details");
    println!("details: {details}");
    let mean_list = details["tile_lists"]["mean_lights"].as_f64().unwrap();
    let tested = details["lights_per_pixel"]["tested"].as_f64().unwrap();
    let shaded = details["lights_per_pixel"]["shaded"].as_f64().unwrap();
    println!("lights per pixel: {tested:.1} tested, {shaded:.1} shaded");
    assert!(
        shaded > 0.0 && shaded <= tested && tested < n as f64,
        "{tested} {shaded}"
    );
    assert!(
        mean_list < 0.5 * n as f64,
        "culling kept {mean_list} of {n} lights per tile"
    );
    let (mut worst_ratio, mut max_diff, mut dropped_total) = (0f64, 0f32, 0f64);
    for i in 0..culled.pixels.len() {
        let (a, b, k) = (culled.pixels[i], unculled.pixels[i], counts.pixels[i]);
        let reach = k[1];
        // Every light that reaches the pixel was in its tile's list.
        assert!(
            reach <= k[0],
            "pixel {i}: {reach} lights reach it, its tile lists {}",
            k[0]
        );
        let dropped = n as f32 - reach;
        dropped_total += dropped as f64;
        let bound = dropped * cutoff * rho / std::f32::consts::PI;
        for c in 0..3 {
            let diff = b[c] - a[c];
            let eps = 1e-5 * b[c].abs() + 1e-7;
            assert!(
                diff >= -eps && diff <= bound + eps,
                "pixel {i} channel {c}: unculled {} culled {} differ by {diff}, bound {bound} ({dropped} lights dropped)",
                b[c],
                a[c]
            );
            max_diff = max_diff.max(diff);
            if bound > 0.0 {
                worst_ratio = worst_ratio.max((diff / bound) as f64);
            }
        }
    }
    println!(
        "{n} lights, cutoff {cutoff}: mean tile list {mean_list:.1}, mean dropped per pixel {:.1}, largest difference {max_diff:.3e}, largest difference / bound {worst_ratio:.3}",
        dropped_total / culled.pixels.len() as f64
    );
    assert!(
        max_diff > 0.0,
        "culling dropped nothing: the test would be vacuous"
    );
    // Overflowing tile lists fall back to every light: the same sums in the same order.
    let (small, st_small) = render_with(
        &scene,
        &format!(r#"{{"type":"deferred","max_depth":2,"cutoff":{cutoff},"tile_capacity":8}}"#),
        1,
        size,
        5,
    );
    let over = st_small.details.unwrap()["tile_lists"]["overflowed_tiles"]
        .as_u64()
        .unwrap();
    assert!(over > 0, "no tile overflowed with capacity 8");
    assert_eq!(
        small.pixels, culled.pixels,
        "overflowed tiles shade differently"
    );
}

#[test]
fn per_pixel_cap_keeps_the_strongest_light() {
    // Two lights at one place, one ten times stronger: with a cap of 1 only it is shaded.
    let both = parse(&floor_scene(
        r#"{"type": "point", "position": [0.3, 1, 0.2], "intensity": [1, 1, 1]},
           {"type": "point", "position": [0.3, 1, 0.2], "intensity": [10, 8, 6]}"#,
        "",
        "",
    ));
    let strong = parse(&floor_scene(
        r#"{"type": "point", "position": [0.3, 1, 0.2], "intensity": [10, 8, 6]}"#,
        "",
        "",
    ));
    let (capped, st) = render_with(
        &both,
        r#"{"type":"deferred","max_lights_per_pixel":1}"#,
        2,
        (16, 16),
        1,
    );
    let d = st.details.unwrap();
    assert_eq!(d["lights_per_pixel"]["shaded"], 1.0, "{d}");
    assert_eq!(d["lights_per_pixel"]["tested"], 2.0, "{d}");
    let alone = render_with(&strong, r#"{"type":"deferred"}"#, 2, (16, 16), 1).0;
    let all = render_with(&both, r#"{"type":"deferred"}"#, 2, (16, 16), 1).0;
    assert_eq!(capped.pixels, alone.pixels);
    assert_ne!(all.pixels, alone.pixels);
}

#[test]
fn white_furnace_is_one_and_passes_split_freely() {
    // A white diffuse sphere under constant radiance 1: the ambient term's BSDF sample has
    // weight 1, so every sample is exactly 1 (the sphere is convex: nothing is occluded).
    let scene = load("furnace.json");
    let (img, st) = render_passes(&scene, r#"{"type":"deferred"}"#, 4, (16, 16), 2, Some(1));
    let worst = img
        .pixels
        .iter()
        .flatten()
        .map(|v| (v - 1.0).abs())
        .fold(0f32, f32::max);
    println!(
        "furnace: worst |L − 1| = {worst:.2e}; details {}",
        st.details.unwrap()
    );
    assert!(worst < 1e-4, "{worst}");
    // Samples are keyed by index: 1+3 samples in two passes equal 4 in one.
    let scene = parse(&floor_scene(FEW_LIGHTS, "", ""));
    let a = render_passes(&scene, r#"{"type":"deferred"}"#, 4, (16, 16), 9, Some(3)).0;
    let b = render_passes(&scene, r#"{"type":"deferred"}"#, 4, (16, 16), 9, Some(4)).0;
    assert_eq!(a.pixels, b.pixels);
}

#[test]
fn batches_of_any_size_accumulate_the_same_sums() {
    // Samples are keyed by index and the shade stage adds a batch's samples in sample order, so
    // one sample per dispatch, batches of 2 and the automatic batch give the same accumulation,
    // odd half included, bit for bit — on a 24×16 film (two tiles, one partial) with culling on
    // and the environment. On lavapipe the session hands a pass to the integrator in
    // LLVMPIPE_MAX_DISPATCHES chunks (render/session.rs), so the pass has 2·that + 2 samples:
    // chunks of 2 and two of 3, which batches of 2 cut into 2 + 1. The automatic batch's session
    // has a warm-up pass and a reset first, which its details and image must not show.
    let scene = parse(&floor_scene(FEW_LIGHTS, "", SKY));
    let (w, h) = (24u64, 16u64);
    let compiled = compile(&scene, w as u32, h as u32).expect("compile");
    let _serial = gpu_lock();
    let ctx = gpu();
    let split = renderer::render::LLVMPIPE_MAX_DISPATCHES;
    let spp = 2 * split + 2;
    let chunks: Vec<u32> = if ctx.info.name.contains("llvmpipe") {
        (0..split).map(|i| if i < 2 { 3 } else { 2 }).collect()
    } else {
        vec![spp]
    };
    assert_eq!(chunks.iter().sum::<u32>(), spp);
    let run = |batch: Option<u32>| {
        let extra = batch.map_or(String::new(), |b| format!(r#","samples_per_batch":{b}"#));
        let json = format!(r#"{{"type":"deferred","max_depth":2,"cutoff":0.05{extra}}}"#);
        let mut s =
            RenderSession::new(&ctx, &compiled, &options(&json), None, 11).expect("session");
        if batch.is_none() {
            // A warm-up pass and a reset: the details then speak of the render alone.
            s.run_pass(1).expect("warm-up pass");
            s.reset(11).expect("reset");
        }
        s.run_pass(spp).expect("pass");
        (s.accumulation().expect("accumulation"), s.stats())
    };
    let (one, st_one) = run(Some(1));
    let d_one = st_one.details.clone().expect("details");
    assert_eq!(d_one["batches"].as_u64(), Some(spp as u64));
    for batch in [Some(2), None] {
        let (acc, st) = run(batch);
        let d = st.details.clone().expect("details");
        let b = d["samples_per_batch"].as_u64().unwrap();
        println!("batch {b}: rays {}, details {d}", st.rays);
        // The batches recorded, and the per-sample slices allocated for them.
        let batches: u64 = chunks.iter().map(|&c| c.div_ceil(b as u32) as u64).sum();
        assert_eq!(d["batches"].as_u64(), Some(batches), "{d}");
        assert!(batches < spp as u64);
        assert_eq!(d["memory_bytes"]["gbuffer"].as_u64(), Some(b * w * h * 16));
        assert_eq!(d["memory_bytes"]["tile_counts"].as_u64(), Some(b * 2 * 4));
        assert!(acc.iter().any(|p| p[0] > 0.0), "black image");
        let differ = acc.iter().zip(&one).filter(|(a, b)| a != b).count();
        assert_eq!(
            differ, 0,
            "batch {b}: {differ} accumulation entries differ from batch 1"
        );
        assert_eq!(st.rays, st_one.rays);
        assert_eq!(d["lights_per_pixel"], d_one["lights_per_pixel"]);
        assert!(d["lights_per_pixel"]["pixel_samples"].as_u64().unwrap() > 0);
        // The stage timings count every sample of a batch (where the queue has timestamps).
        let ms = d["stage_ms"]["gbuffer"].as_f64().unwrap();
        let per = d["stage_ms_per_sample"]["gbuffer"].as_f64().unwrap();
        if ms > 0.0 {
            assert!(
                (ms / per - spp as f64).abs() < 1e-6,
                "{ms} ms over {per} ms per sample"
            );
        }
    }
    ctx.check_validation().expect("validation layer messages");
}

#[test]
fn emitters_seen_directly_match_nee_at_max_depth_1() {
    let scene = load("cornell.json");
    let size = (16, 16);
    let nee = estimate(&scene, r#"{"type":"nee","max_depth":1}"#, 8, size);
    let def = estimate(&scene, r#"{"type":"deferred","max_depth":1}"#, 8, size);
    // Same camera rays from the same random numbers: identical images.
    assert_eq!(def.img.pixels, nee.img.pixels);
}

#[test]
fn shadows_against_nee_with_an_occluder_report() {
    // A grey box floats between the lights and the floor: shadows matter.
    let scene = parse(&floor_scene(
        FEW_LIGHTS,
        r#", {"type": "box", "min": [-0.5, 0.3, -0.4], "max": [0.3, 0.5, 0.4], "material": "grey"}"#,
        "",
    ));
    let size = (16, 16);
    let nee = estimate(&scene, r#"{"type":"nee","max_depth":2}"#, 128, size);
    let def = estimate(
        &scene,
        r#"{"type":"deferred","max_depth":2,"shadows":true,"cutoff":0}"#,
        16,
        size,
    );
    let unshadowed = estimate(
        &scene,
        r#"{"type":"deferred","max_depth":2,"cutoff":0}"#,
        16,
        size,
    );
    // With point, spot and directional lights shadow rays are exact: asserted like the
    // unoccluded case. Without shadows the difference is large (printed).
    compare(
        "occluder: deferred shadows on vs nee",
        &def,
        &nee,
        1e-3,
        true,
    );
    let (r, limit) = compare(
        "occluder: deferred shadows off vs nee",
        &unshadowed,
        &nee,
        1e-3,
        false,
    );
    assert!(
        r > limit,
        "the occluder should matter without shadows: relMSE {r} ≤ {limit}"
    );
}

#[test]
fn cornell_box_against_nee_report() {
    // The area light becomes two cosine-weighted point-like lights (one per triangle), exact in
    // the far field only: the relMSE against nee is reported, with a loose sanity bound.
    let scene = load("cornell.json");
    let size = (16, 16);
    let nee = estimate(&scene, r#"{"type":"nee","max_depth":2}"#, 64, size);
    let def = estimate(
        &scene,
        r#"{"type":"deferred","max_depth":2,"shadows":true}"#,
        16,
        size,
    );
    let (r, _) = compare(
        "cornell: deferred (shadows) vs nee max_depth 2",
        &def,
        &nee,
        0.0,
        false,
    );
    assert!(r.is_finite() && r < 0.5, "cornell relMSE {r}");
}

#[test]
fn merging_keeps_the_far_field_of_many_small_lights() {
    // 216 lights of I = 0.01 in a 0.1-wide cluster 2 above the floor: at cutoff 0.02 each has
    // radius 0.71 and alone is culled everywhere on the floor, but together they deliver ~0.5.
    // With merge_radius 1.5 they become one light of the summed intensity at their centroid.
    let mut lights = Vec::new();
    for i in 0..6 {
        for j in 0..6 {
            for k in 0..6 {
                let p = [
                    0.05 + 0.02 * i as f32,
                    2.05 + 0.02 * j as f32,
                    0.05 + 0.02 * k as f32,
                ];
                lights.push(format!(
                    r#"{{"type":"point","position":[{},{},{}],"intensity":[0.01,0.01,0.01]}}"#,
                    p[0], p[1], p[2]
                ));
            }
        }
    }
    let scene = parse(&floor_scene(&lights.join(","), "", ""));
    let size = (16, 16);
    let exact = render_with(&scene, r#"{"type":"deferred","cull":false}"#, 4, size, 3).0;
    let (merged, st) = render_with(
        &scene,
        r#"{"type":"deferred","cutoff":0.02,"merge_radius":1.5}"#,
        4,
        size,
        3,
    );
    let culled = render_with(&scene, r#"{"type":"deferred","cutoff":0.02}"#, 4, size, 3).0;
    let d = st.details.unwrap();
    assert_eq!(d["lights"]["merged_from"], 216, "{d}");
    assert_eq!(d["lights"]["merged_into"], 1, "{d}");
    let r_merged = rel_mse(&merged, &exact).unwrap();
    let r_culled = rel_mse(&culled, &exact).unwrap();
    println!("216 clustered lights: relMSE against all lights unculled: merged {r_merged:.2e}, culled without merging {r_culled:.2e}");
    // Cluster size 0.1 at distance ≥ 2: the merged light's relative error is O((0.1/2)²).
    assert!(r_merged < 1e-4, "{r_merged}");
    assert!(r_culled > 0.1, "{r_culled}");
}

#[test]
fn candela_render_takes_deferred_options() {
    use candela_tests::{run_candela, scratch, text};
    let dir = scratch("deferred_cli");
    let out = dir.join("out.exr");
    let o = run_candela(&[
        "render",
        "scenes/cornell.json",
        "-o",
        out.to_str().unwrap(),
        "--integrator",
        "deferred",
        "--options",
        r#"{"shadows": true, "cutoff": 0.01, "max_lights_per_pixel": 4}"#,
        "--spp",
        "2",
        "--width",
        "16",
        "--height",
        "16",
        "--json",
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json report");
    assert_eq!(v["integrator"], "deferred");
    let d = &v["details"];
    assert_eq!(d["gbuffer_bytes_per_pixel"], 16);
    assert_eq!(d["options"]["shadows"], true);
    assert_eq!(d["lights"]["scene_triangle"], 2, "{d}");
    assert!(d["stage_ms"]["shade"].as_f64().unwrap() >= 0.0);
    // Bad values are refused with the field named.
    let bad = run_candela(&[
        "render",
        "scenes/cornell.json",
        "-o",
        out.to_str().unwrap(),
        "--integrator",
        "deferred",
        "--options",
        r#"{"max_lights_per_pixel": 99}"#,
        "--spp",
        "1",
    ]);
    assert!(!bad.status.success());
    assert!(
        text(&bad.stderr).contains("max_lights_per_pixel"),
        "{}",
        text(&bad.stderr)
    );
}

#[test]
fn matches_nee_with_shadows_on_point_spot_directional_and_environment_lights() {
    // Scenes without area lights: with shadow rays, deferred computes exactly nee's direct
    // light (point, spot and directional lights among spheres and a box; an environment map
    // lighting spheres and a rough conductor, through the ambient term's BSDF sample).
    for (name, nee_spp, def_spp) in [("lights.json", 128, 16), ("envmap.json", 128, 32)] {
        let scene = load(name);
        let size = (16, 16);
        let nee = estimate(&scene, r#"{"type":"nee","max_depth":2}"#, nee_spp, size);
        let def = estimate(
            &scene,
            r#"{"type":"deferred","max_depth":2,"shadows":true,"cutoff":0}"#,
            def_spp,
            size,
        );
        compare(
            &format!("{name}: deferred (shadows) vs nee"),
            &def,
            &nee,
            1e-3,
            true,
        );
    }
}

#[test]
fn cone_culling_skips_only_lights_that_cannot_reach() {
    // 64 narrow spots (10°) pointing straight down from 0.5 above the floor, unbounded radii
    // (cutoff 0): only their cones cull. A culled light contributes exactly nothing, so the
    // image equals the unculled one bit for bit, while the tile lists hold a fraction of them.
    let mut lights = Vec::new();
    for i in 0..8 {
        for j in 0..8 {
            let (x, z) = (-1.75 + 0.5 * i as f32, -1.75 + 0.5 * j as f32);
            lights.push(format!(
                r#"{{"type":"spot","position":[{x},0.5,{z}],"look_at":[{x},0,{z}],"intensity":[1,1,1],"cutoff_angle":10}}"#
            ));
        }
    }
    let scene = parse(&floor_scene(&lights.join(","), "", ""));
    let size = (48, 48);
    let (culled, st) = render_with(&scene, r#"{"type":"deferred","cutoff":0}"#, 1, size, 4);
    let unculled = render_with(&scene, r#"{"type":"deferred","cull":false}"#, 1, size, 4).0;
    let mean = st.details.unwrap()["tile_lists"]["mean_lights"]
        .as_f64()
        .unwrap();
    println!("64 narrow spots, cutoff 0: mean tile list {mean:.1}");
    assert!(mean < 32.0, "cones culled little: {mean} of 64 per tile");
    assert_eq!(culled.pixels, unculled.pixels);
    // The Cornell box's light (two cosine lights, a hemisphere each) likewise.
    let cornell = load("cornell.json");
    let a = render_with(
        &cornell,
        r#"{"type":"deferred","cutoff":0}"#,
        1,
        (16, 16),
        4,
    )
    .0;
    let b = render_with(
        &cornell,
        r#"{"type":"deferred","cull":false}"#,
        1,
        (16, 16),
        4,
    )
    .0;
    assert_eq!(a.pixels, b.pixels);
}

#[test]
fn nan_samples_are_dropped_and_counted() {
    // The kernel test hook poisons every sample whose index is 3 mod 7, in the three-stage path
    // (max_depth 2) and in the emitters-only kernel (max_depth 1): 14 samples hold two per pixel.
    let scene = load("furnace.json");
    let compiled = compile(&scene, 8, 8).unwrap();
    let _serial = gpu_lock();
    let ctx = gpu();
    for json in [
        r#"{"type":"deferred"}"#,
        r#"{"type":"deferred","max_depth":1}"#,
    ] {
        let mut s = RenderSession::new(&ctx, &compiled, &options(json), None, 9).unwrap();
        s.set_debug_flags(renderer::layout::PUSH_FLAG_INJECT_NAN);
        s.run_pass(10).unwrap();
        s.run_pass(4).unwrap();
        let img = s.image().unwrap();
        assert_eq!(s.stats().dropped_samples, 2 * 64, "{json}");
        assert!(img.pixels.iter().flatten().all(|v| v.is_finite()), "{json}");
    }
    ctx.check_validation().expect("validation layer messages");
}
