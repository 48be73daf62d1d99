//! `/api/jobs`: submit (JSON or multipart upload, optionally waiting for the end), list, get,
//! cancel, pause, resume, reprioritise (`PATCH`) and delete (`DELETE`, a finished job with its
//! files). Who may do what is auth.rs's (a submitter manages only its own jobs); every change
//! records who made it (`by` in the job's events). State changes go through the
//! store's transition table (409 on an invalid one) and wake the GPU worker.

use std::collections::HashMap;

use axum::body::Bytes;
use axum::extract::{FromRequest, Multipart, Request, State};
use axum::http::{header, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::Json;
use serde::Deserialize;
use serde_json::{json, Value};
use tokio::sync::broadcast::error::RecvError;

use super::extract::{JobIdPath, QueryMap};
use crate::api_error::ApiError;
use crate::auth::Caller;
use crate::jobs::model::{JobId, JobRecord, JobState, NewJob, MAX_PRIORITY};
use crate::jobs::request::{
    parse_object, parse_request, prepare, JobRequest, ReferenceSpec, SceneInput,
};
use crate::jobs::upload::{read_multipart, Upload};
use crate::state::AppState;
use crate::store::{JobPaths, Transition};

/// A boolean query parameter: true/1/yes, false/0/no/empty.
pub fn query_bool(q: &HashMap<String, String>, name: &str) -> Result<bool, ApiError> {
    match q.get(name).map(|s| s.to_ascii_lowercase()) {
        None => Ok(false),
        Some(v) => match v.as_str() {
            "" | "true" | "1" | "yes" => Ok(true),
            "false" | "0" | "no" => Ok(false),
            _ => Err(ApiError::bad_request(format!(
                "{name}: expected true or false, got \"{v}\""
            ))),
        },
    }
}

fn body_error(status: StatusCode, text: String, limit: usize) -> ApiError {
    if status == StatusCode::PAYLOAD_TOO_LARGE {
        ApiError::PayloadTooLarge(format!(
            "the request body is larger than this server's limit of {limit} bytes"
        ))
    } else {
        ApiError::bad_request(format!("reading the body: {text}"))
    }
}

/// Resolves a request's `reference` (`{"job": ID}`: that done job's image; `{"file": NAME}`:
/// an uploaded EXR) to an EXR path kept under `<data>/references`, checked against the film size.
fn resolve_reference(
    store: &crate::store::Store,
    data_dir: &std::path::Path,
    upload: Option<&std::path::Path>,
    reference: Option<ReferenceSpec>,
    settings: &crate::jobs::model::JobSettings,
) -> Result<Option<String>, ApiError> {
    let Some(reference) = reference else {
        return Ok(None);
    };
    let malformed = || {
        ApiError::invalid(
            "reference",
            "reference: expected {\"job\": ID} or {\"file\": \"NAME.exr\"}",
        )
    };
    let source = match (reference.job, reference.file) {
        _ if !reference.other.is_empty() => return Err(malformed()),
        (Some(id), None) => {
            let rec = store.get_job(id).map_err(|_| {
                ApiError::invalid("reference.job", format!("reference.job: no job {id}"))
            })?;
            if rec.state != JobState::Done {
                return Err(ApiError::invalid(
                    "reference.job",
                    format!(
                        "reference.job: job {id} is {}, not done",
                        rec.state.as_str()
                    ),
                ));
            }
            JobPaths::new(data_dir, id).image()
        }
        (None, Some(name)) => upload
            .map(|b| b.join(&name))
            .filter(|p| !name.is_empty() && !name.contains("..") && p.is_file())
            .ok_or_else(|| {
                ApiError::invalid(
                    "reference.file",
                    format!("reference.file: no uploaded file \"{name}\""),
                )
            })?,
        _ => return Err(malformed()),
    };
    let image = renderer::film::read_exr(&source).map_err(|e| {
        ApiError::invalid("reference", format!("reference: reading the image: {e}"))
    })?;
    if (image.width, image.height) != (settings.width, settings.height) {
        return Err(ApiError::invalid(
            "reference",
            format!(
                "reference: the image is {}x{}, the job's film is {}x{}",
                image.width, image.height, settings.width, settings.height
            ),
        ));
    }
    // A copy of its own, so the reference outlives the upload and later changes to its source.
    let dir = data_dir.join("references");
    std::fs::create_dir_all(&dir).map_err(ApiError::internal)?;
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos())
        .unwrap_or(0);
    let dest = dir.join(format!("{nanos}.exr"));
    std::fs::copy(&source, &dest).map_err(ApiError::internal)?;
    Ok(Some(dest.to_string_lossy().into_owned()))
}

