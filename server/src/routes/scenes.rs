//! `GET /api/scenes`: the built-in example scenes (name, film size, render defaults, assets);
//! `GET /api/scenes/{name}`: one scene's JSON document, e.g. to edit and submit inline.

use axum::extract::Path;
use axum::http::header;
use axum::response::{IntoResponse, Response};
use axum::Json;
use serde_json::{json, Value};

use crate::api_error::ApiError;
use crate::builtin_scenes;

/// The catalogue.
pub async fn list() -> Json<Value> {
    Json(json!({ "scenes": builtin_scenes::catalog() }))
}

/// One scene document.
pub async fn get_one(Path(name): Path<String>) -> Result<Response, ApiError> {
    let name = name.strip_suffix(".json").unwrap_or(&name);
    let text = builtin_scenes::scene_json(name).ok_or_else(|| {
        ApiError::NotFound(format!(
            "no built-in scene \"{name}\" (available: {})",
            builtin_scenes::names()
        ))
    })?;
    Ok(([(header::CONTENT_TYPE, "application/json")], text).into_response())
}
