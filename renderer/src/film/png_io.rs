//! PNG out: the image tonemapped to sRGB8 ([`super::tonemap_srgb8`]), 8-bit RGB, no alpha.

use std::path::Path;

use image::codecs::png::PngEncoder;
use image::{ExtendedColorType, ImageEncoder};

use crate::scene::Tonemap;

use super::atomic::write_atomic;
use super::error::one_line;
use super::{tonemap_srgb8, FilmError, Image};

/// Encodes `img` as an 8-bit RGB PNG in memory after exposure and tonemapping (see
/// [`super::tonemap_srgb8`]; NaN/Inf pixels encode as black).
pub fn encode_png(img: &Image, exposure_ev: f32, tonemap: Tonemap) -> Result<Vec<u8>, FilmError> {
    if !img.is_well_formed() {
        return Err(FilmError::Malformed {
            path: None,
            width: img.width,
            height: img.height,
            len: img.pixels.len(),
        });
    }
    let rgb8 = tonemap_srgb8(img, exposure_ev, tonemap);
    let mut bytes = Vec::new();
    PngEncoder::new(&mut bytes)
        .write_image(&rgb8, img.width, img.height, ExtendedColorType::Rgb8)
        .map_err(|e| FilmError::Encode {
            format: "PNG",
            path: None,
            message: one_line(e),
        })?;
    Ok(bytes)
}

/// Writes `img` to `path` as PNG (see [`encode_png`]), atomically.
pub fn write_png(
    path: &Path,
    img: &Image,
    exposure_ev: f32,
    tonemap: Tonemap,
) -> Result<(), FilmError> {
    let bytes = encode_png(img, exposure_ev, tonemap).map_err(|e| e.at(path))?;
    write_atomic(path, &bytes).map_err(|source| FilmError::Write {
        path: path.to_path_buf(),
        source,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::test_dir;
    use crate::film::tonemap::tests::inverse_curve;

    fn decode(bytes: &[u8]) -> image::RgbImage {
        image::load_from_memory_with_format(bytes, image::ImageFormat::Png)
            .unwrap()
            .to_rgb8()
    }

    /// For every tonemap and a few exposures, inputs whose display-linear value is 0, 0.18, 0.5
    /// and 1 must decode to sRGB 0, 118, 188 and 255.
    #[test]
    fn decodes_to_expected_srgb() {
        for tonemap in [Tonemap::Clamp, Tonemap::Reinhard, Tonemap::Aces] {
            // An exposed value that saturates each curve (Reinhard only in the limit).
            let one = match tonemap {
                Tonemap::Clamp => 1.0,
                Tonemap::Reinhard => 1e6,
                Tonemap::Aces => 10.0,
            };
            let exposed = [
                0.0,
                inverse_curve(0.18, tonemap),
                inverse_curve(0.5, tonemap),
                one,
            ];
            for ev in [-1.0f32, 0.0, 1.0, 2.5] {
                let scale = (-ev as f64).exp2();
                let img = Image::from_fn(4, 1, |x, _| {
                    let v = (exposed[x as usize] * scale) as f32;
                    [v, v, v]
                });
                let png = decode(&encode_png(&img, ev, tonemap).unwrap());
                assert_eq!(png.dimensions(), (4, 1));
                let got: Vec<u8> = png.pixels().map(|p| p.0[0]).collect();
                assert_eq!(got, vec![0, 118, 188, 255], "{tonemap:?} at {ev} EV");
                assert!(png.pixels().all(|p| p.0[0] == p.0[1] && p.0[1] == p.0[2]));
            }
        }
    }

    #[test]
    fn rows_top_down_and_nan_black() {
        let mut img = Image::new(2, 2);
        img.set(1, 0, [1.0, 0.0, 0.0]);
        img.set(0, 1, [f32::NAN, 1.0, 1.0]);
        img.set(1, 1, [0.0, 0.0, 1.0]);
        let png = decode(&encode_png(&img, 0.0, Tonemap::Clamp).unwrap());
        assert_eq!(png.get_pixel(1, 0).0, [255, 0, 0]);
        assert_eq!(png.get_pixel(0, 1).0, [0, 0, 0]);
        assert_eq!(png.get_pixel(1, 1).0, [0, 0, 255]);
    }

    #[test]
    fn write_png_file() {
        let dir = test_dir("png");
        let path = dir.join("a.png");
        let img = Image::from_fn(3, 2, |_, _| [0.5, 0.18, 1.0]);
        write_png(&path, &img, 0.0, Tonemap::Clamp).unwrap();
        let png = decode(&std::fs::read(&path).unwrap());
        assert_eq!(png.get_pixel(2, 1).0, [188, 118, 255]);
    }
}
