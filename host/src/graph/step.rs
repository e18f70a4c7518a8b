//! Passes and the steps of a command list.

use super::kernel::Kernel;
use super::resources::{BufferId, Handle};
use drape_types::DispatchArgs;

/// How many workgroups a pass runs.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Dispatch {
    /// One thread per item: `ceil(n / workgroup size)` workgroups.
    Threads(u32),
    /// Exactly this many workgroups.
    Workgroups(u32),
    /// As many as the `DispatchArgs` in this buffer say (written by an earlier pass).
    Indirect(Handle<DispatchArgs>),
}

impl Dispatch {
    /// Workgroups of a direct dispatch (`None` for an indirect one).
    pub fn direct_workgroups(self, workgroup_size: u32) -> Option<u32> {
        match self {
            Dispatch::Threads(n) => Some(n.div_ceil(workgroup_size)),
            Dispatch::Workgroups(n) => Some(n),
            Dispatch::Indirect(_) => None,
        }
    }
}

/// How a step touches a buffer.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Access {
    Read,
    Write,
    /// Read as indirect dispatch arguments.
    IndirectRead,
}

/// One dispatch.
#[derive(Clone, Debug, PartialEq)]
pub struct Pass {
    /// Timing label (several passes may share one).
    pub label: &'static str,
    pub kernel: &'static Kernel,
    /// Buffer i goes to binding i.
    pub bindings: Vec<BufferId>,
    /// Push constants (16 bytes) for kernels that take them.
    pub push: Option<[u32; 4]>,
    pub dispatch: Dispatch,
}

/// One entry of a command list.
#[derive(Clone, Debug, PartialEq)]
pub enum Step {
    /// Fill a whole buffer with a 32-bit value.
    Fill {
        buffer: BufferId,
        value: u32,
    },
    Run(Pass),
    /// A pass the scene does not need: not recorded, reported as skipped.
    Skip {
        label: &'static str,
    },
}

impl Step {
    /// A pass of `kernel` over `bindings`.
    pub fn run(label: &'static str, kernel: &'static Kernel, bindings: Vec<BufferId>, dispatch: Dispatch) -> Step {
        Step::Run(Pass { label, kernel, bindings, push: None, dispatch })
    }

    /// A pass with push constants.
    pub fn run_with(
        label: &'static str,
        kernel: &'static Kernel,
        bindings: Vec<BufferId>,
        push: [u32; 4],
        dispatch: Dispatch,
    ) -> Step {
        Step::Run(Pass { label, kernel, bindings, push: Some(push), dispatch })
    }

    pub fn fill<T>(buffer: Handle<T>, value: u32) -> Step {
        Step::Fill { buffer: buffer.id(), value }
    }

    /// Every buffer this step touches and how: what executors derive barriers from.
    pub fn accesses(&self) -> Vec<(BufferId, Access)> {
        match self {
            Step::Fill { buffer, .. } => vec![(*buffer, Access::Write)],
            Step::Skip { .. } => Vec::new(),
            Step::Run(pass) => {
                let mut out: Vec<(BufferId, Access)> = pass
                    .bindings
                    .iter()
                    .zip(pass.kernel.spec.bindings)
                    .map(|(&id, spec)| (id, if spec.writable { Access::Write } else { Access::Read }))
                    .collect();
                if let Dispatch::Indirect(args) = pass.dispatch {
                    out.push((args.id(), Access::IndirectRead));
                }
                out
            }
        }
    }
}

/// Tracks accesses since the last barrier and says when the next step needs one: it reads or
/// writes something written since (read-after-write, write-after-write), or writes something
/// read since (write-after-read). A barrier covers every earlier command, so both sets reset.
#[derive(Default)]
pub struct HazardTracker {
    written: Vec<BufferId>,
    read: Vec<BufferId>,
}

impl HazardTracker {
    /// Whether `accesses` must wait for earlier steps; then records them.
    pub fn needs_barrier(&mut self, accesses: &[(BufferId, Access)]) -> bool {
        let hazard = accesses
            .iter()
            .any(|&(id, access)| self.written.contains(&id) || (access == Access::Write && self.read.contains(&id)));
        if hazard {
            self.written.clear();
            self.read.clear();
        }
        for &(id, access) in accesses {
            match access {
                Access::Write => self.written.push(id),
                Access::Read | Access::IndirectRead => self.read.push(id),
            }
        }
        hazard
    }
}
