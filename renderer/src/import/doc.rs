//! The candela scene document an importer builds (docs/scene-format.md), as a JSON value, with
//! the files it made held in memory (meshes as PLY, embedded or derived images) and, for each
//! material, object and light, the place in the source it came from, so that an error the loader
//! finds later can still name the source file and line.

use std::collections::{BTreeMap, HashMap};

use glam::DMat4;
use serde_json::{json, Map, Value};

use super::derived;
use super::diag::Loc;
use super::meshes;
use super::xform::{object_matrix, place, transform_value};
use crate::film::Image;
use crate::scene::mesh::RawMesh;
use crate::scene::paths::AssetRoot;
use crate::scene::{Limits, MemoryAssets, SceneError};

/// The folder name under which files held in memory are named (`_imported/mesh_3.ply`);
/// `candela convert` renames it to `<output stem>_assets/`.
pub const MEMORY_DIR: &str = "_imported";

/// A scene document under construction.
#[derive(Debug, Default)]
pub(crate) struct Doc {
    pub camera: Map<String, Value>,
    pub film: Map<String, Value>,
    pub render: Map<String, Value>,
    pub environment: Option<Value>,
    /// Materials by name (the document's `materials`, whose order JSON objects do not keep).
    materials: BTreeMap<String, Value>,
    /// Serialised material → its name (identical materials are shared).
    by_content: HashMap<String, String>,
    objects: Vec<Value>,
    /// Definitions by name (placed by `instance` objects, groups.rs).
    definitions: BTreeMap<String, Value>,
    lights: Vec<Value>,
    pub assets: MemoryAssets,
    /// (JSON path prefix, source place) of what was added.
    pub origins: Vec<(String, Loc)>,
}

impl Doc {
    pub fn new() -> Self {
        Doc::default()
    }

    /// Adds a material (or finds an identical one) under a name derived from `hint`; returns it.
    pub fn material(&mut self, hint: &str, m: Value, loc: &Loc) -> String {
        let key = m.to_string();
        if let Some(name) = self.by_content.get(&key) {
            return name.clone();
        }
        let name = first_free(&clean_name(hint), |n| self.materials.contains_key(n));
        self.by_content.insert(key, name.clone());
        self.origins
            .push((format!("materials.{name}"), loc.clone()));
        self.materials.insert(name.clone(), m);
        name
    }

    /// Adds an object.
    pub fn object(&mut self, o: Value, loc: &Loc) {
        self.origins
            .push((format!("objects[{}]", self.objects.len()), loc.clone()));
        self.objects.push(o);
    }

    /// Adds a definition (an object rendered only where `instance` objects place it) under a
    /// name derived from `hint`; returns the name.
    pub fn definition(&mut self, hint: &str, o: Value, loc: &Loc) -> String {
        let name = first_free(&clean_name(hint), |n| self.definitions.contains_key(n));
        self.origins
            .push((format!("definitions.{name}"), loc.clone()));
        self.definitions.insert(name.clone(), o);
        name
    }

    /// Adds an `instance` object placing definition `name` by `to_world`.
    pub fn instance(&mut self, name: &str, to_world: &DMat4, loc: &Loc) {
        let mut o = json!({"type": "instance", "definition": name});
        if let Some(t) = transform_value(to_world) {
            o["transform"] = t;
        }
        self.object(o, loc);
    }

    /// Adds a light.
    pub fn light(&mut self, l: Value, loc: &Loc) {
        self.origins
            .push((format!("lights[{}]", self.lights.len()), loc.clone()));
        self.lights.push(l);
    }

    /// Holds a file in memory under `_imported/<hint>.<ext>` (made unique); returns that path.
    pub fn file(&mut self, hint: &str, ext: &str, bytes: Vec<u8>) -> String {
        let path = |stem: &str| format!("{MEMORY_DIR}/{stem}.{ext}");
        let stem = first_free(&clean_name(hint), |s| self.assets.contains_key(&path(s)));
        let name = path(&stem);
        self.assets.insert(name.clone(), bytes);
        name
    }

    /// Holds a mesh in memory as PLY; returns a `mesh` object for it (no material yet). Flat
    /// shading when the mesh has no normals (face normals, as glTF and pbrt require).
    pub fn mesh_object(&mut self, hint: &str, mesh: &RawMesh) -> Value {
        let smooth = mesh.normals.is_some();
        let file = self.file(hint, "ply", meshes::to_ply(mesh));
        json!({"type": "mesh", "file": file, "smooth": smooth})
    }

    /// A texture derived from `rel` (resolved against `dir` and the files held so far) by
    /// applying `f` to each linear RGBA texel, held in memory as EXR; returns its path.
    pub fn derived_texture(
        &mut self,
        dir: &std::path::Path,
        rel: &str,
        srgb: Option<bool>,
        hint: &str,
        f: impl Fn([f32; 4]) -> [f32; 3],
    ) -> Result<String, SceneError> {
        let root = AssetRoot {
            dir: Some(dir),
            memory: Some(&self.assets),
        };
        let image: Image = derived::derive(root, rel, srgb, &Limits::default(), f)?;
        let bytes = crate::film::encode_exr(&image).map_err(|e| SceneError::Decode {
            path: String::new(),
            file: rel.to_string(),
            msg: e.to_string(),
        })?;
        Ok(self.file(hint, "exr", bytes))
    }

