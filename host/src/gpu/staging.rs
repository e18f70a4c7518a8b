//! Host <-> GPU transfers through staging buffers that are kept and reused (grown to the next
//! power of two when a transfer needs more), with one reused command buffer: a transfer
//! allocates nothing once the pool is large enough.

use super::buffer::Buffer;
use super::commands::{CommandBuffer, full_barrier, transfer_to_host_barrier};
use super::context::Context;
use crate::error::{Error, Result};
use ash::vk;
use gpu_allocator::MemoryLocation;
use std::sync::Arc;

pub struct Staging {
    ctx: Arc<Context>,
    upload: Option<Buffer>,
    download: Option<Buffer>,
    cmd: CommandBuffer,
}

fn not_mapped(what: &str) -> Error {
    Error::Kernel { kernel: what.into(), problem: "staging buffer is not host visible".into() }
}

/// `slot`'s buffer, replaced by a larger one when it holds fewer than `len` bytes.
fn ensure<'a>(
    ctx: &Arc<Context>,
    slot: &'a mut Option<Buffer>,
    name: &str,
    len: u64,
    location: MemoryLocation,
) -> Result<&'a mut Buffer> {
    if slot.as_ref().is_none_or(|b| b.size() < len) {
        *slot = None; // free the old one first
        *slot = Some(Buffer::new(ctx, name, len.next_power_of_two().max(4096), location)?);
    }
    slot.as_mut().ok_or_else(|| not_mapped(name))
}

impl Staging {
    pub fn new(ctx: &Arc<Context>) -> Result<Self> {
        Ok(Staging { ctx: ctx.clone(), upload: None, download: None, cmd: CommandBuffer::new(ctx)? })
    }

    /// Copies `data` to the start of `dst` and waits.
    pub fn upload(&mut self, dst: &Buffer, data: &[u8]) -> Result<()> {
        if data.len() as u64 > dst.size() {
            return Err(Error::InvalidParameter {
                name: "upload",
                problem: format!("{} bytes into a {}-byte buffer", data.len(), dst.size()),
            });
        }
        if data.is_empty() {
            return Ok(());
        }
        let len = data.len() as u64;
        let staging = ensure(&self.ctx, &mut self.upload, "staging upload", len, MemoryLocation::CpuToGpu)?;
        staging.mapped_mut().ok_or_else(|| not_mapped("upload"))?[..data.len()].copy_from_slice(data);
        let (src, dst) = (staging.handle, dst.handle);
        let region = [vk::BufferCopy::default().size(len)];
        self.cmd.record(|device, cmd| unsafe {
            // SAFETY: recording; both buffers outlive the submission, which is waited on. The
            // barriers order the copy after earlier submissions' work on `dst` and make it
            // visible to later ones.
            full_barrier(device, cmd);
            device.cmd_copy_buffer(cmd, src, dst, &region);
            full_barrier(device, cmd);
        })?;
        self.cmd.submit_and_wait()
    }

    /// Reads `len` bytes from the start of `src` (after all earlier submissions).
    pub fn download(&mut self, src: &Buffer, len: u64) -> Result<Vec<u8>> {
        let len = len.min(src.size());
        if len == 0 {
            return Ok(Vec::new());
        }
        let staging = ensure(&self.ctx, &mut self.download, "staging download", len, MemoryLocation::GpuToCpu)?;
        let (from, to) = (src.handle, staging.handle);
        let region = [vk::BufferCopy::default().size(len)];
        self.cmd.record(|device, cmd| unsafe {
            // SAFETY: recording; both buffers outlive the submission. The barrier makes earlier
            // submissions' shader writes visible to the copy (queue submission order); the
            // fence wait makes the copy visible to the host (coherent memory).
            full_barrier(device, cmd);
            device.cmd_copy_buffer(cmd, from, to, &region);
            transfer_to_host_barrier(device, cmd);
        })?;
        self.cmd.submit_and_wait()?;
        let staging = self.download.as_ref().ok_or_else(|| not_mapped("download"))?;
        Ok(staging.mapped().ok_or_else(|| not_mapped("download"))?[..len as usize].to_vec())
    }
}
