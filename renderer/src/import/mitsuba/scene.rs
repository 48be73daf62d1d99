//! Mitsuba's sensor (perspective / thinlens, its film, reconstruction filter and sampler), the
//! integrator's depth and the emitters that are not attached to shapes (point, spot,
//! directional, constant, envmap), with Mitsuba 3's defaults where the XML says nothing.

use glam::{DMat4, DVec3};
use serde_json::{json, Map, Value};

use super::props::{ColorSrc, Plugin};
use super::Ctx;
use crate::import::xform::{camera_frame, camera_value, mirrors_image};
use crate::scene::SceneError;

/// Mitsuba's film size when none is given.
const DEFAULT_FILM: (i64, i64) = (768, 576);

/// `[r, g, b]`, or one number when the three are equal.
pub(crate) fn rgb_value(c: [f64; 3]) -> Value {
    if c[0] == c[1] && c[1] == c[2] {
        json!(c[0])
    } else {
        json!(c)
    }
}

/// A constant colour parameter (textures are not supported where this is used).
pub(crate) fn const_color(
    ctx: &mut Ctx,
    p: &Plugin,
    name: &str,
    default: f64,
) -> Result<[f64; 3], SceneError> {
    match p.color(name)? {
        None => Ok([default; 3]),
        Some(ColorSrc::Const(c)) => Ok(c),
        Some(ColorSrc::Texture(_)) => {
            ctx.report.unsupported(
                &p.loc_of(name),
                &format!("{}: a texture for \"{name}\" is not supported", p.what()),
                &format!("uses {default}"),
            )?;
            Ok([default; 3])
        }
    }
}

