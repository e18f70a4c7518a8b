//! Linear BVH over leaf boxes (Karras 2012, "Maximizing Parallelism in the Construction of
//! BVHs, Octrees, and k-d Trees"): Morton codes of the leaf boxes' centres, a radix sort
//! (`sort.rs`), all internal nodes in parallel (one thread each), then internal boxes bottom-up
//! (one thread per leaf; the second thread to reach a node computes it).
//!
//! The build knows nothing of what a leaf is: a leaf kind (`spheres.rs`) writes one box per leaf
//! in input order and, after the sort, gathers its own data into the tree's leaf order.

use crate::atomics;
use drape_types::glam::{UVec3, Vec3, Vec4, Vec4Swizzles};
use drape_types::{AABB_WORDS, Aabb, BvhNode, ColliderParams, LEAF_BIT, NO_NODE};
use spirv_std::spirv;

/// What a walk of the LBVH looks for: which subtrees to enter, and what to do at each leaf a
/// walk reaches (a leaf's own box, where a query wants it, is the query's to test).
///
/// What the visits find lives apart from the query, in `Found` (plain values: no slices or
/// references), and the query's own fields never change during a walk. The walk's loop then
/// carries only plain values: a query whose fields changed would be carried whole, slices
/// and all, and a SPIR-V phi of a value that holds pointers crashes NVIDIA's shader compiler
/// (driver 580; `tests/engine.rs` checks every kernel for such values).
pub trait TreeQuery {
    /// What the walk's visits find (a count, the best hit so far, ...).
    type Found: Copy;
    /// Whether the subtree under the node box `b` can hold something the query wants.
    fn enters(&self, b: &Aabb) -> bool;
    /// Leaf `leaf` (tree order) is reached; true stops the walk.
    fn leaf(&mut self, leaf: u32, found: &mut Self::Found) -> bool;
}

/// Walks a tree of `leaf_count` leaves (nodes and their boxes; node 0 is the root) depth
/// first, left child first, without a stack (`BvhNode::escape`), offering `query` every leaf
/// under the subtrees it enters. Returns what the visits found (starting from `found`).
///
/// It steps as `PairWalk` does, written out again: a `PairBoxes` that asks the query would hold
/// a reference to it, a pointer kept as data (see `TreeQuery`).
pub fn walk<Q: TreeQuery>(
    nodes: &[BvhNode],
    aabbs: &[Aabb],
    leaf_count: u32,
    query: &mut Q,
    mut found: Q::Found,
) -> Q::Found {
    if leaf_count == 1 {
        query.leaf(0, &mut found);
        return found;
    }
    let mut next = 0; // the root
    let mut stopped = false;
    let mut batch = [0u32; WALK_BATCH];
    while next != NO_NODE && !stopped {
        // A stretch of the walk through internal nodes, collecting the leaves it meets, then
        // the leaves' tests: a GPU's warp (or llvmpipe's SIMD lanes) runs its lanes in
        // lockstep, so a leaf test inside the node loop would run, masked, at every step where
        // any lane met a leaf; after the stretch it runs as often as the busiest lane has
        // leaves. The tests see the same leaves in the same order.
        let mut count = 0;
        while next != NO_NODE && count < WALK_BATCH {
            let index = next & !LEAF_BIT;
            if next & LEAF_BIT != 0 {
                batch[count] = index;
                count += 1;
                next = leaf_escape(nodes, leaf_count, index);
            } else {
                let node = nodes[index as usize];
                next = if query.enters(&aabbs[index as usize]) { node.left } else { node.escape };
            }
        }
        let mut k = 0;
        while k < count && !stopped {
            stopped = query.leaf(batch[k], &mut found);
            k += 1;
        }
    }
    found
}

/// Leaves a `PairWalk` hands over at a time.
pub const WALK_BATCH: usize = 16;

