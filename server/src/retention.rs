//! Retention: which finished jobs go (older than an age, beyond a count, or while the job files
//! exceed a total size, oldest first), removing one job (record, events, then its folder: image,
//! checkpoint, uploaded assets; its reference image once no other job names it), pruning the
//! event logs of finished jobs, and folders under `<data>/jobs` that no job owns. Used by
//! `DELETE /api/jobs/{id}`, the server's periodic pass (`candela serve --retain-*`) and
//! `candela gc`.
//!
//! Unfinished jobs (queued, running, paused) are never removed; their files still count towards
//! the total size, so the size limit may remove every finished job and still be exceeded.

use std::path::{Path, PathBuf};
use std::time::Duration;

pub use crate::config::RetentionPolicy as Policy;
use crate::jobs::model::{JobId, JobRecord};
use crate::store::{JobPaths, Store, StoreError};
use crate::units::format_bytes;

/// A finished job to remove, and why.
#[derive(Debug)]
pub struct Removal {
    pub job: JobRecord,
    /// Bytes of its folder.
    pub bytes: u64,
    pub reason: String,
}

/// What a retention pass did (or, dry, would do).
#[derive(Debug, Default)]
pub struct Report {
    pub removed: Vec<Removal>,
    /// Folders under `<data>/jobs` of no job, removed.
    pub orphans: Vec<(PathBuf, u64)>,
    pub events_pruned: u64,
}

impl Report {
    /// Bytes freed (or that would be).
    pub fn bytes(&self) -> u64 {
        self.removed.iter().map(|r| r.bytes).sum::<u64>()
            + self.orphans.iter().map(|o| o.1).sum::<u64>()
    }
}

/// Total size of the files under `path` (0 when absent; links not followed).
pub fn dir_size(path: &Path) -> u64 {
    let Ok(meta) = std::fs::symlink_metadata(path) else {
        return 0;
    };
    if !meta.is_dir() {
        return meta.len();
    }
    std::fs::read_dir(path)
        .map(|entries| {
            entries
                .filter_map(Result::ok)
                .map(|e| dir_size(&e.path()))
                .sum()
        })
        .unwrap_or(0)
}

/// The finished jobs `policy` removes at time `now` (Unix seconds), oldest first.
pub fn plan(
    store: &Store,
    data_dir: &Path,
    policy: &Policy,
    now: f64,
) -> Result<Vec<Removal>, StoreError> {
    let finished = store.finished_jobs()?;
    let n = finished.len() as u64;
    // Step 1: age and count.
    let mut out = Vec::new();
    let mut kept = Vec::new();
    for (i, job) in finished.into_iter().enumerate() {
        let ended = job.finished_at.unwrap_or(job.updated_at);
        let bytes = dir_size(&JobPaths::new(data_dir, job.id).dir);
        let reason = match (policy.max_age, policy.max_finished) {
            (Some(age), _) if ended < now - age.as_secs_f64() => {
                Some(format!("finished more than {} ago", human_age(age)))
            }
            (_, Some(keep)) if (i as u64) < n.saturating_sub(keep) => {
                Some(format!("more than {keep} finished jobs"))
            }
            _ => None,
        };
        match reason {
            Some(reason) => out.push(Removal { job, bytes, reason }),
            None => kept.push((job, bytes)),
        }
    }
    // Step 2: total size, oldest kept job first.
    if let Some(max) = policy.max_bytes {
        let planned: u64 = out.iter().map(|r| r.bytes).sum();
        let mut total = dir_size(&data_dir.join("jobs")).saturating_sub(planned);
        for (job, bytes) in kept {
            if total <= max {
                break;
            }
            total = total.saturating_sub(bytes);
            out.push(Removal {
                job,
                bytes,
                reason: format!("job files over {}", format_bytes(max)),
            });
        }
    }
    Ok(out)
}

/// `7d`, `12h`, `30m` or `45s`, whichever is whole.
fn human_age(d: Duration) -> String {
    let s = d.as_secs();
    match s {
        _ if s >= 86400 && s.is_multiple_of(86400) => format!("{}d", s / 86400),
        _ if s >= 3600 && s.is_multiple_of(3600) => format!("{}h", s / 3600),
        _ if s >= 60 && s.is_multiple_of(60) => format!("{}m", s / 60),
        _ => format!("{s}s"),
    }
}

/// Removes finished job `id`: its record and events, then its folder (image, checkpoint, uploaded
/// assets) and its reference image when no other job names it. Returns the record and the bytes
/// freed. An unfinished job is a Conflict (cancel it first).
pub fn remove_job(
    store: &Store,
    data_dir: &Path,
    id: JobId,
) -> Result<(JobRecord, u64), StoreError> {
    let rec = store.delete_job(id)?;
    let dir = JobPaths::new(data_dir, id).dir;
    let mut bytes = dir_size(&dir);
    if let Err(e) = std::fs::remove_dir_all(&dir) {
        if e.kind() != std::io::ErrorKind::NotFound {
            tracing::warn!(job = id, path = %dir.display(), error = %e, "removing job files");
        }
    }
    // References are copies under <data>/references (routes/jobs.rs), named by one job each;
    // the check keeps one should another job ever name the same file.
    if let Some(r) = &rec.settings.reference {
        let path = Path::new(r);
        if path.starts_with(data_dir.join("references")) && !store.file_in_use(r)? {
            bytes += dir_size(path);
            let _ = std::fs::remove_file(path);
        }
    }
    Ok((rec, bytes))
}

