//! Which of a triangle collider's triangles have a feature sharp enough to test against a
//! self-colliding cloth in this frame (`self_contact::collider_feature_contact_at`), listed once
//! at the frame's start so each pass dispatches over those alone.
//!
//! A pass measures each collider triangle's folds and keeps the vertices and edges sharp for
//! the cloth's longest edge (`self_contact::sharp_for`); on a smooth scan (the bunny's 69674
//! triangles) few are, yet every pass ran a thread per triangle to find that out, most of its
//! time. A rigid collider's folds do not change with its pose (rotation and translation keep
//! angles), and the cloth's longest edge is measured once per frame, so a triangle with no sharp
//! feature at the frame's start has none in any pass of it. The list is conservative: folds
//! measured here in the collider's own frame count as sharp from `SHARP_MARGIN` of the pass's
//! threshold (a pass measures them after its pose, rounded differently), and a triangle any of
//! whose vertices (or its neighbours' apexes) deform in the frame is always listed. Each listed
//! triangle's pass still applies the exact test, so the pairs are those the full dispatch found.

use crate::atomics;
use crate::contact::CONTACT_THREADS;
use crate::self_contact::{
    CURLED_BIT, FOLDED_SHUT, NO_NEIGHBOUR, OWNED_FEATURE_BITS, fold, grown_longest_edge2, sharp_features,
    tested_features,
};
use drape_types::glam::{UVec3, UVec4, Vec3, Vec4, Vec4Swizzles};
use drape_types::{ColliderParams, ColliderPose, DispatchArgs};
use spirv_std::spirv;

/// How much flatter than a pass's threshold a fold measured here may be and still list its
/// triangle (the fold is scaled by this before the test).
pub const SHARP_MARGIN: f32 = 1.25;

/// Whether collider vertex `i` deforms in the frame (its position at the frame's end differs
/// from its start).
#[inline]
fn deforms(i: u32, (vertices, previous): (&[Vec4], &[Vec4])) -> bool {
    vertices[i as usize].xyz() != previous[i as usize].xyz()
}

/// The fold at edge `k` of the triangle `corners` (its neighbour across the edge has apex
/// `across`), in the collider's frame at the frame's end.
#[inline]
fn local_fold(k: usize, corners: [Vec3; 3], across: u32, vertices: &[Vec4]) -> f32 {
    if across == NO_NEIGHBOUR {
        return FOLDED_SHUT;
    }
    fold(corners[k], corners[(k + 1) % 3], corners[(k + 2) % 3], vertices[across as usize].xyz())
}

/// Whether collider triangle `triangle` (`feature`: its neighbours' apexes and owned bits, as
/// `collider_feature_contact_at` takes) may have a feature sharp for a cloth whose longest
/// squared edge at the frame's start is `longest2` at `thickness`, in some pass of the frame
/// (always where the surface wraps round it: `CURLED_BIT`).
#[inline]
pub fn may_be_sharp(
    triangle: u32,
    feature: UVec4,
    (vertices, previous, indices): (&[Vec4], &[Vec4], &[u32]),
    longest2: f32,
    thickness: f32,
) -> bool {
    let folds = triangle_folds(triangle, feature, (vertices, indices));
    let deforming = deforms_around(triangle, feature, (vertices, previous, indices));
    listed_with(feature, folds, deforming, (longest2, thickness))
}

/// The list's answer for a triangle of `feature` folded by `folds` (`may_be_sharp`): none
/// owned, no; curled round or deforming in the frame, yes; else whether a feature is sharp
/// from `SHARP_MARGIN` of the threshold.
#[inline]
fn listed_with(feature: UVec4, folds: Vec3, deforming: bool, threshold: (f32, f32)) -> bool {
    let owned = feature.w & OWNED_FEATURE_BITS;
    if owned == 0 {
        return false;
    }
    if feature.w & CURLED_BIT != 0 || deforming {
        return true;
    }
    sharp_features(owned, folds, threshold, SHARP_MARGIN) != 0
}

