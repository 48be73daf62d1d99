//! GPU buffers allocated with gpu-allocator, and the staging copies that fill and read them.
//! Storage buffers live in device-local memory; uploads and readbacks go through host-visible
//! staging buffers and a one-shot command buffer, so the same path works on lavapipe and NVIDIA.

use std::sync::Arc;

use ash::vk;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
use gpu_allocator::MemoryLocation;

use super::{GpuContext, GpuError, GpuResult};

/// What a buffer is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BufferUsage {
    /// Device-local storage buffer (kernels read and write it).
    Storage,
    /// Host-visible, written by the CPU, copied to the GPU.
    Upload,
    /// Host-visible, copied into from the GPU, read by the CPU.
    Readback,
}

/// A buffer and its memory; freed on drop.
pub struct Buffer {
    ctx: Arc<GpuContext>,
    pub(crate) raw: vk::Buffer,
    allocation: Option<Allocation>,
    /// Size in bytes (at least 16: Vulkan forbids empty buffers, absent data gets a tiny one).
    pub size: u64,
    pub name: String,
}

impl Buffer {
    /// Allocates an uninitialised buffer of `size` bytes (rounded up to at least 16).
    pub fn new(
        ctx: &Arc<GpuContext>,
        name: &str,
        size: u64,
        usage: BufferUsage,
    ) -> GpuResult<Buffer> {
        let size = size.max(16).next_multiple_of(4);
        let (vk_usage, location) = match usage {
            BufferUsage::Storage => (
                vk::BufferUsageFlags::STORAGE_BUFFER
                    | vk::BufferUsageFlags::TRANSFER_DST
                    | vk::BufferUsageFlags::TRANSFER_SRC,
                MemoryLocation::GpuOnly,
            ),
            BufferUsage::Upload => (vk::BufferUsageFlags::TRANSFER_SRC, MemoryLocation::CpuToGpu),
            BufferUsage::Readback => (vk::BufferUsageFlags::TRANSFER_DST, MemoryLocation::GpuToCpu),
        };
        let info = vk::BufferCreateInfo::default()
            .size(size)
            .usage(vk_usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        // SAFETY: valid device and create info.
        let raw = unsafe { ctx.device.create_buffer(&info, None) }
            .map_err(GpuError::vk("create buffer"))?;
        // SAFETY: `raw` was just created on this device.
        let requirements = unsafe { ctx.device.get_buffer_memory_requirements(raw) };
        let alloc = {
            let mut guard = ctx
                .allocator
                .lock()
                .map_err(|_| GpuError::Other("allocator poisoned".into()))?;
            let allocator = guard
                .as_mut()
                .ok_or_else(|| GpuError::Other("allocator gone".into()))?;
            allocator.allocate(&AllocationCreateDesc {
                name,
                requirements,
                location,
                linear: true,
                allocation_scheme: AllocationScheme::GpuAllocatorManaged,
            })
        };
        let allocation = match alloc {
            Ok(a) => a,
            Err(e) => {
                // SAFETY: the buffer has no memory bound and is not in use.
                unsafe { ctx.device.destroy_buffer(raw, None) };
                return Err(GpuError::Alloc {
                    name: name.to_string(),
                    message: e.to_string(),
                });
            }
        };
        // SAFETY: memory comes from a compatible type, offset respects the requirements.
        unsafe {
            ctx.device
                .bind_buffer_memory(raw, allocation.memory(), allocation.offset())
        }
        .map_err(GpuError::vk("bind buffer memory"))?;
        ctx.set_name(raw, name);
        Ok(Buffer {
            ctx: ctx.clone(),
            raw,
            allocation: Some(allocation),
            size,
            name: name.to_string(),
        })
    }

    /// Creates a device-local storage buffer holding `data` (or 16 zero bytes when empty).
    pub fn from_slice<T: bytemuck::Pod>(
        ctx: &Arc<GpuContext>,
        name: &str,
        data: &[T],
    ) -> GpuResult<Buffer> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let buf = Buffer::new(ctx, name, bytes.len() as u64, BufferUsage::Storage)?;
        if bytes.is_empty() {
            ctx.fill_zero(&buf)?;
        } else {
            ctx.upload(&buf, 0, bytes)?;
        }
        Ok(buf)
    }

