//! Mitsuba BSDFs and textures → candela materials (docs/scene-format.md, "materials"): the inverse
//! of tests/mitsuba/ref_materials.py.
//!
//! Exact: diffuse; conductor / roughconductor (GGX) with `material` names (tables.rs) or η/k;
//! dielectric / roughdielectric (ior = int_ior / ext_ior); principled; twosided (candela's
//! default; without it a material gets `"two_sided": false`, as Mitsuba's BSDFs are black from
//! behind); mask with a texture (candela cuts at 0.5: exact for binary masks). GGX alpha becomes
//! roughness = √alpha (a textured alpha is square-rooted per texel into a derived texture).
//! Approximated, with a warning: plastic / roughplastic (principled, see docs/import.md).
//! Unsupported (error; `--lenient` replaces as the message says): thindielectric, bumpmap,
//! normalmap, blendbsdf, Beckmann microfacets, textured η/k, and the rest.

use serde_json::{json, Map, Value};

use super::props::{ColorSrc, PValue, Plugin};
use super::scene::rgb_value;
use super::{tables, Ctx, Mat};
use crate::scene::SceneError;

/// How a texture is used.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Use {
    /// A colour: the texels as they are.
    Color,
    /// A scalar: Mitsuba reads the luminance of an RGB texture.
    Scalar,
    /// A mask's opacity (nearest filtering is equivalent there; see `texture`).
    Mask,
}

