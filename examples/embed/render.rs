//! The engine's side: an offscreen graphics pass (dynamic rendering, colour + depth) that draws
//! meshes straight from vertex buffers laid out like drape's (`R32G32B32A32_SFLOAT` positions
//! and normals at stride 16, `UINT32` indices), then copies the image into a host-visible buffer.
//! The shaders are drape's `render::surface_vertex` / `render::surface_fragment` (rust-gpu).

use ash::vk;
use drape_types::SurfacePush;
use std::error::Error;

pub type Result<T> = std::result::Result<T, Box<dyn Error>>;

pub const COLOR_FORMAT: vk::Format = vk::Format::R8G8B8A8_UNORM;
const DEPTH_FORMAT: vk::Format = vk::Format::D32_SFLOAT;
/// The background, cleared before drawing: RGBA 0..1.
pub const BACKGROUND: [f32; 4] = [0.0, 0.0, 0.0, 1.0];

/// One indexed draw from vertex buffers with drape's layout.
#[derive(Copy, Clone)]
pub struct Draw {
    pub positions: vk::Buffer,
    pub normals: vk::Buffer,
    pub indices: vk::Buffer,
    pub index_count: u32,
    pub push: SurfacePush,
}

/// Device memory holding one image or buffer.
struct Memory(vk::DeviceMemory);

fn allocate(
    instance: &ash::Instance,
    physical: vk::PhysicalDevice,
    device: &ash::Device,
    requirements: vk::MemoryRequirements,
    flags: vk::MemoryPropertyFlags,
) -> Result<Memory> {
    let properties = unsafe { instance.get_physical_device_memory_properties(physical) };
    let index = (0..properties.memory_type_count)
        .find(|&i| {
            requirements.memory_type_bits & (1 << i) != 0
                && properties.memory_types[i as usize].property_flags.contains(flags)
        })
        .ok_or("no memory type for the offscreen target")?;
    let info = vk::MemoryAllocateInfo::default().allocation_size(requirements.size).memory_type_index(index);
    Ok(Memory(unsafe { device.allocate_memory(&info, None)? }))
}

/// The offscreen target and the pipeline that draws into it.
pub struct Renderer {
    device: ash::Device,
    pub width: u32,
    pub height: u32,
    color: (vk::Image, Memory, vk::ImageView),
    depth: (vk::Image, Memory, vk::ImageView),
    readback: (vk::Buffer, Memory),
    module: vk::ShaderModule,
    layout: vk::PipelineLayout,
    pipeline: vk::Pipeline,
}

impl Renderer {
    pub fn new(
        instance: &ash::Instance,
        physical: vk::PhysicalDevice,
        device: &ash::Device,
        width: u32,
        height: u32,
    ) -> Result<Self> {
        let mut renderer = Renderer {
            device: device.clone(),
            width,
            height,
            color: (vk::Image::null(), Memory(vk::DeviceMemory::null()), vk::ImageView::null()),
            depth: (vk::Image::null(), Memory(vk::DeviceMemory::null()), vk::ImageView::null()),
            readback: (vk::Buffer::null(), Memory(vk::DeviceMemory::null())),
            module: vk::ShaderModule::null(),
            layout: vk::PipelineLayout::null(),
            pipeline: vk::Pipeline::null(),
        };
        // Filled in step by step; `Drop` destroys whatever was created if a later step fails.
        renderer.color = renderer.attachment(
            instance,
            physical,
            COLOR_FORMAT,
            vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC,
            vk::ImageAspectFlags::COLOR,
        )?;
        renderer.depth = renderer.attachment(
            instance,
            physical,
            DEPTH_FORMAT,
            vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
            vk::ImageAspectFlags::DEPTH,
        )?;
        let size = u64::from(width) * u64::from(height) * 4;
        let buffer = unsafe {
            device.create_buffer(
                &vk::BufferCreateInfo::default().size(size).usage(vk::BufferUsageFlags::TRANSFER_DST),
                None,
            )?
        };
        renderer.readback.0 = buffer;
        let requirements = unsafe { device.get_buffer_memory_requirements(buffer) };
        renderer.readback.1 = allocate(
            instance,
            physical,
            device,
            requirements,
            vk::MemoryPropertyFlags::HOST_VISIBLE | vk::MemoryPropertyFlags::HOST_COHERENT,
        )?;
        unsafe { device.bind_buffer_memory(buffer, renderer.readback.1.0, 0)? };
        renderer.pipeline()?;
        Ok(renderer)
    }

