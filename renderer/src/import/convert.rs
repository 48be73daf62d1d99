//! Writing an imported scene as candela JSON (`candela convert IN OUT.json`, and the server, which
//! stores uploaded scenes as JSON): the files held in memory go to a folder beside the JSON
//! (`<stem>_assets/`, binary PLY meshes and images), so the JSON stays small and editable; the
//! files the scene refers to in its own folder are copied when the JSON is written elsewhere.

use std::path::{Path, PathBuf};

use super::doc::{file_names, map_file_names, MEMORY_DIR};
use super::Imported;

/// Why writing failed.
#[derive(Debug, thiserror::Error)]
pub enum ConvertError {
    #[error("cannot write \"{path}\": {msg}")]
    Write { path: String, msg: String },
    #[error("cannot copy \"{from}\" to \"{to}\": {msg}")]
    Copy {
        from: String,
        to: String,
        msg: String,
    },
    #[error("\"{0}\" exists and differs from the scene's file of that name; convert into another folder")]
    WouldOverwrite(String),
}

/// The folder name for an output's files held in memory: `<stem>_assets`.
pub fn assets_dir_name(out: &Path) -> String {
    let stem = out
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scene".into());
    format!("{stem}_assets")
}

/// Writes the imported scene's files into `dir` (memory files under `assets`, the scene's own
/// files copied when `dir` is not the scene's folder) and returns the JSON text, whose file names
/// are relative to `dir`. Returns the files written as well.
pub fn materialize(
    imp: &Imported,
    dir: &Path,
    assets: &str,
) -> Result<(String, Vec<PathBuf>), ConvertError> {
    let mut doc = imp.doc.clone();
    let mut written = Vec::new();
    // Step 1: files held in memory → dir/assets/…
    let prefix = format!("{MEMORY_DIR}/");
    for (name, bytes) in &imp.assets {
        let rel = name.strip_prefix(&prefix).unwrap_or(name);
        let path = dir.join(assets).join(rel);
        write(&path, bytes)?;
        written.push(path);
    }
    map_file_names(&mut doc, &mut |s| {
        let key = crate::scene::paths::memory_key(s);
        imp.assets
            .contains_key(&key)
            .then(|| format!("{assets}/{}", key.strip_prefix(&prefix).unwrap_or(&key)))
    });
    // Step 2: the scene's own files, when the JSON goes to another folder.
    written.extend(copy_referenced(&imp.doc, &imp.base, dir, &imp.assets)?);
    let text = serde_json::to_string_pretty(&doc).unwrap_or_default() + "\n";
    Ok((text, written))
}

/// Copies the files `doc` names (other than those in `memory`) from `base` to `dir`, keeping
/// their relative paths, unless `dir` is `base`; refuses to overwrite a different file.
pub fn copy_referenced(
    doc: &serde_json::Value,
    base: &Path,
    dir: &Path,
    memory: &crate::scene::MemoryAssets,
) -> Result<Vec<PathBuf>, ConvertError> {
    let same = match (dir.canonicalize(), base.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    };
    let mut written = Vec::new();
    if same {
        return Ok(written);
    }
    for rel in file_names(doc) {
        if memory.contains_key(&crate::scene::paths::memory_key(&rel)) {
            continue;
        }
        let (from, to) = (base.join(&rel), dir.join(&rel));
        if !from.is_file() {
            continue; // the loader reports it
        }
        let data = std::fs::read(&from).map_err(|e| ConvertError::Copy {
            from: from.display().to_string(),
            to: to.display().to_string(),
            msg: e.to_string(),
        })?;
        match std::fs::read(&to) {
            Ok(existing) if existing == data => continue,
            Ok(_) => return Err(ConvertError::WouldOverwrite(to.display().to_string())),
            Err(_) => {}
        }
        write(&to, &data)?;
        written.push(to);
    }
    Ok(written)
}

/// Writes `imp` as candela JSON at `out` (its files beside it); returns every file written.
pub fn write_json(imp: &Imported, out: &Path) -> Result<Vec<PathBuf>, ConvertError> {
    let dir = super::folder_of(out);
    let (text, mut written) = materialize(imp, &dir, &assets_dir_name(out))?;
    write(out, text.as_bytes())?;
    written.insert(0, out.to_path_buf());
    Ok(written)
}

fn write(path: &Path, bytes: &[u8]) -> Result<(), ConvertError> {
    let fail = |e: std::io::Error| ConvertError::Write {
        path: path.display().to_string(),
        msg: e.to_string(),
    };
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent).map_err(fail)?;
    }
    std::fs::write(path, bytes).map_err(fail)
}
