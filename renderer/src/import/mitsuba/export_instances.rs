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
        let material = o["material"].as_str();
        if let Some(m) = material {
            member["material"] = json!(m);
        }
        let stem = match material {
            Some(m) => format!("{}__{}", clean(name), clean(m)),
            None => clean(name),
        };
        let id = format!("group_{stem}");
        let to_world = transform_of(o, path)?;
        // Step 2: the group, once per (definition, material).
        if !self.group_ids.contains(&id) {
            let inner = self.shape_at(ex, &def_path, &format!("def_{stem}"), &member)?;
            if inner.has_child("emitter") {
                // Step 3: emitting: this instance written out in place.
                let own = transform_of(def, &def_path)?;
                member["transform"] = json!({"matrix": row_major(&(to_world * own)).to_vec()});
                return self.shape_at(ex, path, &format!("def_{stem}"), &member);
            }
            self.group_ids.insert(id.clone());
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
}
