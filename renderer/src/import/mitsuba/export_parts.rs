//! Materials, textures and shapes of the Mitsuba export (tests/mitsuba/ref_materials.py and
//! ref_shapes.py, as XML): each material once as a `<bsdf id="NAME">` (twosided unless
//! `two_sided` is false or it transmits; `mask` around it for an alpha mask), each object as a
//! shape referring to it, with an `area` emitter when the material emits.

use std::collections::{HashMap, HashSet};

use glam::{DMat4, DVec3};
use serde_json::Value;

use super::export::{num, untranslatable, El, Export};
use crate::film::Image;
use crate::import::meshes::{flip_v, reverse_winding, to_ply};
use crate::scene::desc::{Channel, TextureRefDesc, TransformDesc, TrianglesDesc};
use crate::scene::paths::AssetRoot;
use crate::scene::texture::decode_file;
use crate::scene::transform::Transform;
use crate::scene::{obj, ply, shapes, SceneError};

/// The materials defined so far and what the shapes needed.
pub(crate) struct Parts {
    bsdfs: Vec<El>,
    defined: HashSet<String>,
    /// `<shape type="shapegroup">`s for instances (export_instances.rs), the (definition,
    /// material) pairs they hold, and each pair's unique name.
    pub(super) groups: Vec<El>,
    pub(super) group_defined: HashSet<(String, Option<String>)>,
    pub(super) group_stems: HashMap<(String, Option<String>), String>,
    /// Some material has an alpha mask (Mitsuba then needs `volpath`).
    pub uses_mask: bool,
}

/// How a scalar texture's value becomes Mitsuba's.
type ValueFn = fn(f32) -> f32;

impl Parts {
    pub fn new() -> Self {
        Parts {
            bsdfs: Vec::new(),
            defined: HashSet::new(),
            groups: Vec::new(),
            group_defined: HashSet::new(),
            group_stems: HashMap::new(),
            uses_mask: false,
        }
    }

    /// The `<bsdf>` definitions, in the order first used.
    pub fn take_bsdfs(&mut self) -> Vec<El> {
        std::mem::take(&mut self.bsdfs)
    }

    /// The shape groups the instances refer to (after the BSDFs, before the shapes).
    pub fn take_groups(&mut self) -> Vec<El> {
        std::mem::take(&mut self.groups)
    }

    /// `objects[i]` as a `<shape>` (an instance as export_instances.rs writes it).
    pub fn shape(&mut self, ex: &mut Export, i: usize, o: &Value) -> Result<El, SceneError> {
        let path = format!("objects[{i}]");
        if o["type"] == "instance" {
            return self.instance(ex, &path, o);
        }
        self.shape_at(ex, &path, &i.to_string(), o)
    }

