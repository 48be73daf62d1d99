//! glTF importer tests without a GPU: one scene written three ways (.gltf with a data-URI
//! buffer and image, .gltf with an external .bin and .png, .glb with both in its binary chunk)
//! loads to exactly the scene its hand-written candela JSON equivalent loads to; unsupported
//! constructs are named with their JSON path.

use std::path::{Path, PathBuf};

use base64::Engine as _;
use serde_json::{json, Value};

use crate::import::test_util::assert_same_scene;
use crate::import::{import_file, load_file, ImportOptions};
use crate::scene::paths::tests::temp_dir;

fn grad_png() -> Vec<u8> {
    std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/import/mitsuba/grad.png"))
        .unwrap()
}

/// The test scene's geometry: a quad (4 vertices with normals and uvs) and a triangle strip.
struct Geometry {
    bin: Vec<u8>,
    views: Vec<(usize, usize)>,
}

const QUAD_P: [[f32; 3]; 4] = [
    [-1.0, 0.0, -1.0],
    [1.0, 0.0, -1.0],
    [1.0, 0.0, 1.0],
    [-1.0, 0.0, 1.0],
];
const QUAD_UV: [[f32; 2]; 4] = [[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]];
const QUAD_I: [u16; 6] = [0, 2, 1, 0, 3, 2];
const STRIP_P: [[f32; 3]; 4] = [
    [0.0, 0.5, 0.0],
    [0.5, 0.5, 0.0],
    [0.0, 1.0, 0.25],
    [0.5, 1.0, 0.25],
];
/// A node matrix (column-major) of f32-exact numbers: rotation about y by 90°, scale 2, offset.
const NODE: [f32; 16] = [
    0.0, 0.0, -2.0, 0.0, 0.0, 2.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0.5, 0.25, -1.0, 1.0,
];

fn geometry() -> Geometry {
    let mut bin = Vec::new();
    let mut views = Vec::new();
    let mut push = |bytes: Vec<u8>, bin: &mut Vec<u8>| {
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        views.push((bin.len(), bytes.len()));
        bin.extend(bytes);
    };
    let f = |v: &[f32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    push(f(&QUAD_P.concat()), &mut bin);
    push(f(&[[0.0f32, 1.0, 0.0]; 4].concat()), &mut bin);
    push(f(&QUAD_UV.concat()), &mut bin);
    push(
        QUAD_I.iter().flat_map(|x| x.to_le_bytes()).collect(),
        &mut bin,
    );
    push(f(&STRIP_P.concat()), &mut bin);
    let png = grad_png();
    push(png, &mut bin);
    Geometry { bin, views }
}

/// The glTF JSON; `buffer_uri` None: the .glb chunk; `image` how the image is given.
fn gltf_json(g: &Geometry, buffer_uri: Option<String>, image: Value) -> Value {
    let views: Vec<Value> = g
        .views
        .iter()
        .map(|(o, l)| json!({"buffer": 0, "byteOffset": o, "byteLength": l}))
        .collect();
    let mut buffer = json!({"byteLength": g.bin.len()});
    if let Some(u) = buffer_uri {
        buffer["uri"] = json!(u);
    }
    json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_emissive_strength"],
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2, 3]}],
        "nodes": [
            {"mesh": 0, "matrix": NODE},
            {"mesh": 0, "translation": [0.0, -1.0, 0.0]},
            {"camera": 0, "translation": [0.0, 1.0, 5.0]},
            {"extensions": {"KHR_lights_punctual": {"light": 0}}, "translation": [0.0, 4.0, 0.0]}
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.5, "aspectRatio": 1.5, "znear": 0.1}}],
        "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point", "color": [1.0, 0.5, 0.25], "intensity": 683.0}]}},
        "meshes": [{"name": "thing", "primitives": [
            {"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3, "material": 0},
            {"attributes": {"POSITION": 4}, "mode": 5, "material": 1}
        ]}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-1.0, 0.0, -1.0], "max": [1.0, 0.0, 1.0]},
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"},
            {"bufferView": 3, "componentType": 5123, "count": 6, "type": "SCALAR"},
            {"bufferView": 4, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0.0, 0.5, 0.0], "max": [0.5, 1.0, 0.25]}
        ],
        "materials": [
            {"name": "floor", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0.0, "roughnessFactor": 0.75}},
            {"name": "glow", "doubleSided": true, "pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.4, 0.6, 1.0], "metallicRoughnessTexture": {"index": 0}},
             "emissiveFactor": [1.0, 0.5, 0.0], "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4.0}}}
        ],
        "textures": [{"source": 0}],
        "images": [image],
        "buffers": [buffer],
        "bufferViews": views
    })
}

