//! A job request (`POST /api/jobs` body, or the `job` part of an upload) parsed and checked:
//! unknown fields, ranges and the limits are 4xx errors naming the JSON path; the scene is
//! loaded once here so scene errors come back at submission (422 with the scene's JSON path)
//! rather than as a failed job.
//!
//! Defaults: integrator, spp and max_depth from the scene's `render` section (else `nee`, 256
//! spp), film size, exposure and tonemap from its `film` section, seed 0, priority 10.

use std::path::{Path, PathBuf};

use renderer::integrators::IntegratorOptions;
use renderer::prepare::PrepareError;
use renderer::scene::{SceneError, Tonemap};
use serde::Deserialize;
use serde_json::Value;

use super::model::{AccelSetting, JobSettings, SceneSource, DEFAULT_PRIORITY, MAX_PRIORITY};
use crate::api_error::ApiError;
use crate::builtin_scenes;
use crate::config::RequestLimits;
use crate::jobs::model::NewJob;

/// The fields a client may send.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JobRequest {
    /// An inline scene document.
    pub scene: Option<Value>,
    /// A built-in scene (`GET /api/scenes`).
    pub scene_name: Option<String>,
    /// `"nee"` or `{"type": "nee", "max_depth": 4}`.
    pub integrator: Option<Value>,
    pub spp: Option<u32>,
    pub time_s: Option<f64>,
    /// A quality target: `{"rel_mse": 1e-3}` stops the job once its estimated relMSE is at most
    /// that; spp or time_s is the cap.
    pub until: Option<Until>,
    pub seed: Option<u64>,
    pub priority: Option<u32>,
    pub name: Option<String>,
    pub width: Option<u32>,
    pub height: Option<u32>,
    pub exposure: Option<f32>,
    pub tonemap: Option<String>,
    /// `{"job": ID}` (a done job's image) or `{"file": NAME}` (an uploaded EXR) to compute
    /// progress metrics against.
    pub reference: Option<ReferenceSpec>,
    /// `"grid"` or `{"type": "grid", "grid_resolution": 64}` (default: the scene's
    /// `render.accel`, else `"auto"`).
    pub accel: Option<Value>,
    /// `"specialized"` (default: kernels compiled for what the scene uses) or `"generic"`.
    pub kernels: Option<renderer::compile::KernelMode>,
    /// For an uploaded scene file of another format (Mitsuba XML, glTF, pbrt, .scn): import what
    /// candela cannot express as `warning` events and skip it, instead of refusing the scene.
    pub lenient: Option<bool>,
}

/// A job's quality target (`until`).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Until {
    /// The estimated relMSE (no reference; `rel_mse_estimate` in the progress events) at which
    /// the job stops.
    pub rel_mse: f64,
}

/// A job's reference image: exactly one of `job` (a done job of the same film size) and `file`
/// (an uploaded EXR). Other fields are kept to be refused as a whole (`reference: expected ...`).
#[derive(Debug, Clone, PartialEq, Default, Deserialize)]
pub struct ReferenceSpec {
    pub job: Option<crate::jobs::model::JobId>,
    pub file: Option<String>,
    #[serde(flatten)]
    pub other: serde_json::Map<String, Value>,
}

/// Where the scene comes from besides the request's own fields.
#[derive(Debug)]
pub enum SceneInput {
    /// `scene` or `scene_name` in the request.
    InRequest,
    /// An uploaded scene file whose assets were unpacked into `dir`.
    Uploaded { json: String, dir: PathBuf },
}

/// Parses a request body; JSON syntax errors are 400, everything else 422 naming the field.
pub fn parse_request(body: &[u8]) -> Result<JobRequest, ApiError> {
    parse_object(body)
}

/// Parses a JSON object body into `T` (`deny_unknown_fields`): 400 when it is not a JSON
/// object, 422 naming the field when a field is unknown or of the wrong type.
pub fn parse_object<T: serde::de::DeserializeOwned>(body: &[u8]) -> Result<T, ApiError> {
    let value: Value = serde_json::from_slice(body).map_err(|e| ApiError::BadRequest {
        code: "invalid_json",
        message: format!("the body is not valid JSON: {e}"),
    })?;
    if !value.is_object() {
        return Err(ApiError::BadRequest {
            code: "invalid_json",
            message: "the body must be a JSON object".into(),
        });
    }
    serde_path_to_error::deserialize(value).map_err(|e| {
        let path = e.path().to_string();
        let msg = e.into_inner().to_string();
        // Unknown fields may be reported at their parent; name the field itself.
        let field = msg
            .strip_prefix("unknown field `")
            .and_then(|rest| rest.split('`').next());
        let path = match (field, path.as_str()) {
            (Some(f), ".") => f.to_string(),
            (Some(f), p) if p == f || p.ends_with(&format!(".{f}")) => p.to_string(),
            (Some(f), p) => format!("{p}.{f}"),
            (None, p) => p.to_string(),
        };
        ApiError::invalid(path.clone(), format!("{path}: {}", tidy(&msg)))
    })
}

