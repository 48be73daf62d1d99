//! candela JSON → Mitsuba 3 XML (`candela convert IN.json OUT.xml`), so the same scene can be
//! rendered by Mitsuba side by side with candela. The translation is tests/mitsuba/ref_*.py's
//! (which the tests use to render candela's scenes with Mitsuba), written as a file instead of a
//! Python dict: sensor (perspective / thinlens, `fov_axis` y, clip planes outside the scene),
//! hdrfilm, `path` (`volpath` with alpha masks), lights, environment, and through
//! `export_parts` the materials and shapes.
//!
//! What XML cannot hold inline is written beside it in `<stem>_files/`: inline `triangles` as
//! PLY (v → 1 − v, Mitsuba's PLY convention), scalar textures as grey EXR of the value Mitsuba
//! needs per texel (roughness² for GGX alpha), masks, textured PLY meshes with v flipped, and the
//! environment map resampled to Mitsuba's row convention (2H + 1 rows, exact for bilinear
//! lookups). A scene Mitsuba cannot express exactly is an error naming the JSON path.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use glam::DVec3;
use serde_json::Value;

use super::export_parts::Parts;
use crate::film::Image;
use crate::import::Imported;
use crate::scene::transform::box_corners;
use crate::scene::{Environment, Scene, SceneError};

/// An XML element being written.
#[derive(Debug, Clone, Default)]
pub(crate) struct El {
    tag: String,
    attrs: Vec<(String, String)>,
    children: Vec<El>,
}

impl El {
    pub fn new(tag: &str) -> Self {
        El {
            tag: tag.into(),
            ..Default::default()
        }
    }
    /// `<tag type="ty">`.
    pub fn plugin(tag: &str, ty: &str) -> Self {
        El::new(tag).attr("type", ty)
    }
    pub fn attr(mut self, k: &str, v: impl ToString) -> Self {
        self.attrs.push((k.into(), v.to_string()));
        self
    }
    /// Whether a child element has tag `tag`.
    pub fn has_child(&self, tag: &str) -> bool {
        self.children.iter().any(|c| c.tag == tag)
    }
    pub fn child(mut self, c: El) -> Self {
        self.children.push(c);
        self
    }
    pub fn push(&mut self, c: El) {
        self.children.push(c);
    }
    /// `<float name= value=>`.
    pub fn float(self, name: &str, v: f64) -> Self {
        self.child(El::new("float").attr("name", name).attr("value", num(v)))
    }
    pub fn integer(self, name: &str, v: i64) -> Self {
        self.child(El::new("integer").attr("name", name).attr("value", v))
    }
    pub fn boolean(self, name: &str, v: bool) -> Self {
        self.child(El::new("boolean").attr("name", name).attr("value", v))
    }
    pub fn string(self, name: &str, v: &str) -> Self {
        self.child(El::new("string").attr("name", name).attr("value", v))
    }
    pub fn rgb(self, name: &str, c: [f64; 3]) -> Self {
        let v = if c[0] == c[1] && c[1] == c[2] {
            num(c[0])
        } else {
            format!("{}, {}, {}", num(c[0]), num(c[1]), num(c[2]))
        };
        self.child(El::new("rgb").attr("name", name).attr("value", v))
    }
    pub fn point(self, name: &str, p: DVec3) -> Self {
        self.child(
            El::new("point")
                .attr("name", name)
                .attr("x", num(p.x))
                .attr("y", num(p.y))
                .attr("z", num(p.z)),
        )
    }
    /// `<transform name=><matrix value="16 row-major"/></transform>`.
    pub fn matrix(self, name: &str, m: &glam::DMat4) -> Self {
        let v: Vec<String> = crate::import::xform::row_major(m)
            .iter()
            .map(|&x| num(x))
            .collect();
        self.child(
            El::new("transform")
                .attr("name", name)
                .child(El::new("matrix").attr("value", v.join(" "))),
        )
    }
    fn write(&self, out: &mut String, depth: usize) {
        let pad = "    ".repeat(depth);
        let _ = write!(out, "{pad}<{}", self.tag);
        for (k, v) in &self.attrs {
            let _ = write!(out, " {k}=\"{}\"", escape(v));
        }
        if self.children.is_empty() {
            out.push_str("/>\n");
        } else {
            out.push_str(">\n");
            for c in &self.children {
                c.write(out, depth + 1);
            }
            let _ = writeln!(out, "{pad}</{}>", self.tag);
        }
    }
}

