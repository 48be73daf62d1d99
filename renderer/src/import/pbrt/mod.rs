//! pbrt-v4 scene files → candela's scene document: the common subset (docs/import.md lists it).
//!
//! The directives are run as pbrt runs them (`BasicSceneBuilder`): a current transformation
//! matrix post-multiplied by each transform directive, named coordinate systems ("camera",
//! "world"), a graphics state (CTM, material, area light, ReverseOrientation) pushed by
//! AttributeBegin, named materials and textures, object instancing (candela definitions and
//! `instance` objects, import/groups.rs), Include / Import (names relative to the main file's folder, which they
//! may not leave). Camera, Film, Sampler, PixelFilter and Integrator are read before WorldBegin.
//!
//! pbrt's camera space is left-handed (+x is the image's right while looking down +z with +y
//! up), so a standard pbrt camera draws the mirror image of what candela draws from the same
//! position and direction: the importer then mirrors the whole scene (x → −x) so candela draws
//! pbrt's image. Errors name the file and line.

mod materials;
mod params;
mod shapes;
mod tokens;

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
use params::Params;
use tokens::{Tok, Tokens};

/// Deepest Include nesting accepted.
const MAX_INCLUDE_DEPTH: usize = 32;

/// A converted material.
#[derive(Debug, Clone)]
pub(crate) struct Mat {
    pub value: Value,
    pub hint: String,
}

/// What AttributeBegin saves.
#[derive(Debug, Clone)]
pub(crate) struct GState {
    pub ctm: DMat4,
    pub reverse: bool,
    pub material: Mat,
    /// Area light radiance (and where it was declared) for the shapes that follow.
    pub area: Option<([f64; 3], Loc)>,
}

/// A texture declared with `Texture`: its candela reference and whether it is a float texture.
#[derive(Debug, Clone)]
pub(crate) struct Tex {
    pub value: Value,
    pub float: bool,
}

/// Everything the directives share.
pub(crate) struct Ctx {
    pub doc: Doc,
    pub report: Report,
    pub limits: Limits,
    pub scene_dir: PathBuf,
    shown_dir: PathBuf,
    /// Applied to everything in world space: the identity, or the mirror of the module docs.
    pub world: DMat4,
    pub gs: GState,
    stack: Vec<(GState, Loc, bool)>,
    named_cs: HashMap<String, DMat4>,
    pub named_materials: HashMap<String, Mat>,
    pub textures: HashMap<String, Tex>,
    /// Object instancing: finished objects (defined once, import/groups.rs), and the one being
    /// defined.
    pub instances: HashMap<String, crate::import::groups::Group>,
    pub defining: Option<(String, Vec<(Value, Loc)>, Loc)>,
    in_world: bool,
    camera: Option<(String, Params, Loc, DMat4)>,
    film: (f64, f64),
    saw_filter: bool,
    saw_integrator: bool,
}

/// Imports the pbrt file `path`.
pub(crate) fn import(path: &Path, opts: &ImportOptions) -> ImportResult {
    let file: Arc<str> = Arc::from(path.display().to_string());
    let mut ctx = Ctx {
        doc: Doc::new(),
        report: Report::new(opts.lenient),
        limits: opts.limits.clone(),
        scene_dir: super::folder_of(path),
        shown_dir: path.parent().map(Path::to_path_buf).unwrap_or_default(),
        world: DMat4::IDENTITY,
        gs: GState {
            ctm: DMat4::IDENTITY,
            reverse: false,
            material: Mat {
                value: json!({"type": "diffuse", "reflectance": 0.5}),
                hint: "diffuse".into(),
            },
            area: None,
        },
        stack: Vec::new(),
        named_cs: HashMap::new(),
        named_materials: HashMap::new(),
        textures: HashMap::new(),
        instances: HashMap::new(),
        defining: None,
        in_world: false,
        camera: None,
        film: (1280.0, 720.0),
        saw_filter: false,
        saw_integrator: false,
    };
    let text = super::read_file(path)?;
    let mut tokens = Tokens::new(text, file.clone());
    ctx.run(&mut tokens, 0)?;
    if !ctx.in_world {
        ctx.world_begin(&Loc::file(&file))?;
    }
    if let Some((_, loc, _)) = ctx.stack.last() {
        return Err(loc.error("AttributeBegin without AttributeEnd"));
    }
    let Ctx { doc, report, .. } = ctx;
    let (value, assets, origins) = doc.finish();
    Ok((value, assets, origins, report.warnings))
}

