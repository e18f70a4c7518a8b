//! Contact in two phases, for any leaf kind (`contact::LeafKind`):
//! - **broad phase, once per frame**: each particle gets a query box in the collider's frame,
//!   where its motion is expected to stay over the frame (its start, its start moved by its
//!   velocity, both taken into the collider's frame at the frame's start and end pose, grown by
//!   a slop), and the list of the leaves a motion inside that box can touch (at most
//!   `MAX_CANDIDATES`), from one LBVH walk.
//! - **narrow phase, every substep**: a particle whose substep motion stays inside its box tests
//!   only its list (hits, clearance and the path check); one that left its box, or whose list
//!   overflowed, walks the whole LBVH as `contact::detect_at` does (a counted fallback).
//!
//! The answer is the full traversal's: every leaf a motion inside the box can touch is in the
//! list (`LeafKind::may_touch_region`), and `contact::consider` is a total order, so the list
//! gives the same earliest contact as the tree or the brute-force loop.

use crate::contact::{
    Candidate, LeafKind, Left, NO_CANDIDATE, blocks_relative, consider, detect_at, hit_relative, initial_clearance,
    local_motion, lower_clearance, path_blocked, point_in_aabb, respond_at, substep_motion, target_of,
};
use crate::crowded::CrowdedQueue;
use crate::lbvh::{TreeQuery, walk};
use crate::pose::{SubstepMotion, to_local};
use crate::tiles::sleeping;
use drape_types::glam::{Vec3, Vec4, Vec4Swizzles};
use drape_types::{
    Aabb, BroadPhasePush, BvhNode, CANDIDATES_OVERFLOWED, ColliderParams, ColliderPose, CollisionStatus, Contact,
    ContactPush, ContactQuery, Health, MAX_CANDIDATES, SimParams,
};

/// What the broad phase walks: the LBVH's nodes and boxes, the leaves' boxes and the leaves,
/// all in tree order.
pub type BroadPhaseTree<'a, L> = (&'a [BvhNode], &'a [Aabb], &'a [Aabb], &'a [L]);

/// The box particle (`x`, `v`) is expected to stay in over the frame `frame` (`frame_motion`),
/// in the collider's frame: its start and its start moved by its velocity, each in the
/// collider's frame at that time, grown by a quarter of the thickness, a quarter of the
/// predicted motion and the distance gravity adds over the frame. A particle that still leaves
/// it only costs a full traversal for that substep.
#[inline]
pub fn query_box(frame: &SubstepMotion, x: Vec3, v: Vec3, gravity: Vec3, thickness: f32) -> Aabb {
    let frame_time = frame.h;
    let start = to_local(&frame.start, x);
    let end = to_local(&frame.end, x + v * frame_time);
    let slop = 0.25 * thickness + 0.25 * (end - start).length() + 0.5 * gravity.length() * frame_time * frame_time;
    let s = Vec3::splat(slop);
    Aabb { min: (start.min(end) - s).extend(0.0), max: (start.max(end) + s).extend(0.0) }
}

/// Writes into `list` (up to `MAX_CANDIDATES` entries) the leaves, in tree order, that a motion
/// inside `region` can touch; returns how many, or `CANDIDATES_OVERFLOWED` when they do not fit.
pub fn gather_candidates<K: LeafKind>(
    collider: &ColliderParams,
    nodes: &[BvhNode],
    aabbs: &[Aabb],
    (leaf_bounds, leaves): (&[Aabb], &[K::Leaf]),
    region: &Aabb,
    list: &mut [u32],
    base: usize,
) -> u32 {
    let mut query =
        GatherQuery::<K> { leaf_bounds, region: *region, thickness: collider.thickness, leaves, list, base };
    let (count, full) = walk(nodes, aabbs, collider.leaf_count, &mut query, (0, false));
    if full { CANDIDATES_OVERFLOWED } else { count }
}

