//! A flat binary BVH over axis-aligned boxes (binned SAH, leaves of up to 4 primitives), shared
//! by the triangle queries and the sphere queries of the metrics.

use glam::Vec3;

/// Leaves hold at most this many primitives.
const LEAF_SIZE: usize = 4;
/// SAH candidate planes per axis: `BINS - 1`.
const BINS: usize = 16;
/// Below this depth nodes are split at the object median instead of by SAH, which halves the
/// count: however the centroids are spread, the tree is at most ~40 + 32 levels deep.
const SAH_DEPTH_LIMIT: u32 = 40;

/// One node; the root is `nodes[0]`.
#[derive(Clone, Copy, Debug)]
pub(super) struct Node {
    pub min: Vec3,
    pub max: Vec3,
    /// Interior node: index of the left child (the right child follows it). Leaf: index of its
    /// first primitive in `Bvh::order`.
    pub first: u32,
    /// Primitives in a leaf; 0 for an interior node.
    pub count: u32,
}

impl Node {
    /// Squared distance from `p` to the box (0 inside).
    pub fn distance_squared(&self, p: Vec3) -> f32 {
        (self.min - p).max(p - self.max).max(Vec3::ZERO).length_squared()
    }
}

pub(super) struct Bvh {
    pub nodes: Vec<Node>,
    /// Primitive indices in leaf order: a leaf holds `order[first..first + count]`.
    pub order: Vec<u32>,
}

impl Bvh {
    /// Calls `visit` with every primitive whose box meets the closed box `lo..=hi`.
    pub fn for_each_overlapping(&self, lo: Vec3, hi: Vec3, boxes: &[(Vec3, Vec3)], mut visit: impl FnMut(u32)) {
        if self.nodes.is_empty() {
            return;
        }
        let meets = |min: Vec3, max: Vec3| min.cmple(hi).all() && max.cmpge(lo).all();
        let mut stack = vec![0usize];
        while let Some(n) = stack.pop() {
            let node = self.nodes[n];
            if !meets(node.min, node.max) {
                continue;
            }
            if node.count == 0 {
                stack.extend([node.first as usize, node.first as usize + 1]);
                continue;
            }
            for &i in &self.order[node.first as usize..(node.first + node.count) as usize] {
                let (min, max) = boxes[i as usize];
                if meets(min, max) {
                    visit(i);
                }
            }
        }
    }
}

/// Builds the tree over the boxes `(min, max)` of the primitives.
pub(super) fn build(boxes: &[(Vec3, Vec3)]) -> Bvh {
    let mut order: Vec<u32> = (0..boxes.len() as u32).collect();
    if boxes.is_empty() {
        return Bvh { nodes: Vec::new(), order };
    }
    let centroids: Vec<Vec3> = boxes.iter().map(|&(min, max)| (min + max) * 0.5).collect();
    let empty = Node { min: Vec3::ZERO, max: Vec3::ZERO, first: 0, count: 0 };
    let mut nodes = Vec::with_capacity(2 * boxes.len() / LEAF_SIZE + 1);
    nodes.push(empty);
    // (node, first primitive, end, depth): explicit stack, so no recursion depth to worry about.
    let mut todo = vec![(0usize, 0usize, boxes.len(), 0u32)];
    while let Some((node, start, end, depth)) = todo.pop() {
        let ids = &mut order[start..end];
        let (mut min, mut max) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        let (mut cmin, mut cmax) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for &i in ids.iter() {
            let (lo, hi) = boxes[i as usize];
            (min, max) = (min.min(lo), max.max(hi));
            let c = centroids[i as usize];
            (cmin, cmax) = (cmin.min(c), cmax.max(c));
        }
        nodes[node].min = min;
        nodes[node].max = max;
        if ids.len() <= LEAF_SIZE {
            nodes[node].first = start as u32;
            nodes[node].count = ids.len() as u32;
            continue;
        }
        let mid = split(ids, boxes, &centroids, cmin, cmax, depth);
        let left = nodes.len();
        nodes.push(empty);
        nodes.push(empty);
        nodes[node].first = left as u32;
        todo.push((left, start, start + mid, depth + 1));
        todo.push((left + 1, start + mid, end, depth + 1));
    }
    Bvh { nodes, order }
}

