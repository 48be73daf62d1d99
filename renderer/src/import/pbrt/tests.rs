//! pbrt importer tests without a GPU: tests/import/pbrt/scene.pbrt loads to exactly the scene
//! of its hand-written candela equivalent (scene.json); a standard (left-handed) camera mirrors
//! the scene; every unsupported construct is named with file and line.

use std::path::{Path, PathBuf};

use serde_json::json;

use crate::import::test_util::assert_same_scene;
use crate::import::{import_file, load_file, ImportOptions};
use crate::scene::paths::tests::temp_dir;

fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/import/pbrt")
}

#[test]
fn scene_loads_to_its_json_equivalent() {
    let loaded = load_file(&dir().join("scene.pbrt"), &ImportOptions::default()).unwrap();
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    let reference = crate::scene::load_file(&dir().join("scene.json")).unwrap();
    assert_same_scene(&loaded.scene, &reference);
}

/// Imports a pbrt text written into a fresh folder (with grad.png beside it).
fn import_text(text: &str, lenient: bool) -> Result<crate::import::Imported, String> {
    let d = temp_dir("pbrt");
    std::fs::copy(dir().join("grad.png"), d.join("grad.png")).unwrap();
    std::fs::write(d.join("s.pbrt"), text).unwrap();
    let opts = ImportOptions {
        lenient,
        ..Default::default()
    };
    import_file(&d.join("s.pbrt"), &opts).map_err(|e| e.to_string())
}

#[test]
fn object_instances_define_their_meshes_once() {
    // A group of a mesh and a sphere placed three times, another placed once.
    let imp = import_text(
        "LookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\"\nWorldBegin\n\
         ObjectBegin \"rock\"\n\
           Shape \"trianglemesh\" \"point3 P\" [0 0 0  1 0 0  0 1 0] \"integer indices\" [0 1 2]\n\
           Shape \"sphere\" \"float radius\" [0.1]\n\
         ObjectEnd\n\
         ObjectBegin \"lone\"\n\
           Shape \"trianglemesh\" \"point3 P\" [0 0 0  2 0 0  0 2 0] \"integer indices\" [0 1 2]\n\
         ObjectEnd\n\
         AttributeBegin\nTranslate 1 0 0\nObjectInstance \"rock\"\nAttributeEnd\n\
         AttributeBegin\nTranslate 2 0 0\nObjectInstance \"rock\"\nAttributeEnd\n\
         AttributeBegin\nScale 2 2 2\nObjectInstance \"rock\"\nAttributeEnd\n\
         AttributeBegin\nTranslate 0 3 0\nObjectInstance \"lone\"\nAttributeEnd\n",
        false,
    )
    .unwrap();
    let d = &imp.doc;
    let defs = d["definitions"].as_object().unwrap();
    assert_eq!(defs.keys().collect::<Vec<_>>(), ["rock_0"], "{defs:?}");
    let objects = d["objects"].as_array().unwrap();
    let kinds: Vec<&str> = objects
        .iter()
        .map(|o| o["type"].as_str().unwrap())
        .collect();
    let placed = ["instance", "sphere"];
    assert_eq!(kinds[..6], [placed, placed, placed].concat(), "{kinds:?}");
    // The group placed once is written in place, with its transform.
    assert_eq!(kinds.len(), 7);
    assert_ne!(kinds[6], "instance");
    assert!(objects[6].get("transform").is_some());
    let scene = imp.load(&Default::default()).unwrap();
    assert_eq!((scene.prototypes.len(), scene.instances.len()), (1, 3));
    assert_eq!((scene.meshes.len(), scene.spheres.len()), (1, 3));
    // Instances do not nest (pbrt-v4 refuses it too).
    let e = import_text(
        "Camera \"perspective\"\nWorldBegin\nObjectBegin \"a\"\nShape \"sphere\"\nObjectEnd\n\
         ObjectBegin \"b\"\nObjectInstance \"a\"\nObjectEnd\n",
        false,
    )
    .unwrap_err();
    assert!(
        e.contains("ObjectInstance inside ObjectBegin") && e.contains(":7"),
        "{e}"
    );
}

#[test]
fn a_standard_pbrt_camera_mirrors_the_scene() {
    let imp = import_text(
        "LookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 30\nFilm \"rgb\" \"integer xresolution\" 32 \"integer yresolution\" 64\nWorldBegin\nLightSource \"point\" \"point3 from\" [2 0 0]\nShape \"sphere\"\n",
        false,
    )
    .unwrap();
    // pbrt draws +x on the image's left from here; candela draws the x-mirrored scene.
    assert_eq!(imp.doc["lights"][0]["position"], json!([-2.0, 0.0, 0.0]));
    assert_eq!(imp.doc["camera"]["position"], json!([-0.0, 0.0, 5.0]));
    // Portrait film: pbrt's fov is horizontal.
    let fov = imp.doc["camera"]["fov_y"].as_f64().unwrap();
    assert!((fov - 2.0 * (15f64.to_radians().tan() * 2.0).atan().to_degrees()).abs() < 1e-9);
    assert_eq!(
        imp.doc["render"],
        json!({"integrator": "nee", "max_depth": 6}),
        "pbrt's defaults"
    );
    assert_eq!(
        imp.doc["film"]["filter"],
        json!({"type": "gaussian", "stddev": 0.5})
    );
    imp.load(&Default::default()).unwrap();
}

