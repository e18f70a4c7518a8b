//! The integrator's last stage and the narrow phase over candidate lists in one pass.
//!
//! A particle's last stage (`integrate` stage 3: RK4's `k4 + update`, or Euler's commit) reads
//! its own state and its neighbours' intermediate state, never a neighbour's new position; its
//! narrow phase (`candidates::detect_candidates_at`) reads only its own motion. So one thread
//! can update a particle and then collide it, and the result is the separate passes' bit for
//! bit, without the culling pass, the detect pass and the barriers between them (on lavapipe
//! each dispatch costs tens of microseconds before it does any work; a substep had six).
//!
//! No culling pass decides whether the substep tests anything: a particle with an empty list
//! that stays inside its query box ends at a box test, and one that left it walks the tree,
//! whose root box rejects a motion far from the collider at once. (One difference from the
//! culling pass, which tests the cloth's box against the root box grown by the thickness: a
//! motion within the thickness's `CCD_SLACK` beyond that, in a frame that listed nothing, is
//! walked and may get the contact the leaf kind's grown test finds, where the cull skipped it.)

use crate::candidates::detect_candidates_particle;
use crate::contact::LeafKind;
use crate::crowded::CrowdedQueue;
use crate::integrate::{ClothForces, StageBuffers, integrate_stage_at};
use drape_types::glam::Vec4;
use drape_types::{
    Aabb, BvhNode, ColliderParams, ColliderPose, CollisionStatus, Contact, ContactPush, ContactQuery, Health, SimParams,
};

/// The integration stage this pass runs: the last, which writes the new state.
pub const UPDATE_STAGE: u32 = 3;

/// The stage's state and scratch buffers: `(x, v, x_prev)` and `(x_in, v_in, x_out, v_out,
/// acc_x, acc_v)` as in `integrate::StageBuffers`.
pub type UpdateState<'a> = (&'a mut [Vec4], &'a mut [Vec4], &'a mut [Vec4]);
pub type UpdateScratch<'a> = (&'a [Vec4], &'a [Vec4], &'a mut [Vec4], &'a mut [Vec4], &'a mut [Vec4], &'a mut [Vec4]);

/// Particle `index`'s last integration stage with `forces`, then its contact with the collider
/// over its candidate list (detected and applied at once), and invocation 0 counts the
/// substep (`count_substep`). Threads past the cloth do nothing.
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn update_and_contact_particle<K: LeafKind, F: ClothForces>(
    index: u32,
    push: &ContactPush,
    params: &SimParams,
    forces: &F,
    (x, v, x_prev): UpdateState<'_>,
    (x_in, v_in, x_out, v_out, acc_x, acc_v): UpdateScratch<'_>,
    (collider, pose): (&ColliderParams, &ColliderPose),
    tree: (&[BvhNode], &[Aabb], &[K::Leaf]),
    lists: (&[ContactQuery], &[u32]),
    contacts: &mut [Contact],
    (status, health, crowded): (&mut CollisionStatus, &mut Health, CrowdedQueue<'_>),
) {
    if index >= params.particle_count {
        return;
    }
    // Parameters in registers once, as the integrator's own pass does.
    let p = *params;
    {
        let mut stage =
            StageBuffers { x: &mut *x, v: &mut *v, x_in, v_in, x_out, v_out, acc_x, acc_v, x_prev: &mut *x_prev };
        integrate_stage_at(&p, UPDATE_STAGE, index, &mut stage, forces);
    }
    count_substep(index, status);
    let state = (x, &*x_prev, v);
    detect_candidates_particle::<K>(
        index,
        push,
        &p,
        collider,
        pose,
        tree,
        lists,
        state,
        contacts,
        (status, health, crowded),
    );
}

/// The substep in the collision counters, from invocation 0 alone: tested (`ran`) when the
/// frame's broad phase listed any particle near the collider, else `skipped` (particles that
/// left their query boxes still walk the tree; `fallbacks` counts them). `listed` is not
/// written during the substeps, so every invocation would read the same answer.
#[inline]
pub fn count_substep(index: u32, status: &mut CollisionStatus) {
    if index == 0 {
        if status.listed != 0 {
            status.ran += 1;
        } else {
            status.skipped += 1;
        }
    }
}