/// A walk that pairs a leaf with the later leaves (tree order) whose boxes meet a query box,
/// handing them over in batches: the caller tests a batch's pairs between two stretches of the
/// walk. On llvmpipe a shader's lanes run in lockstep, so a pair test inside the walk's loop
/// would run (masked) at every step where any lane reached a leaf; after the walk it runs as
/// often as the busiest lane has leaves.
///
/// The walk has no stack: it visits the tree depth first, left child first, and where a box
/// fails its query (or after a leaf) it follows the node's escape (`BvhNode::escape`, the
/// subtree after it). Its state is the next entry to visit. Private arrays indexed per lane
/// are memory on llvmpipe and GPUs alike, and the walk for the leaves after `first` starts at
/// the leaf's own escape: the subtrees right of its path from the root, which a walk from the
/// root reaches only through the path's nodes (whose boxes hold the query's own).
pub struct PairWalk {
    /// The next entry to visit: an internal node, a leaf with `LEAF_BIT`, or `NO_NODE` (done).
    next: u32,
    leaf_count: u32,
}

impl PairWalk {
    /// A walk for leaf `first` of a tree (`nodes`) of `leaf_count` leaves: the later leaves its
    /// query takes (a box, `next_batch`; or any `PairBoxes`, `next_batch_in`).
    pub fn new(first: u32, nodes: &[BvhNode], leaf_count: u32) -> Self {
        PairWalk { next: leaf_escape(nodes, leaf_count, first), leaf_count }
    }

    /// A walk for every leaf its query takes, in batches as `new`'s.
    pub fn all(leaf_count: u32) -> Self {
        // A one-leaf tree has no internal node: the tree is its leaf, which may meet the
        // query (a one-triangle cloth under a collider's vertex).
        let next = if leaf_count > 1 { 0 } else { LEAF_BIT };
        PairWalk { next, leaf_count }
    }

    /// A walk that visits leaf `leaf` alone, when its box meets the query: what a walk of the
    /// whole tree would hand over of that leaf (every box above it holds its box).
    pub fn one(leaf: u32) -> Self {
        PairWalk { next: leaf | LEAF_BIT, leaf_count: leaf + 1 }
    }

    /// Whether the walk is over.
    pub fn done(&self) -> bool {
        self.next == NO_NODE
    }

    /// Walks on until `found` holds `WALK_BATCH` leaves or the walk is over; returns how many
    /// it holds (in tree order). Takes the boxes that meet the query box `lo..=hi`.
    pub fn next_batch(
        &mut self,
        (nodes, aabbs, leaf_bounds): (&[BvhNode], &[Aabb], &[Aabb]),
        (lo, hi): (Vec3, Vec3),
        found: &mut [u32; WALK_BATCH],
    ) -> usize {
        self.next_batch_in(nodes, QueryBox { aabbs, leaf_bounds, lo, hi }, found)
    }

    /// `next_batch` with another test of which subtrees and leaves to take (`boxes`).
    pub fn next_batch_in<B: PairBoxes>(&mut self, nodes: &[BvhNode], boxes: B, found: &mut [u32; WALK_BATCH]) -> usize {
        let mut count = 0;
        while self.next != NO_NODE && count < WALK_BATCH {
            let entry = self.next;
            let index = entry & !LEAF_BIT;
            if entry & LEAF_BIT != 0 {
                if boxes.leaf_meets(index) {
                    found[count] = index;
                    count += 1;
                }
                self.next = leaf_escape(nodes, self.leaf_count, index);
            } else {
                let (enters, left, escape) = boxes.step(nodes, index);
                self.next = if enters { left } else { escape };
            }
        }
        count
    }
}

/// Where a depth-first walk goes after leaf `leaf` of `leaf_count` (`BvhNode::leaf_escape`).
#[inline]
fn leaf_escape(nodes: &[BvhNode], leaf_count: u32, leaf: u32) -> u32 {
    if leaf + 1 >= leaf_count { NO_NODE } else { nodes[leaf as usize].leaf_escape }
}

/// Which subtrees and leaves a `PairWalk` takes. Passed by value (slices and plain values), so
/// no local holding pointers is kept in memory (see `TreeQuery`).
pub trait PairBoxes: Copy {
    /// What the walk loads of an internal node to test it (plain values).
    type NodeBoxes: Copy;
    /// Internal node `node`'s boxes.
    fn node_boxes(&self, node: u32) -> Self::NodeBoxes;
    /// Whether the subtree under an internal node with `boxes` can hold a leaf the walk wants.
    fn node_meets(&self, boxes: &Self::NodeBoxes) -> bool;
    /// Whether leaf `leaf` (tree order) is wanted.
    fn leaf_meets(&self, leaf: u32) -> bool;