/// `POST /api/jobs[?wait=true]`: 201 with the job (after it ended, with `wait`).
pub async fn create(
    State(st): State<AppState>,
    caller: Caller,
    QueryMap(q): QueryMap,
    req: Request,
) -> Result<Response, ApiError> {
    caller.may_write()?;
    let wait = query_bool(&q, "wait")?;
    if st.shutting_down() {
        return Err(ApiError::Unavailable("the server is shutting down".into()));
    }
    // Step 1: room in the queue and on the disk.
    check_room(&st)?;
    check_space(&st)?;
    // Step 2: the request, JSON or multipart, checked and its scene loaded.
    let (mut new_job, upload) = read_job(&st, req).await?;
    new_job.owner = caller.name.clone();
    // Step 3: store it (moving uploaded assets into the job's folder) and wake the worker.
    let rec = store_job(&st, new_job, upload).await?;
    // Step 4: with `wait`, answer once it has ended.
    let rec = if wait {
        let rec = wait_for_end(&st, rec.id).await?;
        if !rec.state.is_terminal() {
            return Err(ApiError::Unavailable(format!(
                "the server is shutting down before job {} ended; it resumes at the next start (GET /api/jobs/{})",
                rec.id, rec.id
            )));
        }
        rec
    } else {
        rec
    };
    let location = format!("/api/jobs/{}", rec.id);
    Ok((
        StatusCode::CREATED,
        [(header::LOCATION, location)],
        Json(rec.to_json()),
    )
        .into_response())
}

/// 429 when the unfinished jobs (queued, running, paused) already reach the server's limit.
fn check_room(st: &AppState) -> Result<(), ApiError> {
    let limit = st.config.limits.max_unfinished_jobs;
    let unfinished: u64 = st
        .store
        .count_by_state()?
        .iter()
        .filter(|(s, _)| s.is_unfinished())
        .map(|(_, n)| n)
        .sum();
    if unfinished >= limit {
        return Err(ApiError::TooManyJobs(format!(
            "{unfinished} jobs are unfinished (queued, running or paused); this server accepts at most {limit}: retry when some have ended"
        )));
    }
    Ok(())
}

/// 507 while the data directory's filesystem has less free space than `--min-free-space`.
fn check_space(st: &AppState) -> Result<(), ApiError> {
    let dir = &st.config.data_dir;
    let min = st.config.min_free_space;
    let free = crate::storage::free_bytes(dir).unwrap_or(u64::MAX);
    st.shared.update_free_space(free, free < min);
    if free < min {
        use crate::units::format_bytes;
        return Err(ApiError::InsufficientStorage(format!(
            "the data directory {} has {} ({free} bytes) free, below this server's minimum of {} ({min} bytes, --min-free-space): free some space or delete finished jobs (DELETE /api/jobs/ID, candela gc)",
            dir.display(),
            format_bytes(free),
            format_bytes(min),
        )));
    }
    Ok(())
}

/// Reads the request (a JSON body, or multipart with the scene and its assets) into the job to
/// insert, its scene loaded and checked, and the unpacked upload, if any.
async fn read_job(st: &AppState, req: Request) -> Result<(NewJob, Option<Upload>), ApiError> {
    let limits = &st.config.limits;
    let is_multipart = req
        .headers()
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|ct| ct.starts_with("multipart/form-data"));
    if !is_multipart {
        let body = Bytes::from_request(req, st)
            .await
            .map_err(|e| body_error(e.status(), e.body_text(), limits.max_body_bytes))?;
        let mut job = parse_request(&body)?;
        let reference = job.reference.take();
        let new = checked_job(st, job, SceneInput::InRequest, reference, None).await?;
        return Ok((new, None));
    }
    let mp = Multipart::from_request(req, st)
        .await
        .map_err(|e| ApiError::bad_request(format!("upload: {}", e.body_text())))?;
    let mut up = read_multipart(mp, limits, &st.config.tmp_dir()).await?;
    let input = SceneInput::Uploaded {
        json: up.scene_json.clone(),
        dir: up.base.clone(),
    };
    let mut job = std::mem::take(&mut up.job);
    // `reference` in the job part, or else a part named `reference` holding an EXR.
    let reference = job.reference.take().or_else(|| {
        up.base.join("reference").is_file().then(|| ReferenceSpec {
            file: Some("reference".into()),
            ..Default::default()
        })
    });
    let new = checked_job(st, job, input, reference, Some(up.base.clone())).await?;
    Ok((new, Some(up)))
}

