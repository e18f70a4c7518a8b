//! Which of a collider's listed sharp triangles the cloth cannot reach over the span of its
//! pair lists (the frame, or a window of it), so that a pass walks the cloth's tree from only
//! those it can.
//!
//! On a scan most listed triangles lie away from the cloth, yet each walked the cloth's tree at
//! every pass (the bunny under a 64^2 cloth touching itself: 20 passes a frame, a third of its
//! GPU time). The lists already bound where each cloth triangle can be over their span: within
//! its corners' slops of their predicted paths, or it escapes its region and walks at that
//! pass (`self_pairs::escaped_at`). So, once per span, each listed triangle walks the lists'
//! tree with the box it sweeps over the frame (`frame_swept_box`), grown by the collider's
//! thickness and by gravity's share of the cloth's paths (`self_pairs::lists_tree_reaches`).
//! One that reaches no cloth triangle is marked `LISTED_FAR`. At each pass:
//! - the collider's side walks from the triangles not marked, listed again without the others
//!   (`near`, in the atomics' order, which changes no sum) (`collider_feature_contact`);
//! - each cloth triangle that escaped its region walks the collider's tree for the marked ones
//!   (`feature_walks::collider_features_from_walkers`);
//! - a marked triangle and a cloth triangle that kept to its region are out of each other's
//!   reach: the collider's walk would not have tested them.
//!
//! So each pair the collider's side tested before is tested once, by the same function
//! (`self_contact::collider_feature_contact_at`, told the one cloth leaf on the cloth's side),
//! and the sums are fixed-point: the same frames bit for bit. When the frame walks from the
//! cloth's side (`feature_walks::choose_feature_walks_at`), every cloth triangle takes every
//! listed triangle and nothing is marked.

use crate::contact::CONTACT_THREADS;
use crate::pose::{POSED_BOX_SLACK, rotate};
use crate::self_pairs::{FALL_WORD, lists_tree_reaches};
use drape_types::glam::{UVec3, Vec3, Vec4, Vec4Swizzles};
use drape_types::{Aabb, BvhNode, ColliderParams, ColliderPose, DispatchArgs, Health, WalkNode};
use spirv_std::spirv;

/// A collider triangle's flag (`sharp_features::list_sharp_features` writes 0 or `LISTED`):
/// listed as possibly sharp this frame.
pub const LISTED: u32 = 1;
/// Listed, and out of the reach of every cloth triangle that keeps to its predicted region over
/// the lists' span (`mark_out_of_reach_at`).
pub const LISTED_FAR: u32 = 2;
/// What a walk from the cloth's side takes: every listed triangle (`LISTED | LISTED_FAR`), or,
/// for a cloth triangle that escaped its region while the collider's side walks, the far ones.
pub const TAKE_EVERY_LISTED: u32 = LISTED | LISTED_FAR;

/// A box (world) that holds collider triangle `triangle` at every moment of the frame: its
/// corners lerped between the frame's two shapes (`previous`, `vertices`: the collider's own
/// frame) and placed by the pose the frame interpolates (`pose::interpolate`: the translation
/// lerped, the rotation along the great arc between its two ends). A point `m + d` of the
/// triangle's box in its frame (`m` its centre, `|d|` at most the half-diagonal) turns on an arc
/// about an axis through the origin, which stays within its sagitta, `|m| (1 - |q0 . q1|)`, of
/// the chord between its two turned ends; the translation moves along its own segment.
#[inline]
pub fn frame_swept_box(
    triangle: u32,
    (vertices, previous, indices): (&[Vec4], &[Vec4], &[u32]),
    pose: &ColliderPose,
) -> (Vec3, Vec3) {
    let i = 3 * triangle as usize;
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    let mut k = 0;
    while k < 3 {
        let v = indices[i + k] as usize;
        lo = lo.min(vertices[v].xyz()).min(previous[v].xyz());
        hi = hi.max(vertices[v].xyz()).max(previous[v].xyz());
        k += 1;
    }
    let (centre, half) = ((lo + hi) * 0.5, (hi - lo) * 0.5);
    let (q0, q1) = (pose.previous.rotation, pose.current.rotation);
    let (a0, a1) = (rotate(q0, centre), rotate(q1, centre));
    let (t0, t1) = (pose.previous.translation.xyz(), pose.current.translation.xyz());
    let cosine = q0.dot(q1).abs().min(1.0);
    let sagitta = centre.length() * (1.0 - cosine);
    let (swept_lo, swept_hi) = (a0.min(a1) + t0.min(t1), a0.max(a1) + t0.max(t1));
    let size = swept_lo.abs().max(swept_hi.abs()).max_element() + half.length() + sagitta;
    // The turns round as `to_world`'s do not quite: a few ulps of the coordinates' size.
    let grow = Vec3::splat(half.length() + sagitta + size * (4.0 * POSED_BOX_SLACK) + 1e-30);
    (swept_lo - grow, swept_hi + grow)
}

