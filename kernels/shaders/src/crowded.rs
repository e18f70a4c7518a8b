//! Crowded particles' contact, answered by a workgroup each.
//!
//! Near a finely tessellated collider a particle has many leaves within its reach: one resting
//! on the bunny (69,674 triangles, edges of a millimetre or two) against a 5 mm thickness has
//! about a hundred triangles within its motion's box. The narrow phase tests its list one leaf
//! after another in its lane, and a particle that left its query box (or whose list
//! overflowed) walks the tree node after node; its warp, and the pass, wait for the longest
//! (on an H100, about 89 of the bunny's 158 µs a substep went to the longest walk).
//!
//! Where the frame asks for it (`ContactPush::crowded`), the narrow phase hands such particles
//! (`candidates::is_crowded`: walkers, and lists of `CROWDED_LIST` leaves or more) to this pass,
//! which runs a workgroup per particle: its lanes share the list's leaves, or walk the tree
//! together level by level (`shared_walk`: a level's nodes spread over the lanes, the leaves it
//! reaches tested side by side), and lane 0 folds what they found. The answer is the lane's
//! own, bit for bit: `contact::consider` is a total order and the clearance a minimum, so the
//! order of the tests does not matter, and the level walk reaches exactly the leaves the
//! depth-first walk reaches (a leaf is reached when every internal node above it enters the
//! query). The CPU twin answers each handed-over particle as its lane would have. (On a GPU
//! the claim also needs the driver to compile the same math alike in both pipelines; no
//! `NoContraction` forbids it fusing differently. The H100's final frames were the same.)

use crate::atomics;
use crate::candidates::{detect_candidates_particle, list_blocks, list_hits, walks_tree};
use crate::contact::{
    Candidate, HitQuery, LeafKind, NO_CANDIDATE, PathQuery, consider, initial_clearance, local_motion, path_blocked,
    point_in_aabb, respond_at, substep_motion, target_of, traverse_with_clearance,
};
use crate::lbvh::TreeQuery;
use drape_types::glam::{UVec4, Vec4, Vec4Swizzles};
use drape_types::{
    Aabb, BvhNode, ColliderParams, ColliderPose, CollisionStatus, Contact, ContactPush, ContactQuery, DispatchArgs,
    Health, LEAF_BIT, MAX_CANDIDATES, SimParams,
};

/// Lanes of the crowded pass's workgroups (one particle each).
pub const CROWDED_THREADS: u32 = 64;
/// A candidate list of at least this many leaves is crowded (the host's `ContactPush::crowded`):
/// its tests take more than a few rounds of a lane's own work. (On an H100, the bunny's frame
/// took 1.33, 1.54, 1.65 and 1.72 ms with 8, 16, 32 and 64; 3.77 with 4, where most lists go.)
pub const CROWDED_LIST: u32 = 8;
/// Internal nodes one level of a shared walk holds. A wider level (a motion across much of the
/// collider) leaves the walk to lane 0 alone, as the narrow phase's lane would do it.
pub const FRONTIER: usize = 128;
/// Workgroups the crowded pass runs at most: each takes every `MAX_CROWDED_GROUPS`-th particle
/// after its own, within any device's dispatch limit (65,535).
pub const MAX_CROWDED_GROUPS: u32 = 16384;

/// The crowded particles of a substep: their indices, and the crowded pass's indirect dispatch
/// (x workgroups; the count in `_pad`; the host writes {0, 1, 1, 0} before the narrow phase).
pub type CrowdedQueue<'a> = (&'a mut [u32], &'a mut DispatchArgs);

/// Hands particle `index` to the crowded pass (counted in `status.crowded`).
#[inline]
pub fn hand_over(index: u32, (queue, args): CrowdedQueue<'_>, status: &mut CollisionStatus) {
    let slot = atomics::add(&mut args._pad, 1);
    queue[slot as usize] = index;
    if slot < MAX_CROWDED_GROUPS {
        atomics::max(&mut args.x, slot + 1);
    }
    atomics::add(&mut status.crowded, 1);
}

/// Slots of a shared walk's counters.
const NEXT: usize = 0;
const REACHED: usize = 1;
const LEVEL: usize = 2;
const TOO_WIDE: usize = 3;
/// Slot of the path check's blocked count (apart from the walk's).
const BLOCKED: usize = 4;
pub const COUNTERS: usize = 8;

