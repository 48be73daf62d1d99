//! The server's configuration (from `candela serve`'s flags): where data lives, the token, the
//! intervals of snapshots and checkpoints, scheduling targets, the limits on what a client
//! may ask for, and retention.

use std::path::{Path, PathBuf};
use std::time::Duration;

/// Where the job store lives: the one place that picks the backend from `--database` (or
/// `$CANDELA_DATABASE`).
#[derive(Debug, Clone, PartialEq)]
pub enum Database {
    /// A SQLite file (the zero-setup default: `<data-dir>/candela.db`).
    Sqlite(PathBuf),
    /// A PostgreSQL connection string (`postgres://USER:PASSWORD@HOST:PORT/DB` or the
    /// `host=… dbname=…` form); several processes may share it.
    Postgres(String),
}

impl Database {
    /// The environment variable read when `--database` is not given.
    pub const ENV: &'static str = "CANDELA_DATABASE";

    /// `--database VALUE` (falling back to `$CANDELA_DATABASE`): `postgres://…` or
    /// `postgresql://…` (or `host=… dbname=…`) picks PostgreSQL, `sqlite://PATH` a SQLite file;
    /// neither given (or empty): `<data_dir>/candela.db`.
    pub fn parse(flag: Option<&str>, data_dir: &Path) -> Result<Database, String> {
        let env = std::env::var(Self::ENV).ok();
        let value = flag
            .or(env.as_deref())
            .map(str::trim)
            .filter(|v| !v.is_empty());
        let Some(v) = value else {
            return Ok(Database::Sqlite(data_dir.join("candela.db")));
        };
        if v.starts_with("postgres://") || v.starts_with("postgresql://") || v.contains("dbname=") {
            Ok(Database::Postgres(v.to_string()))
        } else if let Some(path) = v.strip_prefix("sqlite://") {
            if path.is_empty() {
                return Err("sqlite:// needs a file path (sqlite:///var/lib/candela.db)".into());
            }
            Ok(Database::Sqlite(PathBuf::from(path)))
        } else {
            Err(format!(
                "{v}: expected postgres://USER@HOST:PORT/DB or sqlite://PATH"
            ))
        }
    }

    /// For messages: the SQLite path, or the PostgreSQL location without its password.
    pub fn describe(&self) -> String {
        match self {
            Database::Sqlite(p) => p.display().to_string(),
            Database::Postgres(url) => match (url.find("://"), url.rfind('@')) {
                (Some(s), Some(at)) if at > s => {
                    let user = &url[s + 3..at];
                    let user = user.split(':').next().unwrap_or("");
                    format!("{}{user}@{}", &url[..s + 3], &url[at + 1..])
                }
                _ if url.contains("password=") => "PostgreSQL (connection string)".into(),
                _ => url.clone(),
            },
        }
    }
}

/// Limits on requests; each is reported as a 4xx JSON error when exceeded.
#[derive(Debug, Clone)]
pub struct RequestLimits {
    /// Largest request body in bytes (413).
    pub max_body_bytes: usize,
    /// Largest total size of the files extracted from an upload (413).
    pub max_upload_bytes: u64,
    /// Most files in an upload (413).
    pub max_upload_files: usize,
    /// Largest film side and pixel count (422).
    pub film: renderer::prepare::FilmLimits,
    /// Largest spp and time budget (422).
    pub max_spp: u32,
    pub max_time_s: f64,
    /// Most triangles in a scene (422).
    pub max_triangles: usize,
    /// Most unfinished (queued, running, paused) jobs; more is 429.
    pub max_unfinished_jobs: u64,
}

impl Default for RequestLimits {
    fn default() -> Self {
        RequestLimits {
            max_body_bytes: 256 << 20,
            max_upload_bytes: 1 << 30,
            max_upload_files: 10_000,
            film: renderer::prepare::FilmLimits::default(),
            max_spp: 1 << 20,
            max_time_s: 7.0 * 86400.0,
            max_triangles: 20_000_000,
            max_unfinished_jobs: 100,
        }
    }
}

impl RequestLimits {
    /// The scene loader's limits derived from these.
    pub fn scene_limits(&self) -> renderer::scene::Limits {
        renderer::scene::Limits {
            max_width: self.film.max_side,
            max_height: self.film.max_side,
            max_triangles: self.max_triangles,
            ..Default::default()
        }
    }
}

