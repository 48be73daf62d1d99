//! OpenEXR in and out (the `exr` crate; blocks formed and compressed in parallel by exr_zip.rs):
//! linear float32 RGB, no alpha, ZIP (16-line) compressed scanlines, which OpenEXR, Mitsuba,
//! Blender and `exr` itself all read.

use std::io::Cursor;
use std::path::Path;

use exr::prelude::{ReadChannels, ReadLayers, Vec2};

use super::atomic::write_atomic;
use super::error::one_line;
use super::raster::pixel_count;
use super::{FilmError, Image};

/// Encodes `img` as an EXR file in memory: channels R, G, B in float32, no alpha, lossless.
pub fn encode_exr(img: &Image) -> Result<Vec<u8>, FilmError> {
    if !img.is_well_formed() {
        return Err(FilmError::Malformed {
            path: None,
            width: img.width,
            height: img.height,
            len: img.pixels.len(),
        });
    }
    let encode_error = |message: String| FilmError::Encode {
        format: "EXR",
        path: None,
        message,
    };
    if img.width == 0 || img.height == 0 {
        return Err(encode_error(format!(
            "an EXR cannot be {}x{}",
            img.width, img.height
        )));
    }
    super::exr_zip::encode(img).map_err(encode_error)
}

/// Writes `img` to `path` as EXR (see [`encode_exr`]), atomically.
pub fn write_exr(path: &Path, img: &Image) -> Result<(), FilmError> {
    let bytes = encode_exr(img).map_err(|e| e.at(path))?;
    write_atomic(path, &bytes).map_err(|source| FilmError::Write {
        path: path.to_path_buf(),
        source,
    })
}

/// Reads the first layer with R, G and B channels of an EXR file (f16, f32 or u32 samples,
/// converted to f32; an alpha channel is ignored; the largest mip level).
pub fn read_exr(path: &Path) -> Result<Image, FilmError> {
    let bytes = std::fs::read(path).map_err(|e| FilmError::Read {
        path: path.to_path_buf(),
        message: one_line(e),
    })?;
    decode_exr(&bytes).map_err(|message| FilmError::Read {
        path: path.to_path_buf(),
        message,
    })
}

/// Decodes an EXR held in memory, as [`read_exr`] does; the error is a one-line message.
pub fn decode_exr(bytes: &[u8]) -> Result<Image, String> {
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .rgb_channels(
            |size: Vec2<usize>, _channels| {
                let (width, height) = (size.width() as u32, size.height() as u32);
                Image::new(width, height)
            },
            |img: &mut Image, Vec2(x, y): Vec2<usize>, (r, g, b): (f32, f32, f32)| {
                let width = img.width as usize;
                img.pixels[y * width + x] = [r, g, b];
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_buffered(Cursor::new(bytes))
        .map_err(one_line)?;
    let layer = image.layer_data;
    let img = layer.channel_data.pixels;
    debug_assert_eq!(img.pixels.len(), pixel_count(img.width, img.height));
    Ok(img)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::test_dir;

    fn awkward_image() -> Image {
        // Values that a lossy or half-float path would not reproduce bit for bit.
        Image::from_fn(7, 5, |x, y| {
            let v = (x as f32 + 1.0) * 0.1 + (y as f32) * 1e-7;
            [v, -v * 3.3e5, 1.0 / (v + 1e-30) + f32::EPSILON]
        })
    }

    #[test]
    fn round_trip_in_memory_is_exact() {
        let img = awkward_image();
        let back = decode_exr(&encode_exr(&img).unwrap()).unwrap();
        assert_eq!(back, img);
    }

    #[test]
    fn round_trip_file_is_exact_and_keeps_nan() {
        let dir = test_dir("exr");
        let path = dir.join("a.exr");
        let mut img = awkward_image();
        img.set(0, 0, [f32::NAN, f32::INFINITY, f32::MIN_POSITIVE]);
        write_exr(&path, &img).unwrap();
        let back = read_exr(&path).unwrap();
        assert_eq!((back.width, back.height), (7, 5));
        assert!(back.get(0, 0)[0].is_nan());
        assert_eq!(back.get(0, 0)[1..], img.get(0, 0)[1..]);
        assert_eq!(back.pixels[1..], img.pixels[1..]);
    }

    #[test]
    fn reads_rgba_half_ignoring_alpha() {
        use exr::prelude::f16;
        let dir = test_dir("exr-rgba");
        let path = dir.join("half.exr");
        exr::prelude::write_rgba_file(&path, 3, 2, |x, y| {
            let v = f16::from_f32(x as f32 + 0.5 * y as f32);
            (
                v,
                f16::from_f32(0.25),
                f16::from_f32(2.0),
                f16::from_f32(0.5),
            )
        })
        .unwrap();
        let img = read_exr(&path).unwrap();
        assert_eq!((img.width, img.height), (3, 2));
        assert_eq!(img.get(2, 1), [2.5, 0.25, 2.0]);
    }

    #[test]
    fn errors_name_the_file() {
        let dir = test_dir("exr-errors");
        let missing = dir.join("missing.exr");
        let msg = read_exr(&missing).unwrap_err().to_string();
        assert!(msg.contains("missing.exr"), "{msg}");
        let garbage = dir.join("garbage.exr");
        std::fs::write(&garbage, b"not an exr").unwrap();
        let msg = read_exr(&garbage).unwrap_err().to_string();
        assert!(msg.contains("garbage.exr") && !msg.contains('\n'), "{msg}");
        let msg = write_exr(&dir.join("empty.exr"), &Image::new(0, 3))
            .unwrap_err()
            .to_string();
        assert!(msg.contains("empty.exr"), "{msg}");
        let bad = Image {
            width: 2,
            height: 2,
            pixels: vec![[0.0; 3]; 3],
        };
        let msg = write_exr(&dir.join("bad.exr"), &bad)
            .unwrap_err()
            .to_string();
        assert!(
            msg.contains("bad.exr") && msg.contains("malformed"),
            "{msg}"
        );
    }
}
