//! `candela worker`: a render process of a farm, without an HTTP server. It shares the job
//! store (PostgreSQL) and the data directory (the same path on a shared file system) with the
//! API servers (`candela serve --workers 0`) and the other workers, claims runnable jobs with a
//! lease (store/leases.rs), renders them with the server's worker loop (worker/), and writes
//! their events to the store, from which the API servers stream them. On SIGTERM or Ctrl-C it
//! checkpoints its jobs and exits 0; another worker (or itself, restarted) resumes them once
//! their leases expire.
//!
//! `--devices all|0,1` renders on several devices at once: one worker thread per device, each
//! with its own context, claims and leases, named `NAME/gpu0`, `NAME/gpu1`, … (by position in
//! the list).
//!
//! Prints `candela: worker NAME rendering` on stdout once the store is open.

use std::sync::Arc;

use super::serve::{configure, database, lock_data_dir, shutdown_signal, ServeArgs};
use super::CliError;
use crate::config::Database;
use crate::shared::Shared;
use crate::store::Store;

pub fn run(a: ServeArgs) -> Result<(), CliError> {
    if a.workers != 1 {
        return Err(CliError::input("--workers: not for `candela worker`"));
    }
    let (config, _) = configure(&a)?;
    let dir = &config.data_dir;
    // Step 1: the shared store and data directory.
    let db = database(a.database.as_deref(), dir)?;
    if !matches!(db, Database::Postgres(_)) {
        return Err(CliError::input(
            "candela worker: needs a shared store, --database postgres://… (with SQLite, `candela serve` renders its own jobs)",
        ));
    }
    std::fs::create_dir_all(dir.join("jobs"))
        .map_err(|e| CliError::failure(format!("--data-dir {}: {e}", dir.display())))?;
    let lock = lock_data_dir(dir, true)?;
    let store =
        Store::connect(&db).map_err(|e| CliError::failure(format!("{}: {e}", db.describe())))?;
    crate::builtin_scenes::install(&config.builtin_dir())
        .map_err(|e| CliError::failure(format!("writing the built-in scenes: {e}")))?;
    renderer::gpu::set_cache_limits(config.caches);
    let store = Arc::new(store);
    let name = config.worker_id.clone();
    // Step 2: the worker loops (one per device), until a signal.
    let devices = match &a.devices {
        Some(spec) => super::multi_device::parse_devices(spec)?
            .into_iter()
            .map(Some)
            .collect(),
        None => vec![None],
    };
    // A connection per device (the store serialises its calls on one: the devices' claims,
    // hand-offs and done marks would queue there), all opened before any loop starts.
    let mut stores = vec![store];
    while stores.len() < devices.len() {
        let more = Store::connect(&db)
            .map_err(|e| CliError::failure(format!("{}: {e}", db.describe())))?;
        stores.push(Arc::new(more));
    }
    let mut running = Vec::new();
    for (k, index) in devices.iter().enumerate() {
        let mut c = config.clone();
        if let Some(i) = index {
            c.device_index = Some(*i);
            c.worker_id = format!("{name}/gpu{k}");
        }
        let shared = Shared::default();
        shared.set_storage(crate::storage::status(dir, c.min_free_space));
        let store = stores[k].clone();
        let (worker, thread) = crate::worker::spawn(store, Arc::new(shared), Arc::new(c))
            .map_err(|e| CliError::failure(format!("starting the GPU worker: {e}")))?;
        running.push((worker, thread));
    }
    // A job submitted, paused, resumed, canceled or reprioritised: every loop looks at once
    // (store/notify.rs; else within a second).
    if let Database::Postgres(url) = &db {
        let handles: Vec<_> = running.iter().map(|(w, _)| w.clone()).collect();
        let listened = crate::store::listen(url, move |note| {
            if note.changes_jobs() {
                handles.iter().for_each(|h| h.wake());
            }
        });
        if let Err(e) = listened {
            tracing::warn!(error = %e, "LISTEN: not started; polling only");
        }
    }
    println!("candela: worker {name} rendering");
    use std::io::Write;
    let _ = std::io::stdout().flush();
    tracing::info!(worker = %name, devices = running.len(), "rendering");
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(|e| CliError::failure(format!("starting the runtime: {e}")))?;
    rt.block_on(shutdown_signal());
    tracing::info!("shutting down");
    // Step 3: checkpoint and leave.
    for (worker, _) in &running {
        worker.shutdown();
    }
    for (_, thread) in running {
        if thread.join().is_err() {
            tracing::error!("a GPU worker did not stop cleanly");
        }
    }
    drop(lock);
    Ok(())
}
