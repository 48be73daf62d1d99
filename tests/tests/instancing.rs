//! Instancing (docs/scene-format.md, `definitions` and `instance` objects): an instanced scene
//! renders the image of its flattened copy (the same objects written out in place), for inline
//! and OBJ-backed definitions placed with rotations, non-uniform scales, a mirror and a material
//! override; ten thousand instances build and render quickly with memory that follows the
//! unique geometry; what is not supported is refused naming the field or the setting.

use candela_tests::*;
use renderer::accel::{AccelKind, AccelOptions, CacheStatus};
use renderer::compile::{compile, compile_with, CompileOptions};
use renderer::film::Image;
use renderer::scene::Scene;
use serde_json::{json, Value};

/// The Cornell box of scenes/cornell.json without its two blocks, lit by one emissive sphere
/// instead of its quad (lights are numbered in BVH order, which the flattened copy's extra
/// triangles change: with one light, the same seed draws the same light samples), with
/// `objects` added, and `definitions` when given. Assets resolve against scenes/.
fn cornell_with(objects: Vec<Value>, definitions: Option<Value>) -> Scene {
    let base = std::fs::read_to_string(scene_path("cornell.json")).unwrap();
    let mut v: Value = serde_json::from_str(&base).unwrap();
    let list = v["objects"].as_array_mut().unwrap();
    list.retain(|o| o["type"] != "box" && o["material"] != "light");
    list.push(
        json!({"type": "sphere", "center": [0, 0.75, 0], "radius": 0.12, "material": "light"}),
    );
    list.extend(objects);
    if let Some(d) = definitions {
        v["definitions"] = d;
    }
    v["materials"]["blue"] = json!({"type": "diffuse", "reflectance": [0.1, 0.2, 0.7]});
    v["materials"]["metal"] = json!({"type": "conductor", "roughness": 0.3});
    // The checker's green channel (60 and 220) cuts every other square; its red channel (200
    // and 230) would cut nothing.
    v["materials"]["cutout"] = json!({"type": "diffuse", "reflectance": [0.7, 0.6, 0.2],
        "alpha_mask": {"texture": "assets/checker.png", "scale": [2, 2], "channel": "g"}});
    let dir = scene_path("cornell.json").parent().unwrap().to_path_buf();
    renderer::scene::load_str(&v.to_string(), Some(&dir)).unwrap_or_else(|e| panic!("{e}"))
}

/// The placements: rotation with uniform scale, a non-uniform scale, a mirror (negative
/// determinant) with a rotation, a sheared matrix; (transform, material override).
fn placements() -> Vec<(Value, Option<&'static str>)> {
    vec![
        (
            json!({"scale": 0.3, "rotate": {"axis": [0, 1, 0], "angle": 30}, "translate": [-0.45, -0.65, -0.3]}),
            None,
        ),
        (
            json!({"scale": [0.2, 0.35, 0.25], "rotate": {"axis": [1, 1, 0], "angle": 40}, "translate": [0.45, -0.55, 0.1]}),
            Some("blue"),
        ),
        (
            json!({"scale": [-0.25, 0.25, 0.25], "rotate": {"axis": [0, 0, 1], "angle": 20}, "translate": [0.0, 0.35, -0.4]}),
            Some("metal"),
        ),
        (
            json!({"matrix": [0.2, 0.1, 0, -0.5, 0, 0.2, 0.05, 0.3, 0, 0, 0.15, 0.3, 0, 0, 0, 1]}),
            None,
        ),
    ]
}

/// The scene with `shape` (an object without material and transform) defined once and placed
/// by every placement, and its flattened copy.
fn instanced_and_flat(shape: Value, material: &str) -> (Scene, Scene) {
    let overrides: Vec<_> = placements().into_iter().map(|p| p.1).collect();
    instanced_and_flat_with(shape, material, &overrides)
}

