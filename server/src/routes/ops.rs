//! Operations: `GET /api/health` (always open: status, version, device, kernel warm-up, jobs by
//! state, storage), `GET /api/me` (the caller's name and role) and
//! `GET /metrics` (Prometheus text: jobs by state, samples rendered, GPU busy seconds, passes,
//! queue-wait histogram, open event streams, free space; and every worker's figures, from the
//! store: routes/workers.rs).

use axum::extract::State;
use axum::http::header;
use axum::response::{IntoResponse, Response};
use axum::Json;
use serde_json::{json, Value};

use crate::api_error::ApiError;
use crate::state::AppState;

/// Health: `status` is "ok" when the device is ready, "degraded" otherwise (the API still
/// accepts jobs; they wait for the device).
pub async fn health(State(st): State<AppState>) -> Result<Json<Value>, ApiError> {
    let gpu = st.shared.gpu();
    let jobs = st.store.count_by_state()?;
    let status = match (st.shutting_down(), gpu.state) {
        (true, _) => "shutting_down",
        (false, "ready" | "none") => "ok",
        (false, _) => "degraded",
    };
    Ok(Json(json!({
        "status": status,
        "version": env!("CARGO_PKG_VERSION"),
        "uptime_s": st.shared.uptime_s(),
        "gpu": gpu,
        "kernels": st.shared.kernels(),
        "jobs": jobs,
        "auth": crate::auth::required(&st.config, &st.store)?,
        "storage": st.shared.storage(),
    })))
}

/// `GET /api/me`: the caller's name and role.
pub async fn me(caller: crate::auth::Caller) -> Json<Value> {
    Json(json!({"name": caller.name, "role": caller.role.as_str()}))
}

/// Prometheus exposition.
pub async fn metrics(State(st): State<AppState>) -> Result<Response, ApiError> {
    let jobs = st.store.count_by_state()?;
    let mut text = st.shared.prometheus(&jobs);
    text.push_str(&super::workers::prometheus(&st.store)?);
    Ok((
        [(
            header::CONTENT_TYPE,
            "text/plain; version=0.0.4; charset=utf-8",
        )],
        text,
    )
        .into_response())
}