/// A workgroup's shared memory for the crowded pass: the walk's two levels (this one's nodes and
/// the next one's, halves of `frontier`), the leaves a level reached, counters, the lanes' finds
/// (earliest hit and clearance) and lane 0's target (position and whether its path is checked;
/// where the particle stops if the path is blocked).
pub struct Shared<'a> {
    pub frontier: &'a mut [u32; 2 * FRONTIER],
    pub reached: &'a mut [u32; 2 * FRONTIER],
    pub counters: &'a mut [u32; COUNTERS],
    pub finds: &'a mut [UVec4; CROWDED_THREADS as usize],
    pub target: &'a mut [Vec4; 2],
}

#[inline]
fn barrier() {
    #[cfg(target_arch = "spirv")]
    spirv_std::arch::workgroup_memory_barrier_with_group_sync();
}

/// Walks a tree of `leaf_count` leaves (`nodes`, `aabbs`) for `query`, the workgroup's `lanes`
/// lanes together, level by level: lane `lane` takes every `lanes`-th node of a level, and
/// puts the children of those its query enters in the next level (internal nodes) or among
/// the level's reached leaves; then takes every `lanes`-th reached leaf. Returns what this
/// lane's leaves found (from `found`; a lane stops offering leaves once `TreeQuery::leaf` says
/// stop) and whether the walk fitted (false: a level had more than `FRONTIER` nodes, and what
/// the lanes found is incomplete). Every lane must call it (it holds barriers); with one lane
/// (and no barriers: the CPU) it is a plain breadth-first walk.
pub fn shared_walk<Q: TreeQuery>(
    (lane, lanes): (u32, u32),
    (nodes, aabbs, leaf_count): (&[BvhNode], &[Aabb], u32),
    query: &mut Q,
    mut found: Q::Found,
    shared: &mut Shared<'_>,
) -> (Q::Found, bool) {
    if leaf_count == 1 {
        // The tree is its one leaf.
        if lane == 0 {
            query.leaf(0, &mut found);
        }
        return (found, true);
    }
    // Earlier users of the shared memory are done with it before lane 0 seeds the walk.
    barrier();
    if lane == 0 {
        shared.frontier[0] = 0; // the root
        shared.counters[LEVEL] = 1;
        shared.counters[NEXT] = 0;
        shared.counters[REACHED] = 0;
        shared.counters[TOO_WIDE] = 0;
    }
    barrier();
    let mut stopped = false;
    let mut here = 0u32; // the half of `frontier` holding this level
    loop {
        // The same in every lane (read after a barrier), so every lane reaches each barrier.
        let size = shared.counters[LEVEL];
        if size == 0 {
            break;
        }
        let next = (FRONTIER as u32) * (1 - here);
        let mut k = lane;
        while k < size {
            let index = shared.frontier[(FRONTIER as u32 * here + k) as usize];
            if query.enters(&aabbs[index as usize]) {
                let node = nodes[index as usize];
                add_child(node.left, next, shared);
                add_child(node.right, next, shared);
            }
            k += lanes;
        }
        barrier();
        let reached = shared.counters[REACHED];
        let mut k = lane;
        while k < reached && !stopped {
            stopped = query.leaf(shared.reached[k as usize], &mut found);
            k += lanes;
        }
        // Every lane has read this level's counters and leaves before lane 0 resets them.
        barrier();
        if lane == 0 {
            let wide = shared.counters[NEXT] > FRONTIER as u32;
            shared.counters[LEVEL] = if wide { 0 } else { shared.counters[NEXT] };
            shared.counters[TOO_WIDE] |= wide as u32;
            shared.counters[NEXT] = 0;
            shared.counters[REACHED] = 0;
        }
        barrier();
        here = 1 - here;
    }
    (found, shared.counters[TOO_WIDE] == 0)
}

/// Puts `child` among the level's reached leaves, or in the next level (at `next` in
/// `frontier`) while it has room.
#[inline]
fn add_child(child: u32, next: u32, shared: &mut Shared<'_>) {
    if child & LEAF_BIT != 0 {
        // A level of at most `FRONTIER` nodes reaches at most twice as many leaves.
        let slot = atomics::add_workgroup(&mut shared.counters[REACHED], 1);
        shared.reached[slot as usize] = child & !LEAF_BIT;
    } else {
        let slot = atomics::add_workgroup(&mut shared.counters[NEXT], 1);
        if slot < FRONTIER as u32 {
            shared.frontier[(next + slot) as usize] = child;
        }
    }
}

