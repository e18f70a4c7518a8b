//! A pass's collider features against the cloth (`self_contact::collider_feature_contact_at`)
//! walked from the cloth's side: each cloth triangle walks the collider's own tree for the
//! listed sharp triangles near it, where the collider's side has each listed triangle walk the
//! cloth's tree. The same pairs, each tested once by the same function, so the same sums.
//!
//! Which side pays depends on the counts: a scanned collider lists tens of thousands of sharp
//! triangles for a cloth of a few thousand (the dragon's 202,520 triangles, about 115,000
//! walks of the cloth's tree a pass, seven in eight of them finding no cloth triangle at all),
//! while a smooth or coarse one lists a handful, whose walks cost less than a walk per cloth
//! triangle. The frame's list decides (`choose_feature_walks_at`).
//!
//! Exactness: a collider triangle's walk of the cloth's tree tests cloth triangle `C` when `C`'s
//! box in the pass's tree meets the triangle's box swept over the pass (its corners placed by
//! the pose at the pass's start and end, lerped between the frame's two shapes), grown by the
//! thickness. Those corners lie in the collider's leaf box (the tree's leaf boxes hold both
//! shapes of a deforming collider), so the box swept over the pass lies in the box around that
//! leaf box placed by both poses (`posed_box`, a little wider than exact). The cloth's walk
//! enters every collider subtree whose box, so placed, meets `C`'s box grown by the thickness,
//! and hands each listed triangle it finds to the same test, told to test `C` alone
//! (`PairWalk::one`): it tests `C` exactly when the collider's walk would have.

use crate::contact::{CONTACT_THREADS, substep_motion};
use crate::feature_reach::{LISTED_FAR, TAKE_EVERY_LISTED};
use crate::lbvh::{PairBoxes, PairWalk, WALK_BATCH, box_meets};
use crate::pose::{SubstepMotion, abs_rotation_rows, posed_box};
use crate::self_contact::{PairResponse, SelfTree, arm_second_refit, collider_feature_contact_at, tested_features};
use drape_types::glam::{UVec3, UVec4, Vec3, Vec4, Vec4Swizzles};
use drape_types::{Aabb, BvhNode, ColliderParams, ColliderPose, ContactPush, DispatchArgs, RigidPose, SimParams};
use spirv_std::spirv;

/// Which side walks (`choose_feature_walks_at`'s push constant): the frame's list decides.
pub const WALKS_AUTOMATIC: u32 = 0;
/// Every listed collider triangle walks the cloth's tree.
pub const WALKS_FROM_COLLIDER: u32 = 1;
/// Every cloth triangle walks the collider's tree.
pub const WALKS_FROM_CLOTH: u32 = 2;

/// The automatic choice walks from the cloth's side when the collider lists more than this
/// many sharp triangles per cloth triangle. Measured on lavapipe, per pass, 64^2 cloth (7,938
/// triangles): the dragon lists over 4 per cloth triangle in every frame, its collider's side
/// took 9.9 ms and the cloth's 7.2; the bunny at most 2, 2.9 ms against 8.1; a 16^2 cloth on
/// the icosphere, 2.8, 0.80 ms against 0.88. The cloth's side costs about the same whatever
/// the collider lists (its walks reach the collider's leaves near the cloth); the collider's
/// grows with the list.
pub const CLOTH_SIDE_RATIO: u32 = 4;

/// Writes the pass's two indirect dispatches from the frame's list of sharp triangles
/// (`listed`, its count in `_pad`) and the cloth's triangles (`cloth_triangles`): one of them
/// dispatched, the other over no workgroup. Returns whether the cloth's side walks. (A frame
/// that marks the listed triangles out of the cloth's reach, `feature_reach`, marks nothing when
/// the cloth's side walks.)
#[inline]
pub fn choose_feature_walks_at(
    mode: u32,
    listed: &DispatchArgs,
    cloth_triangles: u32,
    (from_collider, from_cloth): (&mut DispatchArgs, &mut DispatchArgs),
) -> bool {
    let cloth_side = match mode {
        WALKS_FROM_CLOTH => true,
        WALKS_FROM_COLLIDER => false,
        _ => listed._pad > CLOTH_SIDE_RATIO * cloth_triangles,
    };
    // Nothing listed: nothing to walk from either side.
    let any = listed._pad > 0;
    let cloth_groups = if cloth_side && any { cloth_triangles.div_ceil(CONTACT_THREADS) } else { 0 };
    let collider_groups = if cloth_side { 0 } else { listed.x };
    *from_collider = DispatchArgs { x: collider_groups, y: 1, z: 1, _pad: 0 };
    *from_cloth = DispatchArgs { x: cloth_groups, y: 1, z: 1, _pad: 0 };
    cloth_groups > 0
}

