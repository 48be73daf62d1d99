//! The compressed 8-wide BVH (`accel: "cwbvh"`) against the binary BVH on lavapipe: closest-hit
//! and any-hit (shadow) queries, alpha cut-outs, every integrator, scenes far from the origin
//! (the requantisation into the camera frame), the kernels for sparse trees (`CWBVH_SPARSE`:
//! scenes of one to three spheres), pathological meshes whose binary trees are chains
//! (the depth bound that keeps the walk within its stack), the cache, the memory figures and the
//! option's spelling.
//!
//! With `cwbvh_bvh_order` the primitives are stored in the binary BVH's order (the CWBVH's leaves
//! reach them through their index buffer), so both structures number primitives and lights
//! alike and, finding the same nearest hits, must give the same image with the same seed.

use candela_tests::accel::{compiled, diff, load, translated};
use candela_tests::*;
use glam::DVec3;
use renderer::accel::{AccelKind, AccelOptions, AccelRequest, CacheStatus};
use renderer::layout::{GpuCwbvhNode, CWBVH_STACK_DEPTH};
use renderer::metrics::rel_mse;
use renderer::scene::{load_str, Scene};
use serde_json::{json, Value};

fn cwbvh(bvh_order: bool) -> AccelOptions {
    AccelOptions {
        kind: AccelKind::Cwbvh,
        cwbvh_bvh_order: bvh_order,
        ..Default::default()
    }
}

/// Renders `scene` with the binary BVH and the CWBVH (same seed); the images must agree.
fn cwbvh_matches_bvh(label: &str, scene: &Scene, integrator: &str, w: u32, spp: u32) {
    let bvh = compiled(scene, w, AccelOptions::default(), None);
    let (reference, stats) = render_compiled(scene, &bvh, integrator, spp, 7, None);
    assert_eq!(stats.accel, "bvh");
    let lit = reference.pixels.iter().filter(|p| p[0] > 0.0).count();
    assert!(lit > 0, "{label} {integrator}: black");
    let c = compiled(scene, w, cwbvh(true), None);
    let (img, stats) = render_compiled(scene, &c, integrator, spp, 7, None);
    assert_eq!(stats.accel, "cwbvh");
    let (n, e) = diff(&img, &reference);
    println!(
        "{label} {integrator}: cwbvh ({} nodes, {:.2} children a node, depth {}, {} accel bytes \
         vs the BVH's {}): {n} of {} pixels differ, relMSE {e:.3e}",
        c.cwbvh.as_ref().unwrap().nodes.len(),
        c.cwbvh.as_ref().unwrap().mean_children(),
        c.bvh_depth,
        c.accel.bytes,
        bvh.accel.bytes,
        img.pixels.len()
    );
    assert!(e < 1e-6, "{label} {integrator}: relMSE {e}");
}

#[test]
fn cwbvh_matches_bvh_on_meshes_and_spheres() {
    // Trees of mostly empty nodes are walked by the kernel that skips empty slots
    // (CWBVH_SPARSE): the one-sphere furnace and the three-sphere envmap scene.
    for (name, sparse) in [("furnace", true), ("envmap", true), ("cornell", false)] {
        let scene = load(&format!("{name}.json"));
        let c = compiled(&scene, 8, cwbvh(true), None);
        assert_eq!(c.cwbvh.as_ref().unwrap().sparse(), sparse, "{name}");
        cwbvh_matches_bvh(name, &scene, "nee", 24, 4);
    }
    cwbvh_matches_bvh("mirror_glass", &load("mirror_glass.json"), "nee", 24, 4);
    cwbvh_matches_bvh("textured_mesh", &load("textured_mesh.json"), "nee", 24, 4);
}

/// Alpha-masked triangles are skipped by both queries: the checker's dark squares (in its green
/// channel, 60 against 220; its red channel, 200 and 230, would cut nothing) cut holes in the
/// sphere, seen by camera rays (closest hit) and shadow rays (any hit).
#[test]
fn cwbvh_matches_bvh_with_alpha_cut_outs() {
    let text = std::fs::read_to_string(scene_path("textured_mesh.json")).unwrap();
    let mut v: Value = serde_json::from_str(&text).unwrap();
    v["materials"]["checker"]["alpha_mask"] =
        json!({"texture": "assets/checker.png", "scale": [2, 1], "channel": "g"});
    let scene = load_str(&v.to_string(), Some(&scene_path(""))).unwrap();
    let c = compiled(&scene, 8, cwbvh(true), None);
    assert!(c.features.alpha, "the scene has no alpha mask");
    cwbvh_matches_bvh("textured_mesh with alpha", &scene, "nee", 24, 4);
}

