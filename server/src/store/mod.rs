//! The job store: one SQLite database (bundled, WAL journal) holding the jobs (settings, scene,
//! state, progress, timestamps) and their event log, so that everything a client was told
//! survives a restart or a crash. Files (checkpoints, images, uploaded assets) live beside it
//! under the data directory; see [`JobPaths`].
//!
//! One connection behind a mutex: statements are short, and holding the lock across "write the
//! event, then broadcast it" makes the broadcast order equal the event id order (events.rs).

mod events;
mod jobs;
mod retention;
mod users;

pub use events::StoredEvent;
pub use jobs::Transition;

use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard};

use rusqlite::Connection;
use tokio::sync::broadcast;

use crate::jobs::model::JobId;

/// The schema of version 1 (`user_version`); [`MIGRATE_V2`] brings it to 2.
const SCHEMA: &str = "
CREATE TABLE IF NOT EXISTS jobs (
    id          INTEGER PRIMARY KEY AUTOINCREMENT,
    name        TEXT NOT NULL,
    state       TEXT NOT NULL,
    priority    INTEGER NOT NULL,
    settings    TEXT NOT NULL,
    scene       TEXT NOT NULL,
    scene_name  TEXT,
    source      TEXT NOT NULL,
    progress    TEXT,
    stats       TEXT,
    error       TEXT,
    created_at  REAL NOT NULL,
    started_at  REAL,
    finished_at REAL,
    updated_at  REAL NOT NULL,
    event_seq   INTEGER NOT NULL DEFAULT 0
);
CREATE INDEX IF NOT EXISTS jobs_by_state ON jobs(state);
CREATE TABLE IF NOT EXISTS events (
    job_id INTEGER NOT NULL,
    seq    INTEGER NOT NULL,
    kind   TEXT NOT NULL,
    data   TEXT NOT NULL,
    at     REAL NOT NULL,
    PRIMARY KEY (job_id, seq)
) WITHOUT ROWID;
";

/// Version 2: who submitted each job (`owner`), why the server holds a job paused (`hold`,
/// e.g. a full disk; NULL when paused by a user), and the named tokens (`users`).
const MIGRATE_V2: &str = "
ALTER TABLE jobs ADD COLUMN owner TEXT;
ALTER TABLE jobs ADD COLUMN hold TEXT;
CREATE TABLE IF NOT EXISTS users (
    name         TEXT PRIMARY KEY,
    role         TEXT NOT NULL,
    token_sha256 TEXT NOT NULL UNIQUE,
    created_at   REAL NOT NULL
);
PRAGMA user_version = 2;
";

/// The schema version this build writes.
const SCHEMA_VERSION: i64 = 2;

/// The database plus the broadcast channel of new events.
pub struct Store {
    conn: Mutex<Connection>,
    events: broadcast::Sender<StoredEvent>,
}

/// Why a store operation failed.
#[derive(Debug)]
pub enum StoreError {
    /// No job with this id.
    NotFound(JobId),
    /// The job's state does not allow the transition.
    Conflict {
        state: crate::jobs::model::JobState,
        message: String,
    },
    /// SQLite (or file system) trouble.
    Db(String),
}

impl std::fmt::Display for StoreError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StoreError::NotFound(id) => write!(f, "no job {id}"),
            StoreError::Conflict { message, .. } => f.write_str(message),
            StoreError::Db(m) => write!(f, "store: {m}"),
        }
    }
}

impl From<rusqlite::Error> for StoreError {
    fn from(e: rusqlite::Error) -> Self {
        StoreError::Db(e.to_string())
    }
}

impl From<StoreError> for crate::api_error::ApiError {
    fn from(e: StoreError) -> Self {
        use crate::api_error::ApiError;
        match e {
            StoreError::NotFound(id) => ApiError::NotFound(format!("no job {id}")),
            StoreError::Conflict { message, .. } => ApiError::Conflict(message),
            StoreError::Db(m) => ApiError::internal(format!("store: {m}")),
        }
    }
}

