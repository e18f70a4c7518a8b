//! Cloth-vs-collider contact (design.md §1), generic over the collider's leaf kind, in two
//! passes per substep:
//! - **detect**: each particle walks the collider's LBVH (stackless, `lbvh::walk`) and writes its
//!   earliest contact (`drape_types::Contact`: where it goes and the surface normal there) or
//!   "none". What a leaf is (a sphere, later a triangle) is a `LeafKind`: its hit test, the box
//!   test that prunes subtrees, and the contact geometry of the chosen leaf.
//! - **respond**: each particle with a contact moves to it and keeps only the tangential part of
//!   its velocity relative to the collider's surface (Coulomb friction on top).
//!
//! A one-workgroup culling pass first tests the cloth's swept bounds against the collider's root
//! box and writes both passes' indirect dispatch, with zero workgroups when they cannot touch.
//!
//! The LBVH lives in the collider's own frame. Each substep, a particle's start and end
//! positions are taken into that frame with the collider's pose at the substep's start and end
//! (interpolated from the frame's previous and current pose), so the test sees the motion
//! relative to the collider: a moving collider sweeps the cloth instead of jumping through it.
//! A static collider (identity poses) gives exactly the frame-fixed test.

use crate::lbvh::{TreeQuery, walk};
use crate::pose::{SubstepMotion, rotate, rotate_inverse, to_local, to_world};
use crate::tiles::sleeping;
use drape_types::glam::{UVec3, Vec3, Vec4, Vec4Swizzles};
use drape_types::{
    Aabb, BvhNode, ColliderParams, ColliderPose, CollisionStatus, Contact, ContactPush, DispatchArgs, NO_LEAF,
    SimParams,
};
use spirv_std::spirv;

/// What the traversal needs to know about a kind of leaf. Implemented by zero-sized types
/// (`spheres::Spheres`); the traversal is monomorphised per kind, on the GPU and the CPU.
pub trait LeafKind {
    /// One leaf as the detect pass reads it (tree order).
    type Leaf: Copy;
    /// Whether the subtree under box `b` can hold a contact of the motion `p0 -> p1`.
    fn may_touch(b: &Aabb, p0: Vec3, p1: Vec3, thickness: f32) -> bool;
    /// The contact of `p0 -> p1` with `leaf` grown by `thickness`: hit parameter in [0, 1]
    /// (0 = `p0` already within it; > 1 = no contact) and the kind's tie-break key: among
    /// leaves hit at the same parameter the smallest key wins.
    fn hit(leaf: Self::Leaf, p0: Vec3, p1: Vec3, thickness: f32) -> (f32, f32);
    /// Where a particle with the hit `t` goes and the outward unit normal there.
    fn surface(leaf: Self::Leaf, p0: Vec3, p1: Vec3, t: f32, thickness: f32) -> (Vec3, Vec3);
    /// Whether the straight path from `p0` to where `surface` sends the particle must be checked
    /// against every leaf (`blocks`); when it is blocked the particle stops at its first
    /// contact, `p0 + (p1 - p0) t`, instead.
    fn checks_path() -> bool {
        false
    }
    /// Whether the path `a -> b` passes through `leaf`'s surface (only asked when
    /// `checks_path`).
    fn blocks(_leaf: Self::Leaf, _a: Vec3, _b: Vec3, _thickness: f32) -> bool {
        false
    }
    /// A lower bound on the distance from `p` to `leaf`'s surface (only asked when
    /// `checks_path`): a path from `p` shorter than every leaf's bound crosses nothing, so its
    /// check can be skipped.
    fn clearance(_leaf: Self::Leaf, _p: Vec3) -> f32 {
        0.0
    }
    /// Whether the subtree under box `b` can hold a contact of some motion that stays inside
    /// the box `region` (the broad phase's test): true whenever `may_touch(b, p0, p1, ..)` is
    /// for some `p0`, `p1` in `region`, so a candidate list misses no leaf a motion inside its
    /// query box can touch.
    fn may_touch_region(b: &Aabb, region: &Aabb, thickness: f32) -> bool;
    /// How far `leaf` moves over the frame as a whole (a deforming collider's leaf: what its
    /// sweep translates it by; nothing for leaves that do not move).
    #[inline]
    fn translation(_leaf: Self::Leaf) -> Vec3 {
        Vec3::ZERO
    }
    /// Where `p`, a point at the time when `left` of the frame (a fraction) is still to come,
    /// is relative to `leaf` as it stands at the frame's end, for a leaf that moves over the
    /// frame: `p` plus the leaf's remaining motion. The tests then see the motion relative to
    /// the leaf.
    #[inline]
    fn relative(leaf: Self::Leaf, p: Vec3, left: f32) -> Vec3 {
        p + Self::still_to_move(leaf, left)
    }
    /// How far `leaf` still moves when `left` of the frame (a fraction) is to come (what
    /// `relative` adds): that share of its `translation`.
    #[inline]
    fn still_to_move(leaf: Self::Leaf, left: f32) -> Vec3 {
        Self::translation(leaf) * left
    }
    /// `leaf` with the size it has when `left` of the frame (a fraction) is to come, for a kind
    /// whose leaves grow or shrink over the frame (a deforming collider's spheres); where it
    /// stands is still the frame's end (`relative`). A motion's tests take the leaf at the
    /// motion's end. Itself for leaves that keep their size.
    fn at(leaf: Self::Leaf, _left: f32) -> Self::Leaf {
        leaf
    }
    /// How far the surface of leaf `leaf` (of `leaves`, the first `count` of which are the
    /// tree's leaves) moves over the frame at point `p` (where the frame ends): a deforming
    /// collider's own motion there, in its frame (`Contact::leaf_motion`). The leaf's mean
    /// motion unless the kind keeps more (nothing for leaves that do not move).
    fn motion_at(leaves: &[Self::Leaf], _count: u32, leaf: u32, _p: Vec3) -> Vec3 {
        Self::still_to_move(leaves[leaf as usize], 1.0)
    }
    /// A finer test of one leaf whose box passed `may_touch_region` (the same guarantee: false
    /// only when no motion inside `region` can hit `leaf`).
    fn may_touch_leaf_region(_leaf: Self::Leaf, _region: &Aabb, _thickness: f32) -> bool {
        true
    }
}

