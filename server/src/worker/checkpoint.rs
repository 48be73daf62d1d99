//! Checkpoints of a render in progress: the raw accumulation buffer (per pixel Σr, Σg, Σb and
//! the samples kept, f32, then any extra per-pixel buffers of the integrator: whatever
//! `RenderSession::accumulation` returns) and the session's [`Progress`] counters, in one file
//! written atomically (a uniquely named temporary sibling, fsync, rename). Restoring both gives
//! an exact resume, because the renderer keys its random numbers by sample index.
//!
//! Layout (little-endian): `CNDLCKP2`, width u32, height u32, JSON length u32, JSON
//! (`{"seed", "entries", "progress"}`), entries·4 f32, CRC-32 (IEEE) u32 of everything before
//! it. The floats go to and come from the file as they lie in memory (no per-value encoding)
//! and the checksum runs at memory speed, so a film-size checkpoint costs about its write:
//! a split job writes one per shard (shard.rs). Files of the first layout (`CNDLCKP1`, the same
//! but an FNV-1a 64 checksum) are still read; builds before layout 2 cannot read it, so every
//! worker of a farm is upgraded together (docs/farm.md).

use std::io::{Read, Seek};
use std::path::Path;

use renderer::render::Progress;
use serde::{Deserialize, Serialize};

const MAGIC: &[u8; 8] = b"CNDLCKP2";
/// The first layout (FNV-1a 64 checksum), read only.
const MAGIC_V1: &[u8; 8] = b"CNDLCKP1";

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

/// The accumulation's bytes as the file holds them (little-endian f32): the memory itself on
/// little-endian machines.
fn le_bytes(accumulation: &[[f32; 4]]) -> std::borrow::Cow<'_, [u8]> {
    if cfg!(target_endian = "little") {
        std::borrow::Cow::Borrowed(bytemuck::cast_slice(accumulation))
    } else {
        let flat = accumulation.iter().flatten();
        std::borrow::Cow::Owned(flat.flat_map(|v| v.to_le_bytes()).collect())
    }
}

/// Writes a checkpoint to `path` atomically; `sync` false leaves it in the page cache (see
/// `renderer::film::write_atomic_parts`: a finished shard's file, shard_write.rs).
pub fn write(
    path: &Path,
    width: u32,
    height: u32,
    seed: u64,
    progress: &Progress,
    accumulation: &[[f32; 4]],
    sync: bool,
) -> std::io::Result<()> {
    let t0 = std::time::Instant::now();
    let json = serde_json::to_vec(&Header {
        seed,
        entries: accumulation.len(),
        progress: *progress,
    })?;
    let mut head = Vec::with_capacity(20 + json.len());
    head.extend_from_slice(MAGIC);
    head.extend_from_slice(&width.to_le_bytes());
    head.extend_from_slice(&height.to_le_bytes());
    head.extend_from_slice(&(json.len() as u32).to_le_bytes());
    head.extend_from_slice(&json);
    let body = le_bytes(accumulation);
    let mut crc = crc32fast::Hasher::new();
    crc.update(&head);
    crc.update(&body);
    let sum = crc.finalize().to_le_bytes();
    let encoded = t0.elapsed();
    // (A temporary sibling of a name of its own, `.NAME.PID.N.tmp`, so that two writers of one
    // file — a worker whose lease was taken over and the new owner — never share one.)
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent)?;
    }
    renderer::film::write_atomic_parts(path, &[&head, &body, &sum], sync)?;
    tracing::debug!(
        path = %path.display(),
        bytes = head.len() + body.len() + sum.len(),
        encode_ms = super::shard::ms(encoded),
        write_ms = super::shard::ms(t0.elapsed() - encoded),
        "checkpoint written"
    );
    Ok(())
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
    let mut acc = Vec::new();
    let progress = read_into(path, width, height, seed, entries, &mut acc)?;
    Ok((progress, acc))
}

/// Bytes of the body a thread of [`read_into`] reads and checksums at a time.
const READ_PIECE: usize = 8 << 20;

/// Most threads [`read_into`] reads one file with.
const READ_THREADS: usize = 8;

