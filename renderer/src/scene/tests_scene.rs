//! Whole-scene tests: one valid scene using every feature (assets written to a temp folder), the
//! documented defaults, and the example scenes under `scenes/` (including `scenes/testdata/`).

use std::path::{Path, PathBuf};

use glam::{DVec3, Vec2, Vec3};
use serde_json::{json, Value};

use super::mesh::geometric_normal;
use super::paths::tests::temp_dir;
use super::texture::tests::write_png;
use super::*;

/// Writes the assets of the full scene into a fresh folder.
pub(super) fn write_assets() -> PathBuf {
    let dir = temp_dir("full");
    write_png(&dir.join("tex.png"));
    exr::prelude::write_rgba_file(dir.join("rough.exr"), 2, 2, |_, _| {
        (0.25f32, 0.0f32, 0.0f32, 1.0f32)
    })
    .unwrap();
    let env = image::Rgb32FImage::from_pixel(8, 4, image::Rgb([2.0f32, 1.0, 0.5]));
    image::DynamicImage::ImageRgb32F(env)
        .save(dir.join("sky.hdr"))
        .unwrap();
    std::fs::write(
        dir.join("model.obj"),
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nusemtl red\nf 1 2 3\nusemtl blue\nf 1 3 4\n",
    )
    .unwrap();
    std::fs::create_dir_all(dir.join("sub")).unwrap();
    std::fs::write(
        dir.join("sub/tri.ply"),
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
         element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
    )
    .unwrap();
    dir
}

/// A scene using every feature of docs/scene-format.md.
pub(super) fn full_scene() -> Value {
    json!({
        "version": 1,
        "camera": {"position": [0, 1, 5], "look_at": [0, 1, 1], "up": [0, 1, 0], "fov_y": 35,
                   "aperture_radius": 0.05},
        "film": {"width": 320, "height": 200, "filter": {"type": "gaussian", "stddev": 0.4},
                 "exposure": 1.5, "tonemap": "aces"},
        "materials": {
            "red": {"type": "diffuse", "reflectance": [0.8, 0.1, 0.1]},
            "blue": {"type": "diffuse", "reflectance": {"texture": "tex.png"},
                     "alpha_mask": {"texture": "tex.png"}},
            "metal": {"type": "conductor", "roughness": {"texture": "rough.exr", "scale": [2, 2]},
                      "anisotropy": 0.5, "eta": [0.2, 0.9, 1.1], "k": [3.9, 2.4, 2.2]},
            "glass": {"type": "dielectric", "ior": 1.33, "roughness": 0.1},
            "plastic": {"type": "principled", "base_color": 0.3, "metallic": 0.2, "clearcoat": 1},
            "shiny": {"type": "phong", "diffuse": [0.2, 0.2, 0.2], "specular": 0.5, "exponent": 100,
                      "two_sided": false},
            "lamp": {"type": "diffuse", "reflectance": 0, "emission": [10, 9, 8]}
        },
        "objects": [
            {"type": "mesh", "file": "model.obj"},
            {"type": "mesh", "file": "sub/tri.ply", "material": "metal", "smooth": false},
            {"type": "triangles", "material": "glass", "positions": [1, 0, 0, 0, 1, 0, 0, 0, 1],
             "indices": [0, 1, 2],
             "transform": {"scale": [2, 1, 1], "rotate": {"axis": [0, 0, 1], "angle": 90},
                           "translate": [10, 20, 30]}},
            {"type": "triangles", "material": "plastic", "positions": [[0, 0, 0], [1, 0, 0], [0, 1, 0]],
             "indices": [[0, 1, 2]], "normals": [[0, 0, 1], [0, 0, 1], [0, 0, 1]],
             "uvs": [[0, 0], [1, 0], [0, 1]]},
            {"type": "sphere", "material": "shiny", "center": [1, 0, 0], "radius": 0.5, "flip_normals": true,
             "transform": {"scale": 3, "rotate": {"axis": [0, 1, 0], "angle": 90}, "translate": [0, 1, 0]}},
            {"type": "quad", "material": "lamp", "origin": [-1, 3, -1], "edge_u": [2, 0, 0], "edge_v": [0, 0, 2]},
            {"type": "box", "material": "red", "min": [-1, 0, -1], "max": [1, 2, 1],
             "transform": {"matrix": [-1, 0, 0, 5,  0, 1, 0, 0,  0, 0, 1, 0,  0, 0, 0, 1]}}
        ],
        "lights": [
            {"type": "point", "position": [0, 5, 0], "intensity": [10, 10, 10]},
            {"type": "spot", "position": [0, 5, 0], "look_at": [0, 0, 0], "intensity": 50, "cutoff_angle": 30},
            {"type": "directional", "direction": [0, -3, 4], "irradiance": 2}
        ],
        "environment": {"type": "map", "file": "sky.hdr", "scale": 0.5, "rotate_y": 90},
        "render": {"integrator": "bdpt", "max_depth": 8, "spp": 64}
    })
}