    /// At internal node `index`: whether the walk enters it, its left child and its escape.
    #[inline]
    fn step(&self, nodes: &[BvhNode], index: u32) -> (bool, u32, u32) {
        let node = nodes[index as usize];
        (self.node_meets(&self.node_boxes(index)), node.left, node.escape)
    }
}

/// The boxes that meet the box `lo..=hi`: the tree's own.
#[derive(Copy, Clone)]
struct QueryBox<'a> {
    aabbs: &'a [Aabb],
    leaf_bounds: &'a [Aabb],
    lo: Vec3,
    hi: Vec3,
}

impl PairBoxes for QueryBox<'_> {
    type NodeBoxes = Aabb;

    #[inline]
    fn node_boxes(&self, node: u32) -> Aabb {
        self.aabbs[node as usize]
    }

    #[inline]
    fn node_meets(&self, b: &Aabb) -> bool {
        box_meets(b, self.lo, self.hi)
    }

    #[inline]
    fn leaf_meets(&self, leaf: u32) -> bool {
        box_meets(&self.leaf_bounds[leaf as usize], self.lo, self.hi)
    }
}

/// Whether box `b` meets the box `lo..=hi`.
#[inline]
pub fn box_meets(b: &Aabb, lo: Vec3, hi: Vec3) -> bool {
    lo.cmple(b.max.xyz()).all() && hi.cmpge(b.min.xyz()).all()
}

/// Spreads the low 10 bits of `v` to every third bit.
#[inline]
pub fn expand_bits(v: u32) -> u32 {
    let mut v = v & 0x3ff;
    v = (v | (v << 16)) & 0x0300_00ff;
    v = (v | (v << 8)) & 0x0300_f00f;
    v = (v | (v << 4)) & 0x030c_30c3;
    v = (v | (v << 2)) & 0x0924_9249;
    v
}

/// 30-bit Morton code of `p` normalised into the box [lo, hi] (10 bits per axis).
#[inline]
pub fn morton_code(p: Vec3, lo: Vec3, hi: Vec3) -> u32 {
    let extent = (hi - lo).max(Vec3::splat(1e-30));
    let unit = ((p - lo) * extent.recip()).clamp(Vec3::ZERO, Vec3::ONE);
    let q = (unit * 1023.0).min(Vec3::splat(1023.0));
    (expand_bits(q.x as u32) << 2) | (expand_bits(q.y as u32) << 1) | expand_bits(q.z as u32)
}

/// Centre of a box (what a leaf's Morton code encodes).
#[inline]
pub fn aabb_centre(b: &Aabb) -> Vec3 {
    (b.min.xyz() + b.max.xyz()) * 0.5
}

#[spirv(compute(threads(256)))]
pub fn morton_codes(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] collider: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] bounds: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] keys: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] values: &mut [u32],
) {
    let i = id.x;
    if i >= collider.leaf_count {
        return;
    }
    keys[i as usize] =
        morton_code(aabb_centre(&bounds[i as usize]), collider.scene_min.xyz(), collider.scene_max.xyz());
    values[i as usize] = i;
}

/// Element `i` of the tree's leaf order: `sorted[i] = input[order[i]]` (leaf boxes here, a
/// leaf kind's own data in its gather).
#[inline]
pub fn gather_at<T: Copy>(i: u32, input: &[T], order: &[u32], sorted: &mut [T]) {
    sorted[i as usize] = input[order[i as usize] as usize];
}

/// Puts the leaf boxes in the tree's order: `sorted[i] = bounds[order[i]]`.
#[spirv(compute(threads(256)))]
pub fn gather_bounds(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] collider: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] bounds: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] order: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] sorted: &mut [Aabb],
) {
    let i = id.x;
    if i < collider.leaf_count {
        gather_at(i, bounds, order, sorted);
    }
}

/// Karras' delta: length of the common prefix of (code_i, i) and (code_j, j); -1 outside.
/// Equal codes fall back to the indices (Karras §4), so every key is unique.
#[inline]
pub fn delta(codes: &[u32], n: u32, i: u32, j: i32) -> i32 {
    if j < 0 || j >= n as i32 {
        return -1;
    }
    let (a, b) = (codes[i as usize], codes[j as usize]);
    if a == b { 32 + (i ^ j as u32).leading_zeros() as i32 } else { (a ^ b).leading_zeros() as i32 }
}

