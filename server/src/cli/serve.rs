//! `candela serve`: the HTTP render server. Opens the store in the data directory, installs
//! the built-in scenes' assets, starts the GPU worker thread and serves the API and the web
//! viewer until SIGTERM or Ctrl-C, then shuts down gracefully: new requests stop, event streams
//! end, every running job is checkpointed (and resumes at the next start), exit status 0.
//!
//! Prints `candela: listening on http://ADDR` on stdout once the socket is bound (the actual
//! port when `--bind` asks for port 0). Refuses (exit 2) to bind a non-loopback address
//! without a token or users (`candela users`): anyone who can reach it could use the GPU.

use std::net::{SocketAddr, ToSocketAddrs};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use clap::Args;
use renderer::gpu::CacheLimits;
use tokio::sync::watch;

use super::CliError;
use crate::app::app;
use crate::config::{Database, ServerConfig};
use crate::shared::Shared;
use crate::state::AppState;
use crate::store::Store;

#[derive(Debug, Args)]
pub struct ServeArgs {
    /// Address to listen on (port 0: any free port).
    #[arg(long, default_value = "127.0.0.1:8080")]
    pub bind: String,
    /// Where jobs, images and checkpoints are kept.
    #[arg(long, default_value = "candela-data")]
    pub data_dir: PathBuf,
    /// The job store: postgres://USER@HOST:PORT/DB (shared by several processes) or
    /// sqlite://PATH (default: $CANDELA_DATABASE, else <data-dir>/candela.db).
    #[arg(long, value_name = "URL")]
    pub database: Option<String>,
    /// Require `Authorization: Bearer TOKEN` on the API (default: $CANDELA_TOKEN).
    #[arg(long)]
    pub token: Option<String>,
    /// Use the first Vulkan device whose name contains this text.
    #[arg(long)]
    pub device: Option<String>,
    /// `candela worker` only: render on these devices at once, one claiming thread each (named
    /// NAME/gpu0, NAME/gpu1, … in leases): "all" (every GPU of the best kind) or indices from
    /// `candela devices`, e.g. 0,1 (an index may repeat: two contexts on one device).
    #[arg(long, value_name = "LIST", conflicts_with = "device")]
    pub devices: Option<String>,
    /// Seconds between snapshots (image + progress event) of a running job.
    #[arg(long, default_value_t = 1.0)]
    pub snapshot_interval: f64,
    /// Seconds between checkpoints of a running job.
    #[arg(long, default_value_t = 10.0)]
    pub checkpoint_interval: f64,
    /// Most unfinished (queued, running, paused) jobs; more submissions get 429.
    #[arg(long, default_value_t = 100)]
    pub max_queued: u64,
    /// Most jobs rendering at once (sharing the GPU); others wait queued.
    #[arg(long, default_value_t = 4)]
    pub max_active: usize,
    /// Largest request body, MiB.
    #[arg(long, default_value_t = 256)]
    pub max_body_mb: u64,
    /// Largest film (pixels).
    #[arg(long, default_value_t = 64 << 20)]
    pub max_pixels: u64,
    /// Largest spp budget.
    #[arg(long, default_value_t = 1 << 20)]
    pub max_spp: u32,
    /// Largest time budget, seconds.
    #[arg(long, default_value_t = 604800.0)]
    pub max_time: f64,
    /// Most triangles in a scene.
    #[arg(long, default_value_t = 20_000_000)]
    pub max_triangles: usize,
    /// Target duration of one render pass, milliseconds.
    #[arg(long, default_value_t = 150)]
    pub pass_ms: u64,
    /// Pass watchdog: a pass longer than this many seconds shrinks its job's passes, and at one
    /// sample per pixel stops the job (0: relative, see --pass-timeout-floor).
    #[arg(long, default_value_t = 0.0)]
    pub pass_timeout: f64,
    /// Without --pass-timeout, the limit of a pass is max(this many seconds, 10 × the median of
    /// the job's recent passes).
    #[arg(long, default_value_t = 30.0)]
    pub pass_timeout_floor: f64,
    /// Seconds between SSE keep-alive comments.
    #[arg(long, default_value_t = 15.0)]
    pub sse_keepalive: f64,
    /// Enable the Vulkan validation layer (its messages fail the job).
    #[arg(long)]
    pub validation: bool,
    /// Compile every kernel afresh; keep no kernel cache (default: <data-dir>/kernel-cache).
    #[arg(long)]
    pub no_kernel_cache: bool,
    /// Build these integrators' kernels for the built-in scenes when the device opens, in the
    /// background: auto (all on a GPU, none on a CPU device), all, none, or a list (nee,bdpt).
    #[arg(long, value_name = "LIST", default_value = "auto")]
    pub warm_kernels: String,
    /// Remove finished jobs (record, events, files) that ended longer ago than this (30d, 12h;
    /// 0: keep them however old).
    #[arg(long, value_name = "AGE", default_value = "30d")]
    pub retain_age: String,
    /// Keep at most this many finished jobs, the newest (0: no limit).
    #[arg(long, value_name = "N", default_value_t = 1000)]
    pub retain_jobs: u64,
    /// Remove the oldest finished jobs while the job files exceed this (20GB, 500MB; 0: no limit).
    #[arg(long, value_name = "SIZE", default_value = "20GB")]
    pub retain_size: String,
    /// Prune the event logs of jobs that finished longer ago than this to their final events
    /// (0: at once).
    #[arg(long, value_name = "AGE", default_value = "1h")]
    pub prune_events_after: String,
    /// Refuse new jobs (507) while the data directory's filesystem has less free space than
    /// this; jobs paused for a full disk resume only above it (500MB, 2GB; 0: never refuse).
    #[arg(long, value_name = "SIZE", default_value = "500MB")]
    pub min_free_space: String,
    /// Seconds between free-space checks (which also resume jobs paused for a full disk).
    #[arg(long, default_value_t = 5.0)]
    pub storage_check_interval: f64,
    /// Kernel variants (compiled SPIR-V) kept in memory; the least recently used go first
    /// (the kernel cache on disk keeps every one).
    #[arg(long, value_name = "N", default_value_t = CacheLimits::DEFAULT.kernels)]
    pub cache_kernels: usize,
    /// Most bytes of SPIR-V kept in memory (64MiB, 16MB).
    #[arg(long, value_name = "SIZE", default_value = "64MiB")]
    pub cache_kernel_bytes: String,
    /// Pipelines (the driver's compiled kernels; on lavapipe a few MB of machine code each)
    /// kept per device; the least recently used are destroyed once no job uses them.
    #[arg(long, value_name = "N", default_value_t = CacheLimits::DEFAULT.pipelines)]
    pub cache_pipelines: usize,
    /// vct voxel volumes kept on the device for the next render of the same geometry.
    #[arg(long, value_name = "N", default_value_t = CacheLimits::DEFAULT.volumes)]
    pub cache_volumes: usize,
    /// Render threads in this process: 1, or 0 for the API alone (with PostgreSQL, separate
    /// `candela worker` processes render).
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub workers: u32,
    /// Seconds a claim on a job holds without a heartbeat (renewed every third of it); after
    /// that another process may take the job over from its checkpoint.
    #[arg(long, value_name = "SECONDS", default_value_t = 30.0)]
    pub lease: f64,
    /// This process's name in render leases (default: HOST:serve for a rendering server on
    /// PostgreSQL, else HOST:PID). A restarted process with the same name resumes its jobs at
    /// once; never give two live processes one name.
    #[arg(long, value_name = "NAME")]
    pub worker_id: Option<String>,
    /// On PostgreSQL, cut a job with a sample budget above N samples per pixel into shards of
    /// N sample indices that any worker may render, merged exactly at the end (0: never;
    /// store/shards.rs). The process that first claims a job decides.
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub shard_spp: u32,
    /// How often retention runs (10m, 1h).
    #[arg(long, value_name = "INTERVAL", default_value = "10m")]
    pub gc_interval: String,
}

