//! docs/scene-format.md against the loader: every field a table documents is accepted, and every
//! field the loader accepts is documented, for every section and every material, object, light,
//! environment and filter type. The accepted fields are read from the loader's own serde types
//! (the list in their "unknown field" message), so neither side can drift.

use std::collections::{BTreeMap, BTreeSet};

use serde::de::DeserializeOwned;

use super::desc::*;
use super::desc_tagged::{
    GaussianFields, ENVIRONMENT_TYPES, FILTER_TYPES, LIGHT_TYPES, MATERIAL_SHARED, MATERIAL_TYPES,
    OBJECT_SHARED, OBJECT_TYPES,
};

const DOC: &str = include_str!("../../../docs/scene-format.md");

/// Heading → the field names in the first column of the table under it (backticked).
fn documented() -> BTreeMap<String, BTreeSet<String>> {
    let mut out = BTreeMap::new();
    let mut heading = String::new();
    for line in DOC.lines() {
        if let Some(h) = line
            .strip_prefix("### ")
            .or_else(|| line.strip_prefix("## "))
        {
            heading = h.trim().to_string();
        } else if let Some(row) = line.strip_prefix("| `") {
            let cell = row.split(" |").next().unwrap_or("");
            let fields = out.entry(heading.clone()).or_insert_with(BTreeSet::new);
            for name in format!("`{cell}").split('`').skip(1).step_by(2) {
                fields.insert(name.to_string());
            }
        }
    }
    out
}

/// The fields serde accepts for `T`, from its message for an unknown field.
fn accepted<T: DeserializeOwned>() -> BTreeSet<String> {
    let Err(e) = serde_json::from_value::<T>(serde_json::json!({"__probe__": 0})) else {
        panic!("{}: accepted an unknown field", std::any::type_name::<T>());
    };
    let msg = e.to_string();
    assert!(msg.contains("unknown field `__probe__`"), "{msg}");
    if msg.contains("there are no fields") {
        return BTreeSet::new();
    }
    let list = msg.split("expected ").nth(1).unwrap_or("");
    let list = list.strip_prefix("one of ").unwrap_or(list);
    list.split('`')
        .skip(1)
        .step_by(2)
        .map(String::from)
        .collect()
}

fn set(names: &[&str]) -> BTreeSet<String> {
    names.iter().map(|s| s.to_string()).collect()
}

fn with_type(mut s: BTreeSet<String>) -> BTreeSet<String> {
    s.insert("type".into());
    s
}

#[test]
fn every_documented_field_is_accepted_and_every_accepted_field_documented() {
    // Every section with a field table, and what the loader accepts there.
    let mut want: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    want.insert("Top level".into(), accepted::<SceneDesc>());
    want.insert("camera".into(), accepted::<CameraDesc>());
    want.insert("film".into(), accepted::<FilmDesc>());
    want.insert("materials".into(), set(MATERIAL_SHARED));
    want.insert("objects".into(), set(OBJECT_SHARED));
    want.insert("texture reference".into(), accepted::<TextureRefDesc>());
    want.insert("transform".into(), accepted::<TransformDesc>());
    want.insert("transform.rotate".into(), accepted::<RotateDesc>());
    want.insert("render".into(), accepted::<RenderDesc>());
    for t in FILTER_TYPES {
        let fields = match *t {
            "box" => continue, // no fields besides `type`; documented in the film table
            "gaussian" => accepted::<GaussianFields>(),
            other => panic!("filter type {other}: add it to this test and to the docs"),
        };
        want.insert(format!("filter: {t}"), with_type(fields));
    }
    for t in MATERIAL_TYPES {
        let fields = match *t {
            "diffuse" => accepted::<DiffuseDesc>(),
            "conductor" => accepted::<ConductorDesc>(),
            "dielectric" => accepted::<DielectricDesc>(),
            "principled" => accepted::<PrincipledDesc>(),
            "phong" => accepted::<PhongDesc>(),
            other => panic!("material type {other}: add it to this test and to the docs"),
        };
        want.insert(format!("material: {t}"), fields);
    }
    for t in OBJECT_TYPES {
        let fields = match *t {
            "mesh" => accepted::<MeshDesc>(),
            "triangles" => accepted::<TrianglesDesc>(),
            "sphere" => accepted::<SphereDesc>(),
            "quad" => accepted::<QuadDesc>(),
            "box" => accepted::<BoxDesc>(),
            "instance" => accepted::<InstanceDesc>(),
            other => panic!("object type {other}: add it to this test and to the docs"),
        };
        want.insert(format!("object: {t}"), fields);
    }
    for t in LIGHT_TYPES {
        let fields = match *t {
            "point" => accepted::<PointLightDesc>(),
            "spot" => accepted::<SpotLightDesc>(),
            "directional" => accepted::<DirectionalLightDesc>(),
            other => panic!("light type {other}: add it to this test and to the docs"),
        };
        want.insert(format!("light: {t}"), with_type(fields));
    }
    for t in ENVIRONMENT_TYPES {
        let fields = match *t {
            "constant" => accepted::<ConstantEnvDesc>(),
            "map" => accepted::<MapEnvDesc>(),
            other => panic!("environment type {other}: add it to this test and to the docs"),
        };
        want.insert(format!("environment: {t}"), with_type(fields));
    }

    let doc = documented();
    let mut problems = Vec::new();
    for (section, fields) in &want {
        let Some(documented) = doc.get(section) else {
            problems.push(format!(
                "docs/scene-format.md has no table under \"{section}\""
            ));
            continue;
        };
        for f in fields.difference(documented) {
            problems.push(format!("{section}: `{f}` is accepted but not documented"));
        }
        for f in documented.difference(fields) {
            problems.push(format!("{section}: `{f}` is documented but not accepted"));
        }
    }
    for section in doc.keys().filter(|s| !want.contains_key(*s)) {
        problems.push(format!(
            "docs/scene-format.md: the table under \"{section}\" is not checked by this test"
        ));
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

#[test]
fn the_probe_reads_serde_field_lists() {
    assert_eq!(accepted::<RotateDesc>(), set(&["axis", "angle"]));
    assert_eq!(accepted::<DiffuseDesc>(), set(&["reflectance"]));
}

/// The example under "definitions" loads (its mesh file from scenes/assets), placing one
/// definition twice.
#[test]
fn the_instancing_example_loads() {
    let section = DOC
        .split("\n## definitions\n")
        .nth(1)
        .expect("a definitions section");
    let json = section
        .split("```json\n")
        .nth(1)
        .and_then(|s| s.split("\n```").next())
        .expect("a json example");
    let scenes = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes");
    let scene = super::load_str(json, Some(&scenes)).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.prototypes.len(), 1);
    assert_eq!(scene.instances.len(), 2);
    assert_eq!(scene.instances[1].material, Some(1));
    assert!(scene.instances[1].to_world.determinant() < 0.0);
    assert_eq!(
        scene.meshes.len(),
        2,
        "the definition itself is not rendered"
    );
}