/// [`read`] into `acc` (resized to `entries`; a buffer kept from an earlier read is reused,
/// so reading many film-size files allocates once). The floats are read by up to
/// [`READ_THREADS`] threads, each a contiguous part in pieces of [`READ_PIECE`] bytes, each
/// checksumming its own part; the parts' CRCs combine into the file's.
pub fn read_into(
    path: &Path,
    width: u32,
    height: u32,
    seed: u64,
    entries: usize,
    acc: &mut Vec<[f32; 4]>,
) -> Result<Progress, String> {
    let t0 = std::time::Instant::now();
    let bad = |what: &str| format!("{}: {what}", path.display());
    let mut file = std::fs::File::open(path).map_err(|e| e.to_string())?;
    let len = file.metadata().map_err(|e| e.to_string())?.len();
    // Step 1: the fixed head, then the JSON header; checked against the expected film.
    let mut head = vec![0u8; 20];
    if len < 28 || file.read_exact(&mut head).is_err() {
        return Err(bad("not a checkpoint"));
    }
    if &head[..8] == MAGIC_V1 {
        let (progress, v1) = read_v1(path, width, height, seed, entries)?;
        *acc = v1;
        return Ok(progress);
    }
    if &head[..8] != MAGIC {
        return Err(bad("not a checkpoint"));
    }
    let u32_at = |b: &[u8], i: usize| u32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
    let (w, h, json_len) = (
        u32_at(&head, 8),
        u32_at(&head, 12),
        u32_at(&head, 16) as usize,
    );
    if (w, h) != (width, height) {
        return Err(bad(&format!("made for {w}x{h}, not {width}x{height}")));
    }
    if len < (20 + json_len + 4) as u64 {
        return Err(bad("truncated"));
    }
    head.resize(20 + json_len, 0);
    file.read_exact(&mut head[20..])
        .map_err(|e| bad(&e.to_string()))?;
    let header: Header = serde_json::from_slice(&head[20..]).map_err(|e| bad(&e.to_string()))?;
    check_header(&header, seed, entries).map_err(|what| bad(&what))?;
    let want = (20 + json_len + entries * 16 + 4) as u64;
    if len != want {
        return Err(bad(&format!("{len} bytes, expected {want} (truncated?)")));
    }
    // Step 2: the floats straight into the accumulation's memory, piece by piece on several
    // threads, each piece checksummed as it arrives; then the stored checksum.
    acc.resize(entries, [0.0; 4]);
    let body: &mut [u8] = bytemuck::cast_slice_mut(&mut acc[..]);
    let at = head.len() as u64;
    let parts = body.len().div_ceil(READ_PIECE).clamp(1, READ_THREADS);
    let part_len = body.len().div_ceil(parts).max(1);
    // Each part read in pieces and checksummed: on the calling thread when there is one, else
    // on threads of its own (not the shared rayon pool: a slow disk must not hold up the other
    // devices' CPU work queued there; a thread the system refuses fails that part's read).
    let read_part = |i: usize, part: &mut [u8]| -> std::io::Result<crc32fast::Hasher> {
        let mut crc = crc32fast::Hasher::new();
        let start = at + (i * part_len) as u64;
        for (j, piece) in part.chunks_mut(READ_PIECE).enumerate() {
            read_exact_at(&file, piece, start + (j * READ_PIECE) as u64)?;
            crc.update(piece);
        }
        Ok(crc)
    };
    let pieces: Vec<std::io::Result<crc32fast::Hasher>> = if parts == 1 {
        vec![read_part(0, body)]
    } else {
        std::thread::scope(|scope| {
            let read_part = &read_part;
            let handles: Vec<_> = (body.chunks_mut(part_len).enumerate())
                .map(|(i, part)| {
                    std::thread::Builder::new()
                        .name("checkpoint-read".into())
                        .spawn_scoped(scope, move || read_part(i, part))
                })
                .collect();
            (handles.into_iter())
                .map(|h| match h {
                    Ok(h) => h.join().unwrap_or_else(|_| {
                        Err(std::io::Error::other("a reading thread panicked"))
                    }),
                    Err(e) => Err(e),
                })
                .collect()
        })
    };
    let read_at = t0.elapsed();
    let mut crc = crc32fast::Hasher::new();
    crc.update(&head);
    for piece in pieces {
        crc.combine(&piece.map_err(|e| bad(&e.to_string()))?);
    }
    let mut sum = [0u8; 4];
    file.seek(std::io::SeekFrom::Start(at + body.len() as u64))
        .and_then(|_| file.read_exact(&mut sum))
        .map_err(|e| bad(&e.to_string()))?;
    if crc.finalize().to_le_bytes() != sum {
        return Err(bad("checksum mismatch"));
    }
    if cfg!(target_endian = "big") {
        for v in acc.iter_mut().flatten() {
            *v = f32::from_bits(u32::from_le(v.to_bits()));
        }
    }
    tracing::debug!(
        path = %path.display(),
        read_ms = super::shard::ms(read_at),
        check_ms = super::shard::ms(t0.elapsed() - read_at),
        "checkpoint read"
    );
    Ok(header.progress)
}

/// Fills `buf` from `file` at byte `at` (without moving a shared file position, so that
/// threads can read one file at once).
fn read_exact_at(file: &std::fs::File, buf: &mut [u8], at: u64) -> std::io::Result<()> {
    #[cfg(unix)]
    {
        std::os::unix::fs::FileExt::read_exact_at(file, buf, at)
    }
    #[cfg(windows)]
    {
        let mut done = 0;
        while done < buf.len() {
            let n =
                std::os::windows::fs::FileExt::seek_read(file, &mut buf[done..], at + done as u64)?;
            if n == 0 {
                return Err(std::io::ErrorKind::UnexpectedEof.into());
            }
            done += n;
        }
        Ok(())
    }
}