/// The leaves a motion inside a region can touch, listed as a walk reaches them (found: how
/// many, and whether the list is full; the walk stops when it is).
struct GatherQuery<'a, K: LeafKind> {
    leaf_bounds: &'a [Aabb],
    region: Aabb,
    thickness: f32,
    leaves: &'a [K::Leaf],
    list: &'a mut [u32],
    base: usize,
}

impl<K: LeafKind> TreeQuery for GatherQuery<'_, K> {
    type Found = (u32, bool);

    #[inline]
    fn enters(&self, b: &Aabb) -> bool {
        K::may_touch_region(b, &self.region, self.thickness)
    }

    #[inline]
    fn leaf(&mut self, leaf: u32, (count, full): &mut (u32, bool)) -> bool {
        if !(K::may_touch_region(&self.leaf_bounds[leaf as usize], &self.region, self.thickness)
            && K::may_touch_leaf_region(self.leaves[leaf as usize], &self.region, self.thickness))
        {
            return false;
        }
        if *count == MAX_CANDIDATES {
            *full = true;
            return true;
        }
        self.list[self.base + *count as usize] = leaf;
        *count += 1;
        false
    }
}

/// Broad phase for particle `index` over the `frame` (`frame_motion`): its query box and
/// candidate list (`candidates[index * MAX_CANDIDATES..]`); returns whether the list holds
/// anything (or overflowed). Pinned particles get an empty list (detect skips them anyway).
#[allow(clippy::too_many_arguments)]
pub fn broad_phase_at<K: LeafKind>(
    index: u32,
    params: &SimParams,
    collider: &ColliderParams,
    frame: &SubstepMotion,
    (nodes, aabbs, leaf_bounds, leaves): BroadPhaseTree<'_, K::Leaf>,
    (x, v): (&[Vec4], &[Vec4]),
    queries: &mut [ContactQuery],
    candidates: &mut [u32],
) -> bool {
    let i = index as usize;
    let region = query_box(frame, x[i].xyz(), v[i].xyz(), params.gravity.xyz(), collider.thickness);
    // A sleeping particle gets its list too: a push may wake it before the frame ends.
    let count = if x[i].w == 0.0 {
        0
    } else {
        let base = i * MAX_CANDIDATES as usize;
        gather_candidates::<K>(collider, nodes, aabbs, (leaf_bounds, leaves), &region, candidates, base)
    };
    queries[i] = ContactQuery { low: region.min, high: region.max, count, _pad: [0; 3] };
    count != 0
}

/// The body of every leaf kind's broad-phase entry point (threads past the cloth do nothing):
/// particles given candidates counted in `status.listed`.
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn broad_phase_particle<K: LeafKind>(
    index: u32,
    push: &BroadPhasePush,
    params: &SimParams,
    collider: &ColliderParams,
    pose: &ColliderPose,
    tree: BroadPhaseTree<'_, K::Leaf>,
    state: (&[Vec4], &[Vec4]),
    (queries, candidates): (&mut [ContactQuery], &mut [u32]),
    status: &mut CollisionStatus,
) {
    if index >= params.particle_count {
        return;
    }
    let frame = frame_motion(params, pose, push);
    if broad_phase_at::<K>(index, params, collider, &frame, tree, state, queries, candidates) {
        crate::atomics::add(&mut status.listed, 1);
    }
}

/// The collider's motion over the whole frame the broad phase looks ahead over (its `h` is the
/// frame's length).
#[inline]
pub fn frame_motion(params: &SimParams, pose: &ColliderPose, push: &BroadPhasePush) -> SubstepMotion {
    SubstepMotion::of(pose, 0.0, 1.0, params.substep * push.substeps as f32)
}

/// Whether a particle's narrow phase walks the whole LBVH instead of its list (`query`): its
/// motion `p0 -> p1` left the query box, or the list overflowed.
#[inline]
pub fn walks_tree(query: &ContactQuery, (p0, p1): (Vec3, Vec3)) -> bool {
    let region = Aabb { min: query.low, max: query.high };
    query.count == CANDIDATES_OVERFLOWED || !point_in_aabb(p0, &region, 0.0) || !point_in_aabb(p1, &region, 0.0)
}