/// serde's backticks as double quotes, location suffix dropped.
fn tidy(msg: &str) -> String {
    let msg = msg.split(" at line ").next().unwrap_or(msg);
    msg.replace('`', "\"")
}

/// A scene error as a 422 whose path is relative to the request body (`prefix` is `scene` for
/// an inline scene, empty for a scene file).
pub fn scene_error(e: &SceneError, prefix: &str) -> ApiError {
    let path = match (e.path(), prefix) {
        (Some(p), "") => Some(p.to_string()),
        (Some(p), pre) if p.starts_with('[') => Some(format!("{pre}{p}")),
        (Some(p), pre) => Some(format!("{pre}.{p}")),
        (None, "") => None,
        (None, pre) => Some(pre.to_string()),
    };
    ApiError::Unprocessable {
        code: "invalid_scene",
        message: e.to_string(),
        path,
    }
}

fn tonemap_name(t: Tonemap) -> &'static str {
    match t {
        Tonemap::Clamp => "clamp",
        Tonemap::Reinhard => "reinhard",
        Tonemap::Aces => "aces",
    }
}

/// Parses a tonemap name.
pub fn parse_tonemap(s: &str) -> Option<Tonemap> {
    match s {
        "clamp" => Some(Tonemap::Clamp),
        "reinhard" => Some(Tonemap::Reinhard),
        "aces" => Some(Tonemap::Aces),
        _ => None,
    }
}

/// The request's `integrator` (a name or `{"type", ...}`; absent: the scene's
/// `render.integrator`, else the default), resolved through the integrator registry.
fn integrator_options(
    v: Option<&Value>,
    scene_default: Option<&str>,
) -> Result<IntegratorOptions, ApiError> {
    IntegratorOptions::resolve(v.unwrap_or(&Value::Null), scene_default).map_err(|e| {
        let path = match e.path.as_str() {
            "" => "integrator".to_string(),
            "render.integrator" => "scene.render.integrator".to_string(),
            p => format!("integrator.{p}"),
        };
        let message = format!("{path}: {}", e.message);
        ApiError::invalid(path, message)
    })
}

/// The request's `accel` field: a name or `{"type", "grid_resolution"}`, checked.
fn accel_setting(v: Option<&Value>) -> Result<Option<AccelSetting>, ApiError> {
    use renderer::accel::{grid::check_resolution, parse_request};
    let setting: AccelSetting = match v {
        None | Some(Value::Null) => return Ok(None),
        Some(Value::String(name)) => AccelSetting {
            kind: name.clone(),
            grid_resolution: None,
        },
        Some(v @ Value::Object(_)) => serde_json::from_value(v.clone()).map_err(|e| {
            ApiError::invalid("accel", format!("accel: {}", tidy(&e.to_string())))
        })?,
        Some(_) => {
            return Err(ApiError::invalid(
                "accel",
                "accel: expected a name (\"grid\") or an object ({\"type\": \"grid\", \"grid_resolution\": 64})",
            ))
        }
    };
    parse_request(&setting.kind)
        .map_err(|e| ApiError::invalid("accel.type", format!("accel.type: {e}")))?;
    if let Some(r) = setting.grid_resolution {
        check_resolution(r.into()).map_err(|e| {
            ApiError::invalid(
                "accel.grid_resolution",
                format!("accel.grid_resolution: {e}"),
            )
        })?;
        if setting.kind != "grid" {
            return Err(ApiError::invalid(
                "accel.grid_resolution",
                "accel.grid_resolution: only applies to \"type\": \"grid\"",
            ));
        }
    }
    Ok(Some(setting))
}

