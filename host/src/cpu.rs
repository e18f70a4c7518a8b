//! The CPU executor: runs any step list (a cloth frame, an LBVH build, a sort) with each kernel's
//! CPU adapter, one workgroup after another, on host buffers allocated from the same
//! `Resources` the GPU uses. It is the GPU's twin in tests: same schedule, same kernel
//! functions, same f32 arithmetic up to instruction selection (FMA).

use crate::error::{Error, Result};
use crate::graph::{BufferId, Dispatch, Handle, HostBuffer, HostDispatch, Pass, Resources, Step};
use drape_types::DispatchArgs;

fn cpu_error(problem: impl Into<String>) -> Error {
    Error::Kernel { kernel: "cpu".into(), problem: problem.into() }
}

/// Host buffers for a `Resources`, and the interpreter of step lists over them.
#[derive(Default)]
pub struct CpuExecutor {
    buffers: Vec<HostBuffer>,
}

impl CpuExecutor {
    pub fn new(resources: &Resources) -> Self {
        let mut this = CpuExecutor::default();
        this.allocate(resources);
        this
    }

    /// Allocates (zeroed) every buffer of `resources` not allocated yet.
    pub fn allocate(&mut self, resources: &Resources) {
        for desc in &resources.descs()[self.buffers.len().min(resources.len())..] {
            self.buffers.push(HostBuffer::zeroed(desc.bytes));
        }
    }

    fn get(&self, id: BufferId) -> Result<&HostBuffer> {
        self.buffers.get(id.index()).ok_or_else(|| cpu_error(format!("buffer {id:?} not allocated")))
    }

    fn get_mut(&mut self, id: BufferId) -> Result<&mut HostBuffer> {
        self.buffers.get_mut(id.index()).ok_or_else(|| cpu_error(format!("buffer {id:?} not allocated")))
    }

    /// Overwrites the start of `id` with `data`.
    pub fn upload_bytes(&mut self, id: BufferId, data: &[u8]) -> Result<()> {
        self.get_mut(id)?.write(data).map_err(cpu_error)
    }

    pub fn upload<T: bytemuck::Pod>(&mut self, buffer: Handle<T>, data: &[T]) -> Result<()> {
        self.upload_bytes(buffer.id(), bytemuck::cast_slice(data))
    }

    /// The first `count` elements of `buffer`.
    pub fn read<T: bytemuck::Pod>(&self, buffer: Handle<T>, count: usize) -> Result<Vec<T>> {
        <Self as crate::graph::ReadBuffers>::read(self, buffer, count)
    }
}

impl crate::graph::ReadBuffers for CpuExecutor {
    fn read<T: bytemuck::Pod>(&self, buffer: Handle<T>, count: usize) -> Result<Vec<T>> {
        let all = self.get(buffer.id())?.slice::<T>();
        all.get(..count).map(<[T]>::to_vec).ok_or_else(|| cpu_error(format!("{buffer:?} holds fewer than {count}")))
    }
}

impl CpuExecutor {
    /// Runs `steps` in order.
    pub fn run(&mut self, steps: &[Step]) -> Result<()> {
        steps.iter().try_for_each(|step| self.run_step(step))
    }

    fn run_step(&mut self, step: &Step) -> Result<()> {
        match step {
            Step::Fill { buffer, value } => {
                self.get_mut(*buffer)?.fill(*value);
                Ok(())
            }
            Step::Write { buffer, offset, bytes } => self.get_mut(*buffer)?.write_at(*offset, bytes).map_err(cpu_error),
            Step::Skip { .. } => Ok(()),
            Step::Run(pass) => self.run_pass(pass),
        }
    }

    fn run_pass(&mut self, pass: &Pass) -> Result<()> {
        let spec = &pass.kernel.spec;
        let workgroups = match pass.dispatch {
            Dispatch::Indirect(args) => self.get(args.id())?.first::<DispatchArgs>().map_err(cpu_error)?.x,
            direct => direct.direct_workgroups(spec.workgroup_size).unwrap_or(0),
        };
        if pass.bindings.len() != spec.bindings.len() {
            return Err(cpu_error(format!(
                "pass `{}` binds {} buffers, {} declares {}",
                pass.label,
                pass.bindings.len(),
                spec.entry,
                spec.bindings.len()
            )));
        }
        // Take the bound buffers out (binding order), run, put them back.
        let mut bound = Vec::with_capacity(pass.bindings.len());
        for (slot, &id) in pass.bindings.iter().enumerate() {
            if pass.bindings[..slot].contains(&id) {
                return Err(cpu_error(format!("pass `{}` binds {id:?} twice", pass.label)));
            }
            bound.push(std::mem::take(self.get_mut(id)?));
        }
        let mut dispatch = HostDispatch {
            workgroups,
            workgroup_size: spec.workgroup_size,
            push: pass.push.unwrap_or_default(),
            buffers: &mut bound,
        };
        let result = (pass.kernel.cpu)(&mut dispatch);
        for (&id, buffer) in pass.bindings.iter().zip(bound) {
            self.buffers[id.index()] = buffer;
        }
        result.map_err(|problem| Error::Kernel { kernel: spec.entry.into(), problem })
    }
}