    /// Object `o` (at JSON path `path`) as a `<shape>`; files it needs are named after `stem`.
    pub(super) fn shape_at(
        &mut self,
        ex: &mut Export,
        path: &str,
        stem: &str,
        o: &Value,
    ) -> Result<El, SceneError> {
        let path = path.to_string();
        let kind = o["type"].as_str().unwrap_or("");
        let desc: Option<TransformDesc> = serde_json::from_value(o["transform"].clone()).ok();
        let xf = Transform::from_desc(desc.as_ref(), &format!("{path}.transform"))?.matrix;
        let mut material = o["material"].as_str().map(String::from);
        let mut shape = match kind {
            "mesh" => {
                let file = o["file"].as_str().unwrap_or("");
                let smooth = o["smooth"].as_bool().unwrap_or(true);
                let ext = crate::scene::paths::extension(file);
                let bytes = std::fs::read(ex.base.join(file))
                    .map_err(|e| SceneError::io(&format!("{path}.file"), file, &e))?;
                let parse_err = |msg: String| SceneError::invalid(format!("{path}.file"), msg);
                let mut parsed = None;
                if ext == "obj" && material.is_none() {
                    // Mitsuba ignores usemtl: one name only.
                    let m = obj::parse(&bytes, usize::MAX).map_err(|e| parse_err(e.msg))?;
                    let used: HashSet<Option<u32>> = m.triangle_names.iter().copied().collect();
                    match used.into_iter().collect::<Vec<_>>().as_slice() {
                        [Some(n)] => material = Some(m.names[*n as usize].clone()),
                        _ => {
                            return Err(untranslatable(
                                &path,
                                "an OBJ whose usemtl names more than one material (Mitsuba ignores usemtl)",
                            ))
                        }
                    }
                    parsed = Some(m.raw);
                }
                let textured = material
                    .as_ref()
                    .is_some_and(|m| ex.doc["materials"][m].to_string().contains("\"texture\""));
                // Mitsuba reads a PLY's v = 0 on the top texel row, candela on the bottom.
                let flip_ply = ext == "ply" && textured;
                // Under a mirroring to_world Mitsuba keeps a mesh's vertex order, so where no
                // vertex normals set its front (none, or face_normals) that front is the other
                // side than candela's (pbrt's rule, docs/scene-format.md's transform): such a
                // mesh is written with its winding reversed (the converse of the importer's).
                let mirrored = xf.determinant() < 0.0 && matches!(ext.as_str(), "obj" | "ply");
                let mut rewritten = None;
                if flip_ply || mirrored {
                    let mut raw = match parsed {
                        Some(raw) => raw,
                        None if ext == "obj" => {
                            obj::parse(&bytes, usize::MAX)
                                .map_err(|e| parse_err(e.msg))?
                                .raw
                        }
                        None => ply::parse(&bytes, usize::MAX).map_err(|e| parse_err(e.msg))?,
                    };
                    let reverse = mirrored && (!smooth || raw.normals.is_none());
                    if reverse {
                        reverse_winding(&mut raw);
                    }
                    if reverse || flip_ply {
                        flip_v(&mut raw);
                        let name = format!("mesh_{stem}{}.ply", reversed_suffix(reverse));
                        rewritten = Some(ex.file(&name, to_ply(&raw)));
                    }
                }
                match rewritten {
                    Some(rel) => El::plugin("shape", "ply").string("filename", &rel),
                    None => El::plugin("shape", &ext).string("filename", file),
                }
                .boolean("face_normals", !smooth)
            }
            "triangles" => {
                let t: TrianglesDesc =
                    serde_json::from_value(strip(o, &["type", "material", "transform"]))
                        .map_err(|e| SceneError::invalid(&path, e.to_string()))?;
                let mut raw = shapes::triangles(&t, &path, usize::MAX)?;
                flip_v(&mut raw);
                let has_normals = raw.normals.is_some();
                // Mirrored without normals: reversed, as a mesh's above.
                let reverse = xf.determinant() < 0.0 && !has_normals;
                if reverse {
                    reverse_winding(&mut raw);
                }
                let name = format!("triangles_{stem}{}.ply", reversed_suffix(reverse));
                let rel = ex.file(&name, to_ply(&raw));
                // Without normals: flat shading, not Mitsuba's computed vertex normals.
                El::plugin("shape", "ply")
                    .string("filename", &rel)
                    .boolean("face_normals", !has_normals)
            }
            "sphere" => {
                let c = vec3(&o["center"]);
                let r = o["radius"].as_f64().unwrap_or(1.0);
                let m = xf * DMat4::from_translation(c) * DMat4::from_scale(DVec3::splat(r));
                El::plugin("shape", "sphere")
                    .boolean("flip_normals", o["flip_normals"].as_bool().unwrap_or(false))
                    .matrix("to_world", &m)
            }
            "quad" => {
                // Mitsuba's rectangle: [-1,1]² at z = 0, normal +z, uv ((x+1)/2, (y+1)/2).
                let (org, eu, ev) = (vec3(&o["origin"]), vec3(&o["edge_u"]), vec3(&o["edge_v"]));
                let n = eu.cross(ev).normalize();
                let c = org + 0.5 * (eu + ev);
                let m = DMat4::from_cols(
                    (0.5 * eu).extend(0.0),
                    (0.5 * ev).extend(0.0),
                    n.extend(0.0),
                    c.extend(1.0),
                );
                El::plugin("shape", "rectangle").matrix("to_world", &(xf * m))
            }
            "box" => {
                let (lo, hi) = (vec3(&o["min"]), vec3(&o["max"]));
                let m =
                    DMat4::from_translation(0.5 * (lo + hi)) * DMat4::from_scale(0.5 * (hi - lo));
                El::plugin("shape", "cube").matrix("to_world", &(xf * m))
            }
            other => {
                return Err(untranslatable(
                    &format!("{path}.type"),
                    &format!("object type \"{other}\""),
                ))
            }
        };
        if matches!(kind, "mesh" | "triangles") && xf != DMat4::IDENTITY {
            shape = shape.matrix("to_world", &xf);
        }
        let Some(name) = material else {
            return Err(SceneError::invalid(format!("{path}.material"), "missing"));
        };
        let emission = self.define(ex, &name)?;
        shape = shape.child(El::new("ref").attr("id", &name));
        if let Some(e) = emission {
            shape = shape.child(El::plugin("emitter", "area").rgb("radiance", e));
        }
        Ok(shape)
    }

