//! GPU buffers that free their memory and handle on `Drop`.

use super::context::Context;
use crate::error::{Result, VkContext};
use ash::vk;
use gpu_allocator::MemoryLocation;
use gpu_allocator::vulkan::Allocation;
use std::sync::Arc;

/// A storage buffer (and transfer source/destination) with its memory.
pub struct Buffer {
    ctx: Arc<Context>,
    pub(crate) handle: vk::Buffer,
    allocation: Option<Allocation>,
    size: u64,
}

impl Buffer {
    /// A buffer of `size` bytes (at least 4) in `location`.
    pub fn new(ctx: &Arc<Context>, name: &str, size: u64, location: MemoryLocation) -> Result<Self> {
        let size = size.max(4);
        let info = vk::BufferCreateInfo::default()
            .size(size)
            .usage(
                // Vertex and index usage: a renderer binds the cloth's buffers directly.
                vk::BufferUsageFlags::STORAGE_BUFFER
                    | vk::BufferUsageFlags::VERTEX_BUFFER
                    | vk::BufferUsageFlags::INDEX_BUFFER
                    | vk::BufferUsageFlags::INDIRECT_BUFFER
                    | vk::BufferUsageFlags::TRANSFER_SRC
                    | vk::BufferUsageFlags::TRANSFER_DST,
            )
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        // SAFETY: valid device and create info.
        let handle = unsafe { ctx.device.create_buffer(&info, None) }.vk("vkCreateBuffer")?;
        let mut buffer = Buffer { ctx: ctx.clone(), handle, allocation: None, size };
        ctx.name_object(handle, name);
        // SAFETY: the buffer was just created on this device.
        let requirements = unsafe { ctx.device.get_buffer_memory_requirements(handle) };
        let allocation = ctx.allocate(name, requirements, location, true)?;
        // SAFETY: memory from the same device, offset aligned per requirements.
        unsafe { ctx.device.bind_buffer_memory(handle, allocation.memory(), allocation.offset()) }
            .vk("vkBindBufferMemory")?;
        buffer.allocation = Some(allocation);
        Ok(buffer)
    }

    /// Size in bytes.
    pub fn size(&self) -> u64 {
        self.size
    }

    /// The mapped bytes of a host-visible buffer.
    pub fn mapped(&self) -> Option<&[u8]> {
        self.allocation.as_ref()?.mapped_slice()
    }

    /// The mapped bytes of a host-visible buffer, writable.
    pub fn mapped_mut(&mut self) -> Option<&mut [u8]> {
        self.allocation.as_mut()?.mapped_slice_mut()
    }
}

impl Drop for Buffer {
    fn drop(&mut self) {
        // SAFETY: the owner guarantees no pending GPU work uses the buffer (every submission is
        // waited on before its recording can be dropped).
        unsafe { self.ctx.device.destroy_buffer(self.handle, None) };
        if let Some(allocation) = self.allocation.take()
            && let Some(allocator) = self.ctx.allocator().as_mut()
        {
            let _ = allocator.free(allocation);
        }
    }
}
