//! From JSON text to a loaded `Scene`: parse (path-tracked serde), then each section in document
//! order — camera, film, materials, objects (shapes and mesh files to world space), lights,
//! environment, render defaults — stopping at the first error.

use std::collections::HashMap;

use glam::{DVec3, Vec2};

use super::desc::*;
use super::error::{from_json_error, index_path, join_path, key_path, SceneError};
use super::mesh::{to_world, FileError, Materials, RawMesh, Shading};
use super::paths::AssetRoot;
use super::texture::TextureCache;
use super::transform::{box_corners, in_f32_range, Transform};
use super::validate::{f32_of, non_negative, non_negative3, positive};
use super::{materials, obj, paths, ply, shapes, validate};
use super::{Environment, Instance, Limits, Scene, Sphere, TriangleMesh};

/// Parses the document (syntax, types, unknown fields, version).
pub(crate) fn parse(json: &str) -> Result<SceneDesc, SceneError> {
    // serde accepts a struct written as an array; a scene must be an object.
    let trimmed = json.trim_start();
    if !trimmed.is_empty() && !trimmed.starts_with('{') {
        let prefix = &json[..json.len() - trimmed.len()];
        let line_start = prefix.rfind('\n').map_or(0, |i| i + 1);
        return Err(SceneError::Syntax {
            path: String::new(),
            line: prefix.matches('\n').count() + 1,
            column: prefix.len() - line_start + 1,
            msg: "a scene must be a JSON object ({\"version\": 1, ...})".into(),
        });
    }
    let mut de = serde_json::Deserializer::from_str(json);
    let desc: SceneDesc = serde_path_to_error::deserialize(&mut de).map_err(from_json_error)?;
    de.end().map_err(|e| SceneError::Syntax {
        path: String::new(),
        line: e.line(),
        column: e.column(),
        msg: "unexpected characters after the scene object".into(),
    })?;
    Ok(desc)
}

/// Loads a scene from JSON text; see `scene::load_str_with_limits`.
pub(crate) fn load(json: &str, root: AssetRoot<'_>, limits: &Limits) -> Result<Scene, SceneError> {
    let desc = parse(json)?;
    let _version_checked = desc.version;
    let camera = validate::camera(&desc.camera)?;
    let film = validate::film(&desc.film, limits)?;

    let mut textures = TextureCache::new(root, limits);
    let mut material_list = Vec::with_capacity(desc.materials.0.len());
    let mut material_names = Vec::with_capacity(desc.materials.0.len());
    for (name, m) in &desc.materials.0 {
        material_list.push(materials::build(name, m, &mut textures)?);
        material_names.push(name.clone());
    }
    let mut objects = Objects {
        root,
        limits,
        by_name: material_names
            .iter()
            .enumerate()
            .map(|(i, n)| (n.as_str(), i as u32))
            .collect(),
        meshes: Vec::new(),
        spheres: Vec::new(),
        prototypes: Vec::new(),
        prototype_facts: Vec::new(),
        definitions: HashMap::new(),
        instances: Vec::new(),
        defining: false,
        triangles: 0,
    };
    // Definitions first (they may appear after the objects that instance them in the file).
    if let Some(defs) = &desc.definitions {
        objects.defining = true;
        for (name, o) in &defs.0 {
            objects.define(name, o)?;
        }
        objects.defining = false;
    }
    for (i, o) in desc.objects.iter().enumerate() {
        objects.add(&index_path("objects", i), o)?;
    }
    let Objects {
        meshes,
        spheres,
        prototypes,
        instances,
        ..
    } = objects;

    let lights = desc
        .lights
        .iter()
        .enumerate()
        .map(|(i, l)| validate::light(l, i))
        .collect::<Result<Vec<_>, _>>()?;
    let environment = match &desc.environment {
        None => None,
        Some(EnvironmentDesc::Constant(c)) => Some(Environment::Constant {
            radiance: non_negative3(c.radiance.0, "environment.radiance")?,
        }),
        Some(EnvironmentDesc::Map(m)) => {
            let texture = textures.load(&m.file, None, Vec2::ONE, "environment.file")?;
            let scale = non_negative(m.scale.unwrap_or(1.0), "environment.scale")?;
            Some(Environment::Map {
                texture,
                scale: f32_of(scale, "environment.scale")?,
                rotate_y: f32_of(m.rotate_y.unwrap_or(0.0), "environment.rotate_y")?,
            })
        }
    };
    let render = validate::render(desc.render.as_ref())?;
    Ok(Scene {
        camera,
        film,
        materials: material_list,
        material_names,
        textures: textures.textures,
        meshes,
        spheres,
        prototypes,
        instances,
        lights,
        environment,
        render,
    })
}

/// What an instance needs to know about its prototype, computed once per definition.
struct PrototypeFacts {
    lo: DVec3,
    hi: DVec3,
}

