//! stub
use std::path::{Path, PathBuf};
use crate::import::Imported;
use crate::scene::SceneError;
/// stub
pub fn write_xml(_imp: &Imported, out: &Path) -> Result<Vec<PathBuf>, SceneError> {
    Err(SceneError::Import { file: out.display().to_string(), line: None, msg: "not yet".into() })
}