/// The `id`-th triangle of the frame's sharp list (`sharp`, its count in `sharp_args._pad`):
/// marked `LISTED_FAR` when no cloth triangle that keeps to its predicted region over the lists'
/// span can come within the collider's thickness of it (the span's tree: `tree`, `motions`,
/// `walk_nodes`; the cloth's `anchors`), counted in `health`; else appended to `near`, whose
/// indirect dispatch (`near_args`, emptied by the host before) the collider's side of the
/// span's passes runs over. Dispatched over the collider's side's own dispatch, which the
/// frame's choice empties when the cloth's side walks: then nothing is marked.
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn mark_out_of_reach_at(
    id: u32,
    (sharp, sharp_args): (&[u32], &DispatchArgs),
    mesh: (&[Vec4], &[Vec4], &[u32]),
    (collider, pose): (&ColliderParams, &ColliderPose),
    self_params: &ColliderParams,
    tree: (&[BvhNode], &[Aabb], &[Aabb]),
    motions: (&[Aabb], &[Aabb]),
    walk_nodes: &[WalkNode],
    anchors: &[Vec4],
    (listed, near, near_args): (&mut [u32], &mut [u32], &mut DispatchArgs),
    health: &mut Health,
) {
    if id >= sharp_args._pad {
        return;
    }
    let triangle = sharp[id as usize];
    let (lo, hi) = frame_swept_box(triangle, mesh, pose);
    // Gravity's share of every particle's predicted path over the span: particle 0's.
    let fall = anchors[FALL_WORD as usize].xyz().abs();
    let box_ = (lo - fall, hi + fall);
    if lists_tree_reaches(box_, collider.thickness, self_params.leaf_count, tree, motions, walk_nodes) {
        listed[triangle as usize] = LISTED;
        crate::atomics::append_for_dispatch(triangle, near, near_args, CONTACT_THREADS);
    } else {
        listed[triangle as usize] = LISTED_FAR;
        crate::atomics::add(&mut health.collider_features_out_of_reach, 1);
    }
}

/// One thread per listed sharp triangle (`mark_out_of_reach_at`), after the lists of each span
/// and the frame's choice of side, over the collider's side's dispatch.
#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(64)))]
pub fn mark_out_of_reach(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] self_params: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] collider: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] pose: &ColliderPose,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] vertices: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] previous: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] indices: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] sharp: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] sharp_args: &DispatchArgs,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] nodes: &[BvhNode],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] aabbs: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] leaf_bounds: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] motion_aabbs: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 12)] leaf_motions: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 13)] walk_nodes: &[WalkNode],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 14)] anchors: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 15)] listed: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 16)] near: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 17)] near_args: &mut DispatchArgs,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 18)] health: &mut Health,
) {
    mark_out_of_reach_at(
        id.x,
        (sharp, sharp_args),
        (vertices, previous, indices),
        (collider, pose),
        self_params,
        (nodes, aabbs, leaf_bounds),
        (motion_aabbs, leaf_motions),
        walk_nodes,
        anchors,
        (listed, near, near_args),
        health,
    );
}
