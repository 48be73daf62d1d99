//! Mitsuba importer tests without a GPU: the test scenes of tests/import/mitsuba import into the
//! expected document and load; every unsupported construct is refused with its name, file and
//! line, and skipped or replaced with a warning under --lenient.

use std::path::{Path, PathBuf};

use serde_json::{json, Value};

use crate::import::{import_file, ImportOptions, Imported};
use crate::scene::paths::tests::temp_dir;

fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/import/mitsuba")
}

/// Imports `body` (the inside of a `<scene>`, one element per line from line 2) with a sensor.
fn import_body(body: &str, lenient: bool) -> Result<Imported, String> {
    let d = temp_dir("mi_import");
    std::fs::copy(dir().join("grad.png"), d.join("grad.png")).unwrap();
    std::fs::copy(dir().join("tile.obj"), d.join("tile.obj")).unwrap();
    std::fs::copy(dir().join("quad_uv.ply"), d.join("quad_uv.ply")).unwrap();
    let text = format!("<scene version=\"3.0.0\">\n{body}\n</scene>\n");
    std::fs::write(d.join("s.xml"), text).unwrap();
    let opts = ImportOptions {
        lenient,
        ..Default::default()
    };
    import_file(&d.join("s.xml"), &opts).map_err(|e| e.to_string())
}

/// The error of `body` (strict) must contain each needle and name `s.xml:LINE`; with --lenient
/// the scene imports, loads and warns.
fn refused(body: &str, line: usize, needles: &[&str]) {
    let e = import_body(body, false)
        .err()
        .unwrap_or_else(|| panic!("accepted: {body}"));
    assert!(e.contains(&format!("s.xml:{line}: ")), "{e}");
    for n in needles {
        assert!(e.contains(n), "{n:?} not in: {e}");
    }
    assert!(e.contains("--lenient"), "{e}");
    let imp = import_body(body, true).unwrap_or_else(|e| panic!("lenient: {e}"));
    assert!(!imp.warnings.is_empty(), "no warning for {body}");
    imp.load(&Default::default())
        .unwrap_or_else(|e| panic!("lenient result does not load: {e}\n{}", imp.json_text()));
}

fn material(imp: &Imported, name: &str) -> Value {
    imp.doc["materials"][name].clone()
}

#[test]
fn cornell_imports_as_expected_and_loads() {
    let imp = import_file(&dir().join("cornell.xml"), &ImportOptions::default()).unwrap();
    assert!(imp.warnings.is_empty(), "{:?}", imp.warnings);
    let d = &imp.doc;
    assert_eq!(
        d["film"],
        json!({"width": 128, "height": 128, "filter": {"type": "gaussian", "stddev": 0.5}})
    );
    assert_eq!(
        d["render"],
        json!({"integrator": "nee", "max_depth": 6, "spp": 64})
    );
    assert_eq!(d["camera"]["position"], json!([0.0, 0.0, 3.9]));
    assert_eq!(
        d["camera"]["fov_y"],
        json!(39.3077),
        "square film: fov x = fov y"
    );
    // twosided → candela's default; the bare principled is one-sided.
    assert_eq!(
        material(&imp, "white"),
        json!({"type": "diffuse", "reflectance": [0.885809, 0.698859, 0.666422]})
    );
    assert_eq!(material(&imp, "blue")["two_sided"], json!(false));
    assert_eq!(
        material(&imp, "white_emitter")["emission"],
        json!([18.387, 13.9873, 6.75357])
    );
    let cu = material(&imp, "roughconductor");
    assert_eq!(cu["eta"], json!([0.20100547, 0.9237495, 1.1022154]));
    assert!((cu["roughness"].as_f64().unwrap() - 0.15f64.sqrt()).abs() < 1e-12);
    assert!(
        (material(&imp, "dielectric")["ior"].as_f64().unwrap() - 1.5046 / 1.000277).abs() < 1e-9
    );
    // 6 rectangles, a cube, two spheres, and 2 instances × 2 shapes: the group's cube is
    // defined once and placed by two `instance` objects, its sphere copied into place.
    let objects = d["objects"].as_array().unwrap();
    assert_eq!(objects.len(), 13);
    let defs = d["definitions"].as_object().unwrap();
    assert_eq!(defs.keys().collect::<Vec<_>>(), ["pebbles_1"]);
    assert_eq!(defs["pebbles_1"]["type"], "box");
    let placed: Vec<&Value> = objects.iter().filter(|o| o["type"] == "instance").collect();
    assert_eq!(placed.len(), 2);
    assert!(placed.iter().all(|o| o["definition"] == "pebbles_1"));
    assert_ne!(placed[0]["transform"], placed[1]["transform"]);
    assert_eq!(objects[0]["type"], "quad");
    assert_eq!(objects[0]["origin"], json!([-1, -1, 0]));
    let scene = imp.load(&Default::default()).unwrap();
    assert_eq!((scene.film.width, scene.spheres.len()), (128, 4));
    assert_eq!((scene.prototypes.len(), scene.instances.len()), (1, 2));
}