/// [`instanced_and_flat`] with the placements' material overrides replaced by `overrides`.
fn instanced_and_flat_with(
    shape: Value,
    material: &str,
    overrides: &[Option<&str>],
) -> (Scene, Scene) {
    let mut def = shape.clone();
    def["material"] = json!(material);
    let mut instances = Vec::new();
    let mut flat = Vec::new();
    for ((t, _), &m) in placements().into_iter().zip(overrides) {
        let mut i = json!({"type": "instance", "definition": "piece", "transform": t});
        let mut f = shape.clone();
        f["transform"] = t;
        f["material"] = json!(m.unwrap_or(material));
        if let Some(m) = m {
            i["material"] = json!(m);
        }
        instances.push(i);
        flat.push(f);
    }
    (
        cornell_with(instances, Some(json!({ "piece": def }))),
        cornell_with(flat, None),
    )
}

/// Mean |a − b| over the mean of b, and the share of pixels that differ by more than 1% of
/// the image's mean.
fn difference(a: &Image, b: &Image) -> (f64, f64) {
    let m = mean(b).iter().sum::<f64>() / 3.0;
    let (mut sum, mut off) = (0.0, 0usize);
    for (p, q) in a.pixels.iter().zip(&b.pixels) {
        let d: f64 = p
            .iter()
            .zip(q)
            .map(|(x, y)| (*x as f64 - *y as f64).abs())
            .sum::<f64>()
            / 3.0;
        sum += d;
        if d > 0.01 * m {
            off += 1;
        }
    }
    let n = a.pixels.len() as f64;
    (sum / n / m, off as f64 / n)
}

const SIZE: u32 = 32;

fn assert_same_image(inst: &Scene, flat: &Scene, what: &str) {
    for integrator in ["pt", "nee"] {
        let (a, sa) = render_loaded(inst, integrator, 4, SIZE, SIZE, 7, Some(4));
        let (b, sb) = render_loaded(flat, integrator, 4, SIZE, SIZE, 7, Some(4));
        assert_eq!(sb.instances, 0);
        assert_eq!(sa.instances, 4, "{what}");
        let (rel, share) = difference(&a, &b);

        println!("{what}, {integrator}: mean |Δ| {rel:.2e} of the mean, {share:.3} of pixels off");
        assert!(mean(&a)[0] > 0.01, "{what}: a dark image proves nothing");
        // Rounding differs (rays meet the triangles in the prototype's frame), so a path may
        // now and then take another turn at an edge; nothing more.
        assert!(
            rel < 1e-3 && share < 0.01,
            "{what}, {integrator}: {rel} {share}"
        );
    }
}

#[test]
fn instanced_boxes_render_like_their_flattened_copy() {
    let (inst, flat) = instanced_and_flat(
        json!({"type": "box", "min": [-1, -1, -1], "max": [1, 1, 1]}),
        "white",
    );
    assert_eq!(inst.prototypes.len(), 1);
    assert_eq!(inst.instances.len(), 4);
    assert_eq!(inst.instanced_triangles(), 48);
    assert_same_image(&inst, &flat, "boxes");
}

#[test]
fn obj_backed_instances_render_like_their_flattened_copy() {
    // uv_sphere.obj has vertex normals and uvs: shading normals go through the inverse
    // transpose, and a mirrored instance keeps its facing.
    let (inst, flat) = instanced_and_flat(
        json!({"type": "mesh", "file": "assets/uv_sphere.obj"}),
        "white",
    );
    assert_same_image(&inst, &flat, "OBJ spheres");
}