/// Writes the three forms into a fresh folder; returns their paths.
fn write_forms() -> (PathBuf, [PathBuf; 3]) {
    let dir = temp_dir("gltf");
    let g = geometry();
    let b64 = base64::engine::general_purpose::STANDARD;
    // .gltf, everything embedded as data URIs.
    let embedded = gltf_json(
        &g,
        Some(format!(
            "data:application/octet-stream;base64,{}",
            b64.encode(&g.bin)
        )),
        json!({"uri": format!("data:image/png;base64,{}", b64.encode(grad_png()))}),
    );
    std::fs::write(dir.join("embedded.gltf"), embedded.to_string()).unwrap();
    // .gltf with its files beside it (the image name percent-encoded).
    std::fs::create_dir_all(dir.join("tex")).unwrap();
    std::fs::write(dir.join("tex/my grad.png"), grad_png()).unwrap();
    std::fs::write(dir.join("scene.bin"), &g.bin).unwrap();
    let external = gltf_json(
        &g,
        Some("scene.bin".into()),
        json!({"uri": "tex/my%20grad.png"}),
    );
    std::fs::write(dir.join("external.gltf"), external.to_string()).unwrap();
    // .glb: JSON chunk + BIN chunk, the image in a buffer view.
    let glb_json = gltf_json(&g, None, json!({"bufferView": 5, "mimeType": "image/png"}));
    let mut j = glb_json.to_string().into_bytes();
    while !j.len().is_multiple_of(4) {
        j.push(b' ');
    }
    let mut bin = g.bin.clone();
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let mut glb = Vec::new();
    glb.extend(b"glTF");
    glb.extend(2u32.to_le_bytes());
    glb.extend(((12 + 8 + j.len() + 8 + bin.len()) as u32).to_le_bytes());
    glb.extend((j.len() as u32).to_le_bytes());
    glb.extend(b"JSON");
    glb.extend(&j);
    glb.extend((bin.len() as u32).to_le_bytes());
    glb.extend(b"BIN\0");
    glb.extend(&bin);
    std::fs::write(dir.join("binary.glb"), glb).unwrap();
    (
        dir.clone(),
        [
            dir.join("embedded.gltf"),
            dir.join("external.gltf"),
            dir.join("binary.glb"),
        ],
    )
}

/// The candela JSON scene the glTF means (docs/import.md's mapping, written by hand).
pub(crate) fn equivalent_json(dir: &Path) -> PathBuf {
    std::fs::write(dir.join("grad.png"), grad_png()).unwrap();
    let node: Vec<f64> = (0..16).map(|i| NODE[(i % 4) * 4 + i / 4] as f64).collect();
    let quad = |t: Value| {
        json!({"type": "triangles", "positions": QUAD_P, "normals": [[0, 1, 0], [0, 1, 0], [0, 1, 0], [0, 1, 0]],
        "uvs": QUAD_UV.iter().map(|[u, v]| [*u as f64, 1.0 - *v as f64]).collect::<Vec<_>>(),
        "indices": QUAD_I, "material": "floor", "transform": t})
    };
    let strip = |t: Value| json!({"type": "triangles", "positions": STRIP_P, "indices": [0, 1, 2, 2, 1, 3], "material": "glow", "transform": t});
    let lift = json!({"translate": [0, -1, 0]});
    let scene = json!({
        "version": 1,
        "camera": {"position": [0, 1, 5], "look_at": [0, 1, 4], "up": [0, 1, 0], "fov_y": 0.5f32 as f64 * 180.0 / std::f64::consts::PI},
        "film": {"width": 768, "height": 512},
        "materials": {
            "floor": {"type": "principled", "base_color": {"texture": "grad.png"}, "metallic": 0.0, "roughness": 0.75, "two_sided": false},
            "glow": {"type": "principled", "base_color": [0.2f32 as f64, 0.4f32 as f64, 0.6f32 as f64],
                     "metallic": {"texture": "grad.png", "srgb": false, "channel": "b"},
                     "roughness": {"texture": "grad.png", "srgb": false, "channel": "g"},
                     "emission": [4.0, 2.0, 0.0]}
        },
        "objects": [quad(json!({"matrix": node})), strip(json!({"matrix": node})), quad(lift.clone()), strip(lift)],
        "lights": [{"type": "point", "position": [0, 4, 0], "intensity": [1.0, 0.5, 0.25]}]
    });
    let path = dir.join("equivalent.json");
    std::fs::write(&path, serde_json::to_string_pretty(&scene).unwrap()).unwrap();
    path
}

