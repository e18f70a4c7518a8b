//! Cloth-vs-collider contact (design.md §1): each particle walks the LBVH with a fixed-size
//! stack; at a sphere within radius + thickness it moves to the first hit of its substep's
//! motion p0 -> p1 with the inflated sphere (radially out if p0 was already inside) and keeps
//! only the tangential part of its velocity. A one-workgroup culling pass first tests the cloth's
//! swept bounds against the collider's root box and dispatches the traversal indirectly with
//! zero workgroups when they cannot touch.
//!
//! The LBVH lives in the collider's own frame. Each substep, a particle's start and end
//! positions are taken into that frame with the collider's pose at the substep's start and end
//! (interpolated from the frame's previous and current pose), so the test sees the motion
//! relative to the collider: a moving collider sweeps the cloth instead of jumping through it.
//! The response acts on the velocity relative to the collider's surface there. A static
//! collider (identity poses) gives exactly the frame-fixed test.

use crate::atomics;
use crate::pose::{SubstepMotion, rotate, rotate_inverse, to_local, to_world};
use drape_types::glam::{UVec3, Vec3, Vec4, Vec4Swizzles};
use drape_types::{
    Aabb, BvhNode, ColliderParams, ColliderPose, CollisionStatus, ContactPush, DispatchArgs, LEAF_BIT, SimParams,
};
#[cfg(target_arch = "spirv")]
use spirv_std::num_traits::Float;
use spirv_std::spirv;

/// Traversal stack entries per particle: the LBVH of 30-bit Morton codes is at most ~30 +
/// log2(N) deep, and each level pushes at most one node.
pub const STACK_SIZE: usize = 64;

/// The earliest contact found so far: hit parameter along p0 -> p1 (0 = p0 already inside),
/// how deep p1 is inside the inflated sphere, sphere index, and the sphere.
#[derive(Copy, Clone)]
pub struct Contact {
    pub t: f32,
    pub depth: f32,
    pub sphere_index: u32,
    pub sphere: Vec4,
}

/// No contact.
pub const NO_CONTACT: Contact = Contact { t: 2.0, depth: 0.0, sphere_index: u32::MAX, sphere: Vec4::ZERO };

/// Whether `p` is inside `b` grown by `margin`.
#[inline]
pub fn point_in_aabb(p: Vec3, b: &Aabb, margin: f32) -> bool {
    p.cmpge(b.min.xyz() - Vec3::splat(margin)).all() && p.cmple(b.max.xyz() + Vec3::splat(margin)).all()
}

/// If p1 lies within `sphere` inflated by `thickness`, the parameter in [0, 1] of the first
/// point of p0 -> p1 on the inflated sphere (0 when p0 is inside too); otherwise > 1.
#[inline]
pub fn hit_parameter(p0: Vec3, p1: Vec3, sphere: Vec4, thickness: f32) -> f32 {
    let c = sphere.xyz();
    let radius = sphere.w + thickness;
    let r2 = radius * radius;
    if (p1 - c).length_squared() >= r2 {
        return 2.0;
    }
    let from = p0 - c;
    let c0 = from.length_squared() - r2;
    if c0 <= 0.0 {
        return 0.0;
    }
    // |from + t d|^2 = r^2 has a root in (0, 1): p0 outside, p1 inside.
    let d = p1 - p0;
    let a = d.length_squared();
    let b = from.dot(d);
    let disc = (b * b - a * c0).max(0.0);
    let t = (-b - disc.sqrt()) * (1.0 / a.max(1e-30));
    t.clamp(0.0, 1.0)
}

/// Keeps the better of the best contact so far and sphere `sphere_index` (hit at `t`, see
/// `hit_parameter`): the earlier hit; among equal hits (typically t = 0, p0 already inside
/// several overlapping spheres) the shallowest, whose radial push-out moves the particle least
/// (pushing out of a deep sphere can push it through a thin part of the mesh); then the lower
/// index. A total order, so any visiting order gives the same answer: the BVH and the
/// brute-force loop agree exactly.
#[inline]
pub fn consider(best: Contact, p1: Vec3, t: f32, sphere_index: u32, sphere: Vec4, thickness: f32) -> Contact {
    if t > 1.0 {
        return best;
    }
    let depth = sphere.w + thickness - (p1 - sphere.xyz()).length();
    let better = t < best.t
        || (t == best.t && (depth < best.depth || (depth == best.depth && sphere_index < best.sphere_index)));
    if better { Contact { t, depth, sphere_index, sphere } } else { best }
}

