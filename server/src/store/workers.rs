//! The workers of a farm as they last reported: every render loop (a `candela worker` device
//! thread, a rendering `candela serve`) writes its figures — device, passes, samples, samples/s
//! over the last heartbeat, the jobs it holds and for how long — with each lease heartbeat, so
//! that any API server's `GET /api/workers`, `/metrics` and the viewer's farm table show every
//! worker of the store. With each report goes the worker's memory ([`WorkerMemory`]: its
//! process's resident size and its kernel variants), in columns of their own. A worker is `running` while its last report is younger than its lease,
//! `stopped` after a clean shutdown, else `lost` (killed, hung or cut off); a day after its last
//! report it is forgotten.

use serde_json::Value;

use super::db::params;
use super::{Store, StoreError};
use crate::jobs::model::now_s;

/// Reports older than this are deleted (by the next report of any worker).
const FORGET_S: f64 = 86_400.0;

/// A worker's memory as it last reported it (None: not known, e.g. a worker older than the
/// columns, or no /proc).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct WorkerMemory {
    /// Resident bytes of the worker's process (shared by the device threads of one process).
    pub rss_bytes: Option<u64>,
    /// Compiled kernel variants (pipelines) its device keeps (at most `--cache-pipelines`).
    pub pipelines_cached: Option<u64>,
    /// Distinct kernel variants its process has compiled since it started.
    pub kernel_variants_seen: Option<u64>,
}

/// A worker's last report.
#[derive(Debug, Clone)]
pub struct WorkerRecord {
    pub name: String,
    /// Unix seconds of the last report.
    pub seen_at: f64,
    /// `running`, `stopped` or `lost`.
    pub state: &'static str,
    /// The figures the worker reported (worker/report.rs).
    pub report: Value,
    pub memory: WorkerMemory,
}

/// A column value as a count.
fn count(v: Option<i64>) -> Option<u64> {
    v.and_then(|v| u64::try_from(v).ok())
}

/// A count as a column value (NULL when unknown or out of range).
fn column(v: Option<u64>) -> Option<i64> {
    v.and_then(|v| i64::try_from(v).ok())
}

impl Store {
    /// Records `name`'s report and memory (`stopped`: its last, at a clean shutdown).
    pub fn report_worker(
        &self,
        name: &str,
        lease_s: f64,
        stopped: bool,
        report: &Value,
        memory: &WorkerMemory,
    ) -> Result<(), StoreError> {
        let text = report.to_string();
        self.read(|c| {
            c.exec(
                "INSERT INTO workers (name, seen_at, lease_s, stopped, report, rss_bytes, \
                 pipelines_cached, kernel_variants_seen) \
                 VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8) ON CONFLICT (name) DO UPDATE SET \
                 seen_at = excluded.seen_at, lease_s = excluded.lease_s, \
                 stopped = excluded.stopped, report = excluded.report, \
                 rss_bytes = excluded.rss_bytes, pipelines_cached = excluded.pipelines_cached, \
                 kernel_variants_seen = excluded.kernel_variants_seen",
                params![
                    name,
                    now_s(),
                    lease_s,
                    stopped as i64,
                    text,
                    column(memory.rss_bytes),
                    column(memory.pipelines_cached),
                    column(memory.kernel_variants_seen),
                ],
            )?;
            // Workers gone for a day (every restart has a new `HOST:PID`) are forgotten.
            c.exec(
                "DELETE FROM workers WHERE seen_at < ?1",
                params![now_s() - FORGET_S],
            )
        })?;
        Ok(())
    }

    /// Every worker that reported within `keep_s` seconds, by name.
    pub fn list_workers(&self, keep_s: f64) -> Result<Vec<WorkerRecord>, StoreError> {
        let now = now_s();
        let rows = self.read(|c| {
            c.query(
                "SELECT name, seen_at, lease_s, stopped, report, rss_bytes, pipelines_cached, \
                 kernel_variants_seen FROM workers \
                 WHERE seen_at >= ?1 ORDER BY name",
                params![now - keep_s],
            )
        })?;
        rows.iter()
            .map(|r| {
                let (seen_at, lease_s) = (r.f64(1)?, r.f64(2)?);
                let state = if r.i64(3)? != 0 {
                    "stopped"
                } else if now - seen_at <= lease_s {
                    "running"
                } else {
                    "lost"
                };
                Ok(WorkerRecord {
                    name: r.text(0)?,
                    seen_at,
                    state,
                    report: serde_json::from_str(&r.text(4)?).unwrap_or(Value::Null),
                    memory: WorkerMemory {
                        rss_bytes: count(r.opt_i64(5)?),
                        pipelines_cached: count(r.opt_i64(6)?),
                        kernel_variants_seen: count(r.opt_i64(7)?),
                    },
                })
            })
            .collect()
    }
}
