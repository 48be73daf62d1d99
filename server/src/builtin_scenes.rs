//! The example scenes of the repository's `scenes/` folder, embedded in the binary (JSON and
//! assets, `include_bytes!`) so that `scene_name` jobs work wherever the binary runs. At startup
//! the assets are written under `<data>/builtin/` (the scenes' base folder), rewriting only
//! files whose content differs.

use std::path::Path;

use serde_json::{json, Value};

/// Built-in scenes: (name, scene JSON).
pub const SCENES: &[(&str, &str)] = &[
    ("cornell", include_str!("../../scenes/cornell.json")),
    ("envmap", include_str!("../../scenes/envmap.json")),
    ("furnace", include_str!("../../scenes/furnace.json")),
    ("lights", include_str!("../../scenes/lights.json")),
    ("mirror_glass", include_str!("../../scenes/mirror_glass.json")),
    ("textured_mesh", include_str!("../../scenes/textured_mesh.json")),
];

/// Their asset files: (path relative to the scenes folder, bytes).
pub const ASSETS: &[(&str, &[u8])] = &[
    (
        "assets/checker.png",
        include_bytes!("../../scenes/assets/checker.png"),
    ),
    ("assets/sky.exr", include_bytes!("../../scenes/assets/sky.exr")),
    (
        "assets/uv_sphere.obj",
        include_bytes!("../../scenes/assets/uv_sphere.obj"),
    ),
];

/// The JSON text of a built-in scene.
pub fn scene_json(name: &str) -> Option<&'static str> {
    SCENES.iter().find(|(n, _)| *n == name).map(|(_, j)| *j)
}

/// The names, comma-separated (for error messages).
pub fn names() -> String {
    SCENES
        .iter()
        .map(|(n, _)| *n)
        .collect::<Vec<_>>()
        .join(", ")
}

/// Writes the assets under `dir` (creating folders), skipping files already identical.
pub fn install(dir: &Path) -> std::io::Result<()> {
    for (rel, bytes) in ASSETS {
        let path = dir.join(rel);
        if std::fs::read(&path).ok().as_deref() == Some(*bytes) {
            continue;
        }
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent)?;
        }
        let tmp = path.with_extension("tmp");
        std::fs::write(&tmp, bytes)?;
        std::fs::rename(&tmp, &path)?;
    }
    Ok(())
}

/// A summary of each scene for `GET /api/scenes`: name, film size, render defaults, files used.
pub fn catalog() -> Vec<Value> {
    SCENES
        .iter()
        .map(|(name, text)| {
            let v: Value = serde_json::from_str(text).unwrap_or(Value::Null);
            let film = &v["film"];
            let assets: Vec<&str> = ASSETS
                .iter()
                .map(|(rel, _)| *rel)
                .filter(|rel| text.contains(rel))
                .collect();
            json!({
                "name": name,
                "width": film.get("width").cloned().unwrap_or(json!(512)),
                "height": film.get("height").cloned().unwrap_or(json!(512)),
                "render": v.get("render").cloned().unwrap_or(json!({})),
                "assets": assets,
                "links": {"scene": format!("/api/scenes/{name}")},
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every scene of `scenes/` (and every asset it uses) is embedded.
    #[test]
    fn every_repository_scene_is_embedded() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes");
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().and_then(|e| e.to_str()) == Some("json") {
                let stem = path.file_stem().unwrap().to_str().unwrap();
                let text = scene_json(stem).unwrap_or_else(|| panic!("{stem} is not embedded"));
                assert_eq!(text, std::fs::read_to_string(&path).unwrap());
            }
        }
        for (rel, bytes) in ASSETS {
            assert_eq!(*bytes, std::fs::read(dir.join(rel)).unwrap().as_slice());
        }
    }

    /// Every built-in scene loads from the installed assets.
    #[test]
    fn builtin_scenes_load() {
        let dir = std::env::temp_dir().join(format!("candela-builtin-{}", std::process::id()));
        install(&dir).unwrap();
        install(&dir).unwrap();
        for (name, text) in SCENES {
            renderer::scene::load_str(text, Some(&dir))
                .unwrap_or_else(|e| panic!("{name}: {e}"));
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}