/// Which finished jobs the server keeps (applied by retention.rs). `None`: no limit of that kind.
#[derive(Debug, Clone, PartialEq)]
pub struct RetentionPolicy {
    /// Finished jobs that ended longer ago than this go.
    pub max_age: Option<Duration>,
    /// At most this many finished jobs are kept (the newest).
    pub max_finished: Option<u64>,
    /// The files of all jobs together are kept under this many bytes (oldest finished go first).
    pub max_bytes: Option<u64>,
    /// The event logs of jobs that finished longer ago than this are pruned.
    pub prune_events_after: Option<Duration>,
}

impl RetentionPolicy {
    /// The server's default: 30 days, 1000 finished jobs, 20 GB of job files; event logs pruned
    /// an hour after the end.
    pub fn server_default() -> RetentionPolicy {
        RetentionPolicy {
            max_age: Some(Duration::from_secs(30 * 86400)),
            max_finished: Some(1000),
            max_bytes: Some(20_000_000_000),
            prune_events_after: Some(Duration::from_secs(3600)),
        }
    }
}

/// Everything the server needs to know at startup.
#[derive(Debug, Clone)]
pub struct ServerConfig {
    /// The data directory (database, job files, built-in assets).
    pub data_dir: PathBuf,
    /// Bearer token; `None`: no authentication (loopback only).
    pub token: Option<String>,
    /// Vulkan device name filter.
    pub device: Option<String>,
    /// The device's position in `candela devices` (`candela worker --devices`); takes
    /// precedence over `device`.
    pub device_index: Option<usize>,
    /// Enable the Vulkan validation layer (tests).
    pub validation: bool,
    /// How often a running job publishes a snapshot (and a progress event).
    pub snapshot_interval: Duration,
    /// How often a running job writes a checkpoint.
    pub checkpoint_interval: Duration,
    /// Target wall time of one pass.
    pub pass_target: Duration,
    /// The pass watchdog's limits (worker/watchdog.rs).
    pub pass_limits: PassLimits,
    /// Most render sessions kept on the GPU at once.
    pub max_active: usize,
    /// SSE keep-alive comment interval.
    pub sse_keepalive: Duration,
    /// The kernel cache folder (compiled kernels, the driver's pipeline cache); None: off.
    pub kernel_cache: Option<PathBuf>,
    /// Which integrators' kernels to build at start, for the built-in scenes' feature sets.
    pub warm_kernels: WarmKernels,
    pub limits: RequestLimits,
    /// Which finished jobs are removed, and how often the server looks (retention.rs).
    pub retention: RetentionPolicy,
    pub gc_interval: Duration,
    /// Below this many free bytes on the data directory's filesystem new jobs are refused (507);
    /// jobs held for a storage fault resume only above it (storage.rs).
    pub min_free_space: u64,
    /// How often the worker measures free space (and tries to resume held jobs).
    pub storage_check_interval: Duration,
    /// Bounds of the renderer's in-memory caches (kernels, pipelines, vct volumes).
    pub caches: renderer::gpu::CacheLimits,
    /// This process's name in render leases (store/leases.rs): `--worker-id`, else `HOST:serve`
    /// for a rendering `candela serve` on PostgreSQL, else `HOST:PID`.
    pub worker_id: String,
    /// How long a claim on a job holds without a heartbeat (`--lease`).
    pub lease: Duration,
    /// How often the worker renews its leases (a third of the lease).
    pub heartbeat: Duration,
    /// Jobs this process claims first are split into shards of this many samples per pixel
    /// (`--shard-spp`; 0: never, and always on SQLite; store/shards.rs).
    pub shard_spp: u32,
}

/// Which kernels the server builds when its device opens (worker/warmup.rs).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum WarmKernels {
    /// Every integrator on a GPU; none on a CPU device (lavapipe), where compiling takes as
    /// long as rendering and tests start many servers.
    Auto,
    /// None.
    None,
    /// These integrators (registry names).
    Only(Vec<String>),
}

