//! Command recording and submission. `GpuContext::record` gives a `Recorder` that labels every
//! dispatch (debug utils) and brackets it with timestamp queries; after the submission completes
//! the timings come back as `DispatchTiming`s. Each submission is waited on before returning, so
//! resources referenced by it may be dropped afterwards.

use std::ffi::CString;
use std::sync::Arc;

use ash::vk;

use super::{ComputePipeline, GpuContext, GpuError, GpuResult};

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
    /// Records a dispatch of `groups` workgroups with push constants, timestamped and labelled,
    /// followed by a compute-to-compute memory barrier.
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
            let barrier = [vk::MemoryBarrier::default()
                .src_access_mask(vk::AccessFlags::SHADER_WRITE | vk::AccessFlags::TRANSFER_WRITE)
                .dst_access_mask(
                    vk::AccessFlags::SHADER_READ
                        | vk::AccessFlags::SHADER_WRITE
                        | vk::AccessFlags::TRANSFER_READ,
                )];
            dev.cmd_pipeline_barrier(
                self.cmd,
                vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::TRANSFER,
                vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::TRANSFER,
                vk::DependencyFlags::empty(),
                &barrier,
                &[],
                &[],
            );
            if let Some(du) = &self.ctx.debug_utils {
                du.cmd_end_debug_utils_label(self.cmd);
            }
        }
        self.labels.push(label.to_string());
        Ok(())
    }
}

impl GpuContext {
    /// Runs `f` on a fresh command buffer, submits it, waits, and returns the dispatch timings.
    pub fn record<F>(self: &Arc<Self>, max_dispatches: u32, f: F) -> GpuResult<Vec<DispatchTiming>>
    where
        F: FnOnce(&mut Recorder<'_>) -> GpuResult<()>,
    {
        let max_dispatches = max_dispatches.max(1);
        let qci = vk::QueryPoolCreateInfo::default()
            .query_type(vk::QueryType::TIMESTAMP)
            .query_count(2 * max_dispatches);
        // SAFETY: valid device and create info.
        let queries = unsafe { self.device.create_query_pool(&qci, None) }
            .map_err(GpuError::vk("create query pool"))?;
        let mut labels = Vec::new();
        let result = self.submit_with("dispatch", |dev, cmd| {
            // SAFETY: the pool was created above; the reset is recorded before any write.
            unsafe { dev.cmd_reset_query_pool(cmd, queries, 0, 2 * max_dispatches) };
            let mut rec = Recorder {
                ctx: self,
                cmd,
                queries,
                max_dispatches,
                labels: Vec::new(),
            };
            let r = f(&mut rec);
            labels = rec.labels;
            r
        });
        let timings = result.and_then(|()| {
            let n = labels.len();
            let mut ticks = vec![0u64; 2 * n];
            if self.timestamps_supported && n > 0 {
                // SAFETY: the submission completed; queries 0..2n were written.
                unsafe {
                    self.device.get_query_pool_results(
                        queries,
                        0,
                        &mut ticks,
                        vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
                    )
                }
                .map_err(GpuError::vk("read timestamps"))?;
            }
            Ok(labels
                .into_iter()
                .enumerate()
                .map(|(i, label)| {
                    let dt = ticks[2 * i + 1].saturating_sub(ticks[2 * i]) as f64
                        * self.timestamp_period_ns
                        * 1e-6;
                    DispatchTiming { label, gpu_ms: dt }
                })
                .collect())
        });
        // SAFETY: no submission uses the pool any more.
        unsafe { self.device.destroy_query_pool(queries, None) };
        timings
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