pub(super) fn load_value(v: &Value, dir: Option<&Path>) -> Result<Scene, SceneError> {
    load_str(&v.to_string(), dir)
}

/// Index of a material by name.
pub(super) fn idx(s: &Scene, name: &str) -> usize {
    s.material_names.iter().position(|n| n == name).unwrap()
}

fn close(a: DVec3, b: DVec3) -> bool {
    (a - b).length() < 1e-9
}

#[test]
fn full_scene_loads_with_every_feature() {
    let dir = write_assets();
    let s = load_value(&full_scene(), Some(&dir)).unwrap();

    assert_eq!(s.camera.focus_distance, 4.0);
    assert_eq!(s.camera.aperture_radius, 0.05);
    assert_eq!((s.film.width, s.film.height), (320, 200));
    assert_eq!(s.film.filter, Filter::Gaussian { stddev: 0.4 });
    assert_eq!((s.film.exposure, s.film.tonemap), (1.5, Tonemap::Aces));

    // serde_json::Value sorts keys, so the document lists materials alphabetically.
    assert_eq!(
        s.material_names,
        ["blue", "glass", "lamp", "metal", "plastic", "red", "shiny"]
    );
    let m = |name: &str| idx(&s, name);
    // tex.png is shared by reflectance and alpha mask; rough.exr; sky.hdr.
    assert_eq!(s.textures.len(), 3);
    assert_eq!(
        s.materials[m("blue")].kind,
        MaterialKind::Diffuse {
            reflectance: ColorParam::Texture(0)
        }
    );
    assert_eq!(s.materials[m("blue")].alpha_mask, Some(0));
    let MaterialKind::Conductor {
        roughness,
        eta_k,
        anisotropy,
        ..
    } = &s.materials[m("metal")].kind
    else {
        panic!()
    };
    assert_eq!(
        (*roughness, *anisotropy),
        (ScalarParam::Texture(1), ScalarParam::Const(0.5))
    );
    assert_eq!(eta_k.unwrap().0, Vec3::new(0.2, 0.9, 1.1));
    assert_eq!(s.textures[1].scale, Vec2::new(2.0, 2.0));
    assert_eq!(
        s.textures[1].texels[0],
        [0.25, 0.0, 0.0, 1.0],
        "EXR is linear by default"
    );
    assert!(!s.materials[m("shiny")].two_sided);
    assert_eq!(s.materials[m("lamp")].emission, Vec3::new(10.0, 9.0, 8.0));

    // Objects: obj, ply, 2 × triangles, quad, box as meshes; one sphere.
    assert_eq!(s.meshes.len(), 6);
    let obj = &s.meshes[0];
    assert_eq!(obj.name, "objects[0] (model.obj)");
    assert_eq!(
        obj.materials,
        vec![m("red") as u32, m("blue") as u32],
        "usemtl red, then blue"
    );
    assert!(obj.normals.is_some(), "smooth by default: computed normals");
    assert!(s.meshes[1].normals.is_none(), "smooth: false");
    assert_eq!(s.meshes[1].materials, vec![m("metal") as u32]);
    // Scale (2,1,1), rotate 90° about z, translate: (1,0,0) → (2,0,0) → (0,2,0) → (10,22,30).
    let t = &s.meshes[2];
    assert!(
        close(t.positions[0], DVec3::new(10.0, 22.0, 30.0)),
        "{}",
        t.positions[0]
    );
    assert!(
        close(t.positions[1], DVec3::new(9.0, 20.0, 30.0)),
        "{}",
        t.positions[1]
    );
    assert!(
        close(t.positions[2], DVec3::new(10.0, 20.0, 31.0)),
        "{}",
        t.positions[2]
    );
    assert!(t.normals.is_none() && t.uvs.is_none());
    assert_eq!(s.meshes[3].normals.as_ref().unwrap()[0], Vec3::Z);
    assert_eq!(s.meshes[3].uvs.as_ref().unwrap()[1], Vec2::X);
    let quad = &s.meshes[4];
    for i in 0..2 {
        assert!(
            close(geometric_normal(quad, i), DVec3::new(0.0, -1.0, 0.0)),
            "edge_u × edge_v = -Y"
        );
    }
    // The box is mirrored in x and moved to x = 5; its normals must still point outward.
    let cube = &s.meshes[5];
    for i in 0..12 {
        let [a, b, c] = cube.indices[i].map(|k| cube.positions[k as usize]);
        let outward = (a + b + c) / 3.0 - DVec3::new(5.0, 1.0, 0.0);
        assert!(
            geometric_normal(cube, i).dot(outward) > 0.0,
            "box triangle {i} faces inward"
        );
    }
    let sphere = &s.spheres[0];
    // (1,0,0) × 3 → (3,0,0) → rotate 90° about y → (0,0,-3) → (0,1,-3).
    assert!(
        close(sphere.center, DVec3::new(0.0, 1.0, -3.0)),
        "{}",
        sphere.center
    );
    assert!((sphere.radius - 1.5).abs() < 1e-12);
    assert!(sphere.flip_normals);
    assert_eq!(sphere.material, m("shiny") as u32);

    assert_eq!(s.lights.len(), 3);
    let Light::Spot {
        direction,
        beam_width,
        cutoff_angle,
        intensity,
        ..
    } = &s.lights[1]
    else {
        panic!()
    };
    assert_eq!(
        (*direction, *cutoff_angle, *beam_width, *intensity),
        (DVec3::NEG_Y, 30.0, 22.5, Vec3::splat(50.0))
    );
    let Light::Directional { direction, .. } = &s.lights[2] else {
        panic!()
    };
    assert!(close(*direction, DVec3::new(0.0, -0.6, 0.8)));
    let Some(Environment::Map {
        texture,
        scale,
        rotate_y,
    }) = &s.environment
    else {
        panic!()
    };
    assert_eq!((*scale, *rotate_y), (0.5, 90.0));
    let sky = &s.textures[*texture as usize];
    assert_eq!(
        (sky.width, sky.height, sky.texels[5]),
        (8, 4, [2.0, 1.0, 0.5, 1.0])
    );
    assert_eq!(
        s.render,
        RenderDefaults {
            integrator: Some("bdpt".into()),
            max_depth: Some(8),
            spp: Some(64),
            ..Default::default()
        }
    );
}

