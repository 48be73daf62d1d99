//! `SceneError`: every way loading a scene can fail, each with a one-line message that names what
//! is wrong and where (the JSON path, or `file:line` inside an OBJ/PLY file).
//!
//! Also the glue that turns serde errors (tracked by `serde_path_to_error`) into `SceneError`s, and
//! the small path-formatting helpers every other file uses to name JSON locations.

use std::fmt;

/// Why a scene could not be loaded. `Display` is one line: where, then what.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The scene file itself could not be read.
    SceneFile { file: String, msg: String },
    /// The JSON text is malformed (or a number does not fit in an f64).
    Syntax {
        /// JSON path being read when it failed ("" at the top level).
        path: String,
        line: usize,
        column: usize,
        msg: String,
    },
    /// A value is missing, of the wrong type, out of range or refers to something absent.
    Invalid { path: String, msg: String },
    /// A referenced file could not be read.
    Io {
        path: String,
        file: String,
        msg: String,
    },
    /// A referenced file was read but could not be decoded (image, EXR, OBJ without a line).
    Decode {
        path: String,
        file: String,
        msg: String,
    },
    /// An error in a scene file of another format (Mitsuba XML, glTF, pbrt, .scn; see
    /// crate::import) at a line when one is known.
    Import {
        file: String,
        line: Option<usize>,
        msg: String,
    },
    /// An error at a line of an OBJ or PLY file (`line` is None inside binary data).
    Parse {
        /// The JSON path of the field naming the file.
        path: String,
        file: String,
        line: Option<usize>,
        msg: String,
    },
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SceneError::SceneFile { file, msg } => {
                write!(f, "cannot read scene file \"{file}\": {msg}")
            }
            SceneError::Syntax {
                path,
                line,
                column,
                msg,
            } => {
                if !path.is_empty() {
                    write!(f, "{path}: ")?;
                }
                write!(f, "JSON error at line {line}, column {column}: {msg}")
            }
            SceneError::Invalid { path, msg } => {
                if path.is_empty() {
                    write!(f, "{msg}")
                } else {
                    write!(f, "{path}: {msg}")
                }
            }
            SceneError::Io { path, file, msg } => {
                write!(f, "{path}: cannot read \"{file}\": {msg}")
            }
            SceneError::Decode { path, file, msg } => {
                write!(f, "{path}: cannot decode \"{file}\": {msg}")
            }
            SceneError::Import { file, line, msg } => match line {
                Some(line) => write!(f, "{file}:{line}: {msg}"),
                None => write!(f, "{file}: {msg}"),
            },
            SceneError::Parse {
                path,
                file,
                line,
                msg,
            } => match line {
                Some(line) => write!(f, "{file}:{line}: {msg} ({path})"),
                None => write!(f, "{file}: {msg} ({path})"),
            },
        }
    }
}

impl SceneError {
    /// The JSON path of the offending value, when there is one (e.g. `objects[3].material`).
    pub fn path(&self) -> Option<&str> {
        let path = match self {
            SceneError::SceneFile { .. } | SceneError::Import { .. } => return None,
            SceneError::Syntax { path, .. }
            | SceneError::Invalid { path, .. }
            | SceneError::Io { path, .. }
            | SceneError::Decode { path, .. }
            | SceneError::Parse { path, .. } => path,
        };
        (!path.is_empty()).then_some(path.as_str())
    }

    /// Shorthand for [`SceneError::Invalid`].
    pub(crate) fn invalid(path: impl Into<String>, msg: impl Into<String>) -> Self {
        SceneError::Invalid {
            path: path.into(),
            msg: msg.into(),
        }
    }

    /// An I/O error on `file` (as written in the scene) named at `path`.
    pub(crate) fn io(path: &str, file: &str, err: &std::io::Error) -> Self {
        SceneError::Io {
            path: path.to_string(),
            file: file.to_string(),
            msg: io_message(err),
        }
    }
}

/// `"No such file or directory"` rather than `"No such file or directory (os error 2)"`.
pub(crate) fn io_message(err: &std::io::Error) -> String {
    let mut s = err.to_string();
    if let Some(i) = s.rfind(" (os error ") {
        s.truncate(i);
    }
    s
}

/// Appends a map key to a JSON path: `.key` for plain names, `["odd key"]` otherwise.
pub(crate) fn key_path(parent: &str, key: &str) -> String {
    let plain = key
        .chars()
        .next()
        .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && key
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
    if plain {
        if parent.is_empty() {
            key.to_string()
        } else {
            format!("{parent}.{key}")
        }
    } else {
        let quoted = serde_json::to_string(key).unwrap_or_else(|_| format!("\"{key}\""));
        format!("{parent}[{quoted}]")
    }
}

/// Appends an array index to a JSON path: `objects[3]`.
pub(crate) fn index_path(parent: &str, index: usize) -> String {
    format!("{parent}[{index}]")
}