    /// Defines material `name` once; returns its emission.
    pub(super) fn define(
        &mut self,
        ex: &mut Export,
        name: &str,
    ) -> Result<Option<[f64; 3]>, SceneError> {
        let m = ex.doc["materials"][name].clone();
        let path = crate::scene::key_path("materials", name);
        let emission = m
            .get("emission")
            .map(color3)
            .filter(|e| e.iter().any(|&x| x != 0.0));
        if self.defined.insert(name.to_string()) {
            let mut bsdf = self.bsdf(ex, &m, &path)?;
            let kind = m["type"].as_str().unwrap_or("");
            let transmissive = kind == "dielectric"
                || (kind == "principled"
                    && m.get("spec_trans")
                        .is_some_and(|v| v != &Value::from(0) && v != &Value::from(0.0)));
            if m["two_sided"].as_bool().unwrap_or(true) && !transmissive {
                bsdf = El::plugin("bsdf", "twosided").child(bsdf);
            }
            if let Some(mask) = m.get("alpha_mask") {
                if emission.is_some() {
                    return Err(untranslatable(
                        &path,
                        "emission with alpha_mask (Mitsuba's area emitter ignores the mask)",
                    ));
                }
                self.uses_mask = true;
                let opacity = self.mask(ex, mask, &format!("{path}.alpha_mask"), name)?;
                bsdf = El::plugin("bsdf", "mask").child(opacity).child(bsdf);
            }
            self.bsdfs.push(bsdf.attr("id", name));
        }
        Ok(emission)
    }

