//! The offscreen renderer: records a picture's draws into a command buffer (its own or an
//! engine's) and reads the picture back.

use super::camera::Camera;
use super::pipeline::SurfacePipeline;
use super::surface_mesh::SurfaceMesh;
use super::target::Target;
use crate::error::{Error, Result};
use crate::gpu::Context;
use crate::gpu::commands::CommandBuffer;
use crate::{ClothId, RigidPose, Solver, VertexBuffers};
use ash::vk;
use drape_types::SurfacePush;
use glam::{Vec3, Vec4};
use std::sync::Arc;

/// The light's direction (towards it): above, a little in front and to the right.
const LIGHT: Vec3 = Vec3::new(0.4, 1.0, 0.3);

/// What one draw binds, as raw handles (for [`Renderer::record`] into an engine's command
/// buffer; the caller keeps the buffers alive until it completes).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct RawDraw {
    pub positions: vk::Buffer,
    pub normals: vk::Buffer,
    pub indices: vk::Buffer,
    pub index_count: u32,
    /// Object -> world (identity for a cloth: its positions are in the world).
    pub pose: RigidPose,
    /// Linear RGB, a = ambient share.
    pub color: Vec4,
}

impl RawDraw {
    /// A cloth drawn from a solver's vertex buffers.
    pub fn cloth(buffers: &VertexBuffers, color: Vec4) -> RawDraw {
        RawDraw {
            positions: buffers.positions,
            normals: buffers.normals,
            indices: buffers.indices,
            index_count: buffers.index_count,
            pose: RigidPose::IDENTITY,
            color,
        }
    }

    /// A mesh drawn at `pose`.
    pub fn mesh(mesh: &SurfaceMesh, pose: RigidPose, color: Vec4) -> RawDraw {
        RawDraw {
            positions: mesh.positions.handle,
            normals: mesh.normals.handle,
            indices: mesh.indices.handle,
            index_count: mesh.index_count,
            pose,
            color,
        }
    }
}

