//! File names written inside source scenes (Mitsuba `filename`s and includes, glTF URIs, pbrt
//! `Include`s and `filename` parameters): relative to the file that names them, and kept inside
//! the scene's folder (absolute names and `..` past the folder are errors), as candela's loader
//! requires of its own scenes.

use std::path::{Component, Path, PathBuf};

/// `a/b` with forward slashes.
pub(crate) fn to_slash(p: &Path) -> String {
    p.components()
        .filter_map(|c| match c {
            Component::Normal(s) => Some(s.to_string_lossy().into_owned()),
            _ => None,
        })
        .collect::<Vec<_>>()
        .join("/")
}

/// `name` (relative, `/` or `\` separated) against `dir` (relative to `scene_dir`), else against
/// the scene's folder: the first that exists, else the first. Errors say why not.
pub(crate) fn resolve_in(scene_dir: &Path, dir: &Path, name: &str) -> Result<PathBuf, String> {
    if name.is_empty() {
        return Err("empty file name".into());
    }
    let p = Path::new(name);
    if p.is_absolute() || p.has_root() || name.starts_with(['/', '\\']) || name.contains(':') {
        return Err(format!(
            "\"{name}\": absolute paths are not allowed; give a path relative to the scene folder"
        ));
    }
    let normalize = |start: &Path| -> Option<PathBuf> {
        let mut out: Vec<String> = to_slash(start)
            .split('/')
            .filter(|s| !s.is_empty())
            .map(String::from)
            .collect();
        for part in name.split(['/', '\\']) {
            match part {
                "" | "." => {}
                ".." => {
                    out.pop()?;
                }
                p => out.push(p.to_string()),
            }
        }
        Some(out.iter().collect())
    };
    let here = normalize(dir);
    let top = normalize(Path::new(""));
    let candidates: Vec<PathBuf> = [here, top].into_iter().flatten().collect();
    if candidates.is_empty() {
        return Err(format!("\"{name}\" leaves the scene folder"));
    }
    Ok(candidates
        .iter()
        .find(|c| scene_dir.join(c).exists())
        .unwrap_or(&candidates[0])
        .clone())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_stay_inside_the_scene_folder() {
        let here = std::env::temp_dir();
        assert_eq!(
            resolve_in(&here, Path::new("sub"), "../a.png").unwrap(),
            PathBuf::from("a.png")
        );
        assert_eq!(
            to_slash(&resolve_in(&here, Path::new("sub"), "t\\b.png").unwrap()),
            "sub/t/b.png"
        );
        assert!(resolve_in(&here, Path::new(""), "../a.png")
            .unwrap_err()
            .contains("leaves"));
        assert!(resolve_in(&here, Path::new(""), "/etc/passwd")
            .unwrap_err()
            .contains("absolute"));
        assert!(resolve_in(&here, Path::new(""), "C:/x.png")
            .unwrap_err()
            .contains("absolute"));
    }
}
