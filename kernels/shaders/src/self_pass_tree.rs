//! A self-collision pass's tree without a refit's climb from every leaf.
//!
//! A pass's walks (the triangles that left their predicted regions, a list that overflowed, a
//! collider's features from the cloth's side) need each internal node's box to hold the boxes
//! its leaves swept over the pass. Every triangle that did not escape has its corners within
//! their slops of their predicted paths at the pass's start and end, so its swept box lies in
//! what the lists' tree (the span's start boxes, grown by the slops, and motion boxes) bounds at
//! those two times: each internal node's box is that bound, computed on its own
//! (`pass_node_box`), no climb and no atomics. Only the escaped triangles' boxes may lie
//! outside it: each of them climbs to the root widening the boxes on its way
//! (`widen_to_leaf_at`, float min and max by compare-and-swap, which no order changes). A
//! refit climbs from all the leaves, two of them at every node through an atomic flag; here
//! only the few walkers climb.
//!
//! The walks find exactly the leaves they found in a refit tree: a node's box only decides
//! whether a walk enters it, and each holds the boxes of the leaves under it, while the walk
//! tests every leaf it reaches against the leaf's own swept box.

use crate::atomics;
use crate::lbvh::parent_slot;
use crate::self_pairs::{FALL_WORD, triangle_bounds_at};
use drape_types::glam::{UVec3, Vec3, Vec4, Vec4Swizzles};
use drape_types::{AABB_WORDS, Aabb, ColliderParams, DispatchArgs, LEAF_BIT, NO_NODE, SelfPassPush};
use spirv_std::spirv;

/// Rounding headroom of a node's bound, relative to its coordinates' size: the escape test and
/// the bound compute a predicted position in different orders of f32 operations (a few
/// units in the last place apart).
const ROUNDING_RELATIVE: f32 = 16.0 * f32::EPSILON;
/// And absolute (m), for coordinates near zero.
const ROUNDING_ABSOLUTE: f32 = 1e-6;

/// Internal node box over fractions `from..to` of the lists' span, from the node's box in the
/// lists' tree (`start`: its triangles' corners at the span's start grown by their slops) and
/// its motion box (`motion`: the corners' predicted motions over the span, gravity's share
/// left out), and gravity's share of every particle's path over the span (`fall`, at the
/// span's end; `t^2 fall` at fraction t). A corner within its slop of its predicted path
/// (`start + t motion + t^2 fall`) at fraction t lies in `start + t motion + t^2 fall` of the
/// boxes (t >= 0), so a triangle that kept to its region at the pass's start and end swept a
/// box (of its corners at those two times) inside the union of the two; one whose corners lie
/// up to `beyond` (m) past their slops, inside that union grown by `beyond`.
#[inline]
pub fn pass_node_box(start: &Aabb, motion: &Aabb, fall: Vec3, (from, to): (f32, f32), beyond: f32) -> Aabb {
    let (lo, hi) = (start.min.xyz() - Vec3::splat(beyond), start.max.xyz() + Vec3::splat(beyond));
    let (motion_lo, motion_hi) = (motion.min.xyz(), motion.max.xyz());
    let (fall_from, fall_to) = (fall * (from * from), fall * (to * to));
    let lo = (lo + motion_lo * from + fall_from).min(lo + motion_lo * to + fall_to);
    let hi = (hi + motion_hi * from + fall_from).max(hi + motion_hi * to + fall_to);
    let margin = lo.abs().max(hi.abs()) * ROUNDING_RELATIVE + Vec3::splat(ROUNDING_ABSOLUTE);
    Aabb { min: (lo - margin).extend(0.0), max: (hi + margin).extend(0.0) }
}