/// The request checked and its scene loaded (off the async threads: it reads files), with its
/// reference resolved.
async fn checked_job(
    st: &AppState,
    job: JobRequest,
    input: SceneInput,
    reference: Option<ReferenceSpec>,
    upload_dir: Option<std::path::PathBuf>,
) -> Result<NewJob, ApiError> {
    let (builtin, cfg, store) = (st.config.builtin_dir(), st.config.clone(), st.store.clone());
    tokio::task::spawn_blocking(move || {
        let mut new = prepare(job, input, &cfg.limits, &builtin)?;
        new.settings.reference = resolve_reference(
            &store,
            &cfg.data_dir,
            upload_dir.as_deref(),
            reference,
            &new.settings,
        )?;
        Ok::<_, ApiError>(new)
    })
    .await
    .map_err(ApiError::internal)?
}

/// Inserts the job, moving an upload's assets into its folder, and wakes the worker.
async fn store_job(
    st: &AppState,
    new_job: NewJob,
    upload: Option<Upload>,
) -> Result<JobRecord, ApiError> {
    let data_dir = st.config.data_dir.clone();
    let store = st.store.clone();
    let import_warnings = upload
        .as_ref()
        .map(|u| u.warnings.clone())
        .unwrap_or_default();
    let rec = tokio::task::spawn_blocking(move || {
        let r = store.insert_job(&new_job, |id| {
            if let Some(up) = &upload {
                let dest = JobPaths::new(&data_dir, id).assets();
                if let Some(parent) = dest.parent() {
                    std::fs::create_dir_all(parent).map_err(|e| e.to_string())?;
                }
                let _ = std::fs::remove_dir_all(&dest);
                std::fs::rename(&up.base, &dest).map_err(|e| e.to_string())?;
            }
            Ok(())
        });
        drop(upload);
        r
    })
    .await
    .map_err(ApiError::internal)??;
    for w in &import_warnings {
        let _ = st
            .store
            .append_event(rec.id, "warning", json!({"message": w}));
    }
    st.shared
        .jobs_submitted
        .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    tracing::info!(job = rec.id, name = %rec.name, "job submitted");
    st.worker.wake();
    Ok(rec)
}

/// Waits until job `id` is done, failed or canceled (or the server shuts down).
async fn wait_for_end(st: &AppState, id: JobId) -> Result<JobRecord, ApiError> {
    let mut live = st.store.subscribe();
    let mut shutdown = st.shutdown.clone();
    loop {
        let rec = st.store.get_job(id)?;
        if rec.state.is_terminal() || *shutdown.borrow() {
            return Ok(rec);
        }
        loop {
            tokio::select! {
                r = live.recv() => match r {
                    Ok(e) if e.job_id == id && e.is_final() => break,
                    Ok(_) => continue,
                    Err(RecvError::Lagged(_)) => break,
                    Err(RecvError::Closed) => return Ok(st.store.get_job(id)?),
                },
                _ = shutdown.changed() => break,
            }
        }
    }
}

/// `GET /api/jobs[?state=queued,running][&limit=N]`: newest first.
pub async fn list(
    State(st): State<AppState>,
    QueryMap(q): QueryMap,
) -> Result<Json<Value>, ApiError> {
    let mut states = Vec::new();
    if let Some(s) = q.get("state") {
        for name in s.split(',').map(str::trim).filter(|n| !n.is_empty()) {
            states.push(JobState::parse(name).ok_or_else(|| {
                ApiError::bad_request(format!(
                    "state: unknown \"{name}\" (queued, running, paused, done, failed or canceled)"
                ))
            })?);
        }
    }
    let limit = match q.get("limit") {
        None => 1000,
        Some(l) => l.parse::<usize>().ok().filter(|n| *n > 0).ok_or_else(|| {
            ApiError::bad_request(format!("limit: expected a positive integer, got \"{l}\""))
        })?,
    };
    let mut jobs = Vec::new();
    if states.is_empty() {
        jobs = st.store.list_jobs(None, limit)?;
    } else {
        for s in states {
            jobs.extend(st.store.list_jobs(Some(s), limit)?);
        }
        jobs.sort_by_key(|j| std::cmp::Reverse(j.id));
        jobs.truncate(limit);
    }
    let jobs: Vec<Value> = jobs.iter().map(JobRecord::to_json).collect();
    Ok(Json(json!({ "jobs": jobs })))
}