/// Which way internal node `i`'s range of leaves extends from leaf `i` (Karras 2012): 1 up,
/// -1 down, towards the neighbour it shares more leading bits with.
#[inline]
fn range_direction(codes: &[u32], n: u32, i: u32) -> i32 {
    let ii = i as i32;
    if delta(codes, n, i, ii + 1) - delta(codes, n, i, ii - 1) >= 0 { 1 } else { -1 }
}

/// Children of internal node `i` (of n - 1), with `LEAF_BIT` marking leaves.
pub fn internal_node(codes: &[u32], n: u32, i: u32) -> BvhNode {
    let ii = i as i32;
    let d = range_direction(codes, n, i);
    let delta_min = delta(codes, n, i, ii - d);
    // Upper bound on the range length, then binary search for its other end.
    let mut l_max: i32 = 2;
    while delta(codes, n, i, ii + l_max * d) > delta_min {
        l_max *= 2;
    }
    let mut l: i32 = 0;
    let mut t = l_max / 2;
    while t >= 1 {
        if delta(codes, n, i, ii + (l + t) * d) > delta_min {
            l += t;
        }
        t /= 2;
    }
    let j = ii + l * d;
    // Split: the highest position where the range's keys differ.
    let delta_node = delta(codes, n, i, j);
    let mut s: i32 = 0;
    let mut divisor: i32 = 2;
    loop {
        let t = (l + divisor - 1) / divisor;
        if delta(codes, n, i, ii + (s + t) * d) > delta_node {
            s += t;
        }
        if t <= 1 {
            break;
        }
        divisor *= 2;
    }
    let gamma = ii + s * d + if d < 0 { -1 } else { 0 };
    let (first, last) = if ii < j { (ii, j) } else { (j, ii) };
    let left = if first == gamma { gamma as u32 | LEAF_BIT } else { gamma as u32 };
    let right = if last == gamma + 1 { (gamma + 1) as u32 | LEAF_BIT } else { (gamma + 1) as u32 };
    BvhNode { left, right, escape: entry_after(codes, n, last as u32), leaf_escape: entry_after(codes, n, i) }
}

/// Where a depth-first walk goes after a subtree whose last leaf is `last` (`BvhNode::escape`):
/// the subtree that starts at leaf `last + 1`. It is the right child of the node whose split
/// is `last` (each split belongs to one node), and a right child's index is its first leaf: the
/// internal node `last + 1` when that node's range starts there (it extends upwards, the
/// direction Karras' `internal_node` takes), else the leaf `last + 1` alone.
#[inline]
pub fn entry_after(codes: &[u32], n: u32, last: u32) -> u32 {
    let s = last + 1;
    if s >= n {
        return NO_NODE;
    }
    let internal_starting_here = s + 1 < n && range_direction(codes, n, s) == 1;
    if internal_starting_here { s } else { s | LEAF_BIT }
}

/// Index in the parents buffer: internal nodes first, then leaves.
#[inline]
pub fn parent_slot(child: u32, leaf_count: u32) -> u32 {
    if child & LEAF_BIT != 0 { leaf_count - 1 + (child & !LEAF_BIT) } else { child }
}

/// Internal node `i` (of `n` - 1): stores its children and links them to it; the root also marks
/// itself parentless. The kernel runs it once per thread, the CPU twin in a loop.
pub fn build_node_at(codes: &[u32], n: u32, i: u32, nodes: &mut [BvhNode], parents: &mut [u32]) {
    let node = internal_node(codes, n, i);
    nodes[i as usize] = node;
    parents[parent_slot(node.left, n) as usize] = i;
    parents[parent_slot(node.right, n) as usize] = i;
    if i == 0 {
        parents[0] = NO_NODE;
    }
}

/// One thread per internal node: its children, and their parent links.
#[spirv(compute(threads(256)))]
pub fn build_nodes(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] collider: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] codes: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] nodes: &mut [BvhNode],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] parents: &mut [u32],
) {
    let n = collider.leaf_count;
    let i = id.x;
    if i + 1 >= n {
        return;
    }
    build_node_at(codes, n, i, nodes, parents);
}

#[inline]
fn union(a: Aabb, b: Aabb) -> Aabb {
    Aabb { min: a.min.min(b.min), max: a.max.max(b.max) }
}

