//! Jobs in the store: insert, read, list, count, and the state transitions, each of which
//! appends its `state` event (plus any `done`/`error` event) in the same transaction.

use std::collections::BTreeMap;

use renderer::render::Progress;
use rusqlite::{params, OptionalExtension, Row};
use serde_json::{json, Value};

use super::events::append_in;
use super::{Store, StoreError};
use crate::jobs::model::{now_s, JobId, JobRecord, JobState, NewJob, SceneSource};

/// A state change and what comes with it.
#[derive(Debug, Default)]
pub struct Transition {
    /// The verb for the 409 message ("pause", "resume", "cancel", ...).
    pub verb: &'static str,
    pub error: Option<String>,
    pub stats: Option<Value>,
    pub progress: Option<Progress>,
    /// Events appended after the `state` event: (kind, data).
    pub extra_events: Vec<(&'static str, Value)>,
    /// Why the change happened, given as the `state` event's `reason`.
    pub reason: Option<String>,
    /// The server holds the job paused for `reason` (a storage fault): stored in `hold`. Every
    /// other transition clears the hold.
    pub hold: bool,
    /// Who asked for the change (a user's name), recorded in the `state` event as `by`.
    pub by: Option<String>,
}

pub(super) const COLUMNS: &str =
    "id, name, state, priority, settings, scene_name, source, progress, stats, \
                       error, created_at, started_at, finished_at, updated_at, owner, hold";

fn bad_column(i: usize, what: &str) -> rusqlite::Error {
    rusqlite::Error::FromSqlConversionFailure(
        i,
        rusqlite::types::Type::Text,
        format!("bad {what} in the store").into(),
    )
}

pub(super) fn record(r: &Row<'_>) -> rusqlite::Result<JobRecord> {
    let state: String = r.get(2)?;
    let settings: String = r.get(4)?;
    let source: String = r.get(6)?;
    let progress: Option<String> = r.get(7)?;
    let stats: Option<String> = r.get(8)?;
    Ok(JobRecord {
        id: r.get(0)?,
        name: r.get(1)?,
        state: JobState::parse(&state).ok_or_else(|| bad_column(2, "state"))?,
        priority: r.get(3)?,
        settings: serde_json::from_str(&settings).map_err(|_| bad_column(4, "settings"))?,
        scene_name: r.get(5)?,
        source: SceneSource::parse(&source).ok_or_else(|| bad_column(6, "source"))?,
        progress: progress.and_then(|p| serde_json::from_str(&p).ok()),
        stats: stats.and_then(|s| serde_json::from_str(&s).ok()),
        error: r.get(9)?,
        created_at: r.get(10)?,
        started_at: r.get(11)?,
        finished_at: r.get(12)?,
        updated_at: r.get(13)?,
        owner: r.get(14)?,
        hold: r.get(15)?,
    })
}

impl Store {
    /// Inserts a queued job with its first `state` event. `before_commit` runs inside the
    /// transaction with the new id (e.g. to move uploaded assets into place); if it fails,
    /// nothing is inserted.
    pub fn insert_job(
        &self,
        job: &NewJob,
        before_commit: impl FnOnce(JobId) -> Result<(), String>,
    ) -> Result<JobRecord, StoreError> {
        let mut conn = self.conn();
        let tx = conn.transaction()?;
        let now = now_s();
        let settings =
            serde_json::to_string(&job.settings).map_err(|e| StoreError::Db(e.to_string()))?;
        tx.execute(
            "INSERT INTO jobs (name, state, priority, settings, scene, scene_name, source, \
             created_at, updated_at, owner) VALUES (?1, 'queued', ?2, ?3, ?4, ?5, ?6, ?7, ?7, ?8)",
            params![
                job.name,
                job.priority,
                settings,
                job.scene,
                job.scene_name,
                job.source.as_str(),
                now,
                job.owner,
            ],
        )?;
        let id = tx.last_insert_rowid();
        let mut data = json!({"state": "queued", "previous": null});
        if let Some(by) = &job.owner {
            data["by"] = json!(by);
        }
        let event = append_in(&tx, id, "state", &data)?;
        before_commit(id).map_err(StoreError::Db)?;
        let rec = tx.query_row(
            &format!("SELECT {COLUMNS} FROM jobs WHERE id = ?1"),
            params![id],
            record,
        )?;
        tx.commit()?;
        self.broadcast(vec![event]);
        Ok(rec)
    }

