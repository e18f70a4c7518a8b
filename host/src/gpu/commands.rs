//! Command buffers with their pool and fence (RAII), one-shot submissions, barriers and
//! descriptor sets.

use super::buffer::Buffer;
use super::context::Context;
use super::pipeline::Pipeline;
use crate::error::{Error, Result, VkContext};
use ash::vk;
use std::sync::Arc;

/// A primary command buffer, its pool and a fence to wait on its submission.
pub struct CommandBuffer {
    ctx: Arc<Context>,
    pool: vk::CommandPool,
    pub(crate) cmd: vk::CommandBuffer,
    fence: vk::Fence,
}

impl CommandBuffer {
    pub fn new(ctx: &Arc<Context>) -> Result<Self> {
        let mut this = CommandBuffer {
            ctx: ctx.clone(),
            pool: vk::CommandPool::null(),
            cmd: vk::CommandBuffer::null(),
            fence: vk::Fence::null(),
        };
        // SAFETY: valid device; handles are stored immediately so Drop cleans up on error.
        unsafe {
            this.pool = ctx
                .device
                .create_command_pool(&vk::CommandPoolCreateInfo::default().queue_family_index(ctx.queue_family), None)
                .vk("vkCreateCommandPool")?;
            this.cmd = ctx
                .device
                .allocate_command_buffers(
                    &vk::CommandBufferAllocateInfo::default()
                        .command_pool(this.pool)
                        .level(vk::CommandBufferLevel::PRIMARY)
                        .command_buffer_count(1),
                )
                .vk("vkAllocateCommandBuffers")?[0];
            this.fence = ctx.device.create_fence(&vk::FenceCreateInfo::default(), None).vk("vkCreateFence")?;
        }
        Ok(this)
    }

    /// Records `body` into the (reset) command buffer.
    pub fn record(&mut self, body: impl FnOnce(&ash::Device, vk::CommandBuffer)) -> Result<()> {
        let device = &self.ctx.device;
        // SAFETY: the buffer is not pending (every submit waits on the fence).
        unsafe {
            device.reset_command_pool(self.pool, vk::CommandPoolResetFlags::empty()).vk("vkResetCommandPool")?;
            device.begin_command_buffer(self.cmd, &vk::CommandBufferBeginInfo::default()).vk("vkBeginCommandBuffer")?;
            body(device, self.cmd);
            device.end_command_buffer(self.cmd).vk("vkEndCommandBuffer")?;
        }
        Ok(())
    }

    /// Submits and blocks until the GPU is done; reports validation errors as an error.
    pub fn submit_and_wait(&self) -> Result<()> {
        let device = &self.ctx.device;
        let cmds = [self.cmd];
        let submit = [vk::SubmitInfo::default().command_buffers(&cmds)];
        // SAFETY: recorded command buffer, unsignalled fence, queue access serialised by lock.
        unsafe {
            {
                let queue = self.ctx.queue();
                device.queue_submit(*queue, &submit, self.fence).vk("vkQueueSubmit")?;
            }
            let waited = device.wait_for_fences(&[self.fence], true, u64::MAX);
            device.reset_fences(&[self.fence]).vk("vkResetFences")?;
            waited.vk("vkWaitForFences")?;
        }
        self.ctx.check_validation()
    }
}

impl Drop for CommandBuffer {
    fn drop(&mut self) {
        // SAFETY: submissions are always waited on, so nothing is pending.
        unsafe {
            self.ctx.device.destroy_fence(self.fence, None);
            self.ctx.device.destroy_command_pool(self.pool, None);
        }
    }
}

/// Records `body` into a fresh command buffer, submits it and waits.
pub fn one_shot(ctx: &Arc<Context>, body: impl FnOnce(&ash::Device, vk::CommandBuffer)) -> Result<()> {
    let mut cmd = CommandBuffer::new(ctx)?;
    cmd.record(body)?;
    cmd.submit_and_wait()
}

/// One global memory barrier: `src_access` writes of `src_stages` made available and visible to
/// `dst_access` of `dst_stages`.
pub fn memory_barrier(
    device: &ash::Device,
    cmd: vk::CommandBuffer,
    (src_stages, src_access): (vk::PipelineStageFlags, vk::AccessFlags),
    (dst_stages, dst_access): (vk::PipelineStageFlags, vk::AccessFlags),
) {
    let barrier = [vk::MemoryBarrier::default().src_access_mask(src_access).dst_access_mask(dst_access)];
    // SAFETY: recording command buffer.
    unsafe {
        device.cmd_pipeline_barrier(cmd, src_stages, dst_stages, vk::DependencyFlags::empty(), &barrier, &[], &[])
    };
}

/// What compute and transfer commands read and write.
pub const COMPUTE_AND_TRANSFER: vk::PipelineStageFlags = vk::PipelineStageFlags::from_raw(
    vk::PipelineStageFlags::COMPUTE_SHADER.as_raw() | vk::PipelineStageFlags::TRANSFER.as_raw(),
);

/// Every access of a later compute or transfer command (indirect dispatch arguments included).
pub const COMPUTE_AND_TRANSFER_ACCESS: vk::AccessFlags = vk::AccessFlags::from_raw(
    vk::AccessFlags::SHADER_READ.as_raw()
        | vk::AccessFlags::SHADER_WRITE.as_raw()
        | vk::AccessFlags::TRANSFER_READ.as_raw()
        | vk::AccessFlags::TRANSFER_WRITE.as_raw()
        | vk::AccessFlags::INDIRECT_COMMAND_READ.as_raw(),
);

