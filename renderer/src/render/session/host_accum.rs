//! A session's accumulation left in host-visible memory by one device copy: what
//! [`RenderSession::accumulation`] returns, without the host copy out of the staging memory,
//! in a buffer that any thread may read and that can be used again. A farm shard's final sums
//! go to its file this way, read by the writer's thread straight from that memory while the
//! device renders the next shard (server/src/worker/shard_write.rs).

use ash::vk;

use super::RenderSession;
use crate::error::RenderError;
use crate::gpu::{Buffer, BufferUsage};

/// The accumulation in a host-visible buffer, [`RenderSession::accumulation`]'s layout.
pub struct HostAccumulation {
    buffer: Buffer,
    entries: usize,
}

impl HostAccumulation {
    /// The entries, as [`RenderSession::accumulation`] returns them.
    pub fn as_slice(&self) -> &[[f32; 4]] {
        let bytes = self.buffer.mapped().expect("a readback buffer is mapped");
        bytemuck::cast_slice(&bytes[..self.entries * 16])
    }

    /// Whether it was made on `ctx` (a buffer of a lost device is not used again).
    pub fn is_of(&self, ctx: &std::sync::Arc<crate::gpu::GpuContext>) -> bool {
        std::sync::Arc::ptr_eq(self.buffer.context(), ctx)
    }

    /// Entries held.
    pub fn len(&self) -> usize {
        self.entries
    }

    /// Whether it holds no entries.
    pub fn is_empty(&self) -> bool {
        self.entries == 0
    }
}

impl RenderSession {
    /// The accumulation (after the queued passes) copied on the device into host-visible
    /// memory: `reuse`'s buffer when it is of this device and large enough, else a new one.
    pub fn accumulation_to_host(
        &mut self,
        reuse: Option<HostAccumulation>,
    ) -> Result<HostAccumulation, RenderError> {
        self.settle()?;
        let entries = self.accumulation_len();
        let bytes = entries as u64 * 16;
        // Step 1: the buffer.
        let buffer = match reuse {
            Some(h)
                if std::sync::Arc::ptr_eq(h.buffer.context(), &self.ctx)
                    && h.buffer.size >= bytes =>
            {
                h.buffer
            }
            _ => Buffer::new(
                &self.ctx,
                "accumulation to host",
                bytes,
                BufferUsage::Readback,
            )?,
        };
        // Step 2: each part copied to its place (accumulation, extra buffers, odd half), then
        // made visible to the host.
        let n = (self.width * self.height) as u64 * 16;
        let mut parts = vec![(&self.accum, n)];
        for (e, b) in &self.extra {
            parts.push((b, n * e.entries_per_pixel as u64));
        }
        parts.push((&self.accum_odd, n));
        self.ctx.one_shot("accumulation to host", |dev, cmd| {
            let mut at = 0;
            for (src, size) in &parts {
                let region = [vk::BufferCopy {
                    src_offset: 0,
                    dst_offset: at,
                    size: *size,
                }];
                // SAFETY: both buffers are alive until the one-shot submission completes.
                unsafe { dev.cmd_copy_buffer(cmd, src.raw, buffer.raw, &region) };
                at += size;
            }
            crate::gpu::host_read_barrier(dev, cmd);
        })?;
        Ok(HostAccumulation { buffer, entries })
    }
}
