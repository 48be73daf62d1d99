//! Scene files of other renderers read into candela's scene document (docs/import.md): Mitsuba 3
//! XML, glTF 2.0 (.gltf/.glb), pbrt-v4 and the vkraytracing `.scn` JSON format.
//!
//! Every importer builds the same JSON document a user could write (docs/scene-format.md), plus
//! files held in memory (meshes given inline, as binary PLY; embedded or derived images), and
//! the scene is then loaded by the one JSON loader (`crate::scene`), so imported scenes get
//! exactly the validation and meaning of JSON scenes. [`load_file`] is the one entry that loads a
//! scene file of any format; [`import_file`] stops at the document (for `candela convert` and
//! the server, which stores JSON), and `convert` writes it out.
//!
//! Error policy (shared, `diag`): what an importer cannot express exactly is an error naming the
//! file, line (XML, pbrt) or JSON path (glTF, .scn) and the construct; with
//! [`ImportOptions::lenient`] it is a warning (returned with the result) and is skipped or
//! replaced as the warning says. Errors the loader finds in the imported document name the
//! source place the offending material, object or light came from.

pub mod convert;
mod derived;
mod diag;
mod doc;
mod files;
pub mod gltf;
mod groups;
mod meshes;
pub mod mitsuba;
pub mod pbrt;
pub mod scn;
#[cfg(test)]
pub(crate) mod test_util;
mod xform;

use std::path::{Path, PathBuf};

use serde_json::Value;

use crate::scene::{Limits, MemoryAssets, Scene, SceneError};

pub use diag::{Diagnostic, Loc};
pub use doc::MEMORY_DIR;

/// A scene file format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// candela's own JSON (docs/scene-format.md).
    Json,
    /// Mitsuba 3 XML.
    Mitsuba,
    /// glTF 2.0, `.gltf` or `.glb`.
    Gltf,
    /// pbrt-v4 scene description.
    Pbrt,
    /// The vkraytracing thesis's `.scn` JSON.
    Scn,
}

impl Format {
    /// Every format with the extensions it is recognised by.
    pub const EXTENSIONS: &'static [(&'static str, Format)] = &[
        ("json", Format::Json),
        ("xml", Format::Mitsuba),
        ("gltf", Format::Gltf),
        ("glb", Format::Gltf),
        ("pbrt", Format::Pbrt),
        ("scn", Format::Scn),
    ];

    /// The format of a file name's extension (case-insensitive).
    pub fn from_extension(path: &Path) -> Option<Format> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        Self::EXTENSIONS
            .iter()
            .find(|(e, _)| *e == ext)
            .map(|&(_, f)| f)
    }

    /// The format of a file's content: the glb magic, XML, a JSON object with glTF's `asset`,
    /// with candela's `version` + `camera` or with `.scn`'s `entities`; pbrt directives.
    pub fn sniff(bytes: &[u8]) -> Option<Format> {
        if bytes.starts_with(b"glTF") {
            return Some(Format::Gltf);
        }
        let head = String::from_utf8_lossy(&bytes[..bytes.len().min(4096)]);
        let text = head.trim_start_matches('\u{feff}').trim_start();
        if text.starts_with('<') {
            return Some(Format::Mitsuba);
        }
        if text.starts_with('{') {
            let v: Value = serde_json::from_slice(bytes).ok()?;
            return Some(
                if v.get("asset").is_some_and(|a| a.get("version").is_some()) {
                    Format::Gltf
                } else if v.get("entities").is_some() || v.get("default_material").is_some() {
                    Format::Scn
                } else {
                    Format::Json
                },
            );
        }
        const PBRT: &[&str] = &[
            "LookAt",
            "Camera",
            "WorldBegin",
            "Film",
            "Sampler",
            "Integrator",
            "Shape",
            "AttributeBegin",
            "Include",
            "Import",
            "Transform",
            "Translate",
            "Scale",
            "Rotate",
            "MakeNamedMaterial",
            "Material",
            "LightSource",
            "Option",
            "ColorSpace",
        ];
        let first = text
            .lines()
            .map(str::trim)
            .find(|l| !l.is_empty() && !l.starts_with('#'))?;
        let word = first.split(|c: char| !c.is_ascii_alphanumeric()).next()?;
        PBRT.contains(&word).then_some(Format::Pbrt)
    }

    /// The format of `path`: by extension, else by content, else JSON.
    pub fn detect(path: &Path, bytes: &[u8]) -> Format {
        Self::from_extension(path)
            .or_else(|| Self::sniff(bytes))
            .unwrap_or(Format::Json)
    }

    /// A short name for messages.
    pub fn name(self) -> &'static str {
        match self {
            Format::Json => "candela JSON",
            Format::Mitsuba => "Mitsuba 3 XML",
            Format::Gltf => "glTF 2.0",
            Format::Pbrt => "pbrt-v4",
            Format::Scn => "vkraytracing .scn",
        }
    }
}

/// How to import.
#[derive(Debug, Clone, Default)]
pub struct ImportOptions {
    /// Unsupported constructs become warnings and are skipped (or replaced, as the warning says).
    pub lenient: bool,
    /// Mitsuba `$name` parameters (`-D name=value` in Mitsuba), before the file's `<default>`s.
    pub params: Vec<(String, String)>,
    /// Limits for loading the result.
    pub limits: Limits,
}

/// A scene read from a file of any format, as candela's document.
#[derive(Debug, Clone)]
pub struct Imported {
    pub format: Format,
    /// The scene document (docs/scene-format.md).
    pub doc: Value,
    /// Files the document names that are held in memory (under [`MEMORY_DIR`]).
    pub assets: MemoryAssets,
    /// The folder the document's other file names are relative to (the source file's folder).
    pub base: PathBuf,
    /// What was skipped, replaced or approximated.
    pub warnings: Vec<Diagnostic>,
    /// (JSON path prefix, source place) of materials, objects and lights.
    origins: Vec<(String, Loc)>,
}

