//! The job store: a database holding the jobs (settings, scene, state, progress, timestamps),
//! their event log and the users, so that everything a client was told survives a restart or a
//! crash. Two backends (db.rs): SQLite (bundled, WAL journal; a file in the data directory, the
//! zero-setup default) and PostgreSQL (postgres.rs; one database several processes share). Files
//! (checkpoints, images, uploaded assets) live under the data directory; see [`JobPaths`].
//!
//! One connection per store, held for the whole of each call: statements are short, and holding
//! it across "commit the event, then broadcast it" makes the broadcast order equal the event id
//! order (events.rs). Per-job event ids are dense and increasing on both backends: each is taken
//! by `UPDATE jobs SET event_seq = event_seq + 1 … RETURNING` in the transaction that stores the
//! event, and that row stays locked until the commit.

mod db;
mod events;
mod jobs;
mod leases;
mod migrate;
mod notify;
mod postgres;
mod retention;
mod shards;
mod users;
mod workers;

pub use events::StoredEvent;
pub use jobs::Transition;
pub use notify::listen;
pub use shards::{sum_progress, Claim, Part, ShardRange};
pub use workers::{WorkerMemory, WorkerRecord};

use std::path::{Path, PathBuf};
use std::sync::Mutex;

use rusqlite::Connection;
use tokio::sync::broadcast;

use crate::config::Database;
use crate::jobs::model::JobId;
use db::{Backend, SqliteConn};

/// The database plus the broadcast channel of new events.
pub struct Store {
    db: Backend,
    events: broadcast::Sender<StoredEvent>,
    /// With other processes writing events (a farm): the last event id broadcast of each job;
    /// events are then broadcast from the table (events.rs, [`Store::relay_new_events`]).
    relay: Option<Mutex<std::collections::HashMap<JobId, i64>>>,
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
    /// Database (or file system) trouble.
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
    /// Opens (creating and migrating if needed) the database `db` names.
    pub fn connect(db: &Database) -> Result<Store, StoreError> {
        match db {
            Database::Sqlite(path) => Store::open(path),
            Database::Postgres(url) => {
                let pg = postgres::Pg::open(url)?;
                let store = Store::with(Backend::Postgres(pg));
                store.write(|c| migrate::migrate(c).map(|()| ((), Vec::new())))?;
                Ok(store)
            }
        }
    }

    /// Opens (creating and migrating if needed) the SQLite database at `path`.
    pub fn open(path: &Path) -> Result<Store, StoreError> {
        let mut conn = Connection::open(path)?;
        // WAL: readers never block the writer; NORMAL sync: a commit survives a process crash
        // (kill -9) — only a power loss may drop the last transactions.
        conn.pragma_update(None, "journal_mode", "WAL")?;
        conn.pragma_update(None, "synchronous", "NORMAL")?;
        conn.pragma_update(None, "foreign_keys", "ON")?;
        conn.busy_timeout(std::time::Duration::from_secs(5))?;
        // Immediate: another process (`candela gc`) opening the same file waits, then finds it
        // migrated.
        let tx = conn.transaction_with_behavior(rusqlite::TransactionBehavior::Immediate)?;
        migrate::migrate(&mut SqliteConn(&tx)).map_err(|e| match e {
            StoreError::Db(m) => StoreError::Db(format!("{}: {m}", path.display())),
            e => e,
        })?;
        tx.commit()?;
        Ok(Store::with(Backend::Sqlite(Mutex::new(conn))))
    }

    fn with(db: Backend) -> Store {
        let (events, _) = broadcast::channel(1024);
        Store {
            db,
            events,
            relay: None,
        }
    }

    /// Broadcasts events from the table rather than as they are written, so that subscribers
    /// also see the events other processes (`candela worker`) write; call
    /// [`Store::relay_new_events`] periodically. Events already stored are not broadcast.
    pub fn with_event_relay(mut self) -> Result<Store, StoreError> {
        let rows = self.read(|c| c.query("SELECT id, event_seq FROM jobs", &[]))?;
        let seen = rows
            .iter()
            .map(|r| Ok((r.i64(0)?, r.i64(1)?)))
            .collect::<Result<_, StoreError>>()?;
        self.relay = Some(Mutex::new(seen));
        Ok(self)
    }

