//! `GET /api/integrators`: the integrator registry (name, summary, unbiased, pass kernel,
//! documentation page, options with their types and meaning), the default, and `auto` (the
//! choice by a pilot, which jobs accept as `"integrator": "auto"`), as the web viewer's form and
//! API clients read them.

use axum::Json;
use renderer::integrators::{IntegratorInfo, DEFAULT_INTEGRATOR, INTEGRATORS};
use serde::Serialize;

/// The answer.
#[derive(Serialize)]
pub struct Catalog {
    pub default: &'static str,
    pub integrators: &'static [IntegratorInfo],
    pub auto: AutoEntry,
}

/// `auto` (renderer::auto): not an integrator of the registry but a choice among its unbiased
/// ones; it takes no options.
#[derive(Serialize)]
pub struct AutoEntry {
    pub name: &'static str,
    pub summary: &'static str,
    pub doc: &'static str,
    pub candidates: Vec<&'static str>,
}

/// The catalogue.
pub async fn list() -> Json<Catalog> {
    Json(Catalog {
        default: DEFAULT_INTEGRATOR,
        integrators: INTEGRATORS,
        auto: AutoEntry {
            name: renderer::auto::AUTO,
            summary: renderer::auto::AUTO_SUMMARY,
            doc: "docs/error-estimate.md",
            candidates: renderer::auto::candidates(),
        },
    })
}