/// A number as Mitsuba reads it back exactly (shortest round-trip form).
pub(crate) fn num(x: f64) -> String {
    format!("{x:?}")
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The export in progress: the scene, its folder, and the files to write beside the XML.
pub(crate) struct Export<'a> {
    pub doc: &'a Value,
    pub scene: &'a Scene,
    /// The JSON scene's folder.
    pub base: &'a Path,
    /// `<stem>_files`, the folder of written files, relative to the XML.
    pub files_dir: String,
    /// Written files: relative path → bytes.
    pub files: BTreeMap<String, Vec<u8>>,
}

impl Export<'_> {
    /// Holds a file to write as `<stem>_files/name`; returns its path relative to the XML.
    pub fn file(&mut self, name: &str, bytes: Vec<u8>) -> String {
        let rel = format!("{}/{name}", self.files_dir);
        self.files.insert(rel.clone(), bytes);
        rel
    }

    /// An image written as EXR beside the XML.
    pub fn exr(&mut self, name: &str, img: &Image) -> Result<String, SceneError> {
        let bytes = crate::film::encode_exr(img)
            .map_err(|e| SceneError::invalid("", format!("{name}: {e}")))?;
        Ok(self.file(name, bytes))
    }
}

/// A scene construct Mitsuba cannot express exactly.
pub(crate) fn untranslatable(path: &str, what: &str) -> SceneError {
    SceneError::invalid(
        path,
        format!("{what}: Mitsuba 3 cannot express this exactly"),
    )
}

/// Writes the candela JSON scene `imp` as Mitsuba XML at `out` (and its files beside it);
/// returns every file written.
pub fn write_xml(imp: &Imported, out: &Path) -> Result<Vec<PathBuf>, SceneError> {
    let scene = imp.load(&Default::default())?;
    let dir = crate::import::folder_of(out);
    let stem = out
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scene".into());
    let mut ex = Export {
        doc: &imp.doc,
        scene: &scene,
        base: &imp.base,
        files_dir: format!("{stem}_files"),
        files: BTreeMap::new(),
    };
    let xml = to_xml(&mut ex)?;
    // Step 2: the scene's own files, when the XML goes to another folder, then ours.
    let mut written =
        crate::import::convert::copy_referenced(&imp.doc, &imp.base, &dir, &imp.assets)
            .map_err(|e| SceneError::invalid("", e.to_string()))?;
    let write = |path: &Path, bytes: &[u8]| -> Result<(), SceneError> {
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent)
                .map_err(|e| SceneError::io("", &parent.display().to_string(), &e))?;
        }
        std::fs::write(path, bytes).map_err(|e| SceneError::io("", &path.display().to_string(), &e))
    };
    for (rel, bytes) in &ex.files {
        let p = dir.join(rel);
        write(&p, bytes)?;
        written.push(p);
    }
    write(out, xml.as_bytes())?;
    written.insert(0, out.to_path_buf());
    Ok(written)
}

/// The XML text of the scene.
pub(crate) fn to_xml(ex: &mut Export) -> Result<String, SceneError> {
    let mut root = El::new("scene").attr("version", "3.0.0");
    let mut parts = Parts::new();
    // Step 1: objects first, for the bounds and whether masks need volpath.
    let mut shapes = Vec::new();
    if let Some(objects) = ex.doc["objects"].as_array() {
        for (i, o) in objects.iter().enumerate() {
            shapes.push(parts.shape(ex, i, o)?);
        }
    }
    // Step 2: integrator and sensor.
    let render = &ex.doc["render"];
    let max_depth = render["max_depth"].as_i64().unwrap_or(6);
    let spp = render["spp"].as_u64().unwrap_or(256);
    root.push(
        El::plugin(
            "integrator",
            if parts.uses_mask { "volpath" } else { "path" },
        )
        .integer("max_depth", max_depth)
        .integer("rr_depth", 5)
        .boolean("hide_emitters", false),
    );
    root.push(sensor(ex, spp)?);
    // Step 3: materials (defined once, referenced by id), shape groups, shapes, lights,
    // environment.
    for b in parts.take_bsdfs() {
        root.push(b);
    }
    for g in parts.take_groups() {
        root.push(g);
    }
    for s in shapes {
        root.push(s);
    }
    for l in &ex.scene.lights {
        root.push(light(l));
    }
    if let Some(env) = &ex.scene.environment {
        root.push(environment(ex, env)?);
    }
    let mut text = String::from("<?xml version=\"1.0\" encoding=\"utf-8\"?>\n<!-- Written by candela convert from a candela JSON scene (docs/import.md). -->\n");
    root.write(&mut text, 0);
    Ok(text)
}

