//! stub
use std::path::Path;
use super::{ImportOptions, ImportResult};
pub(crate) fn import(path: &Path, _opts: &ImportOptions) -> ImportResult {
    Err(crate::scene::SceneError::Import { file: path.display().to_string(), line: None, msg: "not yet".into() })
}
