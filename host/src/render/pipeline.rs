//! The surface pipeline: one render pass (colour + depth, cleared; colour left ready to copy
//! out) and the graphics pipeline of drape's `render::surface_vertex` / `surface_fragment`.

use crate::error::{Result, VkContext};
use crate::gpu::{Context, ShaderModule};
use ash::vk;
use drape_types::SurfacePush;
use std::ffi::CStr;
use std::sync::Arc;

/// The surface shaders' entry points (each in its own SPIR-V module).
const SURFACE_VERTEX: &CStr = c"render::surface_vertex";
const SURFACE_FRAGMENT: &CStr = c"render::surface_fragment";

/// sRGB colour: the shaders write linear light, the picture stores it encoded for display.
pub(crate) const COLOR_FORMAT: vk::Format = vk::Format::R8G8B8A8_SRGB;

/// A render pass and the pipeline drawing into it; destroyed on `Drop`.
pub(crate) struct SurfacePipeline {
    ctx: Arc<Context>,
    pub(crate) render_pass: vk::RenderPass,
    pub(crate) layout: vk::PipelineLayout,
    pub(crate) pipeline: vk::Pipeline,
    pub(crate) depth_format: vk::Format,
}

impl SurfacePipeline {
    pub(crate) fn new(ctx: &Arc<Context>, extent: vk::Extent2D) -> Result<Self> {
        let mut this = SurfacePipeline {
            ctx: ctx.clone(),
            render_pass: vk::RenderPass::null(),
            layout: vk::PipelineLayout::null(),
            pipeline: vk::Pipeline::null(),
            depth_format: depth_format(ctx),
        };
        // Filled step by step; `Drop` destroys what exists if a later step fails.
        this.render_pass = this.create_render_pass()?;
        let push = [vk::PushConstantRange::default()
            .stage_flags(vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT)
            .size(size_of::<SurfacePush>() as u32)];
        // SAFETY: valid device and create info.
        this.layout = unsafe {
            ctx.device
                .create_pipeline_layout(&vk::PipelineLayoutCreateInfo::default().push_constant_ranges(&push), None)
        }
        .vk("vkCreatePipelineLayout")?;
        let vertex = ShaderModule::for_entry(ctx, &SURFACE_VERTEX.to_string_lossy())?;
        let fragment = ShaderModule::for_entry(ctx, &SURFACE_FRAGMENT.to_string_lossy())?;
        this.pipeline = this.create_pipeline((&vertex, &fragment), extent)?;
        Ok(this)
    }

    fn create_render_pass(&self) -> Result<vk::RenderPass> {
        let attachments = [
            vk::AttachmentDescription::default()
                .format(COLOR_FORMAT)
                .samples(vk::SampleCountFlags::TYPE_1)
                .load_op(vk::AttachmentLoadOp::CLEAR)
                .store_op(vk::AttachmentStoreOp::STORE)
                .stencil_load_op(vk::AttachmentLoadOp::DONT_CARE)
                .stencil_store_op(vk::AttachmentStoreOp::DONT_CARE)
                .initial_layout(vk::ImageLayout::UNDEFINED)
                .final_layout(vk::ImageLayout::TRANSFER_SRC_OPTIMAL),
            vk::AttachmentDescription::default()
                .format(self.depth_format)
                .samples(vk::SampleCountFlags::TYPE_1)
                .load_op(vk::AttachmentLoadOp::CLEAR)
                .store_op(vk::AttachmentStoreOp::DONT_CARE)
                .stencil_load_op(vk::AttachmentLoadOp::DONT_CARE)
                .stencil_store_op(vk::AttachmentStoreOp::DONT_CARE)
                .initial_layout(vk::ImageLayout::UNDEFINED)
                .final_layout(vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL),
        ];
        let color = [vk::AttachmentReference { attachment: 0, layout: vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL }];
        let depth =
            vk::AttachmentReference { attachment: 1, layout: vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL };
        let subpasses = [vk::SubpassDescription::default()
            .pipeline_bind_point(vk::PipelineBindPoint::GRAPHICS)
            .color_attachments(&color)
            .depth_stencil_attachment(&depth)];
        let dependencies = [
            // The previous picture's copy out of the colour image and its depth tests finish
            // before this one clears them.
            vk::SubpassDependency::default()
                .src_subpass(vk::SUBPASS_EXTERNAL)
                .dst_subpass(0)
                .src_stage_mask(
                    vk::PipelineStageFlags::TRANSFER
                        | vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT
                        | vk::PipelineStageFlags::LATE_FRAGMENT_TESTS,
                )
                .dst_stage_mask(
                    vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT | vk::PipelineStageFlags::EARLY_FRAGMENT_TESTS,
                )
                .src_access_mask(
                    vk::AccessFlags::COLOR_ATTACHMENT_WRITE | vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE,
                )
                .dst_access_mask(
                    vk::AccessFlags::COLOR_ATTACHMENT_WRITE
                        | vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_READ
                        | vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE,
                ),
            // The drawn colour is complete before the copy reads it.
            vk::SubpassDependency::default()
                .src_subpass(0)
                .dst_subpass(vk::SUBPASS_EXTERNAL)
                .src_stage_mask(vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT)
                .dst_stage_mask(vk::PipelineStageFlags::TRANSFER)
                .src_access_mask(vk::AccessFlags::COLOR_ATTACHMENT_WRITE)
                .dst_access_mask(vk::AccessFlags::TRANSFER_READ),
        ];
        let info = vk::RenderPassCreateInfo::default()
            .attachments(&attachments)
            .subpasses(&subpasses)
            .dependencies(&dependencies);
        // SAFETY: valid device; the create info and its arrays live across the call.
        unsafe { self.ctx.device.create_render_pass(&info, None) }.vk("vkCreateRenderPass")
    }

