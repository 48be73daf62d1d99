//! Texture loading: PNG/JPEG/HDR through `image`, EXR through `exr`, decoded to linear RGBA f32
//! (row 0 at the top). 8- and 16-bit channels are normalised; `srgb` applies the sRGB transfer
//! function's inverse (IEC 61966-2-1) to colour channels, never to alpha. A file is decoded once
//! per sRGB flag; references with another UV scale share the decoded texels. A reference with a
//! `channel` gets its own texture whose colour channels all hold that channel (alpha 1), so the
//! GPU side, which reads red for scalars and masks, needs no per-reference channel.

use std::collections::HashMap;
use std::io::Cursor;
use std::path::PathBuf;

use glam::Vec2;

use super::desc::{Channel, TextureRefDesc};
use super::error::{join_path, SceneError};
use super::paths::{self, AssetPath, AssetRoot};
use super::{Limits, Texture};

/// The sRGB decoding curve (sRGB-encoded value → linear).
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Image formats by extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Format {
    Png,
    Jpeg,
    Hdr,
    Exr,
}

impl Format {
    fn from_name(rel: &str) -> Option<Format> {
        match paths::extension(rel).as_str() {
            "png" => Some(Format::Png),
            "jpg" | "jpeg" => Some(Format::Jpeg),
            "hdr" => Some(Format::Hdr),
            "exr" => Some(Format::Exr),
            _ => None,
        }
    }
    /// sRGB is the default for 8-bit formats only.
    fn default_srgb(self) -> bool {
        matches!(self, Format::Png | Format::Jpeg)
    }
}

/// The scene's textures, de-duplicated as they are loaded.
pub(crate) struct TextureCache<'a> {
    root: AssetRoot<'a>,
    limits: &'a Limits,
    pub textures: Vec<Texture>,
    /// (file, srgb, scale bits, channel) → index in `textures`.
    by_key: HashMap<(PathBuf, bool, [u32; 2], Option<Channel>), u32>,
    /// (file, srgb, channel) → an index whose texels can be shared.
    decoded: HashMap<(PathBuf, bool, Option<Channel>), u32>,
}

impl<'a> TextureCache<'a> {
    pub fn new(root: AssetRoot<'a>, limits: &'a Limits) -> Self {
        TextureCache {
            root,
            limits,
            textures: Vec::new(),
            by_key: HashMap::new(),
            decoded: HashMap::new(),
        }
    }

    /// Loads the texture referenced at `path` (a `{"texture": ...}` object).
    pub fn load_ref(&mut self, r: &TextureRefDesc, path: &str) -> Result<u32, SceneError> {
        let scale = match r.scale {
            None => Vec2::ONE,
            Some([u, v]) => {
                let s = Vec2::new(u as f32, v as f32);
                if !(s.is_finite() && s.x != 0.0 && s.y != 0.0) {
                    return Err(SceneError::invalid(
                        join_path(path, "scale"),
                        format!("must be finite and non-zero, got [{u}, {v}]"),
                    ));
                }
                s
            }
        };
        self.load_channel(
            &r.texture,
            r.srgb,
            scale,
            r.channel,
            &join_path(path, "texture"),
        )
    }

    /// Loads `rel` (written at `path`) with an explicit or default sRGB flag and a UV scale.
    pub fn load(
        &mut self,
        rel: &str,
        srgb: Option<bool>,
        scale: Vec2,
        path: &str,
    ) -> Result<u32, SceneError> {
        self.load_channel(rel, srgb, scale, None, path)
    }