/// Checks a request and loads its scene; returns the job to insert. Blocking (reads assets).
pub fn prepare(
    req: JobRequest,
    input: SceneInput,
    limits: &RequestLimits,
    builtin_dir: &Path,
) -> Result<NewJob, ApiError> {
    // Step 1: the scene text, its base folder, and the prefix of its paths in errors.
    let (text, base, source, prefix) = match input {
        SceneInput::Uploaded { json, dir } => {
            if req.scene.is_some() || req.scene_name.is_some() {
                return Err(ApiError::invalid(
                    "scene",
                    "scene: the scene comes from the upload; do not also give scene or scene_name",
                ));
            }
            (json, Some(dir), SceneSource::Upload, "")
        }
        SceneInput::InRequest => match (&req.scene, &req.scene_name) {
            (Some(_), Some(_)) => {
                return Err(ApiError::invalid(
                    "scene_name",
                    "scene_name: give either scene or scene_name, not both",
                ))
            }
            (Some(v), None) => {
                if !v.is_object() {
                    return Err(ApiError::invalid(
                        "scene",
                        "scene: expected a scene object (docs/scene-format.md)",
                    ));
                }
                (v.to_string(), None, SceneSource::Inline, "scene")
            }
            (None, Some(name)) => {
                let text = builtin_scenes::scene_json(name).ok_or_else(|| {
                    ApiError::invalid(
                        "scene_name",
                        format!(
                            "scene_name: no built-in scene \"{name}\" (available: {})",
                            builtin_scenes::names()
                        ),
                    )
                })?;
                (
                    text.to_string(),
                    Some(builtin_dir.to_path_buf()),
                    SceneSource::Builtin,
                    "",
                )
            }
            (None, None) => {
                return Err(ApiError::invalid(
                    "scene",
                    format!(
                        "scene: missing: give \"scene\" (a scene object) or \"scene_name\" (one of: {})",
                        builtin_scenes::names()
                    ),
                ))
            }
        },
    };
    let scene =
        renderer::scene::load_str_with_limits(&text, base.as_deref(), &limits.scene_limits())
            .map_err(|e| scene_error(&e, prefix))?;

    // Step 2: integrator (`auto`: chosen by a pilot when the job starts; until then the
    // scene's or the default) and budget.
    let auto = matches!(&req.integrator, Some(Value::String(n)) if n == renderer::auto::AUTO);
    let integrator = integrator_options(
        req.integrator.as_ref().filter(|_| !auto),
        scene.render.integrator.as_deref(),
    )?;
    let accel = accel_setting(req.accel.as_ref())?;
    let (spp, time_s) = match (req.spp, req.time_s) {
        (Some(_), Some(_)) => {
            return Err(ApiError::invalid(
                "time_s",
                "time_s: give either spp or time_s, not both",
            ))
        }
        (_, Some(t)) => {
            if !(t > 0.0 && t <= limits.max_time_s) {
                return Err(ApiError::invalid(
                    "time_s",
                    format!(
                        "time_s: must be in (0, {}] seconds, got {t}",
                        limits.max_time_s
                    ),
                ));
            }
            (None, Some(t))
        }
        (n, None) => {
            let n = n.or(scene.render.spp).unwrap_or(256);
            if n == 0 || n > limits.max_spp {
                return Err(ApiError::invalid(
                    "spp",
                    format!("spp: must be in 1..={}, got {n}", limits.max_spp),
                ));
            }
            (Some(n), None)
        }
    };

    let until_rel_mse =
        match req.until {
            Some(Until { rel_mse }) if !(rel_mse.is_finite() && rel_mse > 0.0) => {
                return Err(ApiError::invalid(
                    "until.rel_mse",
                    format!("until.rel_mse: must be a positive number, got {rel_mse}"),
                ))
            }
            Some(_) if auto => return Err(ApiError::invalid(
                "until",
                "until: not with integrator \"auto\" (its pilot shares a budget of spp or time_s)",
            )),
            Some(u) => Some(u.rel_mse),
            None => None,
        };

    // Step 3: film, display defaults, scheduling.
    let width = req.width.unwrap_or(scene.film.width);
    let height = req.height.unwrap_or(scene.film.height);
    if let Err(PrepareError::Film { field, message }) = limits.film.check(width, height) {
        let field = if field == "size" { "width" } else { field };
        return Err(ApiError::invalid(field, format!("{field}: {message}")));
    }
    let exposure = req.exposure.unwrap_or(scene.film.exposure);
    if !(exposure.is_finite() && exposure.abs() <= 64.0) {
        return Err(ApiError::invalid(
            "exposure",
            "exposure: must be in [-64, 64] EV",
        ));
    }
    let tonemap = match &req.tonemap {
        Some(t) => {
            parse_tonemap(t).ok_or_else(|| {
                ApiError::invalid(
                    "tonemap",
                    format!("tonemap: unknown \"{t}\" (clamp, reinhard or aces)"),
                )
            })?;
            t.clone()
        }
        None => tonemap_name(scene.film.tonemap).to_string(),
    };
    let priority = req.priority.unwrap_or(DEFAULT_PRIORITY);
    if !(1..=MAX_PRIORITY).contains(&priority) {
        return Err(ApiError::invalid(
            "priority",
            format!("priority: must be in 1..={MAX_PRIORITY}, got {priority}"),
        ));
    }
    let name = match req.name {
        Some(n) => check_name(&n)?,
        None => req.scene_name.clone().unwrap_or_else(|| match source {
            SceneSource::Upload => "uploaded scene".into(),
            _ => "scene".into(),
        }),
    };
    Ok(NewJob {
        name,
        priority,
        settings: JobSettings {
            integrator,
            auto,
            spp,
            time_s,
            until_rel_mse,
            seed: req.seed.unwrap_or(0),
            width,
            height,
            scene_max_depth: scene.render.max_depth,
            exposure,
            tonemap,
            reference: None,
            accel,
            kernels: req.kernels.unwrap_or_default(),
        },
        scene: text,
        scene_name: req.scene_name,
        source,
        owner: None,
    })
}

