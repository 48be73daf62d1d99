//! candela's EXR files (renderer/src/film/exr_zip.rs, its own ZIP encoder) read by another
//! implementation: Mitsuba 3's `Bitmap`, which reads EXR through the OpenEXR library. Every
//! sample must come back bit for bit (a NaN as a NaN): blocks that compress and blocks stored as
//! they were, films whose height is not a multiple of the 16-line block, one pixel, one line.

use std::path::Path;
use std::process::Command;

use candela_tests::{mitsuba_available, scratch};
use renderer::film::{write_exr, Image};

/// Reads the EXR at argv[1] with Mitsuba and writes height, width, channels (u32) and the
/// samples (f32, rows from the top), little-endian, to argv[2].
const READ: &str = r#"
import struct, sys
import mitsuba as mi
mi.set_variant('scalar_rgb')
t = mi.TensorXf(mi.Bitmap(sys.argv[1]))
h, w, c = t.shape
v = list(t.array)
open(sys.argv[2], 'wb').write(struct.pack('<3I', h, w, c) + struct.pack('<%df' % len(v), *v))
"#;

/// The image at `path` as Mitsuba (OpenEXR) reads it.
fn read_with_openexr(path: &Path) -> Image {
    let out = path.with_extension("raw");
    let run = Command::new("python3")
        .args(["-c", READ])
        .arg(path)
        .arg(&out)
        .output()
        .expect("python3");
    assert!(
        run.status.success(),
        "Mitsuba could not read {}: {}",
        path.display(),
        String::from_utf8_lossy(&run.stderr)
    );
    let bytes = std::fs::read(&out).unwrap();
    let word = |i: usize| u32::from_le_bytes(bytes[4 * i..4 * i + 4].try_into().unwrap());
    let (h, w, c) = (word(0), word(1), word(2));
    assert_eq!(c, 3, "channels of {}", path.display());
    let pixels = (0..(w * h) as usize)
        .map(|p| [0, 1, 2].map(|k| f32::from_bits(word(3 + 3 * p + k))))
        .collect();
    Image {
        width: w,
        height: h,
        pixels,
    }
}

/// Samples as bits, every NaN the same.
fn bits(img: &Image) -> Vec<[u32; 3]> {
    let canon = |v: f32| if v.is_nan() { u32::MAX } else { v.to_bits() };
    img.pixels.iter().map(|p| p.map(canon)).collect()
}

#[test]
fn openexr_reads_candelas_exr_files_exactly() {
    assert!(
        mitsuba_available(),
        "Mitsuba 3 is not installed: run scripts/setup.sh (pip install mitsuba)"
    );
    let dir = scratch("exr_interop");
    let mut state = 0x2545_f491_4f6c_dd1d_u64;
    let mut noise = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        // Finite floats of every exponent and sign.
        f32::from_bits((state >> 32) as u32 & 0xff7f_ffff)
    };
    let mut images = vec![
        // Smooth rows first (their blocks compress), then noise (stored as they were).
        Image::from_fn(37, 41, |x, y| {
            if y < 16 {
                [x as f32 * 0.25, y as f32, 1.0 / (x as f32 + 1.0)]
            } else {
                [noise(), noise(), noise()]
            }
        }),
        Image::from_fn(1, 1, |_, _| [0.5, 2.0, 1e-3]),
        Image::from_fn(300, 1, |x, _| [x as f32, -(x as f32), 0.0]),
        Image::from_fn(3, 17, |x, y| [x as f32, y as f32, 7.0]),
    ];
    // Values a lossy or half-float path would lose, and the non-finite ones.
    images[0].pixels[0] = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY];
    images[0].pixels[1] = [-0.0, f32::MIN_POSITIVE / 8.0, f32::MAX];
    for (i, img) in images.iter().enumerate() {
        let path = dir.join(format!("image{i}.exr"));
        write_exr(&path, img).unwrap();
        let back = read_with_openexr(&path);
        assert_eq!(
            (back.width, back.height),
            (img.width, img.height),
            "image {i}"
        );
        assert_eq!(bits(&back), bits(img), "image {i}: samples differ");
    }
}
