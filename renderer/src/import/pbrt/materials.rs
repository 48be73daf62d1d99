//! pbrt-v4 materials, textures and lights → candela (docs/import.md has the table).
//!
//! diffuse → diffuse; conductor → conductor (η/k as RGB, the named `metal-*` spectra through
//! Mitsuba 3's RGB values of the same metals, `reflectance` through pbrt's own η = 1,
//! k = 2√r / √(1 − r)); dielectric → dielectric (`glass-BK7` as 1.5046); roughness through
//! pbrt's remapping (alpha = √roughness when `remaproughness`) to candela's roughness = √alpha;
//! coateddiffuse → principled (an approximation, warned). `imagemap` textures keep their file
//! when used as they are, else become derived textures (float textures: the mean of RGB, as
//! pbrt reads them). Lights: point, spot, distant, infinite (constant), diffuse area lights.

use glam::DVec3;
use serde_json::{json, Map, Value};

use super::params::{Params, Spectrum};
use super::{Ctx, Mat, Tex};
use crate::import::diag::Loc;
use crate::import::mitsuba::named_conductor;
use crate::scene::SceneError;

/// pbrt's named glasses candela knows (their IOR at 550 nm, constant).
const GLASSES: &[(&str, f64)] = &[("glass-BK7", 1.5046)];

/// A `Material` / `MakeNamedMaterial` of type `ty`.
pub(super) fn material(
    ctx: &mut Ctx,
    ty: &str,
    p: &Params,
    loc: &Loc,
    hint: &str,
) -> Result<Mat, SceneError> {
    p.ignore(&["type"]);
    let what = format!("material \"{ty}\"");
    let mut m = Map::new();
    match ty {
        "diffuse" => {
            m.insert("type".into(), json!("diffuse"));
            m.insert(
                "reflectance".into(),
                color(ctx, p, "reflectance", 0.5, loc)?,
            );
        }
        "conductor" => conductor(ctx, p, &mut m, loc)?,
        "dielectric" => {
            m.insert("type".into(), json!("dielectric"));
            m.insert("ior".into(), json!(eta(ctx, p, loc)?));
            roughness(ctx, p, &mut m, loc, false)?;
        }
        "coateddiffuse" => {
            ctx.report.warn(loc, "material \"coateddiffuse\" is approximated by principled (same diffuse colour, roughness and IOR; docs/import.md)");
            m.insert("type".into(), json!("principled"));
            m.insert("base_color".into(), color(ctx, p, "reflectance", 0.5, loc)?);
            m.insert("metallic".into(), json!(0.0));
            m.insert("ior".into(), json!(eta(ctx, p, loc)?));
            roughness(ctx, p, &mut m, loc, false)?;
            p.ignore(&["thickness", "albedo", "g", "maxdepth", "nsamples"]);
        }
        _ => {
            ctx.report.unsupported(loc, &format!("{what} is not supported (diffuse, conductor, dielectric and coateddiffuse are)"), "a diffuse 0.5")?;
            p.ignore_all();
            m.insert("type".into(), json!("diffuse"));
        }
    }
    for key in ["normalmap", "displacement"] {
        if p.has(key) {
            p.ignore(&[key]);
            ctx.report.unsupported(
                &p.loc(key, loc),
                &format!("{what}: \"{key}\" is not supported"),
                "ignored",
            )?;
        }
    }
    p.finish(&mut ctx.report, &what)?;
    Ok(Mat {
        value: Value::Object(m),
        hint: hint.to_string(),
    })
}

