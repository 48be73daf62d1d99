//! glTF 2.0 (`.gltf` with external or embedded buffers and images, `.glb`) → candela's scene
//! document, through the `gltf` crate (validated documents only, so its accessors cannot panic).
//!
//! The default scene's node tree is walked with each node's world transform (glTF is +Y up,
//! right-handed, metres: candela's own conventions): each mesh primitive becomes a PLY held in
//! memory (`mesh`), shared by every node that instances it; materials (metallic-roughness →
//! principled, `materials`); cameras (the first perspective camera; `yfov`, film aspect from
//! `aspectRatio`); KHR_lights_punctual lights with photometric units turned radiometric at
//! 683 lm/W (docs/import.md). Errors name the file and the glTF JSON path.
//!
//! Extensions: KHR_lights_punctual, KHR_materials_emissive_strength, KHR_materials_ior,
//! KHR_materials_transmission and KHR_texture_transform (scale only) are read. Any other
//! extension the file *requires* is an error (`--lenient`: ignored); one it merely *uses* is
//! ignored with a warning, as the glTF specification allows.

mod materials;
mod mesh;

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::{DMat4, DVec3};
use serde_json::{json, Value};

use super::diag::{Loc, Report};
use super::doc::Doc;
use super::files::resolve_in;
use super::xform::{camera_frame, camera_value, mirrors_image};
use super::{ImportOptions, ImportResult};
use crate::scene::{Limits, SceneError};

/// Extensions this importer reads.
const SUPPORTED: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_materials_emissive_strength",
    "KHR_materials_ior",
    "KHR_materials_transmission",
    "KHR_texture_transform",
];

/// Lumens per watt at 555 nm: photometric ↔ radiometric units (docs/import.md).
pub(crate) const LM_PER_W: f64 = 683.0;

/// Film height when the file gives no camera aspect (width follows `aspectRatio`).
const FILM_HEIGHT: f64 = 512.0;

/// Everything the converters share.
pub(crate) struct Ctx {
    pub doc: Doc,
    pub report: Report,
    pub limits: Limits,
    /// The file as shown in messages.
    pub file: Arc<str>,
    /// The glTF's folder (file names are relative to it).
    pub dir: PathBuf,
    /// Every buffer's bytes.
    pub buffers: Vec<Vec<u8>>,
    /// Converted materials (None: the default material) → scene material name.
    pub materials: HashMap<Option<usize>, String>,
    /// Converted images → their file (on disk or in memory).
    pub images: HashMap<usize, Option<String>>,
    /// (mesh, primitive) → the group of its one `mesh` object over its PLY (None: skipped).
    pub primitives: HashMap<(usize, usize), Option<crate::import::groups::Group>>,
}

impl Ctx {
    /// A place in the file: its JSON path (glTF has no useful lines).
    pub fn at(&self, json_path: &str) -> Loc {
        Loc::file(&Arc::from(format!("{}: {json_path}", self.file)))
    }
}

/// Imports the glTF file `path`.
pub(crate) fn import(path: &Path, opts: &ImportOptions) -> ImportResult {
    // The gltf crate indexes arrays it has not range-checked in places (found by fuzzing:
    // gltf-json's mesh validation, image views), so a malformed file could panic inside it:
    // that becomes an error naming the file, never a crash.
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| import_checked(path, opts)))
        .unwrap_or_else(|panic| {
            let what = panic
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            let file: Arc<str> = Arc::from(path.display().to_string());
            Err(Loc::file(&file).error(format!(
                "malformed glTF (an index or size out of range; the glTF reader failed: {what})"
            )))
        })
}