/// A lane's find as it is shared: the bits of t, key, leaf and clearance. Words, not floats: a
/// leaf index's bits as a float are a denormal, which a GPU may flush to zero on the way.
#[inline]
fn pack((best, clearance): (Candidate, f32)) -> UVec4 {
    UVec4::new(best.t.to_bits(), best.key.to_bits(), best.leaf, clearance.to_bits())
}

/// The earliest hit and least clearance over the lanes' finds (any order gives the same).
#[inline]
fn fold(finds: &[UVec4; CROWDED_THREADS as usize], lanes: u32, clearance: f32) -> (Candidate, f32) {
    let (mut best, mut clearance) = (NO_CANDIDATE, clearance);
    let mut k = 0;
    while k < lanes {
        let f = finds[k as usize];
        best = consider(best, f32::from_bits(f.x), f32::from_bits(f.y), f.z);
        clearance = clearance.min(f32::from_bits(f.w));
        k += 1;
    }
    (best, clearance)
}

/// The crowded pass for particle `index` (handed over by the narrow phase, so awake, unpinned
/// and crowded), the workgroup's `lanes` lanes together: its earliest contact over its list
/// or the tree, the path check, then (lane 0) the contact record and the response, as
/// `candidates::detect_candidates_particle` would have done in its lane; a walk counts in
/// `status.fallbacks`. Every lane must call it (it holds barriers).
#[allow(clippy::too_many_arguments)]
pub fn detect_crowded_particle<K: LeafKind>(
    index: u32,
    (lane, lanes): (u32, u32),
    push: &ContactPush,
    params: &SimParams,
    (collider, pose): (&ColliderParams, &ColliderPose),
    (nodes, aabbs, leaves): (&[BvhNode], &[Aabb], &[K::Leaf]),
    (queries, candidates): (&[ContactQuery], &[u32]),
    (x, x_prev, v): (&mut [Vec4], &[Vec4], &mut [Vec4]),
    contacts: &mut [Contact],
    status: &mut CollisionStatus,
    shared: &mut Shared<'_>,
) {
    let i = index as usize;
    let motion = substep_motion(params, pose, push);
    let (p0, p1) = local_motion(index, &motion, x, x_prev);
    let query = queries[i];
    let region = Aabb { min: query.low, max: query.high };
    let walks = walks_tree(&query, (p0, p1));
    let (thickness, left) = (collider.thickness, motion.left());
    let tree = (nodes, aabbs, collider.leaf_count);
    let list = (candidates, i * MAX_CANDIDATES as usize, query.count);
    let no_find = (NO_CANDIDATE, initial_clearance::<K>(thickness));
    // The lanes' share of the earliest hit and the clearance (see `detect_candidates_at`).
    let (find, fitted) = if walks {
        let mut hits = HitQuery::<K> { leaves, p0, p1, thickness, left };
        shared_walk((lane, lanes), tree, &mut hits, no_find, shared)
    } else {
        (list_hits::<K>(leaves, list, (lane, lanes), (p0, p1), thickness, left, no_find), true)
    };
    shared.finds[lane as usize] = pack(find);
    barrier();
    // Lane 0's answer, written at once as if the path were clear; the lanes learn the target's
    // position, whether its path is checked, and where the particle stops if it is blocked.
    // (Nothing of it stays in lane 0's registers across the barriers: NVIDIA's compiler (driver
    // 580) lost such a value, and the cloth blew up at its first contact.)
    if lane == 0 {
        let (best, clearance) = if fitted {
            fold(shared.finds, lanes, no_find.1)
        } else {
            traverse_with_clearance::<K>(collider, nodes, aabbs, leaves, p0, p1, left)
        };
        let target = target_of::<K>(best, clearance, leaves, (p0, p1), collider, left);
        contacts[i] = target.contact(false);
        shared.target[0] = target.position.extend(if target.check { 1.0 } else { 0.0 });
        shared.target[1] = target.first.extend(0.0);
        shared.counters[BLOCKED] = 0;
    }
    barrier();
    let (to, checked) = (shared.target[0].xyz(), shared.target[0].w != 0.0);
    // The same in every lane, so every lane reaches the walk's barriers.
    if checked {
        if !walks && point_in_aabb(to, &region, 0.0) {
            let blocked = list_blocks::<K>(leaves, list, (lane, lanes), (p0, to), thickness, left);
            count_blocked(blocked, shared);
        } else {
            // The path leaves the box, where the list is not complete: the tree's leaves.
            let mut path = PathQuery::<K> { leaves, a: p0, b: to, thickness, left };
            let (blocked, fitted) = shared_walk((lane, lanes), tree, &mut path, false, shared);
            count_blocked(blocked, shared);
            if !fitted && lane == 0 && path_blocked::<K>(collider, nodes, aabbs, leaves, p0, to, left) {
                count_blocked(true, shared);
            }
        }
        barrier();
    }
    if lane == 0 {
        if checked && shared.counters[BLOCKED] != 0 {
            // Blocked: it stops at its first contact (`Target::contact`).
            let record = contacts[i];
            contacts[i] = Contact { position: shared.target[1].xyz().extend(record.position.w), ..record };
        }
        if walks {
            atomics::add(&mut status.fallbacks, 1);
        }
        respond_at(index, &contacts[i], collider, &substep_motion(params, pose, push), x, v);
    }
}