/// One draw of [`Renderer::render`], borrowing what it binds.
pub enum Draw<'a> {
    /// A cloth of `solver`, as its last completed frame left it.
    Cloth { solver: &'a Solver, cloth: ClothId, color: Vec4 },
    /// A mesh at a rigid pose.
    Mesh { mesh: &'a SurfaceMesh, pose: RigidPose, color: Vec4 },
}

/// A picture read back: RGBA8 (sRGB), rows top to bottom.
#[derive(Clone, Debug, PartialEq)]
pub struct Picture {
    pub width: u32,
    pub height: u32,
    pub rgba: Vec<u8>,
}

/// An offscreen target, the pipeline that draws into it and a command buffer of its own.
pub struct Renderer {
    ctx: Arc<Context>,
    // Declared before the pipeline: the framebuffer goes before the render pass.
    target: Target,
    pipeline: SurfacePipeline,
    commands: CommandBuffer,
}

impl Renderer {
    /// A renderer of `width` x `height` pictures on `ctx`'s device, whose queue family must
    /// draw (graphics); each side at most the device's image and framebuffer limits (4096 or
    /// more on every device).
    pub fn new(ctx: &Arc<Context>, width: u32, height: u32) -> Result<Self> {
        // SAFETY: plain query on the context's physical device.
        let limits = unsafe { ctx.instance.get_physical_device_properties(ctx.physical_device) }.limits;
        let max_side =
            limits.max_image_dimension2_d.min(limits.max_framebuffer_width).min(limits.max_framebuffer_height);
        if !(1..=max_side).contains(&width) || !(1..=max_side).contains(&height) {
            return Err(Error::InvalidParameter {
                name: "picture size",
                problem: format!("got {width}x{height}; each side must be 1..={max_side} pixels on this device"),
            });
        }
        // SAFETY: plain query on the context's physical device.
        let families = unsafe { ctx.instance.get_physical_device_queue_family_properties(ctx.physical_device) };
        let draws =
            families.get(ctx.queue_family as usize).is_some_and(|f| f.queue_flags.contains(vk::QueueFlags::GRAPHICS));
        if !draws {
            return Err(Error::MissingFeature {
                device: ctx.info().name.clone(),
                feature: "graphics on drape's queue family (pictures need one that draws; import a device whose \
                          queue family has VK_QUEUE_GRAPHICS_BIT)",
            });
        }
        let extent = vk::Extent2D { width, height };
        let pipeline = SurfacePipeline::new(ctx, extent)?;
        let target = Target::new(ctx, &pipeline, extent)?;
        Ok(Renderer { ctx: ctx.clone(), target, pipeline, commands: CommandBuffer::new(ctx)? })
    }

    /// Width and height in pixels.
    pub fn size(&self) -> (u32, u32) {
        (self.target.extent.width, self.target.extent.height)
    }

    /// Draws `draws` seen by `camera`, waits for the GPU and returns the picture.
    pub fn render(&mut self, camera: &Camera, draws: &[Draw<'_>]) -> Result<Picture> {
        let mut raw = Vec::with_capacity(draws.len());
        let foreign = |name: &'static str| Error::InvalidParameter {
            name,
            problem: "made on another context than the renderer's; create both from one Context".into(),
        };
        for draw in draws {
            raw.push(match *draw {
                Draw::Cloth { solver, cloth, color } => {
                    if !Arc::ptr_eq(solver.context(), &self.ctx) {
                        return Err(foreign("solver"));
                    }
                    RawDraw::cloth(&solver.vertex_buffers(cloth)?, color)
                }
                Draw::Mesh { mesh, pose, color } => {
                    if !Arc::ptr_eq(&mesh.ctx, &self.ctx) {
                        return Err(foreign("mesh"));
                    }
                    RawDraw::mesh(mesh, pose, color)
                }
            });
        }
        let Renderer { target, pipeline, commands, .. } = self;
        commands.record(|device, cmd| {
            // SAFETY: `cmd` is recording; every buffer drawn is borrowed until this function
            // returns, after the submission completed.
            unsafe { record_into(device, cmd, pipeline, target, camera, &raw) }
        })?;
        commands.submit_and_wait()?;
        // SAFETY: the submission that copied the picture was waited for.
        unsafe { self.picture() }
    }

    /// Records the picture into `cmd`: a barrier that makes earlier compute and transfer writes
    /// (a solver's frame, an upload) visible to vertex input, clear, draw `draws` with depth
    /// test, copy the colour to the readback buffer visible to the host.
    ///
    /// # Safety
    /// `cmd` is recording on the renderer's device, for submission to drape's queue (the
    /// images belong to its family, and the solver's frames are ordered with it by that queue);
    /// the buffers of `draws` and this renderer stay alive, and the meshes unchanged
    /// (`SurfaceMesh::set_vertices`), until it completes; no other submission using this
    /// renderer is pending.
    pub unsafe fn record(&self, cmd: vk::CommandBuffer, camera: &Camera, draws: &[RawDraw]) {
        // SAFETY: forwarded from the caller.
        unsafe { record_into(&self.ctx.device, cmd, &self.pipeline, &self.target, camera, draws) }
    }

    /// The last recorded picture.
    ///
    /// # Safety
    /// The command buffer that recorded it has completed (its fence waited for).
    pub unsafe fn picture(&self) -> Result<Picture> {
        let (width, height) = self.size();
        let bytes = width as usize * height as usize * 4;
        let mapped = self.target.readback.mapped().ok_or_else(|| Error::Kernel {
            kernel: "renderer".into(),
            problem: "readback buffer is not host-visible".into(),
        })?;
        Ok(Picture { width, height, rgba: mapped[..bytes].to_vec() })
    }
}

impl Picture {
    /// Writes the picture as an 8-bit sRGB RGBA PNG.
    #[cfg(feature = "png")]
    pub fn write_png(&self, path: &std::path::Path) -> Result<()> {
        let io = |source: std::io::Error| Error::Io { path: path.to_path_buf(), source };
        let file = std::fs::File::create(path).map_err(io)?;
        let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), self.width, self.height);
        encoder.set_color(png::ColorType::Rgba);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        let encoded = encoder.write_header().and_then(|mut writer| {
            writer.write_image_data(&self.rgba)?;
            writer.finish()
        });
        encoded.map_err(|e| match e {
            png::EncodingError::IoError(source) => io(source),
            other => io(std::io::Error::other(other.to_string())),
        })
    }
}