/// Ten thousand instances of a 12-triangle box, on a grid with rotations: the prototype is
/// stored once (GPU memory for triangles follows the unique geometry; each instance costs a
/// record and a top-level BVH leaf), and a tiny image renders.
#[test]
fn ten_thousand_instances_build_and_render() {
    let mut objects = Vec::new();
    for k in 0..10_000 {
        let (i, j) = ((k % 100) as f64, (k / 100) as f64);
        objects.push(json!({
            "type": "instance",
            "definition": "cube",
            "transform": {
                "scale": [0.006, 0.01, 0.006],
                "rotate": {"axis": [0, 1, 0], "angle": (k * 7) % 360},
                "translate": [-0.9 + 0.018 * i, -0.99, -0.9 + 0.018 * j]
            }
        }));
    }
    let defs =
        json!({"cube": {"type": "box", "min": [-1, 0, -1], "max": [1, 2, 1], "material": "white"}});
    let scene = cornell_with(objects, Some(defs));
    assert_eq!(scene.instances.len(), 10_000);
    assert_eq!(scene.instanced_triangles(), 120_000);
    let start = std::time::Instant::now();
    let c = compile(&scene, 24, 24).unwrap();
    println!("compiled 10000 instances in {:?}", start.elapsed());
    let unique = c.triangle_count;
    assert_eq!(unique, 10 + 12, "walls (10 triangles) and one cube");
    assert_eq!(c.instances.len(), 10_000);
    let (img, stats) = render_loaded(&scene, "nee", 1, 24, 24, 3, Some(3));
    assert_eq!(stats.instances, 10_000);
    assert_eq!(stats.instanced_triangles, 120_000);
    // A record (112 bytes) and about two top-level nodes (64 bytes each) per instance.
    assert!(
        stats.gpu_bytes_per_instance > 112.0 && stats.gpu_bytes_per_instance < 112.0 + 3.0 * 64.0,
        "{}",
        stats.gpu_bytes_per_instance
    );
    assert!(
        stats.geometry_bytes < 40 * 48 * 4,
        "{}",
        stats.geometry_bytes
    );
    assert!(mean(&img)[0] > 0.01);
    println!(
        "{} GPU bytes per instance, geometry {} bytes, accel {} bytes, {:?} in all",
        stats.gpu_bytes_per_instance,
        stats.geometry_bytes,
        stats.accel_bytes,
        start.elapsed()
    );
}

/// A hundred thousand instances of a 500,000-triangle definition load in about the time of
/// their JSON: each instance's checks are O(1) (whether the definition emits is computed once;
/// scanning its triangles per instance, 5·10^10 steps here, took tens of seconds).
#[test]
fn many_instances_of_a_big_definition_load_quickly() {
    let indices: Vec<u32> = (0..500_000).flat_map(|_| [0, 1, 2]).collect();
    let defs = json!({"big": {"type": "triangles", "positions": [0, 0, 0, 1, 0, 0, 0, 1, 0],
        "indices": indices, "material": "white"}});
    let objects: Vec<Value> = (0..100_000)
        .map(|k| {
            json!({"type": "instance", "definition": "big",
            "transform": {"translate": [k as f64 * 0.001, 0, 0]}})
        })
        .collect();
    let json = minimal(Value::Array(objects), defs).to_string();
    let start = std::time::Instant::now();
    let scene = renderer::scene::load_str(&json, None).unwrap_or_else(|e| panic!("{e}"));
    let took = start.elapsed();
    println!("loaded 100000 instances of 500000 triangles in {took:?}");
    assert_eq!(scene.instances.len(), 100_000);
    assert_eq!(scene.instanced_triangles(), 50_000_000_000);
    assert!(took < std::time::Duration::from_secs(5), "{took:?}");
    // Written out (a grid has no second level) they would be 50 billion triangles: refused at
    // once, naming the counts, before anything is allocated.
    let opts = CompileOptions {
        accel: AccelOptions {
            kind: AccelKind::Grid,
            ..Default::default()
        },
        cache: None,
        expand_instances: false,
        max_triangles: None,
    };
    let Err(e) = compile_with(&scene, 8, 8, &opts) else {
        panic!("50 billion triangles written out");
    };
    assert_eq!(
        e.to_string(),
        "instances: writing out 100000 instances as meshes (accel \"grid\" has no second \
         level) would make 50000000000 triangles; at most 50000000"
    );
}

