//! glTF metallic-roughness materials → candela `principled` (docs/import.md has the table):
//! base colour = baseColorFactor × baseColorTexture (sRGB); roughness = roughnessFactor × the G
//! channel and metallic = metallicFactor × the B channel of metallicRoughnessTexture (linear;
//! `"channel"` when the factor is 1, else a derived texture); emission = emissiveFactor ×
//! KHR_materials_emissive_strength (constant); alphaMode MASK → `alpha_mask` from the base
//! colour's alpha (a derived 0/1 texture unless the cutoff is 0.5 and the factor's alpha 1);
//! KHR_materials_ior → `ior`; KHR_materials_transmission → `spec_trans` (R channel);
//! doubleSided false → `two_sided: false`. The glTF default material is white, metallic 1,
//! roughness 1. Normal maps, emissive textures, BLEND, other uv sets, non-repeating samplers and
//! texture transforms other than an integer v scale are unsupported.

use serde_json::{json, Map, Value};

use super::{read_uri, relative_uri, Ctx};
use crate::import::files::to_slash;
use crate::scene::SceneError;

/// The scene material for glTF material `m` (converted once).
pub(super) fn material(ctx: &mut Ctx, m: &::gltf::Material) -> Result<String, SceneError> {
    if let Some(name) = ctx.materials.get(&m.index()) {
        return Ok(name.clone());
    }
    let (path, hint) = match m.index() {
        Some(i) => (
            format!("materials[{i}]"),
            m.name()
                .map(String::from)
                .unwrap_or_else(|| format!("material_{i}")),
        ),
        None => ("the default material".into(), "default".into()),
    };
    let value = convert(ctx, m, &path, &hint)?;
    let name = ctx.doc.material(&hint, value, &ctx.at(&path));
    ctx.materials.insert(m.index(), name.clone());
    Ok(name)
}

fn convert(
    ctx: &mut Ctx,
    m: &::gltf::Material,
    path: &str,
    hint: &str,
) -> Result<Value, SceneError> {
    let pbr = m.pbr_metallic_roughness();
    let mut out = Map::new();
    out.insert("type".into(), json!("principled"));
    // Step 1: base colour, metallic, roughness.
    let [r, g, b, a] = pbr.base_color_factor().map(|x| x as f64);
    let base = match pbr.base_color_texture() {
        None => Some(grey_or_rgb([r, g, b])),
        Some(info) => texture(
            ctx,
            &info,
            &format!("{path}.pbrMetallicRoughness.baseColorTexture"),
            &format!("{hint}_base_color"),
            Texel::Rgb([r, g, b]),
            None,
        )?,
    };
    out.insert(
        "base_color".into(),
        base.unwrap_or_else(|| grey_or_rgb([r, g, b])),
    );
    let (metallic, roughness) = (pbr.metallic_factor() as f64, pbr.roughness_factor() as f64);
    match pbr.metallic_roughness_texture() {
        None => {
            out.insert("metallic".into(), json!(metallic));
            out.insert("roughness".into(), json!(roughness));
        }
        Some(info) => {
            let p = format!("{path}.pbrMetallicRoughness.metallicRoughnessTexture");
            let mt = texture(
                ctx,
                &info,
                &p,
                &format!("{hint}_metallic"),
                Texel::Channel(2, metallic),
                Some(false),
            )?;
            let rt = texture(
                ctx,
                &info,
                &p,
                &format!("{hint}_roughness"),
                Texel::Channel(1, roughness),
                Some(false),
            )?;
            out.insert("metallic".into(), mt.unwrap_or(json!(metallic)));
            out.insert("roughness".into(), rt.unwrap_or(json!(roughness)));
        }
    }
    // Step 2: extensions.
    if let Some(ior) = m.ior() {
        out.insert("ior".into(), json!(ior as f64));
    }
    if let Some(t) = m.transmission() {
        let f = t.transmission_factor() as f64;
        let v = match t.transmission_texture() {
            None => Some(json!(f)),
            Some(info) => texture(
                ctx,
                &info,
                &format!("{path}.extensions.KHR_materials_transmission.transmissionTexture"),
                &format!("{hint}_transmission"),
                Texel::Channel(0, f),
                Some(false),
            )?,
        };
        if let Some(v) = v.filter(|v| v != &json!(0.0)) {
            out.insert("spec_trans".into(), v);
        }
    }
    // Step 3: emission (constant), alpha, sides, what is not supported.
    let strength = m.emissive_strength().unwrap_or(1.0) as f64;
    let e = m.emissive_factor().map(|x| x as f64 * strength);
    if e.iter().any(|&x| x != 0.0) {
        if m.emissive_texture().is_some() {
            ctx.report.unsupported(
                &ctx.at(&format!("{path}.emissiveTexture")),
                "an emissive texture is not supported (candela's emission is constant per material)",
                "emissiveFactor × strength alone",
            )?;
        }
        out.insert("emission".into(), json!(e));
    }
    match m.alpha_mode() {
        ::gltf::material::AlphaMode::Opaque => {}
        ::gltf::material::AlphaMode::Mask => {
            let cutoff = m.alpha_cutoff().unwrap_or(0.5) as f64;
            match pbr.base_color_texture() {
                Some(info) => {
                    let mask = texture(ctx, &info, &format!("{path}.pbrMetallicRoughness.baseColorTexture"), &format!("{hint}_mask"), Texel::Mask(a, cutoff), None)?;
                    if let Some(mask) = mask {
                        out.insert("alpha_mask".into(), mask);
                    }
                }
                None if a >= cutoff => {}
                None => ctx.report.unsupported(
                    &ctx.at(&format!("{path}.alphaMode")),
                    "alphaMode MASK cutting the whole surface away (no texture, alpha below the cutoff) is not supported",
                    "opaque",
                )?,
            }
        }
        ::gltf::material::AlphaMode::Blend => ctx.report.unsupported(
            &ctx.at(&format!("{path}.alphaMode")),
            "alphaMode BLEND is not supported (candela's alpha masks cut out, they do not blend)",
            "opaque",
        )?,
    }
    if !m.double_sided() {
        out.insert("two_sided".into(), json!(false));
    }
    if m.normal_texture().is_some() {
        ctx.report.unsupported(
            &ctx.at(&format!("{path}.normalTexture")),
            "normal maps are not supported",
            "ignored",
        )?;
    }
    Ok(Value::Object(out))
}

