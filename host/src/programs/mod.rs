//! Reusable sub-graphs over handles: each declares the buffers it needs in a simulation's
//! `Resources` and emits its steps. A simulation composes them (cloth step, contact, LBVH build,
//! radix sort, scan); any of them can appear several times with different handles.

pub mod cloth;
pub mod contact;
pub mod lbvh;
pub mod scan;
pub mod self_contact;
pub mod self_failsafe;
pub mod sort;
pub mod spheres;
pub mod tiles;
pub mod triangles;

use crate::graph::{Handle, Step};
use drape_types::DispatchArgs;

/// Empties an indirect dispatch that kernels fill (`drape_kernels::atomics::append_for_dispatch`)
/// or write: no workgroups, and a count of 0 in `_pad`.
pub fn empty_dispatch(args: Handle<DispatchArgs>) -> Step {
    Step::write(args, 0, &[DispatchArgs { x: 0, y: 1, z: 1, _pad: 0 }])
}