    /// The BSDF of one material (ref_materials.py).
    fn bsdf(&mut self, ex: &mut Export, m: &Value, path: &str) -> Result<El, SceneError> {
        let f = |k: &str, d: f64| m.get(k).and_then(Value::as_f64).unwrap_or(d);
        let tag = path.rsplit('.').next().unwrap_or("m").to_string();
        Ok(match m["type"].as_str().unwrap_or("") {
            "diffuse" => {
                let r = self.color(ex, m.get("reflectance"), 0.5, "reflectance", path, &tag)?;
                El::plugin("bsdf", "diffuse").child(r)
            }
            "conductor" => {
                let rough = m.get("roughness").cloned().unwrap_or(Value::from(0.0));
                let a = m.get("anisotropy").cloned().unwrap_or(Value::from(0.0));
                if a.is_object() {
                    return Err(untranslatable(
                        &format!("{path}.anisotropy"),
                        "a textured anisotropy",
                    ));
                }
                let a = a.as_f64().unwrap_or(0.0);
                let mut b = if rough.as_f64() == Some(0.0) {
                    El::plugin("bsdf", "conductor")
                } else if a == 0.0 {
                    El::plugin("bsdf", "roughconductor")
                        .string("distribution", "ggx")
                        .child(self.scalar(ex, &rough, "alpha", path, &tag, |x| x * x)?)
                } else {
                    // candela's anisotropy is Mitsuba principled's mapping: aspect = √(1 − 0.9a),
                    // alpha_u = alpha / aspect, alpha_v = alpha · aspect, alpha = roughness².
                    let r = rough.as_f64().ok_or_else(|| {
                        untranslatable(
                            &format!("{path}.roughness"),
                            "a textured roughness with anisotropy",
                        )
                    })?;
                    let aspect = (1.0 - 0.9 * a).sqrt();
                    El::plugin("bsdf", "roughconductor")
                        .string("distribution", "ggx")
                        .float("alpha_u", r * r / aspect)
                        .float("alpha_v", r * r * aspect)
                };
                match (m.get("eta"), m.get("k")) {
                    (Some(e), Some(k)) => b = b.rgb("eta", color3(e)).rgb("k", color3(k)),
                    _ => b = b.string("material", "none"),
                }
                let r = self.color(
                    ex,
                    m.get("reflectance"),
                    1.0,
                    "specular_reflectance",
                    path,
                    &tag,
                )?;
                b.child(r)
            }
            "dielectric" => {
                let rough = m.get("roughness").cloned().unwrap_or(Value::from(0.0));
                let b = if rough.as_f64() == Some(0.0) {
                    El::plugin("bsdf", "dielectric")
                } else {
                    El::plugin("bsdf", "roughdielectric")
                        .string("distribution", "ggx")
                        .child(self.scalar(ex, &rough, "alpha", path, &tag, |x| x * x)?)
                };
                let t = self.color(
                    ex,
                    m.get("transmittance"),
                    1.0,
                    "specular_transmittance",
                    path,
                    &tag,
                )?;
                let r = self.color(
                    ex,
                    m.get("reflectance"),
                    1.0,
                    "specular_reflectance",
                    path,
                    &tag,
                )?;
                b.float("int_ior", f("ior", 1.5))
                    .float("ext_ior", 1.0)
                    .child(t)
                    .child(r)
            }
            "principled" => self.principled(ex, m, path, &tag)?,
            "phong" => return Err(untranslatable(path, "phong (no Mitsuba 3 equivalent)")),
            other => {
                return Err(untranslatable(
                    &format!("{path}.type"),
                    &format!("material type \"{other}\""),
                ))
            }
        })
    }

    fn principled(
        &mut self,
        ex: &mut Export,
        m: &Value,
        path: &str,
        tag: &str,
    ) -> Result<El, SceneError> {
        let ss = m.get("subsurface").cloned().unwrap_or(Value::from(0.0));
        if ss.as_f64() != Some(0.0) {
            return Err(untranslatable(
                &format!("{path}.subsurface"),
                "principled subsurface",
            ));
        }
        for k in ["spec_trans", "specular", "ior"] {
            if m.get(k).is_some_and(Value::is_object) {
                return Err(untranslatable(
                    &format!("{path}.{k}"),
                    "a textured specular / ior / spec_trans",
                ));
            }
        }
        let mut b = El::plugin("bsdf", "principled")
            .child(self.color(ex, m.get("base_color"), 0.8, "base_color", path, tag)?)
            .child(self.scalar(
                ex,
                m.get("roughness").unwrap_or(&Value::from(0.5)),
                "roughness",
                path,
                tag,
                |x| x,
            )?)
            .child(self.scalar(
                ex,
                m.get("clearcoat_gloss").unwrap_or(&Value::from(1.0)),
                "clearcoat_gloss",
                path,
                tag,
                |x| x,
            )?);
        // Mitsuba switches these lobes on by presence: pass them only when they matter.
        for (key, default) in [
            ("metallic", 0.0),
            ("spec_tint", 0.0),
            ("anisotropic", 0.0),
            ("sheen", 0.0),
            ("sheen_tint", 0.5),
            ("spec_trans", 0.0),
            ("clearcoat", 0.0),
        ] {
            let v = m.get(key).cloned().unwrap_or(Value::from(default));
            if v.is_object() || v.as_f64() != Some(0.0) {
                b = b.child(self.scalar(ex, &v, key, path, tag, |x| x)?);
            }
        }
        // Mitsuba has one Fresnel parameter: `eta` or `specular`.
        let (spec, ior) = (
            m.get("specular").and_then(Value::as_f64),
            m.get("ior").and_then(Value::as_f64),
        );
        Ok(match (spec, ior) {
            (Some(s), None) => b.float("specular", s),
            (s, eta) => {
                let eta = eta.unwrap_or(1.5);
                if let Some(s) = s {
                    if (s - ((eta - 1.0) / (eta + 1.0)).powi(2) / 0.08).abs() > 1e-4 {
                        return Err(untranslatable(
                            path,
                            "specular and ior disagree (Mitsuba derives one from the other)",
                        ));
                    }
                }
                b.float("eta", eta)
            }
        })
    }