/// conductor: η/k (RGB, named metals, or from `reflectance`) and roughness.
fn conductor(
    ctx: &mut Ctx,
    p: &Params,
    m: &mut Map<String, Value>,
    loc: &Loc,
) -> Result<(), SceneError> {
    m.insert("type".into(), json!("conductor"));
    let rgb_or_named = |ctx: &mut Ctx,
                        name: &str,
                        default: &str|
     -> Result<Option<[f64; 3]>, SceneError> {
        let ploc = p.loc(name, loc);
        let s = p
            .spectrum(name)?
            .unwrap_or_else(|| Spectrum::Named(default.into()));
        Ok(match s {
            Spectrum::Rgb(c) => Some(c),
            Spectrum::Named(n) => {
                let metal = n.strip_prefix("metal-").and_then(|r| r.rsplit_once('-'));
                match metal.and_then(|(el, part)| {
                    named_conductor(el).map(|(e, k)| if part == "k" { k } else { e })
                }) {
                    Some(c) => {
                        ctx.report.warn(&ploc, format!("spectrum \"{n}\" is replaced by Mitsuba 3's RGB values for the same metal (docs/import.md)"));
                        Some(c)
                    }
                    None => {
                        ctx.report.unsupported(
                            &ploc,
                            &format!("named spectrum \"{n}\" is not supported"),
                            "copper",
                        )?;
                        named_conductor("Cu").map(|(e, k)| if name == "k" { k } else { e })
                    }
                }
            }
            Spectrum::Texture(_) | Spectrum::Other(_) => {
                ctx.report.unsupported(&ploc, &format!("material \"conductor\": this \"{name}\" is not supported (RGB, constant and named metal spectra are)"), "copper")?;
                named_conductor("Cu").map(|(e, k)| if name == "k" { k } else { e })
            }
        })
    };
    if p.has("reflectance") {
        // pbrt-v4: η = 1, k = 2√r / √(1 − r), which reflects r at normal incidence.
        match p.spectrum("reflectance")? {
            Some(Spectrum::Rgb(r)) => {
                m.insert("eta".into(), json!(1.0));
                m.insert(
                    "k".into(),
                    json!(r.map(|x| {
                        let x = x.clamp(0.0, 0.9999);
                        2.0 * x.sqrt() / (1.0 - x).sqrt()
                    })),
                );
            }
            _ => ctx.report.unsupported(
                &p.loc("reflectance", loc),
                "material \"conductor\": only an RGB reflectance is supported",
                "ignored",
            )?,
        }
        p.ignore(&["eta", "k"]);
    } else {
        let eta = rgb_or_named(ctx, "eta", "metal-Cu-eta")?;
        let k = rgb_or_named(ctx, "k", "metal-Cu-k")?;
        if let (Some(e), Some(k)) = (eta, k) {
            m.insert("eta".into(), json!(e.map(|x| x.max(1e-6))));
            m.insert("k".into(), json!(k));
        }
    }
    roughness(ctx, p, m, loc, true)
}

/// A dielectric's η: a number, a constant spectrum or a named glass.
fn eta(ctx: &mut Ctx, p: &Params, loc: &Loc) -> Result<f64, SceneError> {
    let ploc = p.loc("eta", loc);
    Ok(match p.spectrum("eta")? {
        None => 1.5,
        Some(Spectrum::Rgb([x, ..])) => x,
        Some(Spectrum::Named(n)) => match GLASSES.iter().find(|g| g.0 == n) {
            Some(g) => {
                ctx.report.warn(&ploc, format!("spectrum \"{n}\" is taken as the constant IOR {} (candela's dielectrics do not disperse)", g.1));
                g.1
            }
            None => {
                ctx.report.unsupported(
                    &ploc,
                    &format!("named spectrum \"{n}\" is not supported"),
                    "IOR 1.5",
                )?;
                1.5
            }
        },
        Some(_) => {
            ctx.report.unsupported(
                &ploc,
                "a textured or varying eta is not supported",
                "IOR 1.5",
            )?;
            1.5
        }
    })
}

/// `roughness` or `uroughness` / `vroughness` with `remaproughness` → candela roughness
/// (and anisotropy for conductors).
fn roughness(
    ctx: &mut Ctx,
    p: &Params,
    m: &mut Map<String, Value>,
    loc: &Loc,
    conductor: bool,
) -> Result<(), SceneError> {
    let remap = p.bool("remaproughness")?.unwrap_or(true);
    // pbrt's TrowbridgeReitz alpha, then candela's roughness = √alpha.
    let to_candela = move |x: f64| (if remap { x.max(0.0).sqrt() } else { x.max(0.0) }).sqrt();
    let (u, v) = (p.has("uroughness"), p.has("vroughness"));
    if !u && !v {
        match float_or_texture(ctx, p, "roughness", loc)? {
            None => {}
            Some(FloatParam::Const(x)) => {
                m.insert("roughness".into(), json!(to_candela(x)));
            }
            Some(FloatParam::Texture(t)) => {
                let file = t["texture"].as_str().unwrap_or_default().to_string();
                let dir = ctx.scene_dir.clone();
                let derived =
                    ctx.doc
                        .derived_texture(&dir, &file, Some(false), "roughness", move |x| {
                            [to_candela(x[0] as f64) as f32; 3]
                        })?;
                let mut r = json!({"texture": derived});
                if let Some(s) = t.get("scale") {
                    r["scale"] = s.clone();
                }
                m.insert("roughness".into(), r);
            }
        }
        return Ok(());
    }
    p.ignore(&["roughness"]);
    let (FloatParam::Const(ur), FloatParam::Const(vr)) = (
        float_or_texture(ctx, p, "uroughness", loc)?.unwrap_or(FloatParam::Const(0.0)),
        float_or_texture(ctx, p, "vroughness", loc)?.unwrap_or(FloatParam::Const(0.0)),
    ) else {
        return ctx.report.unsupported(
            loc,
            "textured uroughness / vroughness are not supported",
            "ignored",
        );
    };
    let (au, av) = (to_candela(ur).powi(2), to_candela(vr).powi(2));
    let alpha = (au * av).sqrt();
    m.insert("roughness".into(), json!(alpha.sqrt()));
    if au != av {
        let ratio = if au > 0.0 { av / au } else { 0.0 };
        if conductor && (0.1..=1.0).contains(&ratio) {
            m.insert("anisotropy".into(), json!((1.0 - ratio) / 0.9));
        } else {
            ctx.report.unsupported(loc, "this anisotropic roughness is not supported (candela's needs vroughness ≤ uroughness ≤ 10 vroughness, on conductors)", "isotropic")?;
        }
    }
    Ok(())
}

