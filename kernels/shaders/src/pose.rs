//! Rigid poses of colliders: quaternion rotation, world <-> collider frame, and interpolation
//! between a frame's start and end pose. Written out in scalar operations so the CPU twin and
//! the SPIR-V evaluate exactly the same arithmetic.

use drape_types::glam::{Vec3, Vec4, Vec4Swizzles};
use drape_types::{ColliderPose, RigidPose};
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
