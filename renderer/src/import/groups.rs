//! Instanced groups of the importers (a Mitsuba `shapegroup` placed by `instance` shapes, a pbrt
//! `ObjectBegin` … `ObjectEnd` placed by `ObjectInstance`, a glTF mesh under several nodes) as
//! candela definitions placed by `instance` objects (docs/scene-format.md), so that memory grows
//! with the unique geometry, not with the placements.
//!
//! Each member a definition can hold (mesh, triangles, quad, box) is defined once, the first
//! time its group is placed, and every placement adds one `instance` object per member; other
//! members (spheres) are copied into place as before. A definition placed only once is written
//! in place when the document is finished ([`Doc::finish`]), so a scene without repeated geometry
//! reads exactly as it did before instancing.

use glam::DMat4;
use serde_json::Value;

use super::diag::Loc;
use super::doc::Doc;
use super::xform::place;

/// Object types a definition can hold (docs/scene-format.md, "definitions").
pub const DEFINABLE: [&str; 4] = ["mesh", "triangles", "quad", "box"];

/// A group of objects in its own space, placed any number of times.
#[derive(Debug, Clone)]
pub struct Group {
    /// The name definitions are derived from (the source's group name).
    name: String,
    /// Each member and where the source wrote it (what errors in its definition point at).
    members: Vec<(Value, Loc)>,
    /// Per member, its definition's name (None: copied into place); set at the first placement.
    defined: Option<Vec<Option<String>>>,
}

impl Group {
    pub fn new(name: &str, members: Vec<(Value, Loc)>) -> Self {
        Group {
            name: name.to_string(),
            members,
            defined: None,
        }
    }

    /// Places the group by `to_world` (after each member's own transform): an `instance` object
    /// per definable member, a copy of each other member. Instances point at `loc` (the
    /// placement), definitions and copies at the member's own place in the source.
    pub fn place(&mut self, doc: &mut Doc, to_world: &DMat4, loc: &Loc) {
        let defined = self.defined.get_or_insert_with(|| {
            (self.members.iter().enumerate())
                .map(|(k, (o, member_loc))| {
                    let kind = o["type"].as_str().unwrap_or("");
                    DEFINABLE.contains(&kind).then(|| {
                        let hint = if self.members.len() == 1 {
                            self.name.clone()
                        } else {
                            format!("{}_{k}", self.name)
                        };
                        doc.definition(&hint, o.clone(), member_loc)
                    })
                })
                .collect()
        });
        for ((o, member_loc), def) in self.members.iter().zip(defined.iter()) {
            match def {
                Some(name) => doc.instance(name, to_world, loc),
                None => doc.object(place(o, to_world), member_loc),
            }
        }
    }
}