#[test]
fn lights_scene_mirrors_and_rewrites_what_candela_reads_differently() {
    let imp = import_file(&dir().join("lights.xml"), &ImportOptions::default()).unwrap();
    assert_eq!(imp.warnings.len(), 1, "{:?}", imp.warnings);
    assert!(imp.warnings[0].msg.contains("mirrors the image"));
    let d = &imp.doc;
    // The point light at x = 1.5 lands at −1.5 in the mirrored scene.
    assert_eq!(d["lights"][0]["position"], json!([-1.5, 3.0, 2.0]));
    let objects = d["objects"].as_array().unwrap();
    // The textured PLY and the serialized mesh are held in memory; the OBJ is referenced.
    assert!(objects[1]["file"]
        .as_str()
        .unwrap()
        .starts_with("_imported/quad_uv"));
    assert!(objects[2]["file"]
        .as_str()
        .unwrap()
        .starts_with("_imported/pyramid"));
    assert_eq!(objects[2]["smooth"], json!(false));
    assert_eq!(objects[3]["file"], json!("tile.obj"));
    assert_eq!(imp.assets.len(), 2);
    let mask = &d["materials"][objects[3]["material"].as_str().unwrap()];
    assert_eq!(
        mask["alpha_mask"],
        json!({"texture": "mask.png", "channel": "luminance"})
    );
    let ply_mat = &d["materials"][objects[1]["material"].as_str().unwrap()];
    assert_eq!(
        ply_mat["roughness"],
        json!({"texture": "grad.png", "channel": "luminance"})
    );
    assert_eq!(
        d["environment"],
        json!({"type": "constant", "radiance": [0.08, 0.1, 0.14]})
    );
    let scene = imp.load(&Default::default()).unwrap();
    // The PLY's v was flipped: Mitsuba's v = 0 (top row) is candela's v = 1.
    let ply = scene
        .meshes
        .iter()
        .find(|m| m.name.contains("quad_uv"))
        .unwrap();
    assert_eq!(ply.uvs.as_ref().unwrap()[0], glam::Vec2::new(0.0, 1.0));
}

