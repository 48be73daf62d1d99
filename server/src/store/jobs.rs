//! Jobs in the store: insert, read, list, count, and the state transitions, each of which
//! appends its `state` event (plus any `done`/`error` event) in the same transaction.

use std::collections::BTreeMap;

use renderer::render::Progress;
use serde_json::{json, Value};

use super::db::{params, Conn, Row};
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

fn bad_column(what: &str) -> StoreError {
    StoreError::Db(format!("bad {what} in the store"))
}

/// A job from a row of [`COLUMNS`].
pub(super) fn record(r: &Row) -> Result<JobRecord, StoreError> {
    let progress = r.opt_text(7)?;
    let stats = r.opt_text(8)?;
    Ok(JobRecord {
        id: r.i64(0)?,
        name: r.text(1)?,
        state: JobState::parse(&r.text(2)?).ok_or_else(|| bad_column("state"))?,
        priority: u32::try_from(r.i64(3)?).map_err(|_| bad_column("priority"))?,
        settings: serde_json::from_str(&r.text(4)?).map_err(|_| bad_column("settings"))?,
        scene_name: r.opt_text(5)?,
        source: SceneSource::parse(&r.text(6)?).ok_or_else(|| bad_column("source"))?,
        progress: progress.and_then(|p| serde_json::from_str(&p).ok()),
        stats: stats.and_then(|s| serde_json::from_str(&s).ok()),
        error: r.opt_text(9)?,
        created_at: r.f64(10)?,
        started_at: r.opt_f64(11)?,
        finished_at: r.opt_f64(12)?,
        updated_at: r.f64(13)?,
        owner: r.opt_text(14)?,
        hold: r.opt_text(15)?,
    })
}

/// Job `id`'s record, read in `c`.
pub(super) fn get_in(c: &mut dyn Conn, id: JobId) -> Result<JobRecord, StoreError> {
    let row = c.query_opt(
        &format!("SELECT {COLUMNS} FROM jobs WHERE id = ?1"),
        params![id],
    )?;
    record(&row.ok_or(StoreError::NotFound(id))?)
}

