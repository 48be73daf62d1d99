//! Scene files of other formats on the command line: `candela render` and `candela bench` take
//! them directly (`--lenient`, `-D`), `candela convert` writes candela JSON (meshes beside it) and
//! Mitsuba XML, and bad input is one line naming file and line with exit status 2.

use candela_tests::{assert_bad_input, repo_root, run_candela, scratch, text};

fn path(rel: &str) -> String {
    repo_root().join(rel).to_string_lossy().into_owned()
}

#[test]
fn render_bench_and_convert_take_every_format() {
    let dir = scratch("import_cli");
    // render: an XML with a $parameter, a glTF, a pbrt file, a .scn.
    for (scene, extra) in [
        ("tests/import/mitsuba/cornell.xml", vec!["-D", "res=8"]),
        ("tests/import/gltf/scene.gltf", vec![]),
        ("tests/import/pbrt/scene.pbrt", vec![]),
        ("tests/import/scn/cornell.scn", vec![]),
    ] {
        let out = dir.join("out.png");
        let mut args = vec![
            "render",
            scene,
            "-o",
            out.to_str().unwrap(),
            "--spp",
            "2",
            "--width",
            "8",
            "--height",
            "8",
        ];
        let scene_path = path(scene);
        args[1] = &scene_path;
        args.extend(extra.iter().copied());
        let o = run_candela(&args);
        assert!(o.status.success(), "{scene}: {}", text(&o.stderr));
        assert!(out.is_file());
    }
    // bench: a glTF straight away.
    let o = run_candela(&[
        "bench",
        &path("tests/import/gltf/scene.gltf"),
        "--width",
        "8",
        "--height",
        "8",
        "--integrators",
        "nee",
        "--times",
        "0.05",
        "--repeats",
        "1",
        "--reference-spp",
        "16",
        "--out",
        dir.join("bench").to_str().unwrap(),
    ]);
    assert!(o.status.success(), "bench: {}", text(&o.stderr));
    // convert: XML → JSON (the serialized mesh and the flipped PLY written beside it) → XML.
    let json = dir.join("lights.json");
    let o = run_candela(&[
        "convert",
        &path("tests/import/mitsuba/lights.xml"),
        json.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let stdout = text(&o.stdout);
    assert!(stdout.contains("lights_assets/pyramid.ply"), "{stdout}");
    assert!(
        dir.join("grad.png").is_file(),
        "the scene's own files are copied beside the JSON"
    );
    assert!(
        text(&o.stderr).contains("warning: ") && text(&o.stderr).contains("mirrors the image"),
        "{}",
        text(&o.stderr)
    );
    renderer::scene::load_file(&json).expect("the converted JSON loads");
    let xml = dir.join("again.xml");
    let o = run_candela(&["convert", json.to_str().unwrap(), xml.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(std::fs::read_to_string(&xml)
        .unwrap()
        .contains("<scene version=\"3.0.0\">"));
}

#[test]
fn unsupported_constructs_fail_with_exit_2_unless_lenient() {
    let dir = scratch("import_cli_bad");
    let xml = dir.join("hair.xml");
    std::fs::write(&xml, "<scene version=\"3.0.0\">\n<shape type=\"sphere\">\n<bsdf type=\"hair\"/>\n</shape>\n</scene>\n").unwrap();
    let out = dir.join("out.exr");
    let (x, o) = (xml.to_str().unwrap(), out.to_str().unwrap());
    let r = run_candela(&[
        "render", x, "-o", o, "--spp", "1", "--width", "4", "--height", "4",
    ]);
    assert_bad_input(
        &r,
        &["hair.xml:3: bsdf \"hair\" is not supported", "--lenient"],
    );
    let r = run_candela(&[
        "render",
        x,
        "-o",
        o,
        "--spp",
        "1",
        "--width",
        "4",
        "--height",
        "4",
        "--lenient",
    ]);
    assert!(r.status.success(), "{}", text(&r.stderr));
    assert!(
        text(&r.stderr).contains("warning: ") && text(&r.stderr).contains("bsdf \"hair\""),
        "{}",
        text(&r.stderr)
    );
    let r = run_candela(&[
        "convert",
        x,
        dir.join("x.txt").to_str().unwrap(),
        "--lenient",
    ]);
    assert_bad_input(&r, &["must end in .json"]);
    let r = run_candela(&[
        "convert",
        &path("tests/import/gltf/scene.gltf"),
        dir.join("x.xml").to_str().unwrap(),
    ]);
    assert_bad_input(&r, &["convert the glTF 2.0 scene to .json first"]);
    let r = run_candela(&["render", x, "-o", o, "-D", "novalue"]);
    assert_bad_input(&r, &["-D novalue: expected NAME=VALUE"]);
}