/// Internal node `i`'s box for the pass `span` (`pass_node_box`, past the slops by `span.beyond`
/// of the `thickness`), from the lists' tree kept apart from the passes' (`span_aabbs`,
/// `motion_aabbs`) and gravity's share of the span's paths (any particle's anchor: particle 0's).
#[inline]
pub fn pass_node_box_at(
    i: u32,
    (span, thickness): (&SelfPassPush, f32),
    (span_aabbs, motion_aabbs): (&[Aabb], &[Aabb]),
    anchors: &[Vec4],
    aabbs: &mut [Aabb],
) {
    let fall = anchors[FALL_WORD as usize].xyz();
    let beyond = span.beyond * thickness;
    let boxes = (&span_aabbs[i as usize], &motion_aabbs[i as usize]);
    aabbs[i as usize] = pass_node_box(boxes.0, boxes.1, fall, (span.from, span.to), beyond);
}

/// A walker's climb (sorted leaf `leaf`, which escaped its region in the pass): every internal
/// node above it widened to hold its swept box (`leaf_bounds`), through atomics, as
/// other walkers widen the same nodes.
#[inline]
pub fn widen_to_leaf_at(leaf: u32, leaf_count: u32, parents: &[u32], leaf_bounds: &[Aabb], words: &mut [u32]) {
    // A tree of one leaf has no internal node (and no parentless root to stop at).
    if leaf_count < 2 {
        return;
    }
    let b = leaf_bounds[leaf as usize];
    let (lo, hi) = (b.min.xyz(), b.max.xyz());
    let mut node = parents[parent_slot(leaf | LEAF_BIT, leaf_count) as usize];
    while node != NO_NODE {
        let base = (node * AABB_WORDS) as usize;
        atomics::min_f32(&mut words[base], lo.x);
        atomics::min_f32(&mut words[base + 1], lo.y);
        atomics::min_f32(&mut words[base + 2], lo.z);
        atomics::max_f32(&mut words[base + 4], hi.x);
        atomics::max_f32(&mut words[base + 5], hi.y);
        atomics::max_f32(&mut words[base + 6], hi.z);
        node = parents[node as usize];
    }
}

/// One thread per internal node of the cloth's tree (over the pass's refit dispatch): its box
/// for the pass (`pass_node_box_at`).
#[spirv(compute(threads(256)))]
pub fn derive_pass_tree(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] span: &SelfPassPush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] self_params: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] span_aabbs: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] motion_aabbs: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] anchors: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] aabbs: &mut [Aabb],
) {
    if id.x + 1 < self_params.leaf_count {
        pass_node_box_at(id.x, (span, self_params.thickness), (span_aabbs, motion_aabbs), anchors, aabbs);
    }
}

/// A pass's second run (after the collider's pushes, over their dispatch) in one dispatch: each
/// triangle's box and whether it walks (`self_pairs::triangle_bounds_at`), and each internal
/// node's box for the pass (`pass_node_box_at`, which reads only the lists' tree): the walkers'
/// climbs (`widen_pass_tree`) follow.
#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(256)))]
pub fn triangle_bounds_and_pass_tree(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] span: &SelfPassPush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] self_params: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] x: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] x_prev: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] indices: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] anchors: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] leaf_of: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] leaf_bounds: &mut [Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] escaped: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] strays: &mut [f32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] walkers: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] walk_args: &mut DispatchArgs,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] tree_every_pass: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 12)] pass_refit: &mut DispatchArgs,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 13)] span_aabbs: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 14)] motion_aabbs: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 15)] aabbs: &mut [Aabb],
) {
    let triangles = (x, x_prev, indices, anchors, leaf_of);
    let out = (leaf_bounds, escaped, strays, walkers, walk_args);
    triangle_bounds_at((id.x, span), self_params, triangles, out, (tree_every_pass[0], pass_refit));
    if id.x + 1 < self_params.leaf_count {
        pass_node_box_at(id.x, (span, self_params.thickness), (span_aabbs, motion_aabbs), anchors, aabbs);
    }
}

