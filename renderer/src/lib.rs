//! candela's rendering engine: scene loading, Vulkan compute, BVH, integrators, film.
//!
//! Data flow (see docs/design.md): `scene::load` → `compile` (camera-relative f32 buffers, feature set)
//! → `accel` (BVH) → `gpu` (device, pipelines) → `integrators` (passes) → `film` (EXR/PNG).

pub mod accel;
pub mod auto;
pub mod cache_file;
pub mod caches;
pub mod compile;
pub mod error;
pub mod film;
pub mod fuzz;
pub mod gpu;
pub mod import;
pub mod integrators;
pub mod layout;
pub mod memory;
pub mod metrics;
pub mod prepare;
pub mod render;
pub mod scene;
pub mod upload;

/// Starts the renderer's pool of CPU threads (rayon's global pool: acceleration builds, shard
/// merges, copies) now, at the calling thread's priority, and returns its size. Threads take
/// the priority of the thread that starts them (Linux), so a thread that lowered its own
/// priority must not be the pool's first user.
pub fn start_cpu_pool() -> usize {
    rayon::current_num_threads()
}