/// Checks a job's name: 1..=200 characters, no control characters.
pub fn check_name(n: &str) -> Result<String, ApiError> {
    let n = n.trim();
    if n.is_empty() || n.chars().count() > 200 || n.chars().any(char::is_control) {
        return Err(ApiError::invalid(
            "name",
            "name: must be 1 to 200 characters without control characters",
        ));
    }
    Ok(n.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_fields_are_named() {
        let e = parse_request(br#"{"scene_name": "cornell", "spp": 4, "colour": 1}"#).unwrap_err();
        match e {
            ApiError::Unprocessable { path, message, .. } => {
                assert_eq!(path.as_deref(), Some("colour"));
                assert!(message.contains("unknown field \"colour\""), "{message}");
            }
            e => panic!("{e}"),
        }
        let e = parse_request(br#"{"spp": "many"}"#).unwrap_err();
        assert!(
            matches!(e, ApiError::Unprocessable { path: Some(ref p), .. } if p == "spp"),
            "{e}"
        );
        let e = parse_request(b"{\"spp\": 4").unwrap_err();
        assert!(matches!(e, ApiError::BadRequest { .. }), "{e}");
        let e = parse_request(b"[1]").unwrap_err();
        assert!(matches!(e, ApiError::BadRequest { .. }), "{e}");
    }

    #[test]
    fn defaults_and_limits() {
        let dir = std::env::temp_dir();
        let limits = RequestLimits::default();
        let req = parse_request(br#"{"scene_name": "furnace"}"#).unwrap();
        let job = prepare(req, SceneInput::InRequest, &limits, &dir).unwrap();
        assert_eq!(job.settings.spp, Some(64));
        assert_eq!((job.settings.width, job.settings.height), (64, 64));
        assert_eq!(job.priority, DEFAULT_PRIORITY);
        let req = parse_request(br#"{"scene_name": "furnace", "spp": 0}"#).unwrap();
        let e = prepare(req, SceneInput::InRequest, &limits, &dir).unwrap_err();
        assert!(matches!(e, ApiError::Unprocessable { path: Some(ref p), .. } if p == "spp"));
        let req = parse_request(br#"{"scene": {"version": 1}}"#).unwrap();
        let e = prepare(req, SceneInput::InRequest, &limits, &dir).unwrap_err();
        assert!(
            matches!(e, ApiError::Unprocessable { code: "invalid_scene", path: Some(ref p), .. } if p.starts_with("scene")),
            "{e}"
        );
    }

    /// `accel`: a name or an object, stored with the job; bad values are 422 naming the field.
    #[test]
    fn accel_setting_is_checked_and_stored() {
        let dir = std::env::temp_dir();
        let limits = RequestLimits::default();
        let job = |body: &str| {
            prepare(
                parse_request(body.as_bytes()).unwrap(),
                SceneInput::InRequest,
                &limits,
                &dir,
            )
        };
        let j = job(r#"{"scene_name": "furnace"}"#).unwrap();
        assert_eq!(j.settings.accel, None);
        assert!(serde_json::to_value(&j.settings)
            .unwrap()
            .get("accel")
            .is_none());
        let j = job(r#"{"scene_name": "furnace", "accel": "grid"}"#).unwrap();
        assert_eq!(j.settings.accel.as_ref().unwrap().kind, "grid");
        let j =
            job(r#"{"scene_name": "furnace", "accel": {"type": "grid", "grid_resolution": 32}}"#)
                .unwrap();
        let stored = serde_json::to_value(&j.settings).unwrap();
        assert_eq!(
            stored["accel"],
            serde_json::json!({"type": "grid", "grid_resolution": 32})
        );
        let back: JobSettings = serde_json::from_value(stored).unwrap();
        assert_eq!(back, j.settings);
        for (body, path) in [
            (r#""octree""#, "accel.type"),
            (
                r#"{"type": "grid", "grid_resolution": 0}"#,
                "accel.grid_resolution",
            ),
            (
                r#"{"type": "bvh", "grid_resolution": 8}"#,
                "accel.grid_resolution",
            ),
            (r#"{"type": "grid", "cells": 8}"#, "accel"),
            ("7", "accel"),
        ] {
            let e = job(&format!(r#"{{"scene_name": "furnace", "accel": {body}}}"#)).unwrap_err();
            assert!(
                matches!(e, ApiError::Unprocessable { path: Some(ref p), .. } if p == path),
                "{body}: {e}"
            );
        }
    }
}