fn seconds(flag: &str, v: f64) -> Result<Duration, CliError> {
    if v.is_finite() && v > 0.0 && v <= 86400.0 {
        Ok(Duration::from_secs_f64(v))
    } else {
        Err(CliError::input(format!(
            "{flag}: must be a number of seconds in (0, 86400], got {v}"
        )))
    }
}

/// Whether the store has users (then every request needs a token). A SQLite store that does not
/// exist yet has none.
fn has_users(db: &Database) -> bool {
    let exists = match db {
        Database::Sqlite(path) => path.is_file(),
        Database::Postgres(_) => true,
    };
    exists
        && Store::connect(db)
            .and_then(|s| s.user_count())
            .is_ok_and(|n| n > 0)
}

/// The `--database` flag (or `$CANDELA_DATABASE`, or the data directory's SQLite file).
pub fn database(flag: Option<&str>, data_dir: &std::path::Path) -> Result<Database, CliError> {
    Database::parse(flag, data_dir).map_err(|e| CliError::input(format!("--database {e}")))
}

/// Checks the flags and builds the configuration and bind address.
pub(super) fn configure(a: &ServeArgs) -> Result<(ServerConfig, SocketAddr), CliError> {
    let addrs: Vec<SocketAddr> = a
        .bind
        .to_socket_addrs()
        .map_err(|e| CliError::input(format!("--bind {}: {e} (expected HOST:PORT)", a.bind)))?
        .collect();
    let addr = *addrs
        .first()
        .ok_or_else(|| CliError::input(format!("--bind {}: no address", a.bind)))?;
    let token = a
        .token
        .clone()
        .or_else(|| std::env::var("CANDELA_TOKEN").ok())
        .filter(|t| !t.trim().is_empty());
    if token.is_none()
        && !addrs.iter().all(|a| a.ip().is_loopback())
        && !has_users(&database(a.database.as_deref(), &a.data_dir)?)
    {
        return Err(CliError::input(format!(
            "--bind {}: refusing to listen on a non-loopback address without a token; give --token TOKEN (or set CANDELA_TOKEN), or add users (candela users add NAME --role R)",
            a.bind
        )));
    }
    if a.max_active == 0 || a.max_queued == 0 || a.max_spp == 0 || a.max_pixels == 0 {
        return Err(CliError::input(
            "--max-active, --max-queued, --max-spp and --max-pixels must be at least 1",
        ));
    }
    if !(a.max_time.is_finite() && a.max_time > 0.0) {
        return Err(CliError::input(
            "--max-time: must be a positive number of seconds",
        ));
    }
    let mut c = ServerConfig::new(a.data_dir.clone());
    c.token = token;
    c.device = a.device.clone();
    c.validation = a.validation;
    c.snapshot_interval = seconds("--snapshot-interval", a.snapshot_interval)?;
    c.checkpoint_interval = seconds("--checkpoint-interval", a.checkpoint_interval)?;
    c.sse_keepalive = seconds("--sse-keepalive", a.sse_keepalive)?;
    c.pass_target = Duration::from_millis(a.pass_ms.clamp(1, 10_000));
    c.pass_limits.floor = seconds("--pass-timeout-floor", a.pass_timeout_floor)?;
    c.pass_limits.timeout = match a.pass_timeout {
        t if t == 0.0 => None,
        t => Some(seconds("--pass-timeout", t)?),
    };
    c.max_active = a.max_active;
    if a.no_kernel_cache {
        c.kernel_cache = None;
    }
    c.warm_kernels = crate::config::WarmKernels::parse(&a.warm_kernels)
        .map_err(|e| CliError::input(format!("--warm-kernels: {e}")))?;
    c.limits.max_body_bytes = (a.max_body_mb.clamp(1, 1 << 20) << 20) as usize;
    c.limits.max_upload_bytes = c
        .limits
        .max_upload_bytes
        .max(c.limits.max_body_bytes as u64);
    c.limits.film.max_pixels = a.max_pixels;
    c.limits.max_spp = a.max_spp;
    c.limits.max_time_s = a.max_time;
    c.limits.max_triangles = a.max_triangles;
    c.limits.max_unfinished_jobs = a.max_queued;
    c.retention = retention_policy(a)?;
    c.min_free_space = crate::units::parse_size(&a.min_free_space)
        .map_err(|e| CliError::input(format!("--min-free-space: {e}")))?;
    c.storage_check_interval = seconds("--storage-check-interval", a.storage_check_interval)?;
    c.caches = CacheLimits {
        kernels: a.cache_kernels,
        kernel_bytes: crate::units::parse_size(&a.cache_kernel_bytes)
            .map_err(|e| CliError::input(format!("--cache-kernel-bytes: {e}")))?,
        pipelines: a.cache_pipelines,
        volumes: a.cache_volumes,
    };
    c.lease = seconds("--lease", a.lease)?;
    c.heartbeat = c.lease / 3;
    c.shard_spp = a.shard_spp;
    if let Some(id) = a.worker_id.as_ref().filter(|i| !i.trim().is_empty()) {
        c.worker_id = id.trim().to_string();
    }
    if a.workers > 1 {
        return Err(CliError::input(
            "--workers: 0 or 1 (run `candela worker` processes for more)",
        ));
    }
    c.gc_interval = crate::units::parse_duration(&a.gc_interval)
        .ok()
        .filter(|d| !d.is_zero())
        .ok_or_else(|| {
            CliError::input(format!(
                "--gc-interval {}: expected a duration such as 10m",
                a.gc_interval
            ))
        })?;
    Ok((c, addr))
}

