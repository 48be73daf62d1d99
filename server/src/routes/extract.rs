//! Extractors whose rejections are JSON [`ApiError`]s like every other error: the `{id}` of a
//! job route (anything but a positive integer is simply not a job: 404) and the query string as
//! a map (malformed: 400).

use std::collections::HashMap;

use axum::extract::{FromRequestParts, Path, Query};
use axum::http::request::Parts;

use crate::api_error::ApiError;
use crate::jobs::model::JobId;

/// The `{id}` of `/api/jobs/{id}/...`.
pub struct JobIdPath(pub JobId);

impl<S: Send + Sync> FromRequestParts<S> for JobIdPath {
    type Rejection = ApiError;

    async fn from_request_parts(parts: &mut Parts, state: &S) -> Result<Self, ApiError> {
        let Path(raw) = Path::<String>::from_request_parts(parts, state)
            .await
            .map_err(|e| ApiError::NotFound(format!("no such job ({})", e.body_text())))?;
        raw.parse::<JobId>()
            .ok()
            .filter(|id| *id > 0)
            .map(JobIdPath)
            .ok_or_else(|| ApiError::NotFound(format!("no job \"{raw}\"")))
    }
}

/// The query parameters (last value wins).
pub struct QueryMap(pub HashMap<String, String>);

impl<S: Send + Sync> FromRequestParts<S> for QueryMap {
    type Rejection = ApiError;

    async fn from_request_parts(parts: &mut Parts, _state: &S) -> Result<Self, ApiError> {
        Query::<HashMap<String, String>>::try_from_uri(&parts.uri)
            .map(|Query(q)| QueryMap(q))
            .map_err(|e| ApiError::bad_request(format!("query string: {}", e.body_text())))
    }
}
