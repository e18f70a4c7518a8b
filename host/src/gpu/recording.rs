//! A frame recorded as a list of named passes, with a timestamp query around each dispatch, and
//! the per-pass GPU timing read back from those queries.

use super::buffer::Buffer;
use super::commands::{CommandBuffer, DescriptorArena, full_barrier};
use super::context::Context;
use super::pipeline::Pipeline;
use crate::error::{Result, VkContext};
use ash::vk;
use std::sync::Arc;

/// One step of a recorded frame.
pub enum Command<'a> {
    /// A compute dispatch, timed under `label`.
    Dispatch {
        label: &'static str,
        pipeline: &'a Pipeline,
        set: vk::DescriptorSet,
        push: Vec<u8>,
        groups: u32,
        /// Take the workgroup count from `DispatchArgs` in this buffer instead of `groups`.
        indirect: Option<vk::Buffer>,
    },
    /// Fill a whole buffer with a 32-bit value (e.g. reset counters).
    Fill { buffer: vk::Buffer, value: u32 },
    /// Make every earlier write visible to every later command (derived from declared accesses).
    Barrier,
    /// A pass the scene does not need: not recorded, but reported as skipped.
    Skipped { label: &'static str },
}

/// GPU time of one pass.
#[derive(Clone, Debug, PartialEq)]
pub struct PassTiming {
    pub label: &'static str,
    /// Microseconds, or `None` when the queue has no timestamps.
    pub micros: Option<f64>,
}

/// What one submission of a recorded frame cost on the GPU.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameTimings {
    pub passes: Vec<PassTiming>,
    pub skipped: Vec<&'static str>,
}

