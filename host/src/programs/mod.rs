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