#[test]
fn cwbvh_serves_every_integrator() {
    let scene = load("cornell.json");
    // Every integrator users can pick (pt, nee, bdpt, whitted, deferred, ...).
    for integrator in renderer::integrators::names() {
        cwbvh_matches_bvh("cornell", &scene, integrator, 16, 2);
    }
}

/// Far from the origin the requantised nodes still contain their primitives as uploaded
/// (camera-relative), and a camera move keeps the cache key.
#[test]
fn cwbvh_far_from_the_origin_and_with_the_camera_moved() {
    let far = translated(&load("mirror_glass.json"), DVec3::new(1e5, -1e5, 1e5));
    cwbvh_matches_bvh("mirror_glass translated by 1e5", &far, "nee", 24, 4);
    let dir = scratch("cwbvh-cache-camera");
    let first = compiled(&far, 8, cwbvh(false), Some(&dir));
    let mut moved = far.clone();
    moved.camera.position += DVec3::new(0.5, 0.2, -0.3);
    let second = compiled(&moved, 8, cwbvh(false), Some(&dir));
    assert_eq!(
        (first.accel.cache, second.accel.cache),
        (CacheStatus::Miss, CacheStatus::Hit)
    );
    cwbvh_matches_bvh(
        "mirror_glass translated, camera moved",
        &moved,
        "nee",
        24,
        4,
    );
}

/// In its own leaf order (the default) the CWBVH numbers lights differently, so the image is
/// another estimate of the same picture: as close to the BVH's as the BVH's with another seed.
#[test]
fn cwbvh_in_its_own_order_converges_to_the_bvh_image() {
    let scene = load("cornell.json");
    let bvh = compiled(&scene, 16, AccelOptions::default(), None);
    let (a, _) = render_compiled(&scene, &bvh, "nee", 16, 1, None);
    let (b, _) = render_compiled(&scene, &bvh, "nee", 16, 2, None);
    let c = compiled(&scene, 16, cwbvh(false), None);
    assert!(
        c.cwbvh.as_ref().unwrap().prims.is_empty(),
        "leaf order: no index buffer"
    );
    let (g, _) = render_compiled(&scene, &c, "nee", 16, 1, None);
    let seeds = rel_mse(&b, &a).unwrap();
    let accel = rel_mse(&g, &a).unwrap();
    println!("cornell nee 16 spp: cwbvh (own order) vs BVH {accel:.3e}, seeds {seeds:.3e}");
    assert!(accel < 2.0 * seeds, "cwbvh {accel} vs seed noise {seeds}");
}