    /// The finished document and its files. A definition placed once is written in place
    /// (groups.rs): an instance only pays where geometry repeats.
    pub fn finish(mut self) -> (Value, MemoryAssets, Vec<(String, Loc)>) {
        // Step 1: definitions placed at most once leave; their instance becomes the object.
        let mut uses: HashMap<String, usize> = HashMap::new();
        for o in self.objects.iter().filter(|o| o["type"] == "instance") {
            let name = o["definition"].as_str().unwrap_or_default();
            *uses.entry(name.to_string()).or_default() += 1;
        }
        let once = |name: &str| uses.get(name).copied().unwrap_or(0) <= 1;
        // (An object written in place points at the definition's source place, the member's.)
        let def_locs: HashMap<String, Loc> = (self.origins.iter())
            .filter_map(|(path, loc)| {
                Some((path.strip_prefix("definitions.")?.into(), loc.clone()))
            })
            .collect();
        let mut moved = HashMap::new();
        for (i, o) in self.objects.iter_mut().enumerate() {
            let name = o["definition"].as_str().unwrap_or_default();
            if o["type"] == "instance" && once(name) {
                if let Some(def) = self.definitions.get(name) {
                    if let Some(loc) = def_locs.get(name) {
                        moved.insert(format!("objects[{i}]"), loc.clone());
                    }
                    // An instance's material replaces the definition's (scene-format.md).
                    let mut placed = place(def, &object_matrix(o));
                    if let Some(m) = o.get("material") {
                        placed["material"] = m.clone();
                    }
                    *o = placed;
                }
            }
        }
        for (path, loc) in self.origins.iter_mut() {
            if let Some(l) = moved.get(path.as_str()) {
                *loc = l.clone();
            }
        }
        self.definitions.retain(|n, _| !once(n));
        self.origins
            .retain(|(path, _)| path.strip_prefix("definitions.").is_none_or(|n| !once(n)));
        let mut doc = Map::new();
        doc.insert("version".into(), json!(1));
        doc.insert("camera".into(), Value::Object(self.camera));
        if !self.film.is_empty() {
            doc.insert("film".into(), Value::Object(self.film));
        }
        let materials: Map<String, Value> = self.materials.into_iter().collect();
        doc.insert("materials".into(), Value::Object(materials));
        if !self.definitions.is_empty() {
            let defs: Map<String, Value> = self.definitions.into_iter().collect();
            doc.insert("definitions".into(), Value::Object(defs));
        }
        doc.insert("objects".into(), Value::Array(self.objects));
        if !self.lights.is_empty() {
            doc.insert("lights".into(), Value::Array(self.lights));
        }
        if let Some(e) = self.environment {
            doc.insert("environment".into(), e);
        }
        if !self.render.is_empty() {
            doc.insert("render".into(), Value::Object(self.render));
        }
        (Value::Object(doc), self.assets, self.origins)
    }
}

/// `base`, or `base_2`, `base_3`, … : the first that `taken` does not hold.
pub(crate) fn first_free(base: &str, taken: impl Fn(&str) -> bool) -> String {
    let mut name = base.to_string();
    let mut n = 2;
    while taken(&name) {
        name = format!("{base}_{n}");
        n += 1;
    }
    name
}

/// A name usable as a material name and a file name: letters, digits, `_` and `-`.
fn clean_name(hint: &str) -> String {
    let s: String = hint
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '_' || c == '-' {
                c
            } else {
                '_'
            }
        })
        .take(48)
        .collect();
    if s.is_empty() || s.starts_with(|c: char| c.is_ascii_digit() || c == '-') {
        format!("m_{s}")
    } else {
        s
    }
}

/// Walks every string of a document that names a file (`file`, `texture`) and maps it.
pub(crate) fn map_file_names(v: &mut Value, f: &mut dyn FnMut(&str) -> Option<String>) {
    match v {
        Value::Object(m) => {
            for (k, x) in m.iter_mut() {
                match x {
                    Value::String(s) if k == "file" || k == "texture" => {
                        if let Some(new) = f(s) {
                            *s = new;
                        }
                    }
                    _ => map_file_names(x, f),
                }
            }
        }
        Value::Array(a) => a.iter_mut().for_each(|x| map_file_names(x, f)),
        _ => {}
    }
}

/// Every file name a document refers to, in order, once each.
pub(crate) fn file_names(v: &Value) -> Vec<String> {
    let mut v = v.clone();
    let mut seen = BTreeMap::new();
    let mut order = Vec::new();
    map_file_names(&mut v, &mut |s| {
        if seen.insert(s.to_string(), ()).is_none() {
            order.push(s.to_string());
        }
        None
    });
    order
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    #[test]
    fn materials_are_shared_and_named_uniquely() {
        let file: Arc<str> = Arc::from("a.xml");
        let loc = Loc::new(&file, Some(3));
        let mut d = Doc::new();
        let a = d.material("red wall", json!({"type": "diffuse"}), &loc);
        let b = d.material("red wall", json!({"type": "diffuse"}), &loc);
        let c = d.material(
            "red wall",
            json!({"type": "diffuse", "reflectance": 1}),
            &loc,
        );
        assert_eq!(
            (a.as_str(), b.as_str(), c.as_str()),
            ("red_wall", "red_wall", "red_wall_2")
        );
        assert_eq!(clean_name("3d"), "m_3d");
        let f1 = d.file("mesh", "ply", vec![1]);
        let f2 = d.file("mesh", "ply", vec![2]);
        assert_eq!(
            (f1.as_str(), f2.as_str()),
            ("_imported/mesh.ply", "_imported/mesh_2.ply")
        );
        d.object(json!({"type": "mesh", "file": f1, "material": a}), &loc);
        let (doc, assets, origins) = d.finish();
        assert_eq!(assets.len(), 2);
        assert_eq!(origins.last().unwrap().0, "objects[0]");
        assert_eq!(file_names(&doc), vec!["_imported/mesh.ply".to_string()]);
    }
}