impl WarmKernels {
    /// Parses `auto`, `all`, `none` or a comma-separated list of integrator names.
    pub fn parse(text: &str) -> Result<Self, String> {
        match text.trim() {
            "auto" => Ok(WarmKernels::Auto),
            "none" | "" => Ok(WarmKernels::None),
            "all" => Ok(WarmKernels::Only(
                renderer::integrators::names().map(String::from).collect(),
            )),
            list => {
                let names: Vec<String> = list.split(',').map(|n| n.trim().to_string()).collect();
                for n in &names {
                    if renderer::integrators::info(n).is_none() {
                        return Err(format!(
                            "unknown integrator \"{n}\" (expected auto, all, none or a list of {})",
                            renderer::integrators::names()
                                .collect::<Vec<_>>()
                                .join(", ")
                        ));
                    }
                }
                Ok(WarmKernels::Only(names))
            }
        }
    }

    /// The integrators to warm on a device of this kind ("cpu", "discrete", ...).
    pub fn integrators(&self, device_kind: &str) -> Vec<String> {
        match self {
            WarmKernels::Auto if device_kind != "cpu" => {
                renderer::integrators::names().map(String::from).collect()
            }
            WarmKernels::Auto | WarmKernels::None => Vec::new(),
            WarmKernels::Only(v) => v.clone(),
        }
    }
}

impl ServerConfig {
    /// A configuration with defaults under `data_dir`.
    pub fn new(data_dir: PathBuf) -> Self {
        ServerConfig {
            data_dir: data_dir.clone(),
            token: None,
            device: None,
            device_index: None,
            validation: false,
            snapshot_interval: Duration::from_secs(1),
            checkpoint_interval: Duration::from_secs(10),
            pass_target: Duration::from_millis(150),
            pass_limits: PassLimits {
                timeout: None,
                floor: Duration::from_secs(30),
            },
            max_active: 4,
            sse_keepalive: Duration::from_secs(15),
            kernel_cache: Some(data_dir.join("kernel-cache")),
            warm_kernels: WarmKernels::Auto,
            limits: RequestLimits::default(),
            retention: RetentionPolicy::server_default(),
            gc_interval: Duration::from_secs(600),
            min_free_space: 500_000_000,
            storage_check_interval: Duration::from_secs(5),
            caches: renderer::gpu::CacheLimits::DEFAULT,
            worker_id: default_worker_id(),
            lease: Duration::from_secs(30),
            heartbeat: Duration::from_secs(10),
            shard_spp: 0,
        }
    }

    /// `<data>/builtin`: the built-in scenes' assets.
    pub fn builtin_dir(&self) -> PathBuf {
        self.data_dir.join("builtin")
    }

    /// `<data>/tmp`: uploads being unpacked.
    pub fn tmp_dir(&self) -> PathBuf {
        self.data_dir.join("tmp")
    }
}

/// This machine's name (for render lease names).
pub fn host_name() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .ok()
        .or_else(|| std::env::var("HOSTNAME").ok())
        .map(|h| h.trim().to_string())
        .filter(|h| !h.is_empty())
        .unwrap_or_else(|| "localhost".into())
}

/// `HOST:PID`: this process's default name in render leases.
pub fn default_worker_id() -> String {
    format!("{}:{}", host_name(), std::process::id())
}

/// The pass watchdog's limits (worker/watchdog.rs).
#[derive(Debug, Clone, Copy)]
pub struct PassLimits {
    /// Absolute limit of one pass (`--pass-timeout`); None: relative to the job's median.
    pub timeout: Option<Duration>,
    /// Smallest relative limit (`--pass-timeout-floor`).
    pub floor: Duration,
}

#[cfg(test)]
mod database_tests {
    use super::Database;
    use std::path::Path;

    /// `--database` picks the backend; without it the data directory's SQLite file (the
    /// environment variable is read only when the flag is absent, so the flag cases are exact).
    #[test]
    fn database_flag_picks_the_backend() {
        let dir = Path::new("data");
        let pg = "postgres://u:secret@db:5433/candela";
        assert_eq!(
            Database::parse(Some(pg), dir),
            Ok(Database::Postgres(pg.into()))
        );
        assert_eq!(
            Database::parse(Some("sqlite:///tmp/x.db"), dir),
            Ok(Database::Sqlite("/tmp/x.db".into()))
        );
        assert!(Database::parse(Some("mysql://db/x"), dir).is_err());
        assert!(Database::parse(Some("sqlite://"), dir).is_err());
        let described = Database::Postgres(pg.into()).describe();
        assert_eq!(described, "postgres://u@db:5433/candela");
    }
}
