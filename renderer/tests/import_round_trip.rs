//! candela JSON → Mitsuba 3 XML (`export`) → candela JSON (the Mitsuba importer) keeps the
//! scene: the loaded scenes agree field by field (floats to rounding; materials by content, since
//! an emissive material comes back under `<name>_emitter`). What the round trip does not keep,
//! by design (docs/import.md): film exposure and tonemap, `render.integrator` and accel settings
//! (Mitsuba has no such fields), a camera's `look_at` distance (only its direction), and an
//! environment map's texels (resampled to Mitsuba's row convention; size and placement kept).
//! No GPU.

use std::path::{Path, PathBuf};

use glam::DVec3;
use renderer::import::mitsuba::export::write_xml;
use renderer::import::{import_file, ImportOptions};
use renderer::scene::{
    ColorParam, Environment, Material, MaterialKind, ScalarParam, Scene, Texture,
};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// A fresh folder under target/.
fn scratch(name: &str) -> PathBuf {
    let d = repo().join("target/test-scratch").join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Exports `json` to XML beside it (in `dir`), imports the XML; returns (original, round trip).
fn round_trip(json: &Path, dir: &Path) -> (Scene, Scene) {
    let opts = ImportOptions::default();
    let imp = import_file(json, &opts).unwrap();
    let original = imp.load(&opts.limits).unwrap();
    let xml = dir.join("scene.xml");
    write_xml(&imp, &xml).unwrap_or_else(|e| panic!("{}: {e}", json.display()));
    let back = import_file(&xml, &opts).unwrap_or_else(|e| panic!("{}: {e}", xml.display()));
    let scene = back
        .load(&opts.limits)
        .unwrap_or_else(|e| panic!("{e}\n{}", back.json_text()));
    (original, scene)
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * (1.0 + a.abs().max(b.abs()))
}

fn close3(a: DVec3, b: DVec3, tol: f64) -> bool {
    (0..3).all(|i| close(a[i], b[i], tol))
}

fn same_texture(a: &Texture, b: &Texture, what: &str) {
    assert_eq!(
        (a.width, a.height, a.scale),
        (b.width, b.height, b.scale),
        "{what}"
    );
    for (x, y) in a.texels.iter().zip(b.texels.iter()) {
        for c in 0..3 {
            assert!((x[c] - y[c]).abs() < 2e-5, "{what}: texel {x:?} vs {y:?}");
        }
    }
}

struct Pair<'a> {
    a: &'a Scene,
    b: &'a Scene,
}

