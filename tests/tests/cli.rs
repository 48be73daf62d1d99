//! The `candela render` command end to end: the real binary on the repository's scenes, its
//! report (text and --json), the files it writes, and bad input of every kind: each must exit 2
//! with one clear line naming what is wrong and where, never panic.

use std::process::Output;

use candela_tests::{assert_bad_input, run_candela as run, scene_path, scratch, text};

fn stderr(o: &Output) -> String {
    text(&o.stderr)
}

#[test]
fn renders_png_and_exr_with_a_report() {
    let dir = scratch("cli_render");
    let exr = dir.join("furnace.exr");
    let scene = scene_path("furnace.json");
    let o = run(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        exr.to_str().unwrap(),
        "--spp",
        "4",
        "--width",
        "16",
        "--height",
        "16",
        "--options",
        r#"{"max_depth": 3}"#,
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let report: serde_json::Value =
        serde_json::from_slice(&o.stdout).expect("--json prints one JSON object");
    for key in [
        "device",
        "integrator",
        "spp",
        "time_s",
        "msamples_per_s",
        "rays_per_s",
        "dropped_samples",
    ] {
        assert!(report.get(key).is_some(), "missing {key} in {report}");
    }
    assert_eq!(report["spp"], 4);
    assert_eq!(report["integrator"], "nee");
    assert_eq!(
        report["max_depth"], 3,
        "--options sets the integrator's fields"
    );
    let img = renderer::film::read_exr(&exr).unwrap();
    assert_eq!((img.width, img.height), (16, 16));

    let png = dir.join("furnace.png");
    let o = run(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        png.to_str().unwrap(),
        "--spp",
        "2",
        "--width",
        "8",
        "--height",
        "8",
        "--integrator",
        "pt",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    for key in ["device", "integrator  pt", "Msamples/s", "dropped"] {
        assert!(text.contains(key), "missing {key} in {text}");
    }
    assert!(std::fs::metadata(&png).unwrap().len() > 0);
}

#[test]
fn time_budget_renders_at_least_one_pass() {
    let dir = scratch("cli_time");
    let out = dir.join("t.exr");
    let scene = scene_path("furnace.json");
    let o = run(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--time",
        "0.2",
        "--width",
        "8",
        "--height",
        "8",
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(report["spp"].as_u64().unwrap() >= 1);
}

/// `render` of an instanced scene with an integrator that has no second level (deferred)
/// writes the instances out as meshes (PrepareOptions::expand_instances) and renders them: the
/// report counts their triangles and no instance, and the image is not empty; nee keeps them.
#[test]
fn integrators_without_a_second_level_render_instances() {
    let dir = scratch("cli_instances");
    let scene = write_scene(
        "cli_instances_scene",
        r#"{"version": 1, "camera": {"position": [0,0,5], "look_at": [0,0,0]},
 "film": {"width": 8, "height": 8},
 "materials": {"white": {"type": "diffuse"}},
 "lights": [{"type": "point", "position": [0, 0, 4], "intensity": [20, 20, 20]}],
 "definitions": {"b": {"type": "box", "min": [-0.5,-0.5,-0.5], "max": [0.5,0.5,0.5], "material": "white"}},
 "objects": [{"type": "instance", "definition": "b", "transform": {"translate": [-0.8, 0, 0]}},
             {"type": "instance", "definition": "b", "transform": {"translate": [0.8, 0, 0]}}]}"#,
    );
    let out = dir.join("i.exr");
    let render = |integrator: &str| {
        let o = run(&[
            "render",
            scene.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--integrator",
            integrator,
            "--spp",
            "1",
            "--json",
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        serde_json::from_slice::<serde_json::Value>(&o.stdout).unwrap()
    };
    let report = render("deferred");
    assert_eq!(report["triangles"], 24, "{report}");
    assert_eq!(report["instances"], 0, "{report}");
    let img = renderer::film::read_exr(&out).unwrap();
    assert!(img.pixels.iter().any(|p| p[0] > 0.0), "a black image");
    // nee traces them: they stay two instances of one 12-triangle definition.
    let report = render("nee");
    assert_eq!(report["instances"], 2, "{report}");
    assert_eq!(report["triangles"], 12, "{report}");
}

fn write_scene(name: &str, text: &str) -> std::path::PathBuf {
    let dir = scratch(name);
    let p = dir.join("scene.json");
    std::fs::write(&p, text).unwrap();
    p
}

const GOOD: &str = r#"{"version": 1, "camera": {"position": [0,0,5], "look_at": [0,0,0]},
 "film": {"width": 8, "height": 8},
 "materials": {"white": {"type": "diffuse"}},
 "objects": [{"type": "sphere", "center": [0,0,0], "radius": 1, "material": "white"}]}"#;

#[test]
fn bad_input_exits_2_with_a_clear_line() {
    let out = scratch("cli_bad_out").join("x.exr");
    let o_path = out.to_str().unwrap();
    // Malformed JSON: line and column.
    let p = write_scene("bad_json", "{\"version\": 1,\n \"camera\": {");
    assert_bad_input(
        &run(&["render", p.to_str().unwrap(), "-o", o_path]),
        &["line 2"],
    );
    // Unknown field, with its JSON path.
    let p = write_scene(
        "bad_field",
        &GOOD.replace("\"radius\": 1", "\"radius\": 1, \"radius2\": 3"),
    );
    assert_bad_input(
        &run(&["render", p.to_str().unwrap(), "-o", o_path]),
        &["objects[0]", "radius2"],
    );
    // Missing material.
    let p = write_scene(
        "bad_material",
        &GOOD.replace("\"material\": \"white\"", "\"material\": \"glas\""),
    );
    assert_bad_input(
        &run(&["render", p.to_str().unwrap(), "-o", o_path]),
        &["objects[0].material", "glas"],
    );
    // A number JSON cannot hold as f64 (the nearest JSON has to NaN/Inf).
    let p = write_scene(
        "bad_number",
        &GOOD.replace("\"radius\": 1", "\"radius\": 1e999"),
    );
    assert_bad_input(
        &run(&["render", p.to_str().unwrap(), "-o", o_path]),
        &["objects[0]"],
    );
    // NaN is not JSON at all.
    let p = write_scene("bad_nan", &GOOD.replace("\"radius\": 1", "\"radius\": NaN"));
    assert_bad_input(
        &run(&["render", p.to_str().unwrap(), "-o", o_path]),
        &["line"],
    );
    // Absurd film size in the scene and on the command line.
    let p = write_scene(
        "bad_size",
        &GOOD.replace("\"width\": 8", "\"width\": 1000000000"),
    );
    assert_bad_input(
        &run(&["render", p.to_str().unwrap(), "-o", o_path]),
        &["film.width"],
    );
    let p = write_scene("good", GOOD);
    assert_bad_input(
        &run(&[
            "render",
            p.to_str().unwrap(),
            "-o",
            o_path,
            "--width",
            "99999999",
        ]),
        &["--width"],
    );
    assert_bad_input(
        &run(&["render", p.to_str().unwrap(), "-o", o_path, "--spp", "0"]),
        &["--spp"],
    );
    assert_bad_input(
        &run(&[
            "render",
            p.to_str().unwrap(),
            "-o",
            o_path,
            "--max-depth",
            "0",
        ]),
        &["--max-depth"],
    );
    assert_bad_input(
        &run(&[
            "render",
            p.to_str().unwrap(),
            "-o",
            o_path,
            "--integrator",
            "magic",
        ]),
        &["magic"],
    );
    assert_bad_input(
        &run(&["render", p.to_str().unwrap(), "-o", "out.jpg"]),
        &[".exr or .png"],
    );
    // Missing scene file and missing mesh file.
    assert_bad_input(
        &run(&["render", "no/such/scene.json", "-o", o_path]),
        &["no/such/scene.json"],
    );
    let p = write_scene(
        "bad_mesh",
        &GOOD.replace(
            r#"{"type": "sphere", "center": [0,0,0], "radius": 1, "material": "white"}"#,
            r#"{"type": "mesh", "file": "missing.obj", "material": "white"}"#,
        ),
    );
    assert_bad_input(
        &run(&["render", p.to_str().unwrap(), "-o", o_path]),
        &["objects[0]", "missing.obj"],
    );
    // A path escaping the scene folder.
    let p = write_scene(
        "bad_escape",
        &GOOD.replace(
            r#"{"type": "sphere", "center": [0,0,0], "radius": 1, "material": "white"}"#,
            r#"{"type": "mesh", "file": "../../etc/passwd.obj", "material": "white"}"#,
        ),
    );
    assert_bad_input(
        &run(&["render", p.to_str().unwrap(), "-o", o_path]),
        &["objects[0]"],
    );
    // Integrator options: not JSON, an unknown field, a contradicting type.
    let p = write_scene("good_options", GOOD);
    let with_options = |json: &str| {
        run(&[
            "render",
            p.to_str().unwrap(),
            "-o",
            o_path,
            "--integrator",
            "pt",
            "--options",
            json,
        ])
    };
    assert_bad_input(&with_options("nope"), &["--options", "not JSON"]);
    assert_bad_input(&with_options("[1]"), &["--options", "JSON object"]);
    assert_bad_input(
        &with_options(r#"{"max_dpeth": 3}"#),
        &["--options", "max_dpeth"],
    );
    assert_bad_input(
        &with_options(r#"{"type": "nee"}"#),
        &["--options", "contradicts"],
    );
    // Values out of range are refused before any GPU work, naming the field.
    let o = run(&[
        "render",
        p.to_str().unwrap(),
        "-o",
        o_path,
        "--integrator",
        "vct",
        "--options",
        r#"{"resolution": 96}"#,
    ]);
    assert_bad_input(&o, &["--options", "resolution"]);
    // Unknown device.
    let p = write_scene("good_device", GOOD);
    assert_bad_input(
        &run(&[
            "render",
            p.to_str().unwrap(),
            "-o",
            o_path,
            "--device",
            "no-such-gpu",
        ]),
        &["no-such-gpu"],
    );
}

#[test]
fn devices_lists_at_least_one() {
    let o = run(&["devices", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(!v.as_array().unwrap().is_empty());
}