/// The cache keys the CWBVH apart from the binary BVH (another file, another kind), a second
/// compile loads identical buffers, and the memory figures count what the CWBVH uploads.
#[test]
fn cwbvh_cache_and_memory_figures() {
    let dir = scratch("cwbvh-cache");
    let scene = load("textured_mesh.json");
    let bvh = compiled(&scene, 16, AccelOptions::default(), Some(&dir));
    let first = compiled(&scene, 16, cwbvh(false), Some(&dir));
    assert_eq!(first.accel.cache, CacheStatus::Miss, "keyed like the BVH");
    let second = compiled(&scene, 16, cwbvh(false), Some(&dir));
    assert_eq!(second.accel.cache, CacheStatus::Hit);
    assert_eq!(first.cwbvh, second.cwbvh);
    // Compared as printed: unused index fields hold NONE, a NaN as f32 (never equal to itself).
    assert!(format!("{:?}", first.prims) == format!("{:?}", second.prims));
    let ordered = compiled(&scene, 16, cwbvh(true), Some(&dir));
    assert_eq!(
        ordered.accel.cache,
        CacheStatus::Miss,
        "the testing aid is in the key"
    );
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    println!("{names:?}");
    assert_eq!(names.iter().filter(|n| n.starts_with("cwbvh-")).count(), 2);
    assert_eq!(names.iter().filter(|n| n.starts_with("bvh-")).count(), 1);
    // Memory: the CWBVH's nodes (80 bytes) are the structure (in leaf order no index buffer;
    // with the testing aid 4 bytes a primitive more); no binary nodes beyond the 16-byte
    // placeholder.
    let cw = second.cwbvh.as_ref().unwrap();
    let want = (cw.nodes.len() * std::mem::size_of::<GpuCwbvhNode>()) as u64;
    assert_eq!(second.accel.bytes, want);
    assert!(cw.prims.is_empty());
    let indirect = ordered.cwbvh.as_ref().unwrap();
    assert_eq!(indirect.prims.len(), second.prims.len());
    assert_eq!(ordered.accel.bytes, want + 4 * second.prims.len() as u64);
    let ob = renderer::memory::scene_bytes(&ordered);
    assert_eq!(ob.accel, want + 4 * second.prims.len() as u64 + 32);
    let b = renderer::memory::scene_bytes(&second);
    let bb = renderer::memory::scene_bytes(&bvh);
    assert_eq!(b.geometry, bb.geometry);
    assert_eq!(
        b.accel,
        want + 16 + 16,
        "cwbvh buffers + the empty BVH nodes and parents"
    );
    let (_, stats) = render_compiled(&scene, &second, "nee", 1, 1, None);
    assert_eq!(stats.accel_bytes, b.accel);
    let per_tri = (stats.geometry_bytes + b.accel) as f64 / second.triangle_count as f64;
    println!(
        "textured_mesh: cwbvh {} accel bytes ({} nodes) vs BVH {}; {:.1} GPU bytes a triangle \
         (report: {:.1})",
        b.accel,
        cw.nodes.len(),
        bb.accel,
        per_tri,
        stats.gpu_bytes_per_triangle
    );
    assert!((stats.gpu_bytes_per_triangle - per_tri).abs() < 1e-6 * per_tri);
}

/// "cwbvh" is spelled the same by scenes, the CLI and jobs; "auto" (the default) takes it for
/// large meshes without instances, the binary BVH for scenes with instances, and below
/// AUTO_CWBVH_TRIANGLES builds both and keeps the one of lower estimated cost per ray
/// (accel/estimate.rs): the Cornell box's walls overlap (the CWBVH), one sphere does not (the
/// binary BVH).
#[test]
fn cwbvh_is_selectable_by_name_and_auto_picks_it_for_large_meshes() {
    let text = std::fs::read_to_string(scene_path("cornell.json")).unwrap();
    let mut v: Value = serde_json::from_str(&text).unwrap();
    let cornell = load_str(&text, Some(&scene_path(""))).unwrap();
    let named = |name: &str, s: &Scene| {
        let request = AccelRequest {
            kind: Some(name),
            grid_resolution: None,
        };
        AccelOptions::resolve(request, s.render.accel_request(), s.accel_size()).unwrap()
    };
    assert_eq!(named("cwbvh", &cornell).kind, AccelKind::Cwbvh);
    assert!(!named("cwbvh", &cornell).by_estimate && !named("bvh", &cornell).by_estimate);
    let default = |s: &Scene| {
        AccelOptions::resolve(
            AccelRequest::default(),
            s.render.accel_request(),
            s.accel_size(),
        )
        .unwrap()
    };
    assert!(
        default(&cornell).by_estimate,
        "36 triangles: auto estimates"
    );
    assert_eq!(named("auto", &cornell), default(&cornell));
    // The estimates choose: the Cornell box the CWBVH, the furnace's one sphere the binary BVH;
    // the report carries both costs.
    let c = compiled(&cornell, 8, default(&cornell), None);
    let costs = c.accel.estimate.expect("estimated");
    assert_eq!(c.accel.kind, AccelKind::Cwbvh, "{costs:?}");
    assert!(c.cwbvh.is_some() && c.nodes.is_empty() && costs.cwbvh < costs.bvh);
    let furnace = load("furnace.json");
    let f = compiled(&furnace, 8, default(&furnace), None);
    let costs = f.accel.estimate.expect("estimated");
    assert_eq!(f.accel.kind, AccelKind::Bvh, "{costs:?}");
    assert!(f.cwbvh.is_none() && costs.bvh <= costs.cwbvh);
    let (_, stats) = render_compiled(&furnace, &f, "pt", 1, 1, None);
    assert_eq!(stats.accel, "bvh");
    assert_eq!(stats.accel_estimate, Some(costs));
    // A named structure is built alone, without estimates.
    assert_eq!(
        compiled(&cornell, 8, named("bvh", &cornell), None)
            .accel
            .estimate,
        None
    );
    v["render"]["accel"] = json!("cwbvh");
    let s = load_str(&v.to_string(), Some(&scene_path(""))).unwrap();
    assert_eq!(
        default(&s).kind,
        AccelKind::Cwbvh,
        "the scene's render.accel"
    );
    assert_eq!(named("bvh", &s).kind, AccelKind::Bvh, "the request wins");
    // The same box with AUTO_CWBVH_TRIANGLES triangles (one mesh's repeated): auto takes the
    // CWBVH without estimating; one triangle fewer estimates, and an instance keeps the binary
    // BVH.
    let mut big = cornell.clone();
    let mesh = &mut big.meshes[0];
    let n = renderer::accel::AUTO_CWBVH_TRIANGLES as usize;
    let rest: usize = cornell.meshes[1..].iter().map(|m| m.indices.len()).sum();
    let first = mesh.indices[0];
    mesh.indices.resize(n - rest, first);
    mesh.materials.resize(n - rest, mesh.materials[0]);
    assert_eq!(default(&big).kind, AccelKind::Cwbvh);
    assert!(!default(&big).by_estimate);
    let mut fewer = big.clone();
    fewer.meshes[0].indices.pop();
    fewer.meshes[0].materials.pop();
    assert!(default(&fewer).by_estimate);
    let mut instanced = big.clone();
    instanced.prototypes.push(cornell.meshes[0].clone());
    instanced.instances.push(renderer::scene::Instance {
        prototype: 0,
        to_world: glam::DMat4::IDENTITY,
        material: None,
    });
    assert_eq!(default(&instanced).kind, AccelKind::Bvh);
    assert!(!default(&instanced).by_estimate);
}