impl Pair<'_> {
    fn color(&self, x: &ColorParam, y: &ColorParam, what: &str) {
        match (x, y) {
            (ColorParam::Const(p), ColorParam::Const(q)) => {
                assert!((*p - *q).abs().max_element() < 1e-6, "{what}: {p} vs {q}")
            }
            (ColorParam::Texture(i), ColorParam::Texture(j)) => same_texture(
                &self.a.textures[*i as usize],
                &self.b.textures[*j as usize],
                what,
            ),
            _ => panic!("{what}: {x:?} vs {y:?}"),
        }
    }

    fn scalar(&self, x: &ScalarParam, y: &ScalarParam, what: &str) {
        match (x, y) {
            (ScalarParam::Const(p), ScalarParam::Const(q)) => {
                assert!((p - q).abs() < 1e-6, "{what}: {p} vs {q}")
            }
            (ScalarParam::Texture(i), ScalarParam::Texture(j)) => {
                let (s, t) = (&self.a.textures[*i as usize], &self.b.textures[*j as usize]);
                assert_eq!(
                    (s.width, s.height, s.scale),
                    (t.width, t.height, t.scale),
                    "{what}"
                );
                for (p, q) in s.texels.iter().zip(t.texels.iter()) {
                    assert!(
                        (p[0] - q[0]).abs() < 2e-5,
                        "{what}: red {} vs {}",
                        p[0],
                        q[0]
                    );
                }
            }
            _ => panic!("{what}: {x:?} vs {y:?}"),
        }
    }

    fn material(&self, x: &Material, y: &Material, what: &str) {
        assert_eq!(x.two_sided, y.two_sided, "{what}.two_sided");
        assert!(
            (x.emission - y.emission).abs().max_element() < 1e-6,
            "{what}.emission"
        );
        match (&x.alpha_mask, &y.alpha_mask) {
            (None, None) => {}
            (Some(i), Some(j)) => {
                let (s, t) = (&self.a.textures[*i as usize], &self.b.textures[*j as usize]);
                for (p, q) in s.texels.iter().zip(t.texels.iter()) {
                    assert_eq!(p[0] < 0.5, q[0] < 0.5, "{what}.alpha_mask");
                }
            }
            _ => panic!("{what}.alpha_mask"),
        }
        use MaterialKind as K;
        match (&x.kind, &y.kind) {
            (K::Diffuse { reflectance: p }, K::Diffuse { reflectance: q }) => {
                self.color(p, q, what)
            }
            (
                K::Conductor {
                    reflectance: r1,
                    roughness: g1,
                    anisotropy: a1,
                    eta_k: e1,
                },
                K::Conductor {
                    reflectance: r2,
                    roughness: g2,
                    anisotropy: a2,
                    eta_k: e2,
                },
            ) => {
                self.color(r1, r2, what);
                self.scalar(g1, g2, what);
                self.scalar(a1, a2, what);
                match (e1, e2) {
                    (None, None) => {}
                    (Some((e, k)), Some((f, l))) => {
                        assert!(
                            (*e - *f).abs().max_element() < 1e-6
                                && (*k - *l).abs().max_element() < 1e-6,
                            "{what}.eta/k"
                        )
                    }
                    _ => panic!("{what}.eta_k"),
                }
            }
            (
                K::Dielectric {
                    ior: i1,
                    roughness: g1,
                    transmittance: t1,
                    reflectance: r1,
                },
                K::Dielectric {
                    ior: i2,
                    roughness: g2,
                    transmittance: t2,
                    reflectance: r2,
                },
            ) => {
                assert!((i1 - i2).abs() < 1e-6, "{what}.ior");
                self.scalar(g1, g2, what);
                self.color(t1, t2, what);
                self.color(r1, r2, what);
            }
            (K::Principled { .. }, K::Principled { .. }) => {
                let (
                    K::Principled {
                        base_color: c1,
                        metallic: m1,
                        roughness: g1,
                        specular: s1,
                        spec_tint: st1,
                        anisotropic: a1,
                        sheen: sh1,
                        sheen_tint: sht1,
                        spec_trans: tr1,
                        ior: i1,
                        subsurface: ss1,
                        clearcoat: cc1,
                        clearcoat_gloss: cg1,
                    },
                    K::Principled {
                        base_color: c2,
                        metallic: m2,
                        roughness: g2,
                        specular: s2,
                        spec_tint: st2,
                        anisotropic: a2,
                        sheen: sh2,
                        sheen_tint: sht2,
                        spec_trans: tr2,
                        ior: i2,
                        subsurface: ss2,
                        clearcoat: cc2,
                        clearcoat_gloss: cg2,
                    },
                ) = (&x.kind, &y.kind)
                else {
                    unreachable!()
                };
                self.color(c1, c2, what);
                for (p, q) in [
                    (m1, m2),
                    (g1, g2),
                    (s1, s2),
                    (st1, st2),
                    (a1, a2),
                    (sh1, sh2),
                    (sht1, sht2),
                    (tr1, tr2),
                    (ss1, ss2),
                    (cc1, cc2),
                    (cg1, cg2),
                ] {
                    self.scalar(p, q, what);
                }
                match (i1, i2) {
                    (None, None) => {}
                    (Some(p), Some(q)) => assert!((p - q).abs() < 1e-6, "{what}.ior"),
                    _ => panic!("{what}.ior {i1:?} vs {i2:?}"),
                }
            }
            _ => panic!("{what}: {:?} vs {:?}", x.kind, y.kind),
        }
    }

    fn check(&self) {
        let (a, b) = (self.a, self.b);
        // Camera: the same eye, view direction, right vector and lens.
        let (ca, cb) = (&a.camera, &b.camera);
        assert!(close3(ca.position, cb.position, 1e-9));
        let dir = |c: &renderer::scene::Camera| (c.look_at - c.position).normalize();
        assert!(close3(dir(ca), dir(cb), 1e-9));
        assert!(close3(
            dir(ca).cross(ca.up).normalize(),
            dir(cb).cross(cb.up).normalize(),
            1e-9
        ));
        assert!(close(ca.fov_y, cb.fov_y, 1e-9));
        assert!(close(ca.aperture_radius, cb.aperture_radius, 1e-12));
        if ca.aperture_radius > 0.0 {
            assert!(close(ca.focus_distance, cb.focus_distance, 1e-9));
        }
        assert_eq!(
            (a.film.width, a.film.height, a.film.filter),
            (b.film.width, b.film.height, b.film.filter)
        );
        assert_eq!(
            (a.render.max_depth, a.render.spp),
            (b.render.max_depth, b.render.spp)
        );
        // Geometry, in order, with the material of every triangle by content.
        assert_eq!(a.meshes.len(), b.meshes.len());
        for (i, (m, n)) in a.meshes.iter().zip(&b.meshes).enumerate() {
            assert_eq!(m.indices, n.indices, "mesh {i} ({})", m.name);
            for (p, q) in m.positions.iter().zip(&n.positions) {
                assert!(close3(*p, *q, 1e-6), "mesh {i}: {p} vs {q}");
            }
            match (&m.normals, &n.normals) {
                (None, None) => {}
                (Some(x), Some(y)) => assert!(
                    x.iter()
                        .zip(y)
                        .all(|(p, q)| (*p - *q).abs().max_element() < 1e-5),
                    "mesh {i} normals"
                ),
                _ => panic!(
                    "mesh {i} ({}): normals {} vs {}",
                    m.name,
                    m.normals.is_some(),
                    n.normals.is_some()
                ),
            }
            let textured = |s: &Scene, mat: u32| {
                format!("{:?}", s.materials[mat as usize]).contains("Texture(")
            };
            if textured(a, m.materials[0])
                || m.materials
                    .iter()
                    .any(|&t| a.materials[t as usize].alpha_mask.is_some())
            {
                let (x, y) = (m.uvs.as_ref().unwrap(), n.uvs.as_ref().unwrap());
                assert!(
                    x.iter()
                        .zip(y)
                        .all(|(p, q)| (*p - *q).abs().max_element() < 1e-6),
                    "mesh {i} uvs"
                );
            }
            let mut seen = std::collections::HashSet::new();
            for (t, (&p, &q)) in m.materials.iter().zip(&n.materials).enumerate() {
                if seen.insert((p, q)) {
                    self.material(
                        &a.materials[p as usize],
                        &b.materials[q as usize],
                        &format!(
                            "mesh {i} triangle {t} material {}",
                            a.material_names[p as usize]
                        ),
                    );
                }
            }
        }
        assert_eq!(a.spheres.len(), b.spheres.len());
        for (s, t) in a.spheres.iter().zip(&b.spheres) {
            assert!(close3(s.center, t.center, 1e-9) && close(s.radius, t.radius, 1e-9));
            assert_eq!(s.flip_normals, t.flip_normals);
            self.material(
                &a.materials[s.material as usize],
                &b.materials[t.material as usize],
                "sphere",
            );
        }
        assert_eq!(a.lights.len(), b.lights.len());
        for (l, m) in a.lights.iter().zip(&b.lights) {
            let (p, q) = (format!("{l:?}"), format!("{m:?}"));
            assert_eq!(
                std::mem::discriminant(l),
                std::mem::discriminant(m),
                "{p} vs {q}"
            );
            use renderer::scene::Light as L;
            match (l, m) {
                (
                    L::Point {
                        position: p1,
                        intensity: i1,
                    },
                    L::Point {
                        position: p2,
                        intensity: i2,
                    },
                ) => {
                    assert!(
                        close3(*p1, *p2, 1e-9) && (*i1 - *i2).abs().max_element() < 1e-6,
                        "{p} vs {q}"
                    )
                }
                (
                    L::Spot {
                        position: p1,
                        direction: d1,
                        intensity: i1,
                        cutoff_angle: c1,
                        beam_width: b1,
                    },
                    L::Spot {
                        position: p2,
                        direction: d2,
                        intensity: i2,
                        cutoff_angle: c2,
                        beam_width: b2,
                    },
                ) => {
                    assert!(
                        close3(*p1, *p2, 1e-9)
                            && close3(*d1, *d2, 1e-9)
                            && (*i1 - *i2).abs().max_element() < 1e-6,
                        "{p} vs {q}"
                    );
                    assert!(
                        (c1 - c2).abs() < 1e-5 && (b1 - b2).abs() < 1e-5,
                        "{p} vs {q}"
                    );
                }
                (
                    L::Directional {
                        direction: d1,
                        irradiance: i1,
                    },
                    L::Directional {
                        direction: d2,
                        irradiance: i2,
                    },
                ) => {
                    assert!(
                        close3(*d1, *d2, 1e-9) && (*i1 - *i2).abs().max_element() < 1e-6,
                        "{p} vs {q}"
                    )
                }
                _ => unreachable!(),
            }
        }
        match (&a.environment, &b.environment) {
            (None, None) => {}
            (
                Some(Environment::Constant { radiance: r }),
                Some(Environment::Constant { radiance: s }),
            ) => {
                assert!((*r - *s).abs().max_element() < 1e-6)
            }
            (
                Some(Environment::Map {
                    texture: t,
                    scale: s,
                    rotate_y: r,
                }),
                Some(Environment::Map {
                    texture: u,
                    scale: v,
                    rotate_y: w,
                }),
            ) => {
                assert!(
                    (s - v).abs() < 1e-6
                        && ((r - w + 540.0).rem_euclid(360.0) - 180.0).abs() < 1e-3,
                    "env {s} {r} vs {v} {w}"
                );
                let (t, u) = (&a.textures[*t as usize], &b.textures[*u as usize]);
                assert_eq!(
                    (t.width, 2 * t.height + 1),
                    (u.width, u.height),
                    "resampled to Mitsuba's rows"
                );
            }
            (x, y) => panic!("environment {x:?} vs {y:?}"),
        }
    }
}