/// Counts a lane that found the path blocked.
#[inline]
fn count_blocked(blocked: bool, shared: &mut Shared<'_>) {
    if blocked {
        atomics::add_workgroup(&mut shared.counters[BLOCKED], 1);
    }
}

/// The CPU twin of the crowded pass for particle `index`: what its lane in the narrow phase
/// would have done (`candidates::detect_candidates_particle` without handing over), which the
/// workgroup's answer equals bit for bit.
#[allow(clippy::too_many_arguments)]
pub fn detect_crowded_alone<K: LeafKind>(
    index: u32,
    push: &ContactPush,
    params: &SimParams,
    (collider, pose): (&ColliderParams, &ColliderPose),
    tree: (&[BvhNode], &[Aabb], &[K::Leaf]),
    lists: (&[ContactQuery], &[u32]),
    state: (&mut [Vec4], &[Vec4], &mut [Vec4]),
    contacts: &mut [Contact],
    status: &mut CollisionStatus,
) {
    // Counted when it was handed over.
    let alone = ContactPush { crowded: 0, hand_over: 0, ..*push };
    let mut no_queue = ([0u32; 0], DispatchArgs::default(), Health::default());
    let counters = (status, &mut no_queue.2, (&mut no_queue.0[..], &mut no_queue.1));
    detect_candidates_particle::<K>(index, &alone, params, collider, pose, tree, lists, state, contacts, counters);
}