    /// One job.
    pub fn get_job(&self, id: JobId) -> Result<JobRecord, StoreError> {
        let conn = self.conn();
        conn.query_row(
            &format!("SELECT {COLUMNS} FROM jobs WHERE id = ?1"),
            params![id],
            record,
        )
        .optional()?
        .ok_or(StoreError::NotFound(id))
    }

    /// A job's scene JSON text.
    pub fn get_scene(&self, id: JobId) -> Result<String, StoreError> {
        let conn = self.conn();
        conn.query_row("SELECT scene FROM jobs WHERE id = ?1", params![id], |r| {
            r.get(0)
        })
        .optional()?
        .ok_or(StoreError::NotFound(id))
    }

    /// All jobs (optionally in one state), newest first, at most `limit`.
    pub fn list_jobs(
        &self,
        state: Option<JobState>,
        limit: usize,
    ) -> Result<Vec<JobRecord>, StoreError> {
        let conn = self.conn();
        let limit = limit.min(i64::MAX as usize) as i64;
        let rows = match state {
            Some(s) => {
                let mut stmt = conn.prepare_cached(&format!(
                    "SELECT {COLUMNS} FROM jobs WHERE state = ?1 ORDER BY id DESC LIMIT ?2"
                ))?;
                let v = stmt
                    .query_map(params![s.as_str(), limit], record)?
                    .collect::<Result<Vec<_>, _>>()?;
                v
            }
            None => {
                let mut stmt = conn.prepare_cached(&format!(
                    "SELECT {COLUMNS} FROM jobs ORDER BY id DESC LIMIT ?1"
                ))?;
                let v = stmt
                    .query_map(params![limit], record)?
                    .collect::<Result<Vec<_>, _>>()?;
                v
            }
        };
        Ok(rows)
    }

    /// Number of jobs in each state (every state present, zero when none).
    pub fn count_by_state(&self) -> Result<BTreeMap<JobState, u64>, StoreError> {
        let conn = self.conn();
        let mut out: BTreeMap<JobState, u64> = JobState::ALL.iter().map(|s| (*s, 0)).collect();
        let mut stmt = conn.prepare_cached("SELECT state, COUNT(*) FROM jobs GROUP BY state")?;
        let rows = stmt.query_map([], |r| Ok((r.get::<_, String>(0)?, r.get::<_, i64>(1)?)))?;
        for row in rows {
            let (state, n) = row?;
            if let Some(s) = JobState::parse(&state) {
                out.insert(s, n.max(0) as u64);
            }
        }
        Ok(out)
    }

    /// Queued and running jobs with their priority: running first (they hold renders in
    /// progress), then by priority (highest first), then oldest first.
    pub fn runnable_jobs(&self) -> Result<Vec<(JobId, JobState, u32)>, StoreError> {
        let conn = self.conn();
        let mut stmt = conn.prepare_cached(
            "SELECT id, state, priority FROM jobs WHERE state IN ('queued', 'running') \
             ORDER BY state = 'running' DESC, priority DESC, id ASC",
        )?;
        let rows = stmt.query_map([], |r| {
            let state: String = r.get(1)?;
            Ok((
                r.get(0)?,
                JobState::parse(&state).unwrap_or(JobState::Queued),
                r.get(2)?,
            ))
        })?;
        Ok(rows.collect::<Result<Vec<_>, _>>()?)
    }

