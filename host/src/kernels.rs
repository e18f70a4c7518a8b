//! The host's binding table of every kernel, written once. `tests/engine.rs` checks each against
//! the SPIR-V (names, order, writability, push constants), so they cannot drift.

use crate::gpu::{BindingSpec, KernelSpec};
use drape_kernels::WORKGROUP_SIZE;
use drape_kernels::collide::{COLLIDE_THREADS, CULL_THREADS};
use drape_kernels::sort::SORT_TILE;

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

const RADIX_COUNT: &[BindingSpec] = &[read("keys"), write("counts")];
const RADIX_SCATTER: &[BindingSpec] =
    &[read("keys_in"), read("values_in"), read("offsets"), write("keys_out"), write("values_out")];
const SCAN_BLOCKS: &[BindingSpec] = &[write("data"), write("sums")];
const SCAN_ADD: &[BindingSpec] = &[write("data"), read("sums")];
const MORTON_CODES: &[BindingSpec] = &[read("collider"), read("spheres"), write("keys"), write("values")];
const GATHER_LEAVES: &[BindingSpec] = &[read("collider"), read("spheres"), read("order"), write("sorted")];
const BUILD_NODES: &[BindingSpec] = &[read("collider"), read("codes"), write("nodes"), write("parents")];
const REFIT: &[BindingSpec] =
    &[read("collider"), read("nodes"), read("parents"), read("sorted"), write("flags"), write("aabbs")];
const COLLIDE: &[BindingSpec] = &[
    read("params"),
    read("collider"),
    read("nodes"),
    read("aabbs"),
    read("spheres"),
    write("x"),
    write("v"),
    read("x_prev"),
    write("status"),
];
const COLLIDE_BRUTE_FORCE: &[BindingSpec] =
    &[read("params"), read("collider"), read("spheres"), write("x"), write("v"), read("x_prev")];
const CULL_COLLISION: &[BindingSpec] = &[
    read("params"),
    read("collider"),
    read("aabbs"),
    read("spheres"),
    read("x"),
    read("x_prev"),
    write("args"),
    write("status"),
];

/// The kernels drape dispatches.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum KernelId {
    IntegrateStage,
    VertexNormals,
    CheckHealth,
    RadixCount,
    RadixScatter,
    ScanBlocks,
    ScanAdd,
    MortonCodes,
    GatherLeaves,
    BuildNodes,
    Refit,
    Collide,
    CollideBruteForce,
    CullCollision,
}

impl KernelId {
    pub const ALL: [KernelId; 14] = [
        KernelId::IntegrateStage,
        KernelId::VertexNormals,
        KernelId::CheckHealth,
        KernelId::RadixCount,
        KernelId::RadixScatter,
        KernelId::ScanBlocks,
        KernelId::ScanAdd,
        KernelId::MortonCodes,
        KernelId::GatherLeaves,
        KernelId::BuildNodes,
        KernelId::Refit,
        KernelId::Collide,
        KernelId::CollideBruteForce,
        KernelId::CullCollision,
    ];

    /// The kernel's entry point and binding table.
    pub fn spec(self) -> KernelSpec {
        let sort_push = size_of::<drape_types::SortPush>() as u32;
        let spec = |entry, bindings, push_constant_size, workgroup_size| KernelSpec {
            entry,
            bindings,
            push_constant_size,
            workgroup_size,
        };
        match self {
            KernelId::IntegrateStage => spec(
                "integrate::integrate_stage",
                INTEGRATE_STAGE,
                size_of::<drape_types::StagePush>() as u32,
                WORKGROUP_SIZE,
            ),
            KernelId::VertexNormals => spec("normals::vertex_normals", VERTEX_NORMALS, 0, WORKGROUP_SIZE),
            KernelId::CheckHealth => spec("health::check_health", CHECK_HEALTH, 0, WORKGROUP_SIZE),
            KernelId::RadixCount => spec("sort::radix_count", RADIX_COUNT, sort_push, SORT_TILE),
            KernelId::RadixScatter => spec("sort::radix_scatter", RADIX_SCATTER, sort_push, SORT_TILE),
            KernelId::ScanBlocks => spec("sort::scan_blocks", SCAN_BLOCKS, sort_push, 256),
            KernelId::ScanAdd => spec("sort::scan_add", SCAN_ADD, sort_push, 256),
            KernelId::MortonCodes => spec("lbvh::morton_codes", MORTON_CODES, 0, 256),
            KernelId::GatherLeaves => spec("lbvh::gather_leaves", GATHER_LEAVES, 0, 256),
            KernelId::BuildNodes => spec("lbvh::build_nodes", BUILD_NODES, 0, 256),
            KernelId::Refit => spec("lbvh::refit", REFIT, 0, 256),
            KernelId::Collide => spec("collide::collide", COLLIDE, 0, COLLIDE_THREADS),
            KernelId::CollideBruteForce => {
                spec("collide::collide_brute_force", COLLIDE_BRUTE_FORCE, 0, COLLIDE_THREADS)
            }
            KernelId::CullCollision => spec("collide::cull_collision", CULL_COLLISION, 0, CULL_THREADS),
        }
    }
}