impl Ctx {
    /// Runs the directives of one file.
    fn run(&mut self, t: &mut Tokens, depth: usize) -> Result<(), SceneError> {
        while let Some(tok) = t.next()? {
            let loc = t.loc(tok.line);
            let Tok::Word(name) = tok.tok else {
                return Err(loc.error("expected a directive"));
            };
            self.directive(&name, t, &loc, depth)?;
        }
        Ok(())
    }

    fn directive(
        &mut self,
        name: &str,
        t: &mut Tokens,
        loc: &Loc,
        depth: usize,
    ) -> Result<(), SceneError> {
        let ctm = self.gs.ctm;
        match name {
            "Identity" => self.gs.ctm = DMat4::IDENTITY,
            "Translate" => {
                let v = numbers(t, 3, loc)?;
                self.gs.ctm = ctm * DMat4::from_translation(DVec3::new(v[0], v[1], v[2]));
            }
            "Scale" => {
                let v = numbers(t, 3, loc)?;
                self.gs.ctm = ctm * DMat4::from_scale(DVec3::new(v[0], v[1], v[2]));
            }
            "Rotate" => {
                let v = numbers(t, 4, loc)?;
                let axis = DVec3::new(v[1], v[2], v[3]);
                let axis = axis
                    .try_normalize()
                    .ok_or_else(|| loc.error("Rotate: zero axis"))?;
                self.gs.ctm = ctm * DMat4::from_axis_angle(axis, v[0].to_radians());
            }
            "LookAt" => {
                let v = numbers(t, 9, loc)?;
                let m = look_at(
                    DVec3::new(v[0], v[1], v[2]),
                    DVec3::new(v[3], v[4], v[5]),
                    DVec3::new(v[6], v[7], v[8]),
                )
                .ok_or_else(|| loc.error("LookAt: the eye, target and up vector are degenerate"))?;
                self.gs.ctm = ctm * m;
            }
            "Transform" | "ConcatTransform" => {
                let v = numbers(t, 16, loc)?;
                // pbrt writes the matrix column by column.
                let m = DMat4::from_cols_array(&v.try_into().expect("16 numbers"));
                self.gs.ctm = if name == "Transform" { m } else { ctm * m };
            }
            "CoordinateSystem" => {
                let n = string(t, loc)?;
                self.named_cs.insert(n, ctm);
            }
            "CoordSysTransform" => {
                let n = string(t, loc)?;
                match self.named_cs.get(&n) {
                    Some(m) => self.gs.ctm = *m,
                    None => self.report.warn(
                        loc,
                        format!("CoordSysTransform: no coordinate system \"{n}\": ignored"),
                    ),
                }
            }
            "ReverseOrientation" => self.gs.reverse = !self.gs.reverse,
            "AttributeBegin" | "TransformBegin" => {
                self.stack
                    .push((self.gs.clone(), loc.clone(), name == "TransformBegin"));
            }
            "AttributeEnd" | "TransformEnd" => {
                let (saved, _, only_ctm) = self
                    .stack
                    .pop()
                    .ok_or_else(|| loc.error(format!("{name} without a matching begin")))?;
                if only_ctm {
                    self.gs.ctm = saved.ctm;
                } else {
                    self.gs = saved;
                }
            }
            "ActiveTransform" | "TransformTimes" => {
                let n = if name == "TransformTimes" { 2 } else { 1 };
                for _ in 0..n {
                    t.next()?;
                }
                self.report.unsupported(
                    loc,
                    &format!("{name} (motion blur) is not supported"),
                    "ignored",
                )?;
            }
            "Option" => {
                let p = params::read(t)?;
                p.ignore_all();
                self.report
                    .warn(loc, "Option: rendering options are ignored");
            }
            "ColorSpace" => {
                let n = string(t, loc)?;
                if n != "srgb" {
                    self.report.unsupported(
                        loc,
                        &format!(
                            "ColorSpace \"{n}\" is not supported (candela renders linear sRGB)"
                        ),
                        "srgb",
                    )?;
                }
            }
            "Attribute" => {
                let target = string(t, loc)?;
                let _ = params::read(t)?;
                self.report.unsupported(
                    loc,
                    &format!("Attribute \"{target}\" (parameter defaults) is not supported"),
                    "ignored",
                )?;
            }
            "Camera" | "Film" | "Sampler" | "PixelFilter" | "Integrator" | "Accelerator" => {
                let ty = string(t, loc)?;
                let p = params::read(t)?;
                if self.in_world {
                    return Err(loc.error(format!("{name} must come before WorldBegin")));
                }
                self.options(name, &ty, p, loc)?;
            }
            "MakeNamedMedium" => {
                let n = string(t, loc)?;
                let _ = params::read(t)?;
                self.report.unsupported(
                    loc,
                    &format!("MakeNamedMedium \"{n}\": participating media are not supported"),
                    "ignored",
                )?;
            }
            "MediumInterface" => {
                let a = string(t, loc)?;
                let b = match t.peek()? {
                    Some(tok) if matches!(tok.tok, Tok::Str(_)) => string(t, loc)?,
                    _ => a.clone(),
                };
                if !a.is_empty() || !b.is_empty() {
                    self.report.unsupported(
                        loc,
                        "MediumInterface: participating media are not supported",
                        "ignored",
                    )?;
                }
            }
            "WorldBegin" => self.world_begin(loc)?,
            "WorldEnd" => {}
            "Include" | "Import" => {
                let n = string(t, loc)?;
                if depth + 1 > MAX_INCLUDE_DEPTH {
                    return Err(loc.error(format!(
                        "{name} nested more than {MAX_INCLUDE_DEPTH} deep (a cycle?)"
                    )));
                }
                let rel = resolve_in(&self.scene_dir, Path::new(""), &n)
                    .map_err(|m| loc.error(format!("{name}: {m}")))?;
                let full = self.scene_dir.join(&rel);
                if n.ends_with(".gz") {
                    return Err(loc.error(format!(
                        "{name} \"{n}\": compressed files are not supported"
                    )));
                }
                let text = std::fs::read(&full).map_err(|e| {
                    loc.error(format!("{name} \"{n}\": {}", crate::scene::io_message(&e)))
                })?;
                let shown: Arc<str> = Arc::from(self.shown_dir.join(&rel).display().to_string());
                let mut inner = Tokens::new(text, shown);
                self.run(&mut inner, depth + 1)?;
            }
            "Shape" => {
                let ty = string(t, loc)?;
                let p = params::read(t)?;
                self.in_world_only(name, loc)?;
                shapes::shape(self, &ty, &p, loc)?;
            }
            "Material" => {
                let ty = string(t, loc)?;
                let p = params::read(t)?;
                self.gs.material = materials::material(self, &ty, &p, loc, &ty)?;
            }
            "MakeNamedMaterial" => {
                let n = string(t, loc)?;
                let p = params::read(t)?;
                let ty = p.string("type")?.ok_or_else(|| {
                    loc.error(format!("MakeNamedMaterial \"{n}\" needs \"string type\""))
                })?;
                let m = materials::material(self, &ty, &p, loc, &n)?;
                self.named_materials.insert(n, m);
            }
            "NamedMaterial" => {
                let n = string(t, loc)?;
                self.gs.material = self.named_materials.get(&n).cloned().ok_or_else(|| {
                    loc.error(format!("NamedMaterial: no material \"{n}\" was made"))
                })?;
            }
            "Texture" => {
                let n = string(t, loc)?;
                let kind = string(t, loc)?;
                let class = string(t, loc)?;
                let p = params::read(t)?;
                materials::texture(self, &n, &kind, &class, &p, loc)?;
            }
            "LightSource" => {
                let ty = string(t, loc)?;
                let p = params::read(t)?;
                self.in_world_only(name, loc)?;
                materials::light(self, &ty, &p, loc)?;
            }
            "AreaLightSource" => {
                let ty = string(t, loc)?;
                let p = params::read(t)?;
                materials::area_light(self, &ty, &p, loc)?;
            }
            "ObjectBegin" => {
                let n = string(t, loc)?;
                if self.defining.is_some() {
                    return Err(loc.error("ObjectBegin inside another ObjectBegin"));
                }
                self.stack.push((self.gs.clone(), loc.clone(), false));
                self.defining = Some((n, Vec::new(), loc.clone()));
            }
            "ObjectEnd" => {
                let (n, objects, _) = self
                    .defining
                    .take()
                    .ok_or_else(|| loc.error("ObjectEnd without ObjectBegin"))?;
                let group = crate::import::groups::Group::new(&n, objects);
                self.instances.insert(n, group);
                let (saved, _, _) = self
                    .stack
                    .pop()
                    .ok_or_else(|| loc.error("ObjectEnd without ObjectBegin"))?;
                self.gs = saved;
            }
            "ObjectInstance" => {
                let n = string(t, loc)?;
                if self.defining.is_some() {
                    // pbrt-v4 refuses it too: instances do not nest.
                    return Err(loc.error("ObjectInstance inside ObjectBegin"));
                }
                let group = self
                    .instances
                    .get_mut(&n)
                    .ok_or_else(|| loc.error(format!("ObjectInstance: no object \"{n}\"")))?;
                group.place(&mut self.doc, &(self.world * ctm), loc);
            }
            other => return Err(loc.error(format!("unknown directive \"{other}\""))),
        }
        Ok(())
    }

