//! The Vulkan executor: allocates a `Resources`' buffers, transfers through a pooled staging
//! area, and records step lists into frames, with barriers derived from the passes' declared
//! reads and writes. Pipelines are created on first use (each costs a driver compile) and shared
//! by every frame recorded here.

use super::commands::DescriptorArena;
use super::recording::FrameBindings;
use super::staging::Staging;
use super::{Buffer, Command, Context, Pipeline, RecordedFrame, ShaderModule};
use crate::error::{Error, Result};
use crate::graph::{BufferId, Dispatch, Handle, HazardTracker, Memory, Resources, Step};
use gpu_allocator::MemoryLocation;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

impl crate::graph::ReadBuffers for Engine {
    fn read<T: bytemuck::Pod>(&self, buffer: Handle<T>, count: usize) -> Result<Vec<T>> {
        self.download(buffer, count)
    }
}

/// Buffers and pipelines of one simulation (or standalone LBVH build).
pub struct Engine {
    pipelines: HashMap<&'static str, Arc<Pipeline>>,
    /// Buffer `BufferId(i)` at [i].
    buffers: Vec<Arc<Buffer>>,
    staging: Mutex<Staging>,
    module: ShaderModule,
    ctx: Arc<Context>,
}

fn engine_error(problem: String) -> Error {
    Error::Kernel { kernel: "engine".into(), problem }
}

impl Engine {
    pub fn new(ctx: &Arc<Context>) -> Result<Self> {
        Ok(Engine {
            pipelines: HashMap::new(),
            buffers: Vec::new(),
            staging: Mutex::new(Staging::new(ctx)?),
            module: ShaderModule::new(ctx, crate::KERNELS_SPV)?,
            ctx: ctx.clone(),
        })
    }

    pub fn context(&self) -> &Arc<Context> {
        &self.ctx
    }

    /// Allocates every buffer of `resources` not allocated yet (resources only grow).
    pub fn allocate(&mut self, resources: &Resources) -> Result<()> {
        for desc in &resources.descs()[self.buffers.len().min(resources.len())..] {
            let location = match desc.memory {
                Memory::Device => MemoryLocation::GpuOnly,
                Memory::Readback => MemoryLocation::GpuToCpu,
            };
            self.buffers.push(Arc::new(Buffer::new(&self.ctx, &desc.name, desc.bytes, location)?));
        }
        Ok(())
    }

    pub fn buffer(&self, id: BufferId) -> Result<&Arc<Buffer>> {
        self.buffers.get(id.index()).ok_or_else(|| engine_error(format!("buffer {id:?} not allocated")))
    }

    fn staging(&self) -> std::sync::MutexGuard<'_, Staging> {
        // A poisoned lock only means a panic mid-transfer elsewhere; the pool itself is intact.
        self.staging.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Overwrites the start of `buffer` with `data`.
    pub fn upload<T: bytemuck::Pod>(&self, buffer: Handle<T>, data: &[T]) -> Result<()> {
        self.upload_bytes(buffer.id(), bytemuck::cast_slice(data))
    }

    pub fn upload_bytes(&self, id: BufferId, data: &[u8]) -> Result<()> {
        let target = self.buffer(id)?;
        self.staging().upload(target, data)
    }

    /// Reads the first `count` elements of `buffer`.
    pub fn download<T: bytemuck::Pod>(&self, buffer: Handle<T>, count: usize) -> Result<Vec<T>> {
        let bytes = self.staging().download(self.buffer(buffer.id())?, (count * size_of::<T>()) as u64)?;
        Ok(bytes.chunks_exact(size_of::<T>()).map(bytemuck::pod_read_unaligned).collect())
    }

    /// Reads a host-visible (mapped) buffer without a copy.
    pub fn read_mapped<T: bytemuck::Pod>(&self, buffer: Handle<T>) -> Result<T> {
        let b = self.buffer(buffer.id())?;
        let bytes = b.mapped().ok_or_else(|| engine_error(format!("{buffer:?} is not host visible")))?;
        if bytes.len() < size_of::<T>() {
            return Err(engine_error(format!("{buffer:?} is smaller than its type")));
        }
        Ok(bytemuck::pod_read_unaligned(&bytes[..size_of::<T>()]))
    }

    fn pipeline(&mut self, kernel: &'static crate::graph::Kernel) -> Result<Arc<Pipeline>> {
        if let Some(p) = self.pipelines.get(kernel.spec.entry) {
            return Ok(p.clone());
        }
        let pipeline = Arc::new(Pipeline::new(&self.ctx, &self.module, kernel.spec)?);
        self.pipelines.insert(kernel.spec.entry, pipeline.clone());
        Ok(pipeline)
    }

    /// Records `steps` into a frame that can be submitted any number of times. The frame holds
    /// its descriptor sets, pipelines and buffers; dropping it frees its descriptor pool.
    pub fn record(&mut self, steps: &[Step], timed: bool) -> Result<RecordedFrame> {
        // One descriptor set per distinct (kernel, bindings).
        let mut distinct: Vec<(&'static str, &[BufferId])> = Vec::new();
        let mut pipelines: Vec<Arc<Pipeline>> = Vec::new();
        for step in steps {
            if let Step::Run(pass) = step {
                let key = (pass.kernel.spec.entry, &pass.bindings[..]);
                if !distinct.contains(&key) {
                    distinct.push(key);
                }
                let p = self.pipeline(pass.kernel)?;
                if !pipelines.iter().any(|q| Arc::ptr_eq(q, &p)) {
                    pipelines.push(p);
                }
            }
        }
        let total_bindings: usize = distinct.iter().map(|(_, b)| b.len()).sum();
        let arena = DescriptorArena::new(&self.ctx, distinct.len() as u32, total_bindings as u32)?;
        let mut sets = HashMap::new();
        let mut used: Vec<BufferId> = Vec::new();
        for &(entry, ids) in &distinct {
            let pipeline = &self.pipelines[entry];
            let bound: Vec<&Buffer> = ids.iter().map(|id| self.buffer(*id).map(|b| &**b)).collect::<Result<_>>()?;
            sets.insert((entry, ids), arena.bind(pipeline, &bound)?);
        }
        let mut hazards = HazardTracker::default();
        let mut commands = Vec::with_capacity(steps.len() * 2);
        for step in steps {
            for (id, _) in step.accesses() {
                if !used.contains(&id) {
                    used.push(id);
                }
            }
            if hazards.needs_barrier(&step.accesses()) {
                commands.push(Command::Barrier);
            }
            commands.push(match step {
                Step::Fill { buffer, value } => Command::Fill { buffer: self.buffer(*buffer)?.handle, value: *value },
                Step::Skip { label } => Command::Skipped { label },
                Step::Run(pass) => {
                    let pipeline = &self.pipelines[pass.kernel.spec.entry];
                    let (groups, indirect) = match pass.dispatch {
                        Dispatch::Indirect(args) => (0, Some(self.buffer(args.id())?.handle)),
                        direct => (direct.direct_workgroups(pass.kernel.spec.workgroup_size).unwrap_or(0), None),
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
                        set: sets[&(pass.kernel.spec.entry, &pass.bindings[..])],
                        push: pass.push.map(|p| bytemuck::bytes_of(&p).to_vec()).unwrap_or_default(),
                        groups,
                        indirect,
                    }
                }
            });
        }
        let buffers = used.iter().map(|&id| self.buffer(id).cloned()).collect::<Result<_>>()?;
        RecordedFrame::record(&self.ctx, &commands, FrameBindings { arena, pipelines, buffers }, timed)
    }
}
