//! 2D images (render targets) that free their view, handle and memory on `Drop`.

use super::context::Context;
use crate::error::{Result, VkContext};
use ash::vk;
use gpu_allocator::MemoryLocation;
use gpu_allocator::vulkan::Allocation;
use std::sync::Arc;

/// One 2D image in device memory with a view of all of it.
pub struct Image {
    ctx: Arc<Context>,
    pub(crate) handle: vk::Image,
    pub(crate) view: vk::ImageView,
    allocation: Option<Allocation>,
}

impl Image {
    /// A `width` x `height` image of `format`, one mip level and layer, optimal tiling.
    pub fn new(
        ctx: &Arc<Context>,
        name: &str,
        (width, height): (u32, u32),
        format: vk::Format,
        usage: vk::ImageUsageFlags,
        aspect: vk::ImageAspectFlags,
    ) -> Result<Self> {
        let info = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(format)
            .extent(vk::Extent3D { width, height, depth: 1 })
            .mip_levels(1)
            .array_layers(1)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(usage)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        // SAFETY: valid device and create info.
        let handle = unsafe { ctx.device.create_image(&info, None) }.vk("vkCreateImage")?;
        // From here on `Drop` destroys whatever exists.
        let mut image = Image { ctx: ctx.clone(), handle, view: vk::ImageView::null(), allocation: None };
        ctx.name_object(handle, name);
        // SAFETY: the image was just created on this device.
        let requirements = unsafe { ctx.device.get_image_memory_requirements(handle) };
        let allocation = ctx.allocate(name, requirements, MemoryLocation::GpuOnly, false)?;
        // SAFETY: memory from the same device, offset aligned per requirements.
        unsafe { ctx.device.bind_image_memory(handle, allocation.memory(), allocation.offset()) }
            .vk("vkBindImageMemory")?;
        image.allocation = Some(allocation);
        let view_info = vk::ImageViewCreateInfo::default()
            .image(handle)
            .view_type(vk::ImageViewType::TYPE_2D)
            .format(format)
            .subresource_range(whole(aspect));
        // SAFETY: the image is bound to memory; the view covers its only level and layer.
        image.view = unsafe { ctx.device.create_image_view(&view_info, None) }.vk("vkCreateImageView")?;
        Ok(image)
    }
}

/// The one mip level and layer of an image.
pub(crate) fn whole(aspect: vk::ImageAspectFlags) -> vk::ImageSubresourceRange {
    vk::ImageSubresourceRange {
        aspect_mask: aspect,
        base_mip_level: 0,
        level_count: 1,
        base_array_layer: 0,
        layer_count: 1,
    }
}

impl Drop for Image {
    fn drop(&mut self) {
        // SAFETY: the owner waits for every submission that uses the image before dropping it.
        unsafe {
            self.ctx.device.destroy_image_view(self.view, None);
            self.ctx.device.destroy_image(self.handle, None);
        }
        if let Some(allocation) = self.allocation.take()
            && let Some(allocator) = self.ctx.allocator().as_mut()
        {
            let _ = allocator.free(allocation);
        }
    }
}