impl Store {
    /// Opens (creating if needed) the database at `path`.
    pub fn open(path: &Path) -> Result<Store, StoreError> {
        let conn = Connection::open(path)?;
        // WAL: readers never block the writer; NORMAL sync: a commit survives a process crash
        // (kill -9) — only a power loss may drop the last transactions.
        conn.pragma_update(None, "journal_mode", "WAL")?;
        conn.pragma_update(None, "synchronous", "NORMAL")?;
        conn.pragma_update(None, "foreign_keys", "ON")?;
        conn.busy_timeout(std::time::Duration::from_secs(5))?;
        let version: i64 = conn.pragma_query_value(None, "user_version", |r| r.get(0))?;
        if version > SCHEMA_VERSION {
            return Err(StoreError::Db(format!(
                "{} was written by a newer candela (schema {version})",
                path.display()
            )));
        }
        conn.execute_batch(SCHEMA)?;
        if version < 2 {
            // Immediate: another process (`candela gc`) opening the same file waits, then finds
            // it migrated.
            conn.execute_batch("BEGIN IMMEDIATE")?;
            let now: i64 = conn.pragma_query_value(None, "user_version", |r| r.get(0))?;
            let migrated = if now < 2 {
                conn.execute_batch(MIGRATE_V2)
            } else {
                Ok(())
            };
            match migrated {
                Ok(()) => conn.execute_batch("COMMIT")?,
                Err(e) => {
                    let _ = conn.execute_batch("ROLLBACK");
                    return Err(e.into());
                }
            }
        }
        let (events, _) = broadcast::channel(1024);
        Ok(Store {
            conn: Mutex::new(conn),
            events,
        })
    }

    /// The connection (a poisoned lock is recovered: SQLite keeps itself consistent).
    fn conn(&self) -> MutexGuard<'_, Connection> {
        self.conn.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Receives every event appended from now on (all jobs).
    pub fn subscribe(&self) -> broadcast::Receiver<StoredEvent> {
        self.events.subscribe()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A version 1 database (before owners, holds and users) opens, migrated, with its jobs.
    #[test]
    fn migrates_a_version_1_store() {
        let dir = std::env::temp_dir().join(format!("candela-store-v1-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("candela.db");
        {
            let conn = Connection::open(&path).unwrap();
            conn.execute_batch(SCHEMA).unwrap();
            conn.execute_batch(
                "PRAGMA user_version = 1; INSERT INTO jobs (name, state, priority, settings, \
                 scene, source, created_at, updated_at) VALUES ('old', 'done', 10, \
                 '{\"integrator\": {\"type\": \"nee\"}, \"spp\": 1, \"time_s\": null, \"seed\": 0, \
                 \"width\": 4, \"height\": 4, \"scene_max_depth\": null, \"exposure\": 0.0, \
                 \"tonemap\": \"clamp\"}', '{}', 'inline', 1.0, 1.0);",
            )
            .unwrap();
        }
        let store = Store::open(&path).unwrap();
        let job = store.get_job(1).unwrap();
        assert_eq!(
            (job.name.as_str(), job.owner, job.hold),
            ("old", None, None)
        );
        assert_eq!(store.user_count().unwrap(), 0);
        drop(store);
        // Opening again is a no-op.
        assert!(Store::open(&path).unwrap().get_job(1).is_ok());
        let _ = std::fs::remove_dir_all(&dir);
    }
}

/// Where a job's files live under the data directory.
#[derive(Debug, Clone)]
pub struct JobPaths {
    /// `<data>/jobs/<id>`.
    pub dir: PathBuf,
}

impl JobPaths {
    /// The paths of job `id` under `data_dir`.
    pub fn new(data_dir: &Path, id: JobId) -> JobPaths {
        JobPaths {
            dir: data_dir.join("jobs").join(id.to_string()),
        }
    }
    /// Uploaded assets (the scene's base folder for uploaded scenes).
    pub fn assets(&self) -> PathBuf {
        self.dir.join("assets")
    }
    /// The accumulation checkpoint.
    pub fn checkpoint(&self) -> PathBuf {
        self.dir.join("checkpoint.bin")
    }
    /// The latest image written to disk (at checkpoints, pause, cancel and the end).
    pub fn image(&self) -> PathBuf {
        self.dir.join("image.exr")
    }
}
