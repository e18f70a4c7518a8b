//! Surface shaders: draw a cloth or a collider straight from vertex buffers laid out as drape's
//! (`R32G32B32A32_SFLOAT` positions and normals, stride 16). Not used by the simulation; they
//! are what a renderer (the embedding example, the CLI's pictures) binds.

use crate::pose::{rotate, to_world};
use drape_types::SurfacePush;
use drape_types::glam::{Vec3, Vec4, Vec4Swizzles};
#[cfg(target_arch = "spirv")]
use spirv_std::num_traits::Float;
use spirv_std::spirv;

/// Clip-space position of an object-space point.
#[inline]
pub fn surface_clip(push: &SurfacePush, position: Vec3) -> Vec4 {
    let world = to_world(&push.pose, position);
    let m = &push.view_projection;
    m[0] * world.x + m[1] * world.y + m[2] * world.z + m[3]
}

/// Two-sided Lambert shading with an ambient share: cloth is seen from both sides.
#[inline]
pub fn surface_shade(push: &SurfacePush, world_normal: Vec3) -> Vec4 {
    let length_squared = world_normal.length_squared();
    let facing = if length_squared > 0.0 {
        (world_normal.dot(push.light.xyz()) * (1.0 / length_squared.sqrt())).abs()
    } else {
        0.0
    };
    let ambient = push.color.w;
    let light = ambient + (1.0 - ambient) * facing;
    (push.color.xyz() * light).extend(1.0)
}

#[spirv(vertex)]
pub fn surface_vertex(
    position: Vec4,
    normal: Vec4,
    #[spirv(push_constant)] push: &SurfacePush,
    #[spirv(position)] clip: &mut Vec4,
    world_normal: &mut Vec3,
) {
    *clip = surface_clip(push, position.xyz());
    *world_normal = rotate(push.pose.rotation, normal.xyz());
}

#[spirv(fragment)]
pub fn surface_fragment(world_normal: Vec3, #[spirv(push_constant)] push: &SurfacePush, color: &mut Vec4) {
    *color = surface_shade(push, world_normal);
}
