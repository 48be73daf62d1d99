//! Mitsuba 3 XML → candela's scene document, and back (`export`).
//!
//! candela's JSON follows Mitsuba 3's meaning field by field (docs/scene-format.md names the
//! Mitsuba equivalent of each), so this importer is the inverse of tests/mitsuba/ref_*.py, the
//! translator the tests use: sensors (`scene`), BSDFs and textures (`bsdfs`), shapes, instancing
//! and area emitters (`shapes`, `serialized`), other emitters (`scene`). docs/import.md lists the
//! mapping and the few documented approximations (plastic, disk, Beckmann under --lenient).
//!
//! The sensor is read first: when its transform mirrors the image (a Blender-style
//! `<scale x="-1"/>`), the whole scene is mirrored (x → −x) so that candela, which has no mirrored
//! cameras, draws the same image.

mod bsdfs;
pub mod export;
mod export_instances;
mod export_parts;
mod props;
mod scene;
mod serialized;
mod shapes;
mod tables;
mod xml;

use std::collections::HashMap;
use std::path::Path;

use glam::{DMat4, DVec3};
use serde_json::Value;

use super::diag::Report;
use super::doc::Doc;
use super::{ImportOptions, ImportResult};
use crate::scene::{Limits, SceneError};
use props::Plugin;
use xml::Tree;

pub(crate) use tables::conductor as named_conductor;

/// A converted BSDF.
#[derive(Debug, Clone)]
pub(crate) struct Mat {
    /// The candela material (no emission).
    pub value: Value,
    /// A name for it (the bsdf's id, else its type).
    pub hint: String,
}

impl Mat {
    /// Whether the material reads textures (then mesh uv conventions matter).
    pub fn textured(&self) -> bool {
        self.value.to_string().contains("\"texture\"")
    }
}

/// Everything the converters share.
pub(crate) struct Ctx<'t> {
    pub tree: &'t Tree,
    pub doc: Doc,
    pub report: Report,
    pub limits: Limits,
    /// Applied to everything in world space (the identity, or a mirror; see the module docs).
    pub world: DMat4,
    /// Converted BSDFs by node.
    pub materials: HashMap<usize, Mat>,
    /// Shape groups (by node): candela objects in the group's space, defined once.
    pub groups: HashMap<usize, crate::import::groups::Group>,
}

impl Ctx<'_> {
    /// A plugin's `to_world` (or another transform property) in candela's world.
    pub fn to_world(&self, p: &Plugin, name: &str) -> Result<DMat4, SceneError> {
        Ok(self.world * p.transform(name)?)
    }

    /// A point in candela's world.
    pub fn point(&self, p: DVec3) -> DVec3 {
        self.world.transform_point3(p)
    }

    /// A direction in candela's world.
    pub fn vector(&self, v: DVec3) -> DVec3 {
        self.world.transform_vector3(v)
    }
}

/// Imports the Mitsuba scene `path`.
pub(crate) fn import(path: &Path, opts: &ImportOptions) -> ImportResult {
    let tree = xml::parse(path, &opts.params)?;
    let mut ctx = Ctx {
        tree: &tree,
        doc: Doc::new(),
        report: Report::new(opts.lenient),
        limits: opts.limits.clone(),
        world: DMat4::IDENTITY,
        materials: HashMap::new(),
        groups: HashMap::new(),
    };
    let root = &tree.nodes[tree.root];
    if root.tag != "scene" {
        return Err(root.loc.error("the root element must be <scene>"));
    }
    // Step 1: sensor (camera, film, samples) and integrator, whatever their order.
    let children = root.children.clone();
    let sensors: Vec<usize> = children
        .iter()
        .copied()
        .filter(|&c| tree.nodes[c].tag == "sensor")
        .collect();
    scene::sensor(&mut ctx, &sensors)?;
    let integrators: Vec<usize> = children
        .iter()
        .copied()
        .filter(|&c| tree.nodes[c].tag == "integrator")
        .collect();
    for &c in &integrators {
        scene::integrator(&mut ctx, c)?;
    }
    if integrators.is_empty() {
        // Mitsuba's default integrator: path, unbounded depth.
        ctx.doc
            .render
            .insert("max_depth".into(), serde_json::json!(-1));
    }
    // Step 2: everything else in document order.
    for &c in &children {
        let n = &tree.nodes[c];
        match n.tag.as_str() {
            "sensor" | "integrator" => {}
            // Defined where they are referenced.
            "bsdf" | "texture" => {}
            "shape" if n.attr("type") == Some("shapegroup") => {}
            "shape" => shapes::shape(&mut ctx, c)?,
            "emitter" => scene::emitter(&mut ctx, c)?,
            other => {
                let what = match n.attr("type") {
                    Some(t) => format!("<{other} type=\"{t}\">"),
                    None => format!("<{other}>"),
                };
                ctx.report.unsupported(
                    &n.loc,
                    &format!("{what} at the top level of the scene is not supported"),
                    "skipped",
                )?;
            }
        }
    }
    let Ctx { doc, report, .. } = ctx;
    let (value, assets, origins) = doc.finish();
    Ok((value, assets, origins, report.warnings))
}

#[cfg(test)]
mod tests;
