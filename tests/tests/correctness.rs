//! Correctness without a reference renderer: analytic answers (white furnace), the two path
//! tracers agreeing, determinism whatever the pass split, and invariance under translating the
//! whole scene far from the origin.

use candela_tests::accel::translated;
use candela_tests::{gpu, render_loaded, render_scene, scene_path};
use renderer::compile::compile;
use renderer::integrators::IntegratorOptions;
use renderer::metrics::{downsample_box, rel_mse};
use renderer::render::RenderSession;

/// A white (reflectance 1) diffuse sphere under constant radiance 1 is exactly 1 everywhere, for
/// both integrators, unbounded depth.
#[test]
fn white_furnace_is_exactly_one() {
    for integrator in ["pt", "nee"] {
        let (img, stats) =
            render_scene(&scene_path("furnace.json"), integrator, 32, 24, 24, 1, None);
        let m = img.mean();
        let worst = img
            .pixels
            .iter()
            .flatten()
            .map(|&v| (v as f64 - 1.0).abs())
            .fold(0.0, f64::max);
        println!(
            "furnace {integrator}: mean {m:?}, worst pixel error {worst:.2e}, {} dropped",
            stats.dropped_samples
        );
        for c in m {
            assert!((c - 1.0).abs() < 5e-3, "{integrator}: mean {m:?}");
        }
        assert_eq!(stats.dropped_samples, 0);
    }
}

/// Inside a closed sphere that emits radiance 1 inward and reflects ρ = 0.5 diffusely, every
/// point sees L = 1 + ρ + … + ρ^(k−1) at max_depth k: 1.5 at 2, 1.75 at 3. The shading points lie
/// on the emitter itself, which light sampling must handle (it once sampled the near side of
/// the sphere from such points and gave 1.40 at max_depth 2). Every integrator that samples
/// lights is checked against the closed form.
#[test]
fn inside_an_emissive_sphere_is_the_geometric_series() {
    let scene = renderer::scene::load_str(
        r#"{"version": 1,
            "camera": {"position": [0, 0, 0.5], "look_at": [0, 0, 0], "fov_y": 60},
            "film": {"width": 8, "height": 8},
            "materials": {"glow": {"type": "diffuse", "reflectance": 0.5, "emission": [1, 1, 1]}},
            "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 2,
                         "flip_normals": true, "material": "glow"}]}"#,
        None,
    )
    .unwrap();
    for (integrator, depth, expected) in [
        ("pt", 2, 1.5),
        ("nee", 2, 1.5),
        ("nee", 3, 1.75),
        ("bdpt", 3, 1.75),
        ("whitted", 2, 1.5),
    ] {
        let (img, _) = render_loaded(&scene, integrator, 64, 8, 8, 1, Some(depth));
        let m = img.mean();
        println!("emissive sphere {integrator} max_depth {depth}: mean {m:?}, expected {expected}");
        for c in m {
            assert!(
                (c - expected).abs() < 2e-3 * expected,
                "{integrator} max_depth {depth}: {m:?}, expected {expected}"
            );
        }
    }
}