/// `[r, g, b]`, or one number when the three are equal.
fn grey_or_rgb(c: [f64; 3]) -> Value {
    if c[0] == c[1] && c[1] == c[2] {
        json!(c[0])
    } else {
        json!(c)
    }
}

/// What a texture reference reads.
#[derive(Clone, Copy)]
enum Texel {
    /// Colour × factor.
    Rgb([f64; 3]),
    /// One channel (0 = R) × factor.
    Channel(usize, f64),
    /// 1 where alpha × factor ≥ cutoff, else 0.
    Mask(f64, f64),
}

/// A candela texture reference for `info` reading `texel` (None when skipped under --lenient).
fn texture(
    ctx: &mut Ctx,
    info: &::gltf::texture::Info,
    path: &str,
    hint: &str,
    texel: Texel,
    srgb: Option<bool>,
) -> Result<Option<Value>, SceneError> {
    let at = ctx.at(path);
    // Step 1: uv set, transform and sampler.
    let mut set = info.tex_coord();
    let mut scale = [1.0f64, 1.0];
    if let Some(t) = info.texture_transform() {
        set = t.tex_coord().unwrap_or(set);
        let [su, sv] = t.scale().map(|x| x as f64);
        let shifted = t.offset() != [0.0, 0.0] || t.rotation() != 0.0;
        // candela's v = 1 − glTF's v: scaling v agrees with glTF only by an integer.
        if shifted || sv.fract() != 0.0 {
            ctx.report.unsupported(&at, "KHR_texture_transform with an offset, a rotation or a non-integer v scale is not supported", "its scale is kept")?;
        }
        scale = [su, sv];
    }
    if set != 0 {
        ctx.report.unsupported(
            &at,
            &format!("texture coordinate set {set} is not supported (only TEXCOORD_0)"),
            "the texture is ignored",
        )?;
        return Ok(None);
    }
    let tex = info.texture();
    let sampler = tex.sampler();
    use ::gltf::texture::WrappingMode;
    if sampler.wrap_s() != WrappingMode::Repeat || sampler.wrap_t() != WrappingMode::Repeat {
        ctx.report.unsupported(
            &ctx.at(&format!("samplers[{}]", sampler.index().unwrap_or(0))),
            "clamped or mirrored texture wrapping is not supported (candela repeats)",
            "repeat",
        )?;
    }
    // Step 2: the image file, then the reference (a derived texture when a factor or cutoff applies).
    let Some(file) = image_file(ctx, &tex.source())? else {
        return Ok(None);
    };
    let mut r = Map::new();
    let identity = match texel {
        Texel::Rgb(f) => f == [1.0; 3],
        Texel::Channel(_, f) => f == 1.0,
        Texel::Mask(a, cutoff) => a == 1.0 && cutoff == 0.5,
    };
    if identity {
        r.insert("texture".into(), json!(file));
        if srgb == Some(false) {
            r.insert("srgb".into(), json!(false));
        }
        let channel = match texel {
            Texel::Channel(c, _) => Some(["r", "g", "b"][c]),
            Texel::Mask(..) => Some("a"),
            Texel::Rgb(_) => None,
        };
        if let Some(c) = channel {
            r.insert("channel".into(), json!(c));
        }
    } else {
        let dir = ctx.dir.clone();
        let derived = ctx
            .doc
            .derived_texture(&dir, &file, srgb, hint, move |t| match texel {
                Texel::Rgb(f) => [t[0] * f[0] as f32, t[1] * f[1] as f32, t[2] * f[2] as f32],
                Texel::Channel(c, f) => [t[c] * f as f32; 3],
                Texel::Mask(a, cutoff) => [if t[3] as f64 * a >= cutoff { 1.0 } else { 0.0 }; 3],
            })?;
        r.insert("texture".into(), json!(derived));
    }
    if scale != [1.0, 1.0] {
        r.insert("scale".into(), json!(scale));
    }
    Ok(Some(Value::Object(r)))
}

