//! The fixed camera of a picture: in front of and above a box, the whole box in view.

use glam::{Mat4, Vec3};

/// World -> clip (Vulkan: y down, depth 0..1) and where the camera stands.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Camera {
    pub view_projection: Mat4,
    pub eye: Vec3,
    pub target: Vec3,
}

/// Vertical field of view.
const FOV_Y_DEGREES: f32 = 35.0;
/// Where the camera looks from, relative to the box's centre (front, above, a little right):
/// a cloth lying on a collider shows its folds, a hanging one its face.
const VIEW_DIRECTION: Vec3 = Vec3::new(0.35, 0.55, 1.0);

impl Camera {
    /// A perspective camera looking at `target` from `eye`, `aspect` = width / height.
    pub fn look_at(eye: Vec3, target: Vec3, aspect: f32, near: f32, far: f32) -> Camera {
        use glam::camera::rh::{proj::vulkan, view::look_at_mat4};
        let view = look_at_mat4(eye, target, Vec3::Y);
        let projection = vulkan::perspective(FOV_Y_DEGREES.to_radians(), aspect, near, far);
        Camera { view_projection: projection * view, eye, target }
    }

    /// Frames the box `lo..hi` from the fixed direction: the nearest distance at which all
    /// eight corners are inside the field of view, plus a 5% margin; near and far planes hug
    /// the box (depth precision where the surfaces are).
    pub fn framing(lo: Vec3, hi: Vec3, aspect: f32) -> Camera {
        let target = 0.5 * (lo + hi);
        let back = VIEW_DIRECTION.normalize();
        let right = Vec3::Y.cross(back).normalize();
        let up = back.cross(right);
        let tan_y = (0.5 * FOV_Y_DEGREES.to_radians()).tan();
        let tan_x = tan_y * aspect.max(1e-3);
        let half = (0.5 * (hi - lo)).max(Vec3::splat(1e-3));
        let corners = (0..8).map(|i| {
            let sign = Vec3::new(
                if i & 1 == 0 { -1.0 } else { 1.0 },
                if i & 2 == 0 { -1.0 } else { 1.0 },
                if i & 4 == 0 { -1.0 } else { 1.0 },
            );
            sign * half
        });
        // A corner at offset c is in view from distance D when |c.right| <= (D - c.back) tan_x
        // and |c.up| <= (D - c.back) tan_y.
        let distance = corners
            .map(|c| c.dot(back) + (c.dot(right).abs() / tan_x).max(c.dot(up).abs() / tan_y))
            .fold(0.0f32, f32::max)
            * 1.05;
        let radius = half.length();
        let eye = target + distance * back;
        let near = (distance - 1.5 * radius).max(0.01 * distance);
        Camera::look_at(eye, target, aspect, near, distance + 1.5 * radius)
    }
}

/// The box a picture of a scene frames: the cloth's box, where a pinned cloth can swing down to
/// (one cloth width below its top), and each collider's box clipped sideways to the cloth's
/// reach (half its size around it), so a wide ground does not shrink the cloth to a speck; a
/// collider below the cloth is framed whole (the body a garment falls on).
pub fn scene_box(cloth: &[glam::Vec4], colliders: &[(Vec3, Vec3)]) -> (Vec3, Vec3) {
    let (mut lo, mut hi) = cloth
        .iter()
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| (lo.min(p.truncate()), hi.max(p.truncate())));
    if lo.cmpgt(hi).any() {
        (lo, hi) = (Vec3::ZERO, Vec3::ZERO);
    }
    let size = (hi - lo).max_element().max(0.1);
    if cloth.iter().any(|p| p.w == 0.0) {
        lo.y = lo.y.min(hi.y - size);
    }
    let reach_lo = lo - Vec3::new(0.5 * size, f32::INFINITY, 0.5 * size);
    let reach_hi = hi + Vec3::new(0.5 * size, 0.0, 0.5 * size);
    let (mut out_lo, mut out_hi) = (lo, hi);
    for &(c_lo, c_hi) in colliders {
        let (clipped_lo, clipped_hi) = (c_lo.max(reach_lo), c_hi.min(reach_hi));
        if clipped_lo.cmple(clipped_hi).all() {
            out_lo = out_lo.min(clipped_lo);
            out_hi = out_hi.max(clipped_hi);
        }
    }
    (out_lo, out_hi)
}