    /// A colour field: `<rgb>` or a bitmap (a derived grey EXR when a channel is selected or an
    /// EXR/HDR is decoded as sRGB).
    fn color(
        &mut self,
        ex: &mut Export,
        v: Option<&Value>,
        default: f64,
        name: &str,
        path: &str,
        tag: &str,
    ) -> Result<El, SceneError> {
        let v = match v {
            None => {
                return Ok(El::new("rgb")
                    .attr("name", name)
                    .attr("value", num(default)))
            }
            Some(v) => v,
        };
        if !v.is_object() {
            let c = color3(v);
            return Ok(El::new("rgb").attr("name", name).attr(
                "value",
                format!("{}, {}, {}", num(c[0]), num(c[1]), num(c[2])),
            ));
        }
        let t = texture_ref(v, path, name)?;
        let ext = crate::scene::paths::extension(&t.texture);
        let linear_file = matches!(ext.as_str(), "exr" | "hdr");
        if t.channel.is_none() && !(linear_file && t.srgb == Some(true)) {
            let srgb = t.srgb.unwrap_or(!linear_file);
            return Ok(bitmap(name, &t.texture, !srgb, "bilinear", t.scale));
        }
        let c = t.channel;
        let file = self.derived(ex, &t, &format!("{tag}_{name}"), path, move |x| match c {
            Some(c) => {
                let v = c.pick(x);
                [v, v, v]
            }
            None => [x[0], x[1], x[2]],
        })?;
        Ok(bitmap(name, &file, true, "bilinear", t.scale))
    }

    /// A scalar field through `f`: `<float>` or a grey EXR of f(channel) per texel.
    fn scalar(
        &mut self,
        ex: &mut Export,
        v: &Value,
        name: &str,
        path: &str,
        tag: &str,
        f: ValueFn,
    ) -> Result<El, SceneError> {
        if !v.is_object() {
            return Ok(El::new("float")
                .attr("name", name)
                .attr("value", num(f(v.as_f64().unwrap_or(0.0) as f32) as f64)));
        }
        let t = texture_ref(v, path, name)?;
        let c = t.channel.unwrap_or(Channel::R);
        let file = self.derived(ex, &t, &format!("{tag}_{name}"), path, move |x| {
            let v = f(c.pick(x));
            [v, v, v]
        })?;
        Ok(bitmap(name, &file, true, "bilinear", t.scale))
    }