/// Folders under `<data>/jobs` named for a job the store does not hold, last changed more than
/// `min_age` ago (a folder is created just before its job's record commits).
fn orphans(store: &Store, data_dir: &Path, min_age: Duration) -> Result<Vec<PathBuf>, StoreError> {
    let ids: std::collections::HashSet<JobId> = store.job_ids()?.into_iter().collect();
    let Ok(entries) = std::fs::read_dir(data_dir.join("jobs")) else {
        return Ok(Vec::new());
    };
    Ok(entries
        .filter_map(Result::ok)
        .filter(|e| {
            let id = e.file_name().to_str().and_then(|n| n.parse::<JobId>().ok());
            let old = e
                .metadata()
                .and_then(|m| m.modified())
                .ok()
                .and_then(|t| t.elapsed().ok())
                .is_some_and(|age| age >= min_age);
            id.is_some_and(|id| !ids.contains(&id)) && old
        })
        .map(|e| e.path())
        .collect())
}

/// One retention pass at time `now`: plans, removes (unless `dry_run`), prunes event logs and
/// removes orphaned folders.
pub fn run(
    store: &Store,
    data_dir: &Path,
    policy: &Policy,
    now: f64,
    dry_run: bool,
) -> Result<Report, StoreError> {
    let mut report = Report::default();
    for r in plan(store, data_dir, policy, now)? {
        if dry_run {
            report.removed.push(r);
            continue;
        }
        match remove_job(store, data_dir, r.job.id) {
            Ok((_, bytes)) => report.removed.push(Removal { bytes, ..r }),
            // Deleted meanwhile (by a client or another gc): nothing to report.
            Err(StoreError::NotFound(_)) => {}
            Err(e) => return Err(e),
        }
    }
    if let Some(after) = policy.prune_events_after {
        report.events_pruned = store.prune_events(now - after.as_secs_f64(), dry_run)?;
    }
    for dir in orphans(store, data_dir, Duration::from_secs(600))? {
        let bytes = dir_size(&dir);
        if !dry_run {
            if let Err(e) = std::fs::remove_dir_all(&dir) {
                tracing::warn!(path = %dir.display(), error = %e, "removing an orphaned folder");
                continue;
            }
        }
        report.orphans.push((dir, bytes));
    }
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::jobs::model::{JobSettings, JobState, NewJob, SceneSource};
    use crate::store::Transition;

    /// A store in a fresh folder with `n` done jobs, each with a folder of `bytes` bytes.
    fn store_with_done_jobs(name: &str, n: usize, bytes: usize) -> (Store, PathBuf, Vec<JobId>) {
        let dir =
            std::env::temp_dir().join(format!("candela-retention-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let store = Store::open(&dir.join("candela.db")).unwrap();
        let settings: JobSettings = serde_json::from_value(serde_json::json!({
            "integrator": {"type": "nee"}, "spp": 1, "time_s": null, "seed": 0, "width": 4,
            "height": 4, "scene_max_depth": null, "exposure": 0.0, "tonemap": "clamp"
        }))
        .unwrap();
        let mut ids = Vec::new();
        for i in 0..n {
            let job = NewJob {
                name: format!("j{i}"),
                priority: 10,
                settings: settings.clone(),
                scene: "{}".into(),
                scene_name: None,
                source: SceneSource::Inline,
                owner: None,
            };
            let id = store.insert_job(&job, |_| Ok(())).unwrap().id;
            for to in [JobState::Running, JobState::Done] {
                store.transition(id, to, Transition::default()).unwrap();
            }
            let folder = JobPaths::new(&dir, id).dir;
            std::fs::create_dir_all(&folder).unwrap();
            std::fs::write(folder.join("image.exr"), vec![0u8; bytes]).unwrap();
            ids.push(id);
        }
        (store, dir, ids)
    }

    fn ids(plan: &[Removal]) -> Vec<JobId> {
        plan.iter().map(|r| r.job.id).collect()
    }

    #[test]
    fn plans_by_age_count_and_size() {
        let (store, dir, j) = store_with_done_jobs("plan", 4, 1000);
        let now = crate::jobs::model::now_s();
        let none = Policy {
            max_age: None,
            max_finished: None,
            max_bytes: None,
            prune_events_after: None,
        };
        assert!(plan(&store, &dir, &none, now).unwrap().is_empty());
        // Age: nothing is a day old now; everything is 8 days later.
        let week = Policy {
            max_age: Some(Duration::from_secs(7 * 86400)),
            ..none.clone()
        };
        assert!(plan(&store, &dir, &week, now).unwrap().is_empty());
        assert_eq!(
            ids(&plan(&store, &dir, &week, now + 8.0 * 86400.0).unwrap()),
            j
        );
        // Count: the oldest beyond the newest 3.
        let three = Policy {
            max_finished: Some(3),
            ..none.clone()
        };
        assert_eq!(ids(&plan(&store, &dir, &three, now).unwrap()), vec![j[0]]);
        // Size: 4000 bytes of folders, at most 2500: the two oldest go.
        let size = Policy {
            max_bytes: Some(2500),
            ..none.clone()
        };
        let p = plan(&store, &dir, &size, now).unwrap();
        assert_eq!(ids(&p), vec![j[0], j[1]]);
        assert!(p
            .iter()
            .all(|r| r.bytes == 1000 && r.reason.contains("over")));
        // Unfinished jobs are never planned, and a removal takes the folder.
        let (rec, bytes) = remove_job(&store, &dir, j[0]).unwrap();
        assert_eq!((rec.id, bytes), (j[0], 1000));
        assert!(!JobPaths::new(&dir, j[0]).dir.exists());
        assert!(matches!(
            remove_job(&store, &dir, j[0]),
            Err(StoreError::NotFound(_))
        ));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
