//! Checkpoints of a render in progress: the raw accumulation buffer (per pixel Σr, Σg, Σb and
//! the samples kept, f32, then any extra per-pixel buffers of the integrator: whatever
//! `RenderSession::accumulation` returns) and the session's [`Progress`] counters, in one file
//! written atomically (a uniquely named temporary sibling, fsync, rename). Restoring both gives
//! an exact resume, because the renderer keys its random numbers by sample index.
//!
//! Layout (little-endian): `CNDLCKP1`, width u32, height u32, JSON length u32, JSON
//! (`{"seed", "entries", "progress"}`), entries·4 f32, FNV-1a 64 of everything before it.

use std::path::Path;

use renderer::render::Progress;
use serde::{Deserialize, Serialize};

const MAGIC: &[u8; 8] = b"CNDLCKP1";

/// What a checkpoint holds besides the pixels.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct Header {
    seed: u64,
    /// Number of `[f32; 4]` entries that follow.
    entries: usize,
    progress: Progress,
}

fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in bytes {
        h ^= *b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// Writes a checkpoint to `path` atomically.
pub fn write(
    path: &Path,
    width: u32,
    height: u32,
    seed: u64,
    progress: &Progress,
    accumulation: &[[f32; 4]],
) -> std::io::Result<()> {
    let t0 = std::time::Instant::now();
    let json = serde_json::to_vec(&Header {
        seed,
        entries: accumulation.len(),
        progress: *progress,
    })?;
    let mut buf = Vec::with_capacity(24 + json.len() + accumulation.len() * 16 + 8);
    buf.extend_from_slice(MAGIC);
    buf.extend_from_slice(&width.to_le_bytes());
    buf.extend_from_slice(&height.to_le_bytes());
    buf.extend_from_slice(&(json.len() as u32).to_le_bytes());
    buf.extend_from_slice(&json);
    for px in accumulation {
        for c in px {
            buf.extend_from_slice(&c.to_le_bytes());
        }
    }
    let sum = fnv1a(&buf);
    buf.extend_from_slice(&sum.to_le_bytes());
    let encoded = t0.elapsed();
    write_atomic(path, &buf)?;
    tracing::debug!(
        path = %path.display(),
        bytes = buf.len(),
        encode_ms = encoded.as_millis() as u64,
        write_ms = (t0.elapsed() - encoded).as_millis() as u64,
        "checkpoint written"
    );
    Ok(())
}

/// Writes `bytes` to `path` atomically (renderer::film::write_atomic: a temporary sibling of a
/// name of its own, `.NAME.PID.N.tmp`, so that two writers of one file — a worker whose lease
/// was taken over and the new owner — never write into the same temporary file), creating its
/// folder first.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent)?;
    }
    renderer::film::write_atomic(path, bytes)
}

/// Reads a checkpoint written for a `width`×`height` film, `seed`, and `entries` accumulation
/// entries; `Err` says why it cannot be used (missing, corrupt, or for other settings).
pub fn read(
    path: &Path,
    width: u32,
    height: u32,
    seed: u64,
    entries: usize,
) -> Result<(Progress, Vec<[f32; 4]>), String> {
    let t0 = std::time::Instant::now();
    let bytes = std::fs::read(path).map_err(|e| e.to_string())?;
    let read_at = t0.elapsed();
    let bad = |what: &str| format!("{}: {what}", path.display());
    if bytes.len() < 28 || &bytes[..8] != MAGIC {
        return Err(bad("not a checkpoint"));
    }
    let (body, sum) = bytes.split_at(bytes.len() - 8);
    if fnv1a(body).to_le_bytes() != sum {
        return Err(bad("checksum mismatch"));
    }
    let u32_at = |i: usize| u32::from_le_bytes([body[i], body[i + 1], body[i + 2], body[i + 3]]);
    let (w, h, json_len) = (u32_at(8), u32_at(12), u32_at(16) as usize);
    if (w, h) != (width, height) {
        return Err(bad(&format!("made for {w}x{h}, not {width}x{height}")));
    }
    if body.len() < 20 + json_len {
        return Err(bad("truncated"));
    }
    let header: Header =
        serde_json::from_slice(&body[20..20 + json_len]).map_err(|e| bad(&e.to_string()))?;
    if header.seed != seed {
        return Err(bad("made with another seed"));
    }
    if header.entries != entries || body.len() != 20 + json_len + entries * 16 {
        return Err(bad(&format!(
            "holds {} accumulation entries, the session {entries}",
            header.entries
        )));
    }
    let acc = body[20 + json_len..]
        .chunks_exact(16)
        .map(|px| {
            let f = |i: usize| f32::from_le_bytes([px[i], px[i + 1], px[i + 2], px[i + 3]]);
            [f(0), f(4), f(8), f(12)]
        })
        .collect();
    tracing::debug!(
        path = %path.display(),
        read_ms = read_at.as_millis() as u64,
        decode_ms = (t0.elapsed() - read_at).as_millis() as u64,
        "checkpoint read"
    );
    Ok((header.progress, acc))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_corruption() {
        let dir = std::env::temp_dir().join(format!("candela-ckpt-{}", std::process::id()));
        let path = dir.join("c.bin");
        let progress = Progress {
            spp: 12,
            passes: 3,
            rays: 99,
            dropped_samples: 1,
            time_s: 0.5,
            gpu_time_s: 0.25,
        };
        let acc = vec![[1.0, 2.0, 3.0, 4.0], [0.5, 0.25, 0.0, 12.0]];
        write(&path, 2, 1, 7, &progress, &acc).unwrap();
        assert_eq!(read(&path, 2, 1, 7, 2).unwrap(), (progress, acc));
        assert!(read(&path, 1, 2, 7, 2).is_err());
        assert!(read(&path, 2, 1, 8, 2).is_err());
        assert!(read(&path, 2, 1, 7, 3).is_err());
        let mut bytes = std::fs::read(&path).unwrap();
        let n = bytes.len();
        bytes[n - 12] ^= 1;
        std::fs::write(&path, &bytes).unwrap();
        assert!(read(&path, 2, 1, 7, 2).unwrap_err().contains("checksum"));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
