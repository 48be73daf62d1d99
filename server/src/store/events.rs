//! The event log: every event a job emits (`state`, `progress`, `snapshot`, `done`, `error`) is
//! written to the `events` table with a per-job sequence number, which is the SSE event id, and
//! then broadcast to live subscribers. A client that reconnects with `Last-Event-ID: N` is sent
//! the stored events after N, then the live ones, deduplicated by id.

use serde_json::Value;

use super::db::{params, Conn};
use super::{Store, StoreError};
use crate::jobs::model::{now_s, JobId};

/// One event of one job.
#[derive(Debug, Clone)]
pub struct StoredEvent {
    pub job_id: JobId,
    /// Per-job sequence number, from 1; the SSE `id`.
    pub seq: i64,
    /// The SSE `event` name.
    pub kind: String,
    /// The SSE `data` (JSON).
    pub data: Value,
}

impl StoredEvent {
    /// Whether the stream of this job ends after this event.
    pub fn is_final(&self) -> bool {
        match self.kind.as_str() {
            "done" | "error" => true,
            "state" => self.data.get("state").and_then(Value::as_str) == Some("canceled"),
            _ => false,
        }
    }
}

/// Appends an event inside the caller's transaction and returns it.
pub(super) fn append_in(
    c: &mut dyn Conn,
    job_id: JobId,
    kind: &str,
    data: &Value,
) -> Result<StoredEvent, StoreError> {
    let seq = c
        .query_opt(
            "UPDATE jobs SET event_seq = event_seq + 1 WHERE id = ?1 RETURNING event_seq",
            params![job_id],
        )?
        .ok_or(StoreError::NotFound(job_id))?
        .i64(0)?;
    c.exec(
        "INSERT INTO events (job_id, seq, kind, data, at) VALUES (?1, ?2, ?3, ?4, ?5)",
        params![job_id, seq, kind, data.to_string(), now_s()],
    )?;
    super::notify::notify_in(c, job_id, kind)?;
    Ok(StoredEvent {
        job_id,
        seq,
        kind: kind.to_string(),
        data: data.clone(),
    })
}

impl Store {
    /// Appends one event to job `job_id`'s log and broadcasts it.
    pub fn append_event(
        &self,
        job_id: JobId,
        kind: &str,
        data: Value,
    ) -> Result<StoredEvent, StoreError> {
        self.write(|c| {
            let event = append_in(c, job_id, kind, &data)?;
            Ok((event.clone(), vec![event]))
        })
    }

    /// Broadcasts events already committed (called with the connection held).
    pub(super) fn broadcast(&self, events: Vec<StoredEvent>) {
        for e in events {
            let _ = self.events.send(e);
        }
    }

    /// Relaying (a farm, [`Store::with_event_relay`]): broadcasts every event written since
    /// the last call, by this process or another, in id order per job. Call it periodically.
    pub fn relay_new_events(&self) -> Result<(), StoreError> {
        self.relay_jobs(None)
    }

    /// Broadcasts the events of `jobs` (None: every job) not broadcast yet. Runs holding the
    /// connection and the relay's map, so broadcasts of one job never interleave out of order.
    pub(super) fn relay_jobs(&self, jobs: Option<&[JobId]>) -> Result<(), StoreError> {
        let Some(relay) = &self.relay else {
            return Ok(());
        };
        self.read(|c| {
            let mut seen = relay.lock().unwrap_or_else(|p| p.into_inner());
            // Step 1: the jobs with events past the last broadcast (`event_seq` is committed
            // with the events it numbers, so 1..=event_seq are all there).
            let heads: Vec<(JobId, i64)> = match jobs {
                Some(ids) => ids
                    .iter()
                    .filter_map(|id| {
                        c.query_opt("SELECT event_seq FROM jobs WHERE id = ?1", params![*id])
                            .ok()
                            .flatten()
                            .and_then(|r| r.i64(0).ok())
                            .map(|seq| (*id, seq))
                    })
                    .collect(),
                None => c
                    .query("SELECT id, event_seq FROM jobs", &[])?
                    .iter()
                    .filter_map(|r| Some((r.i64(0).ok()?, r.i64(1).ok()?)))
                    .collect(),
            };
            if jobs.is_none() {
                // Jobs deleted since (retention): forgotten.
                let present: std::collections::HashSet<JobId> =
                    heads.iter().map(|(id, _)| *id).collect();
                seen.retain(|id, _| present.contains(id));
            }
            // Step 2: their new events, broadcast in order.
            for (id, head) in heads {
                let last = seen.get(&id).copied().unwrap_or(0);
                if head <= last {
                    continue;
                }
                let rows = c.query(
                    "SELECT seq, kind, data FROM events WHERE job_id = ?1 AND seq > ?2 ORDER BY seq",
                    params![id, last],
                )?;
                let mut upto = last;
                for r in &rows {
                    let e = StoredEvent {
                        job_id: id,
                        seq: r.i64(0)?,
                        kind: r.text(1)?,
                        data: serde_json::from_str(&r.text(2)?).unwrap_or(Value::Null),
                    };
                    upto = upto.max(e.seq);
                    let _ = self.events.send(e);
                }
                seen.insert(id, upto.max(head));
            }
            Ok(())
        })
    }

    /// The stored events of a job with a sequence number above `after`, in order.
    pub fn events_after(&self, job_id: JobId, after: i64) -> Result<Vec<StoredEvent>, StoreError> {
        let rows = self.read(|c| {
            c.query(
                "SELECT seq, kind, data FROM events WHERE job_id = ?1 AND seq > ?2 ORDER BY seq",
                params![job_id, after],
            )
        })?;
        rows.iter()
            .map(|r| {
                Ok(StoredEvent {
                    job_id,
                    seq: r.i64(0)?,
                    kind: r.text(1)?,
                    data: serde_json::from_str(&r.text(2)?).unwrap_or(Value::Null),
                })
            })
            .collect()
    }

    /// The `metrics` of a job's latest `progress` event that has them.
    pub fn latest_metrics(&self, job_id: JobId) -> Result<Option<Value>, StoreError> {
        let data = self.read(|c| {
            c.query_opt(
                "SELECT data FROM events WHERE job_id = ?1 AND kind = 'progress' \
                 AND data LIKE '%\"metrics\"%' ORDER BY seq DESC LIMIT 1",
                params![job_id],
            )?
            .map(|r| r.text(0))
            .transpose()
        })?;
        Ok(data
            .and_then(|d| serde_json::from_str::<Value>(&d).ok())
            .and_then(|v| v.get("metrics").cloned()))
    }
}