/// Inside a closed cube whose walls emit 1 inward and reflect ρ = 0.5 diffusely, every point sees
/// 1 + ρ + ρ² = 1.75 at max_depth 3, as inside the emissive sphere above, wherever the camera is.
/// Here the camera is a millimetre from a wall, whose plane then passes almost through the origin
/// of the render's camera-relative coordinates: its hit points' error bounds, and with them the
/// offsets of rays leaving it, are tiny. Without the triangle test's conservative bound on t
/// (pbrt's δt, common/intersect.glsl) rays leaving that wall at grazing angles found it again and
/// lost the light beyond (pixels down to 1.731, the mean 1.744; seed 324 of the Mitsuba audit,
/// bench/RESULTS.md). pt sees emission 1 wherever a path goes, so its pixels are all but exact.
#[test]
fn a_camera_beside_a_wall_loses_no_light() {
    let wall = |o: [i32; 3], u: [i32; 3], v: [i32; 3]| {
        format!(
            r#"{{"type": "quad", "origin": {o:?}, "edge_u": {u:?}, "edge_v": {v:?}, "material": "glow"}}"#
        )
    };
    let walls = [
        wall([-1, -1, -1], [0, 2, 0], [0, 0, 2]),
        wall([1, -1, -1], [0, 0, 2], [0, 2, 0]),
        wall([-1, -1, -1], [0, 0, 2], [2, 0, 0]),
        wall([-1, 1, -1], [2, 0, 0], [0, 0, 2]),
        wall([-1, -1, -1], [2, 0, 0], [0, 2, 0]),
        wall([-1, -1, 1], [0, 2, 0], [2, 0, 0]),
    ];
    let scene = renderer::scene::load_str(
        &format!(
            r#"{{"version": 1,
                "camera": {{"position": [-0.999, 0.3, 0.2], "look_at": [1, 0.3, 0.2], "fov_y": 80}},
                "film": {{"width": 16, "height": 16}},
                "materials": {{"glow": {{"type": "diffuse", "reflectance": 0.5, "emission": [1, 1, 1]}}}},
                "objects": [{}]}}"#,
            walls.join(", ")
        ),
        None,
    )
    .unwrap();
    let (img, _) = render_loaded(&scene, "pt", 256, 16, 16, 1, Some(3));
    let worst = img
        .pixels
        .iter()
        .flatten()
        .map(|&v| (v as f64 - 1.75).abs())
        .fold(0.0, f64::max);
    let m = img.mean();
    println!("cube, camera beside a wall: mean {m:?}, worst pixel off by {worst:.4}");
    for c in m {
        assert!((c - 1.75).abs() < 1e-3, "mean {m:?}, expected 1.75");
    }
    assert!(worst < 4e-3, "a pixel is {worst} off 1.75");
}

/// A mesh without uvs is parameterised by each triangle's barycentrics as in Mitsuba, uv = (b1,
/// 1 − b2) in candela's v direction: textures and alpha masks read it there and its tangent, along
/// which anisotropic lobes stretch, runs along the triangle's first edge, whether or not the mesh
/// has normals. So such a mesh renders as the same mesh given those uvs (0, 1), (1, 1), (0, 0)
/// explicitly (that this is Mitsuba's orientation: mitsuba_reference.rs's
/// `meshes_without_uvs_match_mitsuba`). Before, a mesh
/// without uvs had any frame around its normal as its tangent (Mitsuba audit seed 367: an
/// anisotropic principled tetrahedron up to twice too bright), one with normals but no uvs read
/// every texture at (0, 0), and one with neither ignored its alpha mask.
#[test]
fn a_mesh_without_uvs_is_parameterised_by_its_barycentrics() {
    // Two triangles of a floor (unshared vertices, so each can take its own corners' uvs) under
    // a small light, an anisotropic textured conductor or a masked diffuse surface.
    let scene = |normals: bool, uvs: bool, material: &str| {
        let mut mesh = serde_json::json!({"type": "triangles", "material": "floor",
            "positions": [[-1, -0.5, -1], [-1, -0.5, 1], [1, -0.5, -1],
                          [1, -0.5, 1], [1, -0.5, -1], [-1, -0.5, 1]],
            "indices": [0, 1, 2, 3, 4, 5]});
        if normals {
            mesh["normals"] = serde_json::json!(vec![[0, 1, 0]; 6]);
        }
        if uvs {
            mesh["uvs"] = serde_json::json!([[0, 1], [1, 1], [0, 0], [0, 1], [1, 1], [0, 0]]);
        }
        let text = format!(
            r#"{{"version": 1,
                "camera": {{"position": [0, 0.6, 2.2], "look_at": [0, -0.5, 0], "fov_y": 60}},
                "film": {{"width": 24, "height": 24}},
                "materials": {{"floor": {material},
                    "light": {{"type": "diffuse", "reflectance": 0, "emission": [4, 4, 4]}}}},
                "objects": [{mesh}, {{"type": "quad", "origin": [-0.3, 1, -0.8],
                    "edge_u": [0.6, 0, 0], "edge_v": [0, 0, 0.6], "material": "light"}}]}}"#
        );
        renderer::scene::load_str(&text, Some(&scene_path(""))).unwrap()
    };
    let anisotropic = r#"{"type": "conductor", "roughness": 0.5, "anisotropy": 0.9,
        "reflectance": {"texture": "assets/checker.png", "scale": [3, 3]}}"#;
    // The checker's green channel (60 and 220) cuts every other square; its red channel (200
    // and 230) would cut nothing.
    let masked = r#"{"type": "diffuse", "reflectance": 0.8,
        "alpha_mask": {"texture": "assets/checker.png", "scale": [3, 3], "channel": "g"}}"#;
    for (name, material) in [("anisotropic", anisotropic), ("masked", masked)] {
        let render = |normals, uvs| {
            render_loaded(&scene(normals, uvs, material), "nee", 16, 24, 24, 1, None).0
        };
        let explicit = render(true, true);
        for (normals, uvs) in [(false, false), (true, false), (false, true)] {
            let e = rel_mse(&render(normals, uvs), &explicit).unwrap();
            println!(
                "{name} floor, normals {normals}, uvs {uvs}: relMSE {e:.2e} against explicit uvs"
            );
            assert!(
                e < 1e-4,
                "{name}, normals {normals}, uvs {uvs}: relMSE {e:.2e}"
            );
        }
    }
}

