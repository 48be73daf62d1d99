//! `whitted` (classic ray tracing), measured on lavapipe at tiny sizes:
//! - analytic: spheres in front of emissive checker walls under a constant environment (glass,
//!   IOR 1.5; a gold conductor with eta/k Fresnel beside glass and a smooth principled metal
//!   with Schlick Fresnel), and a smooth principled plastic (Lambert lit by a point light with
//!   shadow rays, ambient, a Fresnel coat) beside gold and glass, rendered without pixel jitter
//!   (rays through pixel centres) and compared per pixel with an independent f64 tracer written
//!   here (ray–sphere, Snell, exact dielectric and conductor Fresnel, both branches followed to
//!   max_depth, the same 1e-4 weight cut-off). Pixels whose f64 value changes under a
//!   1/1000-pixel nudge of the ray (an edge or silhouette) are left out; the others must agree
//!   within 1e-4 + 1e-4·value per channel;
//! - `whitted` equals `nee` at max_depth 2 under one delta light (point, spot, directional;
//!   diffuse, phong, rough principled and rough conductor surfaces): same camera rays, same
//!   BSDFs, no randomness left in nee's estimate;
//! - area lights: its fixed quadrature converges to nee's direct light (max_depth 2);
//! - white furnace: a white diffuse sphere under constant radiance 1 is 1 (the ambient term);
//! - each max_depth step only adds light (mirror_glass at 1..10 and −1, pixel by pixel);
//! - determinism: without jitter 1 spp and 16 spp (with another seed) give the same image; with
//!   jitter they differ only by anti-aliasing;
//! - passes give the same image however they are split (lavapipe's loop limiter is avoided);
//! - a report of its relMSE against nee on the Cornell box (no indirect light: darker);
//! - bad options are refused, naming the field.

use candela_tests::{assert_bad_input, gpu, run_candela, scene_path};
use glam::DVec3;
use renderer::compile::compile;
use renderer::film::Image;
use renderer::integrators::IntegratorOptions;
use renderer::metrics::{downsample_box, rel_mse};
use renderer::render::{render, Budget, RenderSession, RenderStats};
use renderer::scene::Scene;

fn options(json: &str) -> IntegratorOptions {
    serde_json::from_str(json).unwrap_or_else(|e| panic!("{json}: {e}"))
}

fn load_json(json: &str) -> Scene {
    renderer::scene::load_str(json, None).unwrap_or_else(|e| panic!("{e}\n{json}"))
}

/// Samples per pixel in one pass. lavapipe (llvmpipe) silently ends every loop of an
/// invocation once 65535 iterations have run in all of them together (Mesa gallivm's
/// `LP_MAX_TGSI_LOOP_ITERATIONS`; see tests/tests/accel_grid.rs). `render` sizes passes by
/// time, so a pass could hold enough samples to reach that, differently from run to run (it
/// did, before whitted split its passes on llvmpipe: up to 1.5% in some pixels). Fixed, small
/// passes keep every render here reproducible whatever the machine's load.
const PASS_SPP: u32 = 8;

/// Renders `scene` at `size` with integrator options given as JSON, in passes of
/// [`PASS_SPP`] samples.
fn render_with(
    scene: &Scene,
    json: &str,
    spp: u32,
    size: (u32, u32),
    seed: u64,
) -> (Image, RenderStats) {
    let ctx = gpu();
    let compiled = compile(scene, size.0, size.1).expect("compile");
    let o = options(json);
    let mut s =
        RenderSession::new(&ctx, &compiled, &o, scene.render.max_depth, seed).expect("session");
    while s.spp() < spp {
        s.run_pass(PASS_SPP.min(spp - s.spp())).expect("pass");
    }
    let out = render(&mut s, Budget::Spp(spp)).expect("render");
    ctx.check_validation().expect("validation layer messages");
    out
}

#[path = "whitted_support/analytic.rs"]
mod analytic;
use analytic::{checker, Analytic, Kind, Sphere};

