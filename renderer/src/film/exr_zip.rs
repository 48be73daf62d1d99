//! The scanline blocks of a ZIP-compressed (16-line) float32 B, G, R EXR, formed and compressed
//! on every core; the `exr` crate writes the header, the offset table and the chunks.
//!
//! Why not `exr`'s own image writer: it forms each block's bytes by calling a closure per pixel
//! on one thread, and deflates at level 4; on a 3840×2160 film that is 0.2–0.25 s of a farm
//! job's serial end (bench/RESULTS.md, issue 15) for a file ~5 % smaller than this encoder's
//! on a noisy render (zlib level 1: 161 against 357 ms at 3840×2160 on the GPU machine's 16
//! cores, `cargo run --release --example exr_encode`). The format is OpenEXR's ZIP compression (ImfZip.cpp), which readers decode
//! whatever the deflate level:
//!
//! 1. a block holds 16 lines; a line holds the B, then the G, then the R samples of its pixels
//!    (channels in alphabetical order), little-endian;
//! 2. its bytes are split: the even-indexed bytes first, then the odd-indexed ones;
//! 3. each byte but the first is replaced by its difference to the one before, plus 128;
//! 4. zlib; a block that does not get smaller is stored as it was (step 1), which readers
//!    recognise by its size.

use exr::block::chunk::{Chunk, CompressedBlock, CompressedScanLineBlock};
use exr::block::writer::ChunksWriter;
use exr::meta::attribute::{ChannelDescription, SampleType};
use exr::meta::header::Header;
use exr::meta::{BlockDescription, Headers};
use exr::prelude::{Compression, LineOrder};
use rayon::prelude::*;
use std::io::Write;

use super::Image;

/// Lines per block of ZIP compression (OpenEXR's ZIP, not ZIPS).
const LINES: usize = 16;

/// The zlib level: 1, the fastest that compresses (see the module doc for the trade). The
/// blocks are compressed on the global rayon pool.
const LEVEL: u32 = 1;

/// `img` as an EXR file; `img` is well-formed and at least 1×1 (the caller checks).
pub(super) fn encode(img: &Image) -> Result<Vec<u8>, String> {
    let (width, height) = (img.width as usize, img.height as usize);
    let channels = ["B", "G", "R"]
        .into_iter()
        .map(|name| ChannelDescription::named(name, SampleType::F32))
        .collect();
    let mut header = Header::new("".into(), (width, height), channels).with_encoding(
        Compression::ZIP16,
        BlockDescription::ScanLines,
        LineOrder::Increasing,
    );
    header.own_attributes.layer_name = None;
    // Steps 1-4 per block, in parallel.
    let blocks: Vec<Vec<u8>> = (0..height.div_ceil(LINES))
        .into_par_iter()
        .map(|b| compress_block(img, b * LINES..((b + 1) * LINES).min(height)))
        .collect();
    let headers: Headers = std::iter::once(header).collect();
    let mut bytes = std::io::Cursor::new(Vec::new());
    exr::block::write(&mut bytes, headers, true, |_meta, writer| {
        for (b, pixels) in blocks.into_iter().enumerate() {
            let block = CompressedScanLineBlock {
                y_coordinate: (b * LINES) as i32,
                compressed_pixels_le: pixels,
            };
            let chunk = Chunk {
                layer_index: 0,
                compressed_block: CompressedBlock::ScanLine(block),
            };
            writer.write_chunk(b, chunk)?;
        }
        Ok(())
    })
    .map_err(super::error::one_line)?;
    Ok(bytes.into_inner())
}

/// The stored bytes of the block of `lines` (steps 1-4 of the module doc).
fn compress_block(img: &Image, lines: std::ops::Range<usize>) -> Vec<u8> {
    let width = img.width as usize;
    // Step 1: the raw block.
    let mut raw = Vec::with_capacity(lines.len() * width * 12);
    for y in lines {
        let row = &img.pixels[y * width..(y + 1) * width];
        for c in [2, 1, 0] {
            for p in row {
                raw.extend_from_slice(&p[c].to_le_bytes());
            }
        }
    }
    // Step 2: even bytes, then odd ones.
    let half = raw.len().div_ceil(2);
    let mut split = vec![0u8; raw.len()];
    for (i, &v) in raw.iter().enumerate() {
        split[if i % 2 == 0 { i / 2 } else { half + i / 2 }] = v;
    }
    // Step 3: differences (from the back, so each byte still sees its predecessor).
    for i in (1..split.len()).rev() {
        split[i] = split[i].wrapping_sub(split[i - 1]).wrapping_add(128);
    }
    // Step 4.
    let mut zlib = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::new(LEVEL));
    let zipped = zlib.write_all(&split).and_then(|_| zlib.finish());
    match zipped {
        Ok(z) if z.len() < raw.len() => z,
        _ => raw,
    }
}

#[cfg(test)]
mod tests {
    use super::super::exr_io::decode_exr;
    use super::*;

    /// The compression and block layout a reader sees in `bytes`.
    fn encoding_of(bytes: &[u8]) -> (Compression, BlockDescription, usize) {
        let meta =
            exr::meta::MetaData::read_from_buffered(std::io::Cursor::new(bytes), true).unwrap();
        let h = &meta.headers[0];
        (h.compression, h.blocks, h.chunk_count)
    }

    #[test]
    fn blocks_round_trip_exactly_compressed_or_stored() {
        // 37 lines: two full blocks and a short one; smooth rows compress, noisy ones do not
        // (stored as they were), so both kinds of block are read back.
        let mut state = 0x9e37_79b9_7f4a_7c15_u64;
        let mut noise = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            f32::from_bits((state >> 32) as u32 & 0x7f7f_ffff)
        };
        let img = Image::from_fn(29, 37, |x, y| {
            if y < 16 {
                [x as f32 * 0.5, 1.0, -2.0]
            } else {
                [noise(), noise(), -noise()]
            }
        });
        let bytes = encode(&img).unwrap();
        assert_eq!(
            encoding_of(&bytes),
            (Compression::ZIP16, BlockDescription::ScanLines, 3)
        );
        let back = decode_exr(&bytes).unwrap();
        let bits =
            |i: &Image| -> Vec<[u32; 3]> { i.pixels.iter().map(|p| p.map(f32::to_bits)).collect() };
        assert_eq!((back.width, back.height), (29, 37));
        assert_eq!(bits(&back), bits(&img));
        // The smooth block was compressed: the file is smaller than the noisy blocks alone
        // stored raw plus the smooth one raw.
        assert!(bytes.len() < 29 * 37 * 12, "{} bytes", bytes.len());
    }

    #[test]
    fn one_pixel_and_one_line() {
        for (w, h) in [(1, 1), (300, 1), (1, 17)] {
            let img = Image::from_fn(w, h, |x, y| [x as f32, y as f32, 0.25]);
            let back = decode_exr(&encode(&img).unwrap()).unwrap();
            assert_eq!(back, img, "{w}x{h}");
        }
    }
}
