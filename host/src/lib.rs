//! # drape
//!
//! GPU cloth simulation (mass-spring, explicit RK4) with automatic mesh colliders and a parallel
//! LBVH, after Mei et al. 2022. Kernels are Rust compiled to SPIR-V by rust-gpu
//! (`kernels/shaders`); this crate drives them with Vulkan through `ash`.
//!
//! ```no_run
//! use drape::{ClothBuilder, Context, SimSettings, Simulation, Validation};
//! let ctx = Context::new(Validation::from_env())?;
//! let cloth = ClothBuilder::new(64, 64).pin_top_corners().build()?;
//! let mut sim = Simulation::new(&ctx, &cloth, SimSettings::default())?;
//! for _ in 0..60 {
//!     let timings = sim.step()?; // per-pass GPU microseconds
//! }
//! let positions = sim.positions()?;
//! # Ok::<(), drape::Error>(())
//! ```

pub mod cloth;
pub mod collider;
mod controls;
pub mod cpu;
mod cpu_sim;
pub mod error;
pub mod gpu;
pub mod graph;
pub mod kernels;
pub mod lbvh;
pub mod mesh;
pub mod metrics;
pub mod obj;
mod program;
pub mod programs;
pub mod reference;
pub mod scenes;
pub mod sim;
pub mod stability;
pub mod timing;

pub use cloth::{Cloth, ClothBuilder};
pub use cpu_sim::CpuSimulation;
pub use drape_types::RigidPose;
pub use error::{Error, Result};
pub use gpu::{Context, ExternalDevice, FrameTimings, Validation};
pub use mesh::Mesh;
pub use sim::{Collider, FrameReport, Integrator, MemoryReport, SimSettings, Simulation, VertexBuffers, rigid_pose};
pub use stability::Stability;

include!(concat!(env!("OUT_DIR"), "/kernels_spv.rs"));
