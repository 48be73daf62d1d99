//! .scn importer tests without a GPU: tests/import/scn/cornell.scn loads to exactly the scene of
//! its hand-written candela equivalent; the usemtl / default_material rules and textures of
//! textures.scn; unsupported fields named with their JSON path.

use std::path::{Path, PathBuf};

use serde_json::json;

use crate::import::test_util::assert_same_scene;
use crate::import::{import_file, load_file, ImportOptions};
use crate::scene::paths::tests::temp_dir;

fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/import/scn")
}

#[test]
fn cornell_loads_to_its_json_equivalent() {
    let loaded = load_file(&dir().join("cornell.scn"), &ImportOptions::default()).unwrap();
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    let reference = crate::scene::load_file(&dir().join("cornell.json")).unwrap();
    assert_same_scene(&loaded.scene, &reference);
}

#[test]
fn usemtl_default_material_and_textures() {
    let strict = import_file(&dir().join("textures.scn"), &ImportOptions::default()).unwrap_err();
    assert!(strict.to_string().contains("entities[0].file: \"box.obj\" uses material \"floor\" (usemtl), which is not in the scene's materials"), "{strict}");
    let lenient = ImportOptions {
        lenient: true,
        ..Default::default()
    };
    let imp = import_file(&dir().join("textures.scn"), &lenient).unwrap();
    let d = &imp.doc;
    // box.obj names ceiling, floor, ... which textures.scn does not define: only leftWall is a
    // scene material; every other group takes the entity's default_material ("rough").
    let objects = d["objects"].as_array().unwrap();
    let first: Vec<&str> = objects
        .iter()
        .take(2)
        .map(|o| o["material"].as_str().unwrap())
        .collect();
    assert_eq!(first, ["rough", "leftWall"]);
    assert!(
        imp.warnings.iter().any(|w| w.msg.contains("\"floor\"")),
        "{:?}",
        imp.warnings
    );
    assert_eq!(
        objects[2]["material"],
        json!("cutout"),
        "material replaces every usemtl"
    );
    assert_eq!(objects[2]["file"], json!("box.obj"));
    assert_eq!(
        d["materials"]["cutout"]["alpha_mask"],
        json!({"texture": "mask.png"})
    );
    assert_eq!(
        d["materials"]["rough"]["roughness"],
        json!({"texture": "grad.png"})
    );
    let frosted = &d["materials"]["frosted"]["spec_trans"];
    assert!(
        frosted["texture"].as_str().unwrap().ends_with(".exr")
            && frosted["scale"] == json!([3.0, 3.0])
    );
    assert_eq!(objects[3]["flip_normals"], json!(true));
    assert_eq!(
        d["film"],
        json!({"width": 1280, "height": 720, "filter": {"type": "gaussian", "stddev": 0.15}})
    );
    imp.load(&Default::default()).unwrap();
}

#[test]
fn unsupported_and_malformed_fields_are_named() {
    let d = temp_dir("scn");
    std::fs::copy(dir().join("box.obj"), d.join("box.obj")).unwrap();
    for (text, needle, lenient_ok) in [
        (
            r#"{"materials": [{"name": "m", "normaltexture": "n.png"}]}"#,
            "materials[0].normaltexture: \"normaltexture\" is not supported",
            true,
        ),
        (
            r#"{"materials": [{"name": "m", "shininess": 3}]}"#,
            "materials[0].shininess: field \"shininess\" is not supported",
            true,
        ),
        (
            r#"{"entities": [{"type": "cone"}]}"#,
            "entities[0].type: entity type \"cone\"",
            true,
        ),
        (
            r#"{"lights": []}"#,
            "lights: field \"lights\" is not supported",
            true,
        ),
        (
            r#"{"entities": [{"type": "sphere", "radius": 1, "material": "nope"}]}"#,
            "entities[0].material: no material \"nope\"",
            false,
        ),
        (
            r#"{"entities": [{"type": "mesh", "file": "../box.obj"}]}"#,
            "leaves the scene folder",
            false,
        ),
        (
            r#"{"camera": {"position": [0, 0]}}"#,
            "camera.position: expected [x, y, z]",
            false,
        ),
        ("{\n\"maxdepth\": }", "s.scn:2: JSON error", false),
    ] {
        std::fs::write(d.join("s.scn"), text).unwrap();
        let e = import_file(&d.join("s.scn"), &ImportOptions::default())
            .err()
            .unwrap_or_else(|| panic!("accepted: {text}"))
            .to_string();
        assert!(e.contains(needle), "{needle:?} not in: {e}");
        let lenient = ImportOptions {
            lenient: true,
            ..Default::default()
        };
        assert_eq!(
            load_file(&d.join("s.scn"), &lenient).is_ok(),
            lenient_ok,
            "{text}"
        );
    }
}
