//! Checked cache files, shared by the on-disk caches (built acceleration structures in
//! `accel::cache`, compiled kernels and the Vulkan pipeline cache in `gpu::kernel_cache`): a
//! 128-bit content hash ([`Hasher128`]) for keys, and a file layout that makes a truncated,
//! corrupt or foreign file detectable, written atomically.
//!
//! File: magic (8 bytes), format version (u32), kind (u32), key (2 × u64), payload length (u64),
//! payload hash (u64), payload. A reader checks every field; [`read_checked`] tells an absent
//! file (a plain miss) from one that is present but unusable (the caller warns and rebuilds).
//! Files are written to a temporary name in the same folder and renamed into place, so a reader
//! never sees a half-written file, and concurrent writers of one key leave one whole file.

use std::io::Write;
use std::path::Path;

/// Bytes before the payload.
pub const HEADER: usize = 8 + 4 + 4 + 16 + 8 + 8;

/// A 128-bit content hash (two independent 64-bit multiply-rotate lanes over 8-byte words with
/// a final avalanche). Not cryptographic: it keys a local cache, it does not authenticate.
#[derive(Clone)]
pub struct Hasher128 {
    a: u64,
    b: u64,
    len: u64,
    tail: Vec<u8>,
}

impl Default for Hasher128 {
    fn default() -> Self {
        Hasher128 {
            a: 0x9e37_79b9_7f4a_7c15,
            b: 0xc2b2_ae3d_27d4_eb4f,
            len: 0,
            tail: Vec::new(),
        }
    }
}

/// splitmix64's finaliser: a 64-bit word's bits mixed.
pub(crate) fn mix64(mut x: u64) -> u64 {
    // splitmix64's finaliser.
    x ^= x >> 30;
    x = x.wrapping_mul(0xbf58_476d_1ce4_e5b9);
    x ^= x >> 27;
    x = x.wrapping_mul(0x94d0_49bb_1331_11eb);
    x ^ (x >> 31)
}

impl Hasher128 {
    fn word(&mut self, w: u64) {
        self.a = (self.a ^ w)
            .wrapping_mul(0x0000_0100_0000_01b3)
            .rotate_left(29)
            .wrapping_add(self.b);
        self.b = self
            .b
            .wrapping_add(w.wrapping_mul(0x87c3_7b91_1142_53d5))
            .rotate_left(31)
            .wrapping_mul(0x4cf5_ad43_2745_937f);
    }

    /// Feeds bytes.
    pub fn update(&mut self, bytes: &[u8]) {
        self.len += bytes.len() as u64;
        let mut rest = bytes;
        if !self.tail.is_empty() {
            let need = 8 - self.tail.len();
            let take = need.min(rest.len());
            self.tail.extend_from_slice(&rest[..take]);
            rest = &rest[take..];
            if self.tail.len() < 8 {
                return;
            }
            let w = u64::from_le_bytes(self.tail[..8].try_into().unwrap());
            self.tail.clear();
            self.word(w);
        }
        let mut chunks = rest.chunks_exact(8);
        for c in &mut chunks {
            self.word(u64::from_le_bytes(c.try_into().unwrap()));
        }
        self.tail.extend_from_slice(chunks.remainder());
    }

    /// Feeds a string with its length, so that consecutive strings cannot run into each other.
    pub fn update_str(&mut self, s: &str) {
        self.update(&(s.len() as u64).to_le_bytes());
        self.update(s.as_bytes());
    }

    /// The 128-bit digest.
    pub fn finish(&self) -> [u64; 2] {
        let mut s = self.clone();
        let mut last = [0u8; 8];
        last[..s.tail.len()].copy_from_slice(&s.tail);
        s.word(u64::from_le_bytes(last));
        s.word(s.len);
        [mix64(s.a ^ mix64(s.b)), mix64(s.b.wrapping_add(s.a))]
    }
}

/// What a cache file is: its magic, format version and kind, all checked on reading.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FileKind {
    pub magic: &'static [u8; 8],
    pub version: u32,
    pub kind: u32,
}