/// Whether a checkpoint's header fits the session: the same seed and accumulation length.
fn check_header(header: &Header, seed: u64, entries: usize) -> Result<(), String> {
    if header.seed != seed {
        return Err("made with another seed".into());
    }
    if header.entries != entries {
        return Err(format!(
            "holds {} accumulation entries, the session {entries}",
            header.entries
        ));
    }
    Ok(())
}

/// [`read`] of a file of the first layout (`CNDLCKP1`: FNV-1a 64 checksum).
fn read_v1(
    path: &Path,
    width: u32,
    height: u32,
    seed: u64,
    entries: usize,
) -> Result<(Progress, Vec<[f32; 4]>), String> {
    let bytes = std::fs::read(path).map_err(|e| e.to_string())?;
    let bad = |what: &str| format!("{}: {what}", path.display());
    if bytes.len() < 28 || &bytes[..8] != MAGIC_V1 {
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
    check_header(&header, seed, entries).map_err(|what| bad(&what))?;
    let want = 20 + json_len + entries * 16;
    if body.len() != want {
        let len = body.len();
        return Err(bad(&format!("{len} bytes, expected {want} (truncated?)")));
    }
    let acc = body[20 + json_len..]
        .chunks_exact(16)
        .map(|px| {
            let f = |i: usize| f32::from_le_bytes([px[i], px[i + 1], px[i + 2], px[i + 3]]);
            [f(0), f(4), f(8), f(12)]
        })
        .collect();
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
        write(&path, 2, 1, 7, &progress, &acc, true).unwrap();
        assert_eq!(read(&path, 2, 1, 7, 2).unwrap(), (progress, acc.clone()));
        assert!(read(&path, 1, 2, 7, 2).is_err());
        assert!(read(&path, 2, 1, 8, 2).is_err());
        assert!(read(&path, 2, 1, 7, 3).is_err());
        let clean = std::fs::read(&path).unwrap();
        let n = clean.len();
        let mut bytes = clean.clone();
        bytes[n - 12] ^= 1;
        std::fs::write(&path, &bytes).unwrap();
        assert!(read(&path, 2, 1, 7, 2).unwrap_err().contains("checksum"));
        // (A clean copy cut short: only the length can tell.)
        std::fs::write(&path, &clean[..n - 1]).unwrap();
        let e = read(&path, 2, 1, 7, 2).unwrap_err();
        assert!(e.contains("truncated?"), "{e}");
        assert!(e.contains(&format!("{} bytes, expected {n}", n - 1)), "{e}");
        // A file of the first layout (FNV-1a 64) still reads.
        let json = serde_json::to_vec(&Header {
            seed: 7,
            entries: 2,
            progress,
        })
        .unwrap();
        let mut v1 = MAGIC_V1.to_vec();
        for x in [2u32, 1, json.len() as u32] {
            v1.extend_from_slice(&x.to_le_bytes());
        }
        v1.extend_from_slice(&json);
        v1.extend(acc.iter().flatten().flat_map(|v| v.to_le_bytes()));
        let sum = fnv1a(&v1);
        v1.extend_from_slice(&sum.to_le_bytes());
        std::fs::write(&path, &v1).unwrap();
        assert_eq!(read(&path, 2, 1, 7, 2).unwrap(), (progress, acc));
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// A body of several read pieces (threads): every piece lands in its place, a flipped bit
    /// in any piece fails the checksum, and a buffer kept from a larger read is reused.
    #[test]
    fn pieces_read_in_parallel() {
        let dir = std::env::temp_dir().join(format!("candela-ckpt-par-{}", std::process::id()));
        let path = dir.join("c.bin");
        let progress = Progress {
            spp: 3,
            ..Default::default()
        };
        // 2.5 pieces of floats, each entry different.
        let entries = READ_PIECE * 5 / 2 / 16 + 3;
        let acc: Vec<[f32; 4]> = (0..entries)
            .map(|i| [i as f32, -(i as f32), 0.5 * i as f32, (i % 7) as f32])
            .collect();
        write(&path, entries as u32, 1, 9, &progress, &acc, false).unwrap();
        let mut buf = vec![[7.0f32; 4]; entries + 100];
        let p = read_into(&path, entries as u32, 1, 9, entries, &mut buf).unwrap();
        assert_eq!(p, progress);
        assert!(buf == acc, "the pieces did not land in their places");
        let clean = std::fs::read(&path).unwrap();
        let body_at = clean.len() - 4 - entries * 16;
        for at in [body_at + 5, body_at + READ_PIECE + 1, clean.len() - 5] {
            let mut bytes = clean.clone();
            bytes[at] ^= 4;
            std::fs::write(&path, &bytes).unwrap();
            let e = read_into(&path, entries as u32, 1, 9, entries, &mut buf).unwrap_err();
            assert!(e.contains("checksum"), "byte {at}: {e}");
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}
