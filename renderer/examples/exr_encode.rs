//! Benchmark (bench/RESULTS.md, issue 15): a 3840×2160 float image encoded as EXR by candela's
//! encoder (`renderer::film::encode_exr`, film/exr_zip.rs) and, side by side, by the `exr`
//! crate's own writer with the settings candela used before (ZIP16, `SMALL_LOSSLESS`): time
//! (best of 3) and size. The image: smooth gradients times 1 + 5% uniform noise per channel,
//! like a converged render's low mantissa bits.
//!
//!     cargo run --release --example exr_encode [WIDTH HEIGHT]

use std::time::Instant;

use exr::prelude::{Encoding, SpecificChannels, Vec2, WritableImage};
use renderer::film::{encode_exr, Image};

fn main() {
    let args: Vec<u32> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let (w, h) = (
        *args.first().unwrap_or(&3840),
        *args.get(1).unwrap_or(&2160),
    );
    let mut state = 1u64;
    let img = Image::from_fn(w, h, |x, y| {
        let base = 0.3 + 0.5 * (x as f32 / w as f32) * (y as f32 / h as f32);
        [0.0f32, 0.1, 0.2].map(|k| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let n = (state >> 40) as f32 / (1u64 << 24) as f32 - 0.5;
            (base + k) * (1.0 + 0.05 * n)
        })
    });
    let best = |f: &dyn Fn() -> usize| {
        (0..3)
            .map(|_| {
                let t = Instant::now();
                let bytes = f();
                (t.elapsed().as_secs_f64(), bytes)
            })
            .fold((f64::MAX, 0), |a, b| if b.0 < a.0 { b } else { a })
    };
    let candela = best(&|| encode_exr(&img).unwrap().len());
    let exr_crate = best(&|| {
        let width = w as usize;
        let channels = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
            let [r, g, b] = img.pixels[y * width + x];
            (r, g, b)
        });
        let image = exr::prelude::Image::from_encoded_channels(
            (w as usize, h as usize),
            Encoding::SMALL_LOSSLESS,
            channels,
        );
        let mut out = std::io::Cursor::new(Vec::new());
        image.write().to_buffered(&mut out).unwrap();
        out.into_inner().len()
    });
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    println!("{w}x{h}, {threads} threads");
    for (name, (s, bytes)) in [("candela exr_zip", candela), ("exr crate ZIP16", exr_crate)] {
        println!("{name}: {:.1} ms, {:.1} MB", s * 1e3, bytes as f64 / 1e6);
    }
}