/// max_depth 1 shows only emitters: in the furnace that is the environment around the sphere and
/// black on it.
#[test]
fn max_depth_one_shows_only_emitters() {
    let (img, _) = render_scene(&scene_path("furnace.json"), "nee", 4, 16, 16, 1, Some(1));
    assert_eq!(
        img.get(8, 8),
        [0.0; 3],
        "the sphere must be black at max_depth 1"
    );
    assert_eq!(img.get(0, 0), [1.0; 3], "the environment is seen directly");
}

/// The same seed gives the same image, bit for bit, whether 8 samples come in one pass or eight.
#[test]
fn image_does_not_depend_on_the_pass_split() {
    let scene = renderer::scene::load_file(&scene_path("cornell.json")).unwrap();
    let compiled = compile(&scene, 24, 24).unwrap();
    let opts = IntegratorOptions::from_name("nee").unwrap();
    let ctx = gpu();
    let mut one = RenderSession::new(&ctx, &compiled, &opts, None, 42).unwrap();
    one.run_pass(8).unwrap();
    let mut many = RenderSession::new(&ctx, &compiled, &opts, None, 42).unwrap();
    for n in [1, 2, 1, 4] {
        many.run_pass(n).unwrap();
    }
    let (a, b) = (one.image().unwrap(), many.image().unwrap());
    assert_eq!(a.pixels, b.pixels, "pass split changed the image");
    let mut other = RenderSession::new(&ctx, &compiled, &opts, None, 43).unwrap();
    other.run_pass(8).unwrap();
    assert_ne!(
        a.pixels,
        other.image().unwrap().pixels,
        "a different seed must give a different image"
    );
}

/// Translating the whole scene (camera included) by 1e5 units changes nothing visible: geometry is
/// composed in f64 and uploaded camera-relative.
#[test]
fn scene_far_from_origin_renders_the_same() {
    let path = scene_path("mirror_glass.json");
    let scene = renderer::scene::load_file(&path).unwrap();
    let far = translated(&scene, glam::DVec3::new(1e5, -1e5, 1e5));
    let (a, _) = render_loaded(&scene, "nee", 16, 32, 32, 5, None);
    let (b, _) = render_loaded(&far, "nee", 16, 32, 32, 5, None);
    let e = rel_mse(&b, &a).unwrap();
    println!("translated by 1e5: relMSE {e:.3e} against the scene at the origin");
    assert!(e < 1e-6, "relMSE {e}");
}