#[test]
fn repository_scenes_survive_json_to_xml_to_json() {
    for name in [
        "cornell",
        "lights",
        "furnace",
        "envmap",
        "textured_mesh",
        "thinlens",
        "mirror_glass",
    ] {
        let dir = scratch(&format!("round_trip_{name}"));
        let (a, b) = round_trip(&repo().join(format!("scenes/{name}.json")), &dir);
        Pair { a: &a, b: &b }.check();
        println!(
            "{name}: round trip kept the scene ({} meshes, {} spheres, {} materials)",
            a.meshes.len(),
            a.spheres.len(),
            a.materials.len()
        );
    }
}

#[test]
fn textures_channels_masks_and_inline_meshes_survive_the_round_trip() {
    let dir = scratch("round_trip_features");
    let src = repo().join("tests/import/mitsuba");
    for f in ["grad.png", "mask.png", "quad_uv.ply"] {
        std::fs::copy(src.join(f), dir.join(f)).unwrap();
    }
    let scene = serde_json::json!({
        "version": 1,
        "camera": {"position": [0, 1, 5], "look_at": [0, 0.5, 0], "up": [0.1, 1, 0], "fov_y": 35, "aperture_radius": 0.05, "focus_distance": 4.5},
        "film": {"width": 40, "height": 30, "filter": "box"},
        "materials": {
            "tex": {"type": "diffuse", "reflectance": {"texture": "grad.png", "scale": [0.5, 1.3]}, "two_sided": false},
            "rough": {"type": "conductor", "roughness": {"texture": "grad.png", "channel": "g"}, "eta": [0.2, 0.9, 1.1], "k": [3.9, 2.4, 2.1]},
            "aniso": {"type": "conductor", "roughness": 0.4, "anisotropy": 0.5, "reflectance": [0.9, 0.8, 0.7]},
            "glass": {"type": "dielectric", "ior": 1.33, "roughness": 0.2, "transmittance": [0.9, 1, 0.9]},
            "disney": {"type": "principled", "base_color": {"texture": "grad.png", "srgb": false}, "metallic": {"texture": "grad.png"}, "specular": 0.3, "sheen": 0.2, "clearcoat": 0.5, "clearcoat_gloss": 0.7},
            "trans": {"type": "principled", "spec_trans": 0.8, "ior": 1.45, "roughness": 0.1},
            "cut": {"type": "diffuse", "alpha_mask": {"texture": "mask.png"}},
            "lamp": {"type": "diffuse", "reflectance": 0, "emission": [5, 4, 3]}
        },
        "objects": [
            {"type": "quad", "origin": [-2, 0, 2], "edge_u": [4, 0, 0], "edge_v": [0, 0, -4], "material": "tex"},
            {"type": "box", "min": [-0.5, 0, -0.5], "max": [0.5, 1, 0.5], "material": "disney", "transform": {"rotate": {"axis": [0, 1, 0], "angle": 30}, "translate": [1, 0, 0]}},
            {"type": "triangles", "positions": [[0, 0, 0], [1, 0, 0], [0, 1, 0]], "indices": [0, 1, 2], "uvs": [[0, 0], [1, 0], [0, 1]], "material": "tex", "transform": {"scale": [1, 2, 1]}},
            {"type": "triangles", "positions": [0, 0, 1, 1, 0, 1, 0, 1, 1], "indices": [0, 1, 2], "normals": [[0, 0, 1], [0, 0.1, 1], [0.1, 0, 1]], "material": "glass"},
            {"type": "mesh", "file": "quad_uv.ply", "material": "rough", "transform": {"translate": [0, 1, -1]}},
            {"type": "mesh", "file": "quad_uv.ply", "material": "cut", "smooth": false, "transform": {"translate": [2, 1, -1]}},
            {"type": "sphere", "center": [-1, 0.5, 0], "radius": 0.5, "material": "aniso"},
            {"type": "sphere", "center": [0, 2, 0], "radius": 0.3, "material": "trans", "flip_normals": true},
            {"type": "quad", "origin": [-0.5, 3, -0.5], "edge_u": [1, 0, 0], "edge_v": [0, 0, 1], "material": "lamp"}
        ],
        "lights": [
            {"type": "point", "position": [1, 3, 1], "intensity": [2, 3, 4]},
            {"type": "spot", "position": [0, 3, 0], "look_at": [0, 0, 0], "intensity": 10, "cutoff_angle": 25, "beam_width": 10},
            {"type": "directional", "direction": [1, -1, 0], "irradiance": 0.5}
        ],
        "environment": {"type": "constant", "radiance": [0.1, 0.2, 0.3]},
        "render": {"max_depth": 5, "spp": 32}
    });
    std::fs::write(
        dir.join("features.json"),
        serde_json::to_string_pretty(&scene).unwrap(),
    )
    .unwrap();
    let (a, b) = round_trip(&dir.join("features.json"), &dir);
    Pair { a: &a, b: &b }.check();
}