/// The `--retain-*` and `--prune-events-after` flags (0: no limit of that kind).
fn retention_policy(a: &ServeArgs) -> Result<crate::config::RetentionPolicy, CliError> {
    use crate::units::{parse_duration, parse_size};
    let age = |flag: &str, v: &str| {
        parse_duration(v)
            .map(|d| Some(d).filter(|d| !d.is_zero()))
            .map_err(|e| CliError::input(format!("{flag}: {e}")))
    };
    Ok(crate::config::RetentionPolicy {
        max_age: age("--retain-age", &a.retain_age)?,
        max_finished: Some(a.retain_jobs).filter(|n| *n > 0),
        max_bytes: parse_size(&a.retain_size)
            .map(|b| Some(b).filter(|b| *b > 0))
            .map_err(|e| CliError::input(format!("--retain-size: {e}")))?,
        prune_events_after: Some(
            parse_duration(&a.prune_events_after)
                .map_err(|e| CliError::input(format!("--prune-events-after: {e}")))?,
        ),
    })
}

/// Applies the retention policy now and every `gc_interval`, until shutdown.
async fn retention_task(st: AppState) {
    let mut stop = st.shutdown.clone();
    loop {
        let (store, config) = (st.store.clone(), st.config.clone());
        let pass = tokio::task::spawn_blocking(move || {
            crate::retention::run(
                &store,
                &config.data_dir,
                &config.retention,
                crate::jobs::model::now_s(),
                false,
            )
        })
        .await;
        match pass {
            Ok(Ok(report)) => {
                for r in &report.removed {
                    st.shared.forget(r.job.id);
                    tracing::info!(job = r.job.id, bytes = r.bytes, reason = %r.reason, "retention removed a job");
                }
                if report.events_pruned > 0 || !report.orphans.is_empty() {
                    tracing::info!(
                        events = report.events_pruned,
                        orphans = report.orphans.len(),
                        "retention pruned"
                    );
                }
            }
            Ok(Err(e)) => tracing::warn!(error = %e, "retention pass"),
            Err(e) => tracing::warn!(error = %e, "retention pass panicked"),
        }
        tokio::select! {
            _ = tokio::time::sleep(st.config.gc_interval) => {}
            _ = stop.wait_for(|s| *s) => return,
        }
    }
}

