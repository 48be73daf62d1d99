//! The in-process cache of built volumes: the structure is rebuilt only when the geometry
//! changes. Keyed by the device and a hash of what the voxels depend on (primitives, shading
//! data, materials, textures, resolution, storage); an entry remembers which lights it was
//! lit for, so a render with other lights re-injects (and refilters) without rebuilding, and a
//! render with another camera (position, orientation, lens) or film reuses it as is, placed
//! relative to the new camera (the volume's corner is kept in world space). At most
//! [`crate::gpu::CacheLimits::volumes`] volumes are kept (least recently used out first);
//! a volume in use by a live session with other lights is never changed underneath it (a fresh,
//! uncached one is built instead).

use std::collections::hash_map::DefaultHasher;
use std::hash::{Hash, Hasher};
use std::sync::{Arc, Mutex, OnceLock};

use super::options::Settings;
use super::volume::Volume;
use crate::compile::CompiledScene;
use crate::gpu::GpuContext;

struct Entry {
    ctx: usize,
    key: u64,
    volume: Arc<Mutex<Volume>>,
    /// GPU bytes of the volume's buffers.
    bytes: u64,
}

fn cache() -> &'static Mutex<Vec<Entry>> {
    static CACHE: OnceLock<Mutex<Vec<Entry>>> = OnceLock::new();
    CACHE.get_or_init(|| Mutex::new(Vec::new()))
}

fn bytes<T: bytemuck::Pod>(h: &mut DefaultHasher, v: &[T]) {
    let b: &[u8] = bytemuck::cast_slice(v);
    b.len().hash(h);
    b.hash(h);
}

/// Hash of what the voxel structure depends on: the world-space geometry (not its
/// camera-relative copy, so a moved camera finds the volume and places it, see
/// `Volume::place`), shading data, materials, textures, resolution and storage.
pub fn geometry_key(scene: &CompiledScene, s: &Settings) -> u64 {
    let mut h = DefaultHasher::new();
    scene.geometry_hash.hash(&mut h);
    bytes(&mut h, &scene.tri_shading);
    bytes(&mut h, &scene.materials);
    bytes(&mut h, &scene.textures);
    bytes(&mut h, &scene.texels);
    (s.resolution, s.storage).hash(&mut h);
    h.finish()
}

/// Hash of what the injected radiance depends on besides the geometry.
pub fn lights_key(scene: &CompiledScene, s: &Settings) -> u64 {
    let mut h = DefaultHasher::new();
    bytes(&mut h, &scene.lights);
    bytes(&mut h, &scene.alias);
    bytes(&mut h, &scene.env_dist);
    bytes(&mut h, &[scene.globals.env]);
    bytes(&mut h, &[scene.globals.env_params]);
    (s.inject_samples, s.bounces, s.cones, s.max_level).hash(&mut h);
    (s.cone_aperture_deg.to_bits(), s.step.to_bits()).hash(&mut h);
    h.finish()
}

/// What a lookup found.
pub enum Lookup {
    /// A volume of this geometry that no live session holds.
    Hit(Arc<Mutex<Volume>>),
    Miss,
}

/// Finds a volume of this geometry on this device that no live session holds (a held one is
/// never changed underneath its session: the caller builds a fresh one instead).
pub fn lookup(ctx: &Arc<GpuContext>, key: u64) -> Lookup {
    let Ok(mut c) = cache().lock() else {
        return Lookup::Miss;
    };
    let id = Arc::as_ptr(ctx) as usize;
    // Volumes of another device are of no use any more (a rebuilt device, another context).
    c.retain(|e| e.ctx == id);
    let Some(i) = c.iter().position(|e| e.key == key) else {
        return Lookup::Miss;
    };
    let e = c.remove(i);
    let free = Arc::strong_count(&e.volume) == 1;
    let v = e.volume.clone();
    c.push(e); // most recently used last
    if free {
        Lookup::Hit(v)
    } else {
        Lookup::Miss
    }
}

/// Stores a freshly built volume, evicting the least recently used beyond the limit
/// ([`crate::gpu::CacheLimits::volumes`]).
pub fn store(ctx: &Arc<GpuContext>, key: u64, volume: Arc<Mutex<Volume>>) {
    // (Fresh from its build, so nobody holds its lock; never wait for one here.)
    let bytes = match volume.try_lock() {
        Ok(v) => v.memory().iter().map(|(_, b)| b).sum(),
        Err(_) => 0,
    };
    let Ok(mut c) = cache().lock() else { return };
    let id = Arc::as_ptr(ctx) as usize;
    c.retain(|e| e.ctx == id && e.key != key);
    c.push(Entry {
        ctx: id,
        key,
        volume,
        bytes,
    });
    let capacity = crate::gpu::cache_limits().volumes;
    while c.len() > capacity {
        c.remove(0);
    }
}

/// (volumes kept, their GPU bytes).
pub fn usage() -> (usize, u64) {
    match cache().lock() {
        Ok(c) => (c.len(), c.iter().map(|e| e.bytes).sum()),
        Err(_) => (0, 0),
    }
}

/// Empties the cache (tests; frees the GPU memory of unused volumes).
pub fn clear() {
    if let Ok(mut c) = cache().lock() {
        c.clear();
    }
}