    /// An alpha mask: Mitsuba's `mask` blends, candela cuts at 0.5; nearest filtering of a binary
    /// mask cuts at texel edges as candela's bilinear-then-0.5 does (ref_materials.py `mask`).
    fn mask(
        &mut self,
        ex: &mut Export,
        v: &Value,
        path: &str,
        tag: &str,
    ) -> Result<El, SceneError> {
        let t = texture_ref(v, path, "")?;
        let c = t.channel.unwrap_or(Channel::R);
        let root = AssetRoot::dir(Some(ex.base));
        let (w, h, texels) = decode_file(root, &t.texture, t.srgb, &Default::default(), path)?;
        if texels.iter().any(|x| {
            let v = c.pick(*x);
            v != 0.0 && v != 1.0
        }) {
            return Err(untranslatable(
                path,
                "a non-binary alpha mask (Mitsuba's mask blends, candela cuts at 0.5)",
            ));
        }
        let img = Image::from_fn(w, h, |x, y| {
            let v = c.pick(texels[(y * w + x) as usize]);
            [v, v, v]
        });
        let file = ex.exr(&format!("{tag}_mask.exr"), &img)?;
        Ok(bitmap("opacity", &file, true, "nearest", t.scale))
    }

    /// A texture decoded as candela decodes it, mapped per texel, written as EXR.
    fn derived(
        &mut self,
        ex: &mut Export,
        t: &TextureRefDesc,
        name: &str,
        path: &str,
        f: impl Fn([f32; 4]) -> [f32; 3],
    ) -> Result<String, SceneError> {
        let root = AssetRoot::dir(Some(ex.base));
        let img = crate::import::derived::derive(root, &t.texture, t.srgb, &Default::default(), f)
            .map_err(|e| SceneError::invalid(path, e.to_string()))?;
        ex.exr(&format!("{}.exr", clean(name)), &img)
    }
}

/// What a mesh file written with its winding reversed adds to its name (the same definition can
/// be written both ways, by emitting instances placed in place).
fn reversed_suffix(reversed: bool) -> &'static str {
    if reversed {
        "_reversed"
    } else {
        ""
    }
}

/// `{"texture": ...}` read as the loader reads it.
fn texture_ref(v: &Value, path: &str, name: &str) -> Result<TextureRefDesc, SceneError> {
    serde_json::from_value(v.clone())
        .map_err(|e| SceneError::invalid(format!("{path}.{name}"), e.to_string()))
}

/// `<texture type="bitmap" name=...>`.
fn bitmap(name: &str, file: &str, raw: bool, filter: &str, scale: Option<[f64; 2]>) -> El {
    let mut b = El::plugin("texture", "bitmap")
        .attr("name", name)
        .string("filename", file)
        .boolean("raw", raw)
        .string("filter_type", filter)
        .string("wrap_mode", "repeat");
    if let Some([su, sv]) = scale.filter(|s| *s != [1.0, 1.0]) {
        // Mitsuba's v runs from the top row (candela's 1 − v): candela's row 1 − sv·v is Mitsuba's
        // sv·(1 − v) shifted by 1 − sv (a whole number of rows when sv is whole).
        let mut xf = El::new("transform")
            .attr("name", "to_uv")
            .child(El::new("scale").attr("x", num(su)).attr("y", num(sv)));
        let shift = (1.0 - sv).rem_euclid(1.0);
        if shift != 0.0 {
            xf = xf.child(El::new("translate").attr("x", "0").attr("y", num(shift)));
        }
        b = b.child(xf);
    }
    b
}

pub(super) fn clean(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '_' || c == '-' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// A JSON `[x, y, z]`.
fn vec3(v: &Value) -> DVec3 {
    let c = color3(v);
    DVec3::new(c[0], c[1], c[2])
}

/// A number or `[r, g, b]`.
fn color3(v: &Value) -> [f64; 3] {
    match v {
        Value::Array(a) => {
            let g = |i: usize| a.get(i).and_then(Value::as_f64).unwrap_or(0.0);
            [g(0), g(1), g(2)]
        }
        other => [other.as_f64().unwrap_or(0.0); 3],
    }
}

/// `o` without `keys`.
fn strip(o: &Value, keys: &[&str]) -> Value {
    let mut o = o.clone();
    if let Some(m) = o.as_object_mut() {
        for k in keys {
            m.remove(*k);
        }
    }
    o
}
