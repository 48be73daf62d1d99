//! `auto` jobs (request `"integrator": "auto"`): the session of a job whose integrator is
//! chosen by a pilot (renderer::auto). When the job first starts, every unbiased integrator
//! renders its share of the pilot (5% of the job's budget together) on the worker's thread; the
//! winner's session, holding its pilot's samples, becomes the job's session. The choice is kept
//! in the job's folder (`auto.json`: the choice, every pilot's figures, the time the other
//! pilots took) so that a job resumed after a pause, a restart or a device loss renders with
//! the same integrator from its checkpoint without a new pilot; it is announced in an `auto`
//! event and reported in the job's final stats (`stats.auto`). A time budget is shortened by
//! the other pilots' time, as `candela render --integrator auto` does.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use renderer::auto::pilot;
use renderer::gpu::GpuContext;
use renderer::integrators::IntegratorOptions;
use renderer::prepare::PreparedScene;
use renderer::render::{Budget, RenderError, RenderSession};
use serde_json::{json, Value};

use crate::jobs::model::JobSettings;
use crate::store::JobPaths;

/// An `auto` job's choice: the `stats.auto` object and what the budget lost to the other
/// pilots.
#[derive(Debug, Clone)]
pub struct AutoRun {
    /// `{"choice": NAME, "pilots": [...]}`, as `RenderStats::auto` serialises.
    pub report: Value,
    /// Seconds the losing pilots rendered (taken off a time budget).
    pub spent_elsewhere_s: f64,
}

/// Where the choice is kept.
fn choice_file(paths: &JobPaths) -> PathBuf {
    paths.dir.join("auto.json")
}

/// The session of an `auto` job: the saved choice's integrator (no pilot), else a fresh pilot
/// whose winner's session is returned with its samples (any older checkpoint, made without a
/// choice, is removed). `fresh` is true when the pilot ran now.
pub fn session(
    prepared: &PreparedScene,
    ctx: &Arc<GpuContext>,
    settings: &JobSettings,
    paths: &JobPaths,
) -> Result<(RenderSession, AutoRun, bool), RenderError> {
    let file = choice_file(paths);
    let max_depth = settings.integrator.max_depth();
    if let Some((mut options, run)) = read(&file) {
        if let Some(d) = max_depth {
            options.set_max_depth(d);
        }
        let session = prepared.session(ctx, &options, settings.seed)?;
        return Ok((session, run, false));
    }
    let _ = std::fs::remove_file(paths.checkpoint());
    let p = pilot(prepared, ctx, settings.seed, max_depth, settings.budget())?;
    let spent_elsewhere_s = match (settings.budget(), p.rest) {
        (Budget::Time(t), Budget::Time(r)) => (t - r).max(0.0),
        _ => 0.0,
    };
    let run = AutoRun {
        report: serde_json::to_value(&p.choice).unwrap_or_default(),
        spent_elsewhere_s,
    };
    // Written whole or not at all (a torn file would mean a second pilot, not a wrong one).
    let saved = json!({"auto": run.report, "spent_elsewhere_s": spent_elsewhere_s});
    let tmp = file.with_extension("json.tmp");
    let written = std::fs::create_dir_all(&paths.dir)
        .and_then(|_| std::fs::write(&tmp, serde_json::to_vec(&saved).unwrap_or_default()))
        .and_then(|_| std::fs::rename(&tmp, &file));
    if let Err(e) = written {
        tracing::warn!(path = %file.display(), error = %e, "saving the auto choice");
    }
    Ok((p.session, run, true))
}

/// The saved choice: the winner's options (the registry's defaults, as the pilot used, before
/// max_depth) and the report; None when absent or unreadable.
fn read(file: &Path) -> Option<(IntegratorOptions, AutoRun)> {
    let v: Value = serde_json::from_slice(&std::fs::read(file).ok()?).ok()?;
    let name = v["auto"]["choice"].as_str()?;
    let options = IntegratorOptions::from_name(name)?;
    Some((
        options,
        AutoRun {
            report: v["auto"].clone(),
            spent_elsewhere_s: v["spent_elsewhere_s"].as_f64().unwrap_or(0.0),
        },
    ))
}
