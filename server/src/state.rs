//! What every HTTP handler can reach (`AppState`): the store, the shared live state, the worker's
//! handle, the configuration and the shutdown signal. Below both the router (`app`) and the
//! handlers (`routes`), which use it.

use std::sync::Arc;

use tokio::sync::watch;

use crate::config::ServerConfig;
use crate::shared::Shared;
use crate::store::Store;
use crate::worker::WorkerHandle;

/// What every handler can reach.
#[derive(Clone)]
pub struct AppState {
    pub store: Arc<Store>,
    pub shared: Arc<Shared>,
    pub worker: WorkerHandle,
    pub config: Arc<ServerConfig>,
    /// Becomes `true` when the server starts shutting down (ends SSE streams and waits).
    pub shutdown: watch::Receiver<bool>,
}

impl AppState {
    /// Whether shutdown has begun.
    pub fn shutting_down(&self) -> bool {
        *self.shutdown.borrow()
    }
}
