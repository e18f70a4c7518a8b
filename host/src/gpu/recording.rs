//! A frame recorded as a list of named passes, with a timestamp query around each dispatch, and
//! the per-pass GPU timing read back from those queries.

use super::buffer::Buffer;
use super::commands::{
    COMPUTE_AND_TRANSFER, COMPUTE_AND_TRANSFER_ACCESS, CommandBuffer, DescriptorArena, memory_barrier, stage_barrier,
};
use super::context::Context;
use super::pipeline::Pipeline;
use crate::error::{Result, VkContext};
use crate::graph::{Barrier, BufferId};
use ash::vk;
use std::collections::HashMap;
use std::sync::Arc;

/// One command of a frame, with the raw handles it uses. The handles stay valid as long as the
/// `FrameBindings` that the commands were encoded from (every holder keeps an `Arc` of them).
#[derive(Clone, Debug)]
pub enum Command {
    /// A compute dispatch, timed under `label`.
    Dispatch {
        label: &'static str,
        pipeline: vk::Pipeline,
        layout: vk::PipelineLayout,
        set: vk::DescriptorSet,
        push: Vec<u8>,
        groups: u32,
        /// Take the workgroup count from `DispatchArgs` in this buffer instead of `groups`.
        indirect: Option<vk::Buffer>,
    },
    /// Fill a whole buffer with a 32-bit value (e.g. reset counters).
    Fill { buffer: vk::Buffer, value: u32 },
    /// Write host bytes into a buffer inline (`vkCmdUpdateBuffer`, in chunks of 64 KiB).
    Write { buffer: vk::Buffer, offset: u64, bytes: Vec<u8> },
    /// Order earlier commands before later ones in the barrier's stages and make their writes
    /// visible there (derived from declared accesses).
    Barrier(Barrier),
    /// A pass the scene does not need: not recorded, but reported as skipped.
    Skipped { label: &'static str },
}

/// Largest `vkCmdUpdateBuffer` (spec limit).
const MAX_UPDATE_BYTES: usize = 65536;

/// Records `commands` into `cb`, with a timestamp pair around each dispatch when `queries` is
/// given (pool, first query; the pool must hold two per dispatch and be reset before). Returns
/// the next free query.
///
/// # Safety
/// `cb` is in the recording state on `device`; every handle in `commands` is alive and stays
/// alive until the command buffer has finished executing.
pub(crate) unsafe fn encode(
    device: &ash::Device,
    labels: Option<&ash::ext::debug_utils::Device>,
    cb: vk::CommandBuffer,
    commands: &[Command],
    queries: Option<(vk::QueryPool, u32)>,
) -> u32 {
    let mut query = queries.map_or(0, |(_, first)| first);
    let queries = queries.map(|(pool, _)| pool);
    // SAFETY: the caller's contract.
    unsafe {
        for command in commands {
            match command {
                Command::Dispatch { label, pipeline, layout, set, push, groups, indirect } => {
                    let labelled = labels.map(|utils| (utils, begin_label(utils, cb, label)));
                    device.cmd_bind_pipeline(cb, vk::PipelineBindPoint::COMPUTE, *pipeline);
                    device.cmd_bind_descriptor_sets(cb, vk::PipelineBindPoint::COMPUTE, *layout, 0, &[*set], &[]);
                    if !push.is_empty() {
                        device.cmd_push_constants(cb, *layout, vk::ShaderStageFlags::COMPUTE, 0, push);
                    }
                    if let Some(pool) = queries {
                        device.cmd_write_timestamp(cb, vk::PipelineStageFlags::TOP_OF_PIPE, pool, query);
                    }
                    match indirect {
                        Some(args) => device.cmd_dispatch_indirect(cb, *args, 0),
                        None => device.cmd_dispatch(cb, *groups, 1, 1),
                    }
                    if let Some(pool) = queries {
                        device.cmd_write_timestamp(cb, vk::PipelineStageFlags::BOTTOM_OF_PIPE, pool, query + 1);
                    }
                    if let Some((utils, true)) = labelled {
                        utils.cmd_end_debug_utils_label(cb);
                    }
                    query += 2;
                }
                Command::Fill { buffer, value } => device.cmd_fill_buffer(cb, *buffer, 0, vk::WHOLE_SIZE, *value),
                Command::Write { buffer, offset, bytes } => {
                    for (i, chunk) in bytes.chunks(MAX_UPDATE_BYTES).enumerate() {
                        let at = offset + (i * MAX_UPDATE_BYTES) as u64;
                        device.cmd_update_buffer(cb, *buffer, at, chunk);
                    }
                }
                Command::Barrier(barrier) => stage_barrier(device, cb, *barrier),
                Command::Skipped { .. } => {}
            }
        }
    }
    query
}

/// Records one frame: ordered after what the queue ran before (`acquire_from_producers`), the
/// concatenation of `segments` (timed from query 0 when a pool is given), and made available to
/// what runs after (`release_to_consumers`); labelled `drape: frame` when debug labels are on.
///
/// # Safety
/// As `encode`.
pub(crate) unsafe fn encode_frame(
    device: &ash::Device,
    labels: Option<&ash::ext::debug_utils::Device>,
    cb: vk::CommandBuffer,
    segments: &[&[Command]],
    queries: Option<vk::QueryPool>,
) {
    // SAFETY: the caller's contract.
    unsafe {
        let frame_label = labels.filter(|utils| begin_label(utils, cb, "frame"));
        acquire_from_producers(device, cb);
        let mut query = 0;
        for segment in segments {
            query = encode(device, labels, cb, segment, queries.map(|pool| (pool, query)));
        }
        release_to_consumers(device, cb);
        if let Some(utils) = frame_label {
            utils.cmd_end_debug_utils_label(cb);
        }
    }
}

/// Opens a debug label `drape: <name>` (ended by `cmd_end_debug_utils_label`); false when the
/// name cannot be a C string (then no label is open).
///
/// # Safety
/// `cb` is in the recording state on the device of `utils`.
pub(crate) unsafe fn begin_label(utils: &ash::ext::debug_utils::Device, cb: vk::CommandBuffer, name: &str) -> bool {
    let Ok(name) = std::ffi::CString::new(format!("drape: {name}")) else { return false };
    // SAFETY: the caller's contract; the label lives across the call.
    unsafe { utils.cmd_begin_debug_utils_label(cb, &vk::DebugUtilsLabelEXT::default().label_name(&name)) };
    true
}

/// Makes a frame's results visible to the host (mapped status) and to whatever the queue runs
/// next: vertex input of a renderer, compute, transfers.
///
/// # Safety
/// `cb` is in the recording state on `device`.
pub(crate) unsafe fn release_to_consumers(device: &ash::Device, cb: vk::CommandBuffer) {
    memory_barrier(
        device,
        cb,
        (COMPUTE_AND_TRANSFER, vk::AccessFlags::SHADER_WRITE | vk::AccessFlags::TRANSFER_WRITE),
        (
            vk::PipelineStageFlags::HOST | RENDER_INPUT | COMPUTE_AND_TRANSFER,
            vk::AccessFlags::HOST_READ
                | vk::AccessFlags::VERTEX_ATTRIBUTE_READ
                | vk::AccessFlags::INDEX_READ
                | vk::AccessFlags::SHADER_READ
                | vk::AccessFlags::TRANSFER_READ,
        ),
    );
}

/// Where a renderer reads a cloth's buffers.
const RENDER_INPUT: vk::PipelineStageFlags = vk::PipelineStageFlags::from_raw(
    vk::PipelineStageFlags::VERTEX_INPUT.as_raw() | vk::PipelineStageFlags::VERTEX_SHADER.as_raw(),
);

/// Orders a frame after what the queue ran before it: the caller's renderer reading the vertex
/// buffers (write-after-read), host writes, and earlier compute and transfers.
///
/// # Safety
/// `cb` is in the recording state on `device`.
pub(crate) unsafe fn acquire_from_producers(device: &ash::Device, cb: vk::CommandBuffer) {
    memory_barrier(
        device,
        cb,
        (
            vk::PipelineStageFlags::HOST | RENDER_INPUT | COMPUTE_AND_TRANSFER,
            vk::AccessFlags::SHADER_WRITE | vk::AccessFlags::TRANSFER_WRITE | vk::AccessFlags::HOST_WRITE,
        ),
        (COMPUTE_AND_TRANSFER | vk::PipelineStageFlags::DRAW_INDIRECT, COMPUTE_AND_TRANSFER_ACCESS),
    );
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
    /// Microseconds from the first pass's start to the last pass's end: the frame's GPU time
    /// with the barriers and idle gaps between passes, which the passes' sum leaves out (on a
    /// real GPU a small cloth's frame is mostly those gaps). `None` without timestamps.
    pub span_micros: Option<f64>,
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

/// What frames bind: descriptor sets for every (kernel, bindings) pair of some step lists, the
/// pipelines and the buffers. Frames hold an `Arc` of it, so nothing a frame refers to can be
/// destroyed while the frame exists (dropping the engine that made it is fine).
pub struct FrameBindings {
    pub(crate) sets: HashMap<(&'static str, Vec<BufferId>), vk::DescriptorSet>,
    pub(crate) pipelines: HashMap<&'static str, Arc<Pipeline>>,
    pub(crate) buffers: Vec<Arc<Buffer>>,
    // Dropped after the sets it holds are no longer referenced (field order).
    pub(crate) _arena: DescriptorArena,
}

/// A frame's commands in drape's own command buffer, re-recorded when its commands change and
/// submitted as often as needed.
pub struct RecordedFrame {
    // Field order is drop order: the command buffer (waited on at every submit) goes first,
    // then what it binds.
    cmd: CommandBuffer,
    queries: Option<QueryPool>,
    bindings: Arc<FrameBindings>,
    ctx: Arc<Context>,
    timed: bool,
    labels: Vec<&'static str>,
    skipped: Vec<&'static str>,
    barriers: u32,
}

impl RecordedFrame {
    /// Records `commands` (encoded from `bindings`); a final barrier makes the results visible
    /// to the host and to later vertex input, compute and transfers. With `timed`, a timestamp
    /// query brackets each dispatch (when the queue supports them).
    pub fn new(ctx: &Arc<Context>, bindings: Arc<FrameBindings>, commands: &[Command], timed: bool) -> Result<Self> {
        let mut frame = RecordedFrame {
            cmd: CommandBuffer::new(ctx)?,
            queries: None,
            bindings,
            ctx: ctx.clone(),
            timed: timed && ctx.info().timestamp_valid_bits > 0,
            labels: Vec::new(),
            skipped: Vec::new(),
            barriers: 0,
        };
        frame.rerecord(&[commands])?;
        Ok(frame)
    }

    /// Replaces the recorded commands (same bindings; the concatenation of `segments`), e.g.
    /// when a frame starts with new parameter writes. Reuses the command buffer; the query pool
    /// only grows.
    pub fn rerecord(&mut self, segments: &[&[Command]]) -> Result<()> {
        let commands = || segments.iter().flat_map(|s| s.iter());
        self.barriers = commands().filter(|c| matches!(c, Command::Barrier(_))).count() as u32;
        self.labels.clear();
        self.skipped.clear();
        for c in commands() {
            match c {
                Command::Dispatch { label, .. } => self.labels.push(label),
                Command::Skipped { label } => self.skipped.push(label),
                _ => {}
            }
        }
        let needed = self.labels.len() as u32 * 2;
        if self.timed && self.queries.as_ref().is_none_or(|q| q.count < needed) {
            self.queries = None;
            self.queries = Some(QueryPool::new(&self.ctx, self.labels.len() as u32)?);
        }
        let queries = self.queries.as_ref().map(|q| (q.pool, q.count));
        let ctx = self.ctx.clone();
        let debug = ctx.debug_utils();
        self.cmd.record(|device, cb| {
            // SAFETY (closure): recording into `cb`; every handle comes from `self.bindings`,
            // which this frame holds as long as the command buffer.
            unsafe {
                if let Some((pool, count)) = queries {
                    device.cmd_reset_query_pool(cb, pool, 0, count);
                }
                encode_frame(device, debug, cb, segments, queries.map(|(pool, _)| pool));
            }
        })
    }

    /// What the recorded commands bind.
    pub fn bindings(&self) -> &Arc<FrameBindings> {
        &self.bindings
    }

    /// Barriers recorded in the frame (derived from the passes' declared accesses).
    pub fn barrier_count(&self) -> u32 {
        self.barriers
    }

    /// Runs the frame on the GPU, waits, and returns each pass's GPU time.
    pub fn submit(&mut self) -> Result<FrameTimings> {
        self.cmd.submit_and_wait()?;
        let mut passes: Vec<PassTiming> = self.labels.iter().map(|&label| PassTiming { label, micros: None }).collect();
        let mut span_micros = None;
        if let Some(q) = &self.queries {
            let mut stamps = vec![0u64; passes.len() * 2];
            if !stamps.is_empty() {
                // SAFETY: the queries of every dispatch were written by the completed submission.
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
            }
            let info = self.ctx.info();
            let mask = if info.timestamp_valid_bits >= 64 { u64::MAX } else { (1u64 << info.timestamp_valid_bits) - 1 };
            let micros =
                |from: u64, to: u64| (to.wrapping_sub(from) & mask) as f64 * info.timestamp_period_ns as f64 / 1000.0;
            for (i, pass) in passes.iter_mut().enumerate() {
                pass.micros = Some(micros(stamps[2 * i], stamps[2 * i + 1]));
            }
            if let (Some(first), Some(last)) = (stamps.first(), stamps.last()) {
                span_micros = Some(micros(*first, *last));
            }
        }
        Ok(FrameTimings { passes, skipped: self.skipped.clone(), span_micros })
    }
}