/// A thousand instances with identical world boxes (the top-level BVH cannot separate them; it
/// is built balanced, within the shader's stack, which has no fallback) render the image of one
/// instance. Every ray reaching the quad tests every copy: on lavapipe, which silently ends a
/// shader's loops after 65,535 iterations (render/session.rs), about 2,000 copies at three
/// bounces already truncate paths, so the count stays well below. The TLAS depth for 5,000
/// copies is checked without rendering (compile/instances.rs).
#[test]
fn coincident_instances_render_like_one() {
    let defs = json!({"q": {"type": "quad", "origin": [-0.3, -0.3, 0], "edge_u": [0.6, 0, 0],
        "edge_v": [0, 0.6, 0], "material": "blue"}});
    let one = json!({"type": "instance", "definition": "q"});
    let many = cornell_with(vec![one.clone(); 1000], Some(defs.clone()));
    let single = cornell_with(vec![one], Some(defs));
    let start = std::time::Instant::now();
    let (a, _) = render_loaded(&many, "nee", 1, 16, 16, 2, Some(3));
    println!(
        "1000 coincident instances rendered in {:?}",
        start.elapsed()
    );
    let (b, _) = render_loaded(&single, "nee", 1, 16, 16, 2, Some(3));
    let (rel, share) = difference(&a, &b);
    assert!(mean(&b)[2] > 0.01);
    assert!(rel < 1e-4 && share < 0.01, "{rel} {share}");
}

fn load_err(v: Value) -> String {
    let dir = scene_path("cornell.json").parent().unwrap().to_path_buf();
    renderer::scene::load_str(&v.to_string(), Some(&dir))
        .err()
        .unwrap_or_else(|| panic!("accepted {v}"))
        .to_string()
}

fn minimal(objects: Value, definitions: Value) -> Value {
    json!({
        "version": 1,
        "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0]},
        "film": {"width": 8, "height": 8},
        "materials": {
            "white": {"type": "diffuse"},
            "lamp": {"type": "diffuse", "emission": [4, 4, 4]}
        },
        "objects": objects,
        "definitions": definitions
    })
}