// Pathological meshes (as in accel_deep.rs): each has an analytic twin that must render the
// same picture. Lit by a point light only, so the light table does not depend on the primitive
// order; shadow rays cross the meshes too.

const W: u32 = 24;

fn deep_scene(extra: Vec<Value>) -> Scene {
    let mut objects = vec![
        json!({"type": "quad", "origin": [-1, 0, 1], "edge_u": [2, 0, 0], "edge_v": [0, 0, -2],
               "material": "white"}),
        json!({"type": "quad", "origin": [-1, 0, -1], "edge_u": [2, 0, 0], "edge_v": [0, 2, 0],
               "material": "white"}),
    ];
    objects.extend(extra);
    let s = json!({
        "version": 1,
        "camera": {"position": [0.3, 1.2, 2.6], "look_at": [0, 0.4, 0], "up": [0, 1, 0],
                   "fov_y": 50},
        "film": {"width": W, "height": W},
        "materials": {
            "white": {"type": "diffuse", "reflectance": [0.8, 0.8, 0.8]},
            "red": {"type": "diffuse", "reflectance": [0.8, 0.2, 0.1]}
        },
        "objects": objects,
        "lights": [{"type": "point", "position": [0.1, 1.7, 0.6], "intensity": [3, 3, 3]}],
        "render": {"max_depth": 3}
    });
    load_str(&s.to_string(), None).expect("scene")
}

fn triangles(tris: &[[[f64; 3]; 3]]) -> Value {
    let positions: Vec<[f64; 3]> = tris.iter().flatten().copied().collect();
    let indices: Vec<u32> = (0..positions.len() as u32).collect();
    json!({"type": "triangles", "positions": positions, "indices": indices, "material": "red"})
}

/// The most groups a walk can push: along a root-to-node path, one per node above it.
fn stack_need(nodes: &[GpuCwbvhNode]) -> usize {
    let mut most = 0;
    let mut stack = vec![(0usize, 1usize)];
    while let Some((i, d)) = stack.pop() {
        most = most.max(d - 1);
        let n = &nodes[i];
        for k in 0..n.e_imask[3].count_ones() as usize {
            stack.push((n.child_base as usize + k, d + 1));
        }
    }
    most
}

