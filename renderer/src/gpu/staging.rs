//! Host-visible staging memory for uploads and readbacks, kept by the context and reused.
//!
//! Every transfer between host and device goes through a staging buffer. Allocating one per
//! transfer made each large transfer pay for fresh pinned host memory (a 4K film's 265 MB
//! accumulation: ~0.25 s per read-back on an H100, twice that with four devices' workers
//! allocating at once), and a transfer's staging buffer was as large as the transfer (a
//! scene's geometry: gigabytes of host memory). Now each direction has one buffer of at most
//! [`CHUNK`] bytes, made on first use and kept until the context goes; a larger transfer runs
//! as a sequence of copies through it, and the host side of each piece is copied by several
//! threads. A transfer that finds its direction's buffer in use by another thread makes a
//! temporary one rather than wait.

use std::sync::{Arc, Mutex};

use ash::vk;
use gpu_allocator::vulkan::Allocation;
use rayon::prelude::*;

use super::buffer::{allocate, free};
use super::{Buffer, BufferUsage, GpuContext, GpuError, GpuResult};

/// The largest staging buffer, bytes: transfers above it go in pieces.
pub const CHUNK: u64 = 32 << 20;

/// Host copies of at least this many bytes are split over threads.
const PARALLEL_COPY: usize = 4 << 20;

/// A staging buffer: a raw buffer and its memory (not a [`Buffer`], which holds the context
/// and would keep it alive from inside itself).
pub(crate) struct Slot {
    raw: vk::Buffer,
    allocation: Allocation,
    size: u64,
}

/// The context's two staging buffers, one per direction.
#[derive(Default)]
pub(crate) struct StagingPool {
    upload: Mutex<Option<Slot>>,
    readback: Mutex<Option<Slot>>,
}

impl StagingPool {
    /// Frees both buffers (the context's teardown, with the device idle).
    pub(crate) fn release(&self, ctx: &GpuContext) {
        for m in [&self.upload, &self.readback] {
            let slot = m.lock().unwrap_or_else(|e| e.into_inner()).take();
            if let Some(slot) = slot {
                free(ctx, slot.raw, slot.allocation);
            }
        }
    }
}

/// Copies `src` into `dst` (equal lengths), on several threads when large.
fn copy_bytes(dst: &mut [u8], src: &[u8]) {
    if dst.len() < PARALLEL_COPY {
        dst.copy_from_slice(src);
    } else {
        let piece = 1 << 20;
        dst.par_chunks_mut(piece)
            .zip(src.par_chunks(piece))
            .for_each(|(d, s)| d.copy_from_slice(s));
    }
}

/// Records a barrier that makes transfer writes visible to host reads (after the fence: a
/// fence alone does not).
pub(crate) fn host_read_barrier(dev: &ash::Device, cmd: vk::CommandBuffer) {
    let barrier = [vk::MemoryBarrier::default()
        .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
        .dst_access_mask(vk::AccessFlags::HOST_READ)];
    // SAFETY: a plain memory barrier in a recording command buffer.
    unsafe {
        dev.cmd_pipeline_barrier(
            cmd,
            vk::PipelineStageFlags::TRANSFER,
            vk::PipelineStageFlags::HOST,
            vk::DependencyFlags::empty(),
            &barrier,
            &[],
            &[],
        )
    };
}

impl GpuContext {
    /// Runs `f` with a staging buffer of `usage` holding at least `need` bytes: the context's
    /// own (grown when too small), or a temporary one when another thread is using it.
    fn with_staging<R>(
        &self,
        usage: BufferUsage,
        need: u64,
        f: impl FnOnce(vk::Buffer, &mut Allocation) -> GpuResult<R>,
    ) -> GpuResult<R> {
        let (m, name) = match usage {
            BufferUsage::Upload => (&self.staging.upload, "staging upload"),
            _ => (&self.staging.readback, "staging readback"),
        };
        // (A slot poisoned by a panic mid-transfer is still a whole buffer: used again.)
        let guard = match m.try_lock() {
            Ok(g) => Some(g),
            Err(std::sync::TryLockError::Poisoned(e)) => Some(e.into_inner()),
            Err(std::sync::TryLockError::WouldBlock) => None,
        };
        let Some(mut guard) = guard else {
            let (raw, mut allocation, _) = allocate(self, name, need, usage)?;
            let r = f(raw, &mut allocation);
            free(self, raw, allocation);
            return r;
        };
        if guard.as_ref().is_none_or(|s| s.size < need) {
            if let Some(old) = guard.take() {
                free(self, old.raw, old.allocation);
            }
            let (raw, allocation, size) = allocate(self, name, need, usage)?;
            *guard = Some(Slot {
                raw,
                allocation,
                size,
            });
        }
        let slot = guard.as_mut().expect("made above");
        f(slot.raw, &mut slot.allocation)
    }

    /// Copies `bytes` into `dst` at `offset` through staging memory, waiting for completion.
    pub fn upload(self: &Arc<Self>, dst: &Buffer, offset: u64, bytes: &[u8]) -> GpuResult<()> {
        if bytes.is_empty() {
            return Ok(());
        }
        let need = (bytes.len() as u64).min(CHUNK);
        self.with_staging(BufferUsage::Upload, need, |staging, allocation| {
            // Each piece: into the staging memory, then a device copy to its place.
            for (i, piece) in bytes.chunks(CHUNK as usize).enumerate() {
                let mapped = allocation
                    .mapped_slice_mut()
                    .ok_or_else(|| GpuError::Other("upload buffer not mapped".into()))?;
                copy_bytes(&mut mapped[..piece.len()], piece);
                self.one_shot("upload", |dev, cmd| {
                    let region = [vk::BufferCopy {
                        src_offset: 0,
                        dst_offset: offset + i as u64 * CHUNK,
                        size: piece.len() as u64,
                    }];
                    // SAFETY: both buffers are alive until the one-shot submission completes.
                    unsafe { dev.cmd_copy_buffer(cmd, staging, dst.raw, &region) };
                })?;
            }
            Ok(())
        })
    }

    /// Reads `dst.len()` bytes of `src` from `offset` into `dst` through staging memory (one
    /// host copy of each byte: accumulations of a 4K film are hundreds of MB).
    pub(crate) fn download_to(
        self: &Arc<Self>,
        src: &Buffer,
        offset: u64,
        dst: &mut [u8],
    ) -> GpuResult<()> {
        if dst.is_empty() {
            return Ok(());
        }
        let need = (dst.len() as u64).min(CHUNK);
        self.with_staging(BufferUsage::Readback, need, |staging, allocation| {
            // Each piece: a device copy into the staging memory, then out to its place.
            for (i, piece) in dst.chunks_mut(CHUNK as usize).enumerate() {
                self.one_shot("download", |dev, cmd| {
                    let region = [vk::BufferCopy {
                        src_offset: offset + i as u64 * CHUNK,
                        dst_offset: 0,
                        size: piece.len() as u64,
                    }];
                    // SAFETY: both buffers are alive until the one-shot submission completes.
                    unsafe { dev.cmd_copy_buffer(cmd, src.raw, staging, &region) };
                    host_read_barrier(dev, cmd);
                })?;
                let mapped = allocation
                    .mapped_slice()
                    .ok_or_else(|| GpuError::Other("readback buffer not mapped".into()))?;
                let len = piece.len();
                copy_bytes(piece, &mapped[..len]);
            }
            Ok(())
        })
    }
}