/// A float parameter or a float texture.
enum FloatParam {
    Const(f64),
    Texture(Value),
}

fn float_or_texture(
    ctx: &mut Ctx,
    p: &Params,
    name: &str,
    loc: &Loc,
) -> Result<Option<FloatParam>, SceneError> {
    Ok(match p.spectrum(name)? {
        None => None,
        Some(Spectrum::Rgb([x, ..])) => Some(FloatParam::Const(x)),
        Some(Spectrum::Texture(t)) => match ctx.textures.get(&t) {
            Some(tex) if tex.float => match &tex.value {
                Value::Number(n) => Some(FloatParam::Const(n.as_f64().unwrap_or(0.0))),
                v => Some(FloatParam::Texture(v.clone())),
            },
            _ => {
                return Err(p
                    .loc(name, loc)
                    .error(format!("\"{name}\": no float texture \"{t}\"")))
            }
        },
        Some(_) => {
            return Err(p
                .loc(name, loc)
                .error(format!("\"{name}\" must be a float or a float texture")))
        }
    })
}

/// A colour parameter: RGB, a constant spectrum, or a spectrum texture.
fn color(
    ctx: &mut Ctx,
    p: &Params,
    name: &str,
    default: f64,
    loc: &Loc,
) -> Result<Value, SceneError> {
    let ploc = p.loc(name, loc);
    Ok(match p.spectrum(name)? {
        None => json!(default),
        Some(Spectrum::Rgb(c)) => json!(c),
        Some(Spectrum::Texture(t)) => match ctx.textures.get(&t) {
            Some(tex) => tex.value.clone(),
            None => return Err(ploc.error(format!("\"{name}\": no texture \"{t}\""))),
        },
        Some(Spectrum::Named(n)) => {
            ctx.report.unsupported(
                &ploc,
                &format!("named spectrum \"{n}\" for \"{name}\" is not supported"),
                &format!("{default}"),
            )?;
            json!(default)
        }
        Some(Spectrum::Other(what)) => {
            ctx.report.unsupported(
                &ploc,
                &format!("{what} for \"{name}\" is not supported"),
                &format!("{default}"),
            )?;
            json!(default)
        }
    })
}

/// `Texture "name" "spectrum"|"float" "class" params`.
pub(super) fn texture(
    ctx: &mut Ctx,
    name: &str,
    kind: &str,
    class: &str,
    p: &Params,
    loc: &Loc,
) -> Result<(), SceneError> {
    let float = match kind {
        "float" => true,
        "spectrum" | "color" => false,
        other => {
            return Err(loc.error(format!(
                "Texture \"{name}\": type must be \"spectrum\" or \"float\", got \"{other}\""
            )))
        }
    };
    let what = format!("texture \"{class}\"");
    let value = match class {
        "constant" => {
            let v = p.spectrum("value")?.unwrap_or(Spectrum::Rgb([1.0; 3]));
            match v {
                Spectrum::Rgb(c) if float => json!(c[0]),
                Spectrum::Rgb(c) => json!(c),
                _ => {
                    return Err(p
                        .loc("value", loc)
                        .error("texture \"constant\": value must be a number or RGB"))
                }
            }
        }
        "imagemap" => match image_texture(ctx, name, float, p, loc)? {
            Some(v) => v,
            None => return Ok(()),
        },
        _ => {
            ctx.report.unsupported(
                loc,
                &format!("{what} is not supported (imagemap and constant are)"),
                "skipped",
            )?;
            p.ignore_all();
            return Ok(());
        }
    };
    p.finish(&mut ctx.report, &what)?;
    ctx.textures.insert(name.to_string(), Tex { value, float });
    Ok(())
}