fn cwbvh_renders_like(label: &str, deep: &Scene, twin: &Scene) {
    let (reference, _) = render_compiled(
        twin,
        &compiled(twin, W, cwbvh(false), None),
        "nee",
        4,
        5,
        None,
    );
    let lit = reference.pixels.iter().filter(|p| p[0] > 0.0).count();
    assert!(
        lit > reference.pixels.len() / 4,
        "{label}: the twin is mostly black"
    );
    let bvh = compiled(deep, W, AccelOptions::default(), None);
    let (bvh_img, _) = render_compiled(deep, &bvh, "nee", 4, 5, None);
    let c = compiled(deep, W, cwbvh(false), None);
    let need = stack_need(&c.cwbvh.as_ref().unwrap().nodes);
    let (img, _) = render_compiled(deep, &c, "nee", 4, 5, None);
    let (n, e) = diff(&img, &reference);
    let (nb, eb) = diff(&bvh_img, &reference);
    println!(
        "{label}: {} primitives, binary BVH depth {}, CWBVH depth {} (a walk pushes at most \
         {need} of {CWBVH_STACK_DEPTH} groups): cwbvh {n} of {} pixels differ from the twin, \
         relMSE {e:.3e} (binary BVH: {nb}, {eb:.3e})",
        c.prims.len(),
        bvh.bvh_depth,
        c.bvh_depth,
        img.pixels.len()
    );
    assert!(
        c.bvh_depth <= CWBVH_STACK_DEPTH as usize,
        "{label}: {}",
        c.bvh_depth
    );
    assert!(need < CWBVH_STACK_DEPTH as usize);
    assert!(e < 1e-4, "{label}: relMSE {e}");
}

#[test]
fn cwbvh_identical_triangles_render_like_one() {
    let t = [[-0.4, 0.8, -0.2], [0.4, 0.8, -0.2], [0.0, 0.8, 0.5]];
    let deep = deep_scene(vec![triangles(&vec![t; 600])]);
    let twin = deep_scene(vec![triangles(&[t])]);
    cwbvh_renders_like("600 identical triangles", &deep, &twin);
}

#[test]
fn cwbvh_nested_and_degenerate_triangles() {
    // Vertical triangles on z = -0.5 sharing the corner c, each 0.95 times the last: PLOC
    // chains them one level per triangle.
    let c = [-0.6, 0.05, -0.5];
    let tri = |s: f64| [c, [c[0] + s, c[1], c[2]], [c[0], c[1] + s, c[2]]];
    let nested: Vec<_> = (0..300).map(|k| tri(1.2 * 0.95f64.powi(k))).collect();
    let deep = deep_scene(vec![triangles(&nested)]);
    let twin = deep_scene(vec![triangles(&[tri(1.2)])]);
    cwbvh_renders_like("300 nested triangles", &deep, &twin);
    // Zero-area triangles on one diagonal line, nested about its foot: render like nothing.
    let p = [-0.5, 0.02, -0.3];
    let d = [0.6, 0.8, 0.45];
    let at = |s: f64| [p[0] + s * d[0], p[1] + s * d[1], p[2] + s * d[2]];
    let slivers: Vec<_> = (0..400)
        .map(|k| {
            let s = 1.8 * 0.96f64.powi(k);
            [p, at(0.5 * s), at(s)]
        })
        .collect();
    cwbvh_renders_like(
        "400 collinear slivers",
        &deep_scene(vec![triangles(&slivers)]),
        &deep_scene(vec![]),
    );
}

/// A mesh big enough that PLOC's binary tree is far deeper than the wide stack on the host
/// (no render: the bound is a property of the build), a million identical triangles.
#[test]
fn a_million_identical_triangles_fit_the_stack() {
    let t = [[-0.4, 0.8, -0.2], [0.4, 0.8, -0.2], [0.0, 0.8, 0.5]];
    let deep = deep_scene(vec![triangles(&vec![t; 1_000_000])]);
    let c = compiled(&deep, 8, cwbvh(false), None);
    let need = stack_need(&c.cwbvh.as_ref().unwrap().nodes);
    println!(
        "1e6 identical triangles: CWBVH depth {}, {} nodes, a walk pushes at most {need}, built \
         in {:.2} s",
        c.bvh_depth,
        c.cwbvh.as_ref().unwrap().nodes.len(),
        c.accel.build_time.as_secs_f64()
    );
    assert!(c.bvh_depth <= CWBVH_STACK_DEPTH as usize);
    assert!(need < CWBVH_STACK_DEPTH as usize);
}

