//! Kernel specialisation, audited on every project scene (scenes/*.json):
//! 1. the features the loader detects (`FeatureSet::detect`) equal the ones the scene uses, as
//!    read independently here from the scene document and its mesh files: none missed (a kernel
//!    without a feature the scene needs renders it wrongly) and none extra (it would compile code
//!    the scene never runs);
//! 2. for every scene (and one scene per material model, whose kernels know every material's
//!    type: `MAT_SOLE`) and integrator, the specialised kernels render the same image as the
//!    generic ones (every feature compiled in), to float tolerance (8×8 pixels, 2 spp: building
//!    the kernels on lavapipe is what costs);
//! 3. the render's constants (filter, camera model, depths, integrator options) compiled into
//!    specialised kernels render what the generic kernel's run-time reads render, for options
//!    that take every folded branch the other way.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use candela_tests::{gpu, repo_root, specialised_vs_generic, specialised_vs_generic_with};
use renderer::compile::{compile, FeatureSet};
use renderer::integrators::names;
use serde_json::Value;

/// The project's scenes.
fn project_scenes() -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(repo_root().join("scenes"))
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().and_then(|e| e.to_str()) == Some("json"))
        .collect();
    v.sort();
    assert!(v.len() >= 8, "expected the project's scenes, found {v:?}");
    v
}