/// Global barrier making transfer and compute writes visible to later compute and transfer.
pub fn full_barrier(device: &ash::Device, cmd: vk::CommandBuffer) {
    memory_barrier(
        device,
        cmd,
        (COMPUTE_AND_TRANSFER, vk::AccessFlags::SHADER_WRITE | vk::AccessFlags::TRANSFER_WRITE),
        (COMPUTE_AND_TRANSFER | vk::PipelineStageFlags::DRAW_INDIRECT, COMPUTE_AND_TRANSFER_ACCESS),
    );
}

/// A barrier between the description layer's stages (`graph::Stages`): kernels, transfers
/// (fills, inline writes) and indirect-argument reads, each mapped to its pipeline stage and
/// access.
pub fn stage_barrier(device: &ash::Device, cmd: vk::CommandBuffer, barrier: crate::graph::Barrier) {
    use crate::graph::Stages;
    // Empty stage masks are invalid without synchronization2; a planned barrier has both.
    debug_assert!(!barrier.before.is_empty() && !barrier.after.is_empty(), "empty barrier {barrier:?}");
    let stages = |set: Stages| {
        let mut flags = vk::PipelineStageFlags::empty();
        for (stage, flag) in [
            (Stages::KERNEL, vk::PipelineStageFlags::COMPUTE_SHADER),
            (Stages::TRANSFER, vk::PipelineStageFlags::TRANSFER),
            (Stages::INDIRECT, vk::PipelineStageFlags::DRAW_INDIRECT),
        ] {
            if set.contains(stage) {
                flags |= flag;
            }
        }
        flags
    };
    let mut src_access = vk::AccessFlags::empty();
    if barrier.before.contains(Stages::KERNEL) {
        src_access |= vk::AccessFlags::SHADER_WRITE;
    }
    if barrier.before.contains(Stages::TRANSFER) {
        src_access |= vk::AccessFlags::TRANSFER_WRITE;
    }
    let mut dst_access = vk::AccessFlags::empty();
    if barrier.after.contains(Stages::KERNEL) {
        dst_access |= vk::AccessFlags::SHADER_READ | vk::AccessFlags::SHADER_WRITE;
    }
    if barrier.after.contains(Stages::TRANSFER) {
        dst_access |= vk::AccessFlags::TRANSFER_READ | vk::AccessFlags::TRANSFER_WRITE;
    }
    if barrier.after.contains(Stages::INDIRECT) {
        dst_access |= vk::AccessFlags::INDIRECT_COMMAND_READ;
    }
    memory_barrier(device, cmd, (stages(barrier.before), src_access), (stages(barrier.after), dst_access));
}

/// Makes transfer writes (a copy into host-visible memory) visible to the host.
pub fn transfer_to_host_barrier(device: &ash::Device, cmd: vk::CommandBuffer) {
    memory_barrier(
        device,
        cmd,
        (vk::PipelineStageFlags::TRANSFER, vk::AccessFlags::TRANSFER_WRITE),
        (vk::PipelineStageFlags::HOST, vk::AccessFlags::HOST_READ),
    );
}

/// A descriptor pool from which sets are allocated; all sets die with it.
pub struct DescriptorArena {
    ctx: Arc<Context>,
    pool: vk::DescriptorPool,
}

impl DescriptorArena {
    /// Room for `max_sets` sets of up to `max_bindings` storage buffers in total.
    pub fn new(ctx: &Arc<Context>, max_sets: u32, max_bindings: u32) -> Result<Self> {
        let sizes = [vk::DescriptorPoolSize::default()
            .ty(vk::DescriptorType::STORAGE_BUFFER)
            .descriptor_count(max_bindings.max(1))];
        let info = vk::DescriptorPoolCreateInfo::default().max_sets(max_sets.max(1)).pool_sizes(&sizes);
        // SAFETY: valid device and create info.
        let pool = unsafe { ctx.device.create_descriptor_pool(&info, None) }.vk("vkCreateDescriptorPool")?;
        Ok(DescriptorArena { ctx: ctx.clone(), pool })
    }

    /// A set for `pipeline` with `buffers[i]` at binding i (whole buffer).
    pub fn bind(&self, pipeline: &Pipeline, buffers: &[&Buffer]) -> Result<vk::DescriptorSet> {
        if buffers.len() != pipeline.spec.bindings.len() {
            return Err(Error::Kernel {
                kernel: pipeline.spec.entry.into(),
                problem: format!(
                    "{} buffers bound, the kernel declares {} bindings",
                    buffers.len(),
                    pipeline.spec.bindings.len()
                ),
            });
        }
        let layouts = [pipeline.set_layout];
        let info = vk::DescriptorSetAllocateInfo::default().descriptor_pool(self.pool).set_layouts(&layouts);
        // SAFETY: pool and layout from this device.
        let set = unsafe { self.ctx.device.allocate_descriptor_sets(&info) }.vk("vkAllocateDescriptorSets")?[0];
        let infos: Vec<[vk::DescriptorBufferInfo; 1]> = buffers
            .iter()
            .map(|b| [vk::DescriptorBufferInfo::default().buffer(b.handle).offset(0).range(vk::WHOLE_SIZE)])
            .collect();
        let writes: Vec<_> = infos
            .iter()
            .enumerate()
            .map(|(i, info)| {
                vk::WriteDescriptorSet::default()
                    .dst_set(set)
                    .dst_binding(i as u32)
                    .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                    .buffer_info(info)
            })
            .collect();
        // SAFETY: set and buffers valid; descriptors are written before any use.
        unsafe { self.ctx.device.update_descriptor_sets(&writes, &[]) };
        Ok(set)
    }
}

impl Drop for DescriptorArena {
    fn drop(&mut self) {
        // SAFETY: no pending work uses the sets (owners wait on submissions).
        unsafe { self.ctx.device.destroy_descriptor_pool(self.pool, None) };
    }
}
