//! Passes and the steps of a command list.

use super::hazards::Stages;
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
    /// Write of `len` bytes at `offset` only (host writes of single values): writes to disjoint
    /// ranges of one buffer need no barrier between them.
    WriteBytes {
        offset: u64,
        len: u64,
    },
}

impl Access {
    pub(super) fn writes(self) -> bool {
        matches!(self, Access::Write | Access::WriteBytes { .. })
    }

    /// The bytes touched (`None` = the whole buffer).
    fn range(self) -> Option<(u64, u64)> {
        match self {
            Access::WriteBytes { offset, len } => Some((offset, offset + len)),
            _ => None,
        }
    }

    pub(super) fn overlaps(self, other: Access) -> bool {
        match (self.range(), other.range()) {
            (Some((a0, a1)), Some((b0, b1))) => a0 < b1 && b0 < a1,
            _ => true,
        }
    }
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
    /// Write `bytes` into a buffer at `offset` (a host value that changed between frames:
    /// parameters, a collider's pose, a pinned particle). Recorded inline (`vkCmdUpdateBuffer`),
    /// so it is ordered with the frame on the queue and needs no staging or wait.
    Write {
        buffer: BufferId,
        offset: u64,
        bytes: Vec<u8>,
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

    /// Writes `data` into `buffer` from element `index` on.
    pub fn write<T: bytemuck::Pod>(buffer: Handle<T>, index: u32, data: &[T]) -> Step {
        Step::Write {
            buffer: buffer.id(),
            offset: index as u64 * size_of::<T>() as u64,
            bytes: bytemuck::cast_slice(data).to_vec(),
        }
    }

    /// Where this step's `access` happens: a fill or inline write in a transfer, a pass's
    /// indirect arguments where the dispatch reads them, its bindings in its kernel.
    pub fn stage_of(&self, access: Access) -> Stages {
        match (self, access) {
            (Step::Fill { .. } | Step::Write { .. }, _) => Stages::TRANSFER,
            (_, Access::IndirectRead) => Stages::INDIRECT,
            _ => Stages::KERNEL,
        }
    }

    /// Every buffer this step touches and how: what executors derive barriers from.
    pub fn accesses(&self) -> Vec<(BufferId, Access)> {
        match self {
            Step::Fill { buffer, .. } => vec![(*buffer, Access::Write)],
            Step::Write { buffer, offset, bytes } => {
                vec![(*buffer, Access::WriteBytes { offset: *offset, len: bytes.len() as u64 })]
            }
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