/// The sensor with its film and sampler (tests/mitsuba/ref_scene.py `sensor`).
fn sensor(ex: &Export, spp: u64) -> Result<El, SceneError> {
    let cam = &ex.scene.camera;
    let film = &ex.scene.film;
    // candela has no clip planes: keep Mitsuba's out of the scene's way.
    let far = scene_far(ex.scene, cam.position);
    let filter = match film.filter {
        crate::scene::Filter::Box => El::plugin("rfilter", "box"),
        crate::scene::Filter::Gaussian { stddev } => {
            El::plugin("rfilter", "gaussian").float("stddev", stddev as f64)
        }
    };
    let look = El::new("lookat")
        .attr("origin", vec3(cam.position))
        .attr("target", vec3(cam.look_at))
        .attr("up", vec3(cam.up));
    let mut s = El::plugin(
        "sensor",
        if cam.aperture_radius > 0.0 {
            "thinlens"
        } else {
            "perspective"
        },
    )
    .float("fov", cam.fov_y)
    .string("fov_axis", "y")
    .float("near_clip", (1e-6 * far.max(1.0)).min(1e-2))
    .float("far_clip", (2.0 * far).max(1e4))
    .child(El::new("transform").attr("name", "to_world").child(look));
    if cam.aperture_radius > 0.0 {
        s = s
            .float("aperture_radius", cam.aperture_radius)
            .float("focus_distance", cam.focus_distance);
    }
    Ok(
        s.child(El::plugin("sampler", "independent").integer("sample_count", spp as i64))
            .child(
                El::plugin("film", "hdrfilm")
                    .integer("width", film.width as i64)
                    .integer("height", film.height as i64)
                    .string("pixel_format", "rgb")
                    .string("component_format", "float32")
                    .child(filter),
            ),
    )
}

/// `x, y, z`.
pub(crate) fn vec3(v: DVec3) -> String {
    format!("{}, {}, {}", num(v.x), num(v.y), num(v.z))
}

/// The distance from `eye` to the farthest corner of the scene's bounds.
fn scene_far(scene: &Scene, eye: DVec3) -> f64 {
    type Bounds = (DVec3, DVec3);
    let empty: Bounds = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    let grow = |(lo, hi): Bounds, p: DVec3| (lo.min(p), hi.max(p));
    let points = |ps: &[DVec3]| ps.iter().copied().fold(empty, grow);
    let mut b = (scene.meshes.iter()).fold(empty, |b, m| {
        let (lo, hi) = points(&m.positions);
        grow(grow(b, lo), hi)
    });
    for s in &scene.spheres {
        b = grow(grow(b, s.center - s.radius), s.center + s.radius);
    }
    // Instances: the corners of their prototype's box, placed.
    let prototypes: Vec<Bounds> = scene
        .prototypes
        .iter()
        .map(|p| points(&p.positions))
        .collect();
    for i in &scene.instances {
        let (plo, phi) = prototypes[i.prototype as usize];
        if plo.x <= phi.x {
            b = box_corners(plo, phi).fold(b, |b, c| grow(b, i.to_world.transform_point3(c)));
        }
    }
    let (lo, hi) = b;
    if lo.x > hi.x {
        return 0.0;
    }
    box_corners(lo, hi)
        .map(|c| (c - eye).length())
        .fold(0.0, f64::max)
}