    fn in_world_only(&self, name: &str, loc: &Loc) -> Result<(), SceneError> {
        if self.in_world {
            Ok(())
        } else {
            Err(loc.error(format!("{name} must come after WorldBegin")))
        }
    }

    /// Camera, Film, Sampler, PixelFilter, Integrator (Accelerator is ignored).
    fn options(&mut self, name: &str, ty: &str, p: Params, loc: &Loc) -> Result<(), SceneError> {
        let what = format!("{name} \"{ty}\"");
        match name {
            "Camera" => {
                let c2w = self.gs.ctm.inverse();
                self.named_cs.insert("camera".into(), c2w);
                self.camera = Some((ty.to_string(), p, loc.clone(), c2w));
                return Ok(());
            }
            "Film" => {
                if !matches!(ty, "rgb" | "gbuffer" | "spectral") {
                    self.report.unsupported(
                        loc,
                        &format!("{what} is not supported"),
                        "read as an rgb film",
                    )?;
                }
                let w = p.num("xresolution")?.unwrap_or(1280.0);
                let h = p.num("yresolution")?.unwrap_or(720.0);
                if !(w >= 1.0 && h >= 1.0) {
                    return Err(loc.error("Film: xresolution and yresolution must be positive"));
                }
                self.film = (w, h);
                self.doc.film.insert("width".into(), json!(w as u64));
                self.doc.film.insert("height".into(), json!(h as u64));
                for key in ["cropwindow", "pixelbounds"] {
                    if p.has(key) {
                        p.nums(key)?;
                        self.report.unsupported(
                            &p.loc(key, loc),
                            &format!("{what}: \"{key}\" is not supported"),
                            "the whole image is rendered",
                        )?;
                    }
                }
                if p.num("iso")?.is_some_and(|x| x != 100.0)
                    || p.num("whitebalance")?.is_some_and(|x| x != 0.0)
                {
                    self.report.unsupported(
                        loc,
                        &format!("{what}: iso other than 100 and white balance are not supported"),
                        "ignored",
                    )?;
                }
                if p.string("sensor")?.is_some_and(|s| s != "cie1931") {
                    self.report.unsupported(
                        &p.loc("sensor", loc),
                        &format!("{what}: sensor curves are not supported"),
                        "ignored",
                    )?;
                }
                p.ignore(&[
                    "filename",
                    "savefp16",
                    "maxcomponentvalue",
                    "diagonal",
                    "exposuretime",
                ]);
            }
            "Sampler" => {
                let spp = p.num("pixelsamples")?.unwrap_or(16.0);
                if spp < 1.0 {
                    return Err(p
                        .loc("pixelsamples", loc)
                        .error("pixelsamples must be at least 1"));
                }
                self.doc.render.insert("spp".into(), json!(spp as u64));
                p.ignore(&[
                    "seed",
                    "dimensions",
                    "jitter",
                    "randomization",
                    "xsamples",
                    "ysamples",
                ]);
            }
            "PixelFilter" => {
                self.saw_filter = true;
                let f = match ty {
                    "box" => {
                        let r = (
                            p.num("xradius")?.unwrap_or(0.5),
                            p.num("yradius")?.unwrap_or(0.5),
                        );
                        if r != (0.5, 0.5) {
                            self.report.unsupported(
                                loc,
                                "PixelFilter \"box\": a radius other than 0.5 is not supported",
                                "radius 0.5",
                            )?;
                        }
                        json!("box")
                    }
                    "gaussian" => {
                        p.ignore(&["xradius", "yradius"]);
                        json!({"type": "gaussian", "stddev": p.num("sigma")?.unwrap_or(0.5)})
                    }
                    _ => {
                        self.report.unsupported(
                            loc,
                            &format!("{what} is not supported (box and gaussian are)"),
                            "the box filter",
                        )?;
                        p.ignore(&["xradius", "yradius", "B", "C", "tau", "sigma"]);
                        json!("box")
                    }
                };
                self.doc.film.insert("filter".into(), f);
            }
            "Integrator" => {
                self.saw_integrator = true;
                let depth = p.num("maxdepth")?.unwrap_or(5.0);
                if !(depth.fract() == 0.0 && (0.0..=1e6).contains(&depth)) {
                    return Err(loc.error(format!(
                        "Integrator \"maxdepth\" must be a whole number in 0..=1000000, got {depth}"
                    )));
                }
                let integrator = match ty {
                    "path" | "volpath" => "nee",
                    "bdpt" => "bdpt",
                    _ => {
                        self.report.unsupported(
                            loc,
                            &format!("{what} is not supported (path, volpath and bdpt are)"),
                            "a path tracer (nee)",
                        )?;
                        "nee"
                    }
                };
                // pbrt's maxdepth counts bounces after the camera ray: candela's (Mitsuba's) + 1.
                self.doc
                    .render
                    .insert("integrator".into(), json!(integrator));
                self.doc
                    .render
                    .insert("max_depth".into(), json!(depth as i64 + 1));
                p.ignore(&[
                    "regularize",
                    "lightsampler",
                    "visualizestrategies",
                    "visualizeweights",
                    "samplelights",
                    "samplebsdf",
                ]);
            }
            _ => {
                p.ignore_all();
            }
        }
        p.finish(&mut self.report, &what)
    }

