//! Resolving asset paths written in a scene (textures, meshes, environment maps) against the scene
//! folder, refusing anything that could escape it: absolute paths, `..` components (either
//! separator) and symlinks whose target lies outside (checked with `canonicalize`).
//!
//! An importer (crate::import) may also hand over files held in memory (its meshes, a glTF's
//! embedded images): they are looked up by their relative path before the folder.

use std::path::{Component, Path, PathBuf};

use super::error::SceneError;
use super::MemoryAssets;

/// Where a scene's files come from: its folder and, optionally, files held in memory.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct AssetRoot<'a> {
    pub dir: Option<&'a Path>,
    pub memory: Option<&'a MemoryAssets>,
}

impl<'a> AssetRoot<'a> {
    /// Files from a folder only.
    pub fn dir(dir: Option<&'a Path>) -> Self {
        AssetRoot { dir, memory: None }
    }
}

/// An asset file that exists inside the scene folder (or in memory).
#[derive(Debug, Clone)]
pub(crate) struct AssetPath {
    /// The canonical path (also the key for de-duplication); `memory:NAME` for files in memory.
    pub canonical: PathBuf,
    /// The path as written in the scene, for messages.
    pub shown: String,
    /// Whether the file is held in memory (under `memory_key(shown)`).
    in_memory: bool,
}

/// The key of `rel` among files held in memory: `./` components dropped.
pub(crate) fn memory_key(rel: &str) -> String {
    rel.split('/')
        .filter(|p| !p.is_empty() && *p != ".")
        .collect::<Vec<_>>()
        .join("/")
}

/// Lower-case extension of a path as written (`"Wood.PNG"` → `"png"`), or "".
pub(crate) fn extension(rel: &str) -> String {
    Path::new(rel)
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .unwrap_or_default()
}

/// Checks that `rel` stays inside the scene folder, without touching the file system.
pub(crate) fn check_relative(rel: &str, json_path: &str) -> Result<(), SceneError> {
    if rel.is_empty() {
        return Err(SceneError::invalid(json_path, "empty file name"));
    }
    if rel.contains('\0') {
        return Err(SceneError::invalid(
            json_path,
            "file name contains a NUL byte",
        ));
    }
    let p = Path::new(rel);
    let absolute = p.is_absolute()
        || p.has_root()
        || rel.starts_with('\\')
        || p.components().any(|c| matches!(c, Component::Prefix(_)))
        || (rel.len() >= 2 && rel.as_bytes()[1] == b':' && rel.as_bytes()[0].is_ascii_alphabetic());
    if absolute {
        return Err(SceneError::invalid(
            json_path,
            format!("\"{rel}\": absolute paths are not allowed; give a path relative to the scene folder"),
        ));
    }
    if rel.split(['/', '\\']).any(|part| part == "..") {
        return Err(SceneError::invalid(
            json_path,
            format!("\"{rel}\" escapes the scene folder (\"..\" is not allowed)"),
        ));
    }
    Ok(())
}

/// Resolves `rel` (as written at `json_path`) against `root`: a file held in memory, else one that
/// exists and lies inside the folder after following symlinks.
pub(crate) fn resolve(
    root: AssetRoot<'_>,
    rel: &str,
    json_path: &str,
) -> Result<AssetPath, SceneError> {
    check_relative(rel, json_path)?;
    let key = memory_key(rel);
    if root.memory.is_some_and(|m| m.contains_key(&key)) {
        return Ok(AssetPath {
            canonical: PathBuf::from(format!("memory:{key}")),
            shown: rel.to_string(),
            in_memory: true,
        });
    }
    let Some(base) = root.dir else {
        return Err(SceneError::invalid(
            json_path,
            format!(
                "\"{rel}\": this scene has no folder for its files (it was given as text only)"
            ),
        ));
    };
    let base_canonical = base
        .canonicalize()
        .map_err(|e| SceneError::io(json_path, &base.display().to_string(), &e))?;
    let canonical = base
        .join(rel)
        .canonicalize()
        .map_err(|e| SceneError::io(json_path, rel, &e))?;
    if !canonical.starts_with(&base_canonical) {
        return Err(SceneError::invalid(
            json_path,
            format!("\"{rel}\" resolves outside the scene folder (through a symbolic link)"),
        ));
    }
    Ok(AssetPath {
        canonical,
        shown: rel.to_string(),
        in_memory: false,
    })
}

