//! PostgreSQL LISTEN/NOTIFY: every transaction that stores a job event also sends a
//! notification on the `candela_events` channel (payload `"<job id> <event kind>"`, delivered
//! at commit), and the processes of a farm listen on it over a connection of their own: an API
//! server relays the new events to its SSE clients at once instead of at its next poll, and a
//! worker looks at the store at once when a job's state or priority changed (submitted, paused,
//! resumed, canceled). Polling stays as the fallback (a notification sent while a listener
//! reconnects is lost; the next poll finds its event).

use std::time::Duration;

use tokio_postgres::{AsyncMessage, NoTls};
use tracing::{info, warn};

use super::db::{params, Conn, Dialect};
use super::StoreError;
use crate::jobs::model::JobId;

/// The channel.
const CHANNEL: &str = "candela_events";

/// A notification: a job has a new event of this kind.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Note {
    pub job: JobId,
    pub kind: String,
}

impl Note {
    /// Whether the job's state or priority changed (a worker should look at the store).
    pub fn changes_jobs(&self) -> bool {
        matches!(self.kind.as_str(), "state" | "priority")
    }
}

/// Inside the transaction that stores event `kind` of job `id`: on PostgreSQL, the
/// notification its commit sends.
pub(super) fn notify_in(c: &mut dyn Conn, id: JobId, kind: &str) -> Result<(), StoreError> {
    if c.dialect() == Dialect::Postgres {
        c.exec(
            "SELECT pg_notify('candela_events', ?1)",
            params![format!("{id} {kind}")],
        )?;
    }
    Ok(())
}

/// Listens on the channel of the PostgreSQL database at `url` on a thread of its own, calling
/// `on_note` for every notification, for ever; reconnects a second after a failure.
pub fn listen(url: &str, on_note: impl Fn(Note) + Send + 'static) -> std::io::Result<()> {
    let url = url.to_string();
    std::thread::Builder::new()
        .name("candela-listen".into())
        .spawn(move || {
            let Ok(rt) = tokio::runtime::Builder::new_current_thread()
                .enable_all()
                .build()
            else {
                return warn!("LISTEN: no runtime; polling only");
            };
            rt.block_on(async move {
                loop {
                    if let Err(e) = listen_once(&url, &on_note).await {
                        warn!(error = %e, "LISTEN {CHANNEL}: reconnecting");
                    }
                    tokio::time::sleep(Duration::from_secs(1)).await;
                }
            })
        })?;
    Ok(())
}

/// One connection's life: LISTEN, then every notification until the connection ends.
async fn listen_once(url: &str, on_note: &impl Fn(Note)) -> Result<(), tokio_postgres::Error> {
    let (client, mut connection) = tokio_postgres::connect(url, NoTls).await?;
    // Step 1: drive the connection, passing its notifications on.
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel();
    let drive = tokio::spawn(async move {
        while let Some(m) = std::future::poll_fn(|cx| connection.poll_message(cx)).await {
            match m {
                Ok(AsyncMessage::Notification(n)) => {
                    let _ = tx.send(n.payload().to_string());
                }
                Ok(_) => {}
                Err(e) => return Err(e),
            }
        }
        Ok(())
    });
    // Step 2: subscribe, then hand each notification over.
    client.batch_execute(&format!("LISTEN {CHANNEL}")).await?;
    info!("listening for job events (LISTEN {CHANNEL})");
    while let Some(payload) = rx.recv().await {
        let mut parts = payload.splitn(2, ' ');
        let job = parts.next().and_then(|j| j.parse().ok());
        if let (Some(job), Some(kind)) = (job, parts.next()) {
            on_note(Note {
                job,
                kind: kind.to_string(),
            });
        }
    }
    drop(client);
    drive.await.unwrap_or(Ok(()))
}