/// The sensor (the first one; Mitsuba renders sensor 0), or Mitsuba's default camera.
pub(crate) fn sensor(ctx: &mut Ctx, sensors: &[usize]) -> Result<(), SceneError> {
    let Some(&s) = sensors.first() else {
        let root = &ctx.tree.nodes[ctx.tree.root];
        ctx.report.warn(
            &root.loc,
            "no <sensor>: Mitsuba's default camera (at the origin, looking down +Z, 50 mm lens, 768×576 film)",
        );
        ctx.doc.camera =
            camera_value(&camera_frame(&DMat4::IDENTITY, DVec3::Z, DVec3::Y).expect("identity"));
        ctx.doc.camera.insert(
            "fov_y".into(),
            json!(fov_y(&Fov::Diagonal(focal_fov(50.0)), 768.0, 576.0)),
        );
        film_defaults(ctx);
        return Ok(());
    };
    for &extra in &sensors[1..] {
        let loc = ctx.tree.nodes[extra].loc.clone();
        ctx.report.warn(
            &loc,
            "only the first <sensor> is used (Mitsuba renders sensor 0)",
        );
    }
    let p = Plugin::new(ctx.tree, s)?;
    if !matches!(p.ty.as_str(), "perspective" | "thinlens") {
        ctx.report.unsupported(
            &p.loc,
            &format!(
                "{} is not supported (candela has perspective and thin-lens cameras)",
                p.what()
            ),
            "a perspective camera with its transform and fov",
        )?;
    }
    // Step 1: film size and filter (the field of view depends on the aspect ratio).
    let (w, h) = match p.children("film").first() {
        Some(&f) => film(ctx, f)?,
        None => {
            film_defaults(ctx);
            (DEFAULT_FILM.0 as f64, DEFAULT_FILM.1 as f64)
        }
    };
    for sampler_node in p.children("sampler") {
        sampler(ctx, sampler_node)?;
    }
    // Step 2: placement; a mirroring transform mirrors the whole scene instead.
    let m = p.transform("to_world")?;
    if mirrors_image(&m, -DVec3::X, DVec3::Z, DVec3::Y) {
        ctx.world = DMat4::from_scale(DVec3::new(-1.0, 1.0, 1.0));
        ctx.report.warn(
            &p.loc_of("to_world"),
            "the sensor's transform mirrors the image: the whole scene is mirrored (x → −x) so candela draws the same image",
        );
    }
    let frame = camera_frame(&(ctx.world * m), DVec3::Z, DVec3::Y).map_err(|_| {
        p.loc_of("to_world").error(format!(
            "{}: to_world must be a rotation, translation and uniform scale (the view and up directions must stay perpendicular)",
            p.what()
        ))
    })?;
    let mut camera: Map<String, Value> = camera_value(&frame);
    // Step 3: field of view.
    let fov = match (p.float("fov")?, p.get("focal_length").cloned()) {
        (Some(_), Some(_)) => {
            return Err(p
                .loc
                .error("give either \"fov\" or \"focal_length\", not both"))
        }
        (Some(f), None) => match p.string("fov_axis")?.as_deref().unwrap_or("x") {
            "x" => Fov::X(f),
            "y" => Fov::Y(f),
            "diagonal" => Fov::Diagonal(f),
            "smaller" if w < h => Fov::X(f),
            "smaller" => Fov::Y(f),
            "larger" if w > h => Fov::X(f),
            "larger" => Fov::Y(f),
            other => {
                return Err(p.loc_of("fov_axis").error(format!(
                    "unknown fov_axis \"{other}\" (x, y, diagonal, smaller or larger)"
                )))
            }
        },
        (None, Some(v)) => {
            let mm = match v {
                super::props::PValue::Str(s) => s.trim().trim_end_matches("mm").trim().parse().ok(),
                super::props::PValue::Float(x) => Some(x),
                _ => None,
            };
            let mm: f64 = mm.filter(|x: &f64| *x > 0.0).ok_or_else(|| {
                p.loc_of("focal_length")
                    .error("focal_length must be a length in millimetres, like \"50mm\"")
            })?;
            Fov::Diagonal(focal_fov(mm))
        }
        (None, None) => Fov::Diagonal(focal_fov(50.0)),
    };
    camera.insert("fov_y".into(), json!(fov_y(&fov, w, h)));
    // Step 4: lens and what does not change the image.
    let far = p.float("far_clip")?.unwrap_or(1e4);
    if p.ty == "thinlens" {
        let radius = p
            .float("aperture_radius")?
            .ok_or_else(|| p.loc.error("sensor \"thinlens\" needs \"aperture_radius\""))?;
        camera.insert("aperture_radius".into(), json!(radius));
        camera.insert(
            "focus_distance".into(),
            json!(p.float("focus_distance")?.unwrap_or(far)),
        );
    }
    p.ignore(&["near_clip", "shutter_open", "shutter_close", "srf"]);
    for key in ["principal_point_offset_x", "principal_point_offset_y"] {
        if p.float(key)?.is_some_and(|x| x != 0.0) {
            ctx.report.unsupported(
                &p.loc_of(key),
                &format!(
                    "{}: \"{key}\" (an off-centre image) is not supported",
                    p.what()
                ),
                "ignored",
            )?;
        }
    }
    p.finish(&mut ctx.report)?;
    ctx.doc.camera = camera;
    Ok(())
}

/// A field of view in degrees along one axis.
enum Fov {
    X(f64),
    Y(f64),
    Diagonal(f64),
}

/// Mitsuba's `focal_length`: the diagonal field of view of a 36 × 24 mm film.
fn focal_fov(mm: f64) -> f64 {
    2.0 * (36f64.hypot(24.0) / (2.0 * mm)).atan().to_degrees()
}

/// The vertical field of view of a `w` × `h` film.
fn fov_y(fov: &Fov, w: f64, h: f64) -> f64 {
    let t = |deg: f64| (deg.to_radians() / 2.0).tan();
    let from_tan = |x: f64| 2.0 * x.atan().to_degrees();
    match *fov {
        Fov::Y(f) => f,
        Fov::X(f) => from_tan(t(f) * h / w),
        Fov::Diagonal(f) => from_tan(t(f) * h / w.hypot(h)),
    }
}