impl Imported {
    /// Loads the document with candela's loader; an error inside something imported names the
    /// source place it came from (`scene.xml:12: objects[3].radius: ...`).
    pub fn load(&self, limits: &Limits) -> Result<Scene, SceneError> {
        let json = self.doc.to_string();
        crate::scene::load_str_with_assets(&json, Some(&self.base), &self.assets, limits)
            .map_err(|e| self.locate(e))
    }

    /// The document as pretty-printed JSON.
    pub fn json_text(&self) -> String {
        serde_json::to_string_pretty(&self.doc).unwrap_or_default()
    }

    /// Attaches the source place to a loader error whose JSON path lies in something imported.
    fn locate(&self, e: SceneError) -> SceneError {
        let Some(path) = e.path() else { return e };
        let found = self.origins.iter().rev().find(|(prefix, _)| {
            path == prefix
                || path
                    .strip_prefix(prefix.as_str())
                    .is_some_and(|rest| rest.starts_with(['.', '[']))
        });
        match found {
            Some((_, loc)) if self.format != Format::Json => loc.error(e.to_string()),
            _ => e,
        }
    }
}

/// A loaded scene with the importer's warnings.
#[derive(Debug)]
pub struct Loaded {
    pub scene: Scene,
    pub format: Format,
    pub warnings: Vec<Diagnostic>,
}

/// Loads a scene file of any format (chosen by extension, else by content): candela JSON goes
/// straight to the loader, the others through their importer.
pub fn load_file(path: &Path, opts: &ImportOptions) -> Result<Loaded, SceneError> {
    let format = detect_file(path)?;
    if format == Format::Json {
        let scene = crate::scene::load_file_with_limits(path, &opts.limits)?;
        return Ok(Loaded {
            scene,
            format,
            warnings: Vec::new(),
        });
    }
    let imported = import_as(path, format, opts)?;
    let scene = imported.load(&opts.limits)?;
    Ok(Loaded {
        scene,
        format,
        warnings: imported.warnings,
    })
}

/// Reads a scene file of any format into candela's document without loading it.
pub fn import_file(path: &Path, opts: &ImportOptions) -> Result<Imported, SceneError> {
    let format = detect_file(path)?;
    import_as(path, format, opts)
}

/// The format of a scene file (reads its start only when the extension says nothing).
pub fn detect_file(path: &Path) -> Result<Format, SceneError> {
    if let Some(f) = Format::from_extension(path) {
        return Ok(f);
    }
    let bytes = read_file(path)?;
    Ok(Format::detect(path, &bytes))
}

/// Reads a whole source file.
pub(crate) fn read_file(path: &Path) -> Result<Vec<u8>, SceneError> {
    std::fs::read(path).map_err(|e| SceneError::SceneFile {
        file: path.display().to_string(),
        msg: crate::scene::io_message(&e),
    })
}

/// The folder of a scene file (`.` for a bare name).
pub(crate) fn folder_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

fn import_as(path: &Path, format: Format, opts: &ImportOptions) -> Result<Imported, SceneError> {
    let base = folder_of(path);
    let (doc, assets, origins, warnings) = match format {
        Format::Json => {
            let text = read_file(path)?;
            let doc: Value = serde_json::from_slice(&text).map_err(|e| SceneError::Syntax {
                path: String::new(),
                line: e.line(),
                column: e.column(),
                msg: e.to_string(),
            })?;
            (doc, MemoryAssets::new(), Vec::new(), Vec::new())
        }
        Format::Mitsuba => mitsuba::import(path, opts)?,
        Format::Gltf => gltf::import(path, opts)?,
        Format::Pbrt => pbrt::import(path, opts)?,
        Format::Scn => scn::import(path, opts)?,
    };
    Ok(Imported {
        format,
        doc,
        assets,
        base,
        warnings,
        origins,
    })
}

/// What each importer returns: the document, its files in memory, the origins of its parts and
/// the warnings.
pub(crate) type ImportResult =
    Result<(Value, MemoryAssets, Vec<(String, Loc)>, Vec<Diagnostic>), SceneError>;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats_by_extension_and_content() {
        assert_eq!(
            Format::from_extension(Path::new("a/B.GLB")),
            Some(Format::Gltf)
        );
        assert_eq!(
            Format::from_extension(Path::new("a.xml")),
            Some(Format::Mitsuba)
        );
        assert_eq!(Format::from_extension(Path::new("a.txt")), None);
        assert_eq!(Format::sniff(b"glTF\x02\0\0\0"), Some(Format::Gltf));
        assert_eq!(
            Format::sniff(b"  <?xml version=\"1.0\"?><scene/>"),
            Some(Format::Mitsuba)
        );
        assert_eq!(
            Format::sniff(br#"{"asset": {"version": "2.0"}}"#),
            Some(Format::Gltf)
        );
        assert_eq!(
            Format::sniff(br#"{"version": 1, "camera": {}}"#),
            Some(Format::Json)
        );
        assert_eq!(Format::sniff(br#"{"entities": []}"#), Some(Format::Scn));
        assert_eq!(
            Format::sniff(b"# a pbrt file\nLookAt 0 0 5  0 0 0  0 1 0\n"),
            Some(Format::Pbrt)
        );
        assert_eq!(Format::sniff(b"hello"), None);
        assert_eq!(Format::detect(Path::new("x"), b"hello"), Format::Json);
    }
}
