//! The vkraytracing thesis's `.scn` scenes (JSON, read by its `SceneLoader::Scene`) → candela's
//! scene document. docs/import.md maps every field; the loader's own defaults apply where a field
//! is missing (resolution 1280 × 720, maxdepth 5, camera at the origin looking at (0, 0, 2) with
//! a 45° vertical field of view, materials white with roughness 1).
//!
//! Materials are Disney-style and become `principled` (opacity o → spec_trans 1 − o; the
//! thesis's textures read their red channel after sRGB decoding, as candela's do; `tiling` is the
//! uv scale). Entities: `mesh` (an OBJ; `material` replaces every usemtl, else each usemtl names a
//! scene material and faces before the first usemtl take `default_material`, the entity's or the
//! scene's) placed by position · scale · rotation (x, then y, then z, radians: glm's order), and
//! `sphere` (position and radius; rotation and scale do not apply to spheres in the thesis).
//! Errors name the file and the JSON path.

use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;

use glam::{DMat4, DVec3};
use serde_json::{json, Map, Value};

use super::diag::{Loc, Report};
use super::doc::Doc;
use super::files::{resolve_in, to_slash};
use super::meshes::{file_error, read_file};
use super::xform::transform_value;
use super::{ImportOptions, ImportResult};
use crate::scene::{obj, SceneError};

/// Top-level fields the thesis reads.
const TOP: &[&str] = &["resolution", "maxdepth", "camera", "materials", "entities"];
const CAMERA: &[&str] = &["position", "lookat", "fov", "antialiasing_radius"];
/// Material fields → candela principled fields (scalars).
const SCALARS: &[(&str, &str)] = &[
    ("metallic", "metallic"),
    ("roughness", "roughness"),
    ("subsurface", "subsurface"),
    ("speculartint", "spec_tint"),
    ("anisotropic", "anisotropic"),
    ("sheen", "sheen"),
    ("sheentint", "sheen_tint"),
    ("clearcoat", "clearcoat"),
    ("clearcoatgloss", "clearcoat_gloss"),
];
const TEXTURES: &[&str] = &[
    "albedotexture",
    "metallictexture",
    "roughnesstexture",
    "opacitytexture",
    "masktexture",
    "normaltexture",
    "emissiontexture",
    "anisotropictexture",
];

struct Ctx {
    doc: Doc,
    report: Report,
    file: Arc<str>,
    dir: std::path::PathBuf,
    limits: crate::scene::Limits,
    /// .scn material name → candela material (name) and its value.
    materials: HashMap<String, (String, Value)>,
}

/// A place in `file`: a JSON path.
fn at_of(file: &Arc<str>, path: &str) -> Loc {
    Loc::file(&Arc::from(format!("{file}: {path}")))
}

impl Ctx {
    fn at(&self, path: &str) -> Loc {
        at_of(&self.file, path)
    }

    /// Unknown keys of `obj` at `path` are unsupported (ignored under --lenient).
    fn known(
        &mut self,
        obj: &Map<String, Value>,
        path: &str,
        known: &[&str],
    ) -> Result<(), SceneError> {
        for k in obj.keys() {
            if !known.contains(&k.as_str()) {
                let p = if path.is_empty() {
                    k.clone()
                } else {
                    format!("{path}.{k}")
                };
                self.report.unsupported(
                    &self.at(&p),
                    &format!("field \"{k}\" is not supported"),
                    "ignored",
                )?;
            }
        }
        Ok(())
    }
}

/// A number at `path`.
fn number(v: &Value, loc: &Loc) -> Result<f64, SceneError> {
    v.as_f64().ok_or_else(|| loc.error("expected a number"))
}

/// `[x, y, z]` at `path`.
fn vec3(v: &Value, loc: &Loc) -> Result<DVec3, SceneError> {
    match v
        .as_array()
        .map(|a| a.iter().map(Value::as_f64).collect::<Option<Vec<f64>>>())
    {
        Some(Some(a)) if a.len() == 3 => Ok(DVec3::new(a[0], a[1], a[2])),
        _ => Err(loc.error("expected [x, y, z]")),
    }
}

