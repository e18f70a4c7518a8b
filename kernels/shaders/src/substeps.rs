//! A small cloth's frame of integration in one dispatch: one workgroup runs every substep's
//! stages, with a workgroup barrier between stages where `integrate` has a dispatch and a
//! pipeline barrier.
//!
//! On a GPU a dispatch and its barrier cost about 8 µs however little they do (an H200 timed a
//! 2 x 2 cloth's stage at 8.1 µs, a 64^2 cloth's at 8.6), so a small cloth's frame costs more in
//! dispatches than in arithmetic. One workgroup runs on one multiprocessor, though: on the
//! H200 it wins up to about 32^2 particles (a 16^2 frame 154 -> 78 µs) and loses beyond (64^2:
//! 28 µs a stage against 8.6); `SimSettings::one_workgroup_substeps` chooses.
//!
//! The math is `integrate::integrate_stage_at`'s, particle by particle, in the same stages with
//! the same ping-pong buffers: the frame is the stage-per-dispatch frame's, bit for bit on a
//! driver that rounds both kernels alike (lavapipe; NVIDIA's compiler contracts the grid's
//! kernels differently, a few ulp).

use crate::integrate::{ClothForces, GridSprings, SpringList, StageBuffers, integrate_stage_at};
use drape_types::glam::{UVec3, Vec4};
use drape_types::{ParticleSprings, SimParams, Spring, SubstepsPush, integrator};
use spirv_std::spirv;

/// Lanes of the one workgroup (the most a Vulkan driver must allow).
pub const SUBSTEPS_THREADS: u32 = 1024;

/// Every buffer a frame's stages use: the state, both ping-pong pairs (A: `xa`, `va`; B: `xb`,
/// `vb`), the sums and the substep's start.
pub struct FrameBuffers<'a> {
    pub x: &'a mut [Vec4],
    pub v: &'a mut [Vec4],
    pub xa: &'a mut [Vec4],
    pub va: &'a mut [Vec4],
    pub xb: &'a mut [Vec4],
    pub vb: &'a mut [Vec4],
    pub acc_x: &'a mut [Vec4],
    pub acc_v: &'a mut [Vec4],
    pub x_prev: &'a mut [Vec4],
}

impl FrameBuffers<'_> {
    /// A stage that reads B and writes A (RK4's k1 and k3, both of Euler's).
    #[inline]
    fn b_to_a(&mut self) -> StageBuffers<'_> {
        StageBuffers {
            x: self.x,
            v: self.v,
            x_in: self.xb,
            v_in: self.vb,
            x_out: self.xa,
            v_out: self.va,
            acc_x: self.acc_x,
            acc_v: self.acc_v,
            x_prev: self.x_prev,
        }
    }

    /// A stage that reads A and writes B (RK4's k2 and k4).
    #[inline]
    fn a_to_b(&mut self) -> StageBuffers<'_> {
        StageBuffers {
            x: self.x,
            v: self.v,
            x_in: self.xa,
            v_in: self.va,
            x_out: self.xb,
            v_out: self.vb,
            acc_x: self.acc_x,
            acc_v: self.acc_v,
            x_prev: self.x_prev,
        }
    }
}

/// Stage `stage` for the particles of lane `lane` of `lanes` (every `lanes`-th from `lane`).
#[inline]
fn lane_stage<F: ClothForces>(p: &SimParams, stage: u32, (lane, lanes): (u32, u32), b: &mut StageBuffers, forces: &F) {
    let mut i = lane;
    while i < p.particle_count {
        integrate_stage_at(p, stage, i, b, forces);
        i += lanes;
    }
}

/// `substeps` substeps of lane `lane` of `lanes`, `barrier` after each stage (every lane must
/// call it: it holds barriers). The buffers' roles per stage are those `programs::cloth` gives
/// the stage-per-dispatch frame; each call below names its pair, so no buffer is chosen at run
/// time (a kernel must not hold pointers as data: `gpu::portability`). With one lane and no
/// barrier (the CPU twin) it is the stage-per-dispatch frame's loops in order.
#[inline]
pub fn frame_substeps<F: ClothForces>(
    p: &SimParams,
    substeps: u32,
    lanes: (u32, u32),
    f: &mut FrameBuffers,
    forces: &F,
    barrier: impl Fn(),
) {
    for _ in 0..substeps {
        if p.integrator == integrator::SEMI_IMPLICIT_EULER {
            lane_stage(p, 0, lanes, &mut f.b_to_a(), forces);
            barrier();
            lane_stage(p, 3, lanes, &mut f.b_to_a(), forces);
            barrier();
        } else {
            lane_stage(p, 0, lanes, &mut f.b_to_a(), forces);
            barrier();
            lane_stage(p, 1, lanes, &mut f.a_to_b(), forces);
            barrier();
            lane_stage(p, 2, lanes, &mut f.b_to_a(), forces);
            barrier();
            lane_stage(p, 3, lanes, &mut f.a_to_b(), forces);
            barrier();
        }
    }
}

/// Waits for the workgroup's lanes, what each wrote to storage buffers visible to the others.
#[inline]
fn storage_barrier() {
    #[cfg(target_arch = "spirv")]
    {
        use spirv_std::memory::{Scope, Semantics};
        spirv_std::arch::control_barrier::<
            { Scope::Workgroup as u32 },
            { Scope::Workgroup as u32 },
            { Semantics::ACQUIRE_RELEASE.bits() | Semantics::UNIFORM_MEMORY.bits() },
        >();
    }
}

/// A grid cloth's frame of `push.substeps` substeps; dispatched as one workgroup.
#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(1024)))]
pub fn integrate_substeps(
    #[spirv(local_invocation_id)] lid: UVec3,
    #[spirv(push_constant)] push: &SubstepsPush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &SimParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] x: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] v: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] xa: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] va: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] xb: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] vb: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] acc_x: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] acc_v: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] x_prev: &mut [Vec4],
) {
    let params = *params;
    let mut f = FrameBuffers { x, v, xa, va, xb, vb, acc_x, acc_v, x_prev };
    frame_substeps(&params, push.substeps, (lid.x, SUBSTEPS_THREADS), &mut f, &GridSprings, storage_barrier);
}

/// `integrate_substeps` for a spring-list cloth: bindings 10 and 11 hold its particles' spring
/// ranges and the springs.
#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(1024)))]
pub fn integrate_substeps_springs(
    #[spirv(local_invocation_id)] lid: UVec3,
    #[spirv(push_constant)] push: &SubstepsPush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &SimParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] x: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] v: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] xa: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] va: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] xb: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] vb: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] acc_x: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] acc_v: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] x_prev: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] particles: &[ParticleSprings],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] springs: &[Spring],
) {
    let params = *params;
    let mut f = FrameBuffers { x, v, xa, va, xb, vb, acc_x, acc_v, x_prev };
    let forces = SpringList { particles, springs };
    frame_substeps(&params, push.substeps, (lid.x, SUBSTEPS_THREADS), &mut f, &forces, storage_barrier);
}
