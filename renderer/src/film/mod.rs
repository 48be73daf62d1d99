//! Film output: the linear-radiance [`Image`], EXR in and out, PNG out (exposure, tonemap, sRGB),
//! all files written atomically (temporary sibling, then rename).
//!
//! EXR is always linear radiance; exposure and tonemap apply to PNG only (docs/scene-format.md, `film`).
//! The display transform ([`tonemap_srgb8`], documented in the `tonemap` module): exposure `2^EV`,
//! per-channel curve (clamp, Reinhard `x/(1+x)`, Narkowicz 2015 ACES fit without the 0.6
//! pre-scale), clamp to [0, 1], sRGB OETF, round; NaN/Inf pixels encode as black.

mod atomic;
mod error;
mod exr_io;
mod exr_zip;
mod png_io;
mod raster;
mod tonemap;

use std::path::Path;

use crate::scene::Tonemap;

pub use atomic::{write_atomic, write_atomic_parts};
pub use error::FilmError;
pub use exr_io::{decode_exr, encode_exr, read_exr, write_exr};
pub use png_io::{encode_png, write_png};
pub use raster::Image;
pub use tonemap::{srgb_oetf, tonemap_channel, tonemap_pixel, tonemap_srgb8, MAX_EXPOSED};

/// Writes `img` as EXR (linear, exposure and tonemap ignored) or PNG (tonemapped), chosen by the
/// extension of `path`, `.exr` or `.png` in any case; any other extension is an error naming it.
pub fn write_image(
    path: &Path,
    img: &Image,
    exposure_ev: f32,
    tonemap: Tonemap,
) -> Result<(), FilmError> {
    let extension = path
        .extension()
        .map(|e| e.to_string_lossy().into_owned())
        .unwrap_or_default();
    match extension.to_ascii_lowercase().as_str() {
        "exr" => write_exr(path, img),
        "png" => write_png(path, img, exposure_ev, tonemap),
        _ => Err(FilmError::UnsupportedExtension {
            path: path.to_path_buf(),
            extension,
        }),
    }
}

/// A fresh, empty folder for one test's files, removed when dropped.
#[cfg(test)]
pub(crate) struct TestDir(std::path::PathBuf);

#[cfg(test)]
impl std::ops::Deref for TestDir {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

#[cfg(test)]
impl Drop for TestDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A fresh, empty folder named after the test and this process.
#[cfg(test)]
pub(crate) fn test_dir(name: &str) -> TestDir {
    let dir = std::env::temp_dir().join(format!("candela-film-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    TestDir(dir)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn write_image_by_extension() {
        let dir = test_dir("write-image");
        let img = Image::from_fn(2, 2, |x, y| [x as f32, y as f32, 0.25]);
        write_image(&dir.join("a.EXR"), &img, 3.0, Tonemap::Aces).unwrap();
        assert_eq!(read_exr(&dir.join("a.EXR")).unwrap(), img);
        write_image(&dir.join("b.Png"), &img, 0.0, Tonemap::Clamp).unwrap();
        let png = image::open(dir.join("b.Png")).unwrap().to_rgb8();
        assert_eq!(png.get_pixel(1, 1).0, [255, 255, 137]);
    }

    #[test]
    fn write_image_rejects_unknown_extensions() {
        let dir = test_dir("write-image-reject");
        let img = Image::new(1, 1);
        let err = write_image(&dir.join("c.jpg"), &img, 0.0, Tonemap::Clamp).unwrap_err();
        assert!(matches!(err, FilmError::UnsupportedExtension { .. }));
        let msg = err.to_string();
        assert!(msg.contains("c.jpg") && msg.contains("\"jpg\""), "{msg}");
        assert!(!dir.join("c.jpg").exists());
        let msg = write_image(&dir.join("noext"), &img, 0.0, Tonemap::Clamp)
            .unwrap_err()
            .to_string();
        assert!(msg.contains("noext") && msg.contains("\"\""), "{msg}");
    }
}
