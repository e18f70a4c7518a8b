//! drape's compute kernels. Each kernel is a thin `#[spirv(compute)]` entry point over a plain
//! function (`*_at`) that holds the math; the host's CPU executor calls those same functions, so
//! the GPU and the CPU run one source.
//!
//! Floating-point rule: kernels never divide floats; they multiply by an explicit reciprocal
//! (`x * (1.0 / y)`). Mesa's NIR lowers `a / b` to `a * rcp(b)`, so a plain division rounds
//! differently on the GPU than on the CPU; with explicit reciprocals both sides compute the
//! same operations and lavapipe matches the CPU bit for bit.
#![cfg_attr(target_arch = "spirv", no_std)]

pub mod atomics;
pub mod candidates;
pub mod cloth;
pub mod contact;
pub mod crowded;
pub mod feature_reach;
pub mod feature_walks;
pub mod health;
pub mod integrate;
pub mod lbvh;
pub mod normals;
pub mod pose;
pub mod render;
pub mod self_contact;
pub mod self_failsafe;
pub mod self_pairs;
pub mod self_pass_tree;
pub mod sharp_features;
pub mod sort;
pub mod spheres;
pub mod substeps;
pub mod tiles;
pub mod triangles;
pub mod update_contact;

#[cfg(test)]
mod test_random;

/// Threads per workgroup of every 1-D kernel here (the host divides by it).
pub const WORKGROUP_SIZE: u32 = 256;