/// The best leaf found so far: hit parameter, tie-break key, leaf index (tree order).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Candidate {
    pub t: f32,
    pub key: f32,
    pub leaf: u32,
}

/// No contact.
pub const NO_CANDIDATE: Candidate = Candidate { t: 2.0, key: 0.0, leaf: NO_LEAF };

/// Whether `p` is inside `b` grown by `margin`.
#[inline]
pub fn point_in_aabb(p: Vec3, b: &Aabb, margin: f32) -> bool {
    p.cmpge(b.min.xyz() - Vec3::splat(margin)).all() && p.cmple(b.max.xyz() + Vec3::splat(margin)).all()
}

/// Keeps the better of `best` and leaf `leaf` hit at `t` with tie-break `key`: the earlier
/// hit; among equal hits (typically p0 already within several leaves) the smaller key (the
/// leaf kind's choice, see `LeafKind::hit`); then the lower index. A total order, so any
/// visiting order gives the same answer: the BVH and the brute-force loop agree exactly.
#[inline]
pub fn consider(best: Candidate, t: f32, key: f32, leaf: u32) -> Candidate {
    if t > 1.0 {
        return best;
    }
    let better = t < best.t || (t == best.t && (key < best.key || (key == best.key && leaf < best.leaf)));
    if better { Candidate { t, key, leaf } } else { best }
}

/// How much of the frame is left at a motion's start and end (`SubstepMotion::left`); (0, 0)
/// tests against the leaves as they stand at the frame's end.
pub type Left = (f32, f32);

/// `K::hit` of the motion `p0 -> p1` relative to `leaf` (see `LeafKind::relative`), sized as at
/// the motion's end (`LeafKind::at`).
#[inline]
pub fn hit_relative<K: LeafKind>(leaf: K::Leaf, p0: Vec3, p1: Vec3, thickness: f32, left: Left) -> (f32, f32) {
    K::hit(K::at(leaf, left.1), K::relative(leaf, p0, left.0), K::relative(leaf, p1, left.1), thickness)
}

/// `K::blocks` of the path `a -> b` relative to `leaf`.
#[inline]
pub fn blocks_relative<K: LeafKind>(leaf: K::Leaf, a: Vec3, b: Vec3, thickness: f32, left: Left) -> bool {
    K::blocks(leaf, K::relative(leaf, a, left.0), K::relative(leaf, b, left.1), thickness)
}

/// The clearance bound before any leaf is seen (for kinds that check paths): the thickness,
/// which bounds every leaf a search leaves out (its box is farther than that from the motion);
/// 0 for kinds that do not check paths.
#[inline]
pub fn initial_clearance<K: LeafKind>(thickness: f32) -> f32 {
    if K::checks_path() { thickness } else { 0.0 }
}

/// `clearance` lowered by `leaf`'s clearance from `p0` (relative to the leaf, see
/// `LeafKind::relative`), for kinds that check paths.
#[inline]
pub fn lower_clearance<K: LeafKind>(clearance: f32, leaf: K::Leaf, p0: Vec3, left: Left) -> f32 {
    if K::checks_path() { clearance.min(K::clearance(leaf, K::relative(leaf, p0, left.0))) } else { clearance }
}

/// Earliest contact of p0 -> p1 with the LBVH's leaves as they stand at the frame's end.
pub fn traverse<K: LeafKind>(
    collider: &ColliderParams,
    nodes: &[BvhNode],
    aabbs: &[Aabb],
    leaves: &[K::Leaf],
    p0: Vec3,
    p1: Vec3,
) -> Candidate {
    traverse_with_clearance::<K>(collider, nodes, aabbs, leaves, p0, p1, (0.0, 0.0)).0
}

/// `traverse`, also returning (for kinds that check paths) a lower bound on the distance from
/// `p0` to every leaf: the least `clearance` over the leaves visited, and the thickness for the
/// subtrees not visited (their boxes are farther than the thickness from the whole motion, in
/// some axis). 0 for kinds that do not check paths.
pub fn traverse_with_clearance<K: LeafKind>(
    collider: &ColliderParams,
    nodes: &[BvhNode],
    aabbs: &[Aabb],
    leaves: &[K::Leaf],
    p0: Vec3,
    p1: Vec3,
    left: Left,
) -> (Candidate, f32) {
    let thickness = collider.thickness;
    let clearance = initial_clearance::<K>(thickness);
    let mut query = HitQuery::<K> { leaves, p0, p1, thickness, left };
    walk(nodes, aabbs, collider.leaf_count, &mut query, (NO_CANDIDATE, clearance))
}

