//! Work described as data: which kernel runs, on which buffers, with which push constants, how
//! many workgroups and under which timing label. The Vulkan engine records such a list; the CPU
//! executor runs the same list with the same kernel functions, so both follow one schedule.

use crate::kernels::KernelId;
use drape_types::{SortPush, StagePush, integrator};

/// Every buffer a simulation or an LBVH build binds.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum BufferId {
    Params,
    X,
    V,
    /// Ping-pong intermediate states of the Runge-Kutta stages.
    XA,
    VA,
    XB,
    VB,
    AccX,
    AccV,
    XPrev,
    Normals,
    Health,
    // Collider and LBVH.
    Collider,
    /// Spheres in input order, and in Morton order (the leaves).
    Spheres,
    SortedSpheres,
    /// Sort ping-pong: keys (Morton codes) and values (sphere indices).
    KeysA,
    ValuesA,
    KeysB,
    ValuesB,
    /// Digit counts per tile, then their exclusive scan.
    Counts,
    /// Block sums of the scan's levels.
    ScanSums(u8),
    Nodes,
    Parents,
    Flags,
    Aabbs,
    DispatchArgs,
    CollisionStatus,
}

/// How many workgroups a pass runs.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Groups {
    /// One thread per item, `ceil(n / workgroup size)` workgroups.
    Threads(u32),
    /// Exactly this many workgroups.
    Workgroups(u32),
    /// As many as the `DispatchArgs` in this buffer say (written by an earlier pass).
    Indirect(BufferId),
}

/// One dispatch.
#[derive(Clone, Debug, PartialEq)]
pub struct Pass {
    pub label: &'static str,
    pub kernel: KernelId,
    pub bindings: Vec<BufferId>,
    /// Push constants (16 bytes) for kernels that take them.
    pub push: Option<[u32; 4]>,
    pub groups: Groups,
}

/// One entry of a recorded command list.
#[derive(Clone, Debug, PartialEq)]
pub enum FrameStep {
    /// Fill a whole buffer with a 32-bit value.
    Fill {
        buffer: BufferId,
        value: u32,
    },
    Run(Pass),
    /// A pass the scene does not need: not recorded, reported as skipped.
    Skip {
        label: &'static str,
    },
}

/// What a cloth frame must do.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct FramePlan {
    pub particles: u32,
    pub substeps: u32,
    pub integrator: u32,
    pub normals: bool,
    /// Collision after every substep, and how.
    pub collision: CollisionMode,
}

/// How (and whether) a frame collides the cloth with its collider.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum CollisionMode {
    /// No collider: no collision pass is recorded.
    None,
    /// Cull against the root box, then traverse the LBVH (indirect dispatch).
    Bvh,
    /// Test every sphere for every particle (baseline for benchmarks and tests).
    BruteForce,
}

fn stage_pass(
    label: &'static str,
    stage: u32,
    input: (BufferId, BufferId),
    output: (BufferId, BufferId),
    n: u32,
) -> Pass {
    use BufferId::*;
    let push = StagePush { stage, _pad: [0; 3] };
    Pass {
        label,
        kernel: KernelId::IntegrateStage,
        bindings: vec![Params, X, V, input.0, input.1, output.0, output.1, AccX, AccV, XPrev],
        push: Some(bytemuck::cast(push)),
        groups: Groups::Threads(n),
    }
}

/// Label of the collision traversal pass.
pub const COLLIDE_LABEL: &str = "collide (BVH)";
/// Label of the culling pass.
pub const CULL_LABEL: &str = "collide: cull";

fn collision_passes(mode: CollisionMode, n: u32) -> Vec<FrameStep> {
    use BufferId::*;
    match mode {
        CollisionMode::None => vec![FrameStep::Skip { label: "collide" }],
        CollisionMode::Bvh => vec![
            FrameStep::Run(Pass {
                label: CULL_LABEL,
                kernel: KernelId::CullCollision,
                bindings: vec![Params, Collider, Aabbs, SortedSpheres, X, XPrev, DispatchArgs, CollisionStatus],
                push: None,
                groups: Groups::Workgroups(1),
            }),
            FrameStep::Run(Pass {
                label: COLLIDE_LABEL,
                kernel: KernelId::Collide,
                bindings: vec![Params, Collider, Nodes, Aabbs, SortedSpheres, X, V, XPrev, CollisionStatus],
                push: None,
                groups: Groups::Indirect(DispatchArgs),
            }),
        ],
        CollisionMode::BruteForce => vec![FrameStep::Run(Pass {
            label: "collide (brute force)",
            kernel: KernelId::CollideBruteForce,
            bindings: vec![Params, Collider, SortedSpheres, X, V, XPrev],
            push: None,
            groups: Groups::Threads(n),
        })],
    }
}