#[test]
fn unsupported_plugins_are_named_with_file_and_line() {
    let sphere = |bsdf: &str| format!("<shape type=\"sphere\">\n{bsdf}\n</shape>");
    refused(
        &sphere("<bsdf type=\"hair\"/>"),
        3,
        &["bsdf \"hair\" is not supported"],
    );
    refused(
        &sphere("<bsdf type=\"thindielectric\"/>"),
        3,
        &["bsdf \"thindielectric\""],
    );
    refused(
        &sphere("<bsdf type=\"bumpmap\"><texture type=\"bitmap\"><string name=\"filename\" value=\"grad.png\"/></texture><bsdf type=\"diffuse\"/></bsdf>"),
        3,
        &["bumpmap", "no bump or normal mapping"],
    );
    refused(
        &sphere("<bsdf type=\"roughconductor\"/>"),
        3,
        &["distribution \"beckmann\""],
    );
    refused(
        &sphere(
            "<bsdf type=\"diffuse\"><texture type=\"checkerboard\" name=\"reflectance\"/></bsdf>",
        ),
        3,
        &["texture \"checkerboard\""],
    );
    refused(
        &sphere("<bsdf type=\"mask\"><float name=\"opacity\" value=\"0.5\"/><bsdf type=\"diffuse\"/></bsdf>"),
        3,
        &["constant opacity"],
    );
    refused(
        &sphere("<bsdf type=\"diffuse\">\n<float name=\"shininess\" value=\"2\"/></bsdf>"),
        4,
        &["parameter \"shininess\""],
    );
    refused(
        "<shape type=\"cylinder\"/>",
        2,
        &["shape \"cylinder\" is not supported"],
    );
    refused("<emitter type=\"sunsky\"/>", 2, &["emitter \"sunsky\""]);
    refused(
        "<medium type=\"homogeneous\"/>",
        2,
        &["<medium type=\"homogeneous\">"],
    );
    refused(
        "<shape type=\"sphere\"><emitter type=\"area\"><texture type=\"bitmap\" name=\"radiance\"><string name=\"filename\" value=\"grad.png\"/></texture></emitter></shape>",
        2,
        &["textured radiance"],
    );
    refused(
        "<sensor type=\"orthographic\"><transform name=\"to_world\"><lookat origin=\"0,0,5\" target=\"0,0,0\"/></transform></sensor>",
        2,
        &["sensor \"orthographic\""],
    );
    refused("<integrator type=\"aov\"/>", 2, &["integrator \"aov\""]);
    refused(
        "<sensor type=\"perspective\"><film type=\"hdrfilm\"><rfilter type=\"tent\"/></film></sensor>",
        2,
        &["rfilter \"tent\""],
    );
    refused(
        "<emitter type=\"envmap\"><string name=\"filename\" value=\"grad.png\"/><transform name=\"to_world\"><rotate x=\"1\" angle=\"30\"/></transform></emitter>",
        2,
        &["rotation about +Y"],
    );
    refused(
        "<emitter type=\"constant\"/>\n<emitter type=\"constant\"/>",
        3,
        &["second environment"],
    );
}

#[test]
fn malformed_scenes_are_errors_even_when_lenient() {
    for (body, needle) in [
        ("<shape type=\"obj\"/>", "needs \"filename\""),
        ("<shape type=\"obj\"><string name=\"filename\" value=\"../x.obj\"/></shape>", "leaves the scene folder"),
        ("<shape type=\"obj\"><string name=\"filename\" value=\"/etc/x.obj\"/></shape>", "absolute paths"),
        ("<shape type=\"sphere\"><ref id=\"nope\"/></shape>", "unresolved reference to \"nope\""),
        ("<shape type=\"sphere\"><bsdf type=\"conductor\"><string name=\"material\" value=\"Fe\"/></bsdf></shape>", "unknown material \"Fe\""),
        ("<shape type=\"sphere\"><bsdf type=\"dielectric\"><string name=\"int_ior\" value=\"glass\"/></bsdf></shape>", "unknown IOR name \"glass\""),
        ("<shape type=\"sphere\"><float name=\"radius\" value=\"x\"/></shape>", "could not parse floating point value \"x\""),
        ("<shape type=\"sphere\"><transform name=\"to_world\"><scale x=\"1\" y=\"2\"/></transform></shape>", "uniform scale"),
        ("<emitter type=\"area\"/>", "must be nested in a <shape>"),
        ("<integrator type=\"path\"><integer name=\"max_depth\" value=\"0\"/></integrator>", "max_depth must be -1"),
    ] {
        for lenient in [false, true] {
            let e = import_body(body, lenient).err().unwrap_or_else(|| panic!("accepted: {body}"));
            assert!(e.contains("s.xml:2: "), "{e}");
            assert!(e.contains(needle), "{needle:?} not in: {e}");
        }
    }
}

