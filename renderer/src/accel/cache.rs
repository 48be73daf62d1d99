//! On-disk cache of built acceleration structures, keyed by scene content: a 128-bit hash of the
//! primitive geometry (camera-relative f32 positions and bounds, as the builders see them), the
//! accel kind, its parameters and [`FORMAT_VERSION`]. A second run of the same scene with the
//! same camera and options loads the structure instead of building it.
//!
//! File: `DIR/{bvh|grid}-{key}.bin` = magic, format version, kind, key, payload length, payload
//! hash, payload. A file whose header, length or payload hash does not match (truncated,
//! corrupt, another version, a hash collision of the name) is ignored: the structure is rebuilt
//! and the file overwritten. Files are written to a temporary name and renamed into place, so a
//! reader never sees a half-written file.

use std::io::Write;
use std::path::{Path, PathBuf};

use super::grid::Grid;
use super::{AccelKind, AccelOptions, PrimBounds};
use crate::layout::{GpuBvhNode, GpuGridInfo, GpuPrim, PRIM_SPHERE};

/// Bumped whenever a builder or the file layout changes, so old files are never reused.
pub const FORMAT_VERSION: u32 = 1;
const MAGIC: &[u8; 8] = b"CNDLACCL";
const HEADER: usize = 8 + 4 + 4 + 16 + 8 + 8;

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

fn mix64(mut x: u64) -> u64 {
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

/// The cache key of a build: what the builders read, plus the options and the format version.
pub fn key(opts: &AccelOptions, prims: &[GpuPrim], bounds: &[PrimBounds]) -> [u64; 2] {
    let mut h = Hasher128::default();
    h.update(MAGIC);
    h.update(&FORMAT_VERSION.to_le_bytes());
    h.update(&(opts.kind as u32).to_le_bytes());
    if opts.kind == AccelKind::Grid {
        h.update(&opts.grid_resolution.unwrap_or(0).to_le_bytes());
        h.update(&[opts.grid_bvh_order as u8]);
    }
    h.update(&(prims.len() as u64).to_le_bytes());
    h.update(bytemuck::cast_slice(bounds_words(bounds).as_slice()));
    let mut geo = Vec::with_capacity(prims.len() * 10);
    for p in prims {
        let sphere = p.a[3].to_bits() & PRIM_SPHERE;
        geo.extend_from_slice(&[p.a[0], p.a[1], p.a[2], p.b[0], p.b[1], p.b[2]]);
        geo.extend_from_slice(&[p.c[0], p.c[1], p.c[2], f32::from_bits(sphere)]);
    }
    h.update(bytemuck::cast_slice(&geo));
    h.finish()
}

fn bounds_words(bounds: &[PrimBounds]) -> Vec<f32> {
    bounds
        .iter()
        .flat_map(|b| b.min.into_iter().chain(b.max))
        .collect()
}

/// The file of a key.
pub fn path(dir: &Path, kind: AccelKind, key: [u64; 2]) -> PathBuf {
    dir.join(format!(
        "{}-{:016x}{:016x}.bin",
        kind.name(),
        key[0],
        key[1]
    ))
}

/// What a cache file holds.
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    pub order: Vec<u32>,
    pub nodes: Vec<GpuBvhNode>,
    pub depth: u32,
    pub grid: Option<(GpuGridInfo, Vec<u32>, Vec<u32>)>,
}

fn put_u32s(out: &mut Vec<u8>, v: &[u32]) {
    out.extend_from_slice(&(v.len() as u64).to_le_bytes());
    out.extend_from_slice(bytemuck::cast_slice(v));
}

/// Serialises an entry (payload only).
fn encode(e: &Entry) -> Vec<u8> {
    let mut out = Vec::new();
    out.extend_from_slice(&e.depth.to_le_bytes());
    put_u32s(&mut out, &e.order);
    put_u32s(&mut out, bytemuck::cast_slice(&e.nodes));
    match &e.grid {
        None => out.push(0),
        Some((info, cells, prims)) => {
            out.push(1);
            out.extend_from_slice(bytemuck::bytes_of(info));
            put_u32s(&mut out, cells);
            put_u32s(&mut out, prims);
        }
    }
    out
}

/// A cursor over a payload; every read is bounds-checked.
struct Reader<'a>(&'a [u8]);

impl Reader<'_> {
    fn take(&mut self, n: usize) -> Option<&[u8]> {
        if self.0.len() < n {
            return None;
        }
        let (a, b) = self.0.split_at(n);
        self.0 = b;
        Some(a)
    }
    fn u32(&mut self) -> Option<u32> {
        Some(u32::from_le_bytes(self.take(4)?.try_into().ok()?))
    }
    fn u32s(&mut self) -> Option<Vec<u32>> {
        let n = u64::from_le_bytes(self.take(8)?.try_into().ok()?);
        let bytes = self.take(usize::try_from(n).ok()?.checked_mul(4)?)?;
        Some(
            bytes
                .chunks_exact(4)
                .map(|c| u32::from_le_bytes(c.try_into().unwrap()))
                .collect(),
        )
    }
}

