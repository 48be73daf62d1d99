//! The HTTP application: the `app(state) -> Router` factory (every route of the
//! API, the metrics, the embedded web viewer), authentication (tokens and roles, auth.rs), JSON fallbacks for
//! unknown routes and methods, the body-size limit, and a 500 JSON answer (not a dropped
//! connection) should a handler ever panic.

use std::collections::HashMap;

use axum::extract::{DefaultBodyLimit, Query, Request, State};
use axum::http::{header, Method};
use axum::middleware::{self, Next};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::Router;
use tower_http::catch_panic::CatchPanicLayer;
use tower_http::trace::TraceLayer;

use crate::api_error::ApiError;
use crate::auth;
use crate::routes;
use crate::state::AppState;

/// The router with every route, layer and fallback.
pub fn app(state: AppState) -> Router {
    let api = Router::new()
        .route("/api/health", get(routes::ops::health))
        .route(
            "/api/jobs",
            post(routes::jobs::create).get(routes::jobs::list),
        )
        .route(
            "/api/jobs/{id}",
            get(routes::jobs::get_one)
                .delete(routes::jobs::remove)
                .patch(routes::jobs::patch),
        )
        .route("/api/jobs/{id}/cancel", post(routes::jobs::cancel))
        .route("/api/jobs/{id}/pause", post(routes::jobs::pause))
        .route("/api/jobs/{id}/resume", post(routes::jobs::resume))
        .route("/api/jobs/{id}/events", get(routes::events::stream))
        .route("/api/jobs/{id}/image.png", get(routes::images::png))
        .route("/api/jobs/{id}/image.exr", get(routes::images::exr))
        .route("/api/me", get(routes::ops::me))
        .route("/api/workers", get(routes::workers::list))
        .route("/api/integrators", get(routes::integrators::list))
        .route("/api/scenes", get(routes::scenes::list))
        .route("/api/scenes/{name}", get(routes::scenes::get_one))
        .route("/metrics", get(routes::ops::metrics));
    Router::new()
        .merge(api)
        .merge(routes::static_files::router())
        .fallback(not_found)
        .method_not_allowed_fallback(method_not_allowed)
        .layer(middleware::from_fn_with_state(state.clone(), authenticate))
        .layer(DefaultBodyLimit::max(state.config.limits.max_body_bytes))
        .layer(TraceLayer::new_for_http())
        .layer(CatchPanicLayer::custom(panic_response))
        .with_state(state)
}

/// A handler that panicked (a bug): 500 JSON, the panic logged; the server carries on.
fn panic_response(err: Box<dyn std::any::Any + Send + 'static>) -> Response {
    let what = err
        .downcast_ref::<String>()
        .cloned()
        .or_else(|| err.downcast_ref::<&str>().map(|s| s.to_string()))
        .unwrap_or_default();
    ApiError::internal(format!("handler panicked: {what}")).into_response()
}

async fn not_found(req: Request) -> ApiError {
    ApiError::NotFound(format!("no route {} {}", req.method(), req.uri().path()))
}

async fn method_not_allowed() -> ApiError {
    ApiError::MethodNotAllowed
}

/// For `/api/*` (except `/api/health`) and `/metrics`: finds the caller (auth.rs) from
/// `Authorization: Bearer TOKEN`, or `?token=TOKEN` where a header cannot be set (EventSource,
/// `<img src>`): 401 when a token is needed and missing or unknown, 403 for a viewer's
/// non-GET request; handlers check job ownership. The web viewer's static files stay open.
async fn authenticate(State(st): State<AppState>, mut req: Request, next: Next) -> Response {
    let path = req.uri().path();
    let protected = (path.starts_with("/api/") || path == "/metrics") && path != "/api/health";
    if !protected {
        return next.run(req).await;
    }
    let from_header = req
        .headers()
        .get(header::AUTHORIZATION)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.strip_prefix("Bearer "))
        .map(|t| t.trim().to_string());
    let from_query = || {
        Query::<HashMap<String, String>>::try_from_uri(req.uri())
            .ok()
            .and_then(|q| q.0.get("token").cloned())
    };
    let given = from_header.or_else(from_query);
    let caller = match auth::resolve(&st.config, &st.store, given.as_deref()) {
        Ok(c) => c,
        Err(e) => return e.into_response(),
    };
    let reads = matches!(*req.method(), Method::GET | Method::HEAD);
    if !reads {
        if let Err(e) = caller.may_write() {
            return e.into_response();
        }
    }
    req.extensions_mut().insert(caller);
    next.run(req).await
}