    /// [`TextureCache::load`] with one channel selected (None: all four as stored).
    fn load_channel(
        &mut self,
        rel: &str,
        srgb: Option<bool>,
        scale: Vec2,
        channel: Option<Channel>,
        path: &str,
    ) -> Result<u32, SceneError> {
        paths::check_relative(rel, path)?;
        let Some(format) = Format::from_name(rel) else {
            return Err(SceneError::invalid(
                path,
                format!(
                    "\"{rel}\": unsupported texture format (expected .png, .jpg, .jpeg, .exr or .hdr)"
                ),
            ));
        };
        let asset = paths::resolve(self.root, rel, path)?;
        let srgb = srgb.unwrap_or(format.default_srgb());
        let key = (
            asset.canonical.clone(),
            srgb,
            [scale.x.to_bits(), scale.y.to_bits()],
            channel,
        );
        if let Some(&i) = self.by_key.get(&key) {
            return Ok(i);
        }
        // Texels already decoded for this file: with this channel (use as they are), or raw.
        let exact = self.decoded.get(&(asset.canonical.clone(), srgb, channel));
        let raw = self.decoded.get(&(asset.canonical.clone(), srgb, None));
        let (mut texture, needs_channel) = match (exact, raw) {
            (Some(&i), _) => (self.textures[i as usize].clone(), false),
            (None, Some(&i)) => (self.textures[i as usize].clone(), channel.is_some()),
            (None, None) => {
                let bytes = paths::read(self.root, &asset, path)?;
                let (width, height, texels) =
                    decode(&bytes, &asset, format, srgb, self.limits, path)?;
                let texture = Texture {
                    source: rel.to_string(),
                    width,
                    height,
                    texels: texels.into(),
                    scale,
                };
                (texture, channel.is_some())
            }
        };
        texture.scale = scale;
        if let (Some(c), true) = (channel, needs_channel) {
            let picked = texture.texels.iter().map(|t| {
                let v = c.pick(*t);
                [v, v, v, 1.0]
            });
            texture.texels = picked.collect();
        }
        let index = u32::try_from(self.textures.len())
            .map_err(|_| SceneError::invalid(path, "too many textures"))?;
        self.textures.push(texture);
        self.by_key.insert(key, index);
        self.decoded
            .entry((asset.canonical, srgb, channel))
            .or_insert(index);
        Ok(index)
    }
}

/// Decodes the texture file `rel` (written at `path`) as the loader would, without caching:
/// (width, height, linear RGBA texels). Importers derive new textures from these.
pub(crate) fn decode_file(
    root: AssetRoot<'_>,
    rel: &str,
    srgb: Option<bool>,
    limits: &Limits,
    path: &str,
) -> Result<(u32, u32, Vec<[f32; 4]>), SceneError> {
    paths::check_relative(rel, path)?;
    let format = Format::from_name(rel).ok_or_else(|| {
        SceneError::invalid(path, format!("\"{rel}\": unsupported texture format"))
    })?;
    let asset = paths::resolve(root, rel, path)?;
    let bytes = paths::read(root, &asset, path)?;
    decode(
        &bytes,
        &asset,
        format,
        srgb.unwrap_or(format.default_srgb()),
        limits,
        path,
    )
}

/// Decodes a file's bytes to (width, height, linear RGBA texels).
fn decode(
    bytes: &[u8],
    asset: &AssetPath,
    format: Format,
    srgb: bool,
    limits: &Limits,
    path: &str,
) -> Result<(u32, u32, Vec<[f32; 4]>), SceneError> {
    let fail = |msg: String| SceneError::Decode {
        path: path.to_string(),
        file: asset.shown.clone(),
        msg,
    };
    let check_size = |w: u64, h: u64| {
        if w == 0 || h == 0 {
            return Err(fail("the image is empty".into()));
        }
        if w.saturating_mul(h) > limits.max_texture_pixels
            || w > u32::MAX as u64
            || h > u32::MAX as u64
        {
            return Err(fail(format!(
                "{w}×{h} pixels exceeds the limit of {} pixels",
                limits.max_texture_pixels
            )));
        }
        Ok(())
    };
    let (w, h, mut texels) = match format {
        Format::Exr => {
            let meta = exr::meta::MetaData::read_from_buffered(Cursor::new(bytes), false)
                .map_err(|e| fail(e.to_string()))?;
            for header in meta.headers.iter() {
                check_size(header.layer_size.0 as u64, header.layer_size.1 as u64)?;
            }
            decode_exr(bytes).map_err(fail)?
        }
        _ => {
            let image_format = match format {
                Format::Png => image::ImageFormat::Png,
                Format::Jpeg => image::ImageFormat::Jpeg,
                _ => image::ImageFormat::Hdr,
            };
            let (w, h) = image::ImageReader::with_format(Cursor::new(bytes), image_format)
                .into_dimensions()
                .map_err(|e| fail(e.to_string()))?;
            check_size(w as u64, h as u64)?;
            let mut reader = image::ImageReader::with_format(Cursor::new(bytes), image_format);
            let mut image_limits = image::Limits::default();
            image_limits.max_alloc = Some((w as u64 * h as u64).saturating_mul(32) + (64 << 20));
            reader.limits(image_limits);
            let img = reader.decode().map_err(|e| fail(e.to_string()))?;
            (w, h, to_rgba_f32(img))
        }
    };
    if srgb {
        for t in &mut texels {
            for c in &mut t[..3] {
                *c = srgb_to_linear(c.max(0.0));
            }
        }
    }
    Ok((w, h, texels))
}

