//! Command recording and submission. A `Recorder` labels every dispatch (debug utils) and
//! brackets it with timestamp queries; after the submission completes the timings come back as
//! `DispatchTiming`s. `GpuContext::record` submits and waits (resources it used may be dropped
//! afterwards); a `Frame` submits without waiting, for passes queued back to back.

use std::ffi::CString;
use std::sync::Arc;

use ash::vk;

use super::{Buffer, ComputePipeline, GpuContext, GpuError, GpuResult};

/// How long one labelled dispatch took on the GPU.
#[derive(Debug, Clone, serde::Serialize)]
pub struct DispatchTiming {
    pub label: String,
    /// GPU time in milliseconds (0 where the queue has no timestamps).
    pub gpu_ms: f64,
}

/// Records dispatches into one command buffer.
pub struct Recorder<'a> {
    ctx: &'a GpuContext,
    cmd: vk::CommandBuffer,
    queries: vk::QueryPool,
    max_dispatches: u32,
    labels: Vec<String>,
}

impl Recorder<'_> {
    /// Copies `size` bytes of `src` (from `src_offset`) into `dst` (at `dst_offset`), ordered
    /// after every earlier command and before every later one and the host's reads.
    pub fn copy(
        &mut self,
        src: &Buffer,
        src_offset: u64,
        dst: &Buffer,
        dst_offset: u64,
        size: u64,
    ) {
        let region = [vk::BufferCopy {
            src_offset,
            dst_offset,
            size,
        }];
        // SAFETY: recording state; both buffers outlive the submission (the caller holds them).
        unsafe {
            self.ctx
                .device
                .cmd_copy_buffer(self.cmd, src.raw, dst.raw, &region)
        };
        full_barrier(&self.ctx.device, self.cmd);
    }

    /// Fills `dst` with zeros, ordered like [`Recorder::copy`].
    pub fn fill_zero(&mut self, dst: &Buffer) {
        // SAFETY: recording state; the buffer outlives the submission.
        unsafe {
            self.ctx
                .device
                .cmd_fill_buffer(self.cmd, dst.raw, 0, vk::WHOLE_SIZE, 0)
        };
        full_barrier(&self.ctx.device, self.cmd);
    }

    /// Records a dispatch of `groups` workgroups with push constants, timestamped and labelled,
    /// followed by a memory barrier (later dispatches, copies and host reads see its writes).
    pub fn dispatch(
        &mut self,
        pipeline: &ComputePipeline,
        push: &[u8],
        groups: [u32; 3],
        label: &str,
    ) -> GpuResult<()> {
        let n = self.labels.len() as u32;
        if n >= self.max_dispatches {
            return Err(GpuError::Other(format!(
                "too many dispatches in one submission (max {})",
                self.max_dispatches
            )));
        }
        let dev = &self.ctx.device;
        let clabel = CString::new(label).unwrap_or_default();
        // SAFETY: the command buffer is in the recording state; the pipeline, its layout and
        // descriptor set outlive the submission (the caller holds them across `record`).
        unsafe {
            if let Some(du) = &self.ctx.debug_utils {
                du.cmd_begin_debug_utils_label(
                    self.cmd,
                    &vk::DebugUtilsLabelEXT::default().label_name(&clabel),
                );
            }
            if self.ctx.timestamps_supported {
                dev.cmd_write_timestamp(
                    self.cmd,
                    vk::PipelineStageFlags::TOP_OF_PIPE,
                    self.queries,
                    2 * n,
                );
            }
            dev.cmd_bind_pipeline(self.cmd, vk::PipelineBindPoint::COMPUTE, pipeline.pipeline);
            dev.cmd_bind_descriptor_sets(
                self.cmd,
                vk::PipelineBindPoint::COMPUTE,
                pipeline.layout,
                0,
                &[pipeline.set],
                &[],
            );
            if !push.is_empty() {
                dev.cmd_push_constants(
                    self.cmd,
                    pipeline.layout,
                    vk::ShaderStageFlags::COMPUTE,
                    0,
                    push,
                );
            }
            dev.cmd_dispatch(self.cmd, groups[0], groups[1], groups[2]);
            if self.ctx.timestamps_supported {
                dev.cmd_write_timestamp(
                    self.cmd,
                    vk::PipelineStageFlags::BOTTOM_OF_PIPE,
                    self.queries,
                    2 * n + 1,
                );
            }
            full_barrier(dev, self.cmd);
            if let Some(du) = &self.ctx.debug_utils {
                du.cmd_end_debug_utils_label(self.cmd);
            }
        }
        self.labels.push(label.to_string());
        Ok(())
    }
}

