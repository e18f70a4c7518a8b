//! A set of named GPU buffers plus the pipelines that run on them: records `program` step lists
//! into frames. Pipelines are created on first use (each costs a driver compile).

use super::commands::{DescriptorArena, download, upload};
use super::{Buffer, Command, Context, Pipeline, RecordedFrame, ShaderModule};
use crate::error::{Error, Result};
use crate::kernels::KernelId;
use crate::program::{BufferId, FrameStep, Groups};
use gpu_allocator::MemoryLocation;
use std::collections::HashMap;
use std::sync::Arc;

/// Buffers, pipelines and descriptor sets of one simulation (or LBVH build).
pub struct Engine {
    // Drop order: sets, pipelines, buffers, module; the context (Arc) outlives all.
    arenas: Vec<DescriptorArena>,
    pipelines: HashMap<KernelId, Pipeline>,
    buffers: HashMap<BufferId, Buffer>,
    module: ShaderModule,
    ctx: Arc<Context>,
}

fn missing(problem: String) -> Error {
    Error::Kernel { kernel: "engine".into(), problem }
}

impl Engine {
    pub fn new(ctx: &Arc<Context>) -> Result<Self> {
        Ok(Engine {
            arenas: Vec::new(),
            pipelines: HashMap::new(),
            buffers: HashMap::new(),
            module: ShaderModule::new(ctx, crate::KERNELS_SPV)?,
            ctx: ctx.clone(),
        })
    }

    pub fn context(&self) -> &Arc<Context> {
        &self.ctx
    }

    /// Allocates buffer `id` of `bytes` bytes (replacing any previous one).
    pub fn create(&mut self, id: BufferId, bytes: u64, location: MemoryLocation) -> Result<()> {
        let buffer = Buffer::new(&self.ctx, &format!("{id:?}"), bytes, location)?;
        self.buffers.insert(id, buffer);
        Ok(())
    }

    /// Allocates buffer `id` on the GPU holding `data`.
    pub fn create_with<T: bytemuck::Pod>(&mut self, id: BufferId, data: &[T]) -> Result<()> {
        self.create(id, size_of_val(data) as u64, MemoryLocation::GpuOnly)?;
        upload(&self.ctx, self.buffer(id)?, bytemuck::cast_slice(data))
    }

    pub fn buffer(&self, id: BufferId) -> Result<&Buffer> {
        self.buffers.get(&id).ok_or_else(|| missing(format!("buffer {id:?} not allocated")))
    }

    /// Overwrites the start of buffer `id` with `data`.
    pub fn upload<T: bytemuck::Pod>(&self, id: BufferId, data: &[T]) -> Result<()> {
        upload(&self.ctx, self.buffer(id)?, bytemuck::cast_slice(data))
    }

    /// Reads `count` elements of type `T` from the start of buffer `id`.
    pub fn download<T: bytemuck::Pod>(&self, id: BufferId, count: usize) -> Result<Vec<T>> {
        let bytes = download(&self.ctx, self.buffer(id)?, (count * size_of::<T>()) as u64)?;
        Ok(bytes.chunks_exact(size_of::<T>()).map(bytemuck::pod_read_unaligned).collect())
    }

    /// Reads a host-visible (mapped) buffer without a copy.
    pub fn read_mapped<T: bytemuck::Pod>(&self, id: BufferId) -> Result<T> {
        let bytes = self.buffer(id)?.mapped().ok_or_else(|| missing(format!("{id:?} is not host visible")))?;
        if bytes.len() < size_of::<T>() {
            return Err(missing(format!("{id:?} is smaller than its type")));
        }
        Ok(bytemuck::pod_read_unaligned(&bytes[..size_of::<T>()]))
    }

    fn ensure_pipeline(&mut self, kernel: KernelId) -> Result<()> {
        if !self.pipelines.contains_key(&kernel) {
            let pipeline = Pipeline::new(&self.ctx, &self.module, kernel.spec())?;
            self.pipelines.insert(kernel, pipeline);
        }
        Ok(())
    }

    /// Records `steps` into a frame that can be submitted any number of times. The frame refers
    /// to this engine's pipelines, sets and buffers: drop it before the engine.
    pub fn record(&mut self, steps: &[FrameStep], timed: bool) -> Result<RecordedFrame> {
        let mut distinct: Vec<(KernelId, Vec<BufferId>)> = Vec::new();
        for step in steps {
            if let FrameStep::Run(pass) = step {
                self.ensure_pipeline(pass.kernel)?;
                let key = (pass.kernel, pass.bindings.clone());
                if !distinct.contains(&key) {
                    distinct.push(key);
                }
            }
        }
        let total_bindings: usize = distinct.iter().map(|(_, b)| b.len()).sum();
        let arena = DescriptorArena::new(&self.ctx, distinct.len() as u32, total_bindings as u32)?;
        let mut sets = HashMap::new();
        for (kernel, ids) in &distinct {
            let pipeline = &self.pipelines[kernel];
            let bound: Vec<&Buffer> = ids.iter().map(|id| self.buffer(*id)).collect::<Result<_>>()?;
            sets.insert((*kernel, ids.clone()), arena.bind(pipeline, &bound)?);
        }
        let mut commands = Vec::with_capacity(steps.len());
        for step in steps {
            commands.push(match step {
                FrameStep::Fill { buffer, value } => {
                    Command::Fill { buffer: self.buffer(*buffer)?.handle, value: *value }
                }
                FrameStep::Skip { label } => Command::Skipped { label },
                FrameStep::Run(pass) => {
                    let pipeline = &self.pipelines[&pass.kernel];
                    let (groups, indirect) = match pass.groups {
                        Groups::Threads(n) => (n.div_ceil(pipeline.spec.workgroup_size), None),
                        Groups::Workgroups(n) => (n, None),
                        Groups::Indirect(id) => (0, Some(self.buffer(id)?.handle)),
                    };
                    if groups > self.ctx.info().max_workgroup_count_x {
                        return Err(Error::InvalidParameter {
                            name: "problem size",
                            problem: format!(
                                "pass `{}` needs {groups} workgroups; this device dispatches at most {}",
                                pass.label,
                                self.ctx.info().max_workgroup_count_x
                            ),
                        });
                    }
                    Command::Dispatch {
                        label: pass.label,
                        pipeline,
                        set: sets[&(pass.kernel, pass.bindings.clone())],
                        push: pass.push.map(|p| bytemuck::bytes_of(&p).to_vec()).unwrap_or_default(),
                        groups,
                        indirect,
                    }
                }
            });
        }
        let frame = RecordedFrame::record(&self.ctx, &commands, timed)?;
        self.arenas.push(arena);
        Ok(frame)
    }
}