/// Reorders `ids` into a left and a right part and returns the size of the left one (never 0
/// and never all of them).
fn split(ids: &mut [u32], boxes: &[(Vec3, Vec3)], centroids: &[Vec3], cmin: Vec3, cmax: Vec3, depth: u32) -> usize {
    let extent = cmax - cmin;
    let half = ids.len() / 2;
    if extent.max_element() <= 0.0 {
        // All centroids coincide: any split is as good as another.
        return half;
    }
    let longest = if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    };
    if depth < SAH_DEPTH_LIMIT
        && let Some((axis, plane)) = best_sah_plane(ids, boxes, centroids, cmin, extent)
    {
        let scale = BINS as f32 / extent[axis];
        let bin = |c: Vec3| (((c[axis] - cmin[axis]) * scale) as usize).min(BINS - 1);
        let mid = partition(ids, |i| bin(centroids[i as usize]) <= plane);
        if mid > 0 && mid < ids.len() {
            return mid;
        }
    }
    ids.select_nth_unstable_by(half, |&a, &b| {
        centroids[a as usize][longest].total_cmp(&centroids[b as usize][longest])
    });
    half
}

/// The (axis, last bin on the left) of least SAH cost `area(left) * n(left) + area(right) * n(right)`.
fn best_sah_plane(
    ids: &[u32],
    boxes: &[(Vec3, Vec3)],
    centroids: &[Vec3],
    cmin: Vec3,
    extent: Vec3,
) -> Option<(usize, usize)> {
    let mut best: Option<(f32, usize, usize)> = None;
    for axis in 0..3 {
        if extent[axis] <= 0.0 {
            continue;
        }
        let scale = BINS as f32 / extent[axis];
        let mut counts = [0usize; BINS];
        let mut bounds = [(Vec3::INFINITY, Vec3::NEG_INFINITY); BINS];
        for &i in ids {
            let b = (((centroids[i as usize][axis] - cmin[axis]) * scale) as usize).min(BINS - 1);
            counts[b] += 1;
            let (lo, hi) = boxes[i as usize];
            bounds[b] = (bounds[b].0.min(lo), bounds[b].1.max(hi));
        }
        // Sweep from the right: cost of everything right of each plane.
        let mut right_cost = [0.0f32; BINS];
        let (mut acc, mut n) = ((Vec3::INFINITY, Vec3::NEG_INFINITY), 0usize);
        for b in (1..BINS).rev() {
            acc = (acc.0.min(bounds[b].0), acc.1.max(bounds[b].1));
            n += counts[b];
            right_cost[b - 1] = if n > 0 { half_area(acc) * n as f32 } else { f32::INFINITY };
        }
        let (mut acc, mut n) = ((Vec3::INFINITY, Vec3::NEG_INFINITY), 0usize);
        for plane in 0..BINS - 1 {
            acc = (acc.0.min(bounds[plane].0), acc.1.max(bounds[plane].1));
            n += counts[plane];
            if n == 0 || n == ids.len() {
                continue;
            }
            let cost = half_area(acc) * n as f32 + right_cost[plane];
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, plane));
            }
        }
    }
    best.map(|(_, axis, plane)| (axis, plane))
}

fn half_area((min, max): (Vec3, Vec3)) -> f32 {
    let e = (max - min).max(Vec3::ZERO);
    e.x * e.y + e.y * e.z + e.z * e.x
}

/// Moves the ids for which `left` holds to the front; returns how many there are.
fn partition(ids: &mut [u32], left: impl Fn(u32) -> bool) -> usize {
    let (mut i, mut j) = (0, ids.len());
    while i < j {
        if left(ids[i]) {
            i += 1;
        } else {
            j -= 1;
            ids.swap(i, j);
        }
    }
    i
}
