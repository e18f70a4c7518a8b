//! Rigid poses of colliders: quaternion rotation, world <-> collider frame, and interpolation
//! between a frame's start and end pose. Written out in scalar operations so the CPU twin and
//! the SPIR-V evaluate exactly the same arithmetic.

use drape_types::glam::{Vec3, Vec4, Vec4Swizzles};
use drape_types::{Aabb, ColliderPose, RigidPose};
#[cfg(target_arch = "spirv")]
use spirv_std::num_traits::Float;

/// `v` rotated by the unit quaternion `q`: v + 2w (u x v) + 2 u x (u x v), u = q.xyz.
#[inline]
pub fn rotate(q: Vec4, v: Vec3) -> Vec3 {
    let u = q.xyz();
    let t = u.cross(v) * 2.0;
    v + t * q.w + u.cross(t)
}

/// `v` rotated by the inverse of `q`.
#[inline]
pub fn rotate_inverse(q: Vec4, v: Vec3) -> Vec3 {
    rotate(Vec4::new(-q.x, -q.y, -q.z, q.w), v)
}

/// A world point in the collider's frame.
#[inline]
pub fn to_local(pose: &RigidPose, p: Vec3) -> Vec3 {
    rotate_inverse(pose.rotation, p - pose.translation.xyz())
}

/// A collider-frame point in the world.
#[inline]
pub fn to_world(pose: &RigidPose, p: Vec3) -> Vec3 {
    rotate(pose.rotation, p) + pose.translation.xyz()
}

/// The rows of the rotation matrix of the unit quaternion `q` (as `rotate` turns a vector),
/// each entry's magnitude: a box of half-extents `e` turned by `q` lies within `|R| e` of its
/// turned centre along each axis.
#[inline]
pub fn abs_rotation_rows(q: Vec4) -> [Vec3; 3] {
    let (x, y, z, w) = (q.x, q.y, q.z, q.w);
    [
        Vec3::new(1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - z * w), 2.0 * (x * z + y * w)).abs(),
        Vec3::new(2.0 * (x * y + z * w), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - x * w)).abs(),
        Vec3::new(2.0 * (x * z - y * w), 2.0 * (y * z + x * w), 1.0 - 2.0 * (x * x + y * y)).abs(),
    ]
}

/// How much wider than the exact turned box `posed_box` makes its box, relative to the size of
/// its coordinates: the matrix and `to_world`'s quaternion round differently (a few ulps
/// each), and the box must hold every point `to_world` places from the local box.
pub const POSED_BOX_SLACK: f32 = 1e-5;

/// A box holding every point of the collider-frame box `b` placed in the world by `pose`
/// (`abs_rows`: `abs_rotation_rows` of its rotation), as `to_world` computes them.
#[inline]
pub fn posed_box(pose: &RigidPose, abs_rows: &[Vec3; 3], b: &Aabb) -> (Vec3, Vec3) {
    let (lo, hi) = (b.min.xyz(), b.max.xyz());
    let centre = to_world(pose, (lo + hi) * 0.5);
    let half = (hi - lo) * 0.5;
    let turned = Vec3::new(abs_rows[0].dot(half), abs_rows[1].dot(half), abs_rows[2].dot(half));
    let slack = (centre.abs().max_element() + turned.max_element()) * POSED_BOX_SLACK + 1e-30;
    (centre - turned - Vec3::splat(slack), centre + turned + Vec3::splat(slack))
}

/// The pose a fraction `t` of the way through the frame: translation lerped, rotation
/// normalised-lerped (the host keeps both quaternions in one hemisphere). Exactly `previous`
/// at t <= 0 and `current` at t >= 1.
#[inline]
pub fn interpolate(pose: &ColliderPose, t: f32) -> RigidPose {
    if t <= 0.0 {
        return pose.previous;
    }
    if t >= 1.0 {
        return pose.current;
    }
    let (q0, q1) = (pose.previous.rotation, pose.current.rotation);
    let q = q0 + (q1 - q0) * t;
    let norm2 = q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w;
    let q = q * (1.0 / norm2.sqrt());
    let (t0, t1) = (pose.previous.translation, pose.current.translation);
    RigidPose { rotation: q, translation: t0 + (t1 - t0) * t }
}

/// The collider's poses at the start and end of one substep, the substep length (s), and its
/// span as fractions of the frame (what a deforming collider's leaves interpolate with).
#[derive(Copy, Clone)]
pub struct SubstepMotion {
    pub start: RigidPose,
    pub end: RigidPose,
    pub h: f32,
    pub from: f32,
    pub to: f32,
}

impl SubstepMotion {
    /// The motion over the substep spanning fractions `from..to` of the frame.
    #[inline]
    pub fn of(pose: &ColliderPose, from: f32, to: f32, h: f32) -> Self {
        SubstepMotion { start: interpolate(pose, from), end: interpolate(pose, to), h, from, to }
    }

    /// How much of the frame is left at the substep's start and end (what a leaf that moves
    /// over the frame still has to move).
    #[inline]
    pub fn left(&self) -> (f32, f32) {
        (1.0 - self.from, 1.0 - self.to)
    }

    /// Velocity of the collider's material point `local` over the substep (m/s).
    #[inline]
    pub fn velocity_at(&self, local: Vec3) -> Vec3 {
        (to_world(&self.end, local) - to_world(&self.start, local)) * (1.0 / self.h)
    }
}