/// Reads internal node `node`'s box through atomics (see `atomics::load`).
#[inline]
pub fn load_aabb(words: &[u32], node: u32) -> Aabb {
    let base = (node * AABB_WORDS) as usize;
    let w = |k: usize| f32::from_bits(atomics::load(&words[base + k]));
    Aabb { min: Vec4::new(w(0), w(1), w(2), 0.0), max: Vec4::new(w(4), w(5), w(6), 0.0) }
}

#[inline]
fn store_aabb(words: &mut [u32], node: u32, b: Aabb) {
    let base = (node * AABB_WORDS) as usize;
    atomics::store(&mut words[base], b.min.x.to_bits());
    atomics::store(&mut words[base + 1], b.min.y.to_bits());
    atomics::store(&mut words[base + 2], b.min.z.to_bits());
    atomics::store(&mut words[base + 4], b.max.x.to_bits());
    atomics::store(&mut words[base + 5], b.max.y.to_bits());
    atomics::store(&mut words[base + 6], b.max.z.to_bits());
}

/// Box of a child: a leaf's box (in tree order), or an internal node's stored box.
#[inline]
fn child_aabb(child: u32, leaf_bounds: &[Aabb], words: &[u32]) -> Aabb {
    if child & LEAF_BIT != 0 { leaf_bounds[(child & !LEAF_BIT) as usize] } else { load_aabb(words, child) }
}

/// Walks from leaf `leaf` towards the root. At each node the first thread to arrive stops; the
/// second (acquire/release on the node's flag makes the sibling's box visible) computes the
/// node's box and goes on.
pub fn refit_from_leaf(
    leaf: u32,
    n: u32,
    nodes: &[BvhNode],
    parents: &[u32],
    leaf_bounds: &[Aabb],
    flags: &mut [u32],
    words: &mut [u32],
) {
    let mine = leaf_bounds[leaf as usize];
    climb_from_leaf(leaf, n, (nodes, parents), flags, mine, |node, children, from_left, mine| {
        fit_node(node, (children, from_left), mine, leaf_bounds, words)
    });
}

/// The refits' climb from leaf `leaf` towards the root: at each node the first thread to arrive
/// stops; the second (acquire/release on the node's flag makes what the sibling's thread wrote
/// visible) calls `fit` with the node, its children, whether it came from the left one, and
/// what it carries up (`mine`: the box of the child it came from, which it computed itself:
/// only the sibling's is loaded), and goes on with what `fit` returns.
#[inline]
fn climb_from_leaf<T: Copy>(
    leaf: u32,
    n: u32,
    (nodes, parents): (&[BvhNode], &[u32]),
    flags: &mut [u32],
    mine: T,
    mut fit: impl FnMut(u32, BvhNode, bool, T) -> T,
) {
    let mut child = leaf | LEAF_BIT;
    let mut node = parents[parent_slot(child, n) as usize];
    let mut mine = mine;
    while node != NO_NODE {
        // The tree's shape does not change in a refit: its loads go out with the flag's atomic
        // (on a GPU each level of the climb is a chain of loads that wait on memory).
        let children = nodes[node as usize];
        let parent = parents[node as usize];
        if atomics::add_acq_rel(&mut flags[node as usize], 1) == 0 {
            return;
        }
        mine = fit(node, children, children.left == child, mine);
        child = node;
        node = parent;
    }
}

/// Internal node `node`'s box (children `children`, the climb coming from the left one when
/// `from_left`, whose box is `mine`): the union of its children's, left first, stored and
/// returned. The box carried up differs from the stored one only in `w`, which is not stored.
#[inline]
fn fit_node(
    node: u32,
    (children, from_left): (BvhNode, bool),
    mine: Aabb,
    leaf_bounds: &[Aabb],
    words: &mut [u32],
) -> Aabb {
    let b = if from_left {
        union(mine, child_aabb(children.right, leaf_bounds, words))
    } else {
        union(child_aabb(children.left, leaf_bounds, words), mine)
    };
    store_aabb(words, node, b);
    b
}

