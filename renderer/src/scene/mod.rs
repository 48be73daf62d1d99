//! Scene loading: a scene JSON document (docs/scene-format.md, version 1) parsed, validated and
//! resolved into the world-space [`Scene`] of `types.rs`.
//!
//! Stages: `desc*` (serde structs, `deny_unknown_fields`, JSON paths tracked by
//! `serde_path_to_error`) → `validate` / `materials` (defaults and ranges) → `assemble` (objects:
//! `shapes`, `obj`, `ply` through `mesh` and `transform` to world space; `texture` decoding; asset
//! paths checked by `paths`); `expand` writes instances out as meshes where a compile needs it. Every failure is a [`SceneError`] whose one-line message names the
//! JSON path (or `file:line` inside a mesh file). Nothing here panics on bad input, and sizes are
//! checked against [`Limits`] before anything is allocated for them.

pub mod types;
pub use types::*;

mod assemble;
pub(crate) mod desc;
mod desc_tagged;
mod desc_values;
mod error;
pub mod expand;
mod materials;
pub(crate) mod mesh;
pub(crate) mod obj;
pub(crate) mod paths;
pub(crate) mod ply;
mod ply_body;
pub(crate) mod shapes;
pub(crate) mod texture;
pub(crate) mod transform;
mod validate;

#[cfg(test)]
mod tests_docs;
#[cfg(test)]
mod tests_errors;
#[cfg(test)]
mod tests_files;
#[cfg(test)]
mod tests_scene;

use std::collections::BTreeMap;
use std::path::Path;

use paths::AssetRoot;

pub use error::SceneError;
pub(crate) use error::{io_message, key_path};

/// Limits applied during load: absurd sizes are errors, not allocations.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Limits {
    /// Largest accepted `film.width`.
    pub max_width: u32,
    /// Largest accepted `film.height`.
    pub max_height: u32,
    /// Most triangles in the whole scene (all meshes, quads and boxes together).
    pub max_triangles: usize,
    /// Most pixels in any one texture.
    pub max_texture_pixels: u64,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_width: 16384,
            max_height: 16384,
            max_triangles: 50_000_000,
            max_texture_pixels: 268_435_456,
        }
    }
}

/// Loads a scene file; relative asset paths resolve against the file's folder.
pub fn load_file(path: &Path) -> Result<Scene, SceneError> {
    load_file_with_limits(path, &Limits::default())
}

/// [`load_file`] with explicit [`Limits`].
pub fn load_file_with_limits(path: &Path, limits: &Limits) -> Result<Scene, SceneError> {
    let json = std::fs::read_to_string(path).map_err(|e| SceneError::SceneFile {
        file: path.display().to_string(),
        msg: error::io_message(&e),
    })?;
    let base = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    load_str_with_limits(&json, Some(base), limits)
}

/// Loads a scene from JSON text whose assets live under `base_dir` (may be None: then any file
/// reference is an error).
pub fn load_str(json: &str, base_dir: Option<&Path>) -> Result<Scene, SceneError> {
    load_str_with_limits(json, base_dir, &Limits::default())
}

/// [`load_str`] with explicit [`Limits`].
pub fn load_str_with_limits(
    json: &str,
    base_dir: Option<&Path>,
    limits: &Limits,
) -> Result<Scene, SceneError> {
    assemble::load(json, AssetRoot::dir(base_dir), limits)
}

/// Files held in memory, by relative path (`meshes/m0.ply`): an importer's meshes and embedded
/// images (crate::import). The loader looks a path up here before the scene folder.
pub type MemoryAssets = BTreeMap<String, Vec<u8>>;

/// [`load_str_with_limits`] with files held in `memory` besides those under `base_dir`.
pub fn load_str_with_assets(
    json: &str,
    base_dir: Option<&Path>,
    memory: &MemoryAssets,
    limits: &Limits,
) -> Result<Scene, SceneError> {
    let root = AssetRoot {
        dir: base_dir,
        memory: Some(memory),
    };
    assemble::load(json, root, limits)
}
