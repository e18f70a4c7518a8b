//! What a kernel is to the host: its entry point and binding table (checked against the SPIR-V
//! by `tests/engine.rs`), and its CPU adapter, which runs the kernel's own functions on
//! `HostBuffer`s. Each kernel family defines its `Kernel`s in its own file under
//! `crate::kernels`; executors only see this struct.

use super::host::HostDispatch;

/// One storage-buffer binding as the kernel declares it.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct BindingSpec {
    /// The variable name in the kernel (checked against the SPIR-V).
    pub name: &'static str,
    /// `&mut` in the kernel: the pass writes it (and may read it).
    pub writable: bool,
}

/// A kernel's interface.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct KernelSpec {
    /// Entry point name in the SPIR-V module, e.g. `integrate::integrate_stage`.
    pub entry: &'static str,
    pub bindings: &'static [BindingSpec],
    /// Bytes of push constants (0 = none).
    pub push_constant_size: u32,
    /// Threads per workgroup (the kernel's `threads(..)`).
    pub workgroup_size: u32,
}

impl KernelSpec {
    /// A kernel without push constants.
    pub const fn new(entry: &'static str, bindings: &'static [BindingSpec], workgroup_size: u32) -> Self {
        KernelSpec { entry, bindings, push_constant_size: 0, workgroup_size }
    }
}

/// Runs a kernel's workgroups on the CPU.
pub type CpuKernelFn = fn(&mut HostDispatch<'_>) -> Result<(), String>;

/// A kernel: interface plus CPU adapter.
pub struct Kernel {
    pub spec: KernelSpec,
    pub cpu: CpuKernelFn,
}

impl std::fmt::Debug for Kernel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.spec.entry)
    }
}

impl PartialEq for Kernel {
    fn eq(&self, other: &Self) -> bool {
        self.spec.entry == other.spec.entry
    }
}

impl BindingSpec {
    pub const fn read(name: &'static str) -> Self {
        BindingSpec { name, writable: false }
    }
    pub const fn write(name: &'static str) -> Self {
        BindingSpec { name, writable: true }
    }
}
