//! The job model: states and their transitions, the settings a job renders with, the stored
//! record, and the JSON view the API serves (with links).
//!
//! ```text
//!   queued ──► running ──► done
//!     │  ▲        │  └───► failed      (any non-terminal state may fail)
//!     ▼  │        ▼
//!    paused ◄─────┘                    (pause: queued|running → paused; resume: paused → queued)
//!   queued|running|paused ──► canceled
//! ```

use renderer::integrators::IntegratorOptions;
use renderer::render::{Budget, Progress};
use serde::{Deserialize, Serialize};
use serde_json::{json, Value};

/// A job's id (SQLite rowid; never reused).
pub type JobId = i64;

/// Where a job is in its life.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum JobState {
    /// Waiting for its first pass (or for a free slot after a resume).
    Queued,
    /// Started: has rendered (or is about to render) passes.
    Running,
    /// Stopped by the user, checkpointed; `resume` queues it again.
    Paused,
    /// Reached its budget; the final image is on disk.
    Done,
    /// Could not be rendered; `error` says why.
    Failed,
    /// Stopped for good by the user.
    Canceled,
}

impl JobState {
    /// Every state, in lifecycle order.
    pub const ALL: [JobState; 6] = [
        JobState::Queued,
        JobState::Running,
        JobState::Paused,
        JobState::Done,
        JobState::Failed,
        JobState::Canceled,
    ];

    /// The lowercase name used in JSON, the store and query strings.
    pub fn as_str(self) -> &'static str {
        match self {
            JobState::Queued => "queued",
            JobState::Running => "running",
            JobState::Paused => "paused",
            JobState::Done => "done",
            JobState::Failed => "failed",
            JobState::Canceled => "canceled",
        }
    }

    /// Parses a name written by [`JobState::as_str`].
    pub fn parse(s: &str) -> Option<JobState> {
        JobState::ALL.into_iter().find(|st| st.as_str() == s)
    }

    /// Queued, running and paused: the jobs that count against the queue's limit.
    pub fn is_unfinished(self) -> bool {
        !self.is_terminal()
    }

    /// Done, failed and canceled never change again.
    pub fn is_terminal(self) -> bool {
        matches!(self, JobState::Done | JobState::Failed | JobState::Canceled)
    }

    /// Whether `self → to` is a valid transition (see the diagram at the top of this file).
    pub fn can_become(self, to: JobState) -> bool {
        use JobState::*;
        matches!(
            (self, to),
            (Queued, Running | Paused | Canceled | Failed)
                | (Running, Paused | Done | Failed | Canceled)
                | (Paused, Queued | Canceled | Failed)
        )
    }
}

/// Default and range of a job's priority: its share of GPU time is proportional to it.
pub const DEFAULT_PRIORITY: u32 = 10;
/// Highest accepted priority (lowest is 1).
pub const MAX_PRIORITY: u32 = 100;

/// What a job renders with, fixed at submission (stored as JSON).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JobSettings {
    /// The integrator and its options (with `auto`: the scene's or default integrator, a
    /// placeholder until the pilot has chosen).
    pub integrator: IntegratorOptions,
    /// Request `"integrator": "auto"`: the worker runs a pilot of every unbiased integrator
    /// when the job starts and renders with the cheapest (renderer::auto; the choice is kept
    /// in the job's folder, `auto.json`, and reported in its stats and an `auto` event).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub auto: bool,
    /// Samples per pixel to render (exclusive with `time_s`).
    pub spp: Option<u32>,
    /// Seconds of the job's own render time (exclusive with `spp`).
    pub time_s: Option<f64>,
    /// Quality target: the job stops once its estimated relMSE is at most this (after
    /// `renderer::render::UNTIL_MIN_SPP` spp); spp or time_s is the cap (request field
    /// `until: {"rel_mse": X}`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub until_rel_mse: Option<f64>,
    /// RNG seed.
    pub seed: u64,
    /// Film size.
    pub width: u32,
    pub height: u32,
    /// The scene's `render.max_depth` (used when the integrator options give none).
    pub scene_max_depth: Option<i32>,
    /// Default PNG exposure (EV) and tonemap ("clamp", "reinhard", "aces") of the image endpoint.
    pub exposure: f32,
    pub tonemap: String,
    /// The reference image (EXR path on disk) progress metrics are computed against.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference: Option<String>,
    /// The request's acceleration structure, overriding the scene's `render.accel` (absent in
    /// jobs stored before it existed: they use the scene's choice, else the BVH).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub accel: Option<AccelSetting>,
    /// Kernels specialised to the scene (the default; absent in jobs stored before the choice
    /// existed) or generic.
    #[serde(default)]
    pub kernels: renderer::compile::KernelMode,
}

/// A job's acceleration structure: `{"type": "grid", "grid_resolution": 64}` (docs/accel.md).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AccelSetting {
    /// "auto", "bvh", "cwbvh" or "grid".
    #[serde(rename = "type")]
    pub kind: String,
    /// Grid cells along the scene's longest axis (None: the scene's, else automatic).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grid_resolution: Option<u32>,
}

impl JobSettings {
    /// When the render stops.
    pub fn budget(&self) -> Budget {
        match (self.spp, self.time_s) {
            (_, Some(t)) => Budget::Time(t),
            (Some(n), None) => Budget::Spp(n),
            (None, None) => Budget::Spp(1),
        }
    }
}