/// Imports the .scn file `path`.
pub(crate) fn import(path: &Path, opts: &ImportOptions) -> ImportResult {
    let file: Arc<str> = Arc::from(path.display().to_string());
    let bytes = super::read_file(path)?;
    let data: Value = serde_json::from_slice(&bytes).map_err(|e| {
        Loc::new(&file, Some(e.line())).error(format!("JSON error at column {}: {e}", e.column()))
    })?;
    let Some(top) = data.as_object() else {
        return Err(Loc::file(&file).error("a .scn scene must be a JSON object"));
    };
    let mut ctx = Ctx {
        doc: Doc::new(),
        report: Report::new(opts.lenient),
        file: file.clone(),
        dir: super::folder_of(path),
        limits: opts.limits.clone(),
        materials: HashMap::new(),
    };
    ctx.known(top, "", TOP)?;
    // Step 1: film, depth, camera.
    let (w, h) = match top.get("resolution") {
        None => (1280, 720),
        Some(v) => match v
            .as_array()
            .map(|a| a.iter().map(Value::as_u64).collect::<Option<Vec<u64>>>())
        {
            Some(Some(r)) if r.len() == 2 => (r[0], r[1]),
            _ => return Err(ctx.at("resolution").error("expected [width, height]")),
        },
    };
    ctx.doc.film.insert("width".into(), json!(w));
    ctx.doc.film.insert("height".into(), json!(h));
    // The thesis counts path segments, as Mitsuba's max_depth does.
    let depth = match top.get("maxdepth") {
        None => 5,
        Some(v) => v
            .as_i64()
            .filter(|d| *d >= 1)
            .ok_or_else(|| ctx.at("maxdepth").error("expected a positive integer"))?,
    };
    ctx.doc.render.insert("integrator".into(), json!("nee"));
    ctx.doc.render.insert("max_depth".into(), json!(depth));
    camera(&mut ctx, top.get("camera"))?;
    // Step 2: materials (and the implicit default), then entities.
    let list = match top.get("materials") {
        None => Vec::new(),
        Some(Value::Array(a)) => a.clone(),
        Some(_) => return Err(ctx.at("materials").error("expected an array")),
    };
    for (i, m) in list.iter().enumerate() {
        material(&mut ctx, i, m)?;
    }
    if !ctx.materials.contains_key("default_material") {
        let value = defaults();
        let name = ctx
            .doc
            .material("default_material", value.clone(), &ctx.at("materials"));
        ctx.materials
            .insert("default_material".into(), (name, value));
    }
    let entities = match top.get("entities") {
        None => Vec::new(),
        Some(Value::Array(a)) => a.clone(),
        Some(_) => return Err(ctx.at("entities").error("expected an array")),
    };
    for (i, e) in entities.iter().enumerate() {
        entity(&mut ctx, i, e)?;
    }
    let Ctx { doc, report, .. } = ctx;
    let (value, assets, origins) = doc.finish();
    Ok((value, assets, origins, report.warnings))
}

fn camera(ctx: &mut Ctx, v: Option<&Value>) -> Result<(), SceneError> {
    let empty = Map::new();
    let c = match v {
        None => &empty,
        Some(Value::Object(m)) => m,
        Some(_) => return Err(ctx.at("camera").error("expected an object")),
    };
    ctx.known(c, "camera", CAMERA)?;
    let get = |k: &str, d: DVec3| {
        c.get(k)
            .map_or(Ok(d), |v| vec3(v, &ctx.at(&format!("camera.{k}"))))
    };
    let position = get("position", DVec3::ZERO)?;
    let look_at = get("lookat", DVec3::new(0.0, 0.0, 2.0))?;
    let fov = c
        .get("fov")
        .map_or(Ok(45.0), |v| number(v, &ctx.at("camera.fov")))?;
    ctx.doc
        .camera
        .insert("position".into(), json!(position.to_array()));
    ctx.doc
        .camera
        .insert("look_at".into(), json!(look_at.to_array()));
    ctx.doc.camera.insert("fov_y".into(), json!(fov));
    // The thesis jitters each primary ray by a Gaussian of this standard deviation (pixels).
    let aa = c.get("antialiasing_radius").map_or(Ok(0.15), |v| {
        number(v, &ctx.at("camera.antialiasing_radius"))
    })?;
    let filter = if aa > 0.0 {
        json!({"type": "gaussian", "stddev": aa})
    } else {
        json!("box")
    };
    ctx.doc.film.insert("filter".into(), filter);
    Ok(())
}