/// The push constants of one draw.
fn push(camera: &Camera, draw: &RawDraw) -> SurfacePush {
    SurfacePush {
        view_projection: camera.view_projection.to_cols_array_2d().map(Vec4::from_array),
        pose: draw.pose,
        color: draw.color,
        light: LIGHT.normalize().extend(0.0),
    }
}

/// # Safety
/// As for [`Renderer::record`].
unsafe fn record_into(
    device: &ash::Device,
    cmd: vk::CommandBuffer,
    pipeline: &SurfacePipeline,
    target: &Target,
    camera: &Camera,
    draws: &[RawDraw],
) {
    let clear = [
        vk::ClearValue { color: vk::ClearColorValue { float32: super::BACKGROUND } },
        vk::ClearValue { depth_stencil: vk::ClearDepthStencilValue { depth: 1.0, stencil: 0 } },
    ];
    let begin = vk::RenderPassBeginInfo::default()
        .render_pass(pipeline.render_pass)
        .framebuffer(target.framebuffer)
        .render_area(vk::Rect2D { offset: vk::Offset2D::default(), extent: target.extent })
        .clear_values(&clear);
    let stages = vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT;
    // SAFETY: forwarded from the caller; the render pass leaves the colour image in
    // TRANSFER_SRC_OPTIMAL with its writes visible to the copy (its outgoing dependency).
    unsafe {
        // A frame ends with this dependency already; an upload (initial state, teleport,
        // set_state) ends with compute and transfer in mind only.
        crate::gpu::commands::memory_barrier(
            device,
            cmd,
            (
                vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::TRANSFER,
                vk::AccessFlags::SHADER_WRITE | vk::AccessFlags::TRANSFER_WRITE,
            ),
            (
                vk::PipelineStageFlags::VERTEX_INPUT,
                vk::AccessFlags::VERTEX_ATTRIBUTE_READ | vk::AccessFlags::INDEX_READ,
            ),
        );
        device.cmd_begin_render_pass(cmd, &begin, vk::SubpassContents::INLINE);
        device.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, pipeline.pipeline);
        for draw in draws {
            device.cmd_bind_vertex_buffers(cmd, 0, &[draw.positions, draw.normals], &[0, 0]);
            device.cmd_bind_index_buffer(cmd, draw.indices, 0, vk::IndexType::UINT32);
            device.cmd_push_constants(cmd, pipeline.layout, stages, 0, bytemuck::bytes_of(&push(camera, draw)));
            device.cmd_draw_indexed(cmd, draw.index_count, 1, 0, 0, 0);
        }
        device.cmd_end_render_pass(cmd);
        let region = vk::BufferImageCopy::default()
            .image_subresource(vk::ImageSubresourceLayers {
                aspect_mask: vk::ImageAspectFlags::COLOR,
                mip_level: 0,
                base_array_layer: 0,
                layer_count: 1,
            })
            .image_extent(vk::Extent3D { width: target.extent.width, height: target.extent.height, depth: 1 });
        device.cmd_copy_image_to_buffer(
            cmd,
            target.color.handle,
            vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
            target.readback.handle,
            &[region],
        );
        crate::gpu::commands::transfer_to_host_barrier(device, cmd);
    }
}