/// The passes of one frame: per substep the integration stages then the collision; then
/// normals (when asked) and the blow-up check.
pub fn cloth_frame(plan: FramePlan) -> Vec<FrameStep> {
    use BufferId::*;
    let n = plan.particles;
    let a = (XA, VA);
    let b = (XB, VB);
    let mut steps = vec![FrameStep::Fill { buffer: Health, value: 0 }];
    if plan.collision != CollisionMode::None {
        steps.push(FrameStep::Fill { buffer: CollisionStatus, value: 0 });
    }
    for substep in 0..plan.substeps {
        if plan.integrator == integrator::SEMI_IMPLICIT_EULER {
            steps.push(FrameStep::Run(stage_pass("euler: evaluate", 0, b, a, n)));
            steps.push(FrameStep::Run(stage_pass("euler: commit", 3, b, a, n)));
        } else {
            // Stage s reads the previous stage's output: A and B swap roles each stage.
            steps.push(FrameStep::Run(stage_pass("rk4: k1", 0, b, a, n)));
            steps.push(FrameStep::Run(stage_pass("rk4: k2", 1, a, b, n)));
            steps.push(FrameStep::Run(stage_pass("rk4: k3", 2, b, a, n)));
            steps.push(FrameStep::Run(stage_pass("rk4: k4 + update", 3, a, b, n)));
        }
        let collision = collision_passes(plan.collision, n);
        // A skipped pass is listed once, not once per substep.
        if substep == 0 || !matches!(collision[..], [FrameStep::Skip { .. }]) {
            steps.extend(collision);
        }
    }
    if plan.normals {
        steps.push(FrameStep::Run(Pass {
            label: "normals",
            kernel: KernelId::VertexNormals,
            bindings: vec![Params, X, Normals],
            push: None,
            groups: Groups::Threads(n),
        }));
    } else {
        steps.push(FrameStep::Skip { label: "normals" });
    }
    steps.push(FrameStep::Run(Pass {
        label: "health check",
        kernel: KernelId::CheckHealth,
        bindings: vec![Params, X, V, Health],
        push: None,
        groups: Groups::Threads(n),
    }));
    steps
}

/// Passes of an exclusive scan of `count` u32 in `data` (levels of `ScanSums`).
fn scan_steps(data: BufferId, count: u32, level: u8, steps: &mut Vec<FrameStep>) {
    use drape_kernels::sort::SCAN_BLOCK;
    let blocks = count.div_ceil(SCAN_BLOCK).max(1);
    let sums = BufferId::ScanSums(level);
    let push = SortPush { shift: 0, count, tiles: blocks, _pad: 0 };
    steps.push(FrameStep::Run(Pass {
        label: "sort: scan",
        kernel: KernelId::ScanBlocks,
        bindings: vec![data, sums],
        push: Some(bytemuck::cast(push)),
        groups: Groups::Workgroups(blocks),
    }));
    if blocks > 1 {
        scan_steps(sums, blocks, level + 1, steps);
        steps.push(FrameStep::Run(Pass {
            label: "sort: scan",
            kernel: KernelId::ScanAdd,
            bindings: vec![data, sums],
            push: Some(bytemuck::cast(push)),
            // Each thread adds to SCAN_ITEMS entries: one workgroup per block again.
            groups: Groups::Workgroups(blocks),
        }));
    }
}

/// Sizes (in u32) of the scan's block-sum buffers for `count` entries, level by level.
pub fn scan_levels(count: u32) -> Vec<u32> {
    use drape_kernels::sort::SCAN_BLOCK;
    let mut levels = Vec::new();
    let mut n = count;
    loop {
        let blocks = n.div_ceil(SCAN_BLOCK).max(1);
        levels.push(blocks);
        if blocks == 1 {
            return levels;
        }
        n = blocks;
    }
}

/// The LBVH build for `leaves` spheres: Morton codes, 4 radix passes, leaf gather, internal
/// nodes, bottom-up boxes. The sorted codes end in `KeysA`, the order in `ValuesA`.
pub fn lbvh_build(leaves: u32) -> Vec<FrameStep> {
    use BufferId::*;
    use drape_kernels::sort::{RADIX, SORT_TILE};
    let tiles = leaves.div_ceil(SORT_TILE).max(1);
    let mut steps = vec![FrameStep::Run(Pass {
        label: "morton codes",
        kernel: KernelId::MortonCodes,
        bindings: vec![Collider, Spheres, KeysA, ValuesA],
        push: None,
        groups: Groups::Threads(leaves),
    })];
    for pass in 0..4u32 {
        let push = bytemuck::cast(SortPush { shift: 8 * pass, count: leaves, tiles, _pad: 0 });
        let (keys_in, values_in, keys_out, values_out) =
            if pass % 2 == 0 { (KeysA, ValuesA, KeysB, ValuesB) } else { (KeysB, ValuesB, KeysA, ValuesA) };
        steps.push(FrameStep::Run(Pass {
            label: "sort: count",
            kernel: KernelId::RadixCount,
            bindings: vec![keys_in, Counts],
            push: Some(push),
            groups: Groups::Workgroups(tiles),
        }));
        scan_steps(Counts, RADIX * tiles, 0, &mut steps);
        steps.push(FrameStep::Run(Pass {
            label: "sort: scatter",
            kernel: KernelId::RadixScatter,
            bindings: vec![keys_in, values_in, Counts, keys_out, values_out],
            push: Some(push),
            groups: Groups::Workgroups(tiles),
        }));
    }
    steps.push(FrameStep::Run(Pass {
        label: "gather leaves",
        kernel: KernelId::GatherLeaves,
        bindings: vec![Collider, Spheres, ValuesA, SortedSpheres],
        push: None,
        groups: Groups::Threads(leaves),
    }));
    steps.push(FrameStep::Fill { buffer: Flags, value: 0 });
    // The refit writes xyz words only; zero the w words too.
    steps.push(FrameStep::Fill { buffer: Aabbs, value: 0 });
    steps.push(FrameStep::Run(Pass {
        label: "build nodes",
        kernel: KernelId::BuildNodes,
        bindings: vec![Collider, KeysA, Nodes, Parents],
        push: None,
        groups: Groups::Threads(leaves.saturating_sub(1).max(1)),
    }));
    steps.push(FrameStep::Run(Pass {
        label: "refit",
        kernel: KernelId::Refit,
        bindings: vec![Collider, Nodes, Parents, SortedSpheres, Flags, Aabbs],
        push: None,
        groups: Groups::Threads(leaves),
    }));
    steps
}
