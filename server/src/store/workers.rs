//! The workers of a farm as they last reported: every render loop (a `candela worker` device
//! thread, a rendering `candela serve`) writes its figures — device, passes, samples, samples/s
//! over the last heartbeat, the jobs it holds and for how long — with each lease heartbeat, so
//! that any API server's `GET /api/workers`, `/metrics` and the viewer's farm table show every
//! worker of the store. A worker is `running` while its last report is younger than its lease,
//! `stopped` after a clean shutdown, else `lost` (killed, hung or cut off); a day after its last
//! report it is forgotten.

use serde_json::Value;

use super::db::params;
use super::{Store, StoreError};
use crate::jobs::model::now_s;

/// Reports older than this are deleted (by the next report of any worker).
const FORGET_S: f64 = 86_400.0;

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
}

impl Store {
    /// Records `name`'s report (`stopped`: its last, at a clean shutdown).
    pub fn report_worker(
        &self,
        name: &str,
        lease_s: f64,
        stopped: bool,
        report: &Value,
    ) -> Result<(), StoreError> {
        let text = report.to_string();
        self.read(|c| {
            c.exec(
                "INSERT INTO workers (name, seen_at, lease_s, stopped, report) \
                 VALUES (?1, ?2, ?3, ?4, ?5) ON CONFLICT (name) DO UPDATE SET \
                 seen_at = excluded.seen_at, lease_s = excluded.lease_s, \
                 stopped = excluded.stopped, report = excluded.report",
                params![name, now_s(), lease_s, stopped as i64, text],
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
                "SELECT name, seen_at, lease_s, stopped, report FROM workers \
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
                })
            })
            .collect()
    }
}