/// Reads the payload stored under `key`: `Ok(None)` when there is no file, `Err(why)` when a
/// file is there but unusable (truncated, corrupt, another format or key).
pub fn read_checked(path: &Path, what: FileKind, key: [u64; 2]) -> Result<Option<Vec<u8>>, String> {
    let bytes = match std::fs::read(path) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(e.to_string()),
    };
    if bytes.len() < HEADER {
        return Err(format!("truncated ({} bytes)", bytes.len()));
    }
    if &bytes[..8] != what.magic {
        return Err("not a cache file of this kind".into());
    }
    let word = |at: usize, n: usize| -> u64 {
        let mut b = [0u8; 8];
        b[..n].copy_from_slice(&bytes[at..at + n]);
        u64::from_le_bytes(b)
    };
    let (version, kind) = (word(8, 4) as u32, word(12, 4) as u32);
    let stored_key = [word(16, 8), word(24, 8)];
    let (len, sum) = (word(32, 8), word(40, 8));
    let payload = &bytes[HEADER..];
    if version != what.version || kind != what.kind {
        return Err(format!(
            "format {version}/{kind}, expected {}/{}",
            what.version, what.kind
        ));
    }
    if stored_key != key {
        return Err("stored under another key".into());
    }
    if len != payload.len() as u64 {
        return Err(format!(
            "truncated ({} of {len} payload bytes)",
            payload.len()
        ));
    }
    let mut h = Hasher128::default();
    h.update(payload);
    if h.finish()[0] != sum {
        return Err("payload checksum mismatch".into());
    }
    Ok(Some(payload.to_vec()))
}

/// Writes `payload` under `key` atomically (a temporary file in the same folder, then a rename),
/// creating the folder.
pub fn write_checked(
    path: &Path,
    what: FileKind,
    key: [u64; 2],
    payload: &[u8],
) -> std::io::Result<()> {
    let dir = path.parent().unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir)?;
    let mut h = Hasher128::default();
    h.update(payload);
    let mut out = Vec::with_capacity(HEADER + payload.len());
    out.extend_from_slice(what.magic);
    out.extend_from_slice(&what.version.to_le_bytes());
    out.extend_from_slice(&what.kind.to_le_bytes());
    out.extend_from_slice(&key[0].to_le_bytes());
    out.extend_from_slice(&key[1].to_le_bytes());
    out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    out.extend_from_slice(&h.finish()[0].to_le_bytes());
    out.extend_from_slice(payload);
    let tmp = dir.join(format!(
        ".{}.{}.{:?}.tmp",
        path.file_name().and_then(|n| n.to_str()).unwrap_or("cache"),
        std::process::id(),
        std::thread::current().id()
    ));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(&out)?;
        f.sync_all()?;
        drop(f);
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hash_is_split_invariant_and_sensitive() {
        let data: Vec<u8> = (0..1000u32).map(|i| (i * 7 % 251) as u8).collect();
        let mut a = Hasher128::default();
        a.update(&data);
        let mut b = Hasher128::default();
        for c in data.chunks(13) {
            b.update(c);
        }
        assert_eq!(a.finish(), b.finish());
        let mut c = Hasher128::default();
        let mut d2 = data.clone();
        d2[500] ^= 1;
        c.update(&d2);
        assert_ne!(a.finish(), c.finish());
        let mut e = Hasher128::default();
        e.update(&data[..999]);
        assert_ne!(a.finish(), e.finish());
    }

    #[test]
    fn checked_files_round_trip_and_name_what_is_wrong() {
        let dir = std::env::temp_dir().join(format!("candela-cache-file-{}", std::process::id()));
        let p = dir.join("x.bin");
        let kind = FileKind {
            magic: b"CNDLTEST",
            version: 3,
            kind: 1,
        };
        assert_eq!(read_checked(&p, kind, [1, 2]), Ok(None));
        write_checked(&p, kind, [1, 2], b"payload bytes").unwrap();
        assert_eq!(
            read_checked(&p, kind, [1, 2]),
            Ok(Some(b"payload bytes".to_vec()))
        );
        assert!(read_checked(&p, kind, [1, 3]).unwrap_err().contains("key"));
        let other = FileKind { version: 4, ..kind };
        assert!(read_checked(&p, other, [1, 2])
            .unwrap_err()
            .contains("format"));
        let mut bytes = std::fs::read(&p).unwrap();
        let last = bytes.len() - 1;
        bytes[last] ^= 0x55;
        std::fs::write(&p, &bytes).unwrap();
        assert!(read_checked(&p, kind, [1, 2])
            .unwrap_err()
            .contains("checksum"));
        std::fs::write(&p, &bytes[..HEADER + 3]).unwrap();
        assert!(read_checked(&p, kind, [1, 2])
            .unwrap_err()
            .contains("truncated"));
        std::fs::write(&p, &bytes[..10]).unwrap();
        assert!(read_checked(&p, kind, [1, 2])
            .unwrap_err()
            .contains("truncated"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
