//! The sphere leaf kind (the paper's voxel spheres: xyz centre, w radius): each sphere's box for
//! the LBVH build, the spheres gathered into the tree's leaf order, and the contact detect pass
//! over them (the generic traversal of `contact` with the sphere's hit test).

use crate::contact::{LeafKind, point_in_aabb};
use crate::lbvh::gather_at;
use drape_types::glam::{UVec3, Vec3, Vec4, Vec4Swizzles};
use drape_types::{Aabb, ColliderParams};
#[cfg(target_arch = "spirv")]
use spirv_std::num_traits::Float;
use spirv_std::spirv;

/// Bounds of a sphere (xyz centre, w radius).
#[inline]
pub fn sphere_aabb(s: Vec4) -> Aabb {
    let r = Vec3::splat(s.w);
    Aabb { min: (s.xyz() - r).extend(0.0), max: (s.xyz() + r).extend(0.0) }
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

/// Spheres as contact leaves: a particle is in contact when its substep motion ends within
/// radius + thickness of a centre (the paper's test), and goes to the first point of its motion
/// on the inflated sphere (radially out if it started inside).
pub struct Spheres;

impl LeafKind for Spheres {
    type Leaf = Vec4;

    /// Only the motion's end point counts, so a subtree matters when its grown box holds it.
    #[inline]
    fn may_touch(b: &Aabb, _p0: Vec3, p1: Vec3, thickness: f32) -> bool {
        point_in_aabb(p1, b, thickness)
    }

    /// The motion's end is in the region, so it can be in `b` grown by the thickness only if
    /// the region meets that box (the same sums as `point_in_aabb`, on the region's far sides).
    #[inline]
    fn may_touch_region(b: &Aabb, region: &Aabb, thickness: f32) -> bool {
        let m = Vec3::splat(thickness);
        region.max.xyz().cmpge(b.min.xyz() - m).all() && region.min.xyz().cmple(b.max.xyz() + m).all()
    }

    /// Key: how deep the motion ends inside. Among equal hits (typically p0 already inside
    /// several overlapping spheres) the shallowest wins, whose radial push-out moves the
    /// particle least (pushing out of a deep sphere can push it through a thin part of the mesh).
    #[inline]
    fn hit(sphere: Vec4, p0: Vec3, p1: Vec3, thickness: f32) -> (f32, f32) {
        let t = hit_parameter(p0, p1, sphere, thickness);
        let depth = if t > 1.0 { 0.0 } else { sphere.w + thickness - (p1 - sphere.xyz()).length() };
        (t, depth)
    }

    #[inline]
    fn surface(sphere: Vec4, p0: Vec3, p1: Vec3, t: f32, thickness: f32) -> (Vec3, Vec3) {
        let c = sphere.xyz();
        let radius = sphere.w + thickness;
        if t <= 0.0 {
            // Started inside: push p1 radially onto the surface.
            let out = p1 - c;
            let len = out.length();
            let n = if len > 1e-12 { out * (1.0 / len) } else { Vec3::Y };
            (c + n * radius, n)
        } else {
            let hit = p0 + (p1 - p0) * t;
            let out = hit - c;
            let len = out.length();
            let n = if len > 1e-12 { out * (1.0 / len) } else { Vec3::Y };
            (hit, n)
        }
    }
}

/// `bounds[i]` = the box of sphere `i` (input order).
#[spirv(compute(threads(256)))]
pub fn sphere_bounds(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] collider: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] spheres: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] bounds: &mut [Aabb],
) {
    let i = id.x;
    if i < collider.leaf_count {
        bounds[i as usize] = sphere_aabb(spheres[i as usize]);
    }
}

/// Puts the spheres in the tree's leaf order: `sorted[i] = spheres[order[i]]`.
#[spirv(compute(threads(256)))]
pub fn gather_spheres(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] collider: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] spheres: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] order: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] sorted: &mut [Vec4],
) {
    let i = id.x;
    if i < collider.leaf_count {
        gather_at(i, spheres, order, sorted);
    }
}

crate::contact::contact_entry_points!(Spheres, Vec4);
