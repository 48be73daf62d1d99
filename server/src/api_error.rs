//! `ApiError`: every way an API request can fail, mapped to a status code and the JSON body
//! `{"error": {"code", "message", "path"?}}`. Messages are meant for the client; internal details
//! (database or file-system errors) are logged and replaced by a generic message.

use axum::http::{header, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::Json;
use serde_json::json;

/// A failed API request. `path` is the JSON path of the offending value when there is one.
#[derive(Debug)]
pub enum ApiError {
    /// 400: malformed request (JSON syntax, query parameters, multipart framing).
    BadRequest { code: &'static str, message: String },
    /// 401: missing or wrong bearer token.
    Unauthorized,
    /// 403: the caller's role does not allow it (a viewer writing, a submitter touching another's
    /// job).
    Forbidden(String),
    /// 404: no such job, scene, image or route.
    NotFound(String),
    /// 405: the route exists but not with this method.
    MethodNotAllowed,
    /// 409: the job's state does not allow the operation.
    Conflict(String),
    /// 413: the body (or an upload once extracted) is too large.
    PayloadTooLarge(String),
    /// 422: well-formed but invalid: a field's value, or the scene itself.
    Unprocessable {
        code: &'static str,
        message: String,
        path: Option<String>,
    },
    /// 429: too many unfinished jobs; retry later.
    TooManyJobs(String),
    /// 507: the data directory's free space is below the server's minimum.
    InsufficientStorage(String),
    /// 503: the server is shutting down.
    Unavailable(String),
    /// 500: something on our side; the detail is logged, not sent.
    Internal(String),
}

impl ApiError {
    /// A 422 for an invalid field at `path`.
    pub fn invalid(path: impl Into<String>, message: impl Into<String>) -> Self {
        ApiError::Unprocessable {
            code: "invalid_field",
            message: message.into(),
            path: Some(path.into()),
        }
    }

    /// A 400 with code `bad_request`.
    pub fn bad_request(message: impl Into<String>) -> Self {
        ApiError::BadRequest {
            code: "bad_request",
            message: message.into(),
        }
    }

    /// A 500 whose detail is logged.
    pub fn internal(detail: impl std::fmt::Display) -> Self {
        ApiError::Internal(detail.to_string())
    }

    /// The HTTP status.
    pub fn status(&self) -> StatusCode {
        match self {
            ApiError::BadRequest { .. } => StatusCode::BAD_REQUEST,
            ApiError::Unauthorized => StatusCode::UNAUTHORIZED,
            ApiError::Forbidden(_) => StatusCode::FORBIDDEN,
            ApiError::NotFound(_) => StatusCode::NOT_FOUND,
            ApiError::MethodNotAllowed => StatusCode::METHOD_NOT_ALLOWED,
            ApiError::Conflict(_) => StatusCode::CONFLICT,
            ApiError::PayloadTooLarge(_) => StatusCode::PAYLOAD_TOO_LARGE,
            ApiError::Unprocessable { .. } => StatusCode::UNPROCESSABLE_ENTITY,
            ApiError::TooManyJobs(_) => StatusCode::TOO_MANY_REQUESTS,
            ApiError::Unavailable(_) => StatusCode::SERVICE_UNAVAILABLE,
            ApiError::InsufficientStorage(_) => StatusCode::INSUFFICIENT_STORAGE,
            ApiError::Internal(_) => StatusCode::INTERNAL_SERVER_ERROR,
        }
    }

    /// The machine-readable code.
    pub fn code(&self) -> &'static str {
        match self {
            ApiError::BadRequest { code, .. } | ApiError::Unprocessable { code, .. } => code,
            ApiError::Unauthorized => "unauthorized",
            ApiError::Forbidden(_) => "forbidden",
            ApiError::NotFound(_) => "not_found",
            ApiError::MethodNotAllowed => "method_not_allowed",
            ApiError::Conflict(_) => "conflict",
            ApiError::PayloadTooLarge(_) => "payload_too_large",
            ApiError::TooManyJobs(_) => "too_many_jobs",
            ApiError::Unavailable(_) => "unavailable",
            ApiError::InsufficientStorage(_) => "insufficient_storage",
            ApiError::Internal(_) => "internal",
        }
    }

    /// The message sent to the client.
    pub fn message(&self) -> String {
        match self {
            ApiError::BadRequest { message, .. } | ApiError::Unprocessable { message, .. } => {
                message.clone()
            }
            ApiError::Unauthorized => {
                "missing or wrong token: send the header \"Authorization: Bearer TOKEN\"".into()
            }
            ApiError::NotFound(m)
            | ApiError::Forbidden(m)
            | ApiError::Conflict(m)
            | ApiError::PayloadTooLarge(m)
            | ApiError::TooManyJobs(m)
            | ApiError::Unavailable(m)
            | ApiError::InsufficientStorage(m) => m.clone(),
            ApiError::MethodNotAllowed => "method not allowed on this path".into(),
            ApiError::Internal(_) => "internal server error (see the server log)".into(),
        }
    }
}

impl std::fmt::Display for ApiError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} {}: {}",
            self.status().as_u16(),
            self.code(),
            self.message()
        )
    }
}

impl From<rusqlite::Error> for ApiError {
    fn from(e: rusqlite::Error) -> Self {
        ApiError::internal(format!("store: {e}"))
    }
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        if let ApiError::Internal(detail) = &self {
            tracing::error!(%detail, "internal error");
        }
        let mut error = json!({"code": self.code(), "message": self.message()});
        if let ApiError::Unprocessable {
            path: Some(path), ..
        } = &self
        {
            error["path"] = json!(path);
        }
        let mut response = (self.status(), Json(json!({ "error": error }))).into_response();
        match self {
            ApiError::Unauthorized => {
                response.headers_mut().insert(
                    header::WWW_AUTHENTICATE,
                    HeaderValue::from_static("Bearer realm=\"candela\""),
                );
            }
            ApiError::TooManyJobs(_) => {
                response
                    .headers_mut()
                    .insert(header::RETRY_AFTER, HeaderValue::from_static("5"));
            }
            _ => {}
        }
        response
    }
}
