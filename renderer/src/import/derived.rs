//! Textures derived from a source image by a per-texel function, for parameters a format defines
//! through a texture that candela's parameter does not read directly: a factor times a texture
//! (glTF), GGX alpha to candela roughness (√, Mitsuba), a channel times a factor, a mask cut at a
//! threshold. The source is decoded exactly as the loader decodes it (sRGB flag, channels); the
//! result is linear RGB, written as EXR by the caller.

use crate::film::Image;
use crate::scene::paths::AssetRoot;
use crate::scene::texture::decode_file;
use crate::scene::{Limits, SceneError};

/// Decodes `rel` (with the loader's default sRGB rule unless `srgb` is given) and maps each
/// linear RGBA texel through `f`.
pub fn derive(
    root: AssetRoot<'_>,
    rel: &str,
    srgb: Option<bool>,
    limits: &Limits,
    f: impl Fn([f32; 4]) -> [f32; 3],
) -> Result<Image, SceneError> {
    let (w, h, texels) = decode_file(root, rel, srgb, limits, rel)?;
    Ok(Image::from_fn(w, h, |x, y| {
        f(texels[(y as usize) * (w as usize) + x as usize])
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::MemoryAssets;

    #[test]
    fn derives_from_memory_exr() {
        let src = Image::from_fn(2, 1, |x, _| [x as f32 * 0.25, 0.5, 1.0]);
        let mut memory = MemoryAssets::new();
        memory.insert("t.exr".into(), crate::film::encode_exr(&src).unwrap());
        let root = AssetRoot {
            dir: None,
            memory: Some(&memory),
        };
        let out = derive(root, "t.exr", None, &Limits::default(), |t| {
            let r = t[0].sqrt();
            [r, r, r]
        })
        .unwrap();
        assert_eq!(out.get(1, 0), [0.5, 0.5, 0.5]);
        let e = derive(root, "missing.png", None, &Limits::default(), |_| [0.0; 3]);
        assert!(e.is_err());
    }
}