/// Takes the data directory's lock file: exclusive with SQLite (one server per directory),
/// shared with PostgreSQL (the processes of one farm share the directory, and a SQLite server
/// cannot join them).
pub(super) fn lock_data_dir(dir: &std::path::Path, farm: bool) -> Result<std::fs::File, CliError> {
    let lock = std::fs::File::create(dir.join("lock"))
        .map_err(|e| CliError::failure(format!("--data-dir {}: {e}", dir.display())))?;
    let taken = if farm {
        lock.try_lock_shared().is_ok()
    } else {
        lock.try_lock().is_ok()
    };
    if !taken {
        return Err(CliError::failure(format!(
            "--data-dir {}: another candela server is using it{}",
            dir.display(),
            if farm { " with SQLite" } else { "" }
        )));
    }
    Ok(lock)
}

/// Broadcasts the events other processes of the farm wrote (events.rs): when a notification
/// says there are some (store/notify.rs), else every `poll`.
async fn relay_task(store: Arc<Store>, notified: Arc<tokio::sync::Notify>, poll: Duration) {
    loop {
        let s = store.clone();
        match tokio::task::spawn_blocking(move || s.relay_new_events()).await {
            Ok(Err(e)) => tracing::warn!(error = %e, "relaying events"),
            Err(e) => tracing::warn!(error = %e, "relaying events panicked"),
            Ok(Ok(())) => {}
        }
        tokio::select! {
            _ = notified.notified() => {}
            _ = tokio::time::sleep(poll) => {}
        }
    }
}

