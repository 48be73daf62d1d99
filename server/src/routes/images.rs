//! `GET /api/jobs/{id}/image.png?exposure=EV&tonemap=clamp|reinhard|aces` and `image.exr`: the
//! latest snapshot of a job (in memory while it renders; from `<data>/jobs/<id>/image.exr`
//! once checkpointed, paused or ended), 404 before the first. Any `spp` parameter is only a
//! cache-buster. The `X-Candela-Spp` header gives the image's sample count.

use std::sync::Arc;

use axum::extract::State;
use axum::http::header;
use axum::response::{IntoResponse, Response};

use super::extract::{JobIdPath, QueryMap};
use crate::api_error::ApiError;
use crate::jobs::model::{JobId, JobRecord};
use crate::jobs::request::parse_tonemap;
use crate::shared::Snapshot;
use crate::state::AppState;
use crate::store::JobPaths;

/// The latest image of a job: the in-memory snapshot, else the one on disk.
async fn latest(st: &AppState, id: JobId) -> Result<(JobRecord, Arc<Snapshot>), ApiError> {
    let rec = st.store.get_job(id)?;
    if let Some(s) = st.shared.snapshot(id) {
        return Ok((rec, s));
    }
    let path = JobPaths::new(&st.config.data_dir, id).image();
    let spp = rec.progress.map(|p| p.spp).unwrap_or(0);
    let image = tokio::task::spawn_blocking(move || {
        let bytes = std::fs::read(&path).ok()?;
        let image = renderer::film::decode_exr(&bytes).ok()?;
        Some((image, bytes))
    })
    .await
    .map_err(ApiError::internal)?;
    let (image, bytes) = image.ok_or_else(|| {
        ApiError::NotFound(format!(
            "job {id} has no image yet (state {})",
            rec.state.as_str()
        ))
    })?;
    let snap = Snapshot::new(image, spp);
    *snap.exr.lock().unwrap_or_else(|p| p.into_inner()) = Some(bytes);
    Ok((rec, Arc::new(snap)))
}

fn image_response(
    content_type: &'static str,
    id: JobId,
    ext: &str,
    spp: u32,
    body: Vec<u8>,
) -> Response {
    (
        [
            (header::CONTENT_TYPE, content_type.to_string()),
            (header::CACHE_CONTROL, "no-cache".to_string()),
            (
                header::CONTENT_DISPOSITION,
                format!("inline; filename=\"job-{id}.{ext}\""),
            ),
            (
                header::HeaderName::from_static("x-candela-spp"),
                spp.to_string(),
            ),
        ],
        body,
    )
        .into_response()
}

/// `image.png`: tonemapped sRGB.
pub async fn png(
    State(st): State<AppState>,
    JobIdPath(id): JobIdPath,
    QueryMap(q): QueryMap,
) -> Result<Response, ApiError> {
    // Step 1: display parameters (the job's defaults unless given).
    let exposure = match q.get("exposure") {
        None => None,
        Some(e) => Some(
            e.parse::<f32>()
                .ok()
                .filter(|v| v.is_finite() && v.abs() <= 64.0)
                .ok_or_else(|| {
                    ApiError::bad_request(format!(
                        "exposure: expected a number of EV in [-64, 64], got \"{e}\""
                    ))
                })?,
        ),
    };
    let tonemap_name = match q.get("tonemap") {
        None => None,
        Some(t) => {
            parse_tonemap(t).ok_or_else(|| {
                ApiError::bad_request(format!(
                    "tonemap: expected clamp, reinhard or aces, got \"{t}\""
                ))
            })?;
            Some(t.clone())
        }
    };
    // Step 2: the image, encoded (cached per snapshot for the last parameters asked).
    let (rec, snap) = latest(&st, id).await?;
    let exposure = exposure.unwrap_or(rec.settings.exposure);
    let tonemap_name = tonemap_name.unwrap_or(rec.settings.tonemap.clone());
    let tonemap = parse_tonemap(&tonemap_name).unwrap_or(renderer::scene::Tonemap::Clamp);
    let key = (exposure.to_bits(), tonemap_name);
    let spp = snap.spp;
    let bytes = tokio::task::spawn_blocking(move || {
        let mut cache = snap.png.lock().unwrap_or_else(|p| p.into_inner());
        if let Some((k, bytes)) = cache.as_ref() {
            if *k == key {
                return Ok(bytes.clone());
            }
        }
        let bytes = renderer::film::encode_png(&snap.image, exposure, tonemap)?;
        *cache = Some((key, bytes.clone()));
        Ok::<_, renderer::film::FilmError>(bytes)
    })
    .await
    .map_err(ApiError::internal)?
    .map_err(ApiError::internal)?;
    Ok(image_response("image/png", id, "png", spp, bytes))
}

/// `image.exr`: linear radiance, float32 RGB.
pub async fn exr(
    State(st): State<AppState>,
    JobIdPath(id): JobIdPath,
) -> Result<Response, ApiError> {
    let (_, snap) = latest(&st, id).await?;
    let spp = snap.spp;
    let bytes = tokio::task::spawn_blocking(move || {
        let mut cache = snap.exr.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(bytes) = cache.as_ref() {
            return Ok(bytes.clone());
        }
        let bytes = renderer::film::encode_exr(&snap.image)?;
        *cache = Some(bytes.clone());
        Ok::<_, renderer::film::FilmError>(bytes)
    })
    .await
    .map_err(ApiError::internal)?
    .map_err(ApiError::internal)?;
    Ok(image_response("image/x-exr", id, "exr", spp, bytes))
}