impl FrameTimings {
    /// Per label: (dispatches, total microseconds), in first-seen order.
    pub fn by_label(&self) -> Vec<(&'static str, u32, f64)> {
        let mut out: Vec<(&'static str, u32, f64)> = Vec::new();
        for p in &self.passes {
            let t = p.micros.unwrap_or(0.0);
            match out.iter_mut().find(|(l, _, _)| *l == p.label) {
                Some(entry) => {
                    entry.1 += 1;
                    entry.2 += t;
                }
                None => out.push((p.label, 1, t)),
            }
        }
        out
    }

    /// Sum of all pass times (µs).
    pub fn total_micros(&self) -> f64 {
        self.passes.iter().filter_map(|p| p.micros).sum()
    }
}

/// Timestamp queries for `count` passes (two each).
struct QueryPool {
    ctx: Arc<Context>,
    pool: vk::QueryPool,
    count: u32,
}

impl QueryPool {
    fn new(ctx: &Arc<Context>, passes: u32) -> Result<Self> {
        let count = passes * 2;
        let info = vk::QueryPoolCreateInfo::default().query_type(vk::QueryType::TIMESTAMP).query_count(count.max(1));
        // SAFETY: valid device and create info.
        let pool = unsafe { ctx.device.create_query_pool(&info, None) }.vk("vkCreateQueryPool")?;
        Ok(QueryPool { ctx: ctx.clone(), pool, count })
    }
}

impl Drop for QueryPool {
    fn drop(&mut self) {
        // SAFETY: no pending submission uses it (frames wait on their fence).
        unsafe { self.ctx.device.destroy_query_pool(self.pool, None) };
    }
}

/// What a recorded frame binds: it holds them, so nothing it refers to can be destroyed while
/// the frame exists (dropping the engine that made it is fine).
pub struct FrameBindings {
    pub arena: DescriptorArena,
    pub pipelines: Vec<Arc<Pipeline>>,
    pub buffers: Vec<Arc<Buffer>>,
}

/// A frame's commands, recorded once and submitted as often as needed.
pub struct RecordedFrame {
    // Field order is drop order: the command buffer (waited on at every submit) goes first,
    // then what it binds.
    cmd: CommandBuffer,
    queries: Option<QueryPool>,
    _bindings: FrameBindings,
    ctx: Arc<Context>,
    labels: Vec<&'static str>,
    skipped: Vec<&'static str>,
    barriers: u32,
}

impl RecordedFrame {
    /// Records `commands` (barriers included, as the caller placed them); a final barrier makes
    /// shader writes visible to the host (readback of mapped buffers after the wait).
    /// With `timed`, a timestamp query brackets each dispatch (when the queue supports them).
    pub fn record(ctx: &Arc<Context>, commands: &[Command], bindings: FrameBindings, timed: bool) -> Result<Self> {
        let barriers = commands.iter().filter(|c| matches!(c, Command::Barrier)).count() as u32;
        let labels: Vec<&'static str> = commands
            .iter()
            .filter_map(|c| if let Command::Dispatch { label, .. } = c { Some(*label) } else { None })
            .collect();
        let skipped = commands
            .iter()
            .filter_map(|c| if let Command::Skipped { label } = c { Some(*label) } else { None })
            .collect();
        let timed = timed && ctx.info().timestamp_valid_bits > 0;
        let queries = if timed { Some(QueryPool::new(ctx, labels.len() as u32)?) } else { None };
        let mut cmd = CommandBuffer::new(ctx)?;
        cmd.record(|device, cb| {
            // SAFETY (closure): recording into `cb`; every handle used outlives the frame
            // (the owner keeps pipelines, sets and buffers alive as long as the frame).
            unsafe {
                if let Some(q) = &queries {
                    device.cmd_reset_query_pool(cb, q.pool, 0, q.count);
                }
                let mut query = 0;
                for command in commands {
                    match command {
                        Command::Dispatch { pipeline, set, push, groups, indirect, .. } => {
                            device.cmd_bind_pipeline(cb, vk::PipelineBindPoint::COMPUTE, pipeline.pipeline);
                            device.cmd_bind_descriptor_sets(
                                cb,
                                vk::PipelineBindPoint::COMPUTE,
                                pipeline.layout,
                                0,
                                &[*set],
                                &[],
                            );
                            if !push.is_empty() {
                                device.cmd_push_constants(cb, pipeline.layout, vk::ShaderStageFlags::COMPUTE, 0, push);
                            }
                            if let Some(q) = &queries {
                                device.cmd_write_timestamp(cb, vk::PipelineStageFlags::TOP_OF_PIPE, q.pool, query);
                            }
                            match indirect {
                                Some(args) => device.cmd_dispatch_indirect(cb, *args, 0),
                                None => device.cmd_dispatch(cb, *groups, 1, 1),
                            }
                            if let Some(q) = &queries {
                                device.cmd_write_timestamp(
                                    cb,
                                    vk::PipelineStageFlags::BOTTOM_OF_PIPE,
                                    q.pool,
                                    query + 1,
                                );
                            }
                            query += 2;
                        }
                        Command::Fill { buffer, value } => {
                            device.cmd_fill_buffer(cb, *buffer, 0, vk::WHOLE_SIZE, *value);
                        }
                        Command::Barrier => full_barrier(device, cb),
                        Command::Skipped { .. } => {}
                    }
                }
                // The frame's results are visible to the host (mapped status) and to whatever
                // the queue runs next: vertex input of a renderer, compute, transfers.
                let after = [vk::MemoryBarrier::default()
                    .src_access_mask(vk::AccessFlags::SHADER_WRITE | vk::AccessFlags::TRANSFER_WRITE)
                    .dst_access_mask(
                        vk::AccessFlags::HOST_READ
                            | vk::AccessFlags::VERTEX_ATTRIBUTE_READ
                            | vk::AccessFlags::INDEX_READ
                            | vk::AccessFlags::SHADER_READ
                            | vk::AccessFlags::TRANSFER_READ,
                    )];
                device.cmd_pipeline_barrier(
                    cb,
                    vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::TRANSFER,
                    vk::PipelineStageFlags::HOST
                        | vk::PipelineStageFlags::VERTEX_INPUT
                        | vk::PipelineStageFlags::COMPUTE_SHADER
                        | vk::PipelineStageFlags::TRANSFER,
                    vk::DependencyFlags::empty(),
                    &after,
                    &[],
                    &[],
                );
            }
        })?;
        Ok(RecordedFrame { cmd, queries, _bindings: bindings, ctx: ctx.clone(), labels, skipped, barriers })
    }

    /// Barriers recorded in the frame (derived from the passes' declared accesses).
    pub fn barrier_count(&self) -> u32 {
        self.barriers
    }

    /// Runs the frame on the GPU, waits, and returns each pass's GPU time.
    pub fn submit(&mut self) -> Result<FrameTimings> {
        self.cmd.submit_and_wait()?;
        let mut passes: Vec<PassTiming> = self.labels.iter().map(|&label| PassTiming { label, micros: None }).collect();
        if let Some(q) = &self.queries {
            let mut stamps = vec![0u64; q.count as usize];
            // SAFETY: all queries were written by the completed submission.
            unsafe {
                self.ctx
                    .device
                    .get_query_pool_results(
                        q.pool,
                        0,
                        &mut stamps,
                        vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
                    )
                    .vk("vkGetQueryPoolResults")?;
            }
            let info = self.ctx.info();
            let mask = if info.timestamp_valid_bits >= 64 { u64::MAX } else { (1u64 << info.timestamp_valid_bits) - 1 };
            for (i, pass) in passes.iter_mut().enumerate() {
                let ticks = stamps[2 * i + 1].wrapping_sub(stamps[2 * i]) & mask;
                pass.micros = Some(ticks as f64 * info.timestamp_period_ns as f64 / 1000.0);
            }
        }
        Ok(FrameTimings { passes, skipped: self.skipped.clone() })
    }
}