/// The fold of finds split over lanes (as the pass shares them): for the tests.
#[cfg(test)]
fn fold_of(finds: &[(Candidate, f32)], clearance: f32) -> (Candidate, f32) {
    let mut shared = [UVec4::ZERO; CROWDED_THREADS as usize];
    for (k, f) in finds.iter().enumerate() {
        shared[k] = pack(*f);
    }
    fold(&shared, finds.len() as u32, clearance)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lbvh::walk;
    use drape_types::glam::Vec3;

    /// Lists the leaves a query reaches (boxes meeting `lo..=hi`).
    struct Reach {
        lo: Vec3,
        hi: Vec3,
        reached: Vec<u32>,
    }

    impl TreeQuery for Reach {
        type Found = u32;
        fn enters(&self, b: &Aabb) -> bool {
            crate::lbvh::box_meets(b, self.lo, self.hi)
        }
        fn leaf(&mut self, leaf: u32, count: &mut u32) -> bool {
            self.reached.push(leaf);
            *count += 1;
            false
        }
    }

    /// The level walk reaches the leaves the depth-first walk reaches, on one lane: LBVHs of
    /// 1 to 2000 random boxes (codes with repeats), queries of every size; and a query wider
    /// than `FRONTIER` nodes says it did not fit.
    #[test]
    fn the_level_walk_reaches_the_leaves_of_the_depth_first_walk() {
        let mut next = crate::test_random::unit_floats(0x2545_F491_4F6C_DD1D);
        let mut wide_seen = false;
        for n in [1u32, 2, 3, 17, 64, 300, 2000] {
            let mut codes: Vec<u32> = (0..n).map(|_| (next() * 200.0) as u32).collect();
            codes.sort_unstable();
            let internal = (n - 1) as usize;
            let mut nodes = vec![BvhNode::default(); internal.max(1)];
            let mut parents = vec![0u32; internal + n as usize];
            for i in 0..n - 1 {
                crate::lbvh::build_node_at(&codes, n, i, &mut nodes, &mut parents);
            }
            let leaf_boxes: Vec<Aabb> = (0..n)
                .map(|_| {
                    let lo = Vec3::new(next(), next(), next()) * 4.0 - 2.0;
                    Aabb { min: lo.extend(0.0), max: (lo + Vec3::splat(0.1 + 0.2 * next())).extend(0.0) }
                })
                .collect();
            let (mut flags, mut words) =
                (vec![0u32; internal], vec![0u32; internal * drape_types::AABB_WORDS as usize]);
            for leaf in (0..n).filter(|_| n > 1) {
                crate::lbvh::refit_from_leaf(leaf, n, &nodes, &parents, &leaf_boxes, &mut flags, &mut words);
            }
            let aabbs: Vec<Aabb> = (0..internal as u32).map(|k| crate::lbvh::load_aabb(&words, k)).collect();
            for q in 0..40 {
                // The first query takes every leaf.
                let centre = if q == 0 { Vec3::ZERO } else { Vec3::new(next(), next(), next()) * 4.0 - 2.0 };
                let half = Vec3::splat(if q == 0 { 10.0 } else { 0.05 + next() * next() * 2.0 });
                let query = || Reach { lo: centre - half, hi: centre + half, reached: Vec::new() };
                let mut frontier = [0u32; 2 * FRONTIER];
                let mut reached = [0u32; 2 * FRONTIER];
                let mut counters = [0u32; COUNTERS];
                let mut finds = [UVec4::ZERO; CROWDED_THREADS as usize];
                let mut target = [Vec4::ZERO; 2];
                let mut shared = Shared {
                    frontier: &mut frontier,
                    reached: &mut reached,
                    counters: &mut counters,
                    finds: &mut finds,
                    target: &mut target,
                };
                let mut by_levels = query();
                let (count, fitted) = shared_walk((0, 1), (&nodes, &aabbs, n), &mut by_levels, 0, &mut shared);
                let mut depth_first = query();
                let expected = walk(&nodes, &aabbs, n, &mut depth_first, 0);
                if !fitted {
                    // Only a level of more than `FRONTIER` nodes stops it: more leaves below.
                    assert!(n as usize > FRONTIER, "{n} leaves, query {q}: stopped");
                    wide_seen = true;
                    continue;
                }
                let mut levels = by_levels.reached.clone();
                levels.sort_unstable();
                assert_eq!(count, expected, "{n} leaves, query {q}");
                assert_eq!(levels, depth_first.reached, "{n} leaves, query {q}");
            }
        }
        assert!(wide_seen, "no query was wider than the frontier");
    }

    /// Finds split over lanes in any way fold to the one-lane answer.
    #[test]
    fn split_finds_fold_to_the_one_lane_answer() {
        let mut next = crate::test_random::unit_floats(0x9E37_79B9_7F4A_7C15);
        let hits: Vec<(f32, f32, u32)> =
            (0..40).map(|leaf| ((next() * 4.0).floor() * 0.25, (next() * 3.0).floor(), leaf)).collect();
        let alone = hits.iter().fold(NO_CANDIDATE, |b, &(t, key, leaf)| consider(b, t, key, leaf));
        for lanes in [1usize, 3, 7, 64] {
            let mut finds = vec![(NO_CANDIDATE, 1.0f32); lanes];
            for (k, &(t, key, leaf)) in hits.iter().enumerate() {
                let f = &mut finds[(k * 5 + 1) % lanes];
                f.0 = consider(f.0, t, key, leaf);
                f.1 = f.1.min(t + 0.1);
            }
            let (best, clearance) = fold_of(&finds, 1.0);
            assert_eq!(best, alone, "{lanes} lanes");
            assert_eq!(clearance, 0.1, "{lanes} lanes");
        }
    }
}