/// Mitsuba's default film: 768 × 576, Gaussian filter (stddev 0.5).
fn film_defaults(ctx: &mut Ctx) {
    ctx.doc.film.insert("width".into(), json!(DEFAULT_FILM.0));
    ctx.doc.film.insert("height".into(), json!(DEFAULT_FILM.1));
    ctx.doc
        .film
        .insert("filter".into(), json!({"type": "gaussian", "stddev": 0.5}));
}

/// `<film type="hdrfilm">`; returns (width, height).
fn film(ctx: &mut Ctx, node: usize) -> Result<(f64, f64), SceneError> {
    let p = Plugin::new(ctx.tree, node)?;
    if p.ty != "hdrfilm" {
        ctx.report.unsupported(
            &p.loc,
            &format!("{} is not supported", p.what()),
            "read as an hdrfilm",
        )?;
    }
    let w = p.int("width")?.unwrap_or(DEFAULT_FILM.0);
    let h = p.int("height")?.unwrap_or(DEFAULT_FILM.1);
    if w < 1 || h < 1 {
        return Err(p.loc.error("film width and height must be positive"));
    }
    for (key, full) in [
        ("crop_offset_x", 0),
        ("crop_offset_y", 0),
        ("crop_width", w),
        ("crop_height", h),
    ] {
        if p.int(key)?.is_some_and(|v| v != full) {
            ctx.report.unsupported(
                &p.loc_of(key),
                &format!("{}: cropping (\"{key}\") is not supported", p.what()),
                "the whole image is rendered",
            )?;
        }
    }
    p.ignore(&[
        "pixel_format",
        "component_format",
        "file_format",
        "banner",
        "sample_border",
        "compensate",
    ]);
    let filter = match p.children("rfilter").first() {
        None => json!({"type": "gaussian", "stddev": 0.5}),
        Some(&f) => rfilter(ctx, f)?,
    };
    p.finish(&mut ctx.report)?;
    ctx.doc.film.insert("width".into(), json!(w));
    ctx.doc.film.insert("height".into(), json!(h));
    ctx.doc.film.insert("filter".into(), filter);
    Ok((w as f64, h as f64))
}

/// `<rfilter>`: box (radius 0.5) or gaussian.
fn rfilter(ctx: &mut Ctx, node: usize) -> Result<Value, SceneError> {
    let p = Plugin::new(ctx.tree, node)?;
    let v = match p.ty.as_str() {
        "box" => {
            if p.float("radius")?.is_some_and(|r| r != 0.5) {
                ctx.report.unsupported(
                    &p.loc_of("radius"),
                    "rfilter \"box\": a radius other than 0.5 is not supported",
                    "radius 0.5",
                )?;
            }
            json!("box")
        }
        "gaussian" => json!({"type": "gaussian", "stddev": p.float("stddev")?.unwrap_or(0.5)}),
        _ => {
            ctx.report.unsupported(
                &p.loc,
                &format!("{} is not supported (box and gaussian are)", p.what()),
                "the box filter",
            )?;
            p.ignore(&["radius", "b", "c", "lobes"]);
            json!("box")
        }
    };
    p.finish(&mut ctx.report)?;
    Ok(v)
}

/// `<sampler>`: its sample count becomes the scene's default spp.
fn sampler(ctx: &mut Ctx, node: usize) -> Result<(), SceneError> {
    let p = Plugin::new(ctx.tree, node)?;
    const KNOWN: &[&str] = &[
        "independent",
        "stratified",
        "multijitter",
        "orthogonal",
        "ldsampler",
    ];
    if !KNOWN.contains(&p.ty.as_str()) {
        ctx.report.unsupported(
            &p.loc,
            &format!("{} is not supported", p.what()),
            "its sample_count is used",
        )?;
    }
    let spp = p.int("sample_count")?.unwrap_or(4);
    if spp < 1 {
        return Err(p
            .loc_of("sample_count")
            .error("sample_count must be at least 1"));
    }
    // candela's own sampler; these only shape Mitsuba's sample patterns.
    p.ignore(&["seed", "jitter", "strength", "scramble_seed", "dimension"]);
    p.finish(&mut ctx.report)?;
    ctx.doc.render.insert("spp".into(), json!(spp));
    Ok(())
}

