//! Device-scope atomics that also run on the CPU (one invocation at a time), so kernels that use
//! them keep a CPU twin. On SPIR-V they are real atomics; on the host, plain read-modify-writes.

#[cfg(target_arch = "spirv")]
use spirv_std::memory::{Scope, Semantics};

/// `*target += value`, returns the old value.
#[inline]
pub fn add(target: &mut u32, value: u32) -> u32 {
    #[cfg(target_arch = "spirv")]
    unsafe {
        spirv_std::arch::atomic_i_add::<u32, { Scope::Device as u32 }, { Semantics::NONE.bits() }>(
            target, value,
        )
    }
    #[cfg(not(target_arch = "spirv"))]
    {
        let old = *target;
        *target = old.wrapping_add(value);
        old
    }
}

/// `*target = max(*target, value)` (unsigned), returns the old value.
#[inline]
pub fn max(target: &mut u32, value: u32) -> u32 {
    #[cfg(target_arch = "spirv")]
    unsafe {
        spirv_std::arch::atomic_u_max::<u32, { Scope::Device as u32 }, { Semantics::NONE.bits() }>(
            target, value,
        )
    }
    #[cfg(not(target_arch = "spirv"))]
    {
        let old = *target;
        if value > old {
            *target = value;
        }
        old
    }
}