/// Scenes of one material model each (written to a scratch folder), besides the project's: an
/// integrator may light a model through another's code (whitted lights smooth principled
/// surfaces as a Lambertian lobe), which only shows when that other model is absent.
fn single_model_scenes() -> Vec<PathBuf> {
    let dir = candela_tests::scratch("kernels_single_model");
    let models = [
        ("diffuse", r#"{"type": "diffuse", "reflectance": 0.6}"#),
        ("conductor", r#"{"type": "conductor", "roughness": 0.05}"#),
        ("dielectric", r#"{"type": "dielectric", "ior": 1.5}"#),
        (
            "principled_smooth",
            r#"{"type": "principled", "roughness": 0.05, "base_color": [0.7, 0.3, 0.2]}"#,
        ),
        (
            "principled_rough",
            r#"{"type": "principled", "roughness": 0.6, "metallic": 0.5}"#,
        ),
        (
            "phong",
            r#"{"type": "phong", "diffuse": 0.4, "specular": 0.3}"#,
        ),
    ];
    models
        .iter()
        .map(|(name, material)| {
            let scene = format!(
                r#"{{"version": 1, "camera": {{"position": [0, 1, 4], "look_at": [0, 0, 0]}},
                "film": {{"width": 8, "height": 8}},
                "materials": {{"m": {material}}},
                "objects": [{{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "m"}},
                            {{"type": "quad", "origin": [-3, -1, -3], "edge_u": [0, 0, 6], "edge_v": [6, 0, 0], "material": "m"}}],
                "lights": [{{"type": "point", "position": [2, 3, 2], "intensity": [20, 20, 20]}}],
                "environment": {{"type": "constant", "radiance": [0.2, 0.2, 0.2]}}}}"#
            );
            let p = dir.join(format!("{name}.json"));
            std::fs::write(&p, scene).unwrap();
            p
        })
        .collect()
}

/// `usemtl` names of an OBJ file, and whether it has texture coordinates.
fn obj_facts(path: &Path) -> (Vec<String>, bool) {
    let text = std::fs::read_to_string(path).unwrap();
    let usemtl = text
        .lines()
        .filter_map(|l| l.strip_prefix("usemtl "))
        .map(|s| s.trim().to_string())
        .collect();
    (usemtl, text.lines().any(|l| l.starts_with("vt ")))
}

/// Whether a material field (colour or scalar) is a texture reference.
fn is_texture(v: &Value) -> bool {
    v.get("texture").is_some()
}

/// The features a scene document uses, read from the JSON (and its mesh files) alone.
fn expected_features(path: &Path) -> FeatureSet {
    let doc: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    let dir = path.parent().unwrap();
    let materials = doc["materials"].as_object().unwrap();
    let first_material = materials.keys().next().cloned();
    let mut f = FeatureSet::default();
    let mut used: BTreeSet<String> = BTreeSet::new();
    for o in doc["objects"].as_array().unwrap() {
        let kind = o["type"].as_str().unwrap();
        let material = o.get("material").and_then(Value::as_str).map(String::from);
        match kind {
            "sphere" => f.spheres = true,
            // Quads and boxes carry per-face texture coordinates.
            "quad" | "box" => f.tri_shading = true,
            "triangles" => {
                f.tri_shading |= o.get("normals").is_some() || o.get("uvs").is_some();
            }
            "mesh" => {
                let file = dir.join(o["file"].as_str().unwrap());
                let smooth = o.get("smooth").and_then(Value::as_bool).unwrap_or(true);
                let (usemtl, uvs) = obj_facts(&file);
                // Smooth meshes get vertex normals (read or computed).
                f.tri_shading |= smooth || uvs;
                if material.is_none() {
                    used.extend(usemtl.into_iter().filter(|m| materials.contains_key(m)));
                }
            }
            other => panic!(
                "{}: object type {other} not known to this test",
                path.display()
            ),
        }
        match (material, kind) {
            (Some(m), _) => {
                used.insert(m);
            }
            (None, "mesh") if !used.is_empty() => {}
            (None, _) => used.extend(first_material.clone()),
        }
    }
    for name in &used {
        let m = &materials[name];
        f.alpha |= m.get("alpha_mask").is_some();
        f.textures |= m
            .as_object()
            .unwrap()
            .iter()
            .any(|(k, v)| k == "alpha_mask" || is_texture(v));
        match m["type"].as_str().unwrap() {
            "diffuse" => f.mat_diffuse = true,
            "conductor" => f.mat_conductor = true,
            "dielectric" => f.mat_dielectric = true,
            "principled" => f.mat_principled = true,
            "phong" => f.mat_phong = true,
            other => panic!("material type {other} not known to this test"),
        }
    }
    f.delta_lights = doc
        .get("lights")
        .and_then(Value::as_array)
        .is_some_and(|l| !l.is_empty());
    f.environment = doc.get("environment").is_some();
    if doc.get("environment").and_then(|e| e["type"].as_str()) == Some("map") {
        f.env_map = true;
        f.textures = true;
    }
    f
}

#[test]
fn detected_features_are_exactly_the_used_ones() {
    for path in project_scenes() {
        let scene = renderer::scene::load_file(&path).unwrap();
        let detected = FeatureSet::detect(&scene);
        let expected = expected_features(&path);
        println!(
            "{}: {}",
            path.file_name().unwrap().to_string_lossy(),
            detected.names().join(", ")
        );
        assert_eq!(detected, expected, "{}", path.display());
    }
}

#[test]
fn specialised_and_generic_kernels_render_the_same_image() {
    let ctx = gpu();
    let mut worst = 0.0f32;
    for path in project_scenes().into_iter().chain(single_model_scenes()) {
        let scene = renderer::scene::load_file(&path).unwrap();
        let compiled = compile(&scene, 8, 8).unwrap();
        for name in names() {
            let (d, tol) = specialised_vs_generic(&scene, &compiled, name)
                .unwrap_or_else(|e| panic!("{} {name}: {e}", path.display()));
            worst = worst.max(d);
            assert!(
                d <= tol,
                "{} {name}: specialised vs generic differ by {d:e} (relative)",
                path.display()
            );
        }
    }
    ctx.check_validation().unwrap();
    println!("specialised vs generic: largest relative difference {worst:e}");
}

#[test]
fn compiled_in_constants_render_what_run_time_reads_render() {
    let ctx = gpu();
    // Options that flip what the specialised kernels compile in (renderer/src/integrators/*,
    // `constants`), on a Gaussian-filtered scene, a thin lens and a box filter.
    let variants = [
        r#"{"type": "pt", "max_depth": -1, "rr_depth": 1}"#,
        r#"{"type": "nee", "max_depth": 3, "rr_depth": 2}"#,
        r#"{"type": "bdpt", "max_depth": 3, "rr_depth": 1}"#,
        r#"{"type": "whitted", "max_depth": -1}"#,
        r#"{"type": "deferred", "max_depth": 1}"#,
        r#"{"type": "deferred", "shadows": true, "max_lights_per_pixel": 1, "env_ambient": false}"#,
        r#"{"type": "deferred", "cull": false, "shadows": true}"#,
        r#"{"type": "deferred", "debug": "tile_lights"}"#,
        r#"{"type": "vct", "resolution": 64, "storage": "dense", "cones": 3, "cones_per_sample": 2}"#,
        r#"{"type": "vct", "resolution": 64, "shadows": "cone", "max_depth": 2}"#,
        r#"{"type": "vct", "resolution": 64, "ao": true}"#,
    ];
    let mut worst = 0.0f32;
    for scene_name in ["cornell", "thinlens", "textured_mesh"] {
        let path = repo_root().join(format!("scenes/{scene_name}.json"));
        let scene = renderer::scene::load_file(&path).unwrap();
        let compiled = compile(&scene, 8, 8).unwrap();
        for v in variants {
            let spec: Value = serde_json::from_str(v).unwrap();
            let (d, tol) = specialised_vs_generic_with(&scene, &compiled, &spec)
                .unwrap_or_else(|e| panic!("{scene_name} {v}: {e}"));
            worst = worst.max(d);
            assert!(
                d <= tol,
                "{scene_name} {v}: compiled-in constants vs run-time reads differ by {d:e} (relative)"
            );
        }
    }
    ctx.check_validation().unwrap();
    println!("compiled-in constants vs run-time reads: largest relative difference {worst:e}");
}