    /// WorldBegin: the camera is placed (deciding whether the scene is mirrored), the CTM reset.
    fn world_begin(&mut self, loc: &Loc) -> Result<(), SceneError> {
        if self.in_world {
            return Err(loc.error("WorldBegin twice"));
        }
        self.in_world = true;
        let (w, h) = self.film;
        let (ty, p, cloc, c2w) = self.camera.take().unwrap_or_else(|| {
            (
                "perspective".into(),
                Params::default(),
                loc.clone(),
                DMat4::IDENTITY,
            )
        });
        if ty != "perspective" {
            self.report.unsupported(
                &cloc,
                &format!("Camera \"{ty}\" is not supported"),
                "a perspective camera",
            )?;
        }
        if mirrors_image(&c2w, DVec3::X, DVec3::Z, DVec3::Y) {
            self.world = DMat4::from_scale(DVec3::new(-1.0, 1.0, 1.0));
        }
        let frame = camera_frame(&(self.world * c2w), DVec3::Z, DVec3::Y).map_err(|_| {
            cloc.error("the camera transform is not a rotation, translation and uniform scale")
        })?;
        let mut cam = camera_value(&frame);
        // pbrt's fov spans the shorter image axis.
        let fov = p.num("fov")?.unwrap_or(90.0);
        let fov_y = if w >= h {
            fov
        } else {
            2.0 * ((fov.to_radians() / 2.0).tan() * h / w).atan().to_degrees()
        };
        cam.insert("fov_y".into(), json!(fov_y));
        let lens = p.num("lensradius")?.unwrap_or(0.0);
        if lens > 0.0 {
            cam.insert("aperture_radius".into(), json!(lens));
            cam.insert(
                "focus_distance".into(),
                json!(p.num("focaldistance")?.unwrap_or(1e6)),
            );
        } else {
            p.num("focaldistance")?;
        }
        if p.has("screenwindow")
            || p.num("frameaspectratio")?
                .is_some_and(|a| (a - w / h).abs() > 1e-6)
        {
            p.nums("screenwindow")?;
            self.report.unsupported(
                &cloc,
                "Camera: screenwindow / frameaspectratio other than the film's are not supported",
                "ignored",
            )?;
        }
        p.ignore(&[
            "shutteropen",
            "shutterclose",
            "lensfile",
            "aperturediameter",
            "focusdistance",
        ]);
        p.finish(&mut self.report, &format!("Camera \"{ty}\""))?;
        self.doc.camera = cam;
        if !self.doc.film.contains_key("width") {
            self.doc.film.insert("width".into(), json!(w as u64));
            self.doc.film.insert("height".into(), json!(h as u64));
        }
        if !self.saw_filter {
            // pbrt-v4's default pixel filter.
            self.doc
                .film
                .insert("filter".into(), json!({"type": "gaussian", "stddev": 0.5}));
        }
        if !self.saw_integrator {
            // pbrt-v4's default integrator: volpath, maxdepth 5.
            self.doc.render.insert("integrator".into(), json!("nee"));
            self.doc.render.insert("max_depth".into(), json!(6));
        }
        self.gs.ctm = DMat4::IDENTITY;
        self.named_cs.insert("world".into(), DMat4::IDENTITY);
        Ok(())
    }