/// pt and nee converge to the same Cornell box: compared after 4×4 block averaging, where noise
/// is small and bias is not. The expected relMSE between two independent estimates is the sum of
/// their noise levels, each measured as half the relMSE between two seeds of the same integrator;
/// the test allows 3× that.
#[test]
fn pt_and_nee_agree_on_the_cornell_box() {
    let path = scene_path("cornell.json");
    let (pt, _) = render_scene(&path, "pt", 512, 32, 32, 1, None);
    let (pt2, _) = render_scene(&path, "pt", 512, 32, 32, 4, None);
    let (nee, _) = render_scene(&path, "nee", 256, 32, 32, 2, None);
    let (nee2, _) = render_scene(&path, "nee", 256, 32, 32, 3, None);
    let d = |a, b| rel_mse(&downsample_box(a, 4), &downsample_box(b, 4)).unwrap();
    let e = d(&pt, &nee);
    let noise = d(&pt, &pt2) / 2.0 + d(&nee, &nee2) / 2.0;
    let (mp, mn) = (pt.mean(), nee.mean());
    println!("cornell 32x32: relMSE(pt 512 spp, nee 256 spp) {e:.2e} on 4x4 blocks, expected noise {noise:.2e}; means pt {mp:.4?} nee {mn:.4?}");
    for c in 0..3 {
        assert!(
            (mp[c] / mn[c] - 1.0).abs() < 0.03,
            "means differ: pt {mp:?} nee {mn:?}"
        );
    }
    assert!(
        e < 3.0 * noise + 1e-4,
        "pt vs nee {e:.2e} vs expected noise {noise:.2e}"
    );
}

/// NaN samples never reach the film: with every 7th sample poisoned (a kernel test hook), the
/// image stays finite, still averages to the furnace's exact 1 over the samples kept, and the
/// dropped count is exact.
#[test]
fn nan_samples_are_dropped_and_counted() {
    let scene = renderer::scene::load_file(&scene_path("furnace.json")).unwrap();
    let compiled = compile(&scene, 8, 8).unwrap();
    let opts = IntegratorOptions::from_name("nee").unwrap();
    let ctx = gpu();
    let mut s = RenderSession::new(&ctx, &compiled, &opts, None, 9).unwrap();
    s.set_debug_flags(renderer::layout::PUSH_FLAG_INJECT_NAN);
    s.run_pass(10).unwrap();
    s.run_pass(4).unwrap();
    let img = s.image().unwrap();
    let stats = s.stats();
    // Sample indices 0..14 include 3 and 10: two poisoned samples per pixel.
    assert_eq!(stats.dropped_samples, 2 * 64, "dropped count");
    assert!(img.pixels.iter().flatten().all(|v| v.is_finite()));
    assert!(
        (img.mean()[0] - 1.0).abs() < 0.02,
        "furnace mean {:?}",
        img.mean()
    );
}

/// The validation layer is on in tests whenever it is installed, so "no messages" means something.
#[test]
fn validation_layer_is_enabled_when_installed() {
    let installed =
        std::path::Path::new("/usr/share/vulkan/explicit_layer.d/VkLayer_khronos_validation.json")
            .exists();
    let ctx = gpu();
    println!(
        "validation layer installed: {installed}, enabled: {}",
        ctx.validation_enabled
    );
    if installed {
        assert!(ctx.validation_enabled);
    }
}

/// A render stopped after 5 spp and resumed from its checkpoint (accumulation + counters) in a new
/// session ends bit-identical to an uninterrupted one, with the same statistics.
#[test]
fn checkpoint_resume_is_exact() {
    let scene = renderer::scene::load_file(&scene_path("cornell.json")).unwrap();
    let compiled = compile(&scene, 16, 16).unwrap();
    let opts = IntegratorOptions::from_name("nee").unwrap();
    let ctx = gpu();
    let mut whole = RenderSession::new(&ctx, &compiled, &opts, None, 3).unwrap();
    whole.run_pass(5).unwrap();
    whole.run_pass(7).unwrap();
    let mut first = RenderSession::new(&ctx, &compiled, &opts, None, 3).unwrap();
    first.run_pass(5).unwrap();
    let (acc, progress) = (first.accumulation().unwrap(), first.progress());
    drop(first);
    let mut resumed = RenderSession::new(&ctx, &compiled, &opts, None, 3).unwrap();
    resumed.restore(&acc, progress).unwrap();
    resumed.run_pass(7).unwrap();
    assert_eq!(
        whole.image().unwrap().pixels,
        resumed.image().unwrap().pixels
    );
    let (a, b) = (whole.progress(), resumed.progress());
    assert_eq!(
        (a.spp, a.passes, a.rays, a.dropped_samples),
        (b.spp, b.passes, b.rays, b.dropped_samples)
    );
}

