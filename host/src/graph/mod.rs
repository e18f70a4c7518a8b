//! The description layer: work as data, with no Vulkan in it. Buffers are typed handles created
//! per simulation (`Resources`); a pass names a kernel, the buffers it binds (their access comes
//! from the kernel's binding table, so every pass declares what it reads and writes), push
//! constants and a dispatch size, direct or indirect. The Vulkan executor (`crate::gpu`) and the
//! CPU executor (`crate::cpu`) both run these step lists; neither is known here.

mod hazards;
mod host;
mod kernel;
mod resources;
mod step;

pub use hazards::{Barrier, HazardTracker, Stages, plan_barriers};
pub use host::{HostBuffer, HostDispatch};
pub use kernel::{BindingSpec, CpuKernelFn, Kernel, KernelSpec};
pub use resources::{BufferDesc, BufferId, Handle, Memory, ReadBuffers, Resources};
pub use step::{Access, Dispatch, Pass, Step};