#[test]
fn materials_map_exactly() {
    let imp = import_body(
        "<bsdf type=\"roughconductor\" id=\"aniso\"><string name=\"distribution\" value=\"ggx\"/><float name=\"alpha_u\" value=\"0.4\"/><float name=\"alpha_v\" value=\"0.1\"/><rgb name=\"eta\" value=\"0.2, 0.9, 1.1\"/><rgb name=\"k\" value=\"3.9, 2.4, 2.1\"/></bsdf>\n\
         <bsdf type=\"conductor\" id=\"mirror\"/>\n\
         <bsdf type=\"roughdielectric\" id=\"frosted\"><string name=\"distribution\" value=\"ggx\"/><float name=\"alpha\" value=\"0.09\"/><float name=\"int_ior\" value=\"1.33\"/><string name=\"ext_ior\" value=\"vacuum\"/></bsdf>\n\
         <bsdf type=\"principled\" id=\"p\"><float name=\"eta\" value=\"1.4\"/><float name=\"spec_trans\" value=\"0.5\"/><texture type=\"bitmap\" name=\"base_color\"><string name=\"filename\" value=\"grad.png\"/><boolean name=\"raw\" value=\"true\"/><transform name=\"to_uv\"><scale x=\"2\" y=\"4\"/></transform></texture></bsdf>\n\
         <bsdf type=\"roughconductor\" id=\"tex\"><string name=\"distribution\" value=\"ggx\"/><texture type=\"bitmap\" name=\"alpha\"><string name=\"filename\" value=\"grad.png\"/></texture></bsdf>\n\
         <shape type=\"sphere\"><ref id=\"aniso\"/></shape>\n<shape type=\"sphere\"><ref id=\"mirror\"/></shape>\n\
         <shape type=\"sphere\"><ref id=\"frosted\"/></shape>\n<shape type=\"sphere\"><ref id=\"p\"/></shape>\n<shape type=\"sphere\"><ref id=\"tex\"/></shape>",
        false,
    )
    .unwrap();
    let a = material(&imp, "aniso");
    assert!((a["roughness"].as_f64().unwrap() - 0.04f64.sqrt().sqrt()).abs() < 1e-12);
    assert!((a["anisotropy"].as_f64().unwrap() - (1.0 - 0.25) / 0.9).abs() < 1e-12);
    assert_eq!(
        material(&imp, "mirror"),
        json!({"type": "conductor", "two_sided": false})
    );
    let f = material(&imp, "frosted");
    assert_eq!(
        (f["ior"].as_f64(), f["roughness"].as_f64()),
        (Some(1.33), Some(0.3))
    );
    let p = material(&imp, "p");
    assert_eq!(p["ior"], json!(1.4));
    assert!(
        p.get("two_sided").is_none(),
        "transmissive principled stays two-sided"
    );
    assert_eq!(
        p["base_color"],
        json!({"texture": "grad.png", "srgb": false, "scale": [2.0, 4.0]})
    );
    let t = material(&imp, "tex");
    let file = t["roughness"]["texture"].as_str().unwrap();
    assert!(
        file.starts_with("_imported/") && file.ends_with(".exr"),
        "{file}"
    );
    let scene = imp.load(&Default::default()).unwrap();
    // √alpha per texel: the derived texture's texels square back to the source's luminance.
    let derived = scene.textures.iter().find(|x| x.source == file).unwrap();
    let src = crate::scene::texture::decode_file(
        crate::scene::paths::AssetRoot::dir(Some(&dir())),
        "grad.png",
        None,
        &Default::default(),
        "t",
    )
    .unwrap();
    let l = |t: [f32; 4]| 0.2126 * t[0] + 0.7152 * t[1] + 0.0722 * t[2];
    assert!((derived.texels[5][0].powi(2) - l(src.2[5])).abs() < 1e-5);
}

#[test]
fn missing_sensor_and_old_versions() {
    let imp = import_body("<shape type=\"sphere\"/>", false).unwrap();
    assert!(imp.warnings[0].msg.contains("no <sensor>"));
    assert_eq!(imp.doc["film"]["width"], json!(768));
    assert_eq!(
        imp.doc["render"]["max_depth"],
        json!(-1),
        "Mitsuba's path default"
    );
    imp.load(&Default::default()).unwrap();
}