/// Whether a particle's narrow phase is crowded for `ContactPush::crowded` = `longest` (> 0):
/// it walks the tree (`walks`), or its list holds at least `longest` leaves. Its lane would
/// test them one after another.
#[inline]
pub fn is_crowded(query: &ContactQuery, walks: bool, longest: u32) -> bool {
    walks || query.count >= longest
}

/// A particle's candidate list: the lists' buffer, where its list starts and how many leaves
/// it holds.
pub type CandidateList<'a> = (&'a [u32], usize, u32);

/// Which of a list's entries a lane takes: every `stride`-th from `first` ((0, 1): all of
/// them, in order; (lane, lanes): a workgroup lane's share, `crowded`).
pub type ListShare = (u32, u32);

/// The earliest hit of the motion `p0 -> p1` and the least clearance from `p0` (for kinds that
/// check paths) over `share` of a candidate list's leaves, from `found`.
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn list_hits<K: LeafKind>(
    leaves: &[K::Leaf],
    (list, base, count): CandidateList<'_>,
    (first, stride): ListShare,
    (p0, p1): (Vec3, Vec3),
    thickness: f32,
    left: Left,
    (mut best, mut clearance): (Candidate, f32),
) -> (Candidate, f32) {
    let mut j = first;
    while j < count {
        let leaf = list[base + j as usize];
        let l = leaves[leaf as usize];
        let (t, key) = hit_relative::<K>(l, p0, p1, thickness, left);
        best = consider(best, t, key, leaf);
        clearance = lower_clearance::<K>(clearance, l, p0, left);
        j += stride;
    }
    (best, clearance)
}

/// Whether the path `a -> b` crosses any leaf of `share` of a candidate list.
#[inline]
pub fn list_blocks<K: LeafKind>(
    leaves: &[K::Leaf],
    (list, base, count): CandidateList<'_>,
    (first, stride): ListShare,
    (a, b): (Vec3, Vec3),
    thickness: f32,
    left: Left,
) -> bool {
    let mut j = first;
    while j < count {
        if blocks_relative::<K>(leaves[list[base + j as usize] as usize], a, b, thickness, left) {
            return true;
        }
        j += stride;
    }
    false
}

/// What a narrow-phase detect did for one particle beyond writing its contact.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct NarrowOutcome {
    /// It walked the whole LBVH (left its query box, or its list had overflowed).
    pub fell_back: bool,
    /// Nothing was within its reach: its list is empty and its motion stayed inside its query
    /// box (the list holds every leaf a motion inside the box can touch), so it has no contact
    /// and its record was left as it was.
    pub nothing: bool,
    /// It is crowded (`is_crowded`, under the threshold asked for).
    pub crowded: bool,
    /// It is crowded and was asked to hand such a case over: nothing was detected or
    /// written; the crowded pass answers it.
    pub handed_over: bool,
}