fn decode(payload: &[u8]) -> Option<Entry> {
    let mut r = Reader(payload);
    let depth = r.u32()?;
    let order = r.u32s()?;
    let words = r.u32s()?;
    if words.len() % 16 != 0 {
        return None;
    }
    let nodes: Vec<GpuBvhNode> = bytemuck::pod_collect_to_vec(&words);
    let grid = match r.take(1)?[0] {
        0 => None,
        1 => {
            let info: GpuGridInfo =
                bytemuck::pod_read_unaligned(r.take(std::mem::size_of::<GpuGridInfo>())?);
            Some((info, r.u32s()?, r.u32s()?))
        }
        _ => return None,
    };
    r.0.is_empty().then_some(Entry {
        order,
        nodes,
        depth,
        grid,
    })
}

/// Loads the entry for `key`, or None when there is no valid file for it.
pub fn load(dir: &Path, kind: AccelKind, key: [u64; 2]) -> Option<Entry> {
    let bytes = std::fs::read(path(dir, kind, key)).ok()?;
    if bytes.len() < HEADER || &bytes[..8] != MAGIC {
        return None;
    }
    let mut r = Reader(&bytes[8..HEADER]);
    let version = r.u32()?;
    let k = r.u32()?;
    let key0 = u64::from_le_bytes(r.take(8)?.try_into().ok()?);
    let key1 = u64::from_le_bytes(r.take(8)?.try_into().ok()?);
    let len = u64::from_le_bytes(r.take(8)?.try_into().ok()?);
    let sum = u64::from_le_bytes(r.take(8)?.try_into().ok()?);
    let payload = &bytes[HEADER..];
    if version != FORMAT_VERSION
        || k != kind as u32
        || [key0, key1] != key
        || len != payload.len() as u64
    {
        return None;
    }
    let mut h = Hasher128::default();
    h.update(payload);
    if h.finish()[0] != sum {
        return None;
    }
    decode(payload)
}

/// Writes the entry for `key` atomically (a temporary file in `dir`, then a rename).
pub fn store(dir: &Path, kind: AccelKind, key: [u64; 2], e: &Entry) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    let payload = encode(e);
    let mut h = Hasher128::default();
    h.update(&payload);
    let mut out = Vec::with_capacity(HEADER + payload.len());
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    out.extend_from_slice(&(kind as u32).to_le_bytes());
    out.extend_from_slice(&key[0].to_le_bytes());
    out.extend_from_slice(&key[1].to_le_bytes());
    out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    out.extend_from_slice(&h.finish()[0].to_le_bytes());
    out.extend_from_slice(&payload);
    let target = path(dir, kind, key);
    let tmp = dir.join(format!(
        ".{}.{}.{:?}.tmp",
        target
            .file_name()
            .and_then(|n| n.to_str())
            .unwrap_or("accel"),
        std::process::id(),
        std::thread::current().id()
    ));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(&out)?;
        f.sync_all()?;
        drop(f);
        std::fs::rename(&tmp, &target)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

impl Entry {
    /// Splits off the grid of a grid entry (`build_time` is left for the caller to set).
    pub fn take_grid(&mut self) -> Option<Grid> {
        self.grid.take().map(|(info, cells, prims)| Grid {
            info,
            cells,
            prims,
            build_time: Default::default(),
        })
    }
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
    fn entries_round_trip_and_corruption_is_rejected() {
        let dir = std::env::temp_dir().join(format!("candela-accel-cache-{}", std::process::id()));
        let e = Entry {
            order: vec![2, 0, 1],
            nodes: vec![bytemuck::Zeroable::zeroed(); 3],
            depth: 2,
            grid: Some((bytemuck::Zeroable::zeroed(), vec![0, 1, 3], vec![0, 1, 2])),
        };
        let key = [1, 2];
        store(&dir, AccelKind::Grid, key, &e).unwrap();
        assert_eq!(load(&dir, AccelKind::Grid, key), Some(e.clone()));
        assert_eq!(load(&dir, AccelKind::Grid, [1, 3]), None);
        assert_eq!(load(&dir, AccelKind::Bvh, key), None);
        let p = path(&dir, AccelKind::Grid, key);
        let mut bytes = std::fs::read(&p).unwrap();
        let last = bytes.len() - 1;
        bytes[last] ^= 0x55;
        std::fs::write(&p, &bytes).unwrap();
        assert_eq!(load(&dir, AccelKind::Grid, key), None);
        std::fs::write(&p, &bytes[..HEADER + 3]).unwrap();
        assert_eq!(load(&dir, AccelKind::Grid, key), None);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