/// `s` with every instance written out as a mesh, the meshes in a fixed order (by their first
/// position): a round trip keeps what is rendered, not whether an emitting instance stays one.
fn flattened(s: &Scene) -> Scene {
    use renderer::scene::expand::{expand_instances, Expand};
    let mut f = expand_instances(s, Expand::All, "test", u64::MAX)
        .unwrap()
        .unwrap_or_else(|| s.clone());
    let key = |m: &renderer::scene::TriangleMesh| {
        let p = m.positions[0];
        [p.x, p.y, p.z].map(|x| (x * 1e4).round() as i64)
    };
    f.meshes.sort_by_key(key);
    f
}

#[test]
fn instances_survive_the_round_trip_as_shape_groups() {
    let dir = scratch("round_trip_instances");
    std::fs::copy(
        repo().join("tests/import/mitsuba/quad_uv.ply"),
        dir.join("quad_uv.ply"),
    )
    .unwrap();
    let scene = serde_json::json!({
        "version": 1,
        "camera": {"position": [0, 1, 6], "look_at": [0, 0.5, 0]},
        "film": {"width": 32, "height": 24, "filter": "box"},
        "materials": {
            "white": {"type": "diffuse", "reflectance": 0.8},
            "blue": {"type": "diffuse", "reflectance": [0.1, 0.2, 0.6]},
            "lamp": {"type": "diffuse", "reflectance": 0, "emission": [5, 4, 3]},
            "group_a_b__white": {"type": "diffuse", "reflectance": [0.7, 0.3, 0.3]}
        },
        "definitions": {
            "rock": {"type": "triangles", "positions": [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]],
                     "indices": [0, 1, 2, 0, 2, 3, 0, 3, 1], "material": "white",
                     "transform": {"scale": 0.5}},
            "tile": {"type": "mesh", "file": "quad_uv.ply", "material": "white"},
            "light": {"type": "quad", "origin": [-0.5, 0, -0.5], "edge_u": [1, 0, 0], "edge_v": [0, 0, 1],
                      "material": "lamp"},
            "a.b": {"type": "box", "min": [0, 0, 0], "max": [0.2, 0.2, 0.2], "material": "white"},
            "a_b": {"type": "quad", "origin": [0, 0, 0], "edge_u": [0.3, 0, 0], "edge_v": [0, 0.3, 0],
                    "material": "white"}
        },
        "objects": [
            {"type": "box", "min": [-3, -0.1, -3], "max": [3, 0, 3], "material": "group_a_b__white"},
            {"type": "instance", "definition": "rock", "transform": {"translate": [-1, 0, 0]}},
            {"type": "instance", "definition": "rock", "material": "blue",
             "transform": {"scale": [-1, 1.5, 1], "translate": [1, 0, 0]}},
            {"type": "instance", "definition": "rock", "transform": {"rotate": {"axis": [0, 1, 0], "angle": 40}}},
            {"type": "instance", "definition": "tile", "transform": {"translate": [0, 2, -1]}},
            {"type": "instance", "definition": "tile", "transform": {"translate": [1, 2, -1]}},
            {"type": "instance", "definition": "light", "transform": {"translate": [0, 3, 0]}},
            {"type": "instance", "definition": "a.b", "transform": {"translate": [-2, 0, 1]}},
            {"type": "instance", "definition": "a.b", "transform": {"translate": [-2.5, 0, 1]}},
            {"type": "instance", "definition": "a_b", "transform": {"translate": [2, 0, 1]}},
            {"type": "instance", "definition": "a_b", "transform": {"translate": [2.5, 0, 1]}}
        ],
        "render": {"max_depth": 5, "spp": 16}
    });
    std::fs::write(dir.join("inst.json"), scene.to_string()).unwrap();
    let (a, b) = round_trip(&dir.join("inst.json"), &dir);
    // Mitsuba's side: a group per (definition, material) placed, the emitting one in place;
    // "a.b" and "a_b" (alike once cleaned, and "group_a_b__white" a material's id) get groups
    // of their own.
    let xml = std::fs::read_to_string(dir.join("scene.xml")).unwrap();
    assert_eq!(xml.matches(r#"type="shapegroup""#).count(), 5, "{xml}");
    assert_eq!(xml.matches(r#"type="instance""#).count(), 9, "{xml}");
    let ids: Vec<&str> = (xml.split('<'))
        .filter(|tag| !tag.starts_with("ref "))
        .filter_map(|tag| tag.split(" id=\"").nth(1))
        .map(|t| &t[..t.find('"').unwrap()])
        .collect();
    assert!(
        ids.contains(&"group_a_b__white_2") && ids.contains(&"group_a_b__white_3"),
        "{ids:?}"
    );
    let unique: std::collections::HashSet<&&str> = ids.iter().collect();
    assert_eq!(unique.len(), ids.len(), "ids {ids:?}");
    // Back in candela: the groups placed twice are definitions again; the blue rock's group,
    // placed once, and the light are meshes of their own.
    assert_eq!((b.prototypes.len(), b.instances.len()), (4, 8));
    assert_eq!((a.prototypes.len(), a.instances.len()), (5, 10));
    let (fa, fb) = (flattened(&a), flattened(&b));
    assert_eq!(fa.meshes.len(), 11);
    Pair { a: &fa, b: &fb }.check();
}

#[test]
fn what_mitsuba_cannot_express_is_refused_with_its_json_path() {
    let dir = scratch("round_trip_refused");
    for (materials, needle) in [
        (
            serde_json::json!({"m": {"type": "phong"}}),
            "materials.m: phong",
        ),
        (
            serde_json::json!({"m": {"type": "principled", "subsurface": 0.5}}),
            "materials.m.subsurface",
        ),
        (
            serde_json::json!({"m": {"type": "principled", "specular": 0.9, "ior": 1.5}}),
            "specular and ior disagree",
        ),
    ] {
        let scene = serde_json::json!({"version": 1, "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0]},
            "materials": materials, "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "m"}]});
        std::fs::write(dir.join("s.json"), scene.to_string()).unwrap();
        let imp = import_file(&dir.join("s.json"), &ImportOptions::default()).unwrap();
        let e = write_xml(&imp, &dir.join("s.xml")).unwrap_err().to_string();
        assert!(
            e.contains(needle) && e.contains("Mitsuba 3 cannot express this exactly"),
            "{e}"
        );
    }
}
