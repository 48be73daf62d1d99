//! What retention needs from the store: the finished jobs oldest first, deleting one job's record
//! and events, pruning the event logs of finished jobs down to what states their end, and whether
//! a file (a reference image) is still named by some job. The files themselves are removed by
//! `crate::retention`, after the record.

use rusqlite::{params, OptionalExtension};

use super::jobs::{record, COLUMNS};
use super::{Store, StoreError};
use crate::jobs::model::{JobId, JobRecord, JobState};

/// The event kinds a finished job's log keeps in full; of the others (`progress`, `snapshot`)
/// only the last of each kind is kept (the final figures, the final image's link).
const PRUNED_KINDS: &str = "'progress', 'snapshot'";

impl Store {
    /// Finished (done, failed, canceled) jobs, oldest finish first.
    pub fn finished_jobs(&self) -> Result<Vec<JobRecord>, StoreError> {
        let conn = self.conn();
        let mut stmt = conn.prepare_cached(&format!(
            "SELECT {COLUMNS} FROM jobs WHERE state IN ('done', 'failed', 'canceled') \
             ORDER BY COALESCE(finished_at, updated_at) ASC, id ASC"
        ))?;
        let rows = stmt.query_map([], record)?;
        Ok(rows.collect::<Result<Vec<_>, _>>()?)
    }

    /// Every job id in the store.
    pub fn job_ids(&self) -> Result<Vec<JobId>, StoreError> {
        let conn = self.conn();
        let mut stmt = conn.prepare_cached("SELECT id FROM jobs")?;
        let rows = stmt.query_map([], |r| r.get(0))?;
        Ok(rows.collect::<Result<Vec<_>, _>>()?)
    }

    /// Deletes a finished job's record and events; returns the record. 409 (Conflict) for an
    /// unfinished job: it must be canceled first.
    pub fn delete_job(&self, id: JobId) -> Result<JobRecord, StoreError> {
        let mut conn = self.conn();
        let tx = conn.transaction()?;
        let rec = tx
            .query_row(
                &format!("SELECT {COLUMNS} FROM jobs WHERE id = ?1"),
                params![id],
                record,
            )
            .optional()?
            .ok_or(StoreError::NotFound(id))?;
        if !rec.state.is_terminal() {
            return Err(StoreError::Conflict {
                state: rec.state,
                message: format!(
                    "cannot delete job {id}: it is {}; cancel it first (POST /api/jobs/{id}/cancel)",
                    rec.state.as_str()
                ),
            });
        }
        tx.execute("DELETE FROM events WHERE job_id = ?1", params![id])?;
        tx.execute("DELETE FROM jobs WHERE id = ?1", params![id])?;
        tx.commit()?;
        Ok(rec)
    }

    /// Prunes the event logs of jobs that finished before `before` (Unix seconds): every
    /// `progress` and `snapshot` event but the last of each kind goes; `state`, `done`, `error`
    /// and `warning` events stay. Returns the number of events removed (with `dry_run`, that
    /// would be removed).
    pub fn prune_events(&self, before: f64, dry_run: bool) -> Result<u64, StoreError> {
        let conn = self.conn();
        let filter = format!(
            "FROM events WHERE kind IN ({PRUNED_KINDS}) \
             AND job_id IN (SELECT id FROM jobs WHERE state IN ('done', 'failed', 'canceled') \
                            AND COALESCE(finished_at, updated_at) < ?1) \
             AND seq < (SELECT MAX(e.seq) FROM events e \
                        WHERE e.job_id = events.job_id AND e.kind = events.kind)"
        );
        let n = if dry_run {
            conn.query_row(&format!("SELECT COUNT(*) {filter}"), params![before], |r| {
                r.get::<_, i64>(0)
            })?
            .max(0) as usize
        } else {
            conn.execute(&format!("DELETE {filter}"), params![before])?
        };
        Ok(n as u64)
    }

    /// Whether any job's settings name `path` (a reference image kept under the data dir).
    pub fn file_in_use(&self, path: &str) -> Result<bool, StoreError> {
        let conn = self.conn();
        let needle = serde_json::to_string(path).map_err(|e| StoreError::Db(e.to_string()))?;
        let n: i64 = conn.query_row(
            "SELECT COUNT(*) FROM jobs WHERE instr(settings, ?1) > 0",
            params![needle],
            |r| r.get(0),
        )?;
        Ok(n > 0)
    }

    /// The state of a job, if it exists.
    pub fn job_state(&self, id: JobId) -> Result<Option<JobState>, StoreError> {
        let conn = self.conn();
        let s: Option<String> = conn
            .query_row("SELECT state FROM jobs WHERE id = ?1", params![id], |r| {
                r.get(0)
            })
            .optional()?;
        Ok(s.as_deref().and_then(JobState::parse))
    }
}
