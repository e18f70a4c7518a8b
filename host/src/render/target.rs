//! Where a picture is drawn: colour and depth images, their framebuffer, and the host-visible
//! buffer the colour is copied into.

use super::pipeline::{COLOR_FORMAT, SurfacePipeline};
use crate::error::{Result, VkContext};
use crate::gpu::{Buffer, Context, Image};
use ash::vk;
use gpu_allocator::MemoryLocation;
use std::sync::Arc;

pub(crate) struct Target {
    ctx: Arc<Context>,
    pub(crate) extent: vk::Extent2D,
    pub(crate) color: Image,
    _depth: Image,
    pub(crate) framebuffer: vk::Framebuffer,
    pub(crate) readback: Buffer,
}

impl Target {
    pub(crate) fn new(ctx: &Arc<Context>, pipeline: &SurfacePipeline, extent: vk::Extent2D) -> Result<Self> {
        let size = (extent.width, extent.height);
        let color = Image::new(
            ctx,
            "picture colour",
            size,
            COLOR_FORMAT,
            vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC,
            vk::ImageAspectFlags::COLOR,
        )?;
        let depth = Image::new(
            ctx,
            "picture depth",
            size,
            pipeline.depth_format,
            vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
            vk::ImageAspectFlags::DEPTH,
        )?;
        let readback = Buffer::new(
            ctx,
            "picture readback",
            u64::from(extent.width) * u64::from(extent.height) * 4,
            MemoryLocation::GpuToCpu,
        )?;
        let views = [color.view, depth.view];
        let info = vk::FramebufferCreateInfo::default()
            .render_pass(pipeline.render_pass)
            .attachments(&views)
            .width(extent.width)
            .height(extent.height)
            .layers(1);
        // SAFETY: the views are of images of this size and the render pass's formats.
        let framebuffer = unsafe { ctx.device.create_framebuffer(&info, None) }.vk("vkCreateFramebuffer")?;
        Ok(Target { ctx: ctx.clone(), extent, color, _depth: depth, framebuffer, readback })
    }
}

impl Drop for Target {
    fn drop(&mut self) {
        // SAFETY: as for the pipeline: no submission that uses it is pending.
        unsafe { self.ctx.device.destroy_framebuffer(self.framebuffer, None) };
    }
}