fn image_texture(
    ctx: &mut Ctx,
    name: &str,
    float: bool,
    p: &Params,
    loc: &Loc,
) -> Result<Option<Value>, SceneError> {
    let file = p
        .string("filename")?
        .ok_or_else(|| loc.error("texture \"imagemap\" needs \"string filename\""))?;
    let rel = ctx.file(&file, &p.loc("filename", loc))?;
    let ext = rel.rsplit('.').next().unwrap_or("").to_ascii_lowercase();
    if !matches!(ext.as_str(), "png" | "jpg" | "jpeg" | "exr" | "hdr") {
        ctx.report.unsupported(
            &p.loc("filename", loc),
            &format!("texture \"imagemap\": \"{file}\" is not a PNG, JPEG, EXR or HDR image"),
            "skipped",
        )?;
        return Ok(None);
    }
    let srgb = match p.string("encoding")?.as_deref() {
        None => None,
        Some("sRGB") => Some(true),
        Some("linear") => Some(false),
        Some(other) => {
            ctx.report.unsupported(
                &p.loc("encoding", loc),
                &format!("texture encoding \"{other}\" is not supported"),
                "the format's default",
            )?;
            None
        }
    };
    for (key, ok) in [("mapping", "uv"), ("wrap", "repeat")] {
        if let Some(v) = p.string(key)? {
            if v != ok {
                ctx.report.unsupported(
                    &p.loc(key, loc),
                    &format!("texture \"imagemap\": {key} \"{v}\" is not supported"),
                    ok,
                )?;
            }
        }
    }
    if p.num("udelta")?.unwrap_or(0.0) != 0.0 || p.num("vdelta")?.unwrap_or(0.0) != 0.0 {
        ctx.report.unsupported(
            loc,
            "texture \"imagemap\": udelta / vdelta are not supported",
            "ignored",
        )?;
    }
    p.ignore(&["filter", "maxanisotropy"]);
    // pbrt flips t before its top-row-first lookup: row = (1 − vscale·v)·H, exactly candela's rule.
    let scale = [
        p.num("uscale")?.unwrap_or(1.0),
        p.num("vscale")?.unwrap_or(1.0),
    ];
    let (k, invert) = (
        p.num("scale")?.unwrap_or(1.0),
        p.bool("invert")?.unwrap_or(false),
    );
    let mut out = Map::new();
    if float || k != 1.0 || invert {
        // pbrt reads a float texture as the mean of the channels, then scales and inverts.
        let dir = ctx.scene_dir.clone();
        let f = move |t: [f32; 4]| {
            let x = if float {
                (t[0] + t[1] + t[2]) / 3.0
            } else {
                0.0
            };
            let g = |c: f32| {
                let v = c * k as f32;
                if invert {
                    (1.0 - v).max(0.0)
                } else {
                    v
                }
            };
            if float {
                [g(x); 3]
            } else {
                [g(t[0]), g(t[1]), g(t[2])]
            }
        };
        let derived = ctx.doc.derived_texture(&dir, &rel, srgb, name, f)?;
        out.insert("texture".into(), json!(derived));
    } else {
        out.insert("texture".into(), json!(rel));
        if let Some(s) = srgb {
            out.insert("srgb".into(), json!(s));
        }
    }
    if scale != [1.0, 1.0] {
        out.insert("scale".into(), json!(scale));
    }
    Ok(Some(Value::Object(out)))
}

/// A light's RGB (`I` or `L`) times `scale`; `power` is not supported.
fn radiance(ctx: &mut Ctx, p: &Params, name: &str, loc: &Loc) -> Result<[f64; 3], SceneError> {
    let ploc = p.loc(name, loc);
    let c = match p.spectrum(name)? {
        None => [1.0; 3],
        Some(Spectrum::Rgb(c)) => c,
        Some(other) => {
            ctx.report.unsupported(
                &ploc,
                &format!("\"{name}\" {other:?} is not supported (RGB and constant spectra are)"),
                "white",
            )?;
            [1.0; 3]
        }
    };
    if p.has("power") {
        p.num("power")?;
        ctx.report.unsupported(
            &p.loc("power", loc),
            "light \"power\" is not supported (give the radiance or intensity)",
            "ignored",
        )?;
    }
    let s = p.num("scale")?.unwrap_or(1.0);
    Ok(c.map(|x| x * s))
}

