//! On-disk cache of built acceleration structures, keyed by scene content: a 128-bit hash of what
//! the builder reads, the accel kind, its parameters (the measuring knobs' included:
//! `accel::knobs`) and [`FORMAT_VERSION`]. The BVH reads the
//! primitives' boxes in the scene frame (relative to the centre of the scene's bounds, not to
//! the camera: `compile` moves the built nodes to the camera afterwards), so a camera move keeps
//! the key (the compressed wide BVH is built from the same boxes, and keyed with its own kind);
//! the grid reads the camera-relative geometry and bounds, so its key follows the
//! camera. A second run of the same scene and options loads the structure instead of building
//! it.
//!
//! File: `DIR/{bvh|cwbvh|grid}-{key}.bin` = magic, format version, kind, key, payload length, payload
//! hash, payload. A file whose header, length or payload hash does not match (truncated,
//! corrupt, another version, a hash collision of the name) is ignored: the structure is rebuilt
//! and the file overwritten. Files are written to a temporary name and renamed into place, so a
//! reader never sees a half-written file.

use std::path::{Path, PathBuf};

pub use crate::cache_file::Hasher128;
use crate::cache_file::{read_checked, write_checked, FileKind};

use super::grid::Grid;
use super::{AccelKind, AccelOptions, PrimBounds};
use crate::layout::{GpuBvhNode, GpuCwbvhNode, GpuGridInfo, GpuPrim, PRIM_SPHERE};

/// Bumped whenever a builder or the file layout changes, so old files are never reused.
pub const FORMAT_VERSION: u32 = 4;
const MAGIC: &[u8; 8] = b"CNDLACCL";

/// The file header's identity for structures of `kind`.
fn file_kind(kind: AccelKind) -> FileKind {
    FileKind {
        magic: MAGIC,
        version: FORMAT_VERSION,
        kind: kind as u32,
    }
}

/// The cache key of a grid build: what the builder reads (camera-relative geometry and bounds),
/// plus the options and the format version.
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

/// The cache key of a BVH or CWBVH build: the builders read only the primitives' boxes, given in
/// a frame that does not move with the camera (see `compile`), so the key does not either.
pub fn bvh_key(opts: &AccelOptions, bounds: &[PrimBounds]) -> [u64; 2] {
    let mut h = Hasher128::default();
    h.update(MAGIC);
    h.update(&FORMAT_VERSION.to_le_bytes());
    h.update(&(opts.kind as u32).to_le_bytes());
    match opts.kind {
        AccelKind::Cwbvh => h.update(&[opts.cwbvh_bvh_order as u8]),
        _ => h.update(&[opts.bvh_keep_deep as u8]),
    }
    h.update(super::knobs().as_bytes());
    h.update(&(bounds.len() as u64).to_le_bytes());
    h.update(bytemuck::cast_slice(bounds_words(bounds).as_slice()));
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
    /// The CWBVH's nodes and leaf-slot primitive indices.
    pub cwbvh: Option<(Vec<GpuCwbvhNode>, Vec<u32>)>,
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
    match &e.cwbvh {
        None => out.push(0),
        Some((nodes, prims)) => {
            out.push(1);
            put_u32s(&mut out, bytemuck::cast_slice(nodes));
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
    let cwbvh = match r.take(1)?[0] {
        0 => None,
        1 => {
            let words = r.u32s()?;
            if words.len() % 20 != 0 {
                return None;
            }
            Some((bytemuck::pod_collect_to_vec(&words), r.u32s()?))
        }
        _ => return None,
    };
    r.0.is_empty().then_some(Entry {
        order,
        nodes,
        depth,
        grid,
        cwbvh,
    })
}

/// Loads the entry for `key`, or None when there is no valid file for it.
pub fn load(dir: &Path, kind: AccelKind, key: [u64; 2]) -> Option<Entry> {
    let p = path(dir, kind, key);
    match read_checked(&p, file_kind(kind), key) {
        Ok(payload) => decode(&payload?),
        Err(why) => {
            tracing::warn!("accel cache {}: {why}; rebuilding", p.display());
            None
        }
    }
}

/// Writes the entry for `key` atomically (a temporary file in `dir`, then a rename).
pub fn store(dir: &Path, kind: AccelKind, key: [u64; 2], e: &Entry) -> std::io::Result<()> {
    write_checked(&path(dir, kind, key), file_kind(kind), key, &encode(e))
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
    fn entries_round_trip_and_corruption_is_rejected() {
        let dir = std::env::temp_dir().join(format!("candela-accel-cache-{}", std::process::id()));
        let e = Entry {
            order: vec![2, 0, 1],
            nodes: vec![bytemuck::Zeroable::zeroed(); 3],
            depth: 2,
            grid: Some((bytemuck::Zeroable::zeroed(), vec![0, 1, 3], vec![0, 1, 2])),
            cwbvh: None,
        };
        let cw = Entry {
            order: vec![1, 0],
            nodes: vec![],
            depth: 1,
            grid: None,
            cwbvh: Some((vec![bytemuck::Zeroable::zeroed(); 2], vec![0, 1])),
        };
        store(&dir, AccelKind::Cwbvh, [7, 8], &cw).unwrap();
        assert_eq!(load(&dir, AccelKind::Cwbvh, [7, 8]), Some(cw));
        assert_eq!(load(&dir, AccelKind::Bvh, [7, 8]), None);
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
        std::fs::write(&p, &bytes[..crate::cache_file::HEADER + 3]).unwrap();
        assert_eq!(load(&dir, AccelKind::Grid, key), None);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