#[test]
fn an_error_in_a_shapegroup_member_names_the_member_line() {
    // The group's PLY is missing: the loader's error (at definitions.g_0.file) must point at
    // the member's line (4), not at the instance placing it (7 or 8). A sphere member, copied
    // into place, keeps its own line too (5).
    let body = "<bsdf type=\"diffuse\" id=\"w\"/>
<shape type=\"shapegroup\" id=\"g\">
<shape type=\"ply\"><string name=\"filename\" value=\"nope.ply\"/><ref id=\"w\"/></shape>
<shape type=\"sphere\"><float name=\"radius\" value=\"0.5\"/><ref id=\"w\"/></shape>
</shape>
<shape type=\"instance\"><ref id=\"g\"/></shape>
<shape type=\"instance\"><ref id=\"g\"/><transform name=\"to_world\"><translate x=\"2\"/></transform></shape>";
    let imp = import_body(body, false).unwrap();
    let e = imp.load(&Default::default()).unwrap_err().to_string();
    assert!(e.contains("s.xml:4: "), "{e}");
    assert!(e.contains("nope.ply"), "{e}");
    let copies: Vec<_> = (imp.origins.iter())
        .filter(|(path, _)| path.starts_with("objects["))
        .filter(|(path, _)| {
            let k: usize = path["objects[".len()..path.len() - 1].parse().unwrap();
            imp.doc["objects"][k]["type"] == "sphere"
        })
        .map(|(_, loc)| loc.to_string())
        .collect();
    assert_eq!(copies.len(), 2, "{copies:?}");
    assert!(copies.iter().all(|l| l.ends_with("s.xml:5")), "{copies:?}");
    // Placed once, the group's mesh is written in place: its error still names line 4.
    let once = body.rsplit_once('\n').unwrap().0;
    let imp = import_body(once, false).unwrap();
    assert!(imp.doc.get("definitions").is_none(), "{}", imp.json_text());
    let e = imp.load(&Default::default()).unwrap_err().to_string();
    assert!(e.contains("s.xml:4: "), "{e}");
}

#[test]
fn bitmap_to_uv_scale_with_its_v_shift_is_kept_and_others_are_reported() {
    let textured = |transform: &str| {
        format!(
            "<shape type=\"sphere\"><bsdf type=\"diffuse\"><texture type=\"bitmap\" name=\"reflectance\"><string name=\"filename\" value=\"grad.png\"/>\n{transform}</texture></bsdf></shape>"
        )
    };
    // Mitsuba's v runs from the top row: a scale sv with a v shift of 1 − sv (what candela's
    // exporter writes) is candela's scale exactly, also with whole shifts added.
    for shift in ["-0.3", "0.7", "2.7"] {
        let body = textured(&format!(
            "<transform name=\"to_uv\"><scale x=\"0.5\" y=\"1.3\"/><translate y=\"{shift}\"/></transform>"
        ));
        let imp = import_body(&body, false).unwrap_or_else(|e| panic!("{shift}: {e}"));
        let uv_warnings = imp
            .warnings
            .iter()
            .filter(|w| format!("{w:?}").contains("to_uv"));
        assert_eq!(uv_warnings.count(), 0, "{shift}: {:?}", imp.warnings);
        let m = imp.doc["materials"]
            .as_object()
            .unwrap()
            .values()
            .next()
            .unwrap()
            .clone();
        assert_eq!(m["reflectance"]["scale"], json!([0.5, 1.3]), "{shift}");
    }
    // A non-whole v scale without its shift, a u shift, and legacy scales with a shift.
    let transform = |t: &str| format!("<transform name=\"to_uv\">{t}</transform>");
    for body in [
        textured(&transform("<scale x=\"1\" y=\"0.5\"/>")),
        textured(&transform(
            "<scale x=\"2\" y=\"2\"/><translate x=\"0.25\" y=\"-1\"/>",
        )),
        textured(&format!(
            "<float name=\"vscale\" value=\"2\"/>{}",
            transform("<scale y=\"0.25\"/><translate y=\"0.5\"/>")
        )),
    ] {
        refused(&body, 3, &["to_uv other than a scale"]);
    }
}