/// A reusable command buffer with its fence and timestamp queries: record and submit without
/// waiting ([`Frame::submit`]), collect the timings later ([`Frame::wait`]). Render sessions
/// keep two, so the next pass is queued while the last one runs and the GPU never waits for
/// the CPU between passes.
pub struct Frame {
    ctx: Arc<GpuContext>,
    pool: vk::CommandPool,
    cmd: vk::CommandBuffer,
    fence: vk::Fence,
    queries: vk::QueryPool,
    /// Dispatches the query pool has room for.
    query_cap: u32,
    labels: Vec<String>,
    pending: bool,
}

/// Barrier mask pair: everything compute shaders and transfers write, before anything reads or
/// writes again (earlier submissions on the queue included).
fn full_barrier(dev: &ash::Device, cmd: vk::CommandBuffer) {
    let barrier = [vk::MemoryBarrier::default()
        .src_access_mask(vk::AccessFlags::SHADER_WRITE | vk::AccessFlags::TRANSFER_WRITE)
        .dst_access_mask(
            vk::AccessFlags::SHADER_READ
                | vk::AccessFlags::SHADER_WRITE
                | vk::AccessFlags::TRANSFER_READ
                | vk::AccessFlags::TRANSFER_WRITE
                | vk::AccessFlags::HOST_READ,
        )];
    // SAFETY: `cmd` is in the recording state.
    unsafe {
        dev.cmd_pipeline_barrier(
            cmd,
            vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::TRANSFER,
            vk::PipelineStageFlags::COMPUTE_SHADER
                | vk::PipelineStageFlags::TRANSFER
                | vk::PipelineStageFlags::HOST,
            vk::DependencyFlags::empty(),
            &barrier,
            &[],
            &[],
        )
    };
}

impl Frame {
    /// A frame with its own command pool, buffer, fence and query pool.
    pub fn new(ctx: &Arc<GpuContext>) -> GpuResult<Frame> {
        let dev = &ctx.device;
        let mut f = Frame {
            ctx: ctx.clone(),
            pool: vk::CommandPool::null(),
            cmd: vk::CommandBuffer::null(),
            fence: vk::Fence::null(),
            queries: vk::QueryPool::null(),
            query_cap: 0,
            labels: Vec::new(),
            pending: false,
        };
        let pci = vk::CommandPoolCreateInfo::default()
            .queue_family_index(ctx.queue_family)
            .flags(vk::CommandPoolCreateFlags::TRANSIENT);
        // SAFETY: valid device; every handle is destroyed in Drop (null ones are ignored).
        unsafe {
            f.pool = dev
                .create_command_pool(&pci, None)
                .map_err(GpuError::vk("create command pool"))?;
            let ai = vk::CommandBufferAllocateInfo::default()
                .command_pool(f.pool)
                .level(vk::CommandBufferLevel::PRIMARY)
                .command_buffer_count(1);
            f.cmd = dev
                .allocate_command_buffers(&ai)
                .map_err(GpuError::vk("allocate command buffer"))?[0];
            f.fence = dev
                .create_fence(&vk::FenceCreateInfo::default(), None)
                .map_err(GpuError::vk("create fence"))?;
        }
        Ok(f)
    }

    /// Whether a submission of this frame has not been waited for.
    pub fn pending(&self) -> bool {
        self.pending
    }