fn light(l: &crate::scene::Light) -> El {
    use crate::scene::Light;
    let rgb = |v: glam::Vec3| [v.x as f64, v.y as f64, v.z as f64];
    match l {
        Light::Point {
            position,
            intensity,
        } => El::plugin("emitter", "point")
            .point("position", *position)
            .rgb("intensity", rgb(*intensity)),
        Light::Spot {
            position,
            direction,
            intensity,
            cutoff_angle,
            beam_width,
        } => {
            // Mitsuba's spot shines along local +z.
            let up = if direction.y.abs() < 0.9 {
                DVec3::Y
            } else {
                DVec3::X
            };
            El::plugin("emitter", "spot")
                .child(
                    El::new("transform").attr("name", "to_world").child(
                        El::new("lookat")
                            .attr("origin", vec3(*position))
                            .attr("target", vec3(*position + *direction))
                            .attr("up", vec3(up)),
                    ),
                )
                .rgb("intensity", rgb(*intensity))
                .float("cutoff_angle", *cutoff_angle as f64)
                .float("beam_width", *beam_width as f64)
        }
        Light::Directional {
            direction,
            irradiance,
        } => El::plugin("emitter", "directional")
            .child(
                El::new("vector")
                    .attr("name", "direction")
                    .attr("x", num(direction.x))
                    .attr("y", num(direction.y))
                    .attr("z", num(direction.z)),
            )
            .rgb("irradiance", rgb(*irradiance)),
    }
}

/// constant, or envmap with candela's map resampled to Mitsuba's rows and to_world =
/// R_y(rotate_y − 180°) (ref_scene.py `env_to_world`, `env_bitmap`).
fn environment(ex: &mut Export, env: &Environment) -> Result<El, SceneError> {
    match env {
        Environment::Constant { radiance } => Ok(El::plugin("emitter", "constant").rgb(
            "radiance",
            [radiance.x as f64, radiance.y as f64, radiance.z as f64],
        )),
        Environment::Map {
            texture,
            scale,
            rotate_y,
        } => {
            let t = &ex.scene.textures[*texture as usize];
            let (w, h) = (t.width, t.height);
            // Rows: Mitsuba reads v·(H−1), candela v·H − 0.5 (clamped): insert the midpoints and
            // repeat the poles, H → 2H + 1 rows, so the two bilinear lookups agree exactly.
            let img = Image::from_fn(w, 2 * h + 1, |x, j| {
                let ra = (j.max(1) - 1) / 2;
                let rb = (j / 2).min(h - 1);
                let a = t.texels[(ra * w + x) as usize];
                let b = t.texels[(rb * w + x) as usize];
                [
                    0.5 * (a[0] + b[0]),
                    0.5 * (a[1] + b[1]),
                    0.5 * (a[2] + b[2]),
                ]
            });
            let file = ex.exr("environment.exr", &img)?;
            Ok(El::plugin("emitter", "envmap")
                .string("filename", &file)
                .float("scale", *scale as f64)
                .child(
                    El::new("transform").attr("name", "to_world").child(
                        El::new("rotate")
                            .attr("y", 1)
                            .attr("angle", num(*rotate_y as f64 - 180.0)),
                    ),
                ))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The far distance covers spheres, meshes and instances placed far from the definition.
    #[test]
    fn scene_far_covers_instances() {
        let scene = crate::scene::load_str(
            r#"{"version": 1, "camera": {"position": [0, 0, 0], "look_at": [0, 0, -1]},
                "materials": {"m": {"type": "diffuse"}},
                "definitions": {"t": {"type": "triangles", "positions": [[0, 0, 0], [1, 0, 0], [0, 1, 0]],
                                      "indices": [0, 1, 2], "material": "m"}},
                "objects": [
                    {"type": "sphere", "center": [0, 0, -3], "radius": 1, "material": "m"},
                    {"type": "instance", "definition": "t", "transform": {"translate": [0, 0, -50000]}},
                    {"type": "instance", "definition": "t", "transform": {"translate": [0, 0, -50000]}}
                ]}"#,
            None,
        )
        .unwrap();
        assert_eq!(scene.instances.len(), 2);
        let far = scene_far(&scene, DVec3::ZERO);
        // The box spans x, y ∈ [−1, 1], z ∈ [−50000, −2]: its farthest corner from the origin.
        let expected = DVec3::new(1.0, 1.0, -50000.0).length();
        assert!(
            (far - expected).abs() < 1e-6 * expected,
            "{far} vs {expected}"
        );
    }
}