/// The thesis's `objl::Material` defaults as principled fields.
fn defaults() -> Value {
    json!({"type": "principled", "base_color": 1.0, "metallic": 0.0, "roughness": 1.0, "specular": 0.5,
           "spec_tint": 0.0, "anisotropic": 0.0, "sheen": 0.0, "sheen_tint": 0.0, "clearcoat": 0.0,
           "clearcoat_gloss": 0.0, "ior": 1.5})
}

fn material(ctx: &mut Ctx, i: usize, m: &Value) -> Result<(), SceneError> {
    let path = format!("materials[{i}]");
    let Some(m) = m.as_object() else {
        return Err(ctx.at(&path).error("expected an object"));
    };
    let mut known: Vec<&str> = vec![
        "name",
        "color",
        "emission",
        "opacity",
        "ior",
        "anisotropic_direction",
        "tiling",
    ];
    known.extend(SCALARS.iter().map(|s| s.0));
    known.extend(TEXTURES);
    ctx.known(m, &path, &known)?;
    let name = m
        .get("name")
        .and_then(Value::as_str)
        .ok_or_else(|| {
            ctx.at(&format!("{path}.name"))
                .error("missing (a material needs a \"name\")")
        })?
        .to_string();
    let mut out = defaults();
    let file = ctx.file.clone();
    let num = |k: &str| {
        m.get(k)
            .map(|v| number(v, &at_of(&file, &format!("{path}.{k}"))))
            .transpose()
    };
    if let Some(c) = m.get("color") {
        out["base_color"] = json!(vec3(c, &ctx.at(&format!("{path}.color")))?.to_array());
    }
    for (k, field) in SCALARS {
        if let Some(x) = num(k)? {
            // The thesis clamps roughness to 1e-4 and anisotropic to [0, 1].
            let x = match *k {
                "roughness" => x.max(1e-4),
                "anisotropic" => x.clamp(0.0, 1.0),
                _ => x,
            };
            out[*field] = json!(x);
        }
    }
    if let Some(ior) = num("ior")? {
        out["ior"] = json!(ior);
    }
    if let Some(o) = num("opacity")? {
        out["spec_trans"] = json!(1.0 - o);
    }
    if let Some(e) = m.get("emission") {
        let e = vec3(e, &ctx.at(&format!("{path}.emission")))?;
        if e != DVec3::ZERO {
            out["emission"] = json!(e.to_array());
        }
    }
    if let Some(d) = m.get("anisotropic_direction") {
        if vec3(d, &ctx.at(&format!("{path}.anisotropic_direction")))? != DVec3::X {
            ctx.report.unsupported(
                &ctx.at(&format!("{path}.anisotropic_direction")),
                "an anisotropy direction is not supported (candela's follows the uv tangent)",
                "ignored",
            )?;
        }
    }
    let tiling = num("tiling")?.unwrap_or(1.0);
    textures(ctx, m, &path, tiling, &mut out)?;
    let candela = ctx.doc.material(&name, out.clone(), &ctx.at(&path));
    ctx.materials.insert(name, (candela, out));
    Ok(())
}

/// The material's textures (red channel for scalars, after sRGB decoding as the thesis does).
fn textures(
    ctx: &mut Ctx,
    m: &Map<String, Value>,
    path: &str,
    tiling: f64,
    out: &mut Value,
) -> Result<(), SceneError> {
    for key in TEXTURES {
        let Some(v) = m.get(*key) else { continue };
        let at = ctx.at(&format!("{path}.{key}"));
        let name = v.as_str().ok_or_else(|| at.error("expected a file name"))?;
        let rel = resolve_in(&ctx.dir, Path::new(""), name)
            .map(|p| to_slash(&p))
            .map_err(|e| at.error(e))?;
        let mut tex = json!({"texture": rel});
        if tiling != 1.0 {
            if tiling.fract() != 0.0 {
                ctx.report.warn(&at, "a non-integer tiling shifts the texture vertically against the thesis (its v runs top-down)");
            }
            tex["scale"] = json!([tiling, tiling]);
        }
        match *key {
            "albedotexture" => out["base_color"] = tex,
            "metallictexture" => out["metallic"] = tex,
            "roughnesstexture" => out["roughness"] = tex,
            "masktexture" => out["alpha_mask"] = tex,
            "opacitytexture" => {
                let dir = ctx.dir.clone();
                let file = ctx.doc.derived_texture(&dir, &rel, None, "opacity", |t| [1.0 - t[0]; 3])?;
                let mut t = json!({"texture": file});
                if let Some(s) = tex.get("scale") {
                    t["scale"] = s.clone();
                }
                out["spec_trans"] = t;
            }
            other => ctx.report.unsupported(&at, &format!("\"{other}\" is not supported (candela has no normal maps, emission textures or anisotropy direction maps)"), "ignored")?,
        }
    }
    Ok(())
}

