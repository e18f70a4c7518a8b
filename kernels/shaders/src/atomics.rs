//! Device-scope atomics that also run on the CPU (one invocation at a time), so kernels that use
//! them keep a CPU twin. On SPIR-V they are real atomics; on the host, plain read-modify-writes.

use drape_types::DispatchArgs;
#[cfg(target_arch = "spirv")]
use spirv_std::memory::{Scope, Semantics};

/// Appends `value` to `list`, which an indirect dispatch of `threads`-wide workgroups covers
/// (`args`: x workgroups, the count in `_pad`; the host writes {0, 1, 1, 0} before). The first
/// entry of each workgroup's share raises x (atomics on one word are serialised: one in
/// `threads`, not every entry). The order is the atomics'. Returns the entry's slot.
#[inline]
pub fn append_for_dispatch(value: u32, list: &mut [u32], args: &mut DispatchArgs, threads: u32) -> u32 {
    let slot = add(&mut args._pad, 1);
    list[slot as usize] = value;
    if slot.is_multiple_of(threads) {
        max(&mut args.x, slot / threads + 1);
    }
    slot
}

/// `*target += value`, returns the old value.
#[inline]
pub fn add(target: &mut u32, value: u32) -> u32 {
    #[cfg(target_arch = "spirv")]
    unsafe {
        spirv_std::arch::atomic_i_add::<u32, { Scope::Device as u32 }, { Semantics::NONE.bits() }>(target, value)
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
        spirv_std::arch::atomic_u_max::<u32, { Scope::Device as u32 }, { Semantics::NONE.bits() }>(target, value)
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

/// `*target += value` on workgroup-shared memory, returns the old value.
#[inline]
pub fn add_workgroup(target: &mut u32, value: u32) -> u32 {
    #[cfg(target_arch = "spirv")]
    unsafe {
        spirv_std::arch::atomic_i_add::<u32, { Scope::Workgroup as u32 }, { Semantics::NONE.bits() }>(target, value)
    }
    #[cfg(not(target_arch = "spirv"))]
    {
        let old = *target;
        *target = old.wrapping_add(value);
        old
    }
}

/// `*target += value` with acquire-release ordering on device (storage buffer) memory: what
/// this invocation wrote before is visible to whoever sees the new value, and vice versa.
#[inline]
pub fn add_acq_rel(target: &mut u32, value: u32) -> u32 {
    #[cfg(target_arch = "spirv")]
    unsafe {
        spirv_std::arch::atomic_i_add::<
            u32,
            { Scope::Device as u32 },
            { Semantics::ACQUIRE_RELEASE.bits() | Semantics::UNIFORM_MEMORY.bits() },
        >(target, value)
    }
    #[cfg(not(target_arch = "spirv"))]
    {
        let old = *target;
        *target = old.wrapping_add(value);
        old
    }
}

/// Atomic (relaxed, device scope) load: data exchanged between invocations of one dispatch
/// goes through atomics so the acquire/release on the flag orders it (rust-gpu emits no
/// NonPrivate/MakeVisible operands for plain loads and stores).
#[inline]
pub fn load(source: &u32) -> u32 {
    #[cfg(target_arch = "spirv")]
    unsafe {
        spirv_std::arch::atomic_load::<u32, { Scope::Device as u32 }, { Semantics::NONE.bits() }>(source)
    }
    #[cfg(not(target_arch = "spirv"))]
    {
        *source
    }
}

/// Atomic (relaxed, device scope) store; see `load`.
#[inline]
pub fn store(target: &mut u32, value: u32) {
    #[cfg(target_arch = "spirv")]
    unsafe {
        spirv_std::arch::atomic_store::<u32, { Scope::Device as u32 }, { Semantics::NONE.bits() }>(target, value)
    }
    #[cfg(not(target_arch = "spirv"))]
    {
        *target = value;
    }
}

/// `*target = min(*target, value)` on an f32 stored as its bits, by compare-and-swap: the
/// smallest value any invocation brings ends there whatever their order. Writes nothing where
/// the word already holds `value` or less.
#[inline]
pub fn min_f32(target: &mut u32, value: f32) {
    replace_f32_while(target, value, true);
}

/// `*target = max(*target, value)` on an f32 stored as its bits (`min_f32`'s mirror).
#[inline]
pub fn max_f32(target: &mut u32, value: f32) {
    replace_f32_while(target, value, false);
}

/// Stores `value` in `target` (an f32's bits) while it is below (`lower`) or above the word's
/// value, retrying the compare-and-swap when another invocation changed the word between.
#[inline]
fn replace_f32_while(target: &mut u32, value: f32, lower: bool) {
    let beats = |old: u32| if lower { value < f32::from_bits(old) } else { value > f32::from_bits(old) };
    #[cfg(target_arch = "spirv")]
    unsafe {
        let mut old = load(target);
        while beats(old) {
            let seen = spirv_std::arch::atomic_compare_exchange::<
                u32,
                { Scope::Device as u32 },
                { Semantics::NONE.bits() },
                { Semantics::NONE.bits() },
            >(target, value.to_bits(), old);
            if seen == old {
                break;
            }
            old = seen;
        }
    }
    #[cfg(not(target_arch = "spirv"))]
    {
        if beats(*target) {
            *target = value.to_bits();
        }
    }
}