/// Converts any decoded image to RGBA f32, normalising integer channels to [0, 1].
fn to_rgba_f32(img: image::DynamicImage) -> Vec<[f32; 4]> {
    use image::DynamicImage as D;
    match img {
        D::ImageLuma8(_) | D::ImageLumaA8(_) | D::ImageRgb8(_) | D::ImageRgba8(_) => img
            .to_rgba8()
            .pixels()
            .map(|p| p.0.map(|c| c as f32 / 255.0))
            .collect(),
        D::ImageRgb32F(_) | D::ImageRgba32F(_) => img.to_rgba32f().pixels().map(|p| p.0).collect(),
        _ => img
            .to_rgba16()
            .pixels()
            .map(|p| p.0.map(|c| c as f32 / 65535.0))
            .collect(),
    }
}

/// Reads the first RGB(A) layer of an EXR (alpha defaults to 1).
fn decode_exr(bytes: &[u8]) -> Result<(u32, u32, Vec<[f32; 4]>), String> {
    use exr::prelude::*;
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .rgba_channels(
            |size, _| (size.0, vec![[0.0f32; 4]; size.0 * size.1]),
            |(w, texels): &mut (usize, Vec<[f32; 4]>),
             pos: Vec2<usize>,
             (r, g, b, a): (f32, f32, f32, f32)| {
                if let Some(t) = texels.get_mut(pos.1 * *w + pos.0) {
                    *t = [r, g, b, a];
                }
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_buffered(Cursor::new(bytes))
        .map_err(|e| e.to_string())?;
    let size = image.layer_data.size;
    let (_, texels) = image.layer_data.channel_data.pixels;
    let w = u32::try_from(size.0).map_err(|_| "image too wide".to_string())?;
    let h = u32::try_from(size.1).map_err(|_| "image too tall".to_string())?;
    Ok((w, h, texels))
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::scene::paths::tests::temp_dir;
    use std::path::Path;

    /// Writes a 2×1 8-bit RGBA PNG: (128, 0, 255, 255), (255, 255, 255, 128).
    pub(crate) fn write_png(path: &Path) {
        let img =
            image::RgbaImage::from_raw(2, 1, vec![128, 0, 255, 255, 255, 255, 255, 128]).unwrap();
        img.save(path).unwrap();
    }

    #[test]
    fn srgb_decode_values() {
        let dir = temp_dir("tex");
        write_png(&dir.join("a.png"));
        let limits = Limits::default();
        let mut cache = TextureCache::new(AssetRoot::dir(Some(&dir)), &limits);
        let i = cache.load("a.png", None, Vec2::ONE, "p").unwrap();
        let t = &cache.textures[i as usize];
        assert_eq!((t.width, t.height), (2, 1));
        // sRGB 128/255 = 0.50196 → ((0.50196 + 0.055) / 1.055)^2.4 = 0.21586.
        assert!(
            (t.texels[0][0] - 0.215861).abs() < 1e-5,
            "{:?}",
            t.texels[0]
        );
        assert_eq!(t.texels[0][1], 0.0);
        assert_eq!(t.texels[0][2], 1.0);
        assert!(
            (t.texels[1][3] - 128.0 / 255.0).abs() < 1e-6,
            "alpha stays linear"
        );
        // Same file and flag: one texture; linear flag: a second decode.
        assert_eq!(cache.load("a.png", Some(true), Vec2::ONE, "p").unwrap(), i);
        let j = cache.load("a.png", Some(false), Vec2::ONE, "p").unwrap();
        assert_ne!(i, j);
        assert!((cache.textures[j as usize].texels[0][0] - 128.0 / 255.0).abs() < 1e-6);
        let k = cache
            .load("./a.png", None, Vec2::new(2.0, 2.0), "p")
            .unwrap();
        assert_eq!(cache.textures.len(), 3);
        assert_eq!(cache.textures[k as usize].scale, Vec2::new(2.0, 2.0));
        // (Another scale of a decoded image shares its texels, not a copy.)
        let (t_i, t_k) = (&cache.textures[i as usize], &cache.textures[k as usize]);
        assert!(std::sync::Arc::ptr_eq(&t_i.texels, &t_k.texels));
    }

    #[test]
    fn channels_become_grey_textures() {
        let dir = temp_dir("channel");
        write_png(&dir.join("a.png"));
        let limits = Limits::default();
        let mut cache = TextureCache::new(AssetRoot::dir(Some(&dir)), &limits);
        let reference = |channel: &str| TextureRefDesc {
            texture: "a.png".into(),
            srgb: Some(false),
            scale: None,
            channel: serde_json::from_str(&format!("\"{channel}\"")).unwrap(),
        };
        let plain = cache.load("a.png", Some(false), Vec2::ONE, "p").unwrap();
        let b = cache.load_ref(&reference("b"), "p").unwrap();
        let a = cache.load_ref(&reference("a"), "p").unwrap();
        let l = cache.load_ref(&reference("luminance"), "p").unwrap();
        assert_eq!(cache.load_ref(&reference("b"), "p").unwrap(), b, "shared");
        assert_eq!(cache.textures.len(), 4);
        assert_eq!(cache.textures[plain as usize].texels[0][2], 1.0);
        assert_eq!(cache.textures[b as usize].texels[0], [1.0, 1.0, 1.0, 1.0]);
        let half = 128.0 / 255.0;
        assert_eq!(
            cache.textures[a as usize].texels[1],
            [half, half, half, 1.0]
        );
        let lum = 0.2126 * half + 0.0722;
        assert!((cache.textures[l as usize].texels[0][0] - lum).abs() < 1e-6);
        assert!(
            serde_json::from_str::<TextureRefDesc>(r#"{"texture": "a.png", "channel": "x"}"#)
                .is_err()
        );
    }

    #[test]
    fn exr_and_errors() {
        let dir = temp_dir("exr");
        exr::prelude::write_rgba_file(dir.join("e.exr"), 3, 2, |x, y| {
            (x as f32, y as f32, 2.5f32, 1.0f32)
        })
        .unwrap();
        let limits = Limits::default();
        let mut cache = TextureCache::new(AssetRoot::dir(Some(&dir)), &limits);
        let i = cache.load("e.exr", None, Vec2::ONE, "p").unwrap();
        let t = &cache.textures[i as usize];
        assert_eq!((t.width, t.height), (3, 2));
        assert_eq!(
            t.texels[3 + 2],
            [2.0, 1.0, 2.5, 1.0],
            "linear by default, row-major"
        );
        let e = cache
            .load("x.bmp", None, Vec2::ONE, "m.reflectance.texture")
            .unwrap_err();
        assert!(e.to_string().contains("unsupported texture format"), "{e}");
        std::fs::write(dir.join("bad.png"), b"not a png").unwrap();
        let e = cache.load("bad.png", None, Vec2::ONE, "p").unwrap_err();
        assert!(
            e.to_string().starts_with("p: cannot decode \"bad.png\""),
            "{e}"
        );
        let small = Limits {
            max_texture_pixels: 5,
            ..Limits::default()
        };
        let mut cache = TextureCache::new(AssetRoot::dir(Some(&dir)), &small);
        let e = cache.load("e.exr", None, Vec2::ONE, "p").unwrap_err();
        assert!(e.to_string().contains("exceeds the limit"), "{e}");
    }
}