/// The CLI: `--accel cwbvh` renders, reports the CWBVH (kind, nodes, bytes) and caches it; an
/// unknown name lists it among the choices.
#[test]
fn cli_accel_cwbvh() {
    let dir = scratch("cwbvh-cli");
    let out = dir.join("o.exr");
    let cache = dir.join("cache");
    let (out_s, cache_s) = (out.to_str().unwrap(), cache.to_str().unwrap());
    let run = |extra: &[&str]| {
        let mut args = vec!["render", "scenes/cornell.json", "-o", out_s];
        args.extend_from_slice(&["--width", "8", "--height", "8", "--spp", "1"]);
        args.extend_from_slice(extra);
        run_candela(&args)
    };
    assert_bad_input(&run(&["--accel", "kd"]), &["--accel", "kd", "cwbvh"]);
    assert_bad_input(
        &run(&["--accel", "cwbvh", "--grid-resolution", "8"]),
        &["--grid-resolution"],
    );
    let json = |o: std::process::Output| -> Value {
        assert!(o.status.success(), "{}", text(&o.stderr));
        serde_json::from_slice(&o.stdout).expect("one JSON object")
    };
    let args = ["--accel", "cwbvh", "--json", "--accel-cache", cache_s];
    let first = json(run(&args));
    assert_eq!(first["accel"], "cwbvh");
    assert_eq!(first["accel_cache"], "miss");
    assert!(first["bvh_nodes"].as_u64().unwrap() >= 1);
    assert!(first["accel_bytes"].as_u64().unwrap() >= 80);
    let second = json(run(&args));
    assert_eq!(second["accel_cache"], "hit");
    assert_eq!(first["accel_bytes"], second["accel_bytes"]);
    // The report names the kernel variant that ran (the Cornell box's tree is full: no
    // CWBVH_SPARSE).
    let defines: Vec<&str> = (first["kernel_defines"].as_array().expect("kernel_defines"))
        .iter()
        .map(|d| d.as_str().unwrap())
        .collect();
    assert!(defines.contains(&"ACCEL_CWBVH=1"), "{defines:?}");
    assert!(
        !defines.iter().any(|d| d.starts_with("CWBVH_SPARSE")),
        "{defines:?}"
    );
}

/// The measuring define COUNT_STEPS (through `CANDELA_SHADER_DEFINES`, listed in the report's
/// `kernel_defines`) makes `rays` count node fetches (1) or primitive tests (2): on the Cornell
/// box the 8-wide tree fetches fewer nodes per ray than the binary one, and tests fewer walls.
#[test]
fn count_steps_knob_counts_nodes_and_primitives() {
    let dir = scratch("count-steps");
    let out = dir.join("o.exr");
    let report = |accel: &str, count: &str| -> Value {
        let mut args = vec!["render", "scenes/cornell.json", "-o", out.to_str().unwrap()];
        args.extend_from_slice(&[
            "--width", "16", "--height", "12", "--spp", "2", "--seed", "3",
        ]);
        args.extend_from_slice(&["--accel", accel, "--no-accel-cache", "--json"]);
        let o = run_candela_env(&args, &[("CANDELA_SHADER_DEFINES", count)]);
        assert!(o.status.success(), "{}", text(&o.stderr));
        serde_json::from_slice(&o.stdout).expect("one JSON object")
    };
    let per_ray = |accel: &str| -> (f64, f64) {
        let rays = report(accel, "")["rays"].as_f64().unwrap();
        let r = report(accel, "COUNT_STEPS=1");
        assert!(
            r["kernel_defines"].to_string().contains("COUNT_STEPS=1"),
            "{r}"
        );
        let nodes = r["rays"].as_f64().unwrap();
        let prims = report(accel, "COUNT_STEPS=2")["rays"].as_f64().unwrap();
        (nodes / rays, prims / rays)
    };
    let (bvh, cw) = (per_ray("bvh"), per_ray("cwbvh"));
    println!("nodes, primitives per ray: bvh {bvh:?}, cwbvh {cw:?}");
    assert!(bvh.0 >= 1.0 && cw.0 >= 1.0 && bvh.1 >= 1.0 && cw.1 >= 1.0);
    assert!(cw.0 < bvh.0 && cw.1 < bvh.1);
}

