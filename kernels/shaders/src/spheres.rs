//! The sphere leaf kind (the paper's voxel spheres: xyz centre, w radius): each sphere's box for
//! the LBVH build, and the spheres gathered into the tree's leaf order for the traversal.

use crate::lbvh::gather_at;
use drape_types::glam::{UVec3, Vec3, Vec4, Vec4Swizzles};
use drape_types::{Aabb, ColliderParams};
use spirv_std::spirv;

/// Bounds of a sphere (xyz centre, w radius).
#[inline]
pub fn sphere_aabb(s: Vec4) -> Aabb {
    let r = Vec3::splat(s.w);
    Aabb { min: (s.xyz() - r).extend(0.0), max: (s.xyz() + r).extend(0.0) }
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
