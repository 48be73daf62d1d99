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
