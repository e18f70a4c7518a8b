//! # drape
//!
//! GPU cloth simulation (mass-spring, explicit RK4) with automatic mesh colliders and a parallel
//! LBVH, after Mei et al. 2022. Kernels are Rust compiled to SPIR-V by rust-gpu
//! (`kernels/shaders`); this crate drives them with Vulkan through `ash`.
//!
//! The API has the shape of Warp/Newton and NvCloth: builders produce an immutable [`Model`]
//! (cloths, colliders, settings), a [`Solver`] advances its state on the GPU (a [`CpuSolver`]
//! on the CPU, bit for bit the same), and a [`State`] holds what changes as values.
//!
//! ```no_run
//! use drape::{ClothBuilder, Context, Model, SimSettings, Solver, Validation};
//! let ctx = Context::new(Validation::from_env())?;
//! let mut builder = Model::builder();
//! let cloth = builder.add_cloth(ClothBuilder::new(64, 64).pin_top_corners().build()?);
//! let model = builder.settings(SimSettings::default()).build()?;
//! let mut solver = Solver::new(&ctx, &model)?;
//! for _ in 0..60 {
//!     let timings = solver.step()?; // per-pass GPU microseconds
//! }
//! let positions = solver.positions(cloth)?;
//! # Ok::<(), drape::Error>(())
//! ```
//!
//! The modules below the public API (the description layer `graph`, the Vulkan executor `gpu`,
//! the kernels' binding tables, the sub-graphs, the CPU executor, the f64 reference) are
//! visible only with the `internals` feature, which drape's own tests and benchmarks enable;
//! they are not part of the API and change without notice.

/// Declares modules that are public only with the `internals` feature (tests, benchmarks).
macro_rules! internal_modules {
    ($($name:ident),* $(,)?) => {
        $(
            #[cfg(feature = "internals")]
            #[doc(hidden)]
            pub mod $name;
            #[cfg(not(feature = "internals"))]
            #[allow(dead_code, unused_imports)]
            mod $name;
        )*
    };
}

internal_modules!(cpu, gpu, graph, kernels, lbvh, programs, reference);
// rustfmt does not look inside macros: these declarations, compiled never, lead `cargo fmt` to
// the modules `internal_modules!` declares (it had left them unformatted).
#[cfg(any())]
mod cpu;
#[cfg(any())]
mod gpu;
#[cfg(any())]
mod graph;
#[cfg(any())]
mod kernels;
#[cfg(any())]
mod lbvh;
#[cfg(any())]
mod programs;
#[cfg(any())]
mod reference;

pub mod cloth;
pub mod cloth_mesh;
pub mod collider;
mod collider_cover;
mod collider_crease;
mod collider_curl;
mod collider_surface;
mod controls;
mod cpu_solver;
pub mod error;
pub mod mesh;
pub mod metrics;
mod model;
pub mod motion;
pub mod obj;
mod program;
pub mod render;
mod rest_gap;
pub mod scenes;
mod settings;
mod solver;
pub mod stability;
mod state;
pub mod timing;
pub mod topology;
pub mod usd;

pub use cloth::{Cloth, ClothBuilder, ClothTopology, DEFAULT_SELF_FRICTION, PieceMaterial};
pub use cloth_mesh::{ClothMesh, ClothUvs};
pub use cpu_solver::CpuSolver;
pub use drape_types::{RigidPose, SimParams};
pub use error::{Error, Result};
pub use gpu::{
    AllocatorStats, Context, DeviceInfo, ExternalDevice, FrameTimings, PassTiming, Validation, vulkan_loader_lock,
};
pub use lbvh::Lbvh;
pub use mesh::Mesh;
pub use model::{ClothId, Collider, ColliderId, ColliderShape, ContactSearch, Model, ModelBuilder, rigid_pose};
pub use motion::Sleep;
pub use programs::self_contact::FeatureWalks;
pub use settings::{Integrator, SimSettings};
pub use solver::{FrameReport, MemoryReport, Solver, VertexBuffers};
pub use stability::Stability;
pub use state::{ClothState, State, TileState};

include!(concat!(env!("OUT_DIR"), "/kernels_spv.rs"));

/// The SPIR-V module of entry point `entry` (its code only), if drape has that entry point.
pub fn kernel_module(entry: &str) -> Option<&'static [u8]> {
    KERNEL_MODULES.iter().find(|(name, _)| *name == entry).map(|&(_, spirv)| spirv)
}
