//! BVHs of any depth on lavapipe: meshes whose tree is far deeper than the traversal's short
//! stack (`accel::STACK_DEPTH`) render, through the shader's stackless fallback (trees kept as
//! built with `bvh_keep_deep`) and through the bounded trees the builder makes by default.
//!
//! Each pathological mesh has an analytic twin that must render the same picture:
//! - copies of one triangle render like the triangle alone;
//! - coplanar triangles nested about a common corner (sizes shrinking geometrically, so the
//!   agglomerative build chains them one level per triangle) render like the largest alone;
//! - degenerate (zero-area) collinear slivers, nested the same way, render like nothing.
//!
//! The scenes are lit by a point light only, so the light table does not depend on the
//! primitive order and the twins' images may be compared sample for sample; shadow rays
//! (any-hit queries) cross the deep trees too. Also rendered with the uniform grid.

use candela_tests::accel::diff;
use candela_tests::*;
use renderer::accel::{AccelKind, AccelOptions, STACK_DEPTH};
use renderer::compile::{compile_with, CompileOptions, CompiledScene};
use renderer::film::Image;
use renderer::integrators::IntegratorOptions;
use renderer::render::{render, Budget, RenderSession};
use renderer::scene::{load_str, Scene};
use serde_json::{json, Value};

const W: u32 = 24;

/// A floor, a back wall and a point light, plus `extra` objects.
fn scene(extra: Vec<Value>) -> Scene {
    let camera = json!({"position": [0.3, 1.2, 2.6], "look_at": [0, 0.4, 0], "up": [0, 1, 0],
                        "fov_y": 50});
    scene_seen_from(extra, camera)
}