/// Contact response: new position and velocity. The normal velocity into the surface is
/// removed (design.md §1); with `friction` > 0 the tangential velocity also loses up to
/// `friction` times the removed normal speed (Coulomb: it stops when that covers it).
pub fn respond(p0: Vec3, p1: Vec3, v: Vec3, contact: Contact, thickness: f32, friction: f32) -> (Vec3, Vec3) {
    let c = contact.sphere.xyz();
    let radius = contact.sphere.w + thickness;
    let (position, outward) = if contact.t <= 0.0 {
        // Started inside: push p1 radially onto the surface.
        let out = p1 - c;
        let len = out.length();
        let n = if len > 1e-12 { out * (1.0 / len) } else { Vec3::Y };
        (c + n * radius, n)
    } else {
        let hit = p0 + (p1 - p0) * contact.t;
        let out = hit - c;
        let len = out.length();
        let n = if len > 1e-12 { out * (1.0 / len) } else { Vec3::Y };
        (hit, n)
    };
    let into = v.dot(outward).min(0.0);
    let tangential = v - outward * v.dot(outward);
    let speed = tangential.length();
    let kept = if speed > 1e-12 { (1.0 - friction * -into * (1.0 / speed)).max(0.0) } else { 0.0 };
    let normal = outward * (v.dot(outward) - into);
    (position, normal + tangential * kept)
}

/// Earliest contact of p0 -> p1 with the LBVH's spheres. Returns it and whether the stack
/// overflowed (some subtrees were then not visited).
pub fn traverse(
    collider: &ColliderParams,
    nodes: &[BvhNode],
    aabbs: &[Aabb],
    spheres: &[Vec4],
    p0: Vec3,
    p1: Vec3,
) -> (Contact, bool) {
    let thickness = collider.thickness;
    let mut best = NO_CONTACT;
    if collider.leaf_count == 1 {
        let t = hit_parameter(p0, p1, spheres[0], thickness);
        return (consider(best, p1, t, 0, spheres[0], thickness), false);
    }
    let mut stack = [0u32; STACK_SIZE];
    let mut top = 1; // stack[0] = root
    let mut overflow = false;
    while top > 0 {
        top -= 1;
        let node = nodes[stack[top] as usize];
        let mut side = 0;
        while side < 2 {
            let child = if side == 0 { node.left } else { node.right };
            if child & LEAF_BIT != 0 {
                let leaf = child & !LEAF_BIT;
                let sphere = spheres[leaf as usize];
                best = consider(best, p1, hit_parameter(p0, p1, sphere, thickness), leaf, sphere, thickness);
            } else if point_in_aabb(p1, &aabbs[child as usize], thickness) {
                if top < STACK_SIZE {
                    stack[top] = child;
                    top += 1;
                } else {
                    overflow = true;
                }
            }
            side += 1;
        }
    }
    (best, overflow)
}

/// The same contact by testing every sphere (reference and benchmark baseline).
pub fn brute_force(collider: &ColliderParams, spheres: &[Vec4], p0: Vec3, p1: Vec3) -> Contact {
    let mut best = NO_CONTACT;
    let mut i = 0;
    while i < collider.leaf_count {
        let sphere = spheres[i as usize];
        best = consider(best, p1, hit_parameter(p0, p1, sphere, collider.thickness), i, sphere, collider.thickness);
        i += 1;
    }
    best
}

/// Applies `contact` (if any, found for the collider-frame motion `p0 -> p1`) to particle
/// `index`: the response acts in the collider's frame on the velocity relative to its surface.
#[inline]
pub fn apply_contact(
    index: u32,
    contact: Contact,
    collider: &ColliderParams,
    motion: &SubstepMotion,
    (p0, p1): (Vec3, Vec3),
    x: &mut [Vec4],
    v: &mut [Vec4],
) {
    let (thickness, friction) = (collider.thickness, collider.friction);
    let i = index as usize;
    if contact.t <= 1.0 {
        let surface = motion.velocity_at(p1);
        let relative = rotate_inverse(motion.end.rotation, v[i].xyz() - surface);
        let (position, velocity) = respond(p0, p1, relative, contact, thickness, friction);
        x[i] = to_world(&motion.end, position).extend(x[i].w);
        v[i] = (rotate(motion.end.rotation, velocity) + surface).extend(0.0);
    }
}

