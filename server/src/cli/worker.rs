//! `candela worker`: a render process of a farm, without an HTTP server. It shares the job
//! store (PostgreSQL) and the data directory (the same path on a shared file system) with the
//! API servers (`candela serve --workers 0`) and the other workers, claims runnable jobs with a
//! lease (store/leases.rs), renders them with the server's worker loop (worker/), and writes
//! their events to the store, from which the API servers stream them. On SIGTERM or Ctrl-C it
//! checkpoints its jobs and exits 0; another worker (or itself, restarted) resumes them once
//! their leases expire.
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
    let shared = Shared::default();
    shared.set_storage(crate::storage::status(dir, config.min_free_space));
    let name = config.worker_id.clone();
    // Step 2: the worker loop, until a signal.
    let (worker, thread) =
        crate::worker::spawn(Arc::new(store), Arc::new(shared), Arc::new(config))
            .map_err(|e| CliError::failure(format!("starting the GPU worker: {e}")))?;
    println!("candela: worker {name} rendering");
    use std::io::Write;
    let _ = std::io::stdout().flush();
    tracing::info!(worker = %name, "rendering");
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(|e| CliError::failure(format!("starting the runtime: {e}")))?;
    rt.block_on(shutdown_signal());
    tracing::info!("shutting down");
    // Step 3: checkpoint and leave.
    worker.shutdown();
    if thread.join().is_err() {
        tracing::error!("the GPU worker did not stop cleanly");
    }
    drop(lock);
    Ok(())
}
