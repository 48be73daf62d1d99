//! `instance` objects in the Mitsuba export (docs/import.md): each definition placed with a
//! given material becomes one `<shape type="shapegroup">` (a Mitsuba instance cannot change its
//! group's BSDF), each instance an `<shape type="instance">` referring to it with the instance's
//! `to_world`. An instance that emits light is written out in place, its transform composed onto
//! the definition's, as candela's own compile writes it out (Mitsuba's shape groups cannot hold
//! emitters).

use glam::DMat4;
use serde_json::{json, Value};

use super::export::{El, Export};
use super::export_parts::{clean, Parts};
use crate::import::doc::first_free;
use crate::import::xform::row_major;
use crate::scene::desc::TransformDesc;
use crate::scene::transform::Transform;
use crate::scene::SceneError;

/// The matrix of `o`'s `transform` (at `path`).
fn transform_of(o: &Value, path: &str) -> Result<DMat4, SceneError> {
    let desc: Option<TransformDesc> = serde_json::from_value(o["transform"].clone()).ok();
    Ok(Transform::from_desc(desc.as_ref(), &format!("{path}.transform"))?.matrix)
}

impl Parts {
    /// Instance `o` (at `path`) as a `<shape>`; its group is defined on first use.
    pub(super) fn instance(
        &mut self,
        ex: &mut Export,
        path: &str,
        o: &Value,
    ) -> Result<El, SceneError> {
        // Step 1: the definition with the instance's material in place of its own.
        let name = o["definition"].as_str().unwrap_or("");
        let def_path = crate::scene::key_path("definitions", name);
        let Some(def) = ex.doc["definitions"].get(name) else {
            return Err(SceneError::invalid(
                format!("{path}.definition"),
                format!("no definition \"{name}\""),
            ));
        };
        let mut member = def.clone();
        if let Some(m) = o["material"].as_str() {
            member["material"] = json!(m);
        }
        let to_world = transform_of(o, path)?;
        // Step 2: emitting (a named material with emission): this instance written out in
        // place, the transforms composed.
        let key = (
            name.to_string(),
            member["material"].as_str().map(String::from),
        );
        let emits = match &key.1 {
            Some(m) => self.define(ex, m)?.is_some(),
            None => false,
        };
        let stem = format!("def_{}", self.group_stem(ex, &key));
        let in_place = |parts: &mut Parts, ex: &mut Export, mut member: Value| {
            let own = transform_of(def, &def_path)?;
            member["transform"] = json!({"matrix": row_major(&(to_world * own)).to_vec()});
            parts.shape_at(ex, path, &stem, &member)
        };
        if emits {
            return in_place(self, ex, member);
        }
        // Step 3: the group, once per (definition, material).
        let id = format!("group_{}", self.group_stem(ex, &key));
        if !self.group_defined.contains(&key) {
            let inner = self.shape_at(ex, &def_path, &stem, &member)?;
            if inner.has_child("emitter") {
                // A mesh whose material comes from its file (OBJ usemtl) and emits: in place.
                return in_place(self, ex, member);
            }
            self.group_defined.insert(key);
            self.groups.push(
                El::plugin("shape", "shapegroup")
                    .attr("id", &id)
                    .child(inner),
            );
        }
        Ok(El::plugin("shape", "instance")
            .child(El::new("ref").attr("id", &id))
            .matrix("to_world", &to_world))
    }

    /// A name for the group of (definition, material) `key`, unique among the groups and the
    /// materials (which are ids too): the names cleaned, numbered where two clean alike.
    fn group_stem(&mut self, ex: &Export, key: &(String, Option<String>)) -> String {
        if let Some(s) = self.group_stems.get(key) {
            return s.clone();
        }
        let base = match &key.1 {
            Some(m) => format!("{}__{}", clean(&key.0), clean(m)),
            None => clean(&key.0),
        };
        let stem = first_free(&base, |s| {
            self.group_stems.values().any(|v| v == s)
                || ex.doc["materials"].get(format!("group_{s}")).is_some()
        });
        self.group_stems.insert(key.clone(), stem.clone());
        stem
    }
}