    /// Host-visible bytes (Upload and Readback buffers only).
    pub(crate) fn mapped(&self) -> Option<&[u8]> {
        self.allocation.as_ref().and_then(|a| a.mapped_slice())
    }

    pub(crate) fn mapped_mut(&mut self) -> Option<&mut [u8]> {
        self.allocation.as_mut().and_then(|a| a.mapped_slice_mut())
    }
}

impl Drop for Buffer {
    fn drop(&mut self) {
        // SAFETY: callers wait for the GPU before dropping buffers it uses (every submission in
        // this layer is waited on before returning).
        unsafe { self.ctx.device.destroy_buffer(self.raw, None) };
        if let (Some(a), Ok(mut guard)) = (self.allocation.take(), self.ctx.allocator.lock()) {
            if let Some(allocator) = guard.as_mut() {
                let _ = allocator.free(a);
            }
        }
    }
}

impl GpuContext {
    /// Copies `bytes` into `dst` at `offset` through a staging buffer, waiting for completion.
    pub fn upload(self: &Arc<Self>, dst: &Buffer, offset: u64, bytes: &[u8]) -> GpuResult<()> {
        if bytes.is_empty() {
            return Ok(());
        }
        let mut staging = Buffer::new(
            self,
            "staging upload",
            bytes.len() as u64,
            BufferUsage::Upload,
        )?;
        staging
            .mapped_mut()
            .ok_or_else(|| GpuError::Other("upload buffer not mapped".into()))?[..bytes.len()]
            .copy_from_slice(bytes);
        self.one_shot("upload", |dev, cmd| {
            let region = [vk::BufferCopy {
                src_offset: 0,
                dst_offset: offset,
                size: bytes.len() as u64,
            }];
            // SAFETY: both buffers are alive until the one-shot submission completes.
            unsafe { dev.cmd_copy_buffer(cmd, staging.raw, dst.raw, &region) };
        })
    }

    /// Fills a buffer with zeros on the GPU.
    pub fn fill_zero(self: &Arc<Self>, dst: &Buffer) -> GpuResult<()> {
        self.one_shot("fill zero", |dev, cmd| {
            // SAFETY: `dst` is alive until the submission completes.
            unsafe { dev.cmd_fill_buffer(cmd, dst.raw, 0, vk::WHOLE_SIZE, 0) };
        })
    }

    /// Reads `len` bytes of `src` from `offset` back to the host.
    pub fn download(self: &Arc<Self>, src: &Buffer, offset: u64, len: u64) -> GpuResult<Vec<u8>> {
        let mut out = vec![0u8; len as usize];
        self.download_to(src, offset, &mut out)?;
        Ok(out)
    }

    /// Reads `dst.len()` bytes of `src` from `offset` into `dst` (one copy out of the staging
    /// buffer, none more: accumulations of a 4K film are hundreds of MB).
    fn download_to(self: &Arc<Self>, src: &Buffer, offset: u64, dst: &mut [u8]) -> GpuResult<()> {
        let len = dst.len() as u64;
        if len == 0 {
            return Ok(());
        }
        let staging = Buffer::new(self, "staging readback", len, BufferUsage::Readback)?;
        self.one_shot("download", |dev, cmd| {
            let region = [vk::BufferCopy {
                src_offset: offset,
                dst_offset: 0,
                size: len,
            }];
            // SAFETY: both buffers are alive until the one-shot submission completes.
            unsafe { dev.cmd_copy_buffer(cmd, src.raw, staging.raw, &region) };
        })?;
        let m = staging
            .mapped()
            .ok_or_else(|| GpuError::Other("readback buffer not mapped".into()))?;
        dst.copy_from_slice(&m[..len as usize]);
        Ok(())
    }

    /// Reads the first `dst.len()` elements of `src` into `dst`.
    pub fn download_into<T: bytemuck::Pod>(
        self: &Arc<Self>,
        src: &Buffer,
        dst: &mut [T],
    ) -> GpuResult<()> {
        self.download_to(src, 0, bytemuck::cast_slice_mut(dst))
    }

    /// Reads a whole buffer back as a vector of `T`.
    pub fn download_vec<T: bytemuck::Pod>(
        self: &Arc<Self>,
        src: &Buffer,
        count: usize,
    ) -> GpuResult<Vec<T>> {
        let mut out = vec![T::zeroed(); count];
        self.download_into(src, &mut out)?;
        Ok(out)
    }
}