/// The measuring define COUNT_CLOCK makes `rays` the subgroup-clock cycles spent in closest-hit
/// walks (1) or the whole pass kernels (3; any-hit walks, 2, are counted as closest-hit ones
/// are): both are counted, and the walks take part of the kernels' cycles, not more; for pt
/// and for bdpt (two pass kernels).
#[test]
fn count_clock_knob_counts_the_walks_cycles() {
    let dir = scratch("count-clock");
    let out = dir.join("o.exr");
    let cycles = |integrator: &str, count: &str| -> f64 {
        let args = [
            "render",
            "scenes/cornell.json",
            "-o",
            out.to_str().unwrap(),
            "--width",
            "16",
            "--height",
            "12",
            "--spp",
            "2",
            "--seed",
            "3",
            "--integrator",
            integrator,
            "--json",
        ];
        let o = run_candela_env(&args, &[("CANDELA_SHADER_DEFINES", count)]);
        assert!(o.status.success(), "{}", text(&o.stderr));
        let r: Value = serde_json::from_slice(&o.stdout).expect("one JSON object");
        assert!(r["kernel_defines"].to_string().contains(count), "{r}");
        r["rays"].as_f64().unwrap()
    };
    for integrator in ["pt", "bdpt"] {
        let closest = cycles(integrator, "COUNT_CLOCK=1");
        let total = cycles(integrator, "COUNT_CLOCK=3");
        println!("{integrator} cycles: closest-hit walks {closest}, kernels {total}");
        assert!(
            closest > 0.0 && closest < total,
            "{closest} against {total}"
        );
    }
}

/// A cache file whose CWBVH is not a tree within the stack (a cycle, a leaf out of range, too
/// deep) is refused on load and rebuilt: the depth bound the traversal relies on is checked, not
/// trusted.
#[test]
fn cwbvh_cache_entries_are_checked() {
    use renderer::accel::cache;
    let dir = scratch("cwbvh-cache-checked");
    let scene = load("textured_mesh.json");
    let built = compiled(&scene, 8, cwbvh(false), Some(&dir));
    assert_eq!(built.accel.cache, CacheStatus::Miss);
    let name = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .find(|n| n.starts_with("cwbvh-"))
        .unwrap();
    let hex = &name["cwbvh-".len()..name.len() - ".bin".len()];
    let key = [
        u64::from_str_radix(&hex[..16], 16).unwrap(),
        u64::from_str_radix(&hex[16..], 16).unwrap(),
    ];
    let good = cache::load(&dir, AccelKind::Cwbvh, key).expect("the entry");
    let (nodes, _) = good.cwbvh.clone().unwrap();
    assert!(nodes.len() > 2 && nodes[0].e_imask[3] != 0);
    // A chain deeper than the stack: node k's first inner child is node k + 1.
    let mut chain = vec![nodes[0]; CWBVH_STACK_DEPTH as usize + 2];
    for (k, n) in chain.iter_mut().enumerate() {
        n.e_imask[3] = 1;
        n.meta = [0b0011_1000, 0, 0, 0, 0, 0, 0, 0];
        n.child_base = (k + 1) as u32;
    }
    chain.last_mut().unwrap().e_imask[3] = 0;
    chain.last_mut().unwrap().meta = [0; 8];
    let corruptions: Vec<(&str, Vec<GpuCwbvhNode>)> = vec![
        ("a cycle", {
            let mut v = nodes.clone();
            v[0].child_base = 0;
            v
        }),
        ("a leaf out of range", {
            let mut v = nodes.clone();
            let leaf = v.iter().position(|n| n.e_imask[3] != 0xff).unwrap();
            v[leaf].prim_base = 1 << 30;
            v
        }),
        ("deeper than the stack", chain),
    ];
    for (what, bad) in corruptions {
        let mut e = good.clone();
        e.cwbvh = Some((bad, Vec::new()));
        cache::store(&dir, AccelKind::Cwbvh, key, &e).unwrap();
        let again = compiled(&scene, 8, cwbvh(false), Some(&dir));
        assert_eq!(again.accel.cache, CacheStatus::Miss, "{what}: accepted");
        assert_eq!(again.cwbvh, built.cwbvh, "{what}: rebuilt");
    }
    let hit = compiled(&scene, 8, cwbvh(false), Some(&dir));
    assert_eq!(hit.accel.cache, CacheStatus::Hit);
}
