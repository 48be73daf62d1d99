//! What a worker reports of itself with each heartbeat (store/workers.rs): its name, host,
//! device, passes and pixel samples rendered since it started, samples per second since its
//! last report, and each job it holds — the shard, the samples so far, and the seconds since it
//! claimed it (the age of the lease) —, the bytes of finished shards' sums its process keeps
//! for their merge (shard_sums.rs), and its memory (store/workers.rs's `WorkerMemory`): the
//! process's resident size, the pipelines its device keeps and the kernel variants it has
//! compiled since it started.

use std::sync::atomic::Ordering::Relaxed;
use std::time::Instant;

use serde_json::{json, Value};
use tracing::warn;

use super::Worker;
use crate::store::WorkerMemory;

/// The counters at the last report, for the rate.
#[derive(Debug, Clone, Copy)]
pub struct LastReport {
    pub at: Instant,
    pub samples: u64,
}

impl Worker {
    /// The report's figures.
    fn report_json(&mut self) -> Value {
        let samples = self.shared.samples_total.load(Relaxed);
        let passes = self.shared.passes_total.load(Relaxed);
        let now = LastReport {
            at: Instant::now(),
            samples,
        };
        let rate = self.last_report.map_or(0.0, |l| {
            let dt = now.at.duration_since(l.at).as_secs_f64();
            if dt > 0.0 {
                (samples - l.samples) as f64 / dt
            } else {
                0.0
            }
        });
        self.last_report = Some(now);
        let jobs: Vec<Value> = self
            .active
            .iter()
            .map(|(id, j)| {
                json!({
                    "job": id,
                    "shard": j.shard.map(|s| s.range.idx),
                    "spp": j.session.spp(),
                    "target_spp": j.settings.spp,
                    "lease_age_s": j.held_s(),
                })
            })
            .collect();
        json!({
            "host": crate::config::host_name(),
            "pid": std::process::id(),
            "device": self.ctx.as_ref().map(|c| c.info.name.clone()),
            "started_at": self.started_at,
            "passes": passes,
            "samples": samples,
            "samples_per_s": rate,
            "jobs": jobs,
            "kept_shard_bytes": super::shard_sums::kept_bytes(),
        })
    }

    /// The process's memory now.
    fn memory(&self) -> WorkerMemory {
        let (pipelines, _) = self.ctx.as_ref().map_or((0, 0), |c| c.pipeline_usage());
        WorkerMemory {
            rss_bytes: crate::process_memory::resident_bytes(),
            pipelines_cached: Some(pipelines as u64),
            kernel_variants_seen: Some(renderer::gpu::kernel_variants_seen()),
        }
    }

    /// Writes the report to the store (`stopped`: the last one, at shutdown).
    pub(super) fn report(&mut self, stopped: bool) {
        let report = self.report_json();
        let memory = self.memory();
        let lease = self.config.lease.as_secs_f64();
        if let Err(e) =
            self.store
                .report_worker(&self.config.worker_id, lease, stopped, &report, &memory)
        {
            warn!(error = %e, "recording the worker's report");
        }
    }
}