/// `may_be_sharp` through the triangle's cached folds (`folds[triangle]`: its edges' folds in
/// xyz, w 1 once measured), the same answer: measured anew and cached when the frame's start
/// wrote the collider's vertices (`reshaped`) or never yet, else read from the cache. A
/// collider's folds change only where its vertices are written (a pose turns and moves it
/// whole), and measuring them was most of the list's time on a scan: 7.3 ms a frame over the
/// dragon's 202,520 triangles, each loading its own and its neighbours' six vertices twice.
#[inline]
pub fn may_be_sharp_cached(
    triangle: u32,
    feature: UVec4,
    (vertices, previous, indices): (&[Vec4], &[Vec4], &[u32]),
    (longest2, thickness): (f32, f32),
    (folds, reshaped): (&mut [Vec4], bool),
) -> bool {
    let cached = folds[triangle as usize];
    let fresh = reshaped || cached.w == 0.0;
    let measured = if fresh { triangle_folds(triangle, feature, (vertices, indices)) } else { cached.xyz() };
    if fresh {
        folds[triangle as usize] = measured.extend(1.0);
    }
    // Without a write of the vertices nothing deforms in the frame.
    let deforming = fresh && deforms_around(triangle, feature, (vertices, previous, indices));
    listed_with(feature, measured, deforming, (longest2, thickness))
}

/// Whether any vertex of collider triangle `triangle`, or any of its neighbours' apexes,
/// deforms in the frame.
#[inline]
fn deforms_around(triangle: u32, feature: UVec4, (vertices, previous, indices): (&[Vec4], &[Vec4], &[u32])) -> bool {
    let i = 3 * triangle as usize;
    let mesh = (vertices, previous);
    let mut moving = deforms(indices[i], mesh) || deforms(indices[i + 1], mesh) || deforms(indices[i + 2], mesh);
    let across = [feature.x, feature.y, feature.z];
    let mut k = 0;
    while k < 3 {
        moving = moving || (across[k] != NO_NEIGHBOUR && deforms(across[k], mesh));
        k += 1;
    }
    moving
}

/// Collider triangle `triangle`'s folds at its three edges (`local_fold`), in the collider's
/// frame at the frame's end.
#[inline]
fn triangle_folds(triangle: u32, feature: UVec4, (vertices, indices): (&[Vec4], &[u32])) -> Vec3 {
    let i = 3 * triangle as usize;
    let ids = [indices[i], indices[i + 1], indices[i + 2]];
    let corners = [vertices[ids[0] as usize].xyz(), vertices[ids[1] as usize].xyz(), vertices[ids[2] as usize].xyz()];
    Vec3::new(
        local_fold(0, corners, feature.x, vertices),
        local_fold(1, corners, feature.y, vertices),
        local_fold(2, corners, feature.z, vertices),
    )
}

/// Whether the frame's start wrote the collider's vertices (`ColliderPose::sweep`'s y).
#[inline]
pub fn reshaped(pose: &ColliderPose) -> bool {
    pose.sweep.y != 0.0
}

/// Appends collider triangle `triangle` to the frame's list; the passes' indirect dispatch covers
/// the list (`args`: x workgroups of `CONTACT_THREADS`, the count in `_pad`; the host writes
/// {0, 1, 1, 0} before). The order is the atomics', which changes no result: the passes sum
/// their corrections as integers and take their pushes' maxima. The passes' features then walk
/// the cloth's tree, so every pass refits it: the first triangle listed raises
/// `tree_every_pass` (`self_pairs::note_pass_tree`), the others leave the word alone.
#[inline]
pub fn list_sharp(triangle: u32, list: &mut [u32], args: &mut DispatchArgs, tree_every_pass: &mut u32) {
    if atomics::append_for_dispatch(triangle, list, args, CONTACT_THREADS) == 0 {
        atomics::max(tree_every_pass, 1);
    }
}

/// The cloth's longest squared edge as the passes take it (`self_scene_bounds` measured it at
/// the frame's start), and the collider's contact thickness.
#[inline]
pub fn frame_threshold(self_params: &ColliderParams, collider: &ColliderParams) -> (f32, f32) {
    (grown_longest_edge2(self_params), collider.thickness)
}

#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(256)))]
pub fn list_sharp_features(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] self_params: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] collider: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] vertices: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] previous: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] indices: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] features: &[UVec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] sharp: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] sharp_args: &mut DispatchArgs,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] tree_every_pass: &mut u32,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] listed: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] pose: &ColliderPose,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] folds: &mut [Vec4],
) {
    if id.x as usize >= features.len() {
        return;
    }
    let threshold = frame_threshold(self_params, collider);
    let mesh = (vertices, previous, indices);
    let feature = tested_features(features[id.x as usize], collider);
    let sharp_here = may_be_sharp_cached(id.x, feature, mesh, threshold, (folds, reshaped(pose)));
    if sharp_here {
        list_sharp(id.x, sharp, sharp_args, tree_every_pass);
    }
    // Every triangle's flag, each frame (the cloth's side of the passes looks them up:
    // `feature_walks`).
    listed[id.x as usize] = sharp_here as u32;
}