/// The earliest hit of a motion among the leaves a walk reaches, and (for kinds that check
/// paths) the least clearance of those leaves (found: the best candidate and the clearance).
pub(crate) struct HitQuery<'a, K: LeafKind> {
    pub(crate) leaves: &'a [K::Leaf],
    pub(crate) p0: Vec3,
    pub(crate) p1: Vec3,
    pub(crate) thickness: f32,
    pub(crate) left: Left,
}

impl<K: LeafKind> TreeQuery for HitQuery<'_, K> {
    type Found = (Candidate, f32);

    #[inline]
    fn enters(&self, b: &Aabb) -> bool {
        K::may_touch(b, self.p0, self.p1, self.thickness)
    }

    #[inline]
    fn leaf(&mut self, leaf: u32, (best, clearance): &mut (Candidate, f32)) -> bool {
        let l = self.leaves[leaf as usize];
        let (t, key) = hit_relative::<K>(l, self.p0, self.p1, self.thickness, self.left);
        *best = consider(*best, t, key, leaf);
        *clearance = lower_clearance::<K>(*clearance, l, self.p0, self.left);
        false
    }
}

/// The same contact by testing every leaf (reference and benchmark baseline).
pub fn brute_force<K: LeafKind>(collider: &ColliderParams, leaves: &[K::Leaf], p0: Vec3, p1: Vec3) -> Candidate {
    brute_force_relative::<K>(collider, leaves, p0, p1, (0.0, 0.0))
}

/// `brute_force` for a motion with `left` of the frame to come at its start and end.
pub fn brute_force_relative<K: LeafKind>(
    collider: &ColliderParams,
    leaves: &[K::Leaf],
    p0: Vec3,
    p1: Vec3,
    left: Left,
) -> Candidate {
    let mut best = NO_CANDIDATE;
    let mut i = 0;
    while i < collider.leaf_count {
        let (t, key) = hit_relative::<K>(leaves[i as usize], p0, p1, collider.thickness, left);
        best = consider(best, t, key, i);
        i += 1;
    }
    best
}

/// Whether the path `a -> b` passes through any leaf's surface, through the LBVH.
pub fn path_blocked<K: LeafKind>(
    collider: &ColliderParams,
    nodes: &[BvhNode],
    aabbs: &[Aabb],
    leaves: &[K::Leaf],
    a: Vec3,
    b: Vec3,
    left: Left,
) -> bool {
    let mut query = PathQuery::<K> { leaves, a, b, thickness: collider.thickness, left };
    walk(nodes, aabbs, collider.leaf_count, &mut query, false)
}

/// Whether a path crosses any leaf a walk reaches (found: blocked; the walk stops at the
/// first).
pub(crate) struct PathQuery<'a, K: LeafKind> {
    pub(crate) leaves: &'a [K::Leaf],
    pub(crate) a: Vec3,
    pub(crate) b: Vec3,
    pub(crate) thickness: f32,
    pub(crate) left: Left,
}

impl<K: LeafKind> TreeQuery for PathQuery<'_, K> {
    type Found = bool;

    #[inline]
    fn enters(&self, b: &Aabb) -> bool {
        K::may_touch(b, self.a, self.b, self.thickness)
    }

    #[inline]
    fn leaf(&mut self, leaf: u32, blocked: &mut bool) -> bool {
        *blocked = blocks_relative::<K>(self.leaves[leaf as usize], self.a, self.b, self.thickness, self.left);
        *blocked
    }
}

/// The same question by testing every leaf.
pub fn path_blocked_brute_force<K: LeafKind>(
    collider: &ColliderParams,
    leaves: &[K::Leaf],
    a: Vec3,
    b: Vec3,
    left: Left,
) -> bool {
    let mut i = 0;
    while i < collider.leaf_count {
        if blocks_relative::<K>(leaves[i as usize], a, b, collider.thickness, left) {
            return true;
        }
        i += 1;
    }
    false
}

/// Where `best` (found for the collider-frame motion `p0 -> p1`) sends the particle, before
/// any path check: its target, outward normal, and the first contact point (the safe stop).
/// The leaf's surface is found for the motion relative to it, and the target taken back by the
/// leaf's remaining motion at the motion's end.
#[inline]
fn surface_of<K: LeafKind>(
    best: Candidate,
    leaves: &[K::Leaf],
    p0: Vec3,
    p1: Vec3,
    thickness: f32,
    left: Left,
) -> (Vec3, Vec3, Vec3, Vec3) {
    let leaf = leaves[best.leaf as usize];
    let (q0, q1) = (K::relative(leaf, p0, left.0), K::relative(leaf, p1, left.1));
    let (position, normal) = K::surface(K::at(leaf, left.1), q0, q1, best.t, thickness);
    // Back by the leaf's remaining motion itself, not `q1 - p1`: Mesa's NIR, taking float math
    // as reassociable, folds that to the motion, which the CPU's rounding does not (a deforming
    // collider's contacts parted the GPU from its CPU twin by an f32 step). The position
    // against the leaf where the frame ends is returned too, as it is (moving the result back
    // again would be folded the same way).
    (position - K::still_to_move(leaf, left.1), normal, p0 + (p1 - p0) * best.t, position)
}

/// The contact record of `best` at `position` (`Contact::NONE` for no contact); `leaf_motion`
/// is the touched leaf's own motion over the frame.
#[inline]
pub fn contact_at(best: Candidate, position: Vec3, normal: Vec3, leaf_motion: Vec3) -> Contact {
    if best.t > 1.0 {
        return Contact::NONE;
    }
    Contact {
        position: position.extend(best.t),
        normal: normal.extend(best.key),
        leaf: best.leaf,
        leaf_motion: leaf_motion.to_array(),
    }
}

