//! The sphere leaf kind (the paper's voxel spheres: xyz centre, w radius): each sphere's box for
//! the LBVH build, the spheres gathered into the tree's leaf order, and the contact detect pass
//! over them (the generic traversal of `contact` with the sphere's hit test).
//!
//! A deforming collider's spheres (new ones each frame) sweep: each centre and radius moves
//! linearly from where the last frame left it to the new one over the frame's substeps, as a
//! deforming mesh's vertices do, so a sphere moving faster than its size per frame carries the
//! cloth instead of jumping through it, and one that swells pushes it out gradually.

use crate::contact::{LeafKind, point_in_aabb};
use drape_types::glam::{UVec3, Vec3, Vec4, Vec4Swizzles};
use drape_types::{Aabb, ColliderParams, SphereLeaf};
#[cfg(target_arch = "spirv")]
use spirv_std::num_traits::Float;
use spirv_std::spirv;

/// Bounds of a sphere (xyz centre, w radius).
#[inline]
pub fn sphere_aabb(s: Vec4) -> Aabb {
    let r = Vec3::splat(s.w);
    Aabb { min: (s.xyz() - r).extend(0.0), max: (s.xyz() + r).extend(0.0) }
}

/// Bounds of sphere `current` over a frame in which it swept there from `previous` (centre and
/// radius linearly): the balls between lie in the two ends' convex hull, so in their boxes'.
#[inline]
pub fn swept_sphere_aabb(previous: Vec4, current: Vec4) -> Aabb {
    let (start, end) = (sphere_aabb(previous), sphere_aabb(current));
    Aabb { min: start.min.min(end.min), max: start.max.max(end.max) }
}

/// Sphere `i` (input order) as a leaf: where the frame ends it, and how it moved and grew from
/// `previous` (equal spheres give a zero sweep).
#[inline]
pub fn sphere_leaf_at(i: usize, spheres: &[Vec4], previous: &[Vec4]) -> SphereLeaf {
    let sphere = spheres[i];
    SphereLeaf { sphere, sweep: sphere - previous[i] }
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
/// on the inflated sphere (radially out if it started inside). A sweeping sphere's tests see the
/// motion relative to it (`relative`).
pub struct Spheres;

impl LeafKind for Spheres {
    type Leaf = SphereLeaf;

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
    fn hit(leaf: SphereLeaf, p0: Vec3, p1: Vec3, thickness: f32) -> (f32, f32) {
        let sphere = leaf.sphere;
        let t = hit_parameter(p0, p1, sphere, thickness);
        let depth = if t > 1.0 { 0.0 } else { sphere.w + thickness - (p1 - sphere.xyz()).length() };
        (t, depth)
    }

    #[inline]
    fn surface(leaf: SphereLeaf, p0: Vec3, p1: Vec3, t: f32, thickness: f32) -> (Vec3, Vec3) {
        let c = leaf.sphere.xyz();
        let radius = leaf.sphere.w + thickness;
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

    /// The centre's motion over the frame (`relative` is then exact for the centre).
    #[inline]
    fn translation(leaf: SphereLeaf) -> Vec3 {
        leaf.sweep.xyz()
    }

    /// The motion over the frame of the surface point under `p` (where the frame ends): the
    /// centre's, and the radius's growth along the way out through `p`.
    #[inline]
    fn motion_at(leaves: &[SphereLeaf], _count: u32, leaf: u32, p: Vec3) -> Vec3 {
        let leaf = leaves[leaf as usize];
        let out = p - leaf.sphere.xyz();
        let len = out.length();
        let n = if len > 1e-12 { out * (1.0 / len) } else { Vec3::ZERO };
        leaf.sweep.xyz() + n * leaf.sweep.w
    }

    /// The radius when `left` of the frame is to come: the end's less the growth still to come.
    #[inline]
    fn at(leaf: SphereLeaf, left: f32) -> SphereLeaf {
        SphereLeaf { sphere: leaf.sphere.xyz().extend(leaf.sphere.w - leaf.sweep.w * left), sweep: leaf.sweep }
    }
}

/// `bounds[i]` = the box of sphere `i` (input order) over the frame, sweeping from `previous`
/// (`swept_sphere_aabb`).
#[spirv(compute(threads(256)))]
pub fn sphere_bounds(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] collider: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] spheres: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] previous: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] bounds: &mut [Aabb],
) {
    let i = id.x;
    if i < collider.leaf_count {
        bounds[i as usize] = swept_sphere_aabb(previous[i as usize], spheres[i as usize]);
    }
}

/// Puts the spheres in the tree's leaf order as leaves: `sorted[i]` = sphere `order[i]`
/// (`sphere_leaf_at`).
#[spirv(compute(threads(256)))]
pub fn gather_spheres(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] collider: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] spheres: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] previous: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] order: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] sorted: &mut [SphereLeaf],
) {
    let i = id.x;
    if i < collider.leaf_count {
        sorted[i as usize] = sphere_leaf_at(order[i as usize] as usize, spheres, previous);
    }
}

crate::contact::contact_entry_points!(Spheres, SphereLeaf);