#[test]
fn load_file_resolves_against_the_scene_folder() {
    let dir = write_assets();
    std::fs::write(dir.join("scene.json"), full_scene().to_string()).unwrap();
    let s = load_file(&dir.join("scene.json")).unwrap();
    assert_eq!(s.meshes.len(), 6);
    let e = load_file(&dir.join("nope.json")).unwrap_err();
    assert!(e.to_string().starts_with("cannot read scene file"), "{e}");
    assert_eq!(e.path(), None);
    // Text without a folder cannot refer to files.
    let e = load_value(&full_scene(), None).unwrap_err();
    assert_eq!(e.path(), Some("materials.blue.reflectance.texture"));
}

#[test]
fn example_scenes_load() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&root)
        .map(|d| d.filter_map(|e| e.ok().map(|e| e.path())).collect())
        .unwrap_or_default();
    files.extend(
        std::fs::read_dir(root.join("testdata"))
            .map(|d| {
                d.filter_map(|e| e.ok().map(|e| e.path()))
                    .collect::<Vec<_>>()
            })
            .unwrap_or_default(),
    );
    let scenes: Vec<&PathBuf> = files
        .iter()
        .filter(|f| f.extension().is_some_and(|e| e == "json"))
        .collect();
    assert!(!scenes.is_empty(), "no scenes under {}", root.display());
    for f in scenes {
        if let Err(e) = load_file(f) {
            panic!("{}: {e}", f.display());
        }
    }
}

#[test]
fn minimal_scene_gets_documented_defaults() {
    let s = load_str(
        r#"{"version": 1, "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0]}, "materials": {}, "objects": []}"#,
        None,
    )
    .unwrap();
    assert_eq!(
        (s.film.width, s.film.height, s.film.filter, s.film.tonemap),
        (512, 512, Filter::Box, Tonemap::Clamp)
    );
    assert_eq!(s.film.exposure, 0.0);
    assert_eq!(
        (
            s.camera.fov_y,
            s.camera.aperture_radius,
            s.camera.focus_distance
        ),
        (40.0, 0.0, 5.0)
    );
    assert!(s.environment.is_none() && s.lights.is_empty() && s.meshes.is_empty());
    assert_eq!(s.render, RenderDefaults::default());
}

#[test]
fn committed_test_scene_loads() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/testdata/meshes.json");
    let s = load_file(&path).unwrap();
    let (floor, tent) = (&s.meshes[0], &s.meshes[1]);
    assert_eq!(floor.indices.len(), 2);
    assert_eq!(floor.normals.as_ref().unwrap()[0], Vec3::Y);
    assert!(
        close(geometric_normal(floor, 0), DVec3::Y),
        "the floor faces up"
    );
    let (red, white) = (idx(&s, "red") as u32, idx(&s, "white") as u32);
    assert_eq!(tent.materials, vec![red, red, red, red, white, white]);
    // Every tent face points away from the tent's axis (x = z = 0 after the transform).
    for t in 0..tent.indices.len() {
        let [a, b, c] = tent.indices[t].map(|i| tent.positions[i as usize]);
        let centroid = (a + b + c) / 3.0;
        let n = geometric_normal(tent, t);
        assert!(
            n.dot(centroid - DVec3::new(0.0, 0.1, 0.0)) > 0.0,
            "tent face {t} points inward"
        );
    }
}