/// The file of a glTF image: beside the glTF (as named), or held in memory (data URIs, buffer
/// views); None when its format is not supported (under --lenient).
fn image_file(ctx: &mut Ctx, image: &::gltf::Image) -> Result<Option<String>, SceneError> {
    if let Some(f) = ctx.images.get(&image.index()) {
        return Ok(f.clone());
    }
    let at = ctx.at(&format!("images[{}]", image.index()));
    let ext_of_mime = |mime: &str| match mime {
        "image/png" => Some("png"),
        "image/jpeg" => Some("jpg"),
        _ => None,
    };
    let hint = image
        .name()
        .map(String::from)
        .unwrap_or_else(|| format!("image{}", image.index()));
    let file = match image.source() {
        ::gltf::image::Source::View { view, mime_type } => match ext_of_mime(mime_type) {
            Some(ext) => {
                let data = &ctx.buffers[view.buffer().index()];
                let bytes = data
                    .get(view.offset()..view.offset() + view.length())
                    .ok_or_else(|| at.error("its bufferView lies outside the buffer"))?
                    .to_vec();
                Some(ctx.doc.file(&hint, ext, bytes))
            }
            None => None,
        },
        ::gltf::image::Source::Uri { uri, mime_type } if uri.starts_with("data:") => {
            let mime = mime_type.or_else(|| uri[5..].split(';').next());
            match mime.and_then(ext_of_mime) {
                Some(ext) => {
                    let bytes = read_uri(uri, &ctx.dir).map_err(|e| at.error(e))?;
                    Some(ctx.doc.file(&hint, ext, bytes))
                }
                None => None,
            }
        }
        ::gltf::image::Source::Uri { uri, .. } => {
            let rel = to_slash(&relative_uri(uri, &ctx.dir).map_err(|e| at.error(e))?);
            let ext = rel.rsplit('.').next().unwrap_or("").to_ascii_lowercase();
            matches!(ext.as_str(), "png" | "jpg" | "jpeg").then_some(rel)
        }
    };
    if file.is_none() {
        ctx.report.unsupported(
            &at,
            "only PNG and JPEG images are supported",
            "the texture is ignored",
        )?;
    }
    ctx.images.insert(image.index(), file.clone());
    Ok(file)
}