/// The collider's subtrees and leaves whose boxes, placed in the world by the pass's start
/// and end poses, meet the query box (a cloth triangle's box grown by the thickness).
#[derive(Copy, Clone)]
struct PosedQuery<'a> {
    aabbs: &'a [Aabb],
    leaf_bounds: &'a [Aabb],
    start: RigidPose,
    end: RigidPose,
    start_rows: [Vec3; 3],
    end_rows: [Vec3; 3],
    /// The pose is the same at both ends: one placing.
    still: bool,
    lo: Vec3,
    hi: Vec3,
}

impl<'a> PosedQuery<'a> {
    /// The query `(lo, hi)` (world) over collider boxes `aabbs` and `leaf_bounds` placed by
    /// `motion`'s poses.
    #[inline]
    fn new(aabbs: &'a [Aabb], leaf_bounds: &'a [Aabb], motion: &SubstepMotion, (lo, hi): (Vec3, Vec3)) -> Self {
        let (start, end) = (motion.start, motion.end);
        PosedQuery {
            aabbs,
            leaf_bounds,
            start,
            end,
            start_rows: abs_rotation_rows(start.rotation),
            end_rows: abs_rotation_rows(end.rotation),
            still: start.rotation == end.rotation && start.translation == end.translation,
            lo,
            hi,
        }
    }

    /// Whether collider-frame box `b`, placed by either pose and everything between (the box
    /// around both), meets the query.
    #[inline]
    fn meets(&self, b: &Aabb) -> bool {
        let (start_lo, start_hi) = posed_box(&self.start, &self.start_rows, b);
        if self.still {
            return box_meets(&Aabb { min: start_lo.extend(0.0), max: start_hi.extend(0.0) }, self.lo, self.hi);
        }
        let (end_lo, end_hi) = posed_box(&self.end, &self.end_rows, b);
        let swept = Aabb { min: start_lo.min(end_lo).extend(0.0), max: start_hi.max(end_hi).extend(0.0) };
        box_meets(&swept, self.lo, self.hi)
    }
}

impl PairBoxes for PosedQuery<'_> {
    type NodeBoxes = Aabb;

    #[inline]
    fn node_boxes(&self, node: u32) -> Aabb {
        self.aabbs[node as usize]
    }

    #[inline]
    fn node_meets(&self, b: &Aabb) -> bool {
        self.meets(b)
    }

    #[inline]
    fn leaf_meets(&self, leaf: u32) -> bool {
        self.meets(&self.leaf_bounds[leaf as usize])
    }
}

/// A triangle collider's mesh and what the frame listed of it: vertices at the frame's end and
/// start, triangle indices, each triangle's features (`collider_features`) and whether the
/// frame listed it as possibly sharp (`sharp_features::list_sharp_features`).
pub type ListedMesh<'a> = (&'a [Vec4], &'a [Vec4], &'a [u32], &'a [UVec4], &'a [u32]);

/// The collider's tree: nodes, node boxes and leaf boxes (its own frame, tree order) and each
/// leaf's triangle.
pub type ColliderTree<'a> = (&'a [BvhNode], &'a [Aabb], &'a [Aabb], &'a [u32]);

/// The cloth's side of a pass's collider features: cloth triangle `leaf` (the pass tree's
/// sorted leaf) against every listed collider triangle near it whose flag is in `take`
/// (`feature_reach::TAKE_EVERY_LISTED`, or `LISTED_FAR` for a triangle that escaped its region
/// while the collider's side walks), each through `collider_feature_contact_at` for this leaf
/// alone. Returns whether a collider edge pushed a cloth edge.
#[allow(clippy::too_many_arguments)]
pub fn collider_features_of_cloth_triangle_at(
    (leaf, take): (u32, u32),
    (vertices, previous, indices, features, listed): ListedMesh<'_>,
    (collider_nodes, collider_aabbs, collider_leaves, order): ColliderTree<'_>,
    collider: &ColliderParams,
    motion: &SubstepMotion,
    self_params: &ColliderParams,
    tree: SelfTree<'_>,
    cloth_owned: &[u32],
    (x, x_prev, v): (&[Vec4], &[Vec4], &[Vec4]),
    (delta, velocity_changes, pushes, health): (&mut [u32], &mut [u32], &mut [u32], &mut drape_types::Health),
) -> bool {
    let reach = Vec3::splat(collider.thickness);
    let own = &tree.2[leaf as usize];
    let query = (own.min.xyz() - reach, own.max.xyz() + reach);
    let boxes = PosedQuery::new(collider_aabbs, collider_leaves, motion, query);
    let mut walk = PairWalk::all(collider.leaf_count);
    let mut found = [0u32; WALK_BATCH];
    let mut pushed = false;
    while !walk.done() {
        let count = walk.next_batch_in(collider_nodes, boxes, &mut found);
        let mut k = 0;
        while k < count {
            let triangle = order[found[k] as usize];
            if listed[triangle as usize] & take != 0 {
                let out = PairResponse {
                    thickness: collider.thickness,
                    friction: collider.friction,
                    v,
                    rest: x, // a collider's pairs never read it
                    delta: &mut *delta,
                    velocity_changes: &mut *velocity_changes,
                };
                let mine = tested_features(features[triangle as usize], collider);
                let edge_pushed = collider_feature_contact_at(
                    triangle,
                    mine,
                    (vertices, previous, indices),
                    motion,
                    self_params,
                    (tree, leaf),
                    cloth_owned,
                    (x, x_prev),
                    (out, &mut *pushes, &mut *health),
                );
                pushed = pushed || edge_pushed;
            }
            k += 1;
        }
    }
    pushed
}

