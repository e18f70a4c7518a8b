//! The host's binding table of every kernel, written once. `tests/engine.rs` checks each against
//! the SPIR-V (names, order, writability, push constants), so they cannot drift.

use crate::gpu::{BindingSpec, KernelSpec};
use drape_kernels::WORKGROUP_SIZE;

const fn read(name: &'static str) -> BindingSpec {
    BindingSpec { name, writable: false }
}
const fn write(name: &'static str) -> BindingSpec {
    BindingSpec { name, writable: true }
}

const INTEGRATE_STAGE: &[BindingSpec] = &[
    read("params"),
    write("x"),
    write("v"),
    read("x_in"),
    read("v_in"),
    write("x_out"),
    write("v_out"),
    write("acc_x"),
    write("acc_v"),
    write("x_prev"),
];
const VERTEX_NORMALS: &[BindingSpec] = &[read("params"), read("x"), write("normals")];
const CHECK_HEALTH: &[BindingSpec] = &[read("params"), read("x"), read("v"), write("health")];

/// The kernels drape dispatches.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum KernelId {
    IntegrateStage,
    VertexNormals,
    CheckHealth,
}

impl KernelId {
    pub const ALL: [KernelId; 3] = [KernelId::IntegrateStage, KernelId::VertexNormals, KernelId::CheckHealth];

    /// The kernel's entry point and binding table.
    pub fn spec(self) -> KernelSpec {
        match self {
            KernelId::IntegrateStage => KernelSpec {
                entry: "integrate::integrate_stage",
                bindings: INTEGRATE_STAGE,
                push_constant_size: size_of::<drape_types::StagePush>() as u32,
                workgroup_size: WORKGROUP_SIZE,
            },
            KernelId::VertexNormals => KernelSpec {
                entry: "normals::vertex_normals",
                bindings: VERTEX_NORMALS,
                push_constant_size: 0,
                workgroup_size: WORKGROUP_SIZE,
            },
            KernelId::CheckHealth => KernelSpec {
                entry: "health::check_health",
                bindings: CHECK_HEALTH,
                push_constant_size: 0,
                workgroup_size: WORKGROUP_SIZE,
            },
        }
    }
}