fn entity(ctx: &mut Ctx, i: usize, e: &Value) -> Result<(), SceneError> {
    let path = format!("entities[{i}]");
    let Some(e) = e.as_object() else {
        return Err(ctx.at(&path).error("expected an object"));
    };
    let file = ctx.file.clone();
    let at = |k: &str| at_of(&file, &format!("{path}.{k}"));
    let ty = e
        .get("type")
        .and_then(Value::as_str)
        .ok_or_else(|| at("type").error("missing (\"mesh\" or \"sphere\")"))?;
    let get = |k: &str, d: DVec3| e.get(k).map_or(Ok(d), |v| vec3(v, &at(k)));
    let (position, rotation, scale) = (
        get("position", DVec3::ZERO)?,
        get("rotation", DVec3::ZERO)?,
        get("scale", DVec3::ONE)?,
    );
    let material_of = |ctx: &Ctx, k: &str| -> Result<Option<String>, SceneError> {
        match e.get(k) {
            None => Ok(None),
            Some(v) => {
                let n = v.as_str().ok_or_else(|| {
                    ctx.at(&format!("{path}.{k}"))
                        .error("expected a material name")
                })?;
                ctx.materials
                    .get(n)
                    .map(|(c, _)| Some(c.clone()))
                    .ok_or_else(|| {
                        ctx.at(&format!("{path}.{k}"))
                            .error(format!("no material \"{n}\""))
                    })
            }
        }
    };
    let loc = ctx.at(&path);
    match ty {
        "sphere" => {
            ctx.known(
                e,
                &path,
                &[
                    "type",
                    "position",
                    "rotation",
                    "scale",
                    "radius",
                    "material",
                    "inverted_normal",
                    "anisotropic_direction",
                ],
            )?;
            let radius = e
                .get("radius")
                .map(|v| number(v, &at("radius")))
                .transpose()?
                .ok_or_else(|| at("radius").error("missing"))?;
            let material = material_of(ctx, "material")?
                .ok_or_else(|| at("material").error("missing (a sphere needs a material)"))?;
            let mut o = json!({"type": "sphere", "center": position.to_array(), "radius": radius, "material": material});
            if e.get("inverted_normal")
                .and_then(Value::as_i64)
                .is_some_and(|n| n < 0)
            {
                o["flip_normals"] = json!(true);
            }
            if e.get("anisotropic_direction")
                .is_some_and(|d| d != &json!([0, 0, 0]) && d != &json!([0.0, 0.0, 0.0]))
            {
                ctx.report.unsupported(
                    &at("anisotropic_direction"),
                    "an anisotropy direction is not supported",
                    "ignored",
                )?;
            }
            ctx.doc.object(o, &loc);
        }
        "mesh" => {
            ctx.known(
                e,
                &path,
                &[
                    "type",
                    "position",
                    "rotation",
                    "scale",
                    "file",
                    "material",
                    "default_material",
                ],
            )?;
            let Some(file) = e.get("file").and_then(Value::as_str) else {
                // The thesis skips a mesh without a file.
                ctx.report.warn(
                    &loc,
                    "a mesh without \"file\" is skipped (as the thesis does)",
                );
                return Ok(());
            };
            // glm: translate · scale · rotate x · rotate y · rotate z (radians).
            let m = DMat4::from_translation(position)
                * DMat4::from_scale(scale)
                * DMat4::from_rotation_x(rotation.x)
                * DMat4::from_rotation_y(rotation.y)
                * DMat4::from_rotation_z(rotation.z);
            let replace = material_of(ctx, "material")?;
            let fallback = match material_of(ctx, "default_material")? {
                Some(n) => n,
                None => ctx.materials["default_material"].0.clone(),
            };
            mesh(ctx, &path, file, replace, &fallback, &m)?;
        }
        other => {
            ctx.report.unsupported(
                &at("type"),
                &format!("entity type \"{other}\" is not supported (mesh and sphere are)"),
                "skipped",
            )?;
        }
    }
    Ok(())
}

