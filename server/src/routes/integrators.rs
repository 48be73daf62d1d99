//! `GET /api/integrators`: the integrator registry (name, summary, unbiased, pass kernel,
//! documentation page, options with their types and meaning) and the default, as the web
//! viewer's form and API clients read them.

use axum::Json;
use renderer::integrators::{IntegratorInfo, DEFAULT_INTEGRATOR, INTEGRATORS};
use serde::Serialize;

/// The answer.
#[derive(Serialize)]
pub struct Catalog {
    pub default: &'static str,
    pub integrators: &'static [IntegratorInfo],
}

/// The catalogue.
pub async fn list() -> Json<Catalog> {
    Json(Catalog {
        default: DEFAULT_INTEGRATOR,
        integrators: INTEGRATORS,
    })
}