fn import_checked(path: &Path, opts: &ImportOptions) -> ImportResult {
    let file: Arc<str> = Arc::from(path.display().to_string());
    let whole = Loc::file(&file);
    let bytes = super::read_file(path)?;
    let mut report = Report::new(opts.lenient);
    // Step 1: the JSON (and a .glb's binary chunk).
    let (json_bytes, bin) = if bytes.starts_with(b"glTF") {
        let glb = ::gltf::binary::Glb::from_slice(&bytes)
            .map_err(|e| whole.error(format!("not a valid .glb: {e}")))?;
        (glb.json.into_owned(), glb.bin.map(|b| b.into_owned()))
    } else {
        (bytes, None)
    };
    let mut root: ::gltf::json::Root =
        ::gltf::json::deserialize::from_slice(&json_bytes).map_err(|e| {
            Loc::new(&file, Some(e.line()))
                .error(format!("glTF JSON error at column {}: {e}", e.column()))
        })?;
    // Step 2: extensions, then the crate's validation (index ranges, required fields).
    for (i, ext) in root.extensions_required.clone().iter().enumerate() {
        if !SUPPORTED.contains(&ext.as_str()) {
            report.unsupported(
                &Loc::file(&Arc::from(format!("{file}: extensionsRequired[{i}]"))),
                &format!("extension {ext} is required but not supported"),
                "ignored",
            )?;
        }
    }
    root.extensions_required
        .retain(|e| SUPPORTED.contains(&e.as_str()));
    for ext in &root.extensions_used {
        if !SUPPORTED.contains(&ext.as_str()) && !root.extensions_required.contains(ext) {
            report.warn(&whole, format!("extension {ext} is not supported: ignored"));
        }
    }
    precheck(&root).map_err(|e| whole.error(format!("invalid glTF: {e}")))?;
    let document = ::gltf::Document::from_json(root).map_err(|e| match e {
        ::gltf::Error::Validation(errors) => {
            let list: Vec<String> = errors
                .iter()
                .take(3)
                .map(|(p, e)| format!("{}: {e}", p.as_str()))
                .collect();
            whole.error(format!("invalid glTF: {}", list.join("; ")))
        }
        other => whole.error(format!("invalid glTF: {other}")),
    })?;
    let dir = super::folder_of(path);
    let buffers = load_buffers(&document, &file, &dir, bin)?;
    let mut ctx = Ctx {
        doc: Doc::new(),
        report,
        limits: opts.limits.clone(),
        file: file.clone(),
        dir,
        buffers,
        materials: HashMap::new(),
        images: HashMap::new(),
        primitives: HashMap::new(),
    };
    // Step 3: the scene's nodes.
    let scene = match document
        .default_scene()
        .or_else(|| document.scenes().next())
    {
        Some(s) => s,
        None => return Err(whole.error("the file has no scene")),
    };
    let mut walk = Walk {
        camera: None,
        bounds: (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        depth: 0,
    };
    for node in scene.nodes() {
        walk.node(&mut ctx, &node, &DMat4::IDENTITY)?;
    }
    // Step 4: camera and film (or a camera framing the scene).
    match walk.camera.take() {
        Some((camera, aspect)) => {
            ctx.doc.camera = camera;
            if let Some(a) = aspect {
                let w = (FILM_HEIGHT * a).round().max(1.0);
                ctx.doc.film.insert("width".into(), json!(w as u64));
                ctx.doc
                    .film
                    .insert("height".into(), json!(FILM_HEIGHT as u64));
            }
        }
        None => {
            ctx.report.warn(
                &whole,
                "no camera: one is placed in front of the scene (+Z), framing it",
            );
            ctx.doc.camera = framing_camera(walk.bounds);
        }
    }
    let Ctx { doc, report, .. } = ctx;
    let (value, assets, origins) = doc.finish();
    Ok((value, assets, origins, report.warnings))
}

/// Every buffer: the .glb's binary chunk, a `data:` URI, or a file beside the glTF.
/// What the gltf crate assumes instead of checking (it panics on these): every primitive's
/// POSITION accessor exists, and every image has a buffer view with a MIME type or a URI.
fn precheck(root: &::gltf::json::Root) -> Result<(), String> {
    use ::gltf::json::mesh::Semantic;
    use ::gltf::json::validation::Checked;
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            if let Some(a) = prim.attributes.get(&Checked::Valid(Semantic::Positions)) {
                if a.value() >= root.accessors.len() {
                    return Err(format!(
                        "meshes[{m}].primitives[{p}].attributes.POSITION: accessor {} does not exist ({} accessors)",
                        a.value(),
                        root.accessors.len()
                    ));
                }
            }
        }
    }
    for (i, image) in root.images.iter().enumerate() {
        match (&image.buffer_view, &image.uri) {
            (Some(_), _) if image.mime_type.is_none() => {
                return Err(format!("images[{i}]: a bufferView image needs a mimeType"))
            }
            (None, None) => return Err(format!("images[{i}]: neither uri nor bufferView")),
            _ => {}
        }
    }
    Ok(())
}