/// The relay's poll with LISTEN/NOTIFY running: `$CANDELA_EVENT_POLL_S` seconds (default 1; a
/// test sets it long to see that notifications alone carry the events); a quarter second
/// without.
fn event_poll(listening: bool) -> Duration {
    if !listening {
        return Duration::from_millis(250);
    }
    std::env::var("CANDELA_EVENT_POLL_S")
        .ok()
        .and_then(|v| v.parse::<f64>().ok())
        .filter(|s| s.is_finite() && *s > 0.0)
        .map_or(Duration::from_secs(1), Duration::from_secs_f64)
}

/// Resolves on SIGTERM or Ctrl-C.
pub(super) async fn shutdown_signal() {
    let ctrl_c = async {
        let _ = tokio::signal::ctrl_c().await;
    };
    #[cfg(unix)]
    let term = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    #[cfg(not(unix))]
    let term = std::future::pending::<()>();
    tokio::select! {
        _ = ctrl_c => {},
        _ = term => {},
    }
}

/// With `--device`, checks that such a device exists (when devices can be listed at all).
fn check_device(want: Option<&str>) -> Result<(), CliError> {
    let Some(want) = want else { return Ok(()) };
    let Ok(devices) = renderer::gpu::list_devices() else {
        return Ok(()); // no loader: the worker reports it (health: degraded)
    };
    let w = want.to_lowercase();
    if devices.iter().any(|d| d.name.to_lowercase().contains(&w)) {
        return Ok(());
    }
    let names: Vec<&str> = devices.iter().map(|d| d.name.as_str()).collect();
    Err(CliError::input(format!(
        "--device {want}: no such Vulkan device (available: {})",
        names.join(", ")
    )))
}