impl Ctx<'_> {
    /// The candela material of a `<bsdf>` node (converted once).
    pub fn bsdf(&mut self, node: usize) -> Result<Mat, SceneError> {
        if let Some(m) = self.materials.get(&node) {
            return Ok(m.clone());
        }
        let n = &self.tree.nodes[node];
        let hint = n
            .attr("id")
            .or(n.attr("type"))
            .unwrap_or("bsdf")
            .to_string();
        let value = Value::Object(self.convert(node, false)?);
        let mat = Mat { value, hint };
        self.materials.insert(node, mat.clone());
        Ok(mat)
    }

    /// Mitsuba's default BSDF (diffuse 0.5, one-sided).
    pub fn default_bsdf() -> Mat {
        Mat {
            value: json!({"type": "diffuse", "two_sided": false}),
            hint: "default".into(),
        }
    }

    /// One BSDF; `two_sided` when inside a `twosided`.
    fn convert(&mut self, node: usize, two_sided: bool) -> Result<Map<String, Value>, SceneError> {
        let p = Plugin::new(self.tree, node)?;
        if p.tag != "bsdf" {
            return Err(p.loc.error(format!(
                "expected a <bsdf>, got <{}> (id \"{}\")",
                p.tag,
                self.tree.nodes[node].attr("id").unwrap_or("")
            )));
        }
        let mut m = Map::new();
        let mut transmissive = false;
        match p.ty.as_str() {
            "twosided" => {
                let inner = p.children("bsdf");
                let first = match inner.as_slice() {
                    [one] => *one,
                    [a, b] => {
                        if self.convert(*a, true)? != self.convert(*b, true)? {
                            self.report.unsupported(
                                &p.loc,
                                "bsdf \"twosided\" with a different BSDF on each side is not supported",
                                "the front BSDF is used on both sides",
                            )?;
                        }
                        *a
                    }
                    _ => {
                        return Err(p
                            .loc
                            .error("bsdf \"twosided\" needs one or two nested BSDFs"))
                    }
                };
                if two_sided {
                    return Err(p.loc.error("bsdf \"twosided\" nested in another twosided"));
                }
                p.finish(&mut self.report)?;
                let inner = self.convert(first, true)?;
                if inner.get("type") == Some(&json!("dielectric")) {
                    self.report.unsupported(
                        &p.loc,
                        "bsdf \"twosided\" around a dielectric is not supported",
                        "a plain dielectric",
                    )?;
                }
                return Ok(inner);
            }
            "diffuse" => {
                m.insert("type".into(), json!("diffuse"));
                self.put_color(&p, &mut m, "reflectance", "reflectance")?;
            }
            "conductor" | "roughconductor" => self.conductor(&p, &mut m)?,
            "dielectric" | "roughdielectric" => {
                transmissive = true;
                m.insert("type".into(), json!("dielectric"));
                m.insert("ior".into(), json!(self.eta(&p, "bk7")?));
                if p.ty == "roughdielectric" {
                    self.roughness(&p, &mut m, "roughness")?;
                }
                self.put_color(&p, &mut m, "specular_reflectance", "reflectance")?;
                self.put_color(&p, &mut m, "specular_transmittance", "transmittance")?;
            }
            "plastic" | "roughplastic" => self.plastic(&p, &mut m)?,
            "principled" => transmissive = self.principled(&p, &mut m)?,
            "mask" => {
                let inner = p.children("bsdf");
                let [inner] = inner.as_slice() else {
                    return Err(p.loc.error("bsdf \"mask\" needs one nested BSDF"));
                };
                let mask = match p.color("opacity")? {
                    Some(ColorSrc::Const(c)) if c.iter().all(|&x| x == 1.0) => None,
                    Some(ColorSrc::Texture(t)) => self.texture(t, Use::Mask)?,
                    // Mitsuba's default opacity is 0.5.
                    _ => {
                        self.report.unsupported(
                            &p.loc_of("opacity"),
                            "bsdf \"mask\": a constant opacity below 1 is not supported (candela's masks cut out where a texture is below 0.5)",
                            "opaque",
                        )?;
                        None
                    }
                };
                p.finish(&mut self.report)?;
                let mut inner = self.convert(*inner, two_sided)?;
                if let Some(mask) = mask {
                    inner.insert("alpha_mask".into(), mask);
                }
                return Ok(inner);
            }
            "bumpmap" | "normalmap" => {
                self.report.unsupported(
                    &p.loc,
                    &format!(
                        "{} is not supported (candela has no bump or normal mapping)",
                        p.what()
                    ),
                    "its nested BSDF is used without it",
                )?;
                p.ignore(&["scale"]);
                p.object("normalmap")?;
                p.children("texture");
                let inner = p.children("bsdf");
                let Some(&inner) = inner.first() else {
                    return Err(p.loc.error(format!("{} needs a nested BSDF", p.what())));
                };
                p.finish(&mut self.report)?;
                return self.convert(inner, two_sided);
            }
            _ => {
                self.report.unsupported(
                    &p.loc,
                    &format!("{} is not supported", p.what()),
                    "a diffuse 0.5",
                )?;
                return Ok(Ctx::default_bsdf()
                    .value
                    .as_object()
                    .cloned()
                    .unwrap_or_default());
            }
        }
        p.finish(&mut self.report)?;
        if !two_sided && !transmissive {
            m.insert("two_sided".into(), json!(false));
        }
        Ok(m)
    }

    /// conductor / roughconductor.
    fn conductor(&mut self, p: &Plugin, m: &mut Map<String, Value>) -> Result<(), SceneError> {
        m.insert("type".into(), json!("conductor"));
        let material = p.string("material")?;
        let (eta, k) = (p.color("eta")?, p.color("k")?);
        let eta_k = match (material, eta, k) {
            (Some(_), e, k) if e.is_some() || k.is_some() => {
                return Err(p.loc.error(format!(
                    "{}: give either \"material\" or \"eta\"/\"k\", not both",
                    p.what()
                )))
            }
            (Some(name), _, _) if name == "none" => None,
            (Some(name), _, _) => Some(tables::conductor(&name).ok_or_else(|| {
                p.loc_of("material").error(format!(
                    "{}: unknown material \"{name}\" (Mitsuba 3's names: {})",
                    p.what(),
                    tables::conductor_names()
                ))
            })?),
            (None, e, k) => {
                // Mitsuba's defaults are those of material "none": η = 0, k = 1.
                let c = |x: Option<ColorSrc>, d: f64| match x {
                    None => Some([d; 3]),
                    Some(ColorSrc::Const(c)) => Some(c),
                    Some(ColorSrc::Texture(_)) => None,
                };
                match (c(e, 0.0), c(k, 1.0)) {
                    (Some(e), Some(k)) => Some((e, k)),
                    _ => {
                        self.report.unsupported(
                            &p.loc,
                            &format!("{}: textured eta / k are not supported", p.what()),
                            "Fresnel 1 (material \"none\")",
                        )?;
                        None
                    }
                }
            }
        };
        // η = 0, k = 1 is Fresnel 1, which candela writes as no eta/k; η = 0 elsewhere (AlSb's red)
        // also reflects everything and becomes 1e-6 (candela requires η > 0).
        if let Some((eta, k)) = eta_k.filter(|(e, k)| !(*e == [0.0; 3] && *k == [1.0; 3])) {
            m.insert("eta".into(), rgb_value(eta.map(|x| x.max(1e-6))));
            m.insert("k".into(), rgb_value(k));
        }
        if p.ty == "roughconductor" {
            self.roughness(p, m, "roughness")?;
        }
        self.put_color(p, m, "specular_reflectance", "reflectance")?;
        Ok(())
    }

    /// plastic / roughplastic: principled with the same diffuse colour, roughness and IOR
    /// (an approximation, measured in tests/tests/import_mitsuba.rs and named in docs/import.md).
    fn plastic(&mut self, p: &Plugin, m: &mut Map<String, Value>) -> Result<(), SceneError> {
        self.report.warn(
            &p.loc,
            format!(
                "{} is approximated by principled (same diffuse colour, roughness and IOR; docs/import.md)",
                p.what()
            ),
        );
        m.insert("type".into(), json!("principled"));
        match p.color("diffuse_reflectance")? {
            None => {
                m.insert("base_color".into(), json!(0.5));
            }
            Some(c) => {
                let v = self.color_value(p, "diffuse_reflectance", c)?;
                if let Some(v) = v {
                    m.insert("base_color".into(), v);
                }
            }
        }
        m.insert("ior".into(), json!(self.eta_with(p, "polypropylene")?));
        if p.ty == "roughplastic" {
            self.roughness(p, m, "roughness")?;
        } else {
            m.insert("roughness".into(), json!(0.0));
        }
        if let Some(ColorSrc::Const(c)) = p.color("specular_reflectance")? {
            if c != [1.0; 3] {
                self.report.unsupported(
                    &p.loc_of("specular_reflectance"),
                    &format!(
                        "{}: specular_reflectance other than 1 is not supported",
                        p.what()
                    ),
                    "ignored",
                )?;
            }
        }
        if p.bool("nonlinear")? == Some(true) {
            self.report.unsupported(
                &p.loc_of("nonlinear"),
                &format!("{}: nonlinear is not supported", p.what()),
                "ignored",
            )?;
        }
        Ok(())
    }

    /// principled; returns whether it transmits (then it stays two-sided, as in Mitsuba).
    fn principled(&mut self, p: &Plugin, m: &mut Map<String, Value>) -> Result<bool, SceneError> {
        m.insert("type".into(), json!("principled"));
        self.put_color(p, m, "base_color", "base_color")?;
        for key in [
            "roughness",
            "metallic",
            "specular",
            "spec_tint",
            "anisotropic",
            "sheen",
            "sheen_tint",
            "spec_trans",
            "clearcoat",
            "clearcoat_gloss",
        ] {
            self.put_scalar(p, m, key, key)?;
        }
        match (p.has("eta"), m.contains_key("specular")) {
            (true, true) => {
                return Err(p
                    .loc
                    .error("bsdf \"principled\": give either \"specular\" or \"eta\", not both"))
            }
            (true, false) => {
                let eta = p.float("eta")?.ok_or_else(|| {
                    p.loc_of("eta")
                        .error("bsdf \"principled\": eta must be a number")
                })?;
                m.insert("ior".into(), json!(eta));
            }
            _ => {}
        }
        p.ignore(&[
            "main_specular_sampling_rate",
            "clearcoat_sampling_rate",
            "diffuse_reflectance_sampling_rate",
        ]);
        Ok(m.get("spec_trans").is_some_and(|v| v != &json!(0.0)))
    }

    /// `distribution`, `alpha` / `alpha_u` + `alpha_v` → roughness (and conductor anisotropy).
    fn roughness(
        &mut self,
        p: &Plugin,
        m: &mut Map<String, Value>,
        field: &str,
    ) -> Result<(), SceneError> {
        let dist = p
            .string("distribution")?
            .unwrap_or_else(|| "beckmann".into());
        if dist != "ggx" {
            self.report.unsupported(
                &p.loc_of("distribution"),
                &format!(
                    "{}: distribution \"{dist}\" is not supported (candela's microfacets are GGX; Mitsuba's default is beckmann)",
                    p.what()
                ),
                "GGX with the same alpha",
            )?;
        }
        p.ignore(&["sample_visible"]);
        let (au, av) = (p.get("alpha_u").cloned(), p.get("alpha_v").cloned());
        match (au, av) {
            (None, None) => match p.get("alpha").cloned() {
                None => {
                    m.insert(field.into(), json!(0.1f64.sqrt()));
                }
                Some(PValue::Float(a)) => {
                    m.insert(field.into(), json!(a.max(0.0).sqrt()));
                }
                Some(PValue::Object(t)) => {
                    if let Some(v) = self.alpha_texture(p, t)? {
                        m.insert(field.into(), v);
                    }
                }
                Some(_) => {
                    return Err(p
                        .loc_of("alpha")
                        .error("alpha must be a float or a texture"))
                }
            },
            (Some(PValue::Float(u)), Some(PValue::Float(v))) => {
                let alpha = (u * v).max(0.0).sqrt();
                m.insert(field.into(), json!(alpha.sqrt()));
                if u != v {
                    // candela (Mitsuba principled's mapping): aspect = √(1 − 0.9 a),
                    // alpha_u = alpha / aspect, alpha_v = alpha · aspect.
                    let ratio = v / u;
                    let ok =
                        m.get("type") == Some(&json!("conductor")) && (0.1..=1.0).contains(&ratio);
                    if ok {
                        m.insert("anisotropy".into(), json!((1.0 - ratio) / 0.9));
                    } else {
                        self.report.unsupported(
                            &p.loc_of("alpha_u"),
                            &format!(
                                "{}: alpha_u = {u}, alpha_v = {v} is not supported (candela's anisotropy needs alpha_v ≤ alpha_u ≤ 10 alpha_v, on conductors)",
                                p.what()
                            ),
                            "isotropic alpha √(alpha_u · alpha_v)",
                        )?;
                    }
                }
            }
            _ => {
                self.report.unsupported(
                    &p.loc_of("alpha_u"),
                    &format!("{}: give both alpha_u and alpha_v as floats", p.what()),
                    "alpha 0.1",
                )?;
                m.insert(field.into(), json!(0.1f64.sqrt()));
            }
        }
        Ok(())
    }

    /// A textured alpha as a roughness texture: √(luminance) per texel.
    fn alpha_texture(&mut self, p: &Plugin, t: usize) -> Result<Option<Value>, SceneError> {
        let Some(tex) = self.texture(t, Use::Scalar)? else {
            return Ok(None);
        };
        let rel = tex["texture"].as_str().unwrap_or_default().to_string();
        let srgb = tex.get("srgb").and_then(Value::as_bool);
        let hint = format!(
            "{}_roughness",
            self.tree.nodes[p.node].attr("id").unwrap_or("bsdf")
        );
        let dir = self.tree.scene_dir.clone();
        let file = self.doc.derived_texture(&dir, &rel, srgb, &hint, |t| {
            let r = (0.2126 * t[0] + 0.7152 * t[1] + 0.0722 * t[2])
                .max(0.0)
                .sqrt();
            [r, r, r]
        })?;
        let mut out = json!({"texture": file});
        if let Some(s) = tex.get("scale") {
            out["scale"] = s.clone();
        }
        Ok(Some(out))
    }

    /// `int_ior / ext_ior` (names or numbers), Mitsuba's defaults `default_int` and "air".
    fn eta(&mut self, p: &Plugin, default_int: &str) -> Result<f64, SceneError> {
        self.eta_with(p, default_int)
    }

    fn eta_with(&mut self, p: &Plugin, default_int: &str) -> Result<f64, SceneError> {
        let ior = |name: &str, default: &str| -> Result<f64, SceneError> {
            let v = match p.get(name) {
                None => return Ok(tables::ior(default).unwrap_or(1.0)),
                Some(v) => v.clone(),
            };
            match v {
                PValue::Float(x) => Ok(x),
                PValue::Int(i) => Ok(i as f64),
                PValue::Str(s) => tables::ior(&s).ok_or_else(|| {
                    p.loc_of(name).error(format!(
                        "{}: unknown IOR name \"{s}\" (Mitsuba's names: {})",
                        p.what(),
                        tables::ior_names()
                    ))
                }),
                _ => Err(p
                    .loc_of(name)
                    .error(format!("{name} must be a number or an IOR name"))),
            }
        };
        let (int, ext) = (ior("int_ior", default_int)?, ior("ext_ior", "air")?);
        if !(int > 0.0 && ext > 0.0) {
            return Err(p.loc.error("int_ior and ext_ior must be positive"));
        }
        Ok(int / ext)
    }

    /// Copies colour parameter `name` to candela field `field` when given.
    fn put_color(
        &mut self,
        p: &Plugin,
        m: &mut Map<String, Value>,
        name: &str,
        field: &str,
    ) -> Result<(), SceneError> {
        if let Some(c) = p.color(name)? {
            if let Some(v) = self.color_value(p, name, c)? {
                m.insert(field.into(), v);
            }
        }
        Ok(())
    }

    fn color_value(
        &mut self,
        _p: &Plugin,
        _name: &str,
        c: ColorSrc,
    ) -> Result<Option<Value>, SceneError> {
        match c {
            ColorSrc::Const(c) => Ok(Some(rgb_value(c))),
            ColorSrc::Texture(t) => self.texture(t, Use::Color),
        }
    }

    /// Copies scalar parameter `name` (float or texture) to candela field `field` when given.
    fn put_scalar(
        &mut self,
        p: &Plugin,
        m: &mut Map<String, Value>,
        name: &str,
        field: &str,
    ) -> Result<(), SceneError> {
        let v = match p.color(name)? {
            None => return Ok(()),
            Some(ColorSrc::Const(c)) if c[0] == c[1] && c[1] == c[2] => Some(json!(c[0])),
            Some(ColorSrc::Const(_)) => {
                return Err(p
                    .loc_of(name)
                    .error(format!("{}: \"{name}\" must be a single number", p.what())))
            }
            Some(ColorSrc::Texture(t)) => self.texture(t, Use::Scalar)?,
        };
        if let Some(v) = v {
            m.insert(field.into(), v);
        }
        Ok(())
    }

    /// A `<texture>` as a candela texture reference (None when skipped under --lenient).
    fn texture(&mut self, node: usize, usage: Use) -> Result<Option<Value>, SceneError> {
        let p = Plugin::new(self.tree, node)?;
        if p.tag != "texture" || p.ty != "bitmap" {
            self.report.unsupported(
                &p.loc,
                &format!("{} is not supported (only bitmap textures are)", p.what()),
                "the parameter's default",
            )?;
            return Ok(None);
        }
        let name = p
            .string("filename")?
            .ok_or_else(|| p.loc.error("texture \"bitmap\" needs \"filename\""))?;
        let rel = self.tree.resolve(node, &name)?;
        let ext = rel.rsplit('.').next().unwrap_or("").to_ascii_lowercase();
        if !matches!(ext.as_str(), "png" | "jpg" | "jpeg" | "exr" | "hdr") {
            self.report.unsupported(
                &p.loc_of("filename"),
                &format!("texture \"bitmap\": \"{name}\" is not a PNG, JPEG, EXR or HDR image"),
                "the parameter's default",
            )?;
            return Ok(None);
        }
        let mut out = Map::new();
        out.insert("texture".into(), json!(rel));
        if p.bool("raw")? == Some(true) && matches!(ext.as_str(), "png" | "jpg" | "jpeg") {
            out.insert("srgb".into(), json!(false));
        }
        match p.string("filter_type")?.as_deref() {
            None | Some("bilinear") => {}
            // Binary masks: nearest cuts at texel edges, as candela's bilinear-then-0.5 does.
            Some("nearest") if usage == Use::Mask => {}
            Some(other) => self.report.unsupported(
                &p.loc_of("filter_type"),
                &format!("texture \"bitmap\": filter_type \"{other}\" is not supported (candela filters bilinearly)"),
                "bilinear",
            )?,
        }
        if let Some(w) = p.string("wrap_mode")? {
            if w != "repeat" {
                self.report.unsupported(
                    &p.loc_of("wrap_mode"),
                    &format!(
                        "texture \"bitmap\": wrap_mode \"{w}\" is not supported (candela repeats)"
                    ),
                    "repeat",
                )?;
            }
        }
        let to_uv = p.transform("to_uv")?;
        let (su, sv) = (to_uv.x_axis.x, to_uv.y_axis.y);
        let (tu, tv) = (to_uv.w_axis.x, to_uv.w_axis.y);
        let scale_and_shift = to_uv.x_axis.y == 0.0 && to_uv.y_axis.x == 0.0;
        let legacy = (p.float("uscale")?, p.float("vscale")?);
        let (su, sv) = (su * legacy.0.unwrap_or(1.0), sv * legacy.1.unwrap_or(1.0));
        // Legacy uscale/vscale with a to_uv shift compose in no defined order.
        let legacy_with_shift = legacy != (None, None) && (tu, tv) != (0.0, 0.0);
        let offset =
            p.float("uoffset")?.unwrap_or(0.0) != 0.0 || p.float("voffset")?.unwrap_or(0.0) != 0.0;
        // Mitsuba's uv has v = 0 on the top row (candela's v flipped), so its row is sv·(1 − v)
        // + tv where candela's `scale` gives 1 − sv·v: the same texel rows (repeat) exactly when
        // tv ≡ 1 − sv and tu ≡ 0 modulo 1 (what candela's exporter writes).
        let whole = |x: f64| (x - x.round()).abs() < 1e-6;
        if !scale_and_shift || offset || legacy_with_shift || !whole(tu) || !whole(tv - (1.0 - sv))
        {
            self.report.unsupported(
                &p.loc_of("to_uv"),
                "texture \"bitmap\": a to_uv other than a scale (with a v shift of 1 − scale, or a whole v scale) is not supported",
                "its scale is kept",
            )?;
        }
        if (su, sv) != (1.0, 1.0) {
            out.insert("scale".into(), json!([su, sv]));
        }
        if usage != Use::Color {
            out.insert("channel".into(), json!("luminance"));
        }
        p.ignore(&["format", "accel"]);
        p.finish(&mut self.report)?;
        Ok(Some(Value::Object(out)))
    }
}