/// `<integrator>`: path / volpath / direct → candela's `nee` with Mitsuba's max_depth.
pub(crate) fn integrator(ctx: &mut Ctx, node: usize) -> Result<(), SceneError> {
    let p = Plugin::new(ctx.tree, node)?;
    let max_depth = match p.ty.as_str() {
        "path" | "volpath" | "volpathmis" => p.int("max_depth")?.unwrap_or(-1),
        "direct" => {
            p.ignore(&["emitter_samples", "bsdf_samples", "shading_samples"]);
            2
        }
        _ => {
            ctx.report.unsupported(
                &p.loc,
                &format!(
                    "{} is not supported (path, volpath and direct are)",
                    p.what()
                ),
                "a path tracer (nee)",
            )?;
            p.ignore(&["max_depth", "rr_depth", "hide_emitters"]);
            p.children("integrator");
            -1
        }
    };
    if max_depth == 0 || max_depth < -1 {
        return Err(p
            .loc_of("max_depth")
            .error("max_depth must be -1 (unbounded) or at least 1"));
    }
    if p.bool("hide_emitters")? == Some(true) {
        ctx.report.unsupported(
            &p.loc_of("hide_emitters"),
            "integrator: hide_emitters is not supported",
            "emitters stay visible",
        )?;
    }
    // candela's Russian roulette is its own (unbiased either way).
    p.ignore(&["rr_depth"]);
    p.finish(&mut ctx.report)?;
    ctx.doc.render.insert("integrator".into(), json!("nee"));
    ctx.doc.render.insert("max_depth".into(), json!(max_depth));
    Ok(())
}

/// A top-level `<emitter>`.
pub(crate) fn emitter(ctx: &mut Ctx, node: usize) -> Result<(), SceneError> {
    let p = Plugin::new(ctx.tree, node)?;
    let loc = p.loc.clone();
    match p.ty.as_str() {
        "point" => {
            let position = match (p.vec3("position")?, p.has("to_world")) {
                (Some(_), true) => {
                    return Err(loc.error("emitter \"point\": give position or to_world, not both"))
                }
                (Some(pos), false) => ctx.point(pos),
                (None, _) => ctx.to_world(&p, "to_world")?.transform_point3(DVec3::ZERO),
            };
            let intensity = const_color(ctx, &p, "intensity", 1.0)?;
            p.finish(&mut ctx.report)?;
            ctx.doc.light(
                json!({"type": "point", "position": position.to_array(), "intensity": rgb_value(intensity)}),
                &loc,
            );
        }
        "spot" => {
            let m = ctx.to_world(&p, "to_world")?;
            let position = m.transform_point3(DVec3::ZERO);
            let dir = m.transform_vector3(DVec3::Z).normalize();
            let intensity = const_color(ctx, &p, "intensity", 1.0)?;
            let cutoff = p.float("cutoff_angle")?.unwrap_or(20.0);
            let beam = p.float("beam_width")?.unwrap_or(cutoff * 0.75);
            if p.has("texture") {
                p.get("texture");
                ctx.report.unsupported(
                    &p.loc_of("texture"),
                    "emitter \"spot\": a projected texture is not supported",
                    "ignored",
                )?;
            }
            p.finish(&mut ctx.report)?;
            ctx.doc.light(
                json!({"type": "spot", "position": position.to_array(),
                       "look_at": (position + dir).to_array(), "intensity": rgb_value(intensity),
                       "cutoff_angle": cutoff, "beam_width": beam}),
                &loc,
            );
        }
        "directional" => {
            let direction = match (p.vec3("direction")?, p.has("to_world")) {
                (Some(_), true) => {
                    return Err(
                        loc.error("emitter \"directional\": give direction or to_world, not both")
                    )
                }
                (Some(d), false) => ctx.vector(d),
                (None, _) => ctx.to_world(&p, "to_world")?.transform_vector3(DVec3::Z),
            };
            let irradiance = const_color(ctx, &p, "irradiance", 1.0)?;
            p.finish(&mut ctx.report)?;
            ctx.doc.light(
                json!({"type": "directional", "direction": direction.to_array(), "irradiance": rgb_value(irradiance)}),
                &loc,
            );
        }
        "constant" => {
            let radiance = const_color(ctx, &p, "radiance", 1.0)?;
            p.finish(&mut ctx.report)?;
            set_environment(
                ctx,
                &loc,
                json!({"type": "constant", "radiance": rgb_value(radiance)}),
            )?;
        }
        "envmap" => {
            let env = envmap(ctx, &p)?;
            p.finish(&mut ctx.report)?;
            if let Some(env) = env {
                set_environment(ctx, &loc, env)?;
            }
        }
        "area" => {
            return Err(loc
                .error("emitter \"area\" must be nested in a <shape> (it emits from that shape)"))
        }
        _ => {
            ctx.report.unsupported(
                &loc,
                &format!(
                    "{} is not supported (point, spot, directional, constant, envmap and area are)",
                    p.what()
                ),
                "skipped",
            )?;
        }
    }
    Ok(())
}

