//! The Vulkan executor: allocates a `Resources`' buffers, transfers through a pooled staging
//! area, and records step lists into frames, with barriers derived from the passes' declared
//! reads and writes. Pipelines are created on first use (each costs a driver compile) and shared
//! by every frame recorded here.

use super::commands::DescriptorArena;
use super::recording::FrameBindings;
use super::staging::Staging;
use super::{Buffer, Command, Context, Pipeline, RecordedFrame};
use crate::error::{Error, Result};
use crate::graph::{BufferId, Dispatch, Handle, Memory, Resources, Step, plan_barriers};
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
        let pipeline = Arc::new(Pipeline::new(&self.ctx, kernel.spec)?);
        self.pipelines.insert(kernel.spec.entry, pipeline.clone());
        Ok(pipeline)
    }

    /// Descriptor sets for every pass of every list in `step_lists` (one per distinct kernel
    /// and bindings), with the pipelines and buffers they use. Frames encoded from them hold
    /// them; dropping the last holder frees the descriptor pool.
    pub fn bind(&mut self, step_lists: &[&[Step]]) -> Result<Arc<FrameBindings>> {
        let mut distinct: Vec<(&'static str, Vec<BufferId>)> = Vec::new();
        let mut pipelines: HashMap<&'static str, Arc<Pipeline>> = HashMap::new();
        for step in step_lists.iter().flat_map(|s| s.iter()) {
            if let Step::Run(pass) = step {
                let key = (pass.kernel.spec.entry, pass.bindings.clone());
                if !distinct.contains(&key) {
                    distinct.push(key);
                }
                let pipeline = self.pipeline(pass.kernel)?;
                pipelines.insert(pass.kernel.spec.entry, pipeline);
            }
        }
        let total_bindings: usize = distinct.iter().map(|(_, b)| b.len()).sum();
        let arena = DescriptorArena::new(&self.ctx, distinct.len() as u32, total_bindings as u32)?;
        let mut sets = HashMap::new();
        for (entry, ids) in distinct {
            let bound: Vec<&Buffer> = ids.iter().map(|id| self.buffer(*id).map(|b| &**b)).collect::<Result<_>>()?;
            let set = arena.bind(&pipelines[entry], &bound)?;
            sets.insert((entry, ids), set);
        }
        // Every buffer of the engine: writes and fills may touch buffers no pass binds.
        let buffers = self.buffers.clone();
        Ok(Arc::new(FrameBindings { sets, pipelines, buffers, _arena: arena }))
    }

    /// `steps` as commands over `bindings` (which must cover every pass), with a barrier
    /// wherever a step reads or writes what an earlier one wrote, or writes what it read.
    pub fn encode(&self, bindings: &FrameBindings, steps: &[Step]) -> Result<Vec<Command>> {
        let handle = |id: BufferId| {
            bindings.buffers.get(id.index()).map(|b| b.handle).ok_or_else(|| engine_error(format!("{id:?} not bound")))
        };
        let mut commands = Vec::with_capacity(steps.len() * 2);
        for (step, barrier) in steps.iter().zip(plan_barriers(steps)) {
            if let Some(barrier) = barrier {
                commands.push(Command::Barrier(barrier));
            }
            commands.push(match step {
                Step::Fill { buffer, value } => Command::Fill { buffer: handle(*buffer)?, value: *value },
                Step::Write { buffer, offset, bytes } => {
                    if offset % 4 != 0 || bytes.len() % 4 != 0 {
                        return Err(engine_error(format!(
                            "write of {} bytes at {offset}: not 4-byte aligned",
                            bytes.len()
                        )));
                    }
                    Command::Write { buffer: handle(*buffer)?, offset: *offset, bytes: bytes.clone() }
                }
                Step::Skip { label } => Command::Skipped { label },
                Step::Run(pass) => {
                    let entry = pass.kernel.spec.entry;
                    let pipeline =
                        bindings.pipelines.get(entry).ok_or_else(|| engine_error(format!("`{entry}` not bound")))?;
                    let set = *bindings
                        .sets
                        .get(&(entry, pass.bindings.clone()))
                        .ok_or_else(|| engine_error(format!("pass `{}` was not bound", pass.label)))?;
                    let (groups, indirect) = match pass.dispatch {
                        Dispatch::Indirect(args) => (0, Some(handle(args.id())?)),
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
                        pipeline: pipeline.pipeline,
                        layout: pipeline.layout,
                        set,
                        push: pass.push.map(|p| bytemuck::bytes_of(&p).to_vec()).unwrap_or_default(),
                        groups,
                        indirect,
                    }
                }
            });
        }
        Ok(commands)
    }

    /// Binds and encodes `steps` into a frame of drape's own that can be submitted any number
    /// of times.
    pub fn record(&mut self, steps: &[Step], timed: bool) -> Result<RecordedFrame> {
        let bindings = self.bind(&[steps])?;
        let commands = self.encode(&bindings, steps)?;
        RecordedFrame::new(&self.ctx, bindings, &commands, timed)
    }
}