fn scene_seen_from(extra: Vec<Value>, camera: Value) -> Scene {
    let mut objects = vec![
        json!({"type": "quad", "origin": [-1, 0, 1], "edge_u": [2, 0, 0], "edge_v": [0, 0, -2],
               "material": "white"}),
        json!({"type": "quad", "origin": [-1, 0, -1], "edge_u": [2, 0, 0], "edge_v": [0, 2, 0],
               "material": "white"}),
    ];
    objects.extend(extra);
    let s = json!({
        "version": 1,
        "camera": camera,
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

/// An inline mesh of `tris` (three vertices each).
fn triangles(tris: &[[[f64; 3]; 3]], material: &str) -> Value {
    let positions: Vec<[f64; 3]> = tris.iter().flatten().copied().collect();
    let indices: Vec<u32> = (0..positions.len() as u32).collect();
    json!({"type": "triangles", "positions": positions, "indices": indices, "material": material})
}

fn bvh(keep_deep: bool) -> AccelOptions {
    AccelOptions {
        bvh_keep_deep: keep_deep,
        ..Default::default()
    }
}

fn render_with(scene: &Scene, accel: AccelOptions) -> (Image, CompiledScene) {
    let c = compile_with(
        scene,
        W,
        W,
        &CompileOptions {
            accel,
            cache: None,
            expand_instances: false,
            max_triangles: None,
        },
    )
    .expect("compile");
    render_compiled(scene, c)
}

fn render_compiled(scene: &Scene, c: CompiledScene) -> (Image, CompiledScene) {
    let ctx = gpu();
    let options = IntegratorOptions::from_name("nee").expect("nee");
    let mut session =
        RenderSession::new(&ctx, &c, &options, scene.render.max_depth, 5).expect("session");
    // Passes of 1 spp keep each invocation's loop count far below lavapipe's limit.
    let (img, _) = render(&mut session, Budget::Spp(4)).expect("render");
    ctx.check_validation().expect("validation layer messages");
    (img, c)
}

/// Renders `deep` as built (deeper than the stack; also with a stack of 1 entry, so the
/// fallback runs), bounded, and with the grid, and `twin`; all must match.
fn renders_like(label: &str, deep: &Scene, twin: &Scene, min_depth: usize) {
    let (reference, _) = render_with(twin, bvh(false));
    let lit = reference.pixels.iter().filter(|p| p[0] > 0.0).count();
    assert!(
        lit > reference.pixels.len() / 4,
        "{label}: the twin is mostly black"
    );
    let grid = AccelOptions {
        kind: AccelKind::Grid,
        ..Default::default()
    };
    let kinds = [
        ("as built", bvh(true), None),
        ("as built, stack of 1", bvh(true), Some(1)),
        ("bounded", bvh(false), None),
        ("grid", grid, None),
    ];
    for (what, accel, stack) in kinds {
        let opts = CompileOptions {
            accel,
            cache: None,
            expand_instances: false,
            max_triangles: None,
        };
        let mut c = compile_with(deep, W, W, &opts).expect("compile");
        if let Some(n) = stack {
            c = c.with_traversal_stack(n);
        }
        let (img, c) = render_compiled(deep, c);
        let (differ, e) = diff(&img, &reference);
        println!(
            "{label}, {what}: {} primitives, BVH depth {}, {differ} of {} pixels differ, \
             relMSE {e:.3e}",
            c.prims.len(),
            c.bvh_depth,
            img.pixels.len()
        );
        match what {
            "as built" => {
                assert!(c.bvh_depth >= min_depth, "{label}: depth {}", c.bvh_depth);
                assert!(!c.bvh_parents.is_empty());
            }
            "bounded" => assert!(c.bvh_depth <= STACK_DEPTH, "{label}: {}", c.bvh_depth),
            _ => {}
        }
        assert!(e < 1e-4, "{label}, {what}: relMSE {e}");
    }
}

#[test]
fn identical_triangles_render_like_one() {
    let t = [[-0.4, 0.8, -0.2], [0.4, 0.8, -0.2], [0.0, 0.8, 0.5]];
    let deep = scene(vec![triangles(&vec![t; 600], "red")]);
    let twin = scene(vec![triangles(&[t], "red")]);
    renders_like("600 identical triangles", &deep, &twin, 4 * STACK_DEPTH);
}

#[test]
fn nested_coplanar_triangles_render_like_the_largest() {
    // Vertical triangles on z = -0.5 sharing the corner c, each 0.95 times the last.
    let c = [-0.6, 0.05, -0.5];
    let tri = |s: f64| [c, [c[0] + s, c[1], c[2]], [c[0], c[1] + s, c[2]]];
    let nested: Vec<_> = (0..300).map(|k| tri(1.2 * 0.95f64.powi(k))).collect();
    let deep = scene(vec![triangles(&nested, "red")]);
    let twin = scene(vec![triangles(&[tri(1.2)], "red")]);
    renders_like("300 nested triangles", &deep, &twin, 2 * STACK_DEPTH);
}

#[test]
fn degenerate_slivers_render_like_nothing() {
    // Zero-area triangles on one diagonal line through the scene, nested about its foot.
    let p = [-0.5, 0.02, -0.3];
    let d = [0.6, 0.8, 0.45];
    let at = |s: f64| [p[0] + s * d[0], p[1] + s * d[1], p[2] + s * d[2]];
    let slivers: Vec<_> = (0..400)
        .map(|k| {
            let s = 1.8 * 0.96f64.powi(k);
            [p, at(0.5 * s), at(s)]
        })
        .collect();
    let deep = scene(vec![triangles(&slivers, "red")]);
    let twin = scene(vec![]);
    renders_like("400 collinear slivers", &deep, &twin, 2 * STACK_DEPTH);
}

#[test]
fn a_short_stack_falls_back_without_changing_the_image() {
    // With a stack of 1 or 2 entries many walks overflow and are finished by the stackless
    // fallback; it must find the same hits (closest and any-hit) as the full stack. (Checked
    // to fail when the fallback is replaced by giving up: 249 of 576 pixels differ.)
    for name in ["textured_mesh.json", "whitted_classic.json"] {
        let scene = renderer::scene::load_file(&scene_path(name)).unwrap();
        let c = compile_with(&scene, W, W, &CompileOptions::default()).unwrap();
        let need = stack_need(&c.nodes);
        println!(
            "{name}: {} nodes, a walk may need {need} entries",
            c.nodes.len()
        );
        assert!(need > 2, "{name}: the short stacks would never overflow");
        let (reference, _) = render_compiled(&scene, c.clone());
        for entries in [1, 2] {
            let (img, _) = render_compiled(&scene, c.clone().with_traversal_stack(entries));
            let (differ, e) = diff(&img, &reference);
            println!("{name}, stack of {entries}: {differ} pixels differ, relMSE {e:.3e}");
            assert!(e < 1e-6, "{name}, stack of {entries}: relMSE {e}");
        }
    }
}

/// The most stack entries a walk can need: along a root-to-node path, the nodes whose two
/// children are both inner nodes (the traversal pushes only there; leaves are tested at once).
fn stack_need(nodes: &[renderer::layout::GpuBvhNode]) -> usize {
    let mut most = 0;
    let mut stack = vec![(0usize, 0usize)];
    while let Some((i, pushes)) = stack.pop() {
        let n = &nodes[i];
        let both = n.l_count == 0 && n.r_count == 0 && n.left != n.right;
        let p = pushes + both as usize;
        most = most.max(p);
        for (c, count) in [(n.left, n.l_count), (n.right, n.r_count)] {
            if count == 0 && c as usize != i {
                stack.push((c as usize, p));
            }
        }
    }
    most
}