/// Objects being converted, with what they need.
struct Objects<'a> {
    root: AssetRoot<'a>,
    limits: &'a Limits,
    by_name: HashMap<&'a str, u32>,
    meshes: Vec<TriangleMesh>,
    spheres: Vec<Sphere>,
    /// The definitions' meshes, and each definition's index among them (None: it has no
    /// triangles, so its instances are skipped).
    prototypes: Vec<TriangleMesh>,
    /// Each prototype's bounding box (its own frame): computed once per definition so that an
    /// instance costs O(1), not O(triangles).
    prototype_facts: Vec<PrototypeFacts>,
    definitions: HashMap<String, Option<u32>>,
    instances: Vec<Instance>,
    /// Converting a definition: meshes go to `prototypes`; spheres and instances are refused.
    defining: bool,
    /// Triangles so far (bounded by `limits.max_triangles`).
    triangles: usize,
}

impl Objects<'_> {
    fn remaining(&self) -> usize {
        self.limits.max_triangles.saturating_sub(self.triangles)
    }

    /// Converts `definitions.<name>` into a prototype (its transform applied once, in its
    /// own frame).
    fn define(&mut self, name: &str, o: &ObjectDesc) -> Result<(), SceneError> {
        let path = key_path("definitions", name);
        let refused = match &o.shape {
            ShapeDesc::Sphere(_) => Some("a sphere"),
            ShapeDesc::Instance(_) => Some("an instance (nested instancing is not supported)"),
            _ => None,
        };
        if let Some(what) = refused {
            return Err(SceneError::invalid(
                join_path(&path, "type"),
                format!("a definition holds triangles (mesh, triangles, quad or box), not {what}"),
            ));
        }
        let before = self.prototypes.len();
        self.add(&path, o)?;
        let index = (self.prototypes.len() > before).then_some(before as u32);
        self.definitions.insert(name.to_string(), index);
        Ok(())
    }

    /// An `instance` object at `path`: its definition placed with `transform`.
    fn instance(
        &mut self,
        path: &str,
        d: &InstanceDesc,
        material: Option<u32>,
        transform: &Transform,
    ) -> Result<(), SceneError> {
        let def_path = join_path(path, "definition");
        let Some(&entry) = self.definitions.get(d.definition.as_str()) else {
            let mut known: Vec<&str> = self.definitions.keys().map(String::as_str).collect();
            known.sort_unstable();
            return Err(SceneError::invalid(
                def_path,
                if known.is_empty() {
                    format!(
                        "no definition \"{}\" (the scene has no top-level \"definitions\")",
                        d.definition
                    )
                } else {
                    format!(
                        "no definition \"{}\" (defined: {})",
                        d.definition,
                        known.join(", ")
                    )
                },
            ));
        };
        let Some(prototype) = entry else {
            tracing::warn!(
                "{path}: definition \"{}\" has no triangles; skipped",
                d.definition
            );
            return Ok(());
        };
        let facts = &self.prototype_facts[prototype as usize];
        // The placed box must stay within f32 (the GPU's frame), checked on the prototype's
        // box corners: O(1) per instance.
        let inside = box_corners(facts.lo, facts.hi).all(|c| in_f32_range(transform.point(c)));
        if !inside {
            return Err(SceneError::invalid(
                join_path(path, "transform"),
                "places the definition beyond the range of 32-bit floats",
            ));
        }
        // The shader moves rays into the object frame with the inverse, in f32: a tiny scale
        // (accepted by the relative invertibility check) would overflow it to inf (NaN rays).
        if !transform.inverse_fits_f32() {
            return Err(SceneError::invalid(
                join_path(path, "transform"),
                "its inverse (world to object) exceeds the range of 32-bit floats (is a scale too small?)",
            ));
        }
        self.instances.push(Instance {
            prototype,
            to_world: transform.matrix,
            material,
        });
        Ok(())
    }

    /// Converts the object at `path` (`objects[3]`, or `definitions.<name>` while defining).
    fn add(&mut self, path: &str, o: &ObjectDesc) -> Result<(), SceneError> {
        let path = path.to_string();
        let transform_path = join_path(&path, "transform");
        let transform = Transform::from_desc(o.common.transform.as_ref(), &transform_path)?;
        let material = match &o.common.material {
            None => None,
            Some(name) => match self.by_name.get(name.as_str()) {
                Some(&m) => Some(m),
                None => {
                    return Err(SceneError::invalid(
                        join_path(&path, "material"),
                        format!("no material \"{name}\""),
                    ))
                }
            },
        };
        let required = |why: &str| {
            material.ok_or_else(|| {
                SceneError::invalid(&path, format!("missing field \"material\"{why}"))
            })
        };
        match &o.shape {
            ShapeDesc::Sphere(s) => {
                let material = required("")?;
                let radius = positive(s.radius, &join_path(&path, "radius"))?;
                let Some(scale) = transform.uniform_scale() else {
                    return Err(SceneError::invalid(
                        transform_path,
                        "spheres accept only uniform scale",
                    ));
                };
                let center = transform.point(DVec3::from_array(s.center));
                let radius = radius * scale;
                if !(center.is_finite() && radius.is_finite() && radius > 0.0) {
                    return Err(SceneError::invalid(
                        transform_path,
                        "the transform produces a non-finite sphere",
                    ));
                }
                if !(in_f32_range(center + radius) && in_f32_range(center - radius)) {
                    return Err(SceneError::invalid(
                        transform_path,
                        "places the sphere beyond the range of 32-bit floats",
                    ));
                }
                self.spheres.push(Sphere {
                    center,
                    radius,
                    flip_normals: s.flip_normals.unwrap_or(false),
                    material,
                });
                Ok(())
            }
            ShapeDesc::Quad(q) => {
                let raw = shapes::quad(q, &path)?;
                let m = Materials::All(required("")?);
                self.push(raw, &transform, Shading::Flat, path.clone(), m, &path)
            }
            ShapeDesc::Box(b) => {
                let raw = shapes::cube(b, &path)?;
                let m = Materials::All(required("")?);
                self.push(raw, &transform, Shading::Flat, path.clone(), m, &path)
            }
            ShapeDesc::Triangles(t) => {
                let m = Materials::All(required("")?);
                let raw = shapes::triangles(t, &path, self.remaining())?;
                self.push(raw, &transform, Shading::SourceOnly, path.clone(), m, &path)
            }
            ShapeDesc::Mesh(m) => self.mesh_file(&path, m, material, &transform),
            ShapeDesc::Instance(d) => self.instance(&path, d, material, &transform),
        }
    }

    /// A `mesh` object: an OBJ or PLY file.
    fn mesh_file(
        &mut self,
        path: &str,
        m: &MeshDesc,
        material: Option<u32>,
        transform: &Transform,
    ) -> Result<(), SceneError> {
        let file_path = join_path(path, "file");
        paths::check_relative(&m.file, &file_path)?;
        let ext = paths::extension(&m.file);
        if ext != "obj" && ext != "ply" {
            return Err(SceneError::invalid(
                &file_path,
                format!(
                    "\"{}\": unsupported mesh format (expected .obj or .ply)",
                    m.file
                ),
            ));
        }
        let asset = paths::resolve(self.root, &m.file, &file_path)?;
        let data = paths::read(self.root, &asset, &file_path)?;
        let in_file = |e: FileError| SceneError::Parse {
            path: file_path.clone(),
            file: m.file.clone(),
            line: e.line,
            msg: e.msg,
        };
        let missing =
            |why: String| SceneError::invalid(path, format!("missing field \"material\" ({why})"));
        let (raw, materials) = if ext == "ply" {
            let raw = ply::parse(&data, self.remaining()).map_err(in_file)?;
            let m = material.ok_or_else(|| missing("PLY files name no materials".into()))?;
            (raw, Materials::All(m))
        } else {
            let parsed = obj::parse(&data, self.remaining()).map_err(in_file)?;
            match material {
                Some(mi) => (parsed.raw, Materials::All(mi)),
                None => {
                    // Map each triangle's usemtl name to a scene material.
                    let mut ids: Vec<Option<u32>> = vec![None; parsed.names.len()];
                    let mut per_triangle = Vec::with_capacity(parsed.triangle_names.len());
                    for name in &parsed.triangle_names {
                        let Some(n) = *name else {
                            return Err(missing(format!(
                                "\"{}\" has faces without usemtl",
                                m.file
                            )));
                        };
                        let slot = &mut ids[n as usize];
                        if slot.is_none() {
                            let name = &parsed.names[n as usize];
                            let Some(&id) = self.by_name.get(name.as_str()) else {
                                return Err(SceneError::invalid(
                                    &file_path,
                                    format!(
                                        "\"{}\" uses material \"{name}\" (usemtl), which is not in the scene's materials; add it or give \"material\"",
                                        m.file
                                    ),
                                ));
                            };
                            *slot = Some(id);
                        }
                        per_triangle.extend(*slot);
                    }
                    (parsed.raw, Materials::PerTriangle(per_triangle))
                }
            }
        };
        let shading = if m.smooth.unwrap_or(true) {
            Shading::Smooth
        } else {
            Shading::Flat
        };
        let name = format!("{path} ({})", m.file);
        self.push(raw, transform, shading, name, materials, path)
    }

    /// Moves a mesh to world space and adds it, within the triangle limit.
    fn push(
        &mut self,
        raw: RawMesh,
        transform: &Transform,
        shading: Shading,
        name: String,
        materials: Materials,
        path: &str,
    ) -> Result<(), SceneError> {
        if raw.indices.is_empty() {
            tracing::warn!("{name}: no triangles; skipped");
            return Ok(());
        }
        let count = raw.indices.len();
        if count > self.remaining() {
            return Err(SceneError::invalid(
                path,
                format!(
                    "the scene exceeds the limit of {} triangles",
                    self.limits.max_triangles
                ),
            ));
        }
        let mesh = to_world(raw, transform, shading, name, materials, path)?;
        self.triangles += count;
        if self.defining {
            let lo = mesh
                .positions
                .iter()
                .fold(DVec3::INFINITY, |a, &p| a.min(p));
            let hi = mesh
                .positions
                .iter()
                .fold(DVec3::NEG_INFINITY, |a, &p| a.max(p));
            self.prototype_facts.push(PrototypeFacts { lo, hi });
            self.prototypes.push(mesh);
        } else {
            self.meshes.push(mesh);
        }
        Ok(())
    }
}