/// Where a job's scene assets live.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SceneSource {
    /// JSON only, no files.
    Inline,
    /// A built-in scene: assets under `<data>/builtin`.
    Builtin,
    /// Uploaded files: under `<data>/jobs/<id>/assets`.
    Upload,
}

impl SceneSource {
    /// Name stored in the database.
    pub fn as_str(self) -> &'static str {
        match self {
            SceneSource::Inline => "inline",
            SceneSource::Builtin => "builtin",
            SceneSource::Upload => "upload",
        }
    }

    /// Parses [`SceneSource::as_str`].
    pub fn parse(s: &str) -> Option<SceneSource> {
        match s {
            "inline" => Some(SceneSource::Inline),
            "builtin" => Some(SceneSource::Builtin),
            "upload" => Some(SceneSource::Upload),
            _ => None,
        }
    }
}

/// A job as stored (without its scene text, which is fetched separately).
#[derive(Debug, Clone)]
pub struct JobRecord {
    pub id: JobId,
    pub name: String,
    pub state: JobState,
    pub priority: u32,
    pub settings: JobSettings,
    pub scene_name: Option<String>,
    pub source: SceneSource,
    pub progress: Option<Progress>,
    /// Final `RenderStats` of a done job.
    pub stats: Option<Value>,
    pub error: Option<String>,
    /// Unix seconds.
    pub created_at: f64,
    pub started_at: Option<f64>,
    pub finished_at: Option<f64>,
    pub updated_at: f64,
    /// The user who submitted it (None: no named users, or submitted before they existed).
    pub owner: Option<String>,
    /// Why the server holds it paused (a full disk); None when a user paused it.
    pub hold: Option<String>,
}

/// The links of a job, relative to the server root.
pub fn job_links(id: JobId) -> Value {
    json!({
        "self": format!("/api/jobs/{id}"),
        "events": format!("/api/jobs/{id}/events"),
        "image.png": format!("/api/jobs/{id}/image.png"),
        "image.exr": format!("/api/jobs/{id}/image.exr"),
    })
}

impl JobRecord {
    /// The JSON served by the API.
    pub fn to_json(&self) -> Value {
        let p = self.progress.unwrap_or_default();
        let fraction = match self.settings.budget() {
            _ if self.state == JobState::Done => 1.0,
            Budget::Spp(n) => (p.spp as f64 / n.max(1) as f64).min(1.0),
            Budget::Time(t) => (p.time_s / t.max(1e-9)).min(1.0),
        };
        let mut settings = serde_json::to_value(&self.settings).unwrap_or_default();
        if self.settings.reference.is_some() {
            // Whether it has one; the path on the server's disk is not the client's business.
            settings["reference"] = json!(true);
        }
        json!({
            "id": self.id,
            "name": self.name,
            "state": self.state.as_str(),
            "priority": self.priority,
            "scene_name": self.scene_name,
            "scene_source": self.source.as_str(),
            "settings": settings,
            "progress": {
                "spp": p.spp,
                "passes": p.passes,
                "rays": p.rays,
                "dropped_samples": p.dropped_samples,
                "time_s": p.time_s,
                "gpu_time_s": p.gpu_time_s,
                "fraction": fraction,
            },
            "stats": self.stats,
            "error": self.error,
            "created_at": rfc3339(self.created_at),
            "started_at": self.started_at.map(rfc3339),
            "finished_at": self.finished_at.map(rfc3339),
            "updated_at": rfc3339(self.updated_at),
            "owner": self.owner,
            "hold": self.hold,
            "links": job_links(self.id),
        })
    }
}

/// Now, in Unix seconds.
pub fn now_s() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs_f64())
        .unwrap_or(0.0)
}

/// Unix seconds as an RFC 3339 UTC timestamp with milliseconds (`2025-01-02T03:04:05.678Z`).
pub fn rfc3339(t: f64) -> String {
    let ms = (t.max(0.0) * 1000.0).round() as i64;
    let (secs, millis) = (ms.div_euclid(1000), ms.rem_euclid(1000));
    let (days, rem) = (secs.div_euclid(86400), secs.rem_euclid(86400));
    // Civil date from days since 1970-01-01 (H. Hinnant, "chrono-Compatible Low-Level Date
    // Algorithms", days_from_civil inverse).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}.{millis:03}Z",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}

/// A job to insert.
#[derive(Debug, Clone)]
pub struct NewJob {
    pub name: String,
    pub priority: u32,
    pub settings: JobSettings,
    /// The scene JSON text.
    pub scene: String,
    pub scene_name: Option<String>,
    pub source: SceneSource,
    /// The submitting user (None: open server or the shared token).
    pub owner: Option<String>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transitions() {
        use JobState::*;
        assert!(Queued.can_become(Running));
        assert!(Running.can_become(Paused));
        assert!(Paused.can_become(Queued));
        assert!(!Paused.can_become(Running));
        assert!(!Done.can_become(Canceled));
        assert!(!Canceled.can_become(Queued));
        assert!(!Queued.can_become(Done));
        for s in JobState::ALL {
            assert_eq!(JobState::parse(s.as_str()), Some(s));
            assert!(!s.can_become(s));
        }
    }

    #[test]
    fn timestamps() {
        assert_eq!(rfc3339(0.0), "1970-01-01T00:00:00.000Z");
        assert_eq!(rfc3339(951_782_400.5), "2000-02-29T00:00:00.500Z");
        assert_eq!(rfc3339(1_735_787_045.678), "2025-01-02T03:04:05.678Z");
    }
}