#[test]
fn float_textures_and_roughness_remapping() {
    let imp = import_text(
        "Camera \"perspective\"\nWorldBegin\nTexture \"r\" \"float\" \"imagemap\" \"string filename\" \"grad.png\" \"float scale\" 0.5\nMaterial \"conductor\" \"texture roughness\" \"r\"\nShape \"sphere\"\n",
        false,
    )
    .unwrap();
    let m = &imp.doc["materials"]["conductor"];
    assert!(m["roughness"]["texture"]
        .as_str()
        .unwrap()
        .ends_with(".exr"));
    assert!(
        imp.warnings.iter().any(|w| w.msg.contains("metal-Cu")),
        "the default copper"
    );
    let scene = imp.load(&Default::default()).unwrap();
    let src = crate::scene::texture::decode_file(
        crate::scene::paths::AssetRoot::dir(Some(&dir())),
        "grad.png",
        None,
        &Default::default(),
        "t",
    )
    .unwrap();
    let crate::scene::MaterialKind::Conductor {
        roughness: crate::scene::ScalarParam::Texture(t),
        ..
    } = scene.materials[0].kind
    else {
        panic!()
    };
    let texel = scene.textures[t as usize].texels[9][0];
    let pbrt = 0.5 * (src.2[9][0] + src.2[9][1] + src.2[9][2]) / 3.0;
    assert!(
        (texel.powi(4) - pbrt).abs() < 1e-5,
        "candela roughness = pbrt roughness^(1/4)"
    );
}

#[test]
fn unsupported_constructs_are_named_with_file_and_line() {
    let head = "Camera \"perspective\"\nWorldBegin\n";
    for (body, needle) in [
        ("Shape \"bilinearmesh\"", "shape \"bilinearmesh\" is not supported"),
        ("Material \"coatedconductor\"\nShape \"sphere\"", "material \"coatedconductor\" is not supported"),
        ("Material \"diffuse\" \"texture normalmap\" \"n\"\nShape \"sphere\"", "\"normalmap\" is not supported"),
        ("LightSource \"goniometric\"", "LightSource \"goniometric\" is not supported"),
        ("LightSource \"infinite\" \"string filename\" \"sky.exr\"", "infinite light with an image"),
        ("LightSource \"point\" \"blackbody I\" [3000]", "blackbody 3000 K"),
        ("AreaLightSource \"diffuse\" \"bool twosided\" true\nShape \"sphere\"", "two-sided area light"),
        ("Shape \"sphere\" \"float zmax\" 0.5", "partial sphere"),
        ("Shape \"sphere\" \"float wobble\" 2", "parameter \"float wobble\""),
        ("Texture \"c\" \"spectrum\" \"checkerboard\"", "texture \"checkerboard\""),
        ("MakeNamedMedium \"fog\" \"string type\" \"homogeneous\"", "participating media"),
        ("Material \"conductor\" \"spectrum eta\" \"metal-CuZn-eta\" \"rgb k\" [1 1 1]\nShape \"sphere\"", "named spectrum \"metal-CuZn-eta\""),
    ] {
        let text = format!("{head}{body}\n");
        let e = import_text(&text, false).err().unwrap_or_else(|| panic!("accepted: {body}"));
        assert!(e.contains("s.pbrt:3: ") && e.contains(needle) && e.contains("--lenient"), "{needle:?} not in: {e}");
        let imp = import_text(&text, true).unwrap_or_else(|e| panic!("lenient {body}: {e}"));
        assert!(!imp.warnings.is_empty());
        imp.load(&Default::default()).unwrap_or_else(|e| panic!("{body}: {e}"));
    }
    for (text, needle) in [
        ("Camera \"perspective\"\nWorldBegin\nFrobnicate 1\n", "s.pbrt:3: unknown directive \"Frobnicate\""),
        ("WorldBegin\nShape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0] \"integer indices\" [0 1 5]\n", "s.pbrt:2: index 5 out of range"),
        ("WorldBegin\nInclude \"../x.pbrt\"\n", "s.pbrt:2: Include: \"../x.pbrt\" leaves the scene folder"),
        ("WorldBegin\nAttributeEnd\n", "s.pbrt:2: AttributeEnd without a matching begin"),
        ("WorldBegin\nNamedMaterial \"nope\"\n", "s.pbrt:2: NamedMaterial: no material \"nope\""),
        ("Translate 1 2\n", "s.pbrt:1: expected 3 numbers"),
        ("WorldBegin\nCamera \"perspective\"\n", "s.pbrt:2: Camera must come before WorldBegin"),
        ("WorldBegin\nShape \"sphere\" \"float radius\" [1\n", "unterminated ["),
    ] {
        let e = import_text(text, true).err().unwrap_or_else(|| panic!("accepted: {text}"));
        assert!(e.contains(needle), "{needle:?} not in: {e}");
    }
}
