//! Scenes with files, uploaded to the real `candela serve`: multipart (a scene part plus one
//! part per asset), a .tar.gz of the scene folder and a .zip; and the unsafe or broken uploads
//! it must refuse with a 422 naming the problem (paths escaping the folder, a missing asset, no
//! scene.json, not an archive) without writing outside its data directory.

use std::io::Write;
use std::time::Duration;

use candela_tests::server::Server;
use candela_tests::{scene_path, scratch};
use reqwest::blocking::multipart::{Form, Part};
use reqwest::Method;
use serde_json::{json, Value};

const T: Duration = Duration::from_secs(90);

/// The textured-mesh example: (scene text, [(relative path, bytes)]).
fn textured_mesh() -> (String, Vec<(&'static str, Vec<u8>)>) {
    let scene = std::fs::read_to_string(scene_path("textured_mesh.json")).unwrap();
    let assets = ["assets/checker.png", "assets/uv_sphere.obj"]
        .into_iter()
        .map(|rel| (rel, std::fs::read(scene_path(rel)).unwrap()))
        .collect();
    (scene, assets)
}

fn job_part() -> Part {
    Part::text(json!({"spp": 2, "width": 16, "height": 12}).to_string())
}

fn upload(s: &Server, form: Form) -> (u16, Value) {
    s.send(s.request(Method::POST, "/api/jobs").multipart(form))
}

fn finishes(s: &Server, r: (u16, Value)) {
    assert_eq!(r.0, 201, "{}", r.1);
    assert_eq!(r.1["scene_source"], "upload");
    let id = r.1["id"].as_i64().unwrap();
    let done = s.wait_job(id, T, |j| j["state"] != "queued" && j["state"] != "running");
    assert_eq!(done["state"], "done", "{done}");
    assert_eq!(done["progress"]["spp"], 2);
    let png = s
        .request(Method::GET, &format!("/api/jobs/{id}/image.png"))
        .send()
        .unwrap();
    assert_eq!(png.status().as_u16(), 200);
}

fn tar_gz(entries: &[(String, &[u8])]) -> Vec<u8> {
    let gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    let mut b = tar::Builder::new(gz);
    for (name, bytes) in entries {
        let mut h = tar::Header::new_gnu();
        h.set_size(bytes.len() as u64);
        h.set_mode(0o644);
        let dir = name.ends_with('/');
        h.set_entry_type(if dir {
            tar::EntryType::Directory
        } else {
            tar::EntryType::Regular
        });
        b.append_data(&mut h, name, *bytes).unwrap();
    }
    b.into_inner().unwrap().finish().unwrap()
}

fn zip(entries: &[(String, &[u8])]) -> Vec<u8> {
    let mut z = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    for (name, bytes) in entries {
        z.start_file(name.as_str(), zip::write::SimpleFileOptions::default())
            .unwrap();
        z.write_all(bytes).unwrap();
    }
    z.finish().unwrap().into_inner()
}

fn archive_form(bytes: Vec<u8>, name: &str) -> Form {
    Form::new()
        .part("job", job_part())
        .part("archive", Part::bytes(bytes).file_name(name.to_string()))
}

#[test]
fn uploads_render_and_unsafe_ones_are_refused() {
    let dir = scratch("server_uploads");
    let s = Server::start(&dir.join("data"), &[]);
    let (scene, assets) = textured_mesh();

    // Multipart: scene part plus asset parts named by their paths.
    let mut form = Form::new()
        .part("job", job_part())
        .part("scene", Part::text(scene.clone()).file_name("scene.json"));
    for (rel, bytes) in &assets {
        form = form.part(
            *rel,
            Part::bytes(bytes.clone()).file_name(rel.rsplit('/').next().unwrap()),
        );
    }
    finishes(&s, upload(&s, form));

    // A .tar.gz of a folder holding scene.json (with the "./" entry `tar -C dir .` writes).
    let mut entries: Vec<(String, &[u8])> = vec![
        ("./".into(), b""),
        ("./myscene/".into(), b""),
        ("myscene/scene.json".into(), scene.as_bytes()),
    ];
    for (rel, bytes) in &assets {
        entries.push((format!("myscene/{rel}"), bytes));
    }
    finishes(
        &s,
        upload(&s, archive_form(tar_gz(&entries), "myscene.tar.gz")),
    );

    // A .zip with scene.json at its root.
    let mut entries: Vec<(String, &[u8])> = vec![("scene.json".into(), scene.as_bytes())];
    for (rel, bytes) in &assets {
        entries.push((rel.to_string(), bytes));
    }
    finishes(&s, upload(&s, archive_form(zip(&entries), "scene.zip")));

    // Refused: a missing asset (422 with the scene's JSON path).
    let form = Form::new()
        .part("job", job_part())
        .part("scene", Part::text(scene.clone()));
    let (st, e) = upload(&s, form);
    assert_eq!(st, 422, "{e}");
    assert_eq!(e["error"]["code"], "invalid_scene");
    assert!(e["error"]["path"].is_string(), "{e}");

    // Refused: an asset part escaping the folder.
    let form = Form::new()
        .part("scene", Part::text(scene.clone()))
        .part("../escape.png", Part::bytes(vec![1, 2, 3]));
    let (st, e) = upload(&s, form);
    assert_eq!(st, 422, "{e}");
    assert!(!dir.join("escape.png").exists() && !dir.join("data/escape.png").exists());

    // Refused: archive entries escaping the folder (a zip written by hand, zip-slip style).
    let evil = zip(&[
        ("scene.json".into(), scene.as_bytes()),
        ("../../evil.txt".into(), b"x"),
    ]);
    let (st, e) = upload(&s, archive_form(evil, "evil.zip"));
    assert_eq!(st, 422, "{e}");
    assert_eq!(e["error"]["path"], "archive");
    assert!(
        e["error"]["message"].as_str().unwrap().contains("evil.txt"),
        "{e}"
    );
    assert!(!dir.join("evil.txt").exists() && !dir.join("data/evil.txt").exists());

    // Refused: no scene.json; not an archive; scene twice; job part with unknown fields.
    let (st, e) = upload(
        &s,
        archive_form(zip(&[("other.json".into(), b"{}")]), "x.zip"),
    );
    assert_eq!(
        (st, e["error"]["path"].as_str()),
        (422, Some("archive")),
        "{e}"
    );
    let (st, e) = upload(&s, archive_form(b"just some bytes".to_vec(), "x.tar"));
    assert_eq!(
        (st, e["error"]["path"].as_str()),
        (422, Some("archive")),
        "{e}"
    );
    let form = archive_form(zip(&[("scene.json".into(), scene.as_bytes())]), "x.zip")
        .part("scene", Part::text(scene.clone()));
    assert_eq!(upload(&s, form).0, 422);
    let form = Form::new()
        .part("job", Part::text(r#"{"spp": 2, "sppp": 3}"#))
        .part("scene", Part::text(scene.clone()));
    let (st, e) = upload(&s, form);
    assert_eq!(
        (st, e["error"]["path"].as_str()),
        (422, Some("sppp")),
        "{e}"
    );

    // Nothing was left behind in the upload area, and nothing was written outside data/.
    let tmp: Vec<_> = std::fs::read_dir(dir.join("data/tmp")).unwrap().collect();
    assert!(tmp.is_empty(), "{tmp:?}");
    let top: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(top, ["data"]);
}

/// The files of a test scene folder under tests/import/<dir>.
fn import_files(dir: &str, names: &[&str]) -> Vec<(String, Vec<u8>)> {
    let root = candela_tests::repo_root().join("tests/import").join(dir);
    names
        .iter()
        .map(|n| (n.to_string(), std::fs::read(root.join(n)).unwrap()))
        .collect()
}

#[test]
fn scenes_of_other_formats_are_imported_on_upload() {
    let dir = scratch("server_uploads_import");
    let s = Server::start(&dir.join("data"), &[]);

    // Mitsuba XML as the scene part (recognised by its file name), assets as parts.
    let files = import_files(
        "mitsuba",
        &[
            "lights.xml",
            "grad.png",
            "mask.png",
            "quad_uv.ply",
            "pyramid.serialized",
            "tile.obj",
        ],
    );
    let mut form = Form::new().part("job", job_part()).part(
        "scene",
        Part::bytes(files[0].1.clone()).file_name("lights.xml"),
    );
    for (name, bytes) in &files[1..] {
        form = form.part(
            name.clone(),
            Part::bytes(bytes.clone()).file_name(name.clone()),
        );
    }
    finishes(&s, upload(&s, form));

    // pbrt in a .tar.gz: scene.pbrt is chosen over more.pbrt, which it includes.
    let files = import_files(
        "pbrt",
        &["scene.pbrt", "more.pbrt", "grad.png", "quad_uv.ply"],
    );
    let entries: Vec<(String, &[u8])> = files
        .iter()
        .map(|(n, b)| (n.clone(), b.as_slice()))
        .collect();
    finishes(
        &s,
        upload(&s, archive_form(tar_gz(&entries), "pbrt.tar.gz")),
    );

    // .scn in a .zip (the only scene file at its root), glTF as a lone scene part.
    let files = import_files("scn", &["cornell.scn", "box.obj", "grad.png"]);
    let entries: Vec<(String, &[u8])> = files
        .iter()
        .map(|(n, b)| (n.clone(), b.as_slice()))
        .collect();
    finishes(&s, upload(&s, archive_form(zip(&entries), "scn.zip")));
    let gltf = import_files("gltf", &["scene.gltf"]);
    let form = Form::new().part("job", job_part()).part(
        "scene",
        Part::bytes(gltf[0].1.clone()).file_name("scene.gltf"),
    );
    finishes(&s, upload(&s, form));

    // Unsupported: refused with the file and line, or imported with warning events (lenient).
    let xml = "<scene version=\"3.0.0\">\n<shape type=\"sphere\">\n<bsdf type=\"hair\"/>\n</shape>\n</scene>\n";
    let form = Form::new()
        .part("job", job_part())
        .part("scene", Part::text(xml).file_name("hair.xml"));
    let (st, e) = upload(&s, form);
    assert_eq!(
        (st, e["error"]["code"].as_str()),
        (422, Some("invalid_scene")),
        "{e}"
    );
    let msg = e["error"]["message"].as_str().unwrap();
    assert!(
        msg.contains("hair.xml:3: bsdf \"hair\" is not supported"),
        "{e}"
    );
    let job = json!({"spp": 2, "width": 16, "height": 12, "lenient": true}).to_string();
    let form = Form::new()
        .part("job", Part::text(job))
        .part("scene", Part::text(xml).file_name("hair.xml"));
    let r = upload(&s, form);
    let id = r.1["id"].as_i64().unwrap_or_else(|| panic!("{}", r.1));
    finishes(&s, r);
    let events = s.events(id, None).collect_all();
    let warnings: Vec<&str> = events
        .iter()
        .filter(|e| e.event == "warning")
        .filter_map(|e| e.data["message"].as_str())
        .collect();
    assert!(
        warnings
            .iter()
            .any(|w| w.starts_with("hair.xml:3: bsdf \"hair\" is not supported")),
        "{warnings:?}"
    );

    // Ambiguous archives are refused.
    let two = zip(&[
        ("a.xml".into(), xml.as_bytes()),
        ("b.xml".into(), xml.as_bytes()),
    ]);
    let (st, e) = upload(&s, archive_form(two, "two.zip"));
    assert_eq!(
        (st, e["error"]["path"].as_str()),
        (422, Some("archive")),
        "{e}"
    );
    assert!(
        e["error"]["message"]
            .as_str()
            .unwrap()
            .contains("several scene files"),
        "{e}"
    );
}