fn load_buffers(
    document: &::gltf::Document,
    file: &Arc<str>,
    dir: &Path,
    mut bin: Option<Vec<u8>>,
) -> Result<Vec<Vec<u8>>, SceneError> {
    let mut out = Vec::new();
    for b in document.buffers() {
        let at = Loc::file(&Arc::from(format!("{file}: buffers[{}]", b.index())));
        let data = match b.source() {
            ::gltf::buffer::Source::Bin => bin
                .take()
                .ok_or_else(|| at.error("refers to the .glb binary chunk, which is missing"))?,
            ::gltf::buffer::Source::Uri(uri) => read_uri(uri, dir).map_err(|m| at.error(m))?,
        };
        if data.len() < b.length() {
            return Err(at.error(format!(
                "holds {} bytes, fewer than its byteLength {}",
                data.len(),
                b.length()
            )));
        }
        out.push(data);
    }
    Ok(out)
}

/// The bytes of a URI: `data:...;base64,...` or a relative file name (percent-encoded).
pub(crate) fn read_uri(uri: &str, dir: &Path) -> Result<Vec<u8>, String> {
    use base64::Engine as _;
    if let Some(rest) = uri.strip_prefix("data:") {
        let (_, payload) = rest
            .split_once(";base64,")
            .ok_or("only base64 data URIs are supported")?;
        return base64::engine::general_purpose::STANDARD
            .decode(payload.trim())
            .map_err(|e| format!("invalid base64 data URI: {e}"));
    }
    let rel = relative_uri(uri, dir)?;
    std::fs::read(dir.join(&rel))
        .map_err(|e| format!("cannot read \"{uri}\": {}", crate::scene::io_message(&e)))
}

/// A file URI as a path relative to the glTF's folder (which it may not leave).
pub(crate) fn relative_uri(uri: &str, dir: &Path) -> Result<PathBuf, String> {
    if uri.contains("://") {
        return Err(format!(
            "\"{uri}\": only files beside the glTF and data URIs are supported"
        ));
    }
    let decoded = percent_encoding::percent_decode_str(uri)
        .decode_utf8()
        .map_err(|_| format!("\"{uri}\": not UTF-8 after percent-decoding"))?;
    resolve_in(dir, Path::new(""), &decoded)
}

/// The node walk: world transforms, the first camera, the bounds of what was placed.
struct Walk {
    camera: Option<(serde_json::Map<String, Value>, Option<f64>)>,
    bounds: (DVec3, DVec3),
    depth: usize,
}

impl Walk {
    fn node(
        &mut self,
        ctx: &mut Ctx,
        node: &::gltf::Node,
        parent: &DMat4,
    ) -> Result<(), SceneError> {
        let path = format!("nodes[{}]", node.index());
        self.depth += 1;
        if self.depth > 256 {
            return Err(ctx
                .at(&path)
                .error("nodes nested more than 256 deep (a cycle?)"));
        }
        let local = node.transform().matrix();
        let m = *parent * DMat4::from_cols_array_2d(&local.map(|c| c.map(|x| x as f64)));
        if node.skin().is_some() {
            ctx.report.unsupported(
                &ctx.at(&path),
                "skinning is not supported",
                "the mesh is placed in its bind pose",
            )?;
        }
        if let Some(w) = node
            .weights()
            .or_else(|| node.mesh().and_then(|mesh| mesh.weights()))
        {
            if w.iter().any(|&x| x != 0.0) {
                ctx.report.unsupported(
                    &ctx.at(&path),
                    "morph target weights are not supported",
                    "the base shape is used",
                )?;
            }
        }
        if let Some(mesh) = node.mesh() {
            for prim in mesh.primitives() {
                if mesh::place_primitive(ctx, &mesh, &prim, &m)? {
                    self.grow(ctx, &mesh, &prim, &m);
                }
            }
        }
        if let Some(cam) = node.camera() {
            self.camera(ctx, &cam, &m, &path)?;
        }
        if let Some(light) = node.light() {
            light_of(ctx, &light, &m)?;
        }
        for child in node.children() {
            self.node(ctx, &child, &m)?;
        }
        self.depth -= 1;
        Ok(())
    }