#[test]
fn every_form_loads_to_the_equivalent_json_scene() {
    let (dir, forms) = write_forms();
    let reference = crate::scene::load_file(&equivalent_json(&dir)).unwrap();
    for path in forms {
        let loaded = load_file(&path, &ImportOptions::default())
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
        assert_same_scene(&loaded.scene, &reference);
    }
}

#[test]
fn factors_and_masks_become_derived_textures() {
    let (dir, _) = write_forms();
    let mut j: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("external.gltf")).unwrap()).unwrap();
    j["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"] = json!([0.5, 1.0, 1.0, 0.8]);
    j["materials"][0]["alphaMode"] = json!("MASK");
    j["materials"][0]["alphaCutoff"] = json!(0.3);
    std::fs::write(dir.join("factors.gltf"), j.to_string()).unwrap();
    let imp = import_file(&dir.join("factors.gltf"), &ImportOptions::default()).unwrap();
    let floor = &imp.doc["materials"]["floor"];
    assert!(floor["base_color"]["texture"]
        .as_str()
        .unwrap()
        .starts_with("_imported/"));
    assert!(floor["alpha_mask"]["texture"]
        .as_str()
        .unwrap()
        .starts_with("_imported/"));
    let scene = imp.load(&Default::default()).unwrap();
    let plain = crate::scene::texture::decode_file(
        crate::scene::paths::AssetRoot::dir(Some(&dir)),
        "tex/my grad.png",
        None,
        &Default::default(),
        "t",
    )
    .unwrap();
    let crate::scene::MaterialKind::Principled {
        base_color: crate::scene::ColorParam::Texture(t),
        ..
    } = scene.materials[0].kind
    else {
        panic!()
    };
    let derived = &scene.textures[t as usize];
    assert!((derived.texels[7][0] - 0.5 * plain.2[7][0]).abs() < 1e-6);
    assert_eq!(derived.texels[7][1], plain.2[7][1]);
}

/// An edit of a glTF document.
type Edit = Box<dyn Fn(&mut Value)>;

#[test]
fn unsupported_constructs_are_named_with_their_json_path() {
    let (dir, _) = write_forms();
    let base: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("external.gltf")).unwrap()).unwrap();
    let cases: Vec<(&str, Edit)> = vec![
        (
            "materials[0].normalTexture: normal maps",
            Box::new(|j| j["materials"][0]["normalTexture"] = json!({"index": 0})),
        ),
        (
            "materials[1].alphaMode: alphaMode BLEND",
            Box::new(|j| j["materials"][1]["alphaMode"] = json!("BLEND")),
        ),
        (
            "materials[1].emissiveTexture: an emissive texture",
            Box::new(|j| j["materials"][1]["emissiveTexture"] = json!({"index": 0})),
        ),
        (
            "texture coordinate set 1",
            Box::new(|j| {
                j["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["texCoord"] = json!(1)
            }),
        ),
        (
            "samplers[0]: clamped or mirrored",
            Box::new(|j| {
                j["samplers"] = json!([{"wrapS": 33071}]);
                j["textures"][0]["sampler"] = json!(0);
            }),
        ),
        (
            "extensionsRequired[0]: extension KHR_draco_mesh_compression is required",
            Box::new(|j| {
                j["extensionsRequired"] = json!(["KHR_draco_mesh_compression"]);
                j["extensionsUsed"] = json!(["KHR_draco_mesh_compression"]);
            }),
        ),
        (
            "cameras[0]: an orthographic camera",
            Box::new(
                |j| j["cameras"][0] = json!({"type": "orthographic", "orthographic": {"xmag": 1, "ymag": 1, "znear": 0.1, "zfar": 10}}),
            ),
        ),
        (
            "meshes[0].primitives[1]: primitive mode Lines",
            Box::new(|j| j["meshes"][0]["primitives"][1]["mode"] = json!(1)),
        ),
    ];
    for (needle, edit) in cases {
        let mut j = base.clone();
        edit(&mut j);
        std::fs::write(dir.join("case.gltf"), j.to_string()).unwrap();
        let strict = ImportOptions::default();
        let e = import_file(&dir.join("case.gltf"), &strict)
            .err()
            .unwrap_or_else(|| panic!("accepted: {needle}"))
            .to_string();
        assert!(
            e.contains("case.gltf: ") && e.contains(needle) && e.contains("--lenient"),
            "{needle:?} not in: {e}"
        );
        let lenient = ImportOptions {
            lenient: true,
            ..Default::default()
        };
        let loaded = load_file(&dir.join("case.gltf"), &lenient)
            .unwrap_or_else(|e| panic!("lenient {needle}: {e}"));
        assert!(!loaded.warnings.is_empty());
    }
    // Malformed: errors even under --lenient.
    for (needle, edit) in [
        (
            "invalid glTF",
            Box::new(|j: &mut Value| j["meshes"][0]["primitives"][0]["indices"] = json!(42))
                as Edit,
        ),
        (
            "fewer than its byteLength",
            Box::new(|j: &mut Value| j["buffers"][0]["byteLength"] = json!(1 << 20)),
        ),
        (
            "leaves the scene folder",
            Box::new(|j: &mut Value| j["buffers"][0]["uri"] = json!("../scene.bin")),
        ),
        (
            "only files beside the glTF",
            Box::new(|j: &mut Value| j["buffers"][0]["uri"] = json!("https://example.com/a.bin")),
        ),
    ] {
        let mut j = base.clone();
        edit(&mut j);
        std::fs::write(dir.join("bad.gltf"), j.to_string()).unwrap();
        let lenient = ImportOptions {
            lenient: true,
            ..Default::default()
        };
        let e = import_file(&dir.join("bad.gltf"), &lenient)
            .err()
            .unwrap_or_else(|| panic!("accepted: {needle}"))
            .to_string();
        assert!(e.contains(needle), "{needle:?} not in: {e}");
    }
    std::fs::write(
        dir.join("syntax.gltf"),
        "{\n\"asset\": {\"version\": \"2.0\"},\n\"nodes\": [}",
    )
    .unwrap();
    let e = import_file(&dir.join("syntax.gltf"), &ImportOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("syntax.gltf:3: glTF JSON error"), "{e}");
}

