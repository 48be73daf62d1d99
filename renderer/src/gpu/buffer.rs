//! GPU buffers allocated with gpu-allocator, and the staging copies that fill and read them.
//! Storage buffers live in device-local memory; uploads and readbacks go through the context's
//! host-visible staging buffers (staging.rs) and one-shot command buffers, so the same path
//! works on lavapipe and NVIDIA.

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
        let (raw, allocation, size) = allocate(ctx, name, size, usage)?;
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

    /// The context it was made on.
    pub(crate) fn context(&self) -> &Arc<GpuContext> {
        &self.ctx
    }

    /// Host-visible bytes (Upload and Readback buffers only).
    pub(crate) fn mapped(&self) -> Option<&[u8]> {
        self.allocation.as_ref().and_then(|a| a.mapped_slice())
    }
}

/// Creates a buffer of `size` bytes (rounded up to at least 16, a multiple of 4) and binds it
/// to fresh memory for `usage`; returns it, its memory and its size.
pub(crate) fn allocate(
    ctx: &GpuContext,
    name: &str,
    size: u64,
    usage: BufferUsage,
) -> GpuResult<(vk::Buffer, Allocation, u64)> {
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
    let raw =
        unsafe { ctx.device.create_buffer(&info, None) }.map_err(GpuError::vk("create buffer"))?;
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
    let bound = unsafe {
        ctx.device
            .bind_buffer_memory(raw, allocation.memory(), allocation.offset())
    };
    if let Err(e) = bound {
        free(ctx, raw, allocation);
        return Err(GpuError::vk("bind buffer memory")(e));
    }
    ctx.set_name(raw, name);
    Ok((raw, allocation, size))
}

/// Destroys a buffer made by [`allocate`] and frees its memory (the GPU must be done with it).
pub(crate) fn free(ctx: &GpuContext, raw: vk::Buffer, allocation: Allocation) {
    // SAFETY: the caller guarantees the GPU no longer uses the buffer.
    unsafe { ctx.device.destroy_buffer(raw, None) };
    if let Ok(mut guard) = ctx.allocator.lock() {
        if let Some(allocator) = guard.as_mut() {
            let _ = allocator.free(allocation);
        }
    }
}

impl Drop for Buffer {
    fn drop(&mut self) {
        // (Callers wait for the GPU before dropping buffers it uses: every submission in this
        // layer is waited on before returning.)
        if let Some(a) = self.allocation.take() {
            free(&self.ctx, self.raw, a);
        }
    }
}

impl GpuContext {
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
