//! drape's compute kernels. Each kernel is a thin `#[spirv(compute)]` entry point over a plain
//! function (`*_at`) that holds the math; the host's CPU executor calls those same functions, so
//! the GPU and the CPU run one source.
#![cfg_attr(target_arch = "spirv", no_std)]

pub mod atomics;
pub mod cloth;
pub mod health;
pub mod integrate;
pub mod normals;

/// Threads per workgroup of every 1-D kernel here (the host divides by it).
pub const WORKGROUP_SIZE: u32 = 256;
