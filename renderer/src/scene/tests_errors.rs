//! Whole-scene error tests: each class of error with the exact JSON path (or file:line) its
//! message must name, the limits, JSON syntax errors, and mutated documents that must fail
//! cleanly (one-line message, no panic).

use std::path::Path;

use serde_json::{json, Value};

use super::tests_scene::{full_scene, idx, load_value, write_assets};
use super::*;

/// Loads the full scene with one change and returns (message, path).
fn error_with(dir: &Path, change: impl FnOnce(&mut Value)) -> (String, Option<String>) {
    let mut v = full_scene();
    change(&mut v);
    let e = load_value(&v, Some(dir)).unwrap_err();
    (e.to_string(), e.path().map(str::to_string))
}

#[test]
fn errors_name_the_json_path() {
    let dir = write_assets();
    let exact = |change: &dyn Fn(&mut Value), msg: &str| {
        let (m, _) = error_with(&dir, |v| change(v));
        assert_eq!(m, msg);
    };
    let path_is = |change: &dyn Fn(&mut Value), path: &str| {
        let (m, p) = error_with(&dir, |v| change(v));
        assert_eq!(p.as_deref(), Some(path), "{m}");
    };
    // Unknown fields, at any depth.
    exact(&|v| v["camera"]["fov"] = json!(30),
        "camera.fov: unknown field \"fov\", expected one of \"position\", \"look_at\", \"up\", \"fov_y\", \"aperture_radius\", \"focus_distance\"");
    path_is(
        &|v| v["objects"][5]["radius"] = json!(1),
        "objects[5].radius",
    );
    path_is(
        &|v| v["materials"]["red"]["ior"] = json!(1.5),
        "materials.red.ior",
    );
    path_is(
        &|v| v["objects"][2]["transform"]["shear"] = json!(1),
        "objects[2].transform.shear",
    );
    path_is(
        &|v| v["materials"]["blue"]["reflectance"]["gamma"] = json!(2),
        "materials.blue.reflectance.gamma",
    );
    path_is(&|v| v["lights"][1]["angle"] = json!(2), "lights[1].angle");
    path_is(&|v| v["render"]["seed"] = json!(2), "render.seed");
    // Wrong types.
    exact(&|v| v["materials"]["red"]["reflectance"] = json!("red"),
        "materials.red.reflectance: expected a number, [r,g,b] or {\"texture\": ...}, got the string \"red\"");
    exact(
        &|v| v["film"]["width"] = json!("big"),
        "film.width: invalid type: string \"big\", expected u32",
    );
    path_is(
        &|v| v["objects"][3]["positions"][1] = json!([1, 0]),
        "objects[3].positions",
    );
    path_is(
        &|v| v["objects"][4]["center"] = json!([0, 0]),
        "objects[4].center",
    );
    path_is(
        &|v| v["objects"][6]["type"] = json!("cube"),
        "objects[6].type",
    );
    path_is(
        &|v| v["lights"][0]["intensity"] = json!(true),
        "lights[0].intensity",
    );
    exact(
        &|v| v["version"] = json!(2),
        "version: unsupported scene version 2 (this renderer reads version 1)",
    );
    // References and ranges.
    exact(
        &|v| v["objects"][3]["material"] = json!("glas"),
        "objects[3].material: no material \"glas\"",
    );
    exact(
        &|v| v["camera"]["fov_y"] = json!(190),
        "camera.fov_y: must be in (0, 180), got 190",
    );
    exact(
        &|v| v["objects"][4]["radius"] = json!(-1),
        "objects[4].radius: must be > 0, got -1",
    );
    path_is(
        &|v| v["materials"]["glass"]["roughness"] = json!(2),
        "materials.glass.roughness",
    );
    path_is(
        &|v| v["materials"]["lamp"]["emission"] = json!([1, -1, 1]),
        "materials.lamp.emission",
    );
    path_is(
        &|v| v["lights"][1]["cutoff_angle"] = json!(0),
        "lights[1].cutoff_angle",
    );
    path_is(
        &|v| v["lights"][2]["direction"] = json!([0, 0, 0]),
        "lights[2].direction",
    );
    path_is(&|v| v["camera"]["up"] = json!([0, 0, 3]), "camera.up");
    path_is(
        &|v| v["objects"][5]["edge_v"] = json!([4, 0, 0]),
        "objects[5].edge_v",
    );
    path_is(
        &|v| v["objects"][6]["max"] = json!([1, 0, 1]),
        "objects[6].max",
    );
    path_is(
        &|v| v["objects"][2]["indices"] = json!([0, 1, 3]),
        "objects[2].indices[2]",
    );
    path_is(
        &|v| v["objects"][2]["transform"]["scale"] = json!(0),
        "objects[2].transform.scale",
    );
    path_is(
        &|v| v["objects"][6]["transform"]["matrix"][15] = json!(2),
        "objects[6].transform.matrix",
    );
    exact(
        &|v| v["objects"][4]["transform"]["scale"] = json!([1, 2, 1]),
        "objects[4].transform: spheres accept only uniform scale",
    );
    // Beyond the GPU's floats (finite in f64): refused, not built into a broken tree.
    let (m, _) = error_with(&dir, |v| {
        v["objects"][3]["positions"][1] = json!([1e39, 0, 0])
    });
    assert!(
        m.ends_with("a position lies beyond the range of 32-bit floats"),
        "{m}"
    );
    let (m, _) = error_with(&dir, |v| {
        v["objects"][4]["transform"]["scale"] = json!(1e38)
    });
    assert!(
        m.ends_with("places the sphere beyond the range of 32-bit floats"),
        "{m}"
    );
    exact(
        &|v| {
            v["objects"][4]
                .as_object_mut()
                .unwrap()
                .remove("material")
                .map(|_| ())
                .unwrap()
        },
        "objects[4]: missing field \"material\"",
    );
}