#[test]
fn instance_errors_name_the_field() {
    let quad = json!({"type": "quad", "origin": [0, 0, 0], "edge_u": [1, 0, 0], "edge_v": [0, 1, 0], "material": "white"});
    let cases = [
        (
            minimal(json!([{"type": "instance", "definition": "qaud"}]), json!({"quad": quad})),
            "objects[0].definition: no definition \"qaud\" (defined: quad)",
        ),
        (
            minimal(json!([{"type": "instance", "definition": "x"}]), json!({})),
            "objects[0].definition: no definition \"x\"",
        ),
        (
            minimal(
                json!([]),
                json!({"a": quad, "b": {"type": "instance", "definition": "a"}}),
            ),
            "definitions.b.type: a definition holds triangles (mesh, triangles, quad or box), not an instance (nested instancing is not supported)",
        ),
        (
            minimal(
                json!([]),
                json!({"s": {"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "white"}}),
            ),
            "definitions.s.type: a definition holds triangles",
        ),
        (
            minimal(
                json!([{"type": "instance", "definition": "quad", "material": "wood"}]),
                json!({"quad": quad}),
            ),
            "objects[0].material: no material \"wood\"",
        ),
        (
            minimal(
                json!([{"type": "instance", "definition": "quad", "transform": {"scale": [1, 0, 1]}}]),
                json!({"quad": quad}),
            ),
            "objects[0].transform.scale: must be non-zero",
        ),
        (
            minimal(
                json!([{"type": "instance", "definition": "quad", "transform": {"translate": [1e39, 0, 0]}}]),
                json!({"quad": quad}),
            ),
            "objects[0].transform: places the definition beyond the range of 32-bit floats",
        ),
        (
            minimal(
                json!([{"type": "instance", "definition": "quad", "radius": 2}]),
                json!({"quad": quad}),
            ),
            "objects[0].radius: unknown field",
        ),
        (
            minimal(
                json!([]),
                json!({"m": {"type": "mesh", "file": "assets/missing.obj", "material": "white"}}),
            ),
            "definitions.m.file",
        ),
        (
            // Accepted by the relative invertibility check, but its inverse overflows f32.
            minimal(
                json!([{"type": "instance", "definition": "quad", "transform": {"scale": [1e-39, 1e-39, 1e-39]}}]),
                json!({"quad": quad}),
            ),
            "objects[0].transform: its inverse (world to object) exceeds the range of 32-bit floats",
        ),
        (
            minimal(
                json!([{"type": "instance", "definition": "quad", "transform": {"matrix": [1e-38, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]}}]),
                json!({"quad": quad}),
            ),
            "objects[0].transform: its inverse (world to object) exceeds the range of 32-bit floats",
        ),
    ];
    for (scene, want) in cases {
        let e = load_err(scene);
        assert!(e.starts_with(want), "expected {want:?}, got {e:?}");
    }
}

/// The binary BVH is the only structure with a second level, and vct and deferred read
/// primitives by index: there the instances are written out as meshes (scene/expand.rs) and
/// render the image of the flattened copy (the same meshes in the same order, so the same
/// image up to the rounding of the transforms).
#[test]
fn other_structures_and_integrators_render_instances_written_out() {
    let (inst, flat) = instanced_and_flat(
        json!({"type": "box", "min": [-1, -1, -1], "max": [1, 1, 1]}),
        "white",
    );
    let (obj_inst, obj_flat) = instanced_and_flat(
        json!({"type": "mesh", "file": "assets/uv_sphere.obj"}),
        "white",
    );
    let opts = |kind, expand_instances| CompileOptions {
        accel: AccelOptions {
            kind,
            ..Default::default()
        },
        cache: None,
        expand_instances,
        max_triangles: None,
    };
    let cases = [
        (AccelKind::Cwbvh, false, "nee"),
        (AccelKind::Grid, false, "nee"),
        (AccelKind::Bvh, true, "vct"),
        (AccelKind::Bvh, true, "deferred"),
    ];
    // (The OBJ sphere has vertex normals: written out, they go through the inverse transpose
    // of the non-uniform and mirrored placements as the flattened copy's do.)
    let obj_case = (AccelKind::Bvh, true, "deferred");
    let all = cases.iter().map(|c| (*c, &inst, &flat));
    for ((kind, expand, integrator), inst, flat) in all.chain([(obj_case, &obj_inst, &obj_flat)]) {
        let what = format!("{} {integrator}", kind.name());
        let a = compile_with(inst, 24, 24, &opts(kind, expand)).unwrap();
        let b = compile_with(flat, 24, 24, &opts(kind, false)).unwrap();
        assert!(a.instances.is_empty(), "{what}: instances left");
        assert_eq!(a.prims.len(), b.prims.len(), "{what}");
        let (ia, _) = render_compiled(inst, &a, integrator, 2, 5, Some(3));
        let (ib, _) = render_compiled(flat, &b, integrator, 2, 5, Some(3));
        let (rel, share) = difference(&ia, &ib);
        println!("{what}: mean |Δ| {rel:.2e} of the mean, {share:.3} of pixels off");
        assert!(mean(&ia)[0] > 0.01, "{what}: a dark image proves nothing");
        assert!(rel < 1e-3 && share < 0.01, "{what}: {rel} {share}");
    }
    // The caller's triangle limit bounds what is written out, naming it.
    let small = CompileOptions {
        max_triangles: Some(40),
        ..opts(AccelKind::Grid, false)
    };
    let Err(e) = compile_with(&inst, 8, 8, &small) else {
        panic!("written out past the limit");
    };
    assert!(e.to_string().ends_with("triangles; at most 40"), "{e}");
    // A library caller that compiles without writing instances out is told what to do.
    let c = compile(&inst, 8, 8).unwrap();
    let options = renderer::integrators::IntegratorOptions::from_name("vct").unwrap();
    let Err(e) = renderer::render::RenderSession::new(&gpu(), &c, &options, None, 1) else {
        panic!("vct accepted a compiled scene with instances");
    };
    assert!(
        e.to_string().starts_with(
            "integrator \"vct\" does not trace instances (objects of type \"instance\"): prepare the scene with expand_instances"
        ),
        "{e}"
    );
}

/// Instances of an emitting definition or with an emitting material override are lights:
/// written out as meshes with the binary BVH too, while the others stay instances. The scene
/// renders like its copy with those instances written out by hand (the same meshes in the
/// same order, the same instances, so the same lights in the same order).
#[test]
fn emitting_instances_light_the_scene_like_their_written_out_copy() {
    let quad =
        json!({"type": "quad", "origin": [-1, 0, -1], "edge_u": [2, 0, 0], "edge_v": [0, 0, 2]});
    let lamp = [true, false, true, false];
    let (mut instances, mut copy) = (Vec::new(), Vec::new());
    for ((t, _), lit) in placements().into_iter().zip(lamp) {
        let mut i = json!({"type": "instance", "definition": "piece", "transform": t});
        if lit {
            i["material"] = json!("light");
            let mut f = quad.clone();
            f["transform"] = t;
            f["material"] = json!("light");
            copy.push(f);
        } else {
            copy.push(i.clone());
        }
        instances.push(i);
    }
    // And a definition that emits by itself (no override), placed once.
    let t = json!({"scale": 0.2, "translate": [0, 0.9, 0]});
    instances.push(json!({"type": "instance", "definition": "lamp", "transform": t}));
    let mut f = quad.clone();
    f["transform"] = t;
    f["material"] = json!("light");
    copy.push(f);
    let mut def = quad.clone();
    def["material"] = json!("white");
    let mut lamp_def = quad.clone();
    lamp_def["material"] = json!("light");
    let defs = json!({ "piece": def, "lamp": lamp_def });
    let inst = cornell_with(instances, Some(defs.clone()));
    let copy = cornell_with(copy, Some(defs));
    let (a, b) = (
        compile(&inst, 24, 24).unwrap(),
        compile(&copy, 24, 24).unwrap(),
    );
    assert_eq!(a.instances.len(), 2, "the two white quads stay instances");
    // The sphere's light and the three lamps' six triangles.
    assert_eq!((a.lights.len(), b.lights.len()), (7, 7));
    for integrator in ["nee", "pt"] {
        let (ia, _) = render_compiled(&inst, &a, integrator, 4, 7, Some(3));
        let (ib, _) = render_compiled(&copy, &b, integrator, 4, 7, Some(3));
        let (rel, share) = difference(&ia, &ib);
        println!(
            "emitting, {integrator}: mean |Δ| {rel:.2e} of the mean, {share:.3} of pixels off"
        );
        assert!(rel < 1e-3 && share < 0.01, "{integrator}: {rel} {share}");
    }
}

/// bdpt and whitted take instances through the shared traversal too: same image as the
/// flattened copy.
#[test]
fn bdpt_and_whitted_render_instances_like_their_flattened_copy() {
    let (inst, flat) = instanced_and_flat(
        json!({"type": "box", "min": [-1, -1, -1], "max": [1, 1, 1]}),
        "white",
    );
    for integrator in ["bdpt", "whitted"] {
        let (a, _) = render_loaded(&inst, integrator, 2, 24, 24, 5, Some(3));
        let (b, _) = render_loaded(&flat, integrator, 2, 24, 24, 5, Some(3));
        let (rel, share) = difference(&a, &b);
        println!("{integrator}: mean |Δ| {rel:.2e} of the mean, {share:.3} of pixels off");
        assert!(mean(&a)[0] > 0.01);
        assert!(rel < 1e-3 && share < 0.01, "{integrator}: {rel} {share}");
    }
}

/// Alpha masks through instances: a definition whose own material is masked, and instances
/// whose replacing material is masked (and one replacing a masked material by a plain one), on
/// a PLY-backed definition with normals and uvs.
#[test]
fn masked_and_ply_backed_instances_render_like_their_flattened_copy() {
    let ply = json!({"type": "mesh", "file": "testdata/meshes/floor.ply"});
    let (inst, flat) =
        instanced_and_flat_with(ply.clone(), "cutout", &[None, Some("blue"), None, None]);
    assert_same_image(&inst, &flat, "masked PLY");
    let (inst, flat) = instanced_and_flat_with(
        ply,
        "white",
        &[Some("cutout"), None, Some("cutout"), Some("metal")],
    );
    assert_same_image(&inst, &flat, "masked overrides");
}

/// A replacing material's mask on a definition with neither normals nor uvs (tent.obj, flat): the
/// mask reads the triangles' barycentrics as uvs (docs/scene-format.md), so the instances need
/// the shading records a masked mesh of their own gets; the masks must cut something.
#[test]
fn a_masked_replacing_material_cuts_a_definition_without_uvs() {
    let tent = json!({"type": "mesh", "file": "testdata/meshes/tent.obj", "smooth": false});
    let masked = [Some("cutout"), None, Some("cutout"), None];
    let (inst, flat) = instanced_and_flat_with(tent.clone(), "white", &masked);
    assert!(inst.prototypes[0].normals.is_none() && inst.prototypes[0].uvs.is_none());
    assert_same_image(&inst, &flat, "masked overrides without uvs");
    let (_, whole) = instanced_and_flat_with(tent, "white", &[None; 4]);
    let (a, _) = render_loaded(&flat, "nee", 4, SIZE, SIZE, 7, Some(4));
    let (b, _) = render_loaded(&whole, "nee", 4, SIZE, SIZE, 7, Some(4));
    let (rel, share) = difference(&a, &b);
    println!("masked against whole: mean |Δ| {rel:.2e} of the mean, {share:.3} of pixels off");
    assert!(rel > 1e-2, "the masks cut nothing: {rel} {share}");
}

/// Prototype BVHs come from the cache on a second compile; the shader's fallbacks for trees
/// deeper than its stack (the prototype's BVH: the stackless walk; the top-level BVH keeps its
/// full stack, being built within it) give the image of the full stack.
#[test]
fn a_short_stack_renders_instances_the_same() {
    let (inst, _) = instanced_and_flat(
        json!({"type": "mesh", "file": "assets/uv_sphere.obj"}),
        "white",
    );
    // The prototype's BVH is cached like the scene's: the second compile loads it.
    let dir = scratch("instancing-cache");
    let cached = |d: &std::path::Path| {
        let opts = CompileOptions {
            accel: AccelOptions::default(),
            cache: Some(d),
            expand_instances: false,
            max_triangles: None,
        };
        compile_with(&inst, 24, 24, &opts).unwrap()
    };
    assert_eq!(cached(&dir).accel.cache, CacheStatus::Miss);
    let c = cached(&dir);
    assert_eq!(c.accel.cache, CacheStatus::Hit);
    assert!(
        std::fs::read_dir(&dir).unwrap().count() >= 2,
        "scene and prototype BVHs"
    );
    let short = c.clone().with_traversal_stack(1);
    assert!(!short.bvh_parents.is_empty());
    let (a, _) = render_compiled(&inst, &c, "nee", 2, 3, Some(3));
    let (b, _) = render_compiled(&inst, &short, "nee", 2, 3, Some(3));
    assert!(mean(&a)[0] > 0.01);
    let (rel, share) = difference(&b, &a);
    println!("short stack: mean |Δ| {rel:.2e}, {share:.3} of pixels off");
    assert!(rel < 1e-4 && share < 0.01, "{rel} {share}");
}