    fn attachment(
        &self,
        instance: &ash::Instance,
        physical: vk::PhysicalDevice,
        format: vk::Format,
        usage: vk::ImageUsageFlags,
        aspect: vk::ImageAspectFlags,
    ) -> Result<(vk::Image, Memory, vk::ImageView)> {
        let device = &self.device;
        let info = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(format)
            .extent(vk::Extent3D { width: self.width, height: self.height, depth: 1 })
            .mip_levels(1)
            .array_layers(1)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(usage);
        let image = unsafe { device.create_image(&info, None)? };
        let requirements = unsafe { device.get_image_memory_requirements(image) };
        let memory = match allocate(instance, physical, device, requirements, vk::MemoryPropertyFlags::DEVICE_LOCAL) {
            Ok(memory) => memory,
            Err(e) => {
                unsafe { device.destroy_image(image, None) };
                return Err(e);
            }
        };
        let view = unsafe {
            device.bind_image_memory(image, memory.0, 0)?;
            device.create_image_view(
                &vk::ImageViewCreateInfo::default()
                    .image(image)
                    .view_type(vk::ImageViewType::TYPE_2D)
                    .format(format)
                    .subresource_range(subresource(aspect)),
                None,
            )?
        };
        Ok((image, memory, view))
    }

    fn pipeline(&mut self) -> Result<()> {
        let device = &self.device;
        let words: Vec<u32> = drape::KERNELS_SPV.as_chunks::<4>().0.iter().map(|c| u32::from_le_bytes(*c)).collect();
        self.module =
            unsafe { device.create_shader_module(&vk::ShaderModuleCreateInfo::default().code(&words), None)? };
        let push = [vk::PushConstantRange::default()
            .stage_flags(vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT)
            .size(size_of::<SurfacePush>() as u32)];
        self.layout = unsafe {
            device.create_pipeline_layout(&vk::PipelineLayoutCreateInfo::default().push_constant_ranges(&push), None)?
        };
        let stages = [
            vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::VERTEX)
                .module(self.module)
                .name(c"render::surface_vertex"),
            vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::FRAGMENT)
                .module(self.module)
                .name(c"render::surface_fragment"),
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
            width: self.width as f32,
            height: self.height as f32,
            min_depth: 0.0,
            max_depth: 1.0,
        }];
        let scissors = [vk::Rect2D { offset: vk::Offset2D::default(), extent: self.extent() }];
        let viewport = vk::PipelineViewportStateCreateInfo::default().viewports(&viewports).scissors(&scissors);
        // Cloth is seen from both sides: no culling.
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
        let color_formats = [COLOR_FORMAT];
        let mut rendering = vk::PipelineRenderingCreateInfo::default()
            .color_attachment_formats(&color_formats)
            .depth_attachment_format(DEPTH_FORMAT);
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
            .push_next(&mut rendering);
        let pipelines = unsafe { device.create_graphics_pipelines(vk::PipelineCache::null(), &[info], None) }
            .map_err(|(_, e)| e)?;
        self.pipeline = pipelines[0];
        Ok(())
    }

    fn extent(&self) -> vk::Extent2D {
        vk::Extent2D { width: self.width, height: self.height }
    }

    /// Records: clear, draw every `draws` entry with depth test, copy the image to the readback
    /// buffer and make it visible to the host. The vertex buffers must be ready for vertex input
    /// (drape's recorded frame ends with that barrier).
    ///
    /// # Safety
    /// `cmd` is recording; the buffers in `draws` stay alive until it completes.
    pub unsafe fn record(&self, cmd: vk::CommandBuffer, draws: &[Draw]) {
        let d = &self.device;
        unsafe {
            // Earlier frames' copies out of the colour image and depth tests complete before
            // this frame's writes (the layouts are discarded: everything is cleared).
            let to_attachment = [
                image_barrier(
                    self.color.0,
                    vk::ImageAspectFlags::COLOR,
                    vk::AccessFlags::empty(),
                    vk::AccessFlags::COLOR_ATTACHMENT_WRITE,
                    vk::ImageLayout::UNDEFINED,
                    vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
                ),
                image_barrier(
                    self.depth.0,
                    vk::ImageAspectFlags::DEPTH,
                    vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE,
                    vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_READ | vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE,
                    vk::ImageLayout::UNDEFINED,
                    vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL,
                ),
            ];
            d.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::TRANSFER
                    | vk::PipelineStageFlags::EARLY_FRAGMENT_TESTS
                    | vk::PipelineStageFlags::LATE_FRAGMENT_TESTS,
                vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT
                    | vk::PipelineStageFlags::EARLY_FRAGMENT_TESTS
                    | vk::PipelineStageFlags::LATE_FRAGMENT_TESTS,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &to_attachment,
            );
            let color = [vk::RenderingAttachmentInfo::default()
                .image_view(self.color.2)
                .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
                .load_op(vk::AttachmentLoadOp::CLEAR)
                .store_op(vk::AttachmentStoreOp::STORE)
                .clear_value(vk::ClearValue { color: vk::ClearColorValue { float32: BACKGROUND } })];
            let depth = vk::RenderingAttachmentInfo::default()
                .image_view(self.depth.2)
                .image_layout(vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL)
                .load_op(vk::AttachmentLoadOp::CLEAR)
                .store_op(vk::AttachmentStoreOp::DONT_CARE)
                .clear_value(vk::ClearValue { depth_stencil: vk::ClearDepthStencilValue { depth: 1.0, stencil: 0 } });
            let rendering = vk::RenderingInfo::default()
                .render_area(vk::Rect2D { offset: vk::Offset2D::default(), extent: self.extent() })
                .layer_count(1)
                .color_attachments(&color)
                .depth_attachment(&depth);
            d.cmd_begin_rendering(cmd, &rendering);
            d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, self.pipeline);
            for draw in draws {
                d.cmd_bind_vertex_buffers(cmd, 0, &[draw.positions, draw.normals], &[0, 0]);
                d.cmd_bind_index_buffer(cmd, draw.indices, 0, vk::IndexType::UINT32);
                d.cmd_push_constants(
                    cmd,
                    self.layout,
                    vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT,
                    0,
                    bytemuck::bytes_of(&draw.push),
                );
                d.cmd_draw_indexed(cmd, draw.index_count, 1, 0, 0, 0);
            }
            d.cmd_end_rendering(cmd);
            let to_transfer = [image_barrier(
                self.color.0,
                vk::ImageAspectFlags::COLOR,
                vk::AccessFlags::COLOR_ATTACHMENT_WRITE,
                vk::AccessFlags::TRANSFER_READ,
                vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
            )];
            d.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT,
                vk::PipelineStageFlags::TRANSFER,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &to_transfer,
            );
            let region = vk::BufferImageCopy::default()
                .image_subresource(vk::ImageSubresourceLayers {
                    aspect_mask: vk::ImageAspectFlags::COLOR,
                    mip_level: 0,
                    base_array_layer: 0,
                    layer_count: 1,
                })
                .image_extent(vk::Extent3D { width: self.width, height: self.height, depth: 1 });
            d.cmd_copy_image_to_buffer(
                cmd,
                self.color.0,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                self.readback.0,
                &[region],
            );
            let to_host = [vk::MemoryBarrier::default()
                .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
                .dst_access_mask(vk::AccessFlags::HOST_READ)];
            d.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::TRANSFER,
                vk::PipelineStageFlags::HOST,
                vk::DependencyFlags::empty(),
                &to_host,
                &[],
                &[],
            );
        }
    }

    /// The last completed frame's pixels, RGBA8, rows top to bottom.
    ///
    /// # Safety
    /// The command buffer that recorded the copy has completed (its fence waited for).
    pub unsafe fn pixels(&self) -> Result<Vec<u8>> {
        let size = self.width as usize * self.height as usize * 4;
        unsafe {
            let mapped = self.device.map_memory(self.readback.1.0, 0, size as u64, vk::MemoryMapFlags::empty())?;
            let pixels = std::slice::from_raw_parts(mapped as *const u8, size).to_vec();
            self.device.unmap_memory(self.readback.1.0);
            Ok(pixels)
        }
    }
}