/// `LightSource`.
pub(super) fn light(ctx: &mut Ctx, ty: &str, p: &Params, loc: &Loc) -> Result<(), SceneError> {
    let m = ctx.world * ctx.gs.ctm;
    let pt = |name: &str, d: [f64; 3]| -> Result<DVec3, SceneError> {
        Ok(match p.nums(name)? {
            None => DVec3::from_array(d),
            Some(v) if v.len() == 3 => DVec3::new(v[0], v[1], v[2]),
            Some(_) => {
                return Err(p
                    .loc(name, loc)
                    .error(format!("\"{name}\" must be 3 numbers")))
            }
        })
    };
    let what = format!("LightSource \"{ty}\"");
    match ty {
        "point" => {
            let i = radiance(ctx, p, "I", loc)?;
            let pos = m.transform_point3(pt("from", [0.0; 3])?);
            ctx.doc.light(
                json!({"type": "point", "position": pos.to_array(), "intensity": i}),
                loc,
            );
        }
        "spot" => {
            let i = radiance(ctx, p, "I", loc)?;
            let (from, to) = (
                m.transform_point3(pt("from", [0.0; 3])?),
                m.transform_point3(pt("to", [0.0, 0.0, 1.0])?),
            );
            let cone = p.num("coneangle")?.unwrap_or(30.0);
            let delta = p.num("conedelta")?.unwrap_or(5.0);
            ctx.report.warn(loc, "spot light: pbrt's smoothstep falloff becomes candela's linear falloff over the same angles");
            ctx.doc.light(json!({"type": "spot", "position": from.to_array(), "look_at": to.to_array(), "intensity": i,
                                 "cutoff_angle": cone, "beam_width": (cone - delta).max(0.0)}), loc);
        }
        "distant" => {
            let l = radiance(ctx, p, "L", loc)?;
            let d = m.transform_vector3(pt("to", [0.0, 0.0, 1.0])? - pt("from", [0.0; 3])?);
            ctx.doc.light(
                json!({"type": "directional", "direction": d.to_array(), "irradiance": l}),
                loc,
            );
        }
        "infinite" => {
            if p.has("filename") {
                p.string("filename")?;
                ctx.report.unsupported(&p.loc("filename", loc), "an infinite light with an image is not supported (pbrt-v4 maps it equal-area, candela equirectangular)", "skipped")?;
                p.ignore(&["L", "scale", "illuminance", "portal"]);
            } else {
                let l = radiance(ctx, p, "L", loc)?;
                if ctx.doc.environment.is_some() {
                    ctx.report.unsupported(
                        loc,
                        "a second infinite light is not supported",
                        "skipped",
                    )?;
                } else {
                    ctx.doc.environment = Some(json!({"type": "constant", "radiance": l}));
                }
            }
        }
        _ => {
            ctx.report.unsupported(
                loc,
                &format!("{what} is not supported (point, spot, distant and infinite are)"),
                "skipped",
            )?;
            p.ignore_all();
        }
    }
    p.finish(&mut ctx.report, &what)
}

/// `AreaLightSource "diffuse"`: emission for the shapes that follow in this attribute block.
pub(super) fn area_light(ctx: &mut Ctx, ty: &str, p: &Params, loc: &Loc) -> Result<(), SceneError> {
    if ty != "diffuse" {
        return ctx.report.unsupported(
            loc,
            &format!("AreaLightSource \"{ty}\" is not supported (diffuse is)"),
            "skipped",
        );
    }
    let l = radiance(ctx, p, "L", loc)?;
    if p.bool("twosided")? == Some(true) {
        ctx.report.unsupported(
            &p.loc("twosided", loc),
            "a two-sided area light is not supported (candela's emitters emit from the front)",
            "front side only",
        )?;
    }
    if p.has("filename") {
        p.string("filename")?;
        ctx.report.unsupported(
            &p.loc("filename", loc),
            "an image area light is not supported",
            "ignored",
        )?;
    }
    p.finish(&mut ctx.report, "AreaLightSource \"diffuse\"")?;
    ctx.gs.area = Some((l, loc.clone()));
    Ok(())
}