/// The scene's one environment.
fn set_environment(ctx: &mut Ctx, loc: &crate::import::Loc, env: Value) -> Result<(), SceneError> {
    if ctx.doc.environment.is_some() {
        return ctx.report.unsupported(
            loc,
            "a second environment emitter (constant / envmap) is not supported",
            "skipped",
        );
    }
    ctx.doc.environment = Some(env);
    Ok(())
}

/// `envmap`: its `to_world` must turn about +Y only (candela's `rotate_y`).
fn envmap(ctx: &mut Ctx, p: &Plugin) -> Result<Option<Value>, SceneError> {
    let file = p
        .string("filename")?
        .ok_or_else(|| p.loc.error("emitter \"envmap\" needs \"filename\""))?;
    let rel = ctx.tree.resolve(p.node, &file)?;
    let scale = p.float("scale")?.unwrap_or(1.0);
    p.ignore(&["mis_compensation", "filter_type"]);
    if p.has("bitmap") {
        p.get("bitmap");
        return Err(p
            .loc
            .error("emitter \"envmap\": an in-memory \"bitmap\" is not supported"));
    }
    if ctx.world != DMat4::IDENTITY {
        ctx.report.unsupported(
            &p.loc,
            "emitter \"envmap\" under a mirrored sensor is not supported",
            "skipped",
        )?;
        return Ok(None);
    }
    // candela's map: to_world = R_y(rotate_y − 180°) (tests/mitsuba/ref_scene.py).
    let m = p.transform("to_world")?;
    let y = m.transform_vector3(DVec3::Y);
    let x = m.transform_vector3(DVec3::X);
    let rigid = (m.transform_vector3(DVec3::Z).cross(x) - y).length() < 1e-6
        && (x.length() - 1.0).abs() < 1e-6
        && (y - DVec3::Y).length() < 1e-6;
    if !rigid {
        ctx.report.unsupported(
            &p.loc_of("to_world"),
            "emitter \"envmap\": to_world must be a rotation about +Y (candela's environment turns about Y only)",
            "the rotation about Y is kept",
        )?;
    }
    // R_y(θ) maps x to (cos θ, 0, −sin θ).
    let theta = (-x.z).atan2(x.x).to_degrees();
    let rotate_y = theta + 180.0;
    Ok(Some(
        json!({"type": "map", "file": rel, "scale": scale, "rotate_y": rotate_y}),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_of_view() {
        // Mitsuba's default: 50 mm on 768 × 576 is x_fov 38.1848 (printed by Mitsuba 3.9.1).
        let fy = fov_y(&Fov::Diagonal(focal_fov(50.0)), 768.0, 576.0);
        let fx = 2.0
            * ((fy.to_radians() / 2.0).tan() * 768.0 / 576.0)
                .atan()
                .to_degrees();
        assert!((fx - 38.1848).abs() < 1e-3, "{fx}");
        assert!((fov_y(&Fov::X(90.0), 200.0, 100.0) - 53.130102).abs() < 1e-5);
        assert_eq!(fov_y(&Fov::Y(30.0), 200.0, 100.0), 30.0);
    }
}