/// Narrow-phase detect for one particle: writes `contacts[index]`, from its candidate list when
/// its substep motion stays inside its query box, else by a full traversal; or, with an empty
/// list and the motion inside the box, writes nothing (`NarrowOutcome::nothing`: no contact).
/// That is most of a cloth before it reaches the collider, where writing the record and
/// applying it cost as much as the test; a record is read only by its own particle's response,
/// so the one left there is never used. With `longest` > 0 (`ContactPush::crowded`) a crowded
/// particle (`is_crowded`) is reported (`NarrowOutcome::crowded`), and with `hand_over`
/// (`ContactPush::hand_over`) only reported (`NarrowOutcome::handed_over`).
#[allow(clippy::too_many_arguments)]
pub fn detect_candidates_at<K: LeafKind>(
    index: u32,
    collider: &ColliderParams,
    motion: &SubstepMotion,
    (nodes, aabbs, leaves): (&[BvhNode], &[Aabb], &[K::Leaf]),
    (queries, candidates): (&[ContactQuery], &[u32]),
    (x, x_prev): (&[Vec4], &[Vec4]),
    contacts: &mut [Contact],
    (longest, hand_over): (u32, bool),
) -> NarrowOutcome {
    let i = index as usize;
    if x[i].w == 0.0 {
        contacts[i] = Contact::NONE;
        return NarrowOutcome::default();
    }
    let (p0, p1) = local_motion(index, motion, x, x_prev);
    let query = queries[i];
    let region = Aabb { min: query.low, max: query.high };
    let walks = walks_tree(&query, (p0, p1));
    let crowded = longest != 0 && is_crowded(&query, walks, longest);
    if crowded && hand_over {
        return NarrowOutcome { crowded, handed_over: true, ..NarrowOutcome::default() };
    }
    if walks {
        detect_at::<K>(index, collider, motion, nodes, aabbs, leaves, x, x_prev, contacts);
        return NarrowOutcome { fell_back: true, crowded, ..NarrowOutcome::default() };
    }
    if query.count == 0 {
        return NarrowOutcome { nothing: true, ..NarrowOutcome::default() };
    }
    let thickness = collider.thickness;
    let left = motion.left();
    let list = (candidates, i * MAX_CANDIDATES as usize, query.count);
    // A lower bound on the distance from p0 to every leaf (for kinds that check paths): the
    // least clearance of the listed leaves, and the thickness for the rest (no point of the
    // box comes within it of them). A path shorter than half of it needs no check, which
    // saves a second scan of the list for most particles resting on the surface.
    let none = (NO_CANDIDATE, initial_clearance::<K>(thickness));
    let (best, clearance) = list_hits::<K>(leaves, list, (0, 1), (p0, p1), thickness, left, none);
    let target = target_of::<K>(best, clearance, leaves, (p0, p1), collider, left);
    let blocked = target.check
        && if point_in_aabb(target.position, &region, 0.0) {
            list_blocks::<K>(leaves, list, (0, 1), (p0, target.position), thickness, left)
        } else {
            // The path leaves the box, where the list is not complete.
            path_blocked::<K>(collider, nodes, aabbs, leaves, p0, target.position, left)
        };
    contacts[i] = target.contact(blocked);
    NarrowOutcome { crowded, ..NarrowOutcome::default() }
}

/// The body of every leaf kind's narrow-phase entry point: detects particle `index`'s contact
/// over its list (fallbacks counted in `status`) and applies it at once. One
/// pass instead of a detect pass and a respond pass: a particle's detection reads only its own
/// position, so no other thread's response can change what it finds.
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn detect_candidates_particle<K: LeafKind>(
    index: u32,
    push: &ContactPush,
    params: &SimParams,
    collider: &ColliderParams,
    pose: &ColliderPose,
    tree: (&[BvhNode], &[Aabb], &[K::Leaf]),
    lists: (&[ContactQuery], &[u32]),
    (x, x_prev, v): (&mut [Vec4], &[Vec4], &mut [Vec4]),
    contacts: &mut [Contact],
    (status, health, crowded): (&mut CollisionStatus, &mut Health, CrowdedQueue<'_>),
) {
    if index >= params.particle_count {
        return;
    }
    if sleeping(v[index as usize]) {
        // Its tile has come to rest and no collider moves near it: nothing to find.
        contacts[index as usize] = Contact::NONE;
        return;
    }
    let motion = substep_motion(params, pose, push);
    let asked = (push.crowded, push.hand_over != 0);
    let outcome = detect_candidates_at::<K>(index, collider, &motion, tree, lists, (x, x_prev), contacts, asked);
    if outcome.crowded {
        crate::atomics::add(&mut health.crowded_contacts, 1);
    }
    if outcome.handed_over {
        crate::crowded::hand_over(index, crowded, status);
        return;
    }
    if outcome.nothing {
        return;
    }
    if outcome.fell_back {
        crate::atomics::add(&mut status.fallbacks, 1);
    }
    respond_at(index, &contacts[index as usize], collider, &motion, x, v);
}