/// Joins two relative JSON paths (`a.b` + `c[1]` → `a.b.c[1]`, `a` + `[1]` → `a[1]`).
pub(crate) fn join_path(parent: &str, child: &str) -> String {
    if parent.is_empty() {
        child.to_string()
    } else if child.is_empty() {
        parent.to_string()
    } else if child.starts_with('[') {
        format!("{parent}{child}")
    } else {
        format!("{parent}.{child}")
    }
}

/// Formats a `serde_path_to_error` path with [`key_path`] / [`index_path`].
pub(crate) fn format_path(path: &serde_path_to_error::Path) -> String {
    use serde_path_to_error::Segment;
    let mut out = String::new();
    for segment in path {
        out = match segment {
            Segment::Seq { index } => index_path(&out, *index),
            Segment::Map { key } => key_path(&out, key),
            Segment::Enum { variant } => key_path(&out, variant),
            // A position serde could not name (e.g. inside a malformed object): stop there.
            Segment::Unknown => break,
        };
    }
    out
}

/// Marks a custom serde error message as carrying a JSON path relative to where it was raised.
/// Tagged enums are deserialised from a buffered `serde_json::Value` (so `serde_path_to_error`
/// cannot see inside them); they report the inner path this way and [`from_json_error`] joins it
/// to the outer one.
const MARK: char = '\u{1}';

/// A serde error whose message carries `inner_path` (relative to the value being deserialised).
pub(crate) fn nested_error<E: serde::de::Error>(inner_path: &str, msg: &str) -> E {
    E::custom(format!("{MARK}{inner_path}{MARK}{msg}"))
}

/// Splits a message made by [`nested_error`] into (inner path, message).
pub(crate) fn split_nested(msg: &str) -> (&str, &str) {
    if let Some(rest) = msg.strip_prefix(MARK) {
        if let Some((path, msg)) = rest.split_once(MARK) {
            return (path, msg);
        }
    }
    ("", msg)
}

/// Removes serde_json's `" at line L column C"` suffix (location is reported separately).
fn strip_location(msg: &str, line: usize, column: usize) -> &str {
    let suffix = format!(" at line {line} column {column}");
    msg.strip_suffix(suffix.as_str()).unwrap_or(msg)
}

/// Converts a path-tracked serde_json error into a `SceneError`.
pub(crate) fn from_json_error(err: serde_path_to_error::Error<serde_json::Error>) -> SceneError {
    let outer = format_path(err.path());
    let inner = err.into_inner();
    let (line, column) = (inner.line(), inner.column());
    let full = inner.to_string();
    let (nested, msg) = split_nested(strip_location(&full, line, column));
    let path = join_path(&outer, nested);
    let msg = tidy_message(msg);
    match inner.classify() {
        serde_json::error::Category::Syntax | serde_json::error::Category::Eof => {
            SceneError::Syntax {
                path,
                line,
                column,
                msg,
            }
        }
        _ => SceneError::Invalid { path, msg },
    }
}

/// Makes serde's wording clearer where it is terse.
fn tidy_message(msg: &str) -> String {
    if msg == "number out of range" {
        return "number out of range (does not fit in a 64-bit float)".to_string();
    }
    // serde quotes values in backticks: keep numbers bare, put strings in double quotes.
    let mut out = String::with_capacity(msg.len());
    let mut parts = msg.split('`');
    if let Some(first) = parts.next() {
        out.push_str(first);
    }
    let mut inside = true;
    for part in parts {
        if inside && part.parse::<f64>().is_err() {
            out.push('"');
            out.push_str(part);
            out.push('"');
        } else {
            out.push_str(part);
        }
        inside = !inside;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_join_and_quote() {
        assert_eq!(key_path("", "camera"), "camera");
        assert_eq!(key_path("materials", "red"), "materials.red");
        assert_eq!(key_path("materials", "my mat"), "materials[\"my mat\"]");
        assert_eq!(index_path("objects", 3), "objects[3]");
        assert_eq!(join_path("objects[3]", "[1]"), "objects[3][1]");
        assert_eq!(join_path("a", "b.c"), "a.b.c");
        assert_eq!(join_path("", "b"), "b");
    }

    #[test]
    fn nested_round_trip() {
        let e: serde_json::Error = nested_error("reflectance", "bad");
        let s = e.to_string();
        assert_eq!(split_nested(&s), ("reflectance", "bad"));
        assert_eq!(split_nested("plain"), ("", "plain"));
    }

    #[test]
    fn display_forms() {
        let e = SceneError::invalid("camera.fov_y", "must be in (0, 180), got 190");
        assert_eq!(e.to_string(), "camera.fov_y: must be in (0, 180), got 190");
        assert_eq!(e.path(), Some("camera.fov_y"));
        let e = SceneError::Parse {
            path: "objects[0].file".into(),
            file: "bunny.ply".into(),
            line: Some(12),
            msg: "expected 3 numbers".into(),
        };
        assert_eq!(
            e.to_string(),
            "bunny.ply:12: expected 3 numbers (objects[0].file)"
        );
        let io = std::io::Error::from(std::io::ErrorKind::NotFound);
        let e = SceneError::io("objects[0].file", "missing.obj", &io);
        assert!(e
            .to_string()
            .starts_with("objects[0].file: cannot read \"missing.obj\": "));
    }
}