    /// A file named by a parameter, relative to the main file's folder.
    pub fn file(&self, name: &str, loc: &Loc) -> Result<String, SceneError> {
        resolve_in(&self.scene_dir, Path::new(""), name)
            .map(|p| super::files::to_slash(&p))
            .map_err(|m| loc.error(m))
    }
}

/// pbrt's LookAt: the camera-from-world matrix (camera looks down +z, +x = up × dir).
fn look_at(eye: DVec3, target: DVec3, up: DVec3) -> Option<DMat4> {
    let dir = (target - eye).try_normalize()?;
    let right = up.try_normalize()?.cross(dir).try_normalize()?;
    let new_up = dir.cross(right);
    let world_from_camera = DMat4::from_cols(
        right.extend(0.0),
        new_up.extend(0.0),
        dir.extend(0.0),
        eye.extend(1.0),
    );
    Some(world_from_camera.inverse())
}

/// `n` numbers, bare or in brackets.
fn numbers(t: &mut Tokens, n: usize, loc: &Loc) -> Result<Vec<f64>, SceneError> {
    let mut out = Vec::with_capacity(n);
    let bracketed = matches!(t.peek()?, Some(tok) if tok.tok == Tok::Open);
    if bracketed {
        t.next()?;
    }
    while out.len() < n {
        match t.next()? {
            Some(tokens::Token {
                tok: Tok::Word(w),
                line,
            }) => out.push(
                w.parse()
                    .map_err(|_| t.loc(line).error(format!("\"{w}\" is not a number")))?,
            ),
            _ => return Err(loc.error(format!("expected {n} numbers"))),
        }
    }
    if bracketed
        && !matches!(
            t.next()?,
            Some(tokens::Token {
                tok: Tok::Close,
                ..
            })
        )
    {
        return Err(loc.error(format!("expected ] after {n} numbers")));
    }
    Ok(out)
}

/// One quoted string.
fn string(t: &mut Tokens, loc: &Loc) -> Result<String, SceneError> {
    match t.next()? {
        Some(tokens::Token {
            tok: Tok::Str(s), ..
        }) => Ok(s),
        _ => Err(loc.error("expected a quoted string")),
    }
}

#[cfg(test)]
mod tests;