    /// Extends the bounds by a primitive's accessor box.
    fn grow(&mut self, _ctx: &Ctx, _mesh: &::gltf::Mesh, prim: &::gltf::Primitive, m: &DMat4) {
        let b = prim.bounding_box();
        for k in 0..8 {
            let p = DVec3::new(
                if k & 1 == 0 { b.min[0] } else { b.max[0] } as f64,
                if k & 2 == 0 { b.min[1] } else { b.max[1] } as f64,
                if k & 4 == 0 { b.min[2] } else { b.max[2] } as f64,
            );
            let w = m.transform_point3(p);
            self.bounds = (self.bounds.0.min(w), self.bounds.1.max(w));
        }
    }

    fn camera(
        &mut self,
        ctx: &mut Ctx,
        cam: &::gltf::Camera,
        m: &DMat4,
        path: &str,
    ) -> Result<(), SceneError> {
        let at = ctx.at(&format!("cameras[{}]", cam.index()));
        if self.camera.is_some() {
            ctx.report.warn(&at, "only the first camera is used");
            return Ok(());
        }
        let ::gltf::camera::Projection::Perspective(p) = cam.projection() else {
            return ctx.report.unsupported(
                &at,
                "an orthographic camera is not supported",
                "skipped",
            );
        };
        // glTF cameras look down −Z with +Y up and +X to the right of the image.
        if mirrors_image(m, DVec3::X, -DVec3::Z, DVec3::Y) {
            return ctx.report.unsupported(
                &ctx.at(path),
                "a camera under a mirroring transform is not supported",
                "skipped",
            );
        }
        let frame = camera_frame(m, -DVec3::Z, DVec3::Y).map_err(|_| {
            ctx.at(path)
                .error("the camera's transform is not a rotation, translation and uniform scale")
        })?;
        let mut c = camera_value(&frame);
        c.insert("fov_y".into(), json!((p.yfov() as f64).to_degrees()));
        self.camera = Some((c, p.aspect_ratio().map(|a| a as f64)));
        Ok(())
    }
}

/// A KHR_lights_punctual light at world transform `m`.
fn light_of(
    ctx: &mut Ctx,
    light: &::gltf::khr_lights_punctual::Light,
    m: &DMat4,
) -> Result<(), SceneError> {
    use ::gltf::khr_lights_punctual::Kind;
    let at = ctx.at(&format!(
        "extensions.KHR_lights_punctual.lights[{}]",
        light.index()
    ));
    // Photometric (cd, lux) → radiometric (W/sr, W/m²) at 683 lm/W, per unit of colour.
    let scale = light.intensity() as f64 / LM_PER_W;
    let c = light.color().map(|x| x as f64 * scale);
    let position = m.transform_point3(DVec3::ZERO);
    let dir = m.transform_vector3(-DVec3::Z);
    if dir.length() == 0.0 || !dir.is_finite() {
        return Err(at.error("the light's node transform collapses its direction"));
    }
    let dir = dir.normalize();
    let v = match light.kind() {
        Kind::Point => json!({"type": "point", "position": position.to_array(), "intensity": c}),
        Kind::Directional => {
            json!({"type": "directional", "direction": dir.to_array(), "irradiance": c})
        }
        Kind::Spot {
            inner_cone_angle,
            outer_cone_angle,
        } => {
            let outer = (outer_cone_angle as f64).to_degrees();
            let inner = (inner_cone_angle as f64).to_degrees().min(outer);
            json!({"type": "spot", "position": position.to_array(), "look_at": (position + dir).to_array(),
                   "intensity": c, "cutoff_angle": outer, "beam_width": inner})
        }
    };
    ctx.doc.light(v, &at);
    Ok(())
}

/// A camera on +Z looking at the bounds' centre, far enough for a 40° view to hold them.
fn framing_camera((lo, hi): (DVec3, DVec3)) -> serde_json::Map<String, Value> {
    let (center, radius) = if lo.x <= hi.x {
        (0.5 * (lo + hi), (0.5 * (hi - lo).length()).max(1e-3))
    } else {
        (DVec3::ZERO, 1.0)
    };
    let distance = radius / (20f64.to_radians()).sin();
    let mut c = serde_json::Map::new();
    c.insert(
        "position".into(),
        json!((center + DVec3::Z * distance).to_array()),
    );
    c.insert("look_at".into(), json!(center.to_array()));
    c.insert("fov_y".into(), json!(40.0));
    c
}

#[cfg(test)]
mod tests;
