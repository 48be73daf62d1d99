//! Device loss (`VK_ERROR_DEVICE_LOST`, real or injected): no job fails for it. The worker drops
//! every session and the device, creates the device again (kernels and pipelines are rebuilt
//! with it, from the kernel cache on disk), and re-admits every active job from its last
//! checkpoint; sample indices key the random numbers, so the passes lost are rendered again
//! exactly and each job still ends at exactly its spp.
//!
//! A job whose own work loses the device [`MAX_LOSSES_IN_A_ROW`] times without a pass
//! completing in between is failed with that reason, so a scene that crashes the GPU cannot
//! keep the others in a rebuild loop.
//!
//! Test hook: with `CANDELA_TEST_DEVICE_LOSS_FILE=PATH`, a pass that completes while PATH exists
//! reports a device loss instead (and PATH is removed), so a test can lose the device when it
//! chooses, mid-job.

use std::path::PathBuf;
use std::sync::atomic::Ordering::Relaxed;

use renderer::gpu::GpuError;
use renderer::render::RenderError;
use tracing::warn;

use super::Worker;
use crate::jobs::model::JobId;

/// Losses during one job's work, with no pass of it completing between them, before it fails.
pub const MAX_LOSSES_IN_A_ROW: u32 = 3;

/// The test hook's trigger file, from `CANDELA_TEST_DEVICE_LOSS_FILE`.
pub fn trigger_from_env() -> Option<PathBuf> {
    std::env::var_os("CANDELA_TEST_DEVICE_LOSS_FILE").map(PathBuf::from)
}

/// Whether `e` is a lost device.
pub fn is_device_lost(e: &RenderError) -> bool {
    matches!(e, RenderError::Gpu(g) if g.is_device_lost())
}

impl Worker {
    /// The test hook: a device loss in place of `result` when the trigger file exists.
    pub(super) fn injected_loss<T>(
        &self,
        result: Result<T, RenderError>,
    ) -> Result<T, RenderError> {
        match &self.loss_trigger {
            Some(path) if std::fs::remove_file(path).is_ok() => {
                Err(RenderError::Gpu(GpuError::DeviceLost {
                    stage: "render pass (injected by CANDELA_TEST_DEVICE_LOSS_FILE)",
                }))
            }
            _ => result,
        }
    }

    /// The device was lost during job `id`'s `stage`: rebuild it and resume every job from its
    /// checkpoint, unless this job keeps losing it.
    pub(super) fn device_lost(&mut self, id: JobId, why: &str) {
        self.shared.device_losses.fetch_add(1, Relaxed);
        let n = self.losses.entry(id).or_insert(0);
        *n += 1;
        let n = *n;
        warn!(job = id, losses_in_a_row = n, why, "device lost");
        if n >= MAX_LOSSES_IN_A_ROW {
            self.losses.remove(&id);
            self.fail(
                id,
                format!(
                    "{why}; the device was lost {n} times in a row during this job's passes, \
                     so it was stopped to let the other jobs run"
                ),
            );
        }
        self.reset_device(why);
    }
}