/// Tiny and huge scenes: the mirror-and-glass box scaled by 1e-4 and by 1e4 (camera included)
/// renders the same picture as at scale 1. Ray offsets come from rounding-error bounds, not a
/// fixed epsilon, so nothing in the renderer depends on the scene's unit.
#[test]
fn tiny_and_huge_scales_render_the_same() {
    let scene = renderer::scene::load_file(&scene_path("mirror_glass.json")).unwrap();
    let (reference, _) = render_loaded(&scene, "nee", 16, 32, 32, 5, None);
    for s in [1e-4, 1e4] {
        let mut scaled = scene.clone();
        scaled.camera.position *= s;
        scaled.camera.look_at *= s;
        scaled.camera.focus_distance *= s;
        for m in &mut scaled.meshes {
            for p in &mut m.positions {
                *p *= s;
            }
        }
        for sp in &mut scaled.spheres {
            sp.center *= s;
            sp.radius *= s;
        }
        let (img, stats) = render_loaded(&scaled, "nee", 16, 32, 32, 5, None);
        let e = rel_mse(&img, &reference).unwrap();
        println!(
            "scale {s:e}: relMSE {e:.3e} against scale 1, {} dropped samples",
            stats.dropped_samples
        );
        assert!(e < 1e-6, "scale {s}: relMSE {e}");
        assert_eq!(stats.dropped_samples, 0);
    }
}