/// Reads a resolved asset (from `root`'s memory when it was found there).
pub(crate) fn read(
    root: AssetRoot<'_>,
    asset: &AssetPath,
    json_path: &str,
) -> Result<Vec<u8>, SceneError> {
    if asset.in_memory {
        let bytes = root.memory.and_then(|m| m.get(&memory_key(&asset.shown)));
        return bytes.cloned().ok_or_else(|| {
            SceneError::invalid(json_path, format!("\"{}\": not found", asset.shown))
        });
    }
    std::fs::read(&asset.canonical).map_err(|e| SceneError::io(json_path, &asset.shown, &e))
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A fresh, empty folder under the system temp dir.
    pub(crate) fn temp_dir(tag: &str) -> PathBuf {
        use std::sync::atomic::{AtomicUsize, Ordering};
        static N: AtomicUsize = AtomicUsize::new(0);
        let n = N.fetch_add(1, Ordering::Relaxed);
        let dir =
            std::env::temp_dir().join(format!("candela-scene-{}-{tag}-{n}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn rejects_escapes() {
        let e = check_relative("../x.png", "a.texture")
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "a.texture: \"../x.png\" escapes the scene folder (\"..\" is not allowed)"
        );
        let e = check_relative("sub/../../x.png", "p")
            .unwrap_err()
            .to_string();
        assert!(e.contains("escapes"), "{e}");
        let e = check_relative("/etc/passwd", "p").unwrap_err().to_string();
        assert!(e.contains("absolute paths are not allowed"), "{e}");
        assert!(check_relative("C:\\x.png", "p").is_err());
        assert!(check_relative("..\\x.png", "p").is_err());
        assert!(check_relative("", "p").is_err());
        assert!(check_relative("sub/x.png", "p").is_ok());
        assert!(check_relative("./x..png", "p").is_ok());
    }

    #[test]
    fn resolves_inside_and_reports_missing() {
        let dir = temp_dir("paths");
        std::fs::write(dir.join("a.obj"), "v 0 0 0\n").unwrap();
        let a = resolve(AssetRoot::dir(Some(&dir)), "a.obj", "p").unwrap();
        assert!(a.canonical.ends_with("a.obj"));
        let e = resolve(AssetRoot::dir(Some(&dir)), "missing.obj", "objects[0].file").unwrap_err();
        assert_eq!(
            e.to_string(),
            "objects[0].file: cannot read \"missing.obj\": No such file or directory"
        );
        let e = resolve(AssetRoot::dir(None), "a.obj", "p")
            .unwrap_err()
            .to_string();
        assert!(e.contains("no folder"), "{e}");
    }

    #[test]
    fn memory_files_come_first() {
        let dir = temp_dir("memory");
        std::fs::write(dir.join("m.ply"), "on disk").unwrap();
        let mut memory = MemoryAssets::new();
        memory.insert("sub/m.ply".into(), b"in memory".to_vec());
        memory.insert("m.ply".into(), b"shadowing".to_vec());
        let root = AssetRoot {
            dir: Some(&dir),
            memory: Some(&memory),
        };
        let a = resolve(root, "./sub/m.ply", "p").unwrap();
        assert_eq!(read(root, &a, "p").unwrap(), b"in memory");
        let a = resolve(root, "m.ply", "p").unwrap();
        assert_eq!(read(root, &a, "p").unwrap(), b"shadowing");
        let no_dir = AssetRoot {
            dir: None,
            memory: Some(&memory),
        };
        assert!(resolve(no_dir, "sub/m.ply", "p").is_ok());
        assert!(resolve(no_dir, "other.ply", "p").is_err());
        assert!(
            resolve(no_dir, "../m.ply", "p").is_err(),
            "escapes are refused first"
        );
    }

    #[cfg(unix)]
    #[test]
    fn rejects_symlink_escape() {
        let outside = temp_dir("outside");
        std::fs::write(outside.join("secret.png"), "x").unwrap();
        let dir = temp_dir("symlink");
        std::os::unix::fs::symlink(outside.join("secret.png"), dir.join("link.png")).unwrap();
        let e = resolve(AssetRoot::dir(Some(&dir)), "link.png", "p")
            .unwrap_err()
            .to_string();
        assert!(e.contains("resolves outside the scene folder"), "{e}");
    }
}