    /// Receives every event appended from now on (all jobs).
    pub fn subscribe(&self) -> broadcast::Receiver<StoredEvent> {
        self.events.subscribe()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A job's checkpoints go at its end, with the temporary ones a killed writer left; its
    /// image and other files stay.
    #[test]
    fn removing_checkpoints_removes_temporary_ones_left_by_killed_writers() {
        let data = std::env::temp_dir().join(format!("candela-ckpt-rm-{}", std::process::id()));
        let paths = JobPaths::new(&data, 7);
        std::fs::create_dir_all(&paths.dir).unwrap();
        let files = [
            "checkpoint.bin",
            "shard-0.bin",
            "shard-1.bin",
            ".shard-1.bin.4242.8.tmp",
            ".checkpoint.bin.4242.2.tmp",
            ".image.exr.4242.3.tmp",
            "image.exr",
            "scene.json",
        ];
        for f in files {
            std::fs::write(paths.dir.join(f), b"x").unwrap();
        }
        paths.remove_checkpoints(2);
        let mut left: Vec<String> = std::fs::read_dir(&paths.dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        left.sort();
        assert_eq!(left, ["image.exr", "scene.json"]);
        std::fs::remove_dir_all(&data).unwrap();
    }

    /// A version 1 database (before owners, holds and users) opens, migrated, with its jobs.
    #[test]
    fn migrates_a_version_1_store() {
        let dir = std::env::temp_dir().join(format!("candela-store-v1-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("candela.db");
        {
            let conn = Connection::open(&path).unwrap();
            conn.execute_batch(migrate::sqlite_step(1)).unwrap();
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
        // The adopted and the applied steps are recorded; user_version follows the latest.
        let conn = Connection::open(&path).unwrap();
        let versions: Vec<i64> = conn
            .prepare("SELECT version FROM schema_migrations ORDER BY version")
            .unwrap()
            .query_map([], |r| r.get(0))
            .unwrap()
            .collect::<Result<_, _>>()
            .unwrap();
        assert_eq!(versions, (1..=migrate::LATEST).collect::<Vec<_>>());
        let uv: i64 = conn
            .pragma_query_value(None, "user_version", |r| r.get(0))
            .unwrap();
        assert_eq!(uv, migrate::LATEST);
        // Opening again is a no-op.
        assert!(Store::open(&path).unwrap().get_job(1).is_ok());
        // A step this build does not know: refused, naming it.
        conn.execute(
            "INSERT INTO schema_migrations (version, applied_at) VALUES (?1, 0)",
            [migrate::LATEST + 1],
        )
        .unwrap();
        drop(conn);
        let err = Store::open(&path).err().expect("a newer schema is refused");
        assert!(err.to_string().contains("newer candela"), "{err}");
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
    /// The checkpoint of shard `idx` of a job split over workers (shards.rs).
    pub fn shard_checkpoint(&self, idx: u32) -> PathBuf {
        self.dir.join(format!("shard-{idx}.bin"))
    }
    /// Removes the job's checkpoint and those of its shards `0..shards` (none there: no-op), and
    /// the temporary files of checkpoints and live images being written
    /// (`.checkpoint.bin.PID.N.tmp`, `.shard-K.bin.PID.N.tmp`, `.image.exr.PID.N.tmp`:
    /// renderer::film::write_atomic) that a process killed mid-write left behind; the job has
    /// ended, so no writer of them is still owed the file.
    pub fn remove_checkpoints(&self, shards: u32) {
        let _ = std::fs::remove_file(self.checkpoint());
        for k in 0..shards {
            let _ = std::fs::remove_file(self.shard_checkpoint(k));
        }
        let Ok(entries) = std::fs::read_dir(&self.dir) else {
            return;
        };
        for e in entries.flatten() {
            let name = e.file_name();
            let name = name.to_string_lossy();
            // (A live image's too: a shard's worker killed while writing the job's image.)
            let of_checkpoint = name.starts_with(".checkpoint.bin.")
                || name.starts_with(".shard-")
                || name.starts_with(".image.exr.");
            if of_checkpoint && name.ends_with(".tmp") {
                let _ = std::fs::remove_file(e.path());
            }
        }
    }
    /// The latest image written to disk (at checkpoints, pause, cancel and the end).
    pub fn image(&self) -> PathBuf {
        self.dir.join("image.exr")
    }
}