/// Tiny bright lights: a sphere light of radius 1e-3 with radiance L lights a floor exactly like
/// a point light of intensity I = L·πr² (its projected area), so nee's solid-angle sampling of
/// the sphere must match the point light within 1% — without fireflies or NaNs.
#[test]
fn tiny_sphere_light_matches_its_point_light() {
    let r = 1e-3f64;
    let radiance = 5.0f32 / (std::f32::consts::PI * (r * r) as f32);
    let base = r#"{"version": 1, "camera": {"position": [0, 2, 3], "look_at": [0, 0, 0]},
      "film": {"width": 24, "height": 24},
      "materials": {"floor": {"type": "diffuse", "reflectance": 0.7},
                    "bulb": {"type": "diffuse", "reflectance": 0, "emission": [RAD, RAD, RAD]}},
      "objects": [{"type": "quad", "origin": [-2, 0, 2], "edge_u": [4, 0, 0], "edge_v": [0, 0, -4], "material": "floor"}
                  SPHERE],
      "lights": [LIGHT]}"#;
    let sphere_scene = base
        .replace("RAD", &radiance.to_string())
        .replace("SPHERE", &format!(r#", {{"type": "sphere", "center": [0.3, 1, 0], "radius": {r}, "material": "bulb"}}"#))
        .replace("LIGHT", "");
    let point_scene = base.replace("RAD", "0").replace("SPHERE", "").replace(
        "LIGHT",
        r#"{"type": "point", "position": [0.3, 1, 0], "intensity": [5, 5, 5]}"#,
    );
    let sphere = renderer::scene::load_str(&sphere_scene, None).unwrap();
    let point = renderer::scene::load_str(&point_scene, None).unwrap();
    let (a, sa) = render_loaded(&sphere, "nee", 64, 24, 24, 1, Some(2));
    let (b, _) = render_loaded(&point, "nee", 64, 24, 24, 1, Some(2));
    let (ma, mb) = (a.mean(), b.mean());
    let e = rel_mse(&a, &b).unwrap();
    println!("tiny sphere light r={r}: mean {ma:.5?} vs point light {mb:.5?}, relMSE {e:.2e}");
    assert!((ma[0] / mb[0] - 1.0).abs() < 0.01, "{ma:?} vs {mb:?}");
    assert!(e < 1e-3, "relMSE {e}");
    assert_eq!(sa.dropped_samples, 0);
}

/// `reset(seed)` gives exactly what a fresh session with that seed gives (pt/nee and bdpt).
#[test]
fn reset_equals_a_fresh_session() {
    let scene = renderer::scene::load_file(&scene_path("cornell.json")).unwrap();
    let compiled = compile(&scene, 12, 12).unwrap();
    let ctx = gpu();
    for name in ["nee", "bdpt"] {
        let mut opts = IntegratorOptions::from_name(name).unwrap();
        if name == "bdpt" {
            // Fixed-point splats make bdpt bit-reproducible.
            opts = serde_json::from_str(r#"{"type": "bdpt", "fixed_point_splats": true}"#).unwrap();
        }
        let mut reused = RenderSession::new(&ctx, &compiled, &opts, None, 1).unwrap();
        reused.run_pass(3).unwrap();
        reused.reset(8).unwrap();
        reused.run_pass(2).unwrap();
        let mut fresh = RenderSession::new(&ctx, &compiled, &opts, None, 8).unwrap();
        fresh.run_pass(2).unwrap();
        assert_eq!(
            reused.image().unwrap().pixels,
            fresh.image().unwrap().pixels,
            "{name}"
        );
        let (a, b) = (reused.progress(), fresh.progress());
        assert_eq!(
            (a.spp, a.passes, a.rays, a.dropped_samples),
            (b.spp, b.passes, b.rays, b.dropped_samples),
            "{name}"
        );
    }
}

/// A 12×12 view of a grey floor under lamps (`objects`, with their `materials`), direct light only
/// (max_depth 2; `render` adds fields), textures from tests/import/mitsuba (mask.png).
fn lamp_scene(materials: &str, objects: &str, render: &str) -> renderer::scene::Scene {
    let render = if render.is_empty() {
        String::new()
    } else {
        format!(", {render}")
    };
    let text = format!(
        r#"{{"version": 1, "camera": {{"position": [0, 0.8, 3], "look_at": [0, 0, 0], "fov_y": 35}},
            "film": {{"width": 12, "height": 12}},
            "materials": {{"floor": {{"type": "diffuse", "reflectance": [0.8, 0.8, 0.8]}}, {materials}}},
            "objects": [
              {{"type": "quad", "origin": [-3, 0, 3], "edge_u": [6, 0, 0], "edge_v": [0, 0, -6],
                "material": "floor"}},
              {objects}],
            "render": {{"max_depth": 2{render}}}}}"#
    );
    let textures = candela_tests::repo_root().join("tests/import/mitsuba");
    renderer::scene::load_str(&text, Some(&textures)).unwrap()
}

/// A masked lamp beside a whole one: light sampling picks the masked lamp by the power its mask
/// keeps (renderer/src/compile/emitters.rs), with both light samplers, and nee stays unbiased
/// (its pick pdfs in MIS follow): nee with the power sampler and with the light BVH against pt,
/// direct light only.
#[test]
fn masked_and_whole_lamps_sampled_by_the_power_they_keep() {
    let scene = |sampler: &str| {
        lamp_scene(
            r#""whole": {"type": "diffuse", "reflectance": 0, "emission": [2, 2, 2]},
               "masked": {"type": "diffuse", "reflectance": 0, "emission": [6, 6, 6],
                          "alpha_mask": {"texture": "mask.png", "scale": [2, 2]}}"#,
            r#"{"type": "quad", "origin": [-2, 1.5, -1], "edge_u": [1.5, 0, 0], "edge_v": [0, 0, 2],
                "material": "whole"},
               {"type": "quad", "origin": [0.5, 1.2, -1], "edge_u": [1.5, 0, 0], "edge_v": [0, 0, 2],
                "material": "masked"}"#,
            &format!(r#""light_sampler": "{sampler}""#),
        )
    };
    let mean = |s: &renderer::scene::Scene, integrator, spp| {
        let (img, _) = render_loaded(s, integrator, spp, 12, 12, 7, None);
        img.mean()[0]
    };
    let reference = mean(&scene("power"), "pt", 4096);
    for sampler in ["power", "bvh"] {
        let m = mean(&scene(sampler), "nee", 512);
        println!("nee ({sampler} sampler) {m:.4} against pt {reference:.4}");
        assert!(
            (m / reference - 1.0).abs() < 0.03,
            "nee with the {sampler} light sampler: {m:.4} against pt {reference:.4}"
        );
    }
}

