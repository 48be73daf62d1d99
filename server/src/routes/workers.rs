//! The farm's workers (store/workers.rs): `GET /api/workers` (each worker's last report: name,
//! state — running, stopped or lost —, device, passes, samples, samples/s, held jobs with their
//! lease age, `kept_shard_bytes` (finished shards' sums its process keeps for their merge), and
//! its memory: `rss_bytes`, `pipelines_cached`, `kernel_variants_seen`, null where unknown), and
//! the per-worker series of `/metrics`. Workers that last reported more than
//! an hour ago are left out.

use std::fmt::Write;

use axum::extract::State;
use axum::Json;
use serde_json::{json, Value};

use crate::api_error::ApiError;
use crate::state::AppState;
use crate::store::{Store, StoreError, WorkerRecord};

/// How long a worker stays listed after its last report.
const KEEP_S: f64 = 3600.0;

/// `GET /api/workers`.
pub async fn list(State(st): State<AppState>) -> Result<Json<Value>, ApiError> {
    let workers: Vec<Value> = st
        .store
        .list_workers(KEEP_S)?
        .into_iter()
        .map(|w| {
            let mut v = w.report;
            v["name"] = json!(w.name);
            v["state"] = json!(w.state);
            v["seen_at"] = json!(w.seen_at);
            v["rss_bytes"] = json!(w.memory.rss_bytes);
            v["pipelines_cached"] = json!(w.memory.pipelines_cached);
            v["kernel_variants_seen"] = json!(w.memory.kernel_variants_seen);
            v
        })
        .collect();
    Ok(Json(json!({ "workers": workers })))
}

/// A per-worker series: name, type, help, and its value from a worker's report (None: the
/// worker has no such figure, and no line).
type Series = (
    &'static str,
    &'static str,
    &'static str,
    fn(&WorkerRecord) -> Option<f64>,
);

/// A Prometheus label value, escaped.
fn label(v: &str) -> String {
    v.replace('\\', "\\\\")
        .replace('"', "\\\"")
        .replace('\n', "\\n")
}

/// The per-worker series of `/metrics`.
pub fn prometheus(store: &Store) -> Result<String, StoreError> {
    let workers: Vec<WorkerRecord> = store.list_workers(KEEP_S)?;
    let mut out = String::new();
    let series: [Series; 8] = [
        (
            "candela_worker_up",
            "gauge",
            "1 while the worker reports within its lease.",
            |w| Some((w.state == "running") as u8 as f64),
        ),
        (
            "candela_worker_samples_per_second",
            "gauge",
            "Pixel samples per second over the worker's last heartbeat.",
            |w| Some(w.report["samples_per_s"].as_f64().unwrap_or(0.0)),
        ),
        (
            "candela_worker_samples_total",
            "counter",
            "Pixel samples the worker rendered since it started.",
            |w| Some(w.report["samples"].as_f64().unwrap_or(0.0)),
        ),
        (
            "candela_worker_passes_total",
            "counter",
            "Render passes the worker completed since it started.",
            |w| Some(w.report["passes"].as_f64().unwrap_or(0.0)),
        ),
        (
            "candela_worker_rss_bytes",
            "gauge",
            "Resident memory of the worker's process at its last heartbeat.",
            |w| w.memory.rss_bytes.map(|v| v as f64),
        ),
        (
            "candela_worker_pipelines_cached",
            "gauge",
            "Compiled kernel variants (pipelines) the worker's device keeps.",
            |w| w.memory.pipelines_cached.map(|v| v as f64),
        ),
        (
            "candela_worker_kept_shard_bytes",
            "gauge",
            "Bytes of finished shards' sums the worker's process keeps for their merge.",
            |w| w.report["kept_shard_bytes"].as_f64(),
        ),
        (
            "candela_worker_kernel_variants_seen_total",
            "counter",
            "Distinct kernel variants the worker's process compiled since it started.",
            |w| w.memory.kernel_variants_seen.map(|v| v as f64),
        ),
    ];
    for (name, kind, help, value) in series {
        let _ = writeln!(out, "# HELP {name} {help}\n# TYPE {name} {kind}");
        for w in &workers {
            let Some(v) = value(w) else { continue };
            let device = w.report["device"].as_str().unwrap_or("");
            let _ = writeln!(
                out,
                "{name}{{worker=\"{}\",device=\"{}\"}} {v}",
                label(&w.name),
                label(device),
            );
        }
    }
    let name = "candela_worker_lease_age_seconds";
    let _ = writeln!(
        out,
        "# HELP {name} Seconds since the worker claimed each job it holds.\n# TYPE {name} gauge"
    );
    for w in workers.iter().filter(|w| w.state == "running") {
        for j in w.report["jobs"].as_array().into_iter().flatten() {
            let _ = writeln!(
                out,
                "{name}{{worker=\"{}\",job=\"{}\"}} {:.3}",
                label(&w.name),
                j["job"],
                j["lease_age_s"].as_f64().unwrap_or(0.0)
            );
        }
    }
    Ok(out)
}