/// `refit_from_leaf` over two sets of boxes on the same tree at once (`leaf_bounds` into
/// `words`, `other_leaf_bounds` into `other_words`): one climb, one flag per node. A tree that
/// carries a second box per node (`self_pairs::RelativeMotion`'s motions beside the start
/// boxes) refits both for the cost of the climb's atomics and loads of the shape once.
#[allow(clippy::too_many_arguments)]
pub fn refit_two_from_leaf(
    leaf: u32,
    n: u32,
    nodes: &[BvhNode],
    parents: &[u32],
    (leaf_bounds, other_leaf_bounds): (&[Aabb], &[Aabb]),
    flags: &mut [u32],
    words: &mut [u32],
    other_words: &mut [u32],
) {
    let mine = (leaf_bounds[leaf as usize], other_leaf_bounds[leaf as usize]);
    climb_from_leaf(leaf, n, (nodes, parents), flags, mine, |node, children, from_left, (mine, other)| {
        (
            fit_node(node, (children, from_left), mine, leaf_bounds, words),
            fit_node(node, (children, from_left), other, other_leaf_bounds, other_words),
        )
    });
}

/// Threads per workgroup of the refits (`refit`, `refit_two`: their `threads(256)`).
pub const REFIT_THREADS: u32 = 256;

#[spirv(compute(threads(256)))]
pub fn refit(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] collider: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] nodes: &[BvhNode],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] parents: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] leaf_bounds: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] flags: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] aabbs: &mut [u32],
) {
    let n = collider.leaf_count;
    if id.x >= n || n < 2 {
        return;
    }
    refit_from_leaf(id.x, n, nodes, parents, leaf_bounds, flags, aabbs);
}

/// `refit` of two box sets over one tree in one climb (`refit_two_from_leaf`).
#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(256)))]
pub fn refit_two(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] collider: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] nodes: &[BvhNode],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] parents: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] leaf_bounds: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] other_leaf_bounds: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] flags: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] aabbs: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] other_aabbs: &mut [u32],
) {
    let n = collider.leaf_count;
    if id.x >= n || n < 2 {
        return;
    }
    let boxes = (leaf_bounds, other_leaf_bounds);
    refit_two_from_leaf(id.x, n, nodes, parents, boxes, flags, aabbs, other_aabbs);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One climb refits two box sets as two refits do, word for word, and each root holds
    /// the union of its set's leaves: trees of 2 to 200 leaves, codes with repeats.
    #[test]
    fn one_climb_refits_two_box_sets_as_two_refits_do() {
        let mut next = crate::test_random::unit_floats(0x2545_F491_4F6C_DD1D);
        for n in [2u32, 3, 7, 64, 200] {
            let mut codes: Vec<u32> = (0..n).map(|_| (next() * 50.0) as u32).collect();
            codes.sort_unstable();
            let internal = (n - 1) as usize;
            let mut nodes = vec![BvhNode::default(); internal];
            let mut parents = vec![0u32; internal + n as usize];
            for i in 0..n - 1 {
                build_node_at(&codes, n, i, &mut nodes, &mut parents);
            }
            let mut boxes = || -> Vec<Aabb> {
                (0..n)
                    .map(|_| {
                        let lo = Vec3::new(next(), next(), next()) * 4.0 - 2.0;
                        Aabb { min: lo.extend(0.0), max: (lo + Vec3::new(next(), next(), next())).extend(0.0) }
                    })
                    .collect()
            };
            let (a, b) = (boxes(), boxes());
            let words = internal * AABB_WORDS as usize;
            let refit_one = |leaves: &[Aabb]| {
                let (mut flags, mut out) = (vec![0u32; internal], vec![0u32; words]);
                for leaf in 0..n {
                    refit_from_leaf(leaf, n, &nodes, &parents, leaves, &mut flags, &mut out);
                }
                out
            };
            let (mut flags, mut out_a, mut out_b) = (vec![0u32; internal], vec![0u32; words], vec![0u32; words]);
            for leaf in (0..n).rev() {
                refit_two_from_leaf(leaf, n, &nodes, &parents, (&a, &b), &mut flags, &mut out_a, &mut out_b);
            }
            assert_eq!(out_a, refit_one(&a), "{n} leaves: the first set");
            assert_eq!(out_b, refit_one(&b), "{n} leaves: the second set");
            for (leaves, out) in [(&a, &out_a), (&b, &out_b)] {
                let root = load_aabb(out, 0);
                let all = leaves.iter().copied().reduce(union).unwrap_or_default();
                assert_eq!((root.min, root.max), (all.min, all.max), "{n} leaves: the root");
            }
        }
    }
}