/// Particle `index`'s substep motion in the collider's frame (start, end).
#[inline]
pub fn local_motion(index: u32, motion: &SubstepMotion, x: &[Vec4], x_prev: &[Vec4]) -> (Vec3, Vec3) {
    let i = index as usize;
    (to_local(&motion.start, x_prev[i].xyz()), to_local(&motion.end, x[i].xyz()))
}

/// Detect for one particle through the LBVH: writes `contacts[index]`. Pinned particles get no
/// contact.
#[allow(clippy::too_many_arguments)]
pub fn detect_at<K: LeafKind>(
    index: u32,
    collider: &ColliderParams,
    motion: &SubstepMotion,
    nodes: &[BvhNode],
    aabbs: &[Aabb],
    leaves: &[K::Leaf],
    x: &[Vec4],
    x_prev: &[Vec4],
    contacts: &mut [Contact],
) {
    let i = index as usize;
    if x[i].w == 0.0 {
        contacts[i] = Contact::NONE;
        return;
    }
    let (p0, p1) = local_motion(index, motion, x, x_prev);
    let left = motion.left();
    let (best, clearance) = traverse_with_clearance::<K>(collider, nodes, aabbs, leaves, p0, p1, left);
    let target = target_of::<K>(best, clearance, leaves, (p0, p1), collider, left);
    let blocked = target.check && path_blocked::<K>(collider, nodes, aabbs, leaves, p0, target.position, left);
    contacts[i] = target.contact(blocked);
}

/// Where the earliest hit sends a particle, before its path there is checked.
#[derive(Copy, Clone)]
pub struct Target {
    pub best: Candidate,
    /// Where it goes, and the outward normal there.
    pub position: Vec3,
    pub normal: Vec3,
    /// Its first contact: where it stops when the path to `position` is blocked.
    pub first: Vec3,
    /// Whether the path `p0 -> position` must be checked.
    pub check: bool,
    /// The touched leaf's own motion over the frame (`Contact::leaf_motion`).
    pub leaf_motion: Vec3,
}

impl Target {
    /// The contact record, `blocked` saying whether the path to `position` crosses a leaf.
    #[inline]
    pub fn contact(&self, blocked: bool) -> Contact {
        contact_at(self.best, if blocked { self.first } else { self.position }, self.normal, self.leaf_motion)
    }
}

/// The target of the earliest hit `best` of the motion `p0 -> p1`, given `clearance` (a lower
/// bound on the distance from `p0` to every leaf, see `traverse_with_clearance`): its path
/// needs checking unless the kind never checks paths, or the path is too short to reach any
/// surface.
#[inline]
pub fn target_of<K: LeafKind>(
    best: Candidate,
    clearance: f32,
    leaves: &[K::Leaf],
    (p0, p1): (Vec3, Vec3),
    collider: &ColliderParams,
    left: Left,
) -> Target {
    let thickness = collider.thickness;
    if best.t > 1.0 {
        return Target { best, position: p1, normal: Vec3::ZERO, first: p1, check: false, leaf_motion: Vec3::ZERO };
    }
    let (position, normal, first, at_frame_end) = surface_of::<K>(best, leaves, p0, p1, thickness, left);
    let leaf_motion = K::motion_at(leaves, collider.leaf_count, best.leaf, at_frame_end);
    // A path shorter than half the clearance cannot reach any surface (the half covers the
    // crossing test's own margin and rounding): the answer is known without the walk, the
    // same one the walk (or the brute-force loop) would give.
    let short = (position - p0).length() < 0.5 * clearance;
    Target { best, position, normal, first, check: K::checks_path() && !short, leaf_motion }
}

/// The body of every leaf kind's LBVH detect entry point: particle `index` (threads past the
/// cloth do nothing).
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn detect_particle<K: LeafKind>(
    index: u32,
    push: &ContactPush,
    params: &SimParams,
    collider: &ColliderParams,
    pose: &ColliderPose,
    (nodes, aabbs, leaves): (&[BvhNode], &[Aabb], &[K::Leaf]),
    (x, x_prev): (&[Vec4], &[Vec4]),
    contacts: &mut [Contact],
) {
    if index >= params.particle_count {
        return;
    }
    let motion = substep_motion(params, pose, push);
    detect_at::<K>(index, collider, &motion, nodes, aabbs, leaves, x, x_prev, contacts);
}

/// The body of every leaf kind's brute-force detect entry point.
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn detect_brute_force_particle<K: LeafKind>(
    index: u32,
    push: &ContactPush,
    params: &SimParams,
    collider: &ColliderParams,
    pose: &ColliderPose,
    leaves: &[K::Leaf],
    (x, x_prev): (&[Vec4], &[Vec4]),
    contacts: &mut [Contact],
) {
    if index >= params.particle_count {
        return;
    }
    let motion = substep_motion(params, pose, push);
    detect_brute_force_at::<K>(index, collider, &motion, leaves, x, x_prev, contacts);
}

/// Detect for one particle by testing every leaf.
#[allow(clippy::too_many_arguments)]
pub fn detect_brute_force_at<K: LeafKind>(
    index: u32,
    collider: &ColliderParams,
    motion: &SubstepMotion,
    leaves: &[K::Leaf],
    x: &[Vec4],
    x_prev: &[Vec4],
    contacts: &mut [Contact],
) {
    let i = index as usize;
    if x[i].w == 0.0 {
        contacts[i] = Contact::NONE;
        return;
    }
    let (p0, p1) = local_motion(index, motion, x, x_prev);
    let left = motion.left();
    let best = brute_force_relative::<K>(collider, leaves, p0, p1, left);
    // No clearance bound: every path is checked.
    let target = target_of::<K>(best, 0.0, leaves, (p0, p1), collider, left);
    let blocked = target.check && path_blocked_brute_force::<K>(collider, leaves, p0, target.position, left);
    contacts[i] = target.contact(blocked);
}