impl Drop for Renderer {
    fn drop(&mut self) {
        let d = &self.device;
        unsafe {
            d.destroy_pipeline(self.pipeline, None);
            d.destroy_pipeline_layout(self.layout, None);
            d.destroy_shader_module(self.module, None);
            d.destroy_buffer(self.readback.0, None);
            d.free_memory(self.readback.1.0, None);
            for (image, memory, view) in [&self.color, &self.depth] {
                d.destroy_image_view(*view, None);
                d.destroy_image(*image, None);
                d.free_memory(memory.0, None);
            }
        }
    }
}

fn subresource(aspect: vk::ImageAspectFlags) -> vk::ImageSubresourceRange {
    vk::ImageSubresourceRange {
        aspect_mask: aspect,
        base_mip_level: 0,
        level_count: 1,
        base_array_layer: 0,
        layer_count: 1,
    }
}

fn image_barrier(
    image: vk::Image,
    aspect: vk::ImageAspectFlags,
    src: vk::AccessFlags,
    dst: vk::AccessFlags,
    old: vk::ImageLayout,
    new: vk::ImageLayout,
) -> vk::ImageMemoryBarrier<'static> {
    vk::ImageMemoryBarrier::default()
        .image(image)
        .subresource_range(subresource(aspect))
        .src_access_mask(src)
        .dst_access_mask(dst)
        .old_layout(old)
        .new_layout(new)
        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
}