/// Job `id`'s state, read in `c` (locking the row on PostgreSQL).
fn state_for_update(c: &mut dyn Conn, id: JobId) -> Result<JobState, StoreError> {
    let sql = format!(
        "SELECT state FROM jobs WHERE id = ?1{}",
        c.dialect().for_update()
    );
    let row = c.query_opt(&sql, params![id])?;
    let state = row.map(|r| r.text(0)).transpose()?;
    state
        .as_deref()
        .and_then(JobState::parse)
        .ok_or(StoreError::NotFound(id))
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
        let now = now_s();
        let settings =
            serde_json::to_string(&job.settings).map_err(|e| StoreError::Db(e.to_string()))?;
        self.write(|c| {
            let id = c
                .query_one(
                    "INSERT INTO jobs (name, state, priority, settings, scene, scene_name, \
                     source, created_at, updated_at, owner) \
                     VALUES (?1, 'queued', ?2, ?3, ?4, ?5, ?6, ?7, ?7, ?8) RETURNING id",
                    params![
                        job.name.as_str(),
                        job.priority,
                        settings,
                        job.scene.as_str(),
                        job.scene_name.as_deref(),
                        job.source.as_str(),
                        now,
                        job.owner.as_deref(),
                    ],
                )?
                .i64(0)?;
            let mut data = json!({"state": "queued", "previous": null});
            if let Some(by) = &job.owner {
                data["by"] = json!(by);
            }
            let event = append_in(c, id, "state", &data)?;
            before_commit(id).map_err(StoreError::Db)?;
            Ok((get_in(c, id)?, vec![event]))
        })
    }

    /// One job.
    pub fn get_job(&self, id: JobId) -> Result<JobRecord, StoreError> {
        self.read(|c| get_in(c, id))
    }

    /// A job's scene JSON text.
    pub fn get_scene(&self, id: JobId) -> Result<String, StoreError> {
        self.read(|c| {
            c.query_opt("SELECT scene FROM jobs WHERE id = ?1", params![id])?
                .ok_or(StoreError::NotFound(id))?
                .text(0)
        })
    }

    /// All jobs (optionally in one state), newest first, at most `limit`.
    pub fn list_jobs(
        &self,
        state: Option<JobState>,
        limit: usize,
    ) -> Result<Vec<JobRecord>, StoreError> {
        let limit = limit.min(i64::MAX as usize) as i64;
        let rows = self.read(|c| match state {
            Some(s) => c.query(
                &format!("SELECT {COLUMNS} FROM jobs WHERE state = ?1 ORDER BY id DESC LIMIT ?2"),
                params![s.as_str(), limit],
            ),
            None => c.query(
                &format!("SELECT {COLUMNS} FROM jobs ORDER BY id DESC LIMIT ?1"),
                params![limit],
            ),
        })?;
        rows.iter().map(record).collect()
    }

    /// Number of jobs in each state (every state present, zero when none).
    pub fn count_by_state(&self) -> Result<BTreeMap<JobState, u64>, StoreError> {
        let mut out: BTreeMap<JobState, u64> = JobState::ALL.iter().map(|s| (*s, 0)).collect();
        let rows =
            self.read(|c| c.query("SELECT state, COUNT(*) FROM jobs GROUP BY state", &[]))?;
        for row in rows {
            if let Some(s) = JobState::parse(&row.text(0)?) {
                out.insert(s, row.i64(1)?.max(0) as u64);
            }
        }
        Ok(out)
    }

    /// Queued and running jobs with their priority: running first (they hold renders in
    /// progress), then by priority (highest first), then oldest first.
    pub fn runnable_jobs(&self) -> Result<Vec<(JobId, JobState, u32)>, StoreError> {
        let rows = self.read(|c| {
            c.query(
                "SELECT id, state, priority FROM jobs WHERE state IN ('queued', 'running') \
                 ORDER BY state = 'running' DESC, priority DESC, id ASC",
                &[],
            )
        })?;
        rows.iter()
            .map(|r| {
                Ok((
                    r.i64(0)?,
                    JobState::parse(&r.text(1)?).unwrap_or(JobState::Queued),
                    u32::try_from(r.i64(2)?).map_err(|_| bad_column("priority"))?,
                ))
            })
            .collect()
    }

    /// Moves job `id` to `to` if its current state allows it; appends the `state` event and
    /// `t.extra_events`; returns the updated job.
    pub fn transition(
        &self,
        id: JobId,
        to: JobState,
        t: Transition,
    ) -> Result<JobRecord, StoreError> {
        self.write(|c| {
            let from = state_for_update(c, id)?;
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
            c.exec(
                "UPDATE jobs SET state = ?2, updated_at = ?3, \
                 started_at = CASE WHEN ?2 = 'running' AND started_at IS NULL THEN ?3 ELSE started_at END, \
                 finished_at = CASE WHEN ?2 IN ('done', 'failed', 'canceled') THEN ?3 ELSE finished_at END, \
                 error = COALESCE(?4, error), stats = COALESCE(?5, stats), \
                 progress = COALESCE(?6, progress), hold = ?7 WHERE id = ?1",
                params![
                    id,
                    to.as_str(),
                    now,
                    t.error.as_deref(),
                    t.stats.as_ref().map(|s| s.to_string()),
                    t.progress.as_ref().and_then(|p| serde_json::to_string(p).ok()),
                    t.reason.as_deref().filter(|_| t.hold),
                ],
            )?;
            let mut data = json!({"state": to.as_str(), "previous": from.as_str()});
            if let Some(reason) = &t.reason {
                data["reason"] = json!(reason);
            }
            if let Some(by) = &t.by {
                data["by"] = json!(by);
            }
            let mut events = vec![append_in(c, id, "state", &data)?];
            for (kind, data) in &t.extra_events {
                events.push(append_in(c, id, kind, data)?);
            }
            Ok((get_in(c, id)?, events))
        })
    }

    /// Paused jobs the server holds for a storage fault (`hold` set).
    pub fn held_jobs(&self) -> Result<Vec<JobId>, StoreError> {
        let rows = self.read(|c| {
            c.query(
                "SELECT id FROM jobs WHERE state = 'paused' AND hold IS NOT NULL",
                &[],
            )
        })?;
        rows.iter().map(|r| r.i64(0)).collect()
    }

    /// Changes a job's priority (any non-terminal state); appends a `priority` event saying who
    /// (`by`) changed it from what.
    pub fn set_priority(
        &self,
        id: JobId,
        priority: u32,
        by: Option<&str>,
    ) -> Result<JobRecord, StoreError> {
        self.write(|c| {
            let state = state_for_update(c, id)?;
            if state.is_terminal() {
                return Err(StoreError::Conflict {
                    state,
                    message: format!(
                        "cannot change the priority of job {id}: it is {}",
                        state.as_str()
                    ),
                });
            }
            let previous = c
                .query_one("SELECT priority FROM jobs WHERE id = ?1", params![id])?
                .i64(0)?;
            c.exec(
                "UPDATE jobs SET priority = ?2, updated_at = ?3 WHERE id = ?1",
                params![id, priority, now_s()],
            )?;
            let mut data = json!({"priority": priority, "previous": previous});
            if let Some(by) = by {
                data["by"] = json!(by);
            }
            let event = append_in(c, id, "priority", &data)?;
            Ok((get_in(c, id)?, vec![event]))
        })
    }

    /// Records a job's progress counters.
    pub fn set_progress(&self, id: JobId, progress: &Progress) -> Result<(), StoreError> {
        let p = serde_json::to_string(progress).map_err(|e| StoreError::Db(e.to_string()))?;
        self.read(|c| {
            c.exec(
                "UPDATE jobs SET progress = ?2, updated_at = ?3 WHERE id = ?1",
                params![id, p, now_s()],
            )
        })?;
        Ok(())
    }
}