/// One thread per walker of the pass (`self_pairs::add_walker`'s dispatch): its climb
/// (`widen_to_leaf_at`), where the boxes were derived before it (`derived`, the derivation's
/// indirect dispatch: a pass's second run, after the collider's pushes, derives them only
/// where a push moved the cloth, and its walkers otherwise climbed already).
#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(64)))]
pub fn widen_pass_tree(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] self_params: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] parents: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] leaf_bounds: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] walkers: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] walk_args: &DispatchArgs,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] derived: &DispatchArgs,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] aabbs: &mut [u32],
) {
    if derived.x != 0 && id.x < walk_args._pad {
        widen_to_leaf_at(walkers[id.x as usize], self_params.leaf_count, parents, leaf_bounds, aabbs);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::self_failsafe::LIST_CHECK_BEYOND;
    use crate::self_pairs::{
        ANCHOR_WORDS, anchor_at, cloth_triangle_bounds_at, escaped_at, triangle_motion_at, triangle_start_at,
    };
    use drape_types::glam::UVec4;

    fn contains(outer: &Aabb, inner: &Aabb) -> bool {
        outer.min.xyz().cmple(inner.min.xyz()).all() && outer.max.xyz().cmpge(inner.max.xyz()).all()
    }

    /// A triangle that keeps to its predicted region at a pass's start and end sweeps a box
    /// inside its bound over the pass (`pass_node_box`), with the corners as far off their
    /// paths as the escape test lets them be (at most their slops, most of them right at
    /// them; for half the tries up to the fail-safe's `LIST_CHECK_BEYOND` of the thickness
    /// past them, which the bound takes as `beyond`), at coordinates up to 50 m from the
    /// origin (where f32 rounds coarsest), speeds up to 10 m/s and passes anywhere in the
    /// span. A bound without its rounding headroom lets some out (the test can fail), and a
    /// corner beyond its reach escapes.
    #[test]
    fn a_triangle_kept_to_its_region_sweeps_a_box_inside_the_pass_bound() {
        let mut next = crate::test_random::unit_floats(0x9E37_79B9_7F4A_7C15);
        let mut unit = || Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * 2.0;
        let g = Vec3::new(0.0, -9.81, 0.0);
        let indices = [0u32, 1, 2];
        let (mut kept, mut tight_escapes) = (0, 0);
        for k in 0..20_000 {
            let far = [0.0, 1.0, 50.0][k % 3];
            let centre = unit() * far;
            let size = 0.005 + 0.05 * unit().x.abs();
            let mut x = [Vec4::ZERO; 3];
            let mut v = [Vec4::ZERO; 3];
            for i in 0..3 {
                x[i] = (centre + unit() * size).extend(1.0);
                v[i] = (unit() * 10.0 * unit().x.abs()).extend(0.0);
            }
            let thickness = 0.001 + 0.02 * unit().x.abs();
            let frame_time = [1.0 / 60.0, 1.0 / 30.0, 1.0 / 240.0][k % 3];
            let mut anchors = [Vec4::ZERO; 3 * ANCHOR_WORDS as usize];
            for i in 0..3 {
                anchor_at(i, (&x, &v), (frame_time, g, thickness), &mut anchors);
            }
            let (a, b) = (unit().x.abs(), unit().x.abs());
            let (from, to) = (a.min(b), a.max(b));
            let beyond = if k % 2 == 0 { 0.0 } else { LIST_CHECK_BEYOND };
            let span = SelfPassPush { from, to, find_walkers: 0, beyond };
            let reach_past_slop = beyond * thickness;
            // Each corner at each end off its predicted path in a random direction (half of
            // them along an axis, where the box's face is the slop's reach), by a
            // random share of its slop or (about a third of them) by the slop scaled by 1 - 2e-6 to
            // 1 + 2e-6: either side of the escape test's edge.
            let placed = |t: f32, next: &mut dyn FnMut() -> Vec3| -> [Vec4; 3] {
                std::array::from_fn(|i| {
                    let base = ANCHOR_WORDS as usize * i;
                    let (start, motion, fall) =
                        (anchors[base].xyz(), anchors[base + 1].xyz(), anchors[base + FALL_WORD as usize].xyz());
                    let slop = anchors[base].w;
                    let path = start + motion * t + fall * (t * t);
                    let r = next();
                    let share = if r.x > 0.3 { 1.0 + 2e-6 * r.y } else { r.z.abs() };
                    let d = next();
                    let axis = [Vec3::X, Vec3::Y, Vec3::Z][((d.x + 1.0) * 1.5) as usize % 3] * d.y.signum();
                    let direction = if d.z > 0.0 { axis } else { d.normalize_or(Vec3::X) };
                    (path + direction * (slop + reach_past_slop) * share).extend(1.0)
                })
            };
            let (then, now) = (placed(from, &mut unit), placed(to, &mut unit));
            let (escaped, _) = escaped_at(0, (&now, &then), &anchors, &indices, (&span, reach_past_slop));
            if escaped {
                tight_escapes += 1;
                continue;
            }
            kept += 1;
            let swept = cloth_triangle_bounds_at(0, (&now, &then), &indices);
            let start = triangle_start_at(0, &anchors, &indices);
            let motion = triangle_motion_at(UVec4::new(0, 1, 2, 0), &anchors);
            let mut node = [Aabb::default()];
            pass_node_box_at(0, (&span, thickness), (&[start], &[motion]), &anchors, &mut node);
            assert!(contains(&node[0], &swept), "try {k}: {swept:?} outside {:?}", node[0]);
        }
        // Both sides of the edge were tried.
        assert!(kept > 4_000 && tight_escapes > 4_000, "kept {kept}, escaped {tight_escapes}");
    }

    /// The walkers' climbs widen every node above them to their boxes and no other, the
    /// union whatever the order they climb in.
    #[test]
    fn the_walkers_climbs_widen_their_ancestors_in_any_order() {
        // A tree of 4 leaves: root 0 over nodes 1 (leaves 0, 1) and 2 (leaves 2, 3).
        let n = 4;
        let mut parents = [NO_NODE; 7];
        parents[1] = 0;
        parents[2] = 0;
        parents[parent_slot(LEAF_BIT, n) as usize] = 1;
        parents[parent_slot(1 | LEAF_BIT, n) as usize] = 1;
        parents[parent_slot(2 | LEAF_BIT, n) as usize] = 2;
        parents[parent_slot(3 | LEAF_BIT, n) as usize] = 2;
        let cube = |lo: f32, hi: f32| Aabb { min: Vec3::splat(lo).extend(0.0), max: Vec3::splat(hi).extend(0.0) };
        let leaves = [cube(-3.0, -2.0), cube(0.0, 0.5), cube(4.0, 9.0), cube(0.2, 0.8)];
        let start = [cube(-0.5, 0.5), cube(-0.5, 0.5), cube(0.0, 1.0)];
        let climbed = |order: &[u32]| {
            let mut words: Vec<u32> = start
                .iter()
                .flat_map(|b| b.min.to_array().into_iter().chain(b.max.to_array()))
                .map(f32::to_bits)
                .collect();
            for &leaf in order {
                widen_to_leaf_at(leaf, n, &parents, &leaves, &mut words);
            }
            let word = |k: usize| f32::from_bits(words[k]);
            (0..3)
                .map(|i| {
                    let b = AABB_WORDS as usize * i;
                    let min = Vec4::new(word(b), word(b + 1), word(b + 2), word(b + 3));
                    Aabb { min, max: Vec4::new(word(b + 4), word(b + 5), word(b + 6), word(b + 7)) }
                })
                .collect::<Vec<_>>()
        };
        let once = climbed(&[0, 2]);
        assert_eq!(once, climbed(&[2, 0]));
        assert_eq!(once[1], cube(-3.0, 0.5), "node 1 holds leaf 0");
        assert_eq!(once[2], cube(0.0, 9.0), "node 2 holds leaf 2");
        assert_eq!(once[0], cube(-3.0, 9.0), "the root holds both");
        // A leaf already inside its ancestors changes nothing.
        assert_eq!(climbed(&[0, 2, 3, 1]), once);
        // A cloth of one triangle: no internal node, its parent slot left as the buffer holds
        // it (zero, which a climb would take for a node whose parent is itself).
        let mut words = [0u32; AABB_WORDS as usize];
        widen_to_leaf_at(0, 1, &[0], &leaves[..1], &mut words);
        assert_eq!(words, [0; AABB_WORDS as usize]);
    }
}