    /// Moves job `id` to `to` if its current state allows it; appends the `state` event and
    /// `t.extra_events`; returns the updated job.
    pub fn transition(
        &self,
        id: JobId,
        to: JobState,
        t: Transition,
    ) -> Result<JobRecord, StoreError> {
        let mut conn = self.conn();
        let tx = conn.transaction()?;
        let state: Option<String> = tx
            .query_row("SELECT state FROM jobs WHERE id = ?1", params![id], |r| {
                r.get(0)
            })
            .optional()?;
        let from = state
            .as_deref()
            .and_then(JobState::parse)
            .ok_or(StoreError::NotFound(id))?;
        if !from.can_become(to) {
            return Err(StoreError::Conflict {
                state: from,
                message: format!(
                    "cannot {} job {id}: it is {}",
                    if t.verb.is_empty() { "change" } else { t.verb },
                    from.as_str()
                ),
            });
        }
        let now = now_s();
        tx.execute(
            "UPDATE jobs SET state = ?2, updated_at = ?3, \
             started_at = CASE WHEN ?2 = 'running' AND started_at IS NULL THEN ?3 ELSE started_at END, \
             finished_at = CASE WHEN ?2 IN ('done', 'failed', 'canceled') THEN ?3 ELSE finished_at END, \
             error = COALESCE(?4, error), stats = COALESCE(?5, stats), \
             progress = COALESCE(?6, progress), hold = ?7 WHERE id = ?1",
            params![
                id,
                to.as_str(),
                now,
                t.error,
                t.stats.as_ref().map(|s| s.to_string()),
                t.progress.as_ref().and_then(|p| serde_json::to_string(p).ok()),
                t.reason.as_ref().filter(|_| t.hold),
            ],
        )?;
        let mut data = json!({"state": to.as_str(), "previous": from.as_str()});
        if let Some(reason) = &t.reason {
            data["reason"] = json!(reason);
        }
        if let Some(by) = &t.by {
            data["by"] = json!(by);
        }
        let mut events = vec![append_in(&tx, id, "state", &data)?];
        for (kind, data) in &t.extra_events {
            events.push(append_in(&tx, id, kind, data)?);
        }
        let rec = tx.query_row(
            &format!("SELECT {COLUMNS} FROM jobs WHERE id = ?1"),
            params![id],
            record,
        )?;
        tx.commit()?;
        self.broadcast(events);
        Ok(rec)
    }

    /// Paused jobs the server holds for a storage fault (`hold` set).
    pub fn held_jobs(&self) -> Result<Vec<JobId>, StoreError> {
        let conn = self.conn();
        let mut stmt =
            conn.prepare_cached("SELECT id FROM jobs WHERE state = 'paused' AND hold IS NOT NULL")?;
        let rows = stmt.query_map([], |r| r.get(0))?;
        Ok(rows.collect::<Result<Vec<_>, _>>()?)
    }

    /// Changes a job's priority (any non-terminal state); appends a `priority` event saying who
    /// (`by`) changed it from what.
    pub fn set_priority(
        &self,
        id: JobId,
        priority: u32,
        by: Option<&str>,
    ) -> Result<JobRecord, StoreError> {
        let mut conn = self.conn();
        let conn = conn.transaction()?;
        let state: Option<String> = conn
            .query_row("SELECT state FROM jobs WHERE id = ?1", params![id], |r| {
                r.get(0)
            })
            .optional()?;
        let state = state
            .as_deref()
            .and_then(JobState::parse)
            .ok_or(StoreError::NotFound(id))?;
        if state.is_terminal() {
            return Err(StoreError::Conflict {
                state,
                message: format!(
                    "cannot change the priority of job {id}: it is {}",
                    state.as_str()
                ),
            });
        }
        let previous: u32 = conn.query_row(
            "SELECT priority FROM jobs WHERE id = ?1",
            params![id],
            |r| r.get(0),
        )?;
        conn.execute(
            "UPDATE jobs SET priority = ?2, updated_at = ?3 WHERE id = ?1",
            params![id, priority, now_s()],
        )?;
        let mut data = json!({"priority": priority, "previous": previous});
        if let Some(by) = by {
            data["by"] = json!(by);
        }
        let event = append_in(&conn, id, "priority", &data)?;
        let rec = conn.query_row(
            &format!("SELECT {COLUMNS} FROM jobs WHERE id = ?1"),
            params![id],
            record,
        )?;
        conn.commit()?;
        self.broadcast(vec![event]);
        Ok(rec)
    }

    /// Records a job's progress counters.
    pub fn set_progress(&self, id: JobId, progress: &Progress) -> Result<(), StoreError> {
        let conn = self.conn();
        let p = serde_json::to_string(progress).map_err(|e| StoreError::Db(e.to_string()))?;
        conn.execute(
            "UPDATE jobs SET progress = ?2, updated_at = ?3 WHERE id = ?1",
            params![id, p, now_s()],
        )?;
        Ok(())
    }
}