/// Contact response in the collider's frame: the particle moves to `position` and the normal
/// velocity into the surface (`outward` is its unit normal) is removed (design.md §1); with
/// `friction` > 0 the tangential velocity also loses up to `friction` times the removed normal
/// speed (Coulomb: it stops when that covers it). Returns the new position and velocity.
#[inline]
pub fn respond(position: Vec3, outward: Vec3, v: Vec3, friction: f32) -> (Vec3, Vec3) {
    let into = v.dot(outward).min(0.0);
    let tangential = v - outward * v.dot(outward);
    let speed = tangential.length();
    let kept = if speed > 1e-12 { (1.0 - friction * -into * (1.0 / speed)).max(0.0) } else { 0.0 };
    let normal = outward * (v.dot(outward) - into);
    (position, normal + tangential * kept)
}

/// Applies particle `index`'s detected contact, if any: the response acts in the collider's
/// frame on the velocity relative to the collider's surface at the particle (`surface_velocity`).
/// A sleeping particle (`tiles`) stays as it is: no collider moves near it.
#[inline]
pub fn respond_at(
    index: u32,
    contact: &Contact,
    collider: &ColliderParams,
    motion: &SubstepMotion,
    x: &mut [Vec4],
    v: &mut [Vec4],
) {
    let i = index as usize;
    if !contact.is_some() || sleeping(v[i]) {
        return;
    }
    let surface = surface_velocity(contact, motion, x[i].xyz());
    let relative = rotate_inverse(motion.end.rotation, v[i].xyz() - surface);
    let (position, velocity) = respond(contact.position.xyz(), contact.normal.xyz(), relative, collider.friction);
    x[i] = to_world(&motion.end, position).extend(x[i].w);
    v[i] = (rotate(motion.end.rotation, velocity) + surface).extend(0.0);
}

/// The velocity (world) of the collider's surface where a particle at `p` (world, the
/// substep's end) touches it: the pose's motion of that point, plus the surface's own motion
/// there over the substep (its share of `Contact::leaf_motion`, which a deforming collider's
/// vertices give: `LeafKind::motion_at`). Without it, a surface sliding under the cloth by its
/// vertices (a skinned body) would not drag the cloth along by friction.
#[inline]
pub fn surface_velocity(contact: &Contact, motion: &SubstepMotion, p: Vec3) -> Vec3 {
    let by_pose = motion.velocity_at(to_local(&motion.end, p));
    let share = (motion.to - motion.from) * (1.0 / motion.h);
    by_pose + rotate(motion.end.rotation, Vec3::from_array(contact.leaf_motion) * share)
}

/// The collider's motion over the substep a contact pass runs in.
#[inline]
pub fn substep_motion(params: &SimParams, pose: &ColliderPose, push: &ContactPush) -> SubstepMotion {
    SubstepMotion::of(pose, push.from, push.to, params.substep)
}

/// Threads per workgroup of the detect and respond passes (their `threads(64)`).
pub const CONTACT_THREADS: u32 = 64;

#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(64)))]
pub fn respond_contacts(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] push: &ContactPush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &SimParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] collider: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] pose: &ColliderPose,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] contacts: &[Contact],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] x: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] v: &mut [Vec4],
) {
    if id.x >= params.particle_count {
        return;
    }
    let motion = substep_motion(params, pose, push);
    respond_at(id.x, &contacts[id.x as usize], collider, &motion, x, v);
}

/// Root box of the collider (the leaf's box when there is one leaf).
#[inline]
pub fn root_aabb(collider: &ColliderParams, aabbs: &[Aabb], leaf_bounds: &[Aabb]) -> Aabb {
    if collider.leaf_count == 1 { leaf_bounds[0] } else { aabbs[0] }
}

/// Bounds, in the collider's frame, of particles `lane, lane + stride, ...` over both ends of
/// their substep motion relative to the collider.
pub fn swept_bounds(motion: &SubstepMotion, x: &[Vec4], x_prev: &[Vec4], count: u32, lane: u32, stride: u32) -> Aabb {
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    let mut i = lane;
    while i < count {
        let (b, a) = local_motion(i, motion, x, x_prev);
        lo = lo.min(a).min(b);
        hi = hi.max(a).max(b);
        i += stride;
    }
    Aabb { min: lo.extend(0.0), max: hi.extend(0.0) }
}

/// Whether two boxes, one grown by `margin`, overlap.
#[inline]
pub fn aabbs_overlap(a: &Aabb, b: &Aabb, margin: f32) -> bool {
    let m = Vec3::splat(margin);
    (a.min.xyz() - m).cmple(b.max.xyz()).all() && (a.max.xyz() + m).cmpge(b.min.xyz()).all()
}

