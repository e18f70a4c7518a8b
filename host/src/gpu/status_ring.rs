//! Status read back without stalling: each frame recorded into a caller's command buffer ends
//! by copying its small status buffers into the next slot of a host-visible ring and setting
//! that slot's event. The host polls the events (`vkGetEventStatus` never blocks) and reads a
//! slot once its frame has finished, typically one frame late.

use super::buffer::Buffer;
use super::commands::transfer_to_host_barrier;
use super::context::Context;
use crate::error::{Error, Result, VkContext};
use ash::vk;
use gpu_allocator::MemoryLocation;
use std::collections::VecDeque;
use std::sync::Arc;

/// A ring of `slots` status slots of `slot_bytes` each.
pub struct StatusRing {
    // Field order is drop order: the events and buffer are freed after pending frames are
    // waited for (the owner's Drop calls `wait_idle`).
    events: Vec<vk::Event>,
    buffer: Buffer,
    slot_bytes: u64,
    /// (slot, frame number) of frames recorded and not yet read back, oldest first.
    pending: VecDeque<(usize, u64)>,
    next: usize,
    ctx: Arc<Context>,
}

impl StatusRing {
    pub fn new(ctx: &Arc<Context>, slots: usize, slot_bytes: u64) -> Result<Self> {
        let buffer = Buffer::new(ctx, "status ring", slot_bytes * slots as u64, MemoryLocation::GpuToCpu)?;
        let mut ring = StatusRing {
            events: Vec::with_capacity(slots),
            buffer,
            slot_bytes,
            pending: VecDeque::new(),
            next: 0,
            ctx: ctx.clone(),
        };
        for _ in 0..slots {
            // SAFETY: valid device; stored at once so Drop destroys it.
            let event =
                unsafe { ctx.device.create_event(&vk::EventCreateInfo::default(), None) }.vk("vkCreateEvent")?;
            ring.events.push(event);
        }
        Ok(ring)
    }

    /// Bytes of the ring's host-visible buffer.
    pub fn bytes(&self) -> u64 {
        self.slot_bytes * self.events.len() as u64
    }

    /// Frames recorded and not read back yet.
    pub fn pending(&self) -> usize {
        self.pending.len()
    }

    /// Records, into `cb`, copies of `sources` (whole buffers, back to back) into the next slot
    /// and the slot's event, for frame `frame`.
    ///
    /// # Safety
    /// `cb` is recording on this device, and is submitted (once) before the ring is dropped.
    pub unsafe fn record(&mut self, cb: vk::CommandBuffer, sources: &[&Buffer], frame: u64) -> Result<()> {
        if self.pending.len() == self.events.len() {
            return Err(Error::InvalidParameter {
                name: "frames in flight",
                problem: format!(
                    "{} frames recorded with `record` have not finished on the GPU; submit the command \
                     buffers they were recorded into (on drape's queue) and let them complete, or call \
                     `poll_status` before recording more",
                    self.events.len()
                ),
            });
        }
        let slot = self.next;
        let base = slot as u64 * self.slot_bytes;
        let device = &self.ctx.device;
        let mut offset = 0;
        // SAFETY: the caller's contract; every handle is owned by this ring or the simulation.
        unsafe {
            for source in sources {
                let size = source.size();
                if offset + size > self.slot_bytes {
                    return Err(Error::Kernel {
                        kernel: "status ring".into(),
                        problem: "status buffers larger than a slot".into(),
                    });
                }
                let region = [vk::BufferCopy::default().size(size).dst_offset(base + offset)];
                device.cmd_copy_buffer(cb, source.handle, self.buffer.handle, &region);
                offset += size;
            }
            transfer_to_host_barrier(device, cb);
            device.cmd_set_event(cb, self.events[slot], vk::PipelineStageFlags::TRANSFER);
        }
        self.pending.push_back((slot, frame));
        self.next = (slot + 1) % self.events.len();
        Ok(())
    }

    /// The oldest pending frame's status bytes if that frame has finished (never blocks).
    pub fn poll(&mut self) -> Result<Option<(u64, Vec<u8>)>> {
        let Some(&(slot, frame)) = self.pending.front() else { return Ok(None) };
        let device = &self.ctx.device;
        // SAFETY: the event belongs to this device.
        let done = unsafe { device.get_event_status(self.events[slot]) }.vk("vkGetEventStatus")?;
        if !done {
            return Ok(None);
        }
        let base = (slot as u64 * self.slot_bytes) as usize;
        let mapped = self.buffer.mapped().ok_or_else(|| Error::Kernel {
            kernel: "status ring".into(),
            problem: "ring buffer is not host visible".into(),
        })?;
        let bytes = mapped[base..base + self.slot_bytes as usize].to_vec();
        // SAFETY: the event is set, so no pending command sets it any more.
        unsafe { device.reset_event(self.events[slot]) }.vk("vkResetEvent")?;
        self.pending.pop_front();
        Ok(Some((frame, bytes)))
    }

    /// Waits for the queue to finish (when frames are still pending), e.g. before freeing what
    /// they bind.
    pub fn wait_idle(&mut self) {
        if self.pending.is_empty() {
            return;
        }
        let queue = self.ctx.queue();
        // SAFETY: queue access is serialised by the context's lock.
        if let Err(e) = unsafe { self.ctx.device.queue_wait_idle(*queue) } {
            log::error!("vkQueueWaitIdle failed while dropping a simulation with frames in flight: {e}");
        }
    }
}

impl Drop for StatusRing {
    fn drop(&mut self) {
        self.wait_idle();
        for &event in &self.events {
            // SAFETY: nothing pending uses it (waited above).
            unsafe { self.ctx.device.destroy_event(event, None) };
        }
    }
}