#[test]
fn without_a_camera_one_frames_the_scene() {
    let (dir, _) = write_forms();
    let mut j: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("external.gltf")).unwrap()).unwrap();
    j["scenes"][0]["nodes"] = json!([0, 3]);
    std::fs::write(dir.join("nocam.gltf"), j.to_string()).unwrap();
    let loaded = load_file(&dir.join("nocam.gltf"), &ImportOptions::default()).unwrap();
    assert!(loaded.warnings[0].msg.contains("no camera"));
    assert!(loaded.scene.camera.position.z > 0.0);
}

#[test]
fn the_committed_example_loads_to_its_json_equivalent() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/import/gltf");
    let loaded = load_file(&dir.join("scene.gltf"), &ImportOptions::default()).unwrap();
    let reference = crate::scene::load_file(&dir.join("scene.json")).unwrap();
    assert_same_scene(&loaded.scene, &reference);
}

#[test]
fn a_mesh_under_several_nodes_is_defined_once() {
    // The example's mesh (two primitives) sits under two nodes: each primitive is one
    // definition, placed by one `instance` object per node.
    let (dir, _) = write_forms();
    let imp = import_file(&dir.join("external.gltf"), &ImportOptions::default()).unwrap();
    let defs = imp.doc["definitions"].as_object().unwrap();
    assert_eq!(defs.len(), 2, "{defs:?}");
    let objects = imp.doc["objects"].as_array().unwrap();
    assert_eq!(objects.len(), 4);
    assert!(objects.iter().all(|o| o["type"] == "instance"));
    let scene = imp.load(&Default::default()).unwrap();
    assert_eq!(
        (
            scene.prototypes.len(),
            scene.instances.len(),
            scene.meshes.len()
        ),
        (2, 4, 0)
    );
    // Under one node, the mesh is written in place: no definitions.
    let mut j: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("external.gltf")).unwrap()).unwrap();
    j["scenes"][0]["nodes"] = json!([0, 2, 3]);
    j["nodes"][1] = json!({"translation": [0.0, -1.0, 0.0]});
    std::fs::write(dir.join("single.gltf"), j.to_string()).unwrap();
    let imp = import_file(&dir.join("single.gltf"), &ImportOptions::default()).unwrap();
    assert!(imp.doc.get("definitions").is_none());
    let objects = imp.doc["objects"].as_array().unwrap();
    assert_eq!(objects.len(), 2);
    assert!(objects.iter().all(|o| o["type"] == "mesh"), "{objects:?}");
}