/// The union of the 256 lanes' boxes (`own`), reduced in workgroup memory: what lane 0 gets
/// back (the other lanes get their own box back, and must not use it as the union; only lane
/// 0 reads the result, so no lane reads what lane 0 writes last). Min and max are exact in any
/// order, so the CPU twins fold the lanes' boxes in a loop instead.
#[inline]
pub fn reduce_bounds(lane: u32, own: Aabb, lows: &mut [Vec4; 256], highs: &mut [Vec4; 256]) -> Aabb {
    lows[lane as usize] = own.min;
    highs[lane as usize] = own.max;
    let mut stride = 256 / 2;
    while stride > 0 {
        #[cfg(target_arch = "spirv")]
        spirv_std::arch::workgroup_memory_barrier_with_group_sync();
        if lane < stride {
            let other = (lane + stride) as usize;
            lows[lane as usize] = lows[lane as usize].min(lows[other]);
            highs[lane as usize] = highs[lane as usize].max(highs[other]);
        }
        stride /= 2;
    }
    if lane == 0 { Aabb { min: lows[0], max: highs[0] } } else { own }
}

/// Threads of the culling pass (one workgroup).
pub const CULL_THREADS: u32 = 256;

/// One workgroup: reduce the cloth's swept bounds in shared memory, test them against the
/// collider's root box, and write the detect and respond passes' indirect dispatch size
/// (0 = skip). When the frame's broad phase gave any particle a candidate the cloth is at the
/// collider, where the test would say run: the pass says so without reading the cloth (on the
/// bunny with timestamps: 42 µs per substep against ~90, the rest is the dispatch's fixed
/// cost). Running the narrow phase where the test would have skipped it finds no contact there:
/// the test's margin is the thickness, the contacts' the thickness grown by their 0.1% rounding
/// slack, so at most a motion within that sliver of the root box is caught a substep earlier.
#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(256)))]
pub fn cull_contact(
    #[spirv(local_invocation_id)] lid: UVec3,
    #[spirv(push_constant)] push: &ContactPush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &SimParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] collider: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] pose: &ColliderPose,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] aabbs: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] leaf_bounds: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] x: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] x_prev: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] args: &mut DispatchArgs,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] status: &mut CollisionStatus,
    #[spirv(workgroup)] lows: &mut [Vec4; 256],
    #[spirv(workgroup)] highs: &mut [Vec4; 256],
) {
    let lane = lid.x;
    // The same value in every lane (nothing writes it during the pass), so either every lane
    // reaches the reduction's barriers or none does.
    if status.listed != 0 {
        if lane == 0 {
            record_cull(true, params, args, status);
        }
        return;
    }
    let motion = substep_motion(params, pose, push);
    let own = swept_bounds(&motion, x, x_prev, params.particle_count, lane, CULL_THREADS);
    let cloth = reduce_bounds(lane, own, lows, highs);
    if lane == 0 {
        let root = root_aabb(collider, aabbs, leaf_bounds);
        record_cull(aabbs_overlap(&cloth, &root, collider.thickness), params, args, status);
    }
}

/// The culling pass's answer: the next passes' dispatch (`run`: one thread per particle, else
/// none) and the substep counted as run or skipped.
#[inline]
pub fn record_cull(run: bool, params: &SimParams, args: &mut DispatchArgs, status: &mut CollisionStatus) {
    *args =
        DispatchArgs { x: if run { params.particle_count.div_ceil(CONTACT_THREADS) } else { 0 }, y: 1, z: 1, _pad: 0 };
    if run {
        status.ran += 1;
    } else {
        status.skipped += 1;
    }
}