/// An OBJ entity: the file as it is when its usemtl names are all scene materials (or
/// `material` replaces them), else split into one mesh per resolved material.
fn mesh(
    ctx: &mut Ctx,
    path: &str,
    file: &str,
    replace: Option<String>,
    fallback: &str,
    m: &DMat4,
) -> Result<(), SceneError> {
    let at = ctx.at(&format!("{path}.file"));
    let rel = resolve_in(&ctx.dir, Path::new(""), file)
        .map(|p| to_slash(&p))
        .map_err(|e| at.error(e))?;
    if !rel.to_ascii_lowercase().ends_with(".obj") {
        return Err(at.error(format!("\"{file}\": the thesis loads OBJ meshes only")));
    }
    let bytes = read_file(&ctx.dir, &rel, file).map_err(|m| at.error(m))?;
    let parsed =
        obj::parse(&bytes, ctx.limits.max_triangles).map_err(|e| at.error(file_error(file, e)))?;
    // The thesis computes face normals for an OBJ without normals.
    let smooth = parsed.raw.normals.is_some();
    let place = |mut o: Value| {
        if let Some(t) = transform_value(m) {
            o["transform"] = t;
        }
        o
    };
    let loc = ctx.at(path);
    if let Some(material) = replace {
        ctx.doc.object(
            place(json!({"type": "mesh", "file": rel, "smooth": smooth, "material": material})),
            &loc,
        );
        return Ok(());
    }
    // Step 1: each triangle's material by the thesis's rules.
    let mut resolved: Vec<String> = Vec::with_capacity(parsed.triangle_names.len());
    let mut by_name: HashMap<u32, String> = HashMap::new();
    for name in &parsed.triangle_names {
        let r = match name {
            None => fallback.to_string(),
            Some(n) => match by_name.get(n) {
                Some(r) => r.clone(),
                None => {
                    let mtl = &parsed.names[*n as usize];
                    let r = match ctx.materials.get(mtl) {
                        Some((c, _)) => c.clone(),
                        None => {
                            ctx.report.unsupported(&at, &format!("\"{file}\" uses material \"{mtl}\" (usemtl), which is not in the scene's materials"), "the default material")?;
                            fallback.to_string()
                        }
                    };
                    by_name.insert(*n, r.clone());
                    r
                }
            },
        };
        resolved.push(r);
    }
    // Step 2: one object when candela's own usemtl rule gives the same, else one per material.
    let direct = parsed.triangle_names.iter().all(|n| n.is_some())
        && by_name.iter().all(|(n, r)| &parsed.names[*n as usize] == r);
    if direct {
        ctx.doc.object(
            place(json!({"type": "mesh", "file": rel, "smooth": smooth})),
            &loc,
        );
        return Ok(());
    }
    let mut groups: Vec<String> = resolved.clone();
    groups.dedup();
    let mut seen = std::collections::HashSet::new();
    for g in groups.into_iter().filter(|g| seen.insert(g.clone())) {
        let mut part = parsed.raw.clone();
        part.indices = parsed
            .raw
            .indices
            .iter()
            .zip(&resolved)
            .filter(|(_, r)| **r == g)
            .map(|(t, _)| *t)
            .collect();
        let stem = Path::new(&rel)
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let mut o = ctx.doc.mesh_object(&format!("{stem}_{g}"), &part);
        o["smooth"] = json!(smooth);
        o["material"] = json!(g);
        ctx.doc.object(place(o), &loc);
    }
    Ok(())
}

#[cfg(test)]
mod tests;