pub fn run(a: ServeArgs) -> Result<(), CliError> {
    let (mut config, addr) = configure(&a)?;
    if a.devices.is_some() {
        return Err(CliError::input(
            "--devices: for `candela worker` (a server renders on one device: --device)",
        ));
    }
    check_device(a.device.as_deref())?;
    // Step 1: the data directory (one server per directory), the store, the built-in assets.
    let data_dir = config.data_dir.clone();
    let dir = &data_dir;
    std::fs::create_dir_all(dir.join("jobs"))
        .map_err(|e| CliError::failure(format!("--data-dir {}: {e}", dir.display())))?;
    let db = database(a.database.as_deref(), dir)?;
    let farm = matches!(db, Database::Postgres(_));
    let pg_url = match &db {
        Database::Postgres(url) => Some(url.clone()),
        Database::Sqlite(_) => None,
    };
    if !farm && a.workers == 0 {
        return Err(CliError::input(
            "--workers 0: only with a shared store (--database postgres://…); with SQLite nothing would render the jobs",
        ));
    }
    let lock = lock_data_dir(dir, farm)?;
    // A rendering server of a farm: one per machine and data directory, under a name that
    // stays the same across restarts, so that a restarted server resumes its jobs at once
    // rather than after their leases expire.
    let _serve_lock = if farm && a.workers > 0 && a.worker_id.is_none() {
        let host = crate::config::host_name();
        let path = dir.join(format!("serve-{host}.lock"));
        let f = std::fs::File::create(&path)
            .map_err(|e| CliError::failure(format!("{}: {e}", path.display())))?;
        if f.try_lock().is_err() {
            return Err(CliError::failure(format!(
                "--data-dir {}: another rendering candela serve on {host} uses it (give --workers 0 or --worker-id NAME)",
                dir.display()
            )));
        }
        config.worker_id = format!("{host}:serve");
        Some(f)
    } else {
        None
    };
    if !farm {
        // Alone on the store: one worker, nothing to split jobs for.
        config.shard_spp = 0;
        // Alone on the directory: nobody else's uploads are being unpacked.
        let _ = std::fs::remove_dir_all(config.tmp_dir());
    }
    let _ = std::fs::create_dir_all(config.tmp_dir());
    let mut store =
        Store::connect(&db).map_err(|e| CliError::failure(format!("{}: {e}", db.describe())))?;
    if farm {
        // Workers in other processes write events too: stream them from the table.
        store = store
            .with_event_relay()
            .map_err(|e| CliError::failure(format!("{}: {e}", db.describe())))?;
    } else {
        // Alone on the store: claims of an earlier run of this server are void.
        store
            .clear_leases()
            .map_err(|e| CliError::failure(format!("{}: {e}", db.describe())))?;
    }
    let workers = a.workers;
    crate::builtin_scenes::install(&config.builtin_dir())
        .map_err(|e| CliError::failure(format!("writing the built-in scenes: {e}")))?;
    if let Err(e) = crate::storage::make_reserve(dir) {
        tracing::warn!(error = %e, "could not make the space reserve");
    }
    renderer::gpu::set_cache_limits(config.caches);
    let shared = Shared::default();
    shared.set_storage(crate::storage::status(dir, config.min_free_space));
    let (store, shared, config) = (Arc::new(store), Arc::new(shared), Arc::new(config));

    // Step 2: the runtime, the socket, the worker.
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(std::thread::available_parallelism().map_or(2, |n| n.get().clamp(2, 8)))
        .enable_all()
        .build()
        .map_err(|e| CliError::failure(format!("starting the runtime: {e}")))?;
    rt.block_on(async move {
        let listener = tokio::net::TcpListener::bind(addr)
            .await
            .map_err(|e| CliError::failure(format!("--bind {addr}: {e}")))?;
        let local = listener
            .local_addr()
            .map_err(|e| CliError::failure(e.to_string()))?;
        let (worker, thread) = if workers == 0 {
            shared.set_gpu(crate::shared::GpuStatus {
                state: "none",
                device: None,
                error: None,
            });
            (crate::worker::detached(), None)
        } else {
            let (w, t) = crate::worker::spawn(store.clone(), shared.clone(), config.clone())
                .map_err(|e| CliError::failure(format!("starting the GPU worker: {e}")))?;
            (w, Some(t))
        };
        if let Some(url) = &pg_url {
            // Notifications relay events at once and wake the worker on job changes.
            let notified = Arc::new(tokio::sync::Notify::new());
            let (n, w) = (notified.clone(), worker.clone());
            let listening = crate::store::listen(url, move |note| {
                n.notify_one();
                if note.changes_jobs() {
                    w.wake();
                }
            })
            .is_ok();
            tokio::spawn(relay_task(store.clone(), notified, event_poll(listening)));
        }
        let (stop_tx, stop_rx) = watch::channel(false);
        let stop_watch = stop_rx.clone();
        let state = AppState {
            store,
            shared,
            worker: worker.clone(),
            config,
            shutdown: stop_rx,
        };
        println!("candela: listening on http://{local}");
        use std::io::Write;
        let _ = std::io::stdout().flush();
        tracing::info!(%local, "listening");

        // Step 3: serve until a signal; then stop streams, checkpoint, and leave.
        let (sig_tx, sig_rx) = tokio::sync::oneshot::channel::<()>();
        tokio::spawn(async move {
            shutdown_signal().await;
            tracing::info!("shutting down");
            let _ = stop_tx.send(true);
            let _ = sig_tx.send(());
            // Keep the sender alive so receivers see `true`, not a closed channel.
            std::future::pending::<()>().await;
        });
        tokio::spawn(retention_task(state.clone()));
        let server = axum::serve(listener, app(state)).with_graceful_shutdown(async {
            let _ = sig_rx.await;
        });
        let mut served = tokio::spawn(async move { server.await });
        // Wait for the server to stop; once the signal came, give open requests 10 s.
        let mut stopping = stop_watch;
        let result = tokio::select! {
            r = &mut served => Some(r),
            _ = async {
                let _ = stopping.wait_for(|s| *s).await;
                tokio::time::sleep(Duration::from_secs(10)).await;
            } => None,
        };
        let result = match result {
            Some(r) => r,
            None => {
                tracing::warn!("requests still open after 10 s; closing them");
                served.abort();
                Ok(Ok(()))
            }
        };
        worker.shutdown();
        let joined = tokio::task::spawn_blocking(move || thread.map(|t| t.join())).await;
        if !matches!(joined, Ok(None | Some(Ok(())))) {
            tracing::error!("the GPU worker did not stop cleanly");
        }
        match result {
            Ok(Ok(())) => Ok(()),
            Ok(Err(e)) => Err(CliError::failure(format!("server: {e}"))),
            Err(e) => Err(CliError::failure(format!("server: {e}"))),
        }
    })?;
    drop(lock);
    Ok(())
}
