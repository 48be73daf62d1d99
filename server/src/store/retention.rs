//! What retention needs from the store: the finished jobs oldest first, deleting one job's record
//! and events, pruning the event logs of finished jobs down to what states their end, and whether
//! a file (a reference image) is still named by some job. The files themselves are removed by
//! `crate::retention`, after the record.

use super::db::params;
use super::jobs::{record, COLUMNS};
use super::{Store, StoreError};
use crate::jobs::model::{JobId, JobRecord, JobState};

/// The event kinds a finished job's log keeps in full; of the others (`progress`, `snapshot`)
/// only the last of each kind is kept (the final figures, the final image's link).
const PRUNED_KINDS: &str = "'progress', 'snapshot'";

impl Store {
    /// Finished (done, failed, canceled) jobs, oldest finish first.
    pub fn finished_jobs(&self) -> Result<Vec<JobRecord>, StoreError> {
        let rows = self.read(|c| {
            c.query(
                &format!(
                    "SELECT {COLUMNS} FROM jobs WHERE state IN ('done', 'failed', 'canceled') \
                     ORDER BY COALESCE(finished_at, updated_at) ASC, id ASC"
                ),
                &[],
            )
        })?;
        rows.iter().map(record).collect()
    }

    /// Every job id in the store.
    pub fn job_ids(&self) -> Result<Vec<JobId>, StoreError> {
        let rows = self.read(|c| c.query("SELECT id FROM jobs", &[]))?;
        rows.iter().map(|r| r.i64(0)).collect()
    }

    /// Deletes a finished job's record and events; returns the record. 409 (Conflict) for an
    /// unfinished job: it must be canceled first.
    pub fn delete_job(&self, id: JobId) -> Result<JobRecord, StoreError> {
        self.write(|c| {
            let sql = format!(
                "SELECT {COLUMNS} FROM jobs WHERE id = ?1{}",
                c.dialect().for_update()
            );
            let rec = record(&c.query_opt(&sql, params![id])?.ok_or(StoreError::NotFound(id))?)?;
            if !rec.state.is_terminal() {
                return Err(StoreError::Conflict {
                    state: rec.state,
                    message: format!(
                        "cannot delete job {id}: it is {}; cancel it first (POST /api/jobs/{id}/cancel)",
                        rec.state.as_str()
                    ),
                });
            }
            c.exec("DELETE FROM events WHERE job_id = ?1", params![id])?;
            c.exec("DELETE FROM leases WHERE job_id = ?1", params![id])?;
            c.exec("DELETE FROM shards WHERE job_id = ?1", params![id])?;
            c.exec("DELETE FROM jobs WHERE id = ?1", params![id])?;
            Ok((rec, Vec::new()))
        })
    }

    /// Prunes the event logs of jobs that finished before `before` (Unix seconds): every
    /// `progress` and `snapshot` event but the last of each kind goes; `state`, `done`, `error`
    /// and `warning` events stay. Returns the number of events removed (with `dry_run`, that
    /// would be removed).
    pub fn prune_events(&self, before: f64, dry_run: bool) -> Result<u64, StoreError> {
        let filter = format!(
            "FROM events WHERE kind IN ({PRUNED_KINDS}) \
             AND job_id IN (SELECT id FROM jobs WHERE state IN ('done', 'failed', 'canceled') \
                            AND COALESCE(finished_at, updated_at) < ?1) \
             AND seq < (SELECT MAX(e.seq) FROM events e \
                        WHERE e.job_id = events.job_id AND e.kind = events.kind)"
        );
        let n = self.read(|c| {
            if dry_run {
                Ok(
                    c.query_one(&format!("SELECT COUNT(*) {filter}"), params![before])?
                        .i64(0)?
                        .max(0) as u64,
                )
            } else {
                c.exec(&format!("DELETE {filter}"), params![before])
            }
        })?;
        Ok(n)
    }

    /// Whether any job's settings name `path` (a reference image kept under the data dir).
    pub fn file_in_use(&self, path: &str) -> Result<bool, StoreError> {
        let needle = serde_json::to_string(path).map_err(|e| StoreError::Db(e.to_string()))?;
        let n = self.read(|c| {
            let sql = format!(
                "SELECT COUNT(*) FROM jobs WHERE {}(settings, ?1) > 0",
                c.dialect().instr()
            );
            c.query_one(&sql, params![needle])?.i64(0)
        })?;
        Ok(n > 0)
    }

    /// The state of a job, if it exists.
    pub fn job_state(&self, id: JobId) -> Result<Option<JobState>, StoreError> {
        let s = self.read(|c| {
            c.query_opt("SELECT state FROM jobs WHERE id = ?1", params![id])?
                .map(|r| r.text(0))
                .transpose()
        })?;
        Ok(s.as_deref().and_then(JobState::parse))
    }
}