    /// Records `f` (at most `max_dispatches` dispatches) and submits it without waiting; a
    /// barrier first orders it after everything submitted before on the queue.
    pub fn submit<F>(&mut self, max_dispatches: u32, f: F) -> GpuResult<()>
    where
        F: FnOnce(&mut Recorder<'_>) -> GpuResult<()>,
    {
        if self.pending {
            self.wait()?;
        }
        let max_dispatches = max_dispatches.max(1);
        let dev = &self.ctx.device;
        if self.query_cap < max_dispatches {
            let qci = vk::QueryPoolCreateInfo::default()
                .query_type(vk::QueryType::TIMESTAMP)
                .query_count(2 * max_dispatches);
            // SAFETY: the old pool is not in use (no pending submission); valid create info.
            unsafe {
                dev.destroy_query_pool(self.queries, None);
                self.queries = vk::QueryPool::null();
                self.queries = dev
                    .create_query_pool(&qci, None)
                    .map_err(GpuError::vk("create query pool"))?;
            }
            self.query_cap = max_dispatches;
        }
        // SAFETY: the pool's command buffer is not pending; it is reset and re-recorded.
        unsafe {
            dev.reset_command_pool(self.pool, vk::CommandPoolResetFlags::empty())
                .map_err(GpuError::vk("reset command pool"))?;
            dev.begin_command_buffer(
                self.cmd,
                &vk::CommandBufferBeginInfo::default()
                    .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
            )
            .map_err(GpuError::vk("begin command buffer"))?;
            dev.cmd_reset_query_pool(self.cmd, self.queries, 0, 2 * self.query_cap);
        }
        full_barrier(dev, self.cmd);
        let mut rec = Recorder {
            ctx: &self.ctx,
            cmd: self.cmd,
            queries: self.queries,
            max_dispatches,
            labels: Vec::new(),
        };
        let recorded = f(&mut rec);
        self.labels = rec.labels;
        // SAFETY: recording state; ended even after a failed recording, then not submitted.
        let ended = unsafe { dev.end_command_buffer(self.cmd) };
        recorded?;
        ended.map_err(GpuError::vk("end command buffer"))?;
        let cmds = [self.cmd];
        let submit = [vk::SubmitInfo::default().command_buffers(&cmds)];
        let _queue = self
            .ctx
            .queue_lock
            .lock()
            .map_err(|_| GpuError::Other("queue lock poisoned".into()))?;
        // SAFETY: the fence is unsignalled (reset after its last wait) and the command buffer
        // executable; the queue lock serialises access to the queue.
        unsafe { dev.queue_submit(self.ctx.queue, &submit, self.fence) }
            .map_err(GpuError::vk("dispatch"))?;
        self.pending = true;
        Ok(())
    }

    /// Waits for the last submission and returns its dispatch timings.
    pub fn wait(&mut self) -> GpuResult<Vec<DispatchTiming>> {
        if !self.pending {
            return Ok(Vec::new());
        }
        let dev = &self.ctx.device;
        // SAFETY: the fence belongs to this device and was submitted.
        let waited = unsafe { dev.wait_for_fences(&[self.fence], true, u64::MAX) };
        self.pending = false;
        waited.map_err(GpuError::vk("dispatch"))?;
        // SAFETY: signalled and no longer in use.
        unsafe { dev.reset_fences(&[self.fence]) }.map_err(GpuError::vk("reset fence"))?;
        let labels = std::mem::take(&mut self.labels);
        let n = labels.len();
        let mut ticks = vec![0u64; 2 * n];
        if self.ctx.timestamps_supported && n > 0 {
            // SAFETY: the submission completed; queries 0..2n were written.
            unsafe {
                dev.get_query_pool_results(
                    self.queries,
                    0,
                    &mut ticks,
                    vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
                )
            }
            .map_err(GpuError::vk("read timestamps"))?;
        }
        let period = self.ctx.timestamp_period_ns;
        Ok(labels
            .into_iter()
            .enumerate()
            .map(|(i, label)| {
                let dt = ticks[2 * i + 1].saturating_sub(ticks[2 * i]) as f64 * period * 1e-6;
                DispatchTiming { label, gpu_ms: dt }
            })
            .collect())
    }
}

impl Drop for Frame {
    fn drop(&mut self) {
        let dev = &self.ctx.device;
        // SAFETY: a pending submission is waited for first (or the device idled when that
        // fails), so nothing uses these objects when they are destroyed.
        unsafe {
            if self.pending && dev.wait_for_fences(&[self.fence], true, u64::MAX).is_err() {
                let _ = dev.device_wait_idle();
            }
            dev.destroy_query_pool(self.queries, None);
            dev.destroy_fence(self.fence, None);
            dev.destroy_command_pool(self.pool, None);
        }
    }
}

impl GpuContext {
    /// Runs `f` on a fresh command buffer, submits it, waits, and returns the dispatch timings.
    pub fn record<F>(self: &Arc<Self>, max_dispatches: u32, f: F) -> GpuResult<Vec<DispatchTiming>>
    where
        F: FnOnce(&mut Recorder<'_>) -> GpuResult<()>,
    {
        let mut frame = Frame::new(self)?;
        frame.submit(max_dispatches, f)?;
        frame.wait()
    }

    /// Records a one-shot command buffer with `f`, submits and waits.
    pub(crate) fn one_shot<F>(self: &Arc<Self>, what: &'static str, f: F) -> GpuResult<()>
    where
        F: FnOnce(&ash::Device, vk::CommandBuffer),
    {
        self.submit_with(what, |dev, cmd| {
            f(dev, cmd);
            Ok(())
        })
    }

    fn submit_with<F>(&self, what: &'static str, f: F) -> GpuResult<()>
    where
        F: FnOnce(&ash::Device, vk::CommandBuffer) -> GpuResult<()>,
    {
        let dev = &self.device;
        let pci = vk::CommandPoolCreateInfo::default()
            .queue_family_index(self.queue_family)
            .flags(vk::CommandPoolCreateFlags::TRANSIENT);
        // SAFETY: valid device; the pool is destroyed at the end of this function after the wait.
        let pool = unsafe { dev.create_command_pool(&pci, None) }
            .map_err(GpuError::vk("create command pool"))?;
        let run = || -> GpuResult<()> {
            let ai = vk::CommandBufferAllocateInfo::default()
                .command_pool(pool)
                .level(vk::CommandBufferLevel::PRIMARY)
                .command_buffer_count(1);
            // SAFETY: valid pool.
            let cmd = unsafe { dev.allocate_command_buffers(&ai) }
                .map_err(GpuError::vk("allocate command buffer"))?[0];
            let bi = vk::CommandBufferBeginInfo::default()
                .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
            // SAFETY: freshly allocated command buffer.
            unsafe { dev.begin_command_buffer(cmd, &bi) }
                .map_err(GpuError::vk("begin command buffer"))?;
            f(dev, cmd)?;
            // SAFETY: recording state.
            unsafe { dev.end_command_buffer(cmd) }.map_err(GpuError::vk("end command buffer"))?;
            // SAFETY: valid device.
            let fence = unsafe { dev.create_fence(&vk::FenceCreateInfo::default(), None) }
                .map_err(GpuError::vk("create fence"))?;
            let cmds = [cmd];
            let submit = [vk::SubmitInfo::default().command_buffers(&cmds)];
            let r = {
                let _queue = self
                    .queue_lock
                    .lock()
                    .map_err(|_| GpuError::Other("queue lock poisoned".into()))?;
                // SAFETY: the command buffer is executable; the fence is unsignalled; the queue
                // lock serialises access to the queue.
                unsafe { dev.queue_submit(self.queue, &submit, fence) }.map_err(GpuError::vk(what))
            }
            // SAFETY: the fence belongs to this device.
            .and_then(|()| {
                unsafe { dev.wait_for_fences(&[fence], true, u64::MAX) }.map_err(GpuError::vk(what))
            });
            // SAFETY: the fence is no longer in use (waited, or the submit failed).
            unsafe { dev.destroy_fence(fence, None) };
            r
        };
        let r = run();
        if r.is_err() {
            // SAFETY: make sure nothing still runs before the pool goes away.
            let _ = unsafe { dev.device_wait_idle() };
        }
        // SAFETY: all command buffers of the pool have completed.
        unsafe { dev.destroy_command_pool(pool, None) };
        r
    }
}