/// An alpha-masked emitter emits only where its surface exists. Camera rays and BSDF-sampled
/// paths pass through its holes, so light sampling (nee, bdpt's connections and light
/// subpaths, whitted's point set, vct's injection) must give the holes no light either; once it
/// sampled the whole shape and lit the floor as if the lamp had no holes. pt, which finds light
/// only by hitting it, is the reference: direct light only (max_depth 2), a quad lamp and a
/// sphere lamp, each masked to about 61% (tests/import/mitsuba/mask.png). deferred's point-like
/// lights shine with the share of the lamp that exists.
#[test]
fn masked_emitters_light_only_where_they_exist() {
    let lamp_quad = r#"{"type": "quad", "origin": [-1, 1.5, -1], "edge_u": [2, 0, 0],
                        "edge_v": [0, 0, 2], "material": "lamp"}"#;
    let lamp_sphere =
        r#"{"type": "sphere", "center": [0, 1.2, 0], "radius": 0.6, "material": "lamp"}"#;
    for (name, lamp) in [("quad", lamp_quad), ("sphere", lamp_sphere)] {
        let scene = |mask_field: &str| {
            lamp_scene(
                &format!(
                    r#""lamp": {{"type": "diffuse", "reflectance": 0, "emission": [4, 4, 4]{mask_field}}}"#
                ),
                lamp,
                "",
            )
        };
        let masked = scene(r#", "alpha_mask": {"texture": "mask.png", "scale": [2, 2]}"#);
        let whole = scene("");
        let mean = |s, integrator, spp| {
            let (img, _) = render_loaded(s, integrator, spp, 12, 12, 7, None);
            img.mean()[0]
        };
        // The reference, and the mask's effect on it (so the comparison below can fail).
        let reference = mean(&masked, "pt", 4096);
        let unmasked = mean(&whole, "pt", 2048);
        println!("{name} lamp: pt masked {reference:.4}, unmasked {unmasked:.4}");
        assert!(
            reference < 0.8 * unmasked,
            "{name}: the mask hardly dims the lamp"
        );
        for (integrator, spp, tolerance) in [
            ("nee", 512, 0.03),
            ("bdpt", 256, 0.03),
            ("whitted", 16, 0.1),
        ] {
            let m = mean(&masked, integrator, spp);
            println!("{name} lamp: {integrator} {m:.4} (pt {reference:.4})");
            assert!(
                (m / reference - 1.0).abs() < tolerance,
                "{name} lamp: {integrator} {m:.4} against pt {reference:.4}"
            );
        }
        // deferred's point-like lights are approximate, but they shine with the share of the
        // lamp that exists: the mask dims them about as much as it dims pt's image.
        // vct's injection samples the lamps as nee does: its approximation of direct light
        // dims with the mask as pt's image does.
        for (integrator, spp) in [("deferred", 4), ("vct", 4)] {
            let (a, b) = (
                mean(&masked, integrator, spp),
                mean(&whole, integrator, spp),
            );
            let (ratio, pt_ratio) = (a / b, reference / unmasked);
            println!("{name} lamp: {integrator} masked / whole {ratio:.3} (pt {pt_ratio:.3})");
            assert!(
                (ratio / pt_ratio - 1.0).abs() < 0.15,
                "{name} lamp: {integrator}'s mask dims by {ratio:.3}, pt's by {pt_ratio:.3}"
            );
        }
    }
}
