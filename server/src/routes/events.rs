//! `GET /api/jobs/{id}/events`: Server-Sent Events of one job — `state`, `progress`,
//! `snapshot`, `auto`, `warning`, `done`, `error` — each with its id (the per-job sequence
//! number of the event log). Subscribes to the live broadcast *before* reading the log, so
//! nothing falls between the replay and the live events; duplicates are dropped by id.
//!
//! With `Last-Event-ID: N` every stored event after N is replayed; without it, the log is
//! replayed compacted (state changes, plus only the latest `progress` and `snapshot`). The
//! stream ends after `done`, `error` or the `canceled` state, and at shutdown; keep-alive
//! comments flow in between.

use std::convert::Infallible;
use std::sync::atomic::Ordering;
use std::sync::Arc;

use axum::extract::State;
use axum::http::HeaderMap;
use axum::response::sse::{Event, KeepAlive, Sse};
use axum::response::IntoResponse;
use tokio::sync::broadcast::error::RecvError;
use tokio::sync::mpsc;
use tokio_stream::wrappers::ReceiverStream;

use super::extract::JobIdPath;
use crate::api_error::ApiError;
use crate::shared::Shared;
use crate::state::AppState;
use crate::store::StoredEvent;

/// Counts an open stream in the metrics while alive.
struct ClientGuard(Arc<Shared>);

impl Drop for ClientGuard {
    fn drop(&mut self) {
        self.0.sse_clients.fetch_sub(1, Ordering::Relaxed);
    }
}

fn sse_event(e: &StoredEvent) -> Event {
    Event::default()
        .id(e.seq.to_string())
        .event(e.kind.clone())
        .data(e.data.to_string())
}

/// Keeps the last `progress` and `snapshot` events and every other one.
fn compact(events: Vec<StoredEvent>) -> Vec<StoredEvent> {
    let last = |kind: &str| events.iter().rev().find(|e| e.kind == kind).map(|e| e.seq);
    let (progress, snapshot) = (last("progress"), last("snapshot"));
    events
        .into_iter()
        .filter(|e| match e.kind.as_str() {
            "progress" => Some(e.seq) == progress,
            "snapshot" => Some(e.seq) == snapshot,
            _ => true,
        })
        .collect()
}

/// The SSE handler.
pub async fn stream(
    State(st): State<AppState>,
    JobIdPath(id): JobIdPath,
    headers: HeaderMap,
) -> Result<impl IntoResponse, ApiError> {
    let resume_from = match headers.get("last-event-id") {
        None => None,
        Some(v) => Some(
            v.to_str()
                .ok()
                .and_then(|s| s.trim().parse::<i64>().ok())
                .filter(|n| *n >= 0)
                .ok_or_else(|| {
                    ApiError::bad_request("Last-Event-ID: expected an event id (an integer)")
                })?,
        ),
    };
    // Subscribe first, then read the log: every event is in one or the other (or both).
    let mut live = st.store.subscribe();
    let rec = st.store.get_job(id)?;
    let replay = st.store.events_after(id, resume_from.unwrap_or(0))?;
    let replay = if resume_from.is_some() {
        replay
    } else {
        compact(replay)
    };
    let ended = rec.state.is_terminal();

    let (tx, rx) = mpsc::channel::<Result<Event, Infallible>>(64);
    st.shared.sse_clients.fetch_add(1, Ordering::Relaxed);
    let guard = ClientGuard(st.shared.clone());
    let (store, mut shutdown) = (st.store.clone(), st.shutdown.clone());
    tokio::spawn(async move {
        let _guard = guard;
        let mut last = resume_from.unwrap_or(0);
        // Step 1: what the client missed.
        for e in &replay {
            if tx.send(Ok(sse_event(e))).await.is_err() {
                return;
            }
            last = e.seq;
            if e.is_final() {
                return;
            }
        }
        if ended || *shutdown.borrow() {
            return;
        }
        // Step 2: live events, deduplicated by id; the log again if we fell behind.
        loop {
            tokio::select! {
                _ = tx.closed() => return,
                _ = shutdown.changed() => return,
                r = live.recv() => {
                    let batch = match r {
                        Ok(e) if e.job_id == id && e.seq > last => vec![e],
                        Ok(_) => continue,
                        Err(RecvError::Lagged(_)) => match store.events_after(id, last) {
                            Ok(v) => v,
                            Err(_) => return,
                        },
                        Err(RecvError::Closed) => return,
                    };
                    for e in batch {
                        if tx.send(Ok(sse_event(&e))).await.is_err() {
                            return;
                        }
                        last = e.seq;
                        if e.is_final() {
                            return;
                        }
                    }
                }
            }
        }
    });
    Ok(Sse::new(ReceiverStream::new(rx)).keep_alive(
        KeepAlive::new()
            .interval(st.config.sse_keepalive)
            .text("keep-alive"),
    ))
}