    fn create_pipeline(
        &self,
        (vertex, fragment): (&ShaderModule, &ShaderModule),
        extent: vk::Extent2D,
    ) -> Result<vk::Pipeline> {
        let stages = [
            vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::VERTEX)
                .module(vertex.handle)
                .name(SURFACE_VERTEX),
            vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::FRAGMENT)
                .module(fragment.handle)
                .name(SURFACE_FRAGMENT),
        ];
        // drape's layout: positions and normals in separate buffers, one Vec4 per vertex each.
        let bindings = [0, 1].map(|binding| {
            vk::VertexInputBindingDescription::default()
                .binding(binding)
                .stride(16)
                .input_rate(vk::VertexInputRate::VERTEX)
        });
        let attributes = [0, 1].map(|location| {
            vk::VertexInputAttributeDescription::default()
                .location(location)
                .binding(location)
                .format(vk::Format::R32G32B32A32_SFLOAT)
                .offset(0)
        });
        let vertex_input = vk::PipelineVertexInputStateCreateInfo::default()
            .vertex_binding_descriptions(&bindings)
            .vertex_attribute_descriptions(&attributes);
        let assembly =
            vk::PipelineInputAssemblyStateCreateInfo::default().topology(vk::PrimitiveTopology::TRIANGLE_LIST);
        let viewports = [vk::Viewport {
            x: 0.0,
            y: 0.0,
            width: extent.width as f32,
            height: extent.height as f32,
            min_depth: 0.0,
            max_depth: 1.0,
        }];
        let scissors = [vk::Rect2D { offset: vk::Offset2D::default(), extent }];
        let viewport = vk::PipelineViewportStateCreateInfo::default().viewports(&viewports).scissors(&scissors);
        // Cloth is seen from both sides (the fragment shader shades both): no culling.
        let raster = vk::PipelineRasterizationStateCreateInfo::default()
            .polygon_mode(vk::PolygonMode::FILL)
            .cull_mode(vk::CullModeFlags::NONE)
            .line_width(1.0);
        let multisample =
            vk::PipelineMultisampleStateCreateInfo::default().rasterization_samples(vk::SampleCountFlags::TYPE_1);
        let depth = vk::PipelineDepthStencilStateCreateInfo::default()
            .depth_test_enable(true)
            .depth_write_enable(true)
            .depth_compare_op(vk::CompareOp::LESS);
        let blend_attachments =
            [vk::PipelineColorBlendAttachmentState::default().color_write_mask(vk::ColorComponentFlags::RGBA)];
        let blend = vk::PipelineColorBlendStateCreateInfo::default().attachments(&blend_attachments);
        let info = vk::GraphicsPipelineCreateInfo::default()
            .stages(&stages)
            .vertex_input_state(&vertex_input)
            .input_assembly_state(&assembly)
            .viewport_state(&viewport)
            .rasterization_state(&raster)
            .multisample_state(&multisample)
            .depth_stencil_state(&depth)
            .color_blend_state(&blend)
            .layout(self.layout)
            .render_pass(self.render_pass)
            .subpass(0);
        // SAFETY: valid device; the create info and everything it points to live across the call.
        let pipelines = unsafe { self.ctx.device.create_graphics_pipelines(vk::PipelineCache::null(), &[info], None) }
            .map_err(|(_, e)| e)
            .vk("vkCreateGraphicsPipelines")?;
        Ok(pipelines[0])
    }
}

/// 32-bit float depth where the device renders to it (depth precision for a cloth resting
/// millimetres above a collider), else 16-bit (always supported).
fn depth_format(ctx: &Context) -> vk::Format {
    // SAFETY: plain query on the context's physical device.
    let properties =
        unsafe { ctx.instance.get_physical_device_format_properties(ctx.physical_device, vk::Format::D32_SFLOAT) };
    if properties.optimal_tiling_features.contains(vk::FormatFeatureFlags::DEPTH_STENCIL_ATTACHMENT) {
        vk::Format::D32_SFLOAT
    } else {
        vk::Format::D16_UNORM
    }
}

impl Drop for SurfacePipeline {
    fn drop(&mut self) {
        // SAFETY: the renderer waits for its submissions before dropping the pipeline; an
        // engine that records it promises the same (`Renderer::record`).
        unsafe {
            self.ctx.device.destroy_pipeline(self.pipeline, None);
            self.ctx.device.destroy_pipeline_layout(self.layout, None);
            self.ctx.device.destroy_render_pass(self.render_pass, None);
        }
    }
}