/// One thread, after the frame's list of a collider's sharp triangles: the pass's dispatches
/// from the collider's side and from the cloth's (`choose_feature_walks_at`), counting the
/// cloth's side in `Health::feature_walks_from_cloth`. Push constant: the mode
/// (`WALKS_AUTOMATIC`, ...), in `DispatchArgs::x`.
#[spirv(compute(threads(1)))]
pub fn choose_feature_walks(
    #[spirv(push_constant)] mode: &DispatchArgs,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] self_params: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] listed_args: &DispatchArgs,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] from_collider: &mut DispatchArgs,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] from_cloth: &mut DispatchArgs,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] health: &mut drape_types::Health,
) {
    if choose_feature_walks_at(mode.x, listed_args, self_params.leaf_count, (from_collider, from_cloth)) {
        // Atomic: another collider's choice may run beside this one.
        crate::atomics::add(&mut health.feature_walks_from_cloth, 1);
    }
}

#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(64)))]
pub fn collider_features_from_cloth(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] push: &ContactPush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &SimParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] self_params: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] collider: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] pose: &ColliderPose,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] vertices: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] previous: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] indices: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] features: &[UVec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] listed: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] collider_nodes: &[BvhNode],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] collider_aabbs: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] collider_leaves: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 12)] order: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 13)] nodes: &[BvhNode],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 14)] aabbs: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 15)] leaf_bounds: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 16)] sorted: &[UVec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 17)] owned: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 18)] x: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 19)] x_prev: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 20)] v: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 21)] delta: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 22)] velocity_changes: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 23)] pushes: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 24)] health: &mut drape_types::Health,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 25)] features_found: &mut DispatchArgs,
) {
    if id.x >= self_params.leaf_count {
        return;
    }
    let motion = substep_motion(params, pose, push);
    let pushed = collider_features_of_cloth_triangle_at(
        (id.x, TAKE_EVERY_LISTED),
        (vertices, previous, indices, features, listed),
        (collider_nodes, collider_aabbs, collider_leaves, order),
        collider,
        &motion,
        self_params,
        (nodes, aabbs, leaf_bounds, sorted),
        owned,
        (x, x_prev, v),
        (delta, velocity_changes, pushes, health),
    );
    if pushed {
        arm_second_refit(self_params, features_found);
    }
}

/// One thread per cloth triangle that escaped its region in the pass (the pass's walkers,
/// `self_pairs::note_escape`: sorted leaves, their count in `walk_args._pad`), when the frame
/// walks from the collider's side (`from_cloth` dispatches nothing): against the listed collider
/// triangles the lists marked out of the cloth's reach (`feature_reach::LISTED_FAR`), which the
/// collider's side leaves to them. Nothing when the frame has marked none so far
/// (`Health::collider_features_out_of_reach`, zeroed at the frame's start): a smooth collider
/// lists none, and a walk of its whole tree finding no marked triangle cost each escaped
/// triangle as much as its contact walk. Push constants: `ContactPush`.
#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(64)))]
pub fn collider_features_from_walkers(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] push: &ContactPush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &SimParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] self_params: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] collider: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] pose: &ColliderPose,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] vertices: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] previous: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] indices: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] features: &[UVec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] listed: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] collider_nodes: &[BvhNode],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] collider_aabbs: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] collider_leaves: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 12)] order: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 13)] nodes: &[BvhNode],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 14)] aabbs: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 15)] leaf_bounds: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 16)] sorted: &[UVec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 17)] owned: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 18)] x: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 19)] x_prev: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 20)] v: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 21)] walkers: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 22)] walk_args: &DispatchArgs,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 23)] from_cloth: &DispatchArgs,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 24)] delta: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 25)] velocity_changes: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 26)] pushes: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 27)] health: &mut drape_types::Health,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 28)] features_found: &mut DispatchArgs,
) {
    if id.x >= walk_args._pad || from_cloth.x != 0 || health.collider_features_out_of_reach == 0 {
        return;
    }
    let leaf = walkers[id.x as usize];
    let motion = substep_motion(params, pose, push);
    let pushed = collider_features_of_cloth_triangle_at(
        (leaf, LISTED_FAR),
        (vertices, previous, indices, features, listed),
        (collider_nodes, collider_aabbs, collider_leaves, order),
        collider,
        &motion,
        self_params,
        (nodes, aabbs, leaf_bounds, sorted),
        owned,
        (x, x_prev, v),
        (delta, velocity_changes, pushes, health),
    );
    if pushed {
        arm_second_refit(self_params, features_found);
    }
}