/// The contact entry points of leaf kind `$kind` (leaves of type `$leaf`), generated in the leaf
/// kind's own module so they are named after it (`spheres::detect`, `triangles::detect`, ...):
/// `detect` (through the LBVH), `detect_brute_force` (every leaf), `broad_phase` (once per
/// frame: query boxes and candidate lists), `detect_candidates` (every substep, over the
/// lists), `update_contact` / `update_contact_springs` (the integrator's last stage and
/// `detect_candidates` in one pass, `crate::update_contact`) and `detect_crowded` (the crowded
/// particles those hand over, `crate::crowded`). Their binding tables are
/// `kernels::contact::{DETECT, DETECT_BRUTE_FORCE, BROAD_PHASE, DETECT_CANDIDATES,
/// UPDATE_CONTACT, UPDATE_CONTACT_SPRINGS, DETECT_CROWDED}_BINDINGS` on the host.
macro_rules! contact_entry_points {
    ($kind:ty, $leaf:ty) => {
        /// Detect through the LBVH (tree order): one contact per particle.
        #[allow(clippy::too_many_arguments)]
        #[spirv(compute(threads(64)))]
        pub fn detect(
            #[spirv(global_invocation_id)] id: ::drape_types::glam::UVec3,
            #[spirv(push_constant)] push: &::drape_types::ContactPush,
            #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &::drape_types::SimParams,
            #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] collider: &::drape_types::ColliderParams,
            #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] pose: &::drape_types::ColliderPose,
            #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] nodes: &[::drape_types::BvhNode],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] aabbs: &[::drape_types::Aabb],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] leaves: &[$leaf],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] x: &[::drape_types::glam::Vec4],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] x_prev: &[::drape_types::glam::Vec4],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] contacts: &mut [::drape_types::Contact],
        ) {
            $crate::contact::detect_particle::<$kind>(
                id.x,
                push,
                params,
                collider,
                pose,
                (nodes, aabbs, leaves),
                (x, x_prev),
                contacts,
            );
        }

        /// Detect by testing every leaf (the baseline).
        #[allow(clippy::too_many_arguments)]
        #[spirv(compute(threads(64)))]
        pub fn detect_brute_force(
            #[spirv(global_invocation_id)] id: ::drape_types::glam::UVec3,
            #[spirv(push_constant)] push: &::drape_types::ContactPush,
            #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &::drape_types::SimParams,
            #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] collider: &::drape_types::ColliderParams,
            #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] pose: &::drape_types::ColliderPose,
            #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] leaves: &[$leaf],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] x: &[::drape_types::glam::Vec4],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] x_prev: &[::drape_types::glam::Vec4],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] contacts: &mut [::drape_types::Contact],
        ) {
            $crate::contact::detect_brute_force_particle::<$kind>(
                id.x,
                push,
                params,
                collider,
                pose,
                leaves,
                (x, x_prev),
                contacts,
            );
        }

        /// Broad phase over the LBVH (once per frame): each particle's query box and candidate
        /// list.
        #[allow(clippy::too_many_arguments)]
        #[spirv(compute(threads(64)))]
        pub fn broad_phase(
            #[spirv(global_invocation_id)] id: ::drape_types::glam::UVec3,
            #[spirv(push_constant)] push: &::drape_types::BroadPhasePush,
            #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &::drape_types::SimParams,
            #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] collider: &::drape_types::ColliderParams,
            #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] pose: &::drape_types::ColliderPose,
            #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] nodes: &[::drape_types::BvhNode],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] aabbs: &[::drape_types::Aabb],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] leaf_bounds: &[::drape_types::Aabb],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] leaves: &[$leaf],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] x: &[::drape_types::glam::Vec4],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] v: &[::drape_types::glam::Vec4],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] queries: &mut [::drape_types::ContactQuery],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] candidates: &mut [u32],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] status: &mut ::drape_types::CollisionStatus,
        ) {
            $crate::candidates::broad_phase_particle::<$kind>(
                id.x,
                push,
                params,
                collider,
                pose,
                (nodes, aabbs, leaf_bounds, leaves),
                (x, v),
                (queries, candidates),
                status,
            );
        }

        /// Narrow phase (every substep): detect over each particle's candidate list and respond.
        #[allow(clippy::too_many_arguments)]
        #[spirv(compute(threads(64)))]
        pub fn detect_candidates(
            #[spirv(global_invocation_id)] id: ::drape_types::glam::UVec3,
            #[spirv(push_constant)] push: &::drape_types::ContactPush,
            #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &::drape_types::SimParams,
            #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] collider: &::drape_types::ColliderParams,
            #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] pose: &::drape_types::ColliderPose,
            #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] nodes: &[::drape_types::BvhNode],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] aabbs: &[::drape_types::Aabb],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] leaves: &[$leaf],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] queries: &[::drape_types::ContactQuery],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] candidates: &[u32],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] x: &mut [::drape_types::glam::Vec4],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] x_prev: &[::drape_types::glam::Vec4],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] v: &mut [::drape_types::glam::Vec4],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] contacts: &mut [::drape_types::Contact],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 12)] status: &mut ::drape_types::CollisionStatus,
            #[spirv(storage_buffer, descriptor_set = 0, binding = 13)] crowded: &mut [u32],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 14)] crowded_args: &mut ::drape_types::DispatchArgs,
            #[spirv(storage_buffer, descriptor_set = 0, binding = 15)] health: &mut ::drape_types::Health,
        ) {
            $crate::candidates::detect_candidates_particle::<$kind>(
                id.x,
                push,
                params,
                collider,
                pose,
                (nodes, aabbs, leaves),
                (queries, candidates),
                (x, x_prev, v),
                contacts,
                (status, health, (crowded, crowded_args)),
            );
        }

        /// The crowded particles the narrow phase handed over (`crate::crowded`), a workgroup
        /// each (indirect: as many as there are, at most `MAX_CROWDED_GROUPS`).
        #[allow(clippy::too_many_arguments)]
        #[spirv(compute(threads(64)))]
        pub fn detect_crowded(
            #[spirv(workgroup_id)] group: ::drape_types::glam::UVec3,
            #[spirv(local_invocation_id)] lid: ::drape_types::glam::UVec3,
            #[spirv(push_constant)] push: &::drape_types::ContactPush,
            #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &::drape_types::SimParams,
            #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] collider: &::drape_types::ColliderParams,
            #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] pose: &::drape_types::ColliderPose,
            #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] nodes: &[::drape_types::BvhNode],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] aabbs: &[::drape_types::Aabb],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] leaves: &[$leaf],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] queries: &[::drape_types::ContactQuery],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] candidates: &[u32],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] x: &mut [::drape_types::glam::Vec4],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] x_prev: &[::drape_types::glam::Vec4],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] v: &mut [::drape_types::glam::Vec4],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] contacts: &mut [::drape_types::Contact],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 12)] status: &mut ::drape_types::CollisionStatus,
            #[spirv(storage_buffer, descriptor_set = 0, binding = 13)] crowded: &[u32],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 14)] crowded_args: &::drape_types::DispatchArgs,
            #[spirv(workgroup)] frontier: &mut [u32; 2 * $crate::crowded::FRONTIER],
            #[spirv(workgroup)] reached: &mut [u32; 2 * $crate::crowded::FRONTIER],
            #[spirv(workgroup)] counters: &mut [u32; $crate::crowded::COUNTERS],
            #[spirv(workgroup)] finds: &mut [::drape_types::glam::UVec4; $crate::crowded::CROWDED_THREADS as usize],
            #[spirv(workgroup)] target: &mut [::drape_types::glam::Vec4; 2],
        ) {
            let mut shared = $crate::crowded::Shared { frontier, reached, counters, finds, target };
            // The same in every lane, so every lane reaches each barrier.
            let mut entry = group.x;
            while entry < crowded_args._pad {
                $crate::crowded::detect_crowded_particle::<$kind>(
                    crowded[entry as usize],
                    (lid.x, $crate::crowded::CROWDED_THREADS),
                    push,
                    params,
                    (collider, pose),
                    (nodes, aabbs, leaves),
                    (queries, candidates),
                    (x, x_prev, v),
                    contacts,
                    status,
                    &mut shared,
                );
                entry += $crate::crowded::MAX_CROWDED_GROUPS;
            }
        }

        /// The integrator's last stage and the narrow phase in one pass, for a grid cloth
        /// (`update_contact`): bindings 0..=9 are the integrator's, 10.. the narrow phase's.
        #[allow(clippy::too_many_arguments)]
        #[spirv(compute(threads(64)))]
        pub fn update_contact(
            #[spirv(global_invocation_id)] id: ::drape_types::glam::UVec3,
            #[spirv(push_constant)] push: &::drape_types::ContactPush,
            #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &::drape_types::SimParams,
            #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] x: &mut [::drape_types::glam::Vec4],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] v: &mut [::drape_types::glam::Vec4],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] x_in: &[::drape_types::glam::Vec4],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] v_in: &[::drape_types::glam::Vec4],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] x_out: &mut [::drape_types::glam::Vec4],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] v_out: &mut [::drape_types::glam::Vec4],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] acc_x: &mut [::drape_types::glam::Vec4],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] acc_v: &mut [::drape_types::glam::Vec4],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] x_prev: &mut [::drape_types::glam::Vec4],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] collider: &::drape_types::ColliderParams,
            #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] pose: &::drape_types::ColliderPose,
            #[spirv(storage_buffer, descriptor_set = 0, binding = 12)] nodes: &[::drape_types::BvhNode],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 13)] aabbs: &[::drape_types::Aabb],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 14)] leaves: &[$leaf],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 15)] queries: &[::drape_types::ContactQuery],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 16)] candidates: &[u32],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 17)] contacts: &mut [::drape_types::Contact],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 18)] status: &mut ::drape_types::CollisionStatus,
            #[spirv(storage_buffer, descriptor_set = 0, binding = 19)] crowded: &mut [u32],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 20)] crowded_args: &mut ::drape_types::DispatchArgs,
            #[spirv(storage_buffer, descriptor_set = 0, binding = 21)] health: &mut ::drape_types::Health,
        ) {
            $crate::update_contact::update_and_contact_particle::<$kind, _>(
                id.x,
                push,
                params,
                &$crate::integrate::GridSprings,
                (x, v, x_prev),
                (x_in, v_in, x_out, v_out, acc_x, acc_v),
                (collider, pose),
                (nodes, aabbs, leaves),
                (queries, candidates),
                contacts,
                (status, health, (crowded, crowded_args)),
            );
        }

        /// `update_contact` for a spring-list cloth: bindings 19 and 20 hold its particles'
        /// spring ranges and masses, and the springs.
        #[allow(clippy::too_many_arguments)]
        #[spirv(compute(threads(64)))]
        pub fn update_contact_springs(
            #[spirv(global_invocation_id)] id: ::drape_types::glam::UVec3,
            #[spirv(push_constant)] push: &::drape_types::ContactPush,
            #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &::drape_types::SimParams,
            #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] x: &mut [::drape_types::glam::Vec4],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] v: &mut [::drape_types::glam::Vec4],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] x_in: &[::drape_types::glam::Vec4],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] v_in: &[::drape_types::glam::Vec4],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] x_out: &mut [::drape_types::glam::Vec4],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] v_out: &mut [::drape_types::glam::Vec4],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] acc_x: &mut [::drape_types::glam::Vec4],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] acc_v: &mut [::drape_types::glam::Vec4],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] x_prev: &mut [::drape_types::glam::Vec4],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] collider: &::drape_types::ColliderParams,
            #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] pose: &::drape_types::ColliderPose,
            #[spirv(storage_buffer, descriptor_set = 0, binding = 12)] nodes: &[::drape_types::BvhNode],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 13)] aabbs: &[::drape_types::Aabb],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 14)] leaves: &[$leaf],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 15)] queries: &[::drape_types::ContactQuery],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 16)] candidates: &[u32],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 17)] contacts: &mut [::drape_types::Contact],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 18)] status: &mut ::drape_types::CollisionStatus,
            #[spirv(storage_buffer, descriptor_set = 0, binding = 19)] crowded: &mut [u32],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 20)] crowded_args: &mut ::drape_types::DispatchArgs,
            #[spirv(storage_buffer, descriptor_set = 0, binding = 21)] health: &mut ::drape_types::Health,
            #[spirv(storage_buffer, descriptor_set = 0, binding = 22)] particles: &[::drape_types::ParticleSprings],
            #[spirv(storage_buffer, descriptor_set = 0, binding = 23)] springs: &[::drape_types::Spring],
        ) {
            $crate::update_contact::update_and_contact_particle::<$kind, _>(
                id.x,
                push,
                params,
                &$crate::integrate::SpringList { particles, springs },
                (x, v, x_prev),
                (x_in, v_in, x_out, v_out, acc_x, acc_v),
                (collider, pose),
                (nodes, aabbs, leaves),
                (queries, candidates),
                contacts,
                (status, health, (crowded, crowded_args)),
            );
        }
    };
}
pub(crate) use contact_entry_points;