/// Renders the analytic scene with whitted at pixel centres and compares with the reference.
fn check_analytic(name: &str, a: &Analytic, max_depth: i32) {
    let scene = load_json(&a.json());
    let json = format!(r#"{{"type": "whitted", "jitter": false, "max_depth": {max_depth}}}"#);
    let (img, stats) = render_with(&scene, &json, 1, a.size, 7);
    let (reference, stable) = a.reference(max_depth);
    let (mut worst, mut worst_at, mut compared, mut failed) = (0.0f64, 0usize, 0usize, 0usize);
    let mut sum_ref = 0.0;
    for (i, (r, ok)) in reference.iter().zip(&stable).enumerate() {
        if !ok {
            continue;
        }
        compared += 1;
        let g = img.pixels[i];
        for c in 0..3 {
            let (gv, rv) = (g[c] as f64, r[c]);
            sum_ref += rv;
            let err = (gv - rv).abs();
            let allowed = 1e-4 + 1e-4 * rv.abs();
            if err / allowed > worst {
                worst = err / allowed;
                worst_at = i;
            }
            if err > allowed {
                failed += 1;
            }
        }
    }
    let n = reference.len();
    let (wx, wy) = (worst_at as u32 % a.size.0, worst_at as u32 / a.size.0);
    println!(
        "{name} (max_depth {max_depth}): {compared}/{n} pixels compared (the rest straddle an \
         edge), mean reference {:.4}, worst |error| / (1e-4 + 1e-4·ref) = {worst:.3} at ({wx}, {wy}): \
         gpu {:?} ref {:.5?}; {} rays",
        sum_ref / (3 * compared.max(1)) as f64,
        img.pixels[worst_at],
        reference[worst_at].to_array(),
        stats.rays
    );
    assert!(
        compared * 10 >= n * 8,
        "{name}: only {compared} of {n} pixels are away from edges"
    );
    assert_eq!(failed, 0, "{name}: {failed} channel values off (see above)");
}

fn glass_scene() -> Analytic {
    let mut cells = checker(4, 2.0, -3.0, 1.0);
    cells.extend(checker(4, 4.0, 9.0, -1.0));
    Analytic {
        eye: DVec3::new(0.0, 0.0, 5.0),
        fov_y: 35.0,
        size: (24, 24),
        spheres: vec![Sphere {
            c: DVec3::ZERO,
            r: 1.0,
            kind: Kind::Glass { eta: 1.5 },
        }],
        cells,
        point: None,
    }
}

#[test]
fn glass_sphere_matches_the_analytic_reference() {
    let a = glass_scene();
    for max_depth in [1, 3, 8] {
        check_analytic("glass sphere", &a, max_depth);
    }
}

#[test]
fn gold_mirror_metal_and_glass_match_the_analytic_reference() {
    let mut cells = checker(4, 2.0, -3.0, 1.0);
    cells.extend(checker(4, 4.0, 9.0, -1.0));
    let a = Analytic {
        eye: DVec3::new(0.0, 0.5, 6.0),
        fov_y: 40.0,
        size: (32, 16),
        spheres: vec![
            Sphere {
                c: DVec3::new(1.1, 0.0, 0.0),
                r: 1.0,
                kind: Kind::Conductor {
                    eta: DVec3::new(0.143, 0.374, 1.442),
                    k: DVec3::new(3.983, 2.385, 1.603),
                },
            },
            Sphere {
                c: DVec3::new(-1.1, 0.0, 0.0),
                r: 1.0,
                kind: Kind::Glass { eta: 1.5 },
            },
            Sphere {
                c: DVec3::new(0.0, 1.1, 0.8),
                r: 0.6,
                kind: Kind::Metal {
                    base: DVec3::new(0.9, 0.6, 0.3),
                },
            },
        ],
        cells,
        point: None,
    };
    check_analytic("gold mirror + principled metal + glass", &a, 6);
}

#[test]
fn smooth_plastic_under_a_point_light_matches_the_analytic_reference() {
    // Lambert (direct light with shadow rays, ambient) under a dielectric coat, seen directly,
    // in a gold mirror and through glass; the glass casts an opaque shadow.
    let a = Analytic {
        eye: DVec3::new(0.0, 1.0, 6.0),
        fov_y: 40.0,
        size: (32, 24),
        spheres: vec![
            Sphere {
                c: DVec3::new(0.0, -0.2, 0.0),
                r: 1.0,
                kind: Kind::Plastic {
                    base: DVec3::new(0.7, 0.35, 0.2),
                },
            },
            Sphere {
                c: DVec3::new(-1.6, 0.6, -1.5),
                r: 0.8,
                kind: Kind::Conductor {
                    eta: DVec3::new(0.143, 0.374, 1.442),
                    k: DVec3::new(3.983, 2.385, 1.603),
                },
            },
            Sphere {
                c: DVec3::new(1.3, 0.9, 1.4),
                r: 0.6,
                kind: Kind::Glass { eta: 1.5 },
            },
        ],
        cells: Vec::new(),
        point: Some((DVec3::new(3.0, 4.0, 3.0), DVec3::new(30.0, 28.0, 25.0))),
    };
    check_analytic("plastic + gold + glass, point light", &a, 5);
}

// ---------------------------------------------------------------------------------------------
// Agreement with nee.

/// A floor, a back wall, and phong, rough principled and rough conductor spheres, lit by
/// `light` (one JSON light object) or by the area lights given as extra objects.
fn lit_scene(lights: &str, extra_objects: &str, extra_materials: &str) -> String {
    format!(
        r#"{{"version": 1,
  "camera": {{"position": [0, 1, 5], "look_at": [0, 0, 0], "fov_y": 45}},
  "film": {{"width": 16, "height": 16, "filter": "box"}},
  "materials": {{
    "floor": {{"type": "diffuse", "reflectance": [0.7, 0.6, 0.5]}},
    "wall": {{"type": "diffuse", "reflectance": 0.5}},
    "phong": {{"type": "phong", "diffuse": [0.5, 0.3, 0.2], "specular": 0.4, "exponent": 20}},
    "plastic": {{"type": "principled", "base_color": [0.2, 0.5, 0.8], "metallic": 0.3, "roughness": 0.5}},
    "brushed": {{"type": "conductor", "reflectance": [0.9, 0.7, 0.4], "roughness": 0.4}}{extra_materials}
  }},
  "objects": [
    {{"type": "quad", "origin": [-3, -1, 3], "edge_u": [6, 0, 0], "edge_v": [0, 0, -6], "material": "floor"}},
    {{"type": "quad", "origin": [-3, -1, -2], "edge_u": [6, 0, 0], "edge_v": [0, 5, 0], "material": "wall"}},
    {{"type": "sphere", "center": [-1.3, -0.2, 0], "radius": 0.8, "material": "phong"}},
    {{"type": "sphere", "center": [0, -0.3, -0.8], "radius": 0.7, "material": "plastic"}},
    {{"type": "sphere", "center": [1.3, -0.3, 0.2], "radius": 0.7, "material": "brushed"}}{extra_objects}
  ],
  "lights": [{lights}]}}"#
    )
}