/// `GET /api/jobs/{id}`.
pub async fn get_one(
    State(st): State<AppState>,
    JobIdPath(id): JobIdPath,
) -> Result<Json<Value>, ApiError> {
    let rec = st.store.get_job(id)?;
    let mut v = rec.to_json();
    if rec.settings.reference.is_some() {
        if let Some(m) = st.store.latest_metrics(id)? {
            v["progress"]["metrics"] = m;
        }
    }
    Ok(Json(v))
}

async fn change_state(
    st: &AppState,
    caller: &Caller,
    id: JobId,
    to: JobState,
    verb: &'static str,
) -> Result<Json<Value>, ApiError> {
    caller.may_manage(&st.store.get_job(id)?)?;
    let t = Transition {
        verb,
        by: caller.name.clone(),
        ..Default::default()
    };
    let rec = st.store.transition(id, to, t)?;
    tracing::info!(job = id, state = to.as_str(), "job {verb}");
    if to == JobState::Canceled {
        // A paused job's checkpoints (its own, or its shards') are of no more use (an active
        // one's are removed by the worker).
        let shards = st.store.shards(id).map_or(0, |s| s.len() as u32);
        JobPaths::new(&st.config.data_dir, id).remove_checkpoints(shards);
    }
    st.worker.wake();
    Ok(Json(rec.to_json()))
}

/// `POST /api/jobs/{id}/cancel`: queued, running or paused → canceled (409 once it has ended).
pub async fn cancel(
    State(st): State<AppState>,
    caller: Caller,
    JobIdPath(id): JobIdPath,
) -> Result<Json<Value>, ApiError> {
    change_state(&st, &caller, id, JobState::Canceled, "cancel").await
}

/// `DELETE /api/jobs/{id}`: removes a finished job (done, failed, canceled): its record, events
/// and files (204); an unfinished one is 409 (cancel it first).
pub async fn remove(
    State(st): State<AppState>,
    caller: Caller,
    JobIdPath(id): JobIdPath,
) -> Result<StatusCode, ApiError> {
    caller.may_manage(&st.store.get_job(id)?)?;
    let (store, data_dir) = (st.store.clone(), st.config.data_dir.clone());
    let (rec, bytes) =
        tokio::task::spawn_blocking(move || crate::retention::remove_job(&store, &data_dir, id))
            .await
            .map_err(ApiError::internal)??;
    st.shared.forget(id);
    // The job's events go with it: who deleted it is in the server's log.
    let by = caller.name.as_deref().unwrap_or("-");
    tracing::info!(
        job = id,
        state = rec.state.as_str(),
        bytes,
        by,
        "job deleted"
    );
    Ok(StatusCode::NO_CONTENT)
}

/// `POST /api/jobs/{id}/pause`: queued or running → paused (checkpointed).
pub async fn pause(
    State(st): State<AppState>,
    caller: Caller,
    JobIdPath(id): JobIdPath,
) -> Result<Json<Value>, ApiError> {
    change_state(&st, &caller, id, JobState::Paused, "pause").await
}

/// `POST /api/jobs/{id}/resume`: paused → queued.
pub async fn resume(
    State(st): State<AppState>,
    caller: Caller,
    JobIdPath(id): JobIdPath,
) -> Result<Json<Value>, ApiError> {
    change_state(&st, &caller, id, JobState::Queued, "resume").await
}

/// The fields `PATCH` accepts.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct JobPatch {
    priority: Option<u32>,
}

/// `PATCH /api/jobs/{id}` with `{"priority": P}`.
pub async fn patch(
    State(st): State<AppState>,
    caller: Caller,
    JobIdPath(id): JobIdPath,
    body: Result<Bytes, axum::extract::rejection::BytesRejection>,
) -> Result<Json<Value>, ApiError> {
    let body =
        body.map_err(|e| body_error(e.status(), e.body_text(), st.config.limits.max_body_bytes))?;
    let p: JobPatch = parse_object(&body)?;
    let priority = p.priority.ok_or_else(|| {
        ApiError::invalid(
            "priority",
            "priority: missing (the only field PATCH changes)",
        )
    })?;
    if !(1..=MAX_PRIORITY).contains(&priority) {
        return Err(ApiError::invalid(
            "priority",
            format!("priority: must be in 1..={MAX_PRIORITY}, got {priority}"),
        ));
    }
    caller.may_manage(&st.store.get_job(id)?)?;
    let rec = st
        .store
        .set_priority(id, priority, caller.name.as_deref())?;
    st.worker.wake();
    Ok(Json(rec.to_json()))
}
