//! Embeds the repository's example scenes: writes `$OUT_DIR/builtin_scenes.rs` with every
//! top-level `scenes/*.json` (as `include_str!`) and every file in a sub-folder of `scenes/`
//! (their assets, as `include_bytes!`), so a scene added to the folder is served by
//! `GET /api/scenes` without touching the code.

use std::path::{Path, PathBuf};

fn files_under(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let mut entries: Vec<PathBuf> = entries.filter_map(|e| e.ok().map(|e| e.path())).collect();
    entries.sort();
    for path in entries {
        if path.is_dir() {
            files_under(&path, out);
        } else {
            out.push(path);
        }
    }
}

fn main() {
    let manifest = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("manifest dir"));
    let scenes = manifest.join("..").join("scenes");
    println!("cargo:rerun-if-changed={}", scenes.display());
    let mut all = Vec::new();
    files_under(&scenes, &mut all);
    let mut scene_items = String::new();
    let mut asset_items = String::new();
    for path in &all {
        let rel = path.strip_prefix(&scenes).expect("under scenes/");
        let rel_str = rel
            .components()
            .map(|c| c.as_os_str().to_string_lossy().into_owned())
            .collect::<Vec<_>>()
            .join("/");
        let abs = path.canonicalize().unwrap_or_else(|_| path.clone());
        let top_level_json =
            rel.components().count() == 1 && path.extension().is_some_and(|e| e == "json");
        if top_level_json {
            let name = path.file_stem().unwrap().to_string_lossy();
            scene_items.push_str(&format!(
                "    ({name:?}, include_str!({:?})),\n",
                abs.display().to_string()
            ));
        } else if rel.components().count() > 1 {
            asset_items.push_str(&format!(
                "    ({rel_str:?}, include_bytes!({:?})),\n",
                abs.display().to_string()
            ));
        }
    }
    let code = format!(
        "/// Built-in scenes: (name, scene JSON).\n\
         pub const SCENES: &[(&str, &str)] = &[\n{scene_items}];\n\n\
         /// Their asset files: (path relative to the scenes folder, bytes).\n\
         pub const ASSETS: &[(&str, &[u8])] = &[\n{asset_items}];\n"
    );
    let out = PathBuf::from(std::env::var("OUT_DIR").expect("out dir")).join("builtin_scenes.rs");
    std::fs::write(out, code).expect("write builtin_scenes.rs");
}