#[test]
fn equals_nee_at_max_depth_2_under_delta_lights() {
    let lights = [
        (
            "point",
            r#"{"type": "point", "position": [1, 3, 2], "intensity": [10, 9, 8]}"#,
        ),
        (
            "spot",
            r#"{"type": "spot", "position": [0, 3, 1], "look_at": [0, -1, 0], "intensity": [30, 30, 30], "cutoff_angle": 35}"#,
        ),
        (
            "directional",
            r#"{"type": "directional", "direction": [-0.3, -1, -0.5], "irradiance": [1.5, 1.4, 1.2]}"#,
        ),
    ];
    for (name, light) in lights {
        let scene = load_json(&lit_scene(light, "", ""));
        // Same seed: the same jittered camera rays; nee's only other randomness (the light pick
        // and the continuation, which finds no emitter at max_depth 2) changes nothing.
        let (w, _) = render_with(
            &scene,
            r#"{"type": "whitted", "max_depth": 2}"#,
            2,
            (16, 16),
            5,
        );
        let (n, _) = render_with(&scene, r#"{"type": "nee", "max_depth": 2}"#, 2, (16, 16), 5);
        let mut worst = 0.0f64;
        let mut lit = 0;
        for (a, b) in w.pixels.iter().zip(&n.pixels) {
            for c in 0..3 {
                let (a, b) = (a[c] as f64, b[c] as f64);
                worst = worst.max((a - b).abs() / (1e-4 + b.abs()));
                if b > 1e-3 {
                    lit += 1;
                }
            }
        }
        println!(
            "{name} light: max |whitted − nee| / (1e-4 + nee) = {worst:.2e}; {lit} lit channel values; means whitted {:.4?} nee {:.4?}",
            w.mean(),
            n.mean()
        );
        assert!(lit > 200, "{name}: the scene is too dark to test");
        assert!(
            worst < 1e-3,
            "{name}: whitted differs from nee by {worst:.2e}"
        );
    }
}

/// relMSE after 4×4 block averaging.
fn blocks(a: &Image, reference: &Image) -> f64 {
    rel_mse(&downsample_box(a, 4), &downsample_box(reference, 4)).unwrap()
}

/// `lit_scene` lit only by area lights: a quad light facing down and a small emissive sphere.
fn area_lit_scene() -> Scene {
    load_json(&lit_scene(
        "",
        r#",
    {"type": "quad", "origin": [-0.5, 2.5, -0.5], "edge_u": [1, 0, 0], "edge_v": [0, 0, 1], "material": "lamp"},
    {"type": "sphere", "center": [1.8, 1.2, 1.2], "radius": 0.25, "material": "bulb"}"#,
        r#",
    "lamp": {"type": "diffuse", "reflectance": 0, "emission": [6, 6, 5]},
    "bulb": {"type": "diffuse", "reflectance": 0, "emission": [8, 5, 3]}"#,
    ))
}

#[test]
fn area_light_quadrature_converges_to_nee_direct_light() {
    let scene = area_lit_scene();
    // The same seed and sample count give whitted and nee the same camera rays, so the
    // anti-aliasing is identical and the difference is nee's noise plus whitted's quadrature
    // error; a second nee render with another seed measures that noise (twice over).
    let size = (16, 16);
    let spp = 256;
    let nee = r#"{"type": "nee", "max_depth": 2}"#;
    let (reference, _) = render_with(&scene, nee, spp, size, 11);
    let (other, _) = render_with(&scene, nee, spp, size, 12);
    let noise2 = blocks(&other, &reference);
    let json = r#"{"type": "whitted", "max_depth": 2, "area_samples": 16}"#;
    let (img, _) = render_with(&scene, json, spp, size, 11);
    let e = blocks(&img, &reference);
    println!(
        "area_samples 16: relMSE (4×4 blocks) against nee {spp} spp (same camera rays) = {e:.2e}; \
         nee {spp} spp against nee with another seed: {noise2:.2e} (two nee noises, for scale)"
    );
    assert!(e < noise2, "whitted {e:.2e} vs nee-vs-nee {noise2:.2e}");
    // Convergence of the quadrature alone: against 256 points per light, same camera rays.
    let quad = |n: u32| {
        let json = format!(r#"{{"type": "whitted", "max_depth": 2, "area_samples": {n}}}"#);
        render_with(&scene, &json, 16, size, 11).0
    };
    let fine = quad(256);
    let errors: Vec<f64> = [1, 4, 16, 64].map(|n| blocks(&quad(n), &fine)).to_vec();
    println!(
        "relMSE (4×4 blocks) against area_samples 256: 1 point {:.2e}, 4 points {:.2e}, \
         16 points {:.2e}, 64 points {:.2e}",
        errors[0], errors[1], errors[2], errors[3]
    );
    assert!(
        errors.windows(2).all(|w| w[1] < w[0]) && errors[3] < errors[0] / 20.0,
        "{errors:?}"
    );
}

#[test]
fn white_furnace_is_one() {
    let scene = load_json(
        r#"{"version": 1,
  "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "fov_y": 30},
  "film": {"width": 16, "height": 16},
  "materials": {"white": {"type": "diffuse", "reflectance": 1}},
  "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "white"}],
  "environment": {"type": "constant", "radiance": [1, 1, 1]}}"#,
    );
    let (img, _) = render_with(&scene, r#"{"type": "whitted"}"#, 4, (16, 16), 1);
    let worst = img
        .pixels
        .iter()
        .flat_map(|p| p.iter())
        .map(|&v| (v as f64 - 1.0).abs())
        .fold(0.0, f64::max);
    println!("white furnace: max |L − 1| = {worst:.2e}");
    assert!(worst < 1e-5, "{worst}");
}

#[test]
fn each_depth_only_adds_light() {
    // Every term whitted adds is non-negative, so with the same camera rays each pixel can
    // only brighten as max_depth grows; −1 means the cap (16) and must not overflow the stack.
    let scene = renderer::scene::load_file(&scene_path("mirror_glass.json")).expect("scene");
    let mut prev: Option<Image> = None;
    for d in [1, 2, 3, 4, 6, 10, -1] {
        let json = format!(r#"{{"type": "whitted", "jitter": false, "max_depth": {d}}}"#);
        let (img, stats) = render_with(&scene, &json, 1, (24, 24), 0);
        assert!(img.is_well_formed(), "max_depth {d}: non-finite pixels");
        assert_eq!(stats.dropped_samples, 0, "max_depth {d}");
        let m = img.mean();
        println!(
            "mirror_glass max_depth {d:>2}: mean {m:.4?}, {} rays",
            stats.rays
        );
        if let Some(p) = &prev {
            for (a, b) in img.pixels.iter().zip(&p.pixels) {
                for c in 0..3 {
                    assert!(a[c] >= b[c] * (1.0 - 1e-6), "max_depth {d}: {a:?} < {b:?}");
                }
            }
        }
        prev = Some(img);
    }
}

// ---------------------------------------------------------------------------------------------
// Determinism.

#[test]
fn deterministic_apart_from_pixel_jitter() {
    // Without jitter: the image depends on neither the sample count nor the seed.
    let cornell = renderer::scene::load_file(&scene_path("cornell.json")).expect("cornell");
    let nj = r#"{"type": "whitted", "jitter": false}"#;
    let (one, _) = render_with(&cornell, nj, 1, (32, 32), 1);
    let (many, _) = render_with(&cornell, nj, 16, (32, 32), 2);
    let worst = one
        .pixels
        .iter()
        .zip(&many.pixels)
        .flat_map(|(a, b)| (0..3).map(move |c| (a[c] as f64, b[c] as f64)))
        .map(|(a, b)| (a - b).abs() / (1e-6 + b.abs()))
        .fold(0.0, f64::max);
    println!("Cornell box, no jitter: 1 spp (seed 1) vs 16 spp (seed 2): max relative difference {worst:.2e}");
    assert!(worst < 1e-5, "{worst}");
    // With jitter: 1 spp and 64 spp differ by anti-aliasing only. Away from edges (pixels
    // whose 3×3 neighbourhood, the box filter's reach, is smooth in the jitter-free image)
    // they agree up to the shading gradient across a pixel, while nee's differ by its noise.
    let scene = load_json(&lit_scene(
        r#"{"type": "point", "position": [1, 3, 2], "intensity": [10, 9, 8]}"#,
        "",
        "",
    ));
    let size = (32, 32);
    let (centres, _) = render_with(&scene, nj, 1, size, 1);
    let j = r#"{"type": "whitted"}"#;
    let (w1, _) = render_with(&scene, j, 1, size, 1);
    let (w64, _) = render_with(&scene, j, 64, size, 2);
    let (n1, _) = render_with(&scene, r#"{"type": "nee"}"#, 1, size, 1);
    let (n64, _) = render_with(&scene, r#"{"type": "nee"}"#, 64, size, 2);
    let smooth = smooth_pixels(&centres, 1);
    let count = smooth.iter().filter(|s| **s).count();
    let (dw, dn) = (
        mean_rel_diff(&w1, &w64, &smooth),
        mean_rel_diff(&n1, &n64, &smooth),
    );
    println!(
        "point light, jitter: mean |1 spp − 64 spp| / (64 spp + 0.01) over {count} smooth pixels \
         of {}: whitted {dw:.2e}, nee {dn:.2e}",
        smooth.len()
    );
    assert!(count * 4 >= smooth.len(), "too few smooth pixels: {count}");
    assert!(
        dw < 0.02 && dw < dn / 10.0,
        "whitted {dw:.2e} vs nee {dn:.2e}"
    );
}

/// Pixels whose neighbourhood of `radius` differs from them by at most 20% in every channel.
fn smooth_pixels(img: &Image, radius: i32) -> Vec<bool> {
    let (w, h) = (img.width as i32, img.height as i32);
    let mut out = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let p = img.get(x as u32, y as u32);
            let mut ok = true;
            for dy in -radius..=radius {
                for dx in -radius..=radius {
                    let (nx, ny) = ((x + dx).clamp(0, w - 1), (y + dy).clamp(0, h - 1));
                    let q = img.get(nx as u32, ny as u32);
                    ok &= (0..3).all(|c| (q[c] - p[c]).abs() <= 0.2 * (p[c] + 0.01));
                }
            }
            out.push(ok);
        }
    }
    out
}

/// Mean over the marked pixels and channels of |a − b| / (b + 0.01).
fn mean_rel_diff(a: &Image, b: &Image, mask: &[bool]) -> f64 {
    let (mut sum, mut n) = (0.0, 0);
    for ((pa, pb), m) in a.pixels.iter().zip(&b.pixels).zip(mask) {
        if *m {
            for c in 0..3 {
                sum += (pa[c] as f64 - pb[c] as f64).abs() / (pb[c] as f64 + 0.01);
                n += 1;
            }
        }
    }
    sum / n.max(1) as f64
}

#[test]
fn one_big_pass_equals_many_small_ones() {
    // 256 points on each of three area lights: one sample is ~800 shadow rays, so a 16-spp
    // dispatch would exceed llvmpipe's 65535 loop iterations per invocation; the render
    // session splits such passes there (render::LLVMPIPE_MAX_DISPATCHES), and the image must
    // not depend on the split.
    let scene = area_lit_scene();
    let ctx = gpu();
    let compiled = compile(&scene, 16, 16).expect("compile");
    let o = options(r#"{"type": "whitted", "max_depth": 2, "area_samples": 256}"#);
    let mut imgs = Vec::new();
    for split in [vec![16u32], vec![1; 16], vec![5, 11]] {
        let mut s = RenderSession::new(&ctx, &compiled, &o, None, 11).expect("session");
        for n in &split {
            s.run_pass(*n).expect("pass");
        }
        imgs.push(s.image().expect("image"));
    }
    ctx.check_validation().expect("validation layer messages");
    for (i, img) in imgs.iter().enumerate().skip(1) {
        let d = img
            .pixels
            .iter()
            .zip(&imgs[0].pixels)
            .filter(|(a, b)| a != b)
            .count();
        println!("split {i}: {d} pixels differ from one 16-spp pass");
        assert_eq!(d, 0, "split {i}");
    }
}

// ---------------------------------------------------------------------------------------------
// Report: the Cornell box against nee.

#[test]
fn cornell_box_against_nee_report() {
    let scene = renderer::scene::load_file(&scene_path("cornell.json")).expect("cornell");
    let size = (32, 32);
    let (w, ws) = render_with(&scene, r#"{"type": "whitted"}"#, 16, size, 1);
    let (n, _) = render_with(&scene, r#"{"type": "nee"}"#, 512, size, 2);
    let (n2, _) = render_with(&scene, r#"{"type": "nee", "max_depth": 2}"#, 256, size, 3);
    let e = rel_mse(&w, &n).unwrap();
    let e_direct = rel_mse(&w, &n2).unwrap();
    let (mw, mn) = (w.mean(), n.mean());
    println!(
        "Cornell box 32×32: whitted (16 spp, {} rays, {:.3} s GPU) relMSE against nee 512 spp = \
         {e:.4}; against nee max_depth 2 (direct light only, 256 spp) = {e_direct:.4}; means whitted \
         {mw:.4?}, nee {mn:.4?}",
        ws.rays, ws.gpu_time_s
    );
    // Loose bounds: finite, darker than full transport (no indirect light), but not black.
    assert!(e.is_finite() && e < 1.0, "{e}");
    for c in 0..3 {
        assert!(mw[c] < mn[c] && mw[c] > 0.2 * mn[c], "{mw:?} vs {mn:?}");
    }
}

// ---------------------------------------------------------------------------------------------
// Bad options.

#[test]
fn bad_options_are_refused_naming_the_field() {
    // Unknown field: serde names it (library and CLI).
    let e = serde_json::from_str::<IntegratorOptions>(r#"{"type": "whitted", "area_sampels": 4}"#)
        .unwrap_err()
        .to_string();
    assert!(e.contains("area_sampels"), "{e}");
    let o = run_candela(&[
        "render",
        scene_path("cornell.json").to_str().unwrap(),
        "-o",
        "/dev/null/never.exr",
        "--integrator",
        "whitted",
        "--options",
        r#"{"area_sampels": 4}"#,
    ]);
    assert_bad_input(&o, &["area_sampels"]);
    // Out-of-range values: the session refuses them.
    let scene = renderer::scene::load_file(&scene_path("cornell.json")).expect("cornell");
    let compiled = compile(&scene, 8, 8).expect("compile");
    for (json, field) in [
        (r#"{"type": "whitted", "area_samples": 0}"#, "area_samples"),
        (
            r#"{"type": "whitted", "mirror_roughness": -1}"#,
            "mirror_roughness",
        ),
        (r#"{"type": "whitted", "max_depth": -3}"#, "max_depth"),
    ] {
        let err = RenderSession::new(&gpu(), &compiled, &options(json), None, 0)
            .err()
            .unwrap_or_else(|| panic!("{json} accepted"))
            .to_string();
        println!("{json}: {err}");
        assert!(err.contains(field), "{json}: {err}");
    }
}