#[test]
fn file_errors_name_the_file() {
    let dir = write_assets();
    let exact = |change: &dyn Fn(&mut Value), msg: &str| {
        let (m, _) = error_with(&dir, |v| change(v));
        assert_eq!(m, msg);
    };
    exact(
        &|v| v["objects"][0]["file"] = json!("../model.obj"),
        "objects[0].file: \"../model.obj\" escapes the scene folder (\"..\" is not allowed)",
    );
    exact(&|v| v["materials"]["blue"]["reflectance"]["texture"] = json!("/etc/passwd.png"),
        "materials.blue.reflectance.texture: \"/etc/passwd.png\": absolute paths are not allowed; give a path relative to the scene folder");
    exact(
        &|v| v["objects"][0]["file"] = json!("missing.obj"),
        "objects[0].file: cannot read \"missing.obj\": No such file or directory",
    );
    exact(
        &|v| v["objects"][0]["file"] = json!("model.stl"),
        "objects[0].file: \"model.stl\": unsupported mesh format (expected .obj or .ply)",
    );
    exact(&|v| v["environment"]["file"] = json!("sky.tga"),
        "environment.file: \"sky.tga\": unsupported texture format (expected .png, .jpg, .jpeg, .exr or .hdr)");
    // usemtl names must exist unless "material" overrides them.
    exact(&|v| { v["materials"].as_object_mut().unwrap().remove("blue"); },
        "objects[0].file: \"model.obj\" uses material \"blue\" (usemtl), which is not in the scene's materials; add it or give \"material\"");
    let s = {
        let mut v = full_scene();
        v["materials"].as_object_mut().unwrap().remove("blue");
        v["objects"][0]["material"] = json!("red");
        load_value(&v, Some(&dir)).unwrap()
    };
    assert_eq!(s.meshes[0].materials, vec![idx(&s, "red") as u32; 2]);
    exact(
        &|v| {
            v["objects"][1].as_object_mut().unwrap().remove("material");
        },
        "objects[1]: missing field \"material\" (PLY files name no materials)",
    );
    // Errors inside mesh files give file:line and the JSON path.
    std::fs::write(dir.join("bad.ply"), "ply\nformat ascii 2.0\nend_header\n").unwrap();
    exact(
        &|v| v["objects"][1]["file"] = json!("bad.ply"),
        "bad.ply:2: only PLY version 1.0 is supported (objects[1].file)",
    );
    std::fs::write(dir.join("bad.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n").unwrap();
    let (m, p) = error_with(&dir, |v| v["objects"][0]["file"] = json!("bad.obj"));
    assert_eq!(
        m,
        "bad.obj:4: vertex index 7 out of range (3 defined so far) (objects[0].file)"
    );
    assert_eq!(p.as_deref(), Some("objects[0].file"));
    std::fs::write(
        dir.join("nomtl.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    exact(
        &|v| v["objects"][0]["file"] = json!("nomtl.obj"),
        "objects[0]: missing field \"material\" (\"nomtl.obj\" has faces without usemtl)",
    );
    std::fs::write(dir.join("broken.png"), "not a png").unwrap();
    let (m, p) = error_with(&dir, |v| {
        v["materials"]["blue"]["reflectance"]["texture"] = json!("broken.png")
    });
    assert!(
        m.starts_with("materials.blue.reflectance.texture: cannot decode \"broken.png\": "),
        "{m}"
    );
    assert_eq!(p.as_deref(), Some("materials.blue.reflectance.texture"));
}

#[test]
fn limits_bound_sizes() {
    let dir = write_assets();
    let v = full_scene();
    let tight = Limits {
        max_width: 100,
        ..Limits::default()
    };
    let e = load_str_with_limits(&v.to_string(), Some(&dir), &tight).unwrap_err();
    assert_eq!(e.to_string(), "film.width: must be in [1, 100], got 320");
    // The scene has 2 + 1 + 1 + 1 + 2 + 12 = 19 triangles.
    let few = Limits {
        max_triangles: 18,
        ..Limits::default()
    };
    let e = load_str_with_limits(&v.to_string(), Some(&dir), &few).unwrap_err();
    assert_eq!(
        e.to_string(),
        "objects[6]: the scene exceeds the limit of 18 triangles"
    );
    let exact = Limits {
        max_triangles: 19,
        ..Limits::default()
    };
    assert!(load_str_with_limits(&v.to_string(), Some(&dir), &exact).is_ok());
    let small = Limits {
        max_texture_pixels: 4,
        ..Limits::default()
    };
    let e = load_str_with_limits(&v.to_string(), Some(&dir), &small).unwrap_err();
    assert_eq!(e.path(), Some("environment.file"));
}

#[test]
fn json_syntax_errors_give_line_and_column() {
    let text =
        "{\n  \"version\": 1,\n  \"camera\": {\"position\": [0, 0, 5] \"look_at\": [0, 0, 0]}\n}";
    let e = load_str(text, None).unwrap_err();
    assert_eq!(
        e.to_string(),
        "camera: JSON error at line 3, column 36: expected \",\" or \"}\""
    );
    let e = load_str(
        "{\"version\": 1, \"camera\": {\"position\": [0, 0, 5], \"fov_y\": 1e400",
        None,
    )
    .unwrap_err();
    assert_eq!(e.path(), Some("camera.fov_y"));
    assert!(
        e.to_string()
            .contains("number out of range (does not fit in a 64-bit float)"),
        "{e}"
    );
    let e = load_str("[1, 2]", None).unwrap_err();
    assert!(
        e.to_string().contains("a scene must be a JSON object"),
        "{e}"
    );
    let e = load_str("", None).unwrap_err();
    assert!(e.to_string().starts_with("JSON error at line 1"), "{e}");
    let mut v = full_scene();
    let e = load_str(&format!("{v} x"), None).unwrap_err();
    assert!(
        e.to_string()
            .contains("unexpected characters after the scene object"),
        "{e}"
    );
    v.as_object_mut().unwrap().remove("version");
    let e = load_value(&v, None).unwrap_err();
    assert_eq!(
        (e.to_string().as_str(), e.path()),
        ("missing field \"version\"", None)
    );
    let dup = r#"{"version": 1, "camera": {"position": [0,0,5], "look_at": [0,0,0]},
        "materials": {"a": {"type": "diffuse"}, "a": {"type": "phong"}}, "objects": []}"#;
    assert_eq!(
        load_str(dup, None).unwrap_err().to_string(),
        "materials: duplicate name \"a\""
    );
    let ordered = dup.replace(r#""a": {"type": "phong"}"#, r#""0 b": {"type": "phong"}"#);
    assert_eq!(
        load_str(&ordered, None).unwrap().material_names,
        ["a", "0 b"],
        "document order"
    );
}

#[test]
fn loader_never_panics_on_mutated_json() {
    let dir = write_assets();
    let text = full_scene().to_string().into_bytes();
    let mut state = 0x2545_f491_4f6c_dd1du64;
    for _ in 0..1500 {
        let mut d = text.clone();
        super::tests_files::mutate(&mut d, &mut state);
        let json = String::from_utf8_lossy(&d);
        if let Err(e) = load_str(&json, Some(&dir)) {
            let msg = e.to_string();
            assert!(!msg.is_empty() && !msg.contains('\n'), "one line: {msg:?}");
        }
    }
}
