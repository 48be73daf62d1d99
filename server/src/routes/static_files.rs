//! The web viewer: `web/index.html`, `style.css` and the JavaScript modules (`app.js`, the entry
//! module, imports the others), embedded in the binary at build time (no build step, no files
//! to deploy) and served at `/`.

use axum::http::header;
use axum::response::IntoResponse;
use axum::routing::get;
use axum::Router;

use crate::state::AppState;

const INDEX: &str = include_str!("../../../web/index.html");
const STYLE: &str = include_str!("../../../web/style.css");

/// The viewer's JavaScript modules: (URL path, source).
const SCRIPTS: &[(&str, &str)] = &[
    ("/app.js", include_str!("../../../web/app.js")),
    ("/util.js", include_str!("../../../web/util.js")),
    ("/api.js", include_str!("../../../web/api.js")),
    ("/state.js", include_str!("../../../web/state.js")),
    ("/images.js", include_str!("../../../web/images.js")),
    ("/form.js", include_str!("../../../web/form.js")),
    ("/jobs.js", include_str!("../../../web/jobs.js")),
    ("/viewer.js", include_str!("../../../web/viewer.js")),
    ("/chart.js", include_str!("../../../web/chart.js")),
    ("/ab.js", include_str!("../../../web/ab.js")),
    ("/farm.js", include_str!("../../../web/farm.js")),
];

fn file(content_type: &'static str, body: &'static str) -> impl IntoResponse {
    (
        [
            (header::CONTENT_TYPE, content_type),
            (header::CACHE_CONTROL, "no-cache"),
        ],
        body,
    )
}

/// Routes of the static files.
pub fn router() -> Router<AppState> {
    let mut r = Router::new()
        .route(
            "/",
            get(|| async { file("text/html; charset=utf-8", INDEX) }),
        )
        .route(
            "/index.html",
            get(|| async { file("text/html; charset=utf-8", INDEX) }),
        )
        .route(
            "/style.css",
            get(|| async { file("text/css; charset=utf-8", STYLE) }),
        );
    for &(path, body) in SCRIPTS {
        r = r.route(
            path,
            get(move || async move { file("text/javascript; charset=utf-8", body) }),
        );
    }
    r
}