/// Particle `index`'s substep motion in the collider's frame (start, end).
#[inline]
pub fn local_motion(index: u32, motion: &SubstepMotion, x: &[Vec4], x_prev: &[Vec4]) -> (Vec3, Vec3) {
    let i = index as usize;
    (to_local(&motion.start, x_prev[i].xyz()), to_local(&motion.end, x[i].xyz()))
}

/// One particle's collision through the LBVH; returns whether its stack overflowed.
#[allow(clippy::too_many_arguments)]
pub fn collide_at(
    index: u32,
    collider: &ColliderParams,
    motion: &SubstepMotion,
    nodes: &[BvhNode],
    aabbs: &[Aabb],
    spheres: &[Vec4],
    x: &mut [Vec4],
    v: &mut [Vec4],
    x_prev: &[Vec4],
) -> bool {
    if x[index as usize].w == 0.0 {
        return false;
    }
    let (p0, p1) = local_motion(index, motion, x, x_prev);
    let (contact, overflow) = traverse(collider, nodes, aabbs, spheres, p0, p1);
    apply_contact(index, contact, collider, motion, (p0, p1), x, v);
    overflow
}

/// One particle's collision by testing every sphere.
#[allow(clippy::too_many_arguments)]
pub fn collide_brute_force_at(
    index: u32,
    collider: &ColliderParams,
    motion: &SubstepMotion,
    spheres: &[Vec4],
    x: &mut [Vec4],
    v: &mut [Vec4],
    x_prev: &[Vec4],
) {
    if x[index as usize].w == 0.0 {
        return;
    }
    let (p0, p1) = local_motion(index, motion, x, x_prev);
    let contact = brute_force(collider, spheres, p0, p1);
    apply_contact(index, contact, collider, motion, (p0, p1), x, v);
}

/// The collider's motion over the substep a contact pass runs in.
#[inline]
pub fn substep_motion(params: &SimParams, pose: &ColliderPose, push: &ContactPush) -> SubstepMotion {
    SubstepMotion::of(pose, push.from, push.to, params.substep)
}

#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(64)))]
pub fn collide(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] push: &ContactPush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &SimParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] collider: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] pose: &ColliderPose,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] nodes: &[BvhNode],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] aabbs: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] spheres: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] x: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] v: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] x_prev: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] status: &mut CollisionStatus,
) {
    if id.x >= params.particle_count {
        return;
    }
    let motion = substep_motion(params, pose, push);
    if collide_at(id.x, collider, &motion, nodes, aabbs, spheres, x, v, x_prev) {
        atomics::add(&mut status.overflows, 1);
    }
}

#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(64)))]
pub fn collide_brute_force(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] push: &ContactPush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &SimParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] collider: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] pose: &ColliderPose,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] spheres: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] x: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] v: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] x_prev: &[Vec4],
) {
    if id.x >= params.particle_count {
        return;
    }
    let motion = substep_motion(params, pose, push);
    collide_brute_force_at(id.x, collider, &motion, spheres, x, v, x_prev);
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

/// Threads per workgroup of `collide` and `collide_brute_force` (their `threads(64)`).
pub const COLLIDE_THREADS: u32 = 64;

/// Threads of the culling pass (one workgroup).
pub const CULL_THREADS: u32 = 256;

/// One workgroup: reduce the cloth's swept bounds in shared memory, test them against the
/// collider's root box, and write the traversal's indirect dispatch size (0 = skip).
#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(256)))]
pub fn cull_collision(
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
    let motion = substep_motion(params, pose, push);
    let own = swept_bounds(&motion, x, x_prev, params.particle_count, lane, CULL_THREADS);
    lows[lane as usize] = own.min;
    highs[lane as usize] = own.max;
    let mut stride = CULL_THREADS / 2;
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
    if lane == 0 {
        let cloth = Aabb { min: lows[0], max: highs[0] };
        let root = root_aabb(collider, aabbs, leaf_bounds);
        let run = aabbs_overlap(&cloth, &root, collider.thickness);
        *args = DispatchArgs {
            x: if run { params.particle_count.div_ceil(COLLIDE_THREADS) } else { 0 },
            y: 1,
            z: 1,
            _pad: 0,
        };
        if run {
            status.ran += 1;
        } else {
            status.skipped += 1;
        }
    }
}
