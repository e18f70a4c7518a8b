//! Self-collision of a cloth (issue 8): an LBVH over the cloth's own triangles (built by the
//! generic builder once per frame over each triangle's region over the frame, which lists each
//! triangle's pairs for the frame (`self_pairs`); refit at each pass to the triangles swept
//! since the last), and in each self-collision pass, after the collider's response:
//! - **vertex against triangle**: every particle finds the triangles (not its own) within the
//!   thickness, or that it crossed since the last pass;
//! - **edge against edge**: every edge finds the edges (sharing no particle) of the triangles
//!   near it, each pair once, within the thickness or crossed;
//!
//! both per triangle, from the frame's list of its pairs or, for a triangle that left its
//! predicted region or whose list is full, from a walk of the tree (`self_triangle_contact_at`;
//! `self_pairs` says which): each particle and each edge is owned by the first triangle that
//! has it, and each pair of triangles whose boxes (swept over the pass, grown by the thickness)
//! meet is handled once, from the earlier of the two in the tree's leaf order, in both
//! directions (`triangle_pair`, over the primitive pairs `pair_mask` names): the walk enters no
//! subtree that ends before it (`PairWalk`), hands its leaves over in batches (so the pair tests
//! do not run masked inside the walk's loop on lockstep lanes), and each pair loads the two
//! triangles' corners once; every test first checks its primitives' swept boxes;
//! - **collider features against the cloth**: every collider triangle, moving (and deforming)
//!   with the collider, walks the cloth's tree with its swept box (one much larger than the
//!   cloth's edges, once per sharp feature with that feature's box); the vertices it owns are
//!   tested against the cloth triangles' faces and the edges it owns against their edges (each
//!   collider vertex and edge belongs to one of its triangles, like the cloth's), so neither a
//!   spike's tip nor a ridge can pass through a cloth cell between particles (the collider does
//!   not move; the cloth takes the whole correction);
//!
//! and each pair is pushed apart to the thickness along the direction it was apart at the
//! pass's start (the face normal, to the particle's starting side, for vertex-triangle),
//! split by pin weight (position-based dynamics). A pass sweeps from `start`: the positions the
//! last pass left (or the frame's start, copied by `self_scene_bounds`), so passes may be
//! spaced several substeps apart (the host runs as many per frame as the cloth's motion needs
//! to move at most the thickness between two, and at least the last substep's). In the kernels
//! below, `x_prev` is that start. The corrections are summed as fixed-point
//! integers, so the order in which threads add them does not change the result: a run repeats
//! bit for bit, and the CPU twin equals it. Each pair that touches also slows its sliding by
//! Coulomb friction between the layers (`pair_friction`, velocity changes summed the same way).
//! Each particle then changes its velocity by the mean of its friction, moves by the mean of its
//! corrections (`correction_of`: weighted by their lengths, or of those that undo a crossing
//! alone) and loses the velocity that drove it into the contact (inelastic).
//!
//! Not yet: continuous collision of moving triangles beyond this start-side test (a pair that passes
//! through each other within one pass and ends farther apart than the search reach is
//! missed).

use crate::WORKGROUP_SIZE;
use crate::atomics;
use crate::contact::{reduce_bounds, substep_motion};
use crate::lbvh::{PairWalk, WALK_BATCH, box_meets};
use crate::pose::{SubstepMotion, to_world};
use crate::self_pairs::{anchor_particles, triangle_motion_at};
use crate::tiles::wake_particle;
/// The triangles' closest point with its weights lives with the triangle leaves; kept here by
/// name for the pair tests and the host that import it from this module.
pub use crate::triangles::closest_with_weights;
use drape_types::glam::{UVec3, UVec4, Vec3, Vec4, Vec4Swizzles};
use drape_types::{
    Aabb, BvhNode, ColliderParams, ColliderPose, ContactPush, DispatchArgs, Health, SelfAnchorPush, SimParams,
};
#[cfg(target_arch = "spirv")]
use spirv_std::num_traits::Float;
use spirv_std::spirv;

/// Fixed-point scale of the summed corrections: 2^24 units per metre (resolution 6e-8 m,
/// range +-128 m per particle and substep).
pub const FIXED_SCALE: f32 = 16_777_216.0;

/// One workgroup: the box around the cloth's particles, grown by the thickness, normalises the
/// self-collision tree's Morton codes (written into `self_params`).
pub const SCENE_THREADS: u32 = 256;

/// Copies particles `lane, lane + stride, ...` of `x` into `start` (where the frame's first
/// self-collision pass sweeps from).
pub fn copy_start(x: &[Vec4], start: &mut [Vec4], count: u32, lane: u32, stride: u32) {
    let mut i = lane;
    while i < count {
        start[i as usize] = x[i as usize];
        i += stride;
    }
}

/// What anchors (`self_pairs::anchor_at`) predicting over `substeps` substeps take: that
/// time, the gravity and the thickness.
#[inline]
pub fn frame_of(params: &SimParams, self_params: &ColliderParams, substeps: u32) -> (f32, Vec3, f32) {
    (substeps as f32 * params.substep, params.gravity.xyz(), self_params.thickness)
}

#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(256)))]
pub fn self_scene_bounds(
    #[spirv(local_invocation_id)] lid: UVec3,
    #[spirv(push_constant)] push: &SelfAnchorPush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &SimParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] x: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] v: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] indices: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] self_params: &mut ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] start: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] anchors: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] health: &mut Health,
    #[spirv(workgroup)] lows: &mut [Vec4; 256],
    #[spirv(workgroup)] highs: &mut [Vec4; 256],
) {
    let lane = lid.x;
    copy_start(x, start, params.particle_count, lane, SCENE_THREADS);
    let window = frame_of(params, self_params, push.window_substeps);
    let frame = frame_of(params, self_params, push.frame_substeps);
    let lanes = (lane, SCENE_THREADS);
    let mut own = anchor_particles((x, v), (window, frame), anchors, params.particle_count, lanes);
    // The longest edge rides in the box's w (reduced by the same max).
    own.max.w = longest_edge2(x, indices, self_params.leaf_count, lane, SCENE_THREADS);
    let bounds = reduce_bounds(lane, own, lows, highs);
    if lane == 0 {
        write_scene(self_params, &bounds);
        report_scene(self_params, health);
    }
}

/// The longest squared edge of triangles `lane, lane + stride, ...` of `count` (corners
/// `indices[3t..3t + 3]`).
pub fn longest_edge2(x: &[Vec4], indices: &[u32], count: u32, lane: u32, stride: u32) -> f32 {
    let mut longest = 0.0f32;
    let mut t = lane;
    while t < count {
        let i = 3 * t as usize;
        let (a, b, c) =
            (x[indices[i] as usize].xyz(), x[indices[i + 1] as usize].xyz(), x[indices[i + 2] as usize].xyz());
        longest = longest.max(longest_side2(a, b, c));
        t += stride;
    }
    longest
}

/// The squared length of the longest side of triangle `a`, `b`, `c`.
#[inline]
pub fn longest_side2(a: Vec3, b: Vec3, c: Vec3) -> f32 {
    (b - a).length_squared().max((c - a).length_squared()).max((c - b).length_squared())
}

/// How much longer than at the frame's start a cloth edge is assumed to grow within the frame
/// (squared: 1.2x longer; a frame is 1/60 s), for the collider triangles that can skip their
/// walk (`collider_feature_contact_at`).
pub const EDGE_GROWTH2: f32 = 1.44;

/// The cloth's longest squared edge as a frame's collider features are tested for it: measured
/// at the frame's start (`self_scene_bounds`), grown by `EDGE_GROWTH2`.
#[inline]
pub fn grown_longest_edge2(self_params: &ColliderParams) -> f32 {
    self_params.scene_max.w * EDGE_GROWTH2
}

/// Stores the cloth's bounds, grown by the thickness, as the tree's Morton box, and its
/// longest squared edge (`bounds.max.w`) in `scene_max.w`.
#[inline]
pub fn write_scene(self_params: &mut ColliderParams, bounds: &Aabb) {
    let grow = Vec3::splat(self_params.thickness);
    self_params.scene_min = (bounds.min.xyz() - grow).extend(0.0);
    self_params.scene_max = (bounds.max.xyz() + grow).extend(bounds.max.w);
}

/// Puts the scene box `write_scene` wrote in the cloth's health (`Health::self_scene_low`),
/// which the host reads every frame.
pub fn report_scene(self_params: &ColliderParams, health: &mut Health) {
    let (lo, hi) = (self_params.scene_min, self_params.scene_max);
    health.self_scene_low = [lo.x, lo.y, lo.z, 1.0];
    health.self_scene_high = [hi.x, hi.y, hi.z, 1.0];
}

/// Sorted leaf `s`'s corners (xyz) and its triangle index (w), in the tree's order.
#[inline]
pub fn gather_cloth_triangle_at(s: u32, indices: &[u32], order: &[u32]) -> UVec4 {
    let t = order[s as usize];
    let i = 3 * t as usize;
    UVec4::new(indices[i], indices[i + 1], indices[i + 2], t)
}

/// Sorted leaf `s`'s triangle (`gather_cloth_triangle_at`) written to `sorted`, and the leaf to
/// `leaf_of` at the triangle; returns the triangle.
#[inline]
pub fn place_cloth_triangle(
    s: u32,
    (indices, order): (&[u32], &[u32]),
    (sorted, leaf_of): (&mut [UVec4], &mut [u32]),
) -> UVec4 {
    let triangle = gather_cloth_triangle_at(s, indices, order);
    sorted[s as usize] = triangle;
    leaf_of[triangle.w as usize] = s;
    triangle
}

/// Sorted leaf `s`'s triangle (`sorted`), its leaf (`leaf_of`) and its corners' motion box over
/// the frame (`leaf_motions`, what the frame's lists walk with: `self_pairs::triangle_motion_at`).
#[inline]
pub fn gather_cloth_triangle(
    s: u32,
    (indices, order, anchors): (&[u32], &[u32], &[Vec4]),
    (sorted, leaf_of, leaf_motions): (&mut [UVec4], &mut [u32], &mut [Aabb]),
) {
    let triangle = place_cloth_triangle(s, (indices, order), (sorted, leaf_of));
    leaf_motions[s as usize] = triangle_motion_at(triangle, anchors);
}

#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(256)))]
pub fn gather_cloth_triangles(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] self_params: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] indices: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] order: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] anchors: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] sorted: &mut [UVec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] leaf_of: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] leaf_motions: &mut [Aabb],
) {
    if id.x >= self_params.leaf_count {
        return;
    }
    gather_cloth_triangle(id.x, (indices, order, anchors), (sorted, leaf_of, leaf_motions));
}

/// Whether a triangle has collapsed (a segment or a point, within f32's reach): its sides' cross
/// product has squared length `area2` and its longest side squared length `longest2`. No
/// closest point or side can be measured from it.
#[inline]
pub fn collapsed(area2: f32, longest2: f32) -> bool {
    area2 <= 1e-8 * longest2 * longest2
}

/// A vertex-triangle pair's correction: the displacement of the vertex and of each corner
/// (zero when the pair does not touch). `wp` and `w` (the corners') are the pin weights.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct PairCorrection {
    pub vertex: Vec3,
    pub corners: [Vec3; 3],
    /// How far the pair is pushed apart along the face normal (m; vertex-triangle pairs):
    /// the thickness less the vertex's height over the face, so over the thickness when the
    /// vertex ended beyond the face.
    pub push: f32,
    /// Where the pair touches, for its friction (`pair_friction`).
    pub contact: PairContact,
    /// 1 when the pair crossed, 0 when it came within the thickness: a cloth's pairs that
    /// touched at rest answer only a crossing (`touched_at_rest_vertex_face`). (A word, not a
    /// `bool`: `Option` would keep its tag in the bool's spare values, a copy rust-gpu cannot
    /// compile.)
    pub crossed: u32,
}

/// Where a pair of primitives touches, as its four particles make it up: the relative motion
/// at the contact is `sum(coefficients[i] * motion of particle i)` (vertex-triangle: the
/// vertex minus its closest point's barycentric mix of the corners; edge-edge: the first
/// edge's closest point minus the second's), and `normal` (not unit length) is the direction
/// the push separates them in, the first from the second.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct PairContact {
    /// (An array, not a `Vec4`: a 16-byte-aligned field in an `Option` makes rust-gpu emit a
    /// 128-bit constant it cannot compile.)
    pub coefficients: [f32; 4],
    pub normal: Vec3,
}

/// Coulomb friction of a pair in contact, on velocities `v` (its four particles', in the order
/// of `contact.coefficients`; `w` their pin weights): the tangential relative velocity at the
/// contact loses up to `friction` times the normal speed at which the pair approaches (the
/// speed its push stops; nothing while it separates), as a particle on a collider does
/// (`contact::respond`); the change is split over the particles by weight, as the push is.
/// Returns each particle's velocity change. Over a pass a resting layer approaches the one
/// under it at about g cos(slope) times the pass's length, so it holds where tan(slope) <
/// `friction`.
pub fn pair_friction(contact: &PairContact, v: [Vec3; 4], w: Vec4, friction: f32) -> Option<[Vec3; 4]> {
    let (g, normal) = (Vec4::from_array(contact.coefficients), contact.normal);
    let normal2 = normal.length_squared();
    let denom = w.x * g.x * g.x + w.y * g.y * g.y + w.z * g.z * g.z + w.w * g.w * g.w;
    if friction <= 0.0 || normal2 <= 0.0 || denom <= 0.0 {
        return None;
    }
    let relative = v[0] * g.x + v[1] * g.y + v[2] * g.z + v[3] * g.w;
    let approach = relative.dot(normal); // normal speed x |normal|
    if approach >= 0.0 {
        return None;
    }
    let tangential = relative - normal * (approach * (1.0 / normal2));
    let tangential2 = tangential.length_squared();
    if tangential2 <= 0.0 {
        return None;
    }
    // The share of the tangential velocity removed, friction x normal speed / tangential
    // speed, at most all of it; squared, so no reciprocal of a square root (see
    // `pair_correction_within`).
    let normal_speed2 = approach * (approach * (1.0 / normal2));
    let share2 = friction * friction * normal_speed2 * (1.0 / tangential2);
    let share = if share2 >= 1.0 { 1.0 } else { share2.sqrt() };
    let change = tangential * (-share * (1.0 / denom));
    Some([change * (w.x * g.x), change * (w.y * g.y), change * (w.z * g.z), change * (w.w * g.w)])
}

/// The correction of particle `p` (at `p1` now, `p0` at the substep's start) against triangle
/// corners `now` and `then` (the same instants): none unless `p` is within `thickness` of the
/// triangle or has crossed it (its side changed while it stayed over the face); then the pair
/// is pushed apart along the face normal to `thickness` on `p`'s starting side.
pub fn pair_correction(
    (p0, p1): (Vec3, Vec3),
    then: [Vec3; 3],
    now: [Vec3; 3],
    (wp, w): (f32, Vec3),
    thickness: f32,
) -> Option<PairCorrection> {
    pair_correction_within((p0, p1), then, now, (wp, w), (thickness, f32::INFINITY))
}

/// `pair_correction` that takes a crossing ending over the face only up to `crossing_depth`
/// beyond it, and one ending deeper (or beside the face) only when the vertex passed through
/// the face itself during the pass (`passed_through`): a collider's vertex does not move, so
/// a vertex deep under a cloth face that tilted or folded over it has changed sides without
/// passing through the face (pushed in full, those drove the cloth on the dragon unstable),
/// while a spike's tip holding a whole cloth through one cell is passed through by the cell
/// a few centimetres a substep (a 28-degree cone's tip pierced its cloth in 108 of 120
/// frames with only the shallow crossings undone). `crossing_depth` infinite (the cloth's own
/// pairs) takes every crossing that ends over the face and tests no sweep.
pub fn pair_correction_within(
    (p0, p1): (Vec3, Vec3),
    then: [Vec3; 3],
    now: [Vec3; 3],
    (wp, w): (f32, Vec3),
    (thickness, crossing_depth): (f32, f32),
) -> Option<PairCorrection> {
    let [a, b, c] = now;
    let normal = (b - a).cross(c - a);
    let area2 = normal.length_squared();
    let longest = longest_side2(a, b, c);
    if collapsed(area2, longest) {
        return None; // a collapsed triangle has no side to keep
    }
    // Written with the unnormalised normal (length L = sqrt(area2)) and no reciprocal of a
    // square root: llvmpipe computes 1/sqrt as an approximate rsqrt, which would part the GPU
    // from the CPU. Heights below are scaled by L.
    let length = area2.sqrt();
    let (q, weights) = closest_with_weights(p1, a, b, c);
    let distance = (p1 - q).length();
    // The side at the start: of the same material point of the triangle then.
    let [a0, b0, c0] = then;
    let q0 = a0 * weights.x + b0 * weights.y + c0 * weights.z;
    let n0 = (b0 - a0).cross(c0 - a0);
    let start = (p0 - q0).dot(n0);
    let side = if start > 0.0 {
        1.0
    } else if start < 0.0 {
        -1.0
    } else if (p1 - q).dot(normal) >= 0.0 {
        1.0
    } else {
        -1.0
    };
    let dir = normal * side; // length L
    let height_l = (p1 - q).dot(dir); // height x L
    let target_l = thickness * length; // thickness x L
    let interior = weights.x > 0.0 && weights.y > 0.0 && weights.z > 0.0;
    let shallow = height_l > -crossing_depth * length && interior;
    let crossed = height_l < 0.0
        && start != 0.0
        && (shallow || (crossing_depth < f32::INFINITY && passed_through((p0, p1), then, now)));
    if !(distance < thickness || crossed) || height_l >= target_l {
        return None;
    }
    let denom = wp + w.x * weights.x * weights.x + w.y * weights.y * weights.y + w.z * weights.z * weights.z;
    if denom <= 0.0 {
        return None;
    }
    // Unit normal x (thickness - height) / denom = dir x (target_l - height_l) / (L^2 denom).
    let s = (target_l - height_l) * (1.0 / (area2 * denom));
    Some(PairCorrection {
        push: (target_l - height_l) * (1.0 / length),
        vertex: dir * (wp * s),
        corners: [dir * (-w.x * weights.x * s), dir * (-w.y * weights.y * s), dir * (-w.z * weights.z * s)],
        contact: PairContact { coefficients: [1.0, -weights.x, -weights.y, -weights.z], normal: dir },
        crossed: crossed as u32,
    })
}

/// Whether the point moving from `p0` to `p1` passed through the triangle moving from `then`
/// to `now` (each linearly over the pass): at some instant of the pass the point lies in the
/// triangle's plane and over the triangle, its edges included up to `THROUGH_SLACK` of the
/// triangle's size (the instants are found numerically; a neighbour sharing the edge may miss
/// it too). The point's height over the plane is a cubic in time, with up to three such
/// instants: a tip that passes through one cell's face near its edge can cross the plane of
/// the face beside it twice, once outside that face.
pub fn passed_through((p0, p1): (Vec3, Vec3), then: [Vec3; 3], now: [Vec3; 3]) -> bool {
    let cubic = Height::of((p0, p1), then, now);
    // The cubic is monotonic between its turning points: each piece holds at most one root.
    let (t1, t2) = cubic.turning_points();
    let mut lo = 0.0f32;
    let mut piece = 0;
    while piece < 3 {
        let hi = if piece == 0 {
            t1
        } else if piece == 1 {
            t2
        } else {
            1.0
        };
        if hi > lo && cubic.has_root_in(lo, hi) {
            let t = cubic.root_in(lo, hi);
            if over_triangle(p0 + (p1 - p0) * t, lerp_corners(t, then, now)) {
                return true;
            }
        }
        lo = lo.max(hi);
        piece += 1;
    }
    false
}

/// Bisection steps of `Height::root_in`: a root to 2^-20 of the pass.
pub const THROUGH_STEPS: u32 = 20;

/// How far beside a triangle's edge (relative to its size) a point passing its plane still
/// counts as passing through it (`passed_through`).
pub const THROUGH_SLACK: f32 = 1e-3;

/// A moving point's height over a moving triangle's plane (times the normal's length) as a
/// cubic in the pass's fraction `t`: `c0 + c1 t + c2 t^2 + c3 t^3`.
struct Height {
    c: Vec4,
}

impl Height {
    fn of((p0, p1): (Vec3, Vec3), then: [Vec3; 3], now: [Vec3; 3]) -> Height {
        // Relative to the first corner: r = p - a, e1 = b - a, e2 = c - a, each start + t x change.
        let (r, e1, e2) = (p0 - then[0], then[1] - then[0], then[2] - then[0]);
        let dr = (p1 - now[0]) - r;
        let (de1, de2) = ((now[1] - now[0]) - e1, (now[2] - now[0]) - e2);
        // The normal e1 x e2 = n0 + n1 t + n2 t^2.
        let n0 = e1.cross(e2);
        let n1 = e1.cross(de2) + de1.cross(e2);
        let n2 = de1.cross(de2);
        Height { c: Vec4::new(r.dot(n0), r.dot(n1) + dr.dot(n0), r.dot(n2) + dr.dot(n1), dr.dot(n2)) }
    }

    #[inline]
    fn at(&self, t: f32) -> f32 {
        ((self.c.w * t + self.c.z) * t + self.c.y) * t + self.c.x
    }

    /// Where the cubic turns inside (0, 1), in order; pieces without a turning point end at 1.
    fn turning_points(&self) -> (f32, f32) {
        // 3 c3 t^2 + 2 c2 t + c1 = 0.
        let (a, b, c) = (3.0 * self.c.w, 2.0 * self.c.z, self.c.y);
        let (mut t1, mut t2) = (1.0f32, 1.0f32);
        if a == 0.0 {
            if b != 0.0 {
                t1 = -c * (1.0 / b);
            }
        } else {
            let discriminant = b * b - 4.0 * a * c;
            if discriminant > 0.0 {
                let root = discriminant.sqrt();
                let half = 0.5 * (1.0 / a);
                let (u, v) = ((-b - root) * half, (-b + root) * half);
                (t1, t2) = if u < v { (u, v) } else { (v, u) };
            }
        }
        let inside = |t: f32| if t > 0.0 && t < 1.0 { t } else { 1.0 };
        let (t1, t2) = (inside(t1), inside(t2));
        if t1 <= t2 { (t1, t2) } else { (t2, t1) }
    }

    /// Whether the height changes sign (strictly) over [lo, hi], or ends at zero.
    fn has_root_in(&self, lo: f32, hi: f32) -> bool {
        let (a, b) = (self.at(lo), self.at(hi));
        (a > 0.0 && b <= 0.0) || (a < 0.0 && b >= 0.0)
    }

    /// The root in [lo, hi] (`has_root_in`), by bisection.
    fn root_in(&self, mut lo: f32, mut hi: f32) -> f32 {
        let below = self.at(lo) < 0.0;
        let mut step = 0;
        while step < THROUGH_STEPS {
            let mid = 0.5 * (lo + hi);
            if (self.at(mid) < 0.0) == below {
                lo = mid;
            } else {
                hi = mid;
            }
            step += 1;
        }
        0.5 * (lo + hi)
    }
}

/// Whether `p`, in the plane of triangle `corners` (or nearly), lies over it: on the inner
/// side of each edge, up to `THROUGH_SLACK` of the triangle's size.
#[inline]
fn over_triangle(p: Vec3, [a, b, c]: [Vec3; 3]) -> bool {
    let normal = (b - a).cross(c - a);
    let slack = -THROUGH_SLACK * normal.length_squared();
    (b - a).cross(p - a).dot(normal) >= slack
        && (c - b).cross(p - b).dot(normal) >= slack
        && (a - c).cross(p - c).dot(normal) >= slack
}

/// The triangle's corners at fraction `t` of the pass.
#[inline]
fn lerp_corners(t: f32, then: [Vec3; 3], now: [Vec3; 3]) -> [Vec3; 3] {
    [then[0] + (now[0] - then[0]) * t, then[1] + (now[1] - then[1]) * t, then[2] + (now[2] - then[2]) * t]
}

/// Fixed-point scale of the summed friction velocity changes: 2^20 units per m/s (resolution
/// 1e-6 m/s, range +-2048 m/s per particle and pass).
pub const VELOCITY_SCALE: f32 = 1_048_576.0;

/// Adds `d` (m) to particle `i`'s fixed-point sum and counts one correction.
#[inline]
pub fn accumulate(delta: &mut [u32], i: u32, d: Vec3) {
    accumulate_scaled(delta, i, d, FIXED_SCALE);
}

/// Adds `d` to particle `i`'s sum (words `4i..4i + 3`, `scale` units per unit of `d`) and
/// counts one (word `4i + 3`).
#[inline]
pub fn accumulate_scaled(sums: &mut [u32], i: u32, d: Vec3, scale: f32) {
    accumulate_at(sums, 4 * i as usize, d, scale);
}

/// Adds `d` to the sum at words `base..base + 3` (`scale` units per unit of `d`) and counts
/// one (word `base + 3`).
#[inline]
fn accumulate_at(sums: &mut [u32], base: usize, d: Vec3, scale: f32) {
    atomics::add(&mut sums[base], ((d.x * scale) as i32) as u32);
    atomics::add(&mut sums[base + 1], ((d.y * scale) as i32) as u32);
    atomics::add(&mut sums[base + 2], ((d.z * scale) as i32) as u32);
    atomics::add(&mut sums[base + 3], 1);
}

/// Words per particle of a pass's corrections (`PairResponse::delta`): the weighted sum and
/// weight of those that keep a pair apart (words 0-3, `add_weighted`), then the fixed-point sum
/// and count of those that undo a crossing (`CROSSED_WORD..`).
pub const CORRECTION_WORDS: u32 = 8;
/// The first word of a particle's corrections that undo a crossing.
const CROSSED_WORD: usize = 4;

/// Fixed-point scale of the weighted corrections: 2^16 units per thickness (resolution 7.6e-8
/// m at 5 mm). A correction that keeps a pair apart is at most a few thicknesses (a pair pushed
/// to the thickness, a collider feature `COLLIDER_CROSSING_DEPTH` deep), so a particle's sum
/// holds over three hundred of them at three thicknesses each (a crossing's, which may be
/// longer, sums apart).
const RELATIVE_SCALE: f32 = 65_536.0;
/// A correction's weight: one, plus this many per thickness of its length.
const WEIGHT_PER_THICKNESS: f32 = 32.0;
/// The largest weight: a thickness's. A cloth pair's push is at most the thickness; a collider
/// vertex's reaches `COLLIDER_CROSSING_DEPTH` thicknesses, and weighted by all of it, it shoved
/// the lowest of three sheets stacked 12 mm apart on the dragon into the next (the fail-safe
/// put particles back in 50 of 60 frames, against 14 with a plain mean and 14 with this cap).
const WEIGHT_MOST: u32 = 1 + WEIGHT_PER_THICKNESS as u32;

/// Adds correction `d` (m) to particle `i`'s (`CORRECTION_WORDS`), and to its crossings' when
/// it undoes one (`crossed`: `PairCorrection::crossed`); `thickness` is the pair's.
#[inline]
pub fn add_correction(delta: &mut [u32], i: u32, d: Vec3, crossed: u32, thickness: f32) {
    let base = (CORRECTION_WORDS * i) as usize;
    if crossed != 0 {
        accumulate_at(delta, base + CROSSED_WORD, d, FIXED_SCALE);
    } else {
        add_weighted(delta, base, d, thickness);
    }
}

/// Adds `d` (m) to the weighted sum at words `base..base + 3`, in thicknesses (`RELATIVE_SCALE`
/// units), weighted by its length (1 + `WEIGHT_PER_THICKNESS` per thickness, at most `WEIGHT_MOST`),
/// and its weight to word `base + 3`. Integers, so the order of the adds changes nothing.
#[inline]
fn add_weighted(sums: &mut [u32], base: usize, d: Vec3, thickness: f32) {
    let relative = d * (1.0 / thickness);
    let weight = (1 + (relative.length() * WEIGHT_PER_THICKNESS) as u32).min(WEIGHT_MOST);
    let weighted = |c: f32| ((c * RELATIVE_SCALE) as i32).wrapping_mul(weight as i32) as u32;
    atomics::add(&mut sums[base], weighted(relative.x));
    atomics::add(&mut sums[base + 1], weighted(relative.y));
    atomics::add(&mut sums[base + 2], weighted(relative.z));
    atomics::add(&mut sums[base + 3], weight);
}

/// The displacement particle `i`'s corrections (`CORRECTION_WORDS`) give it, at the cloth's
/// `thickness`: the mean of those that undo a crossing when it has any, else the mean of all
/// weighted by their lengths. In one plain mean with the pushes of every pair near it, a pair's
/// correction was diluted:
/// - a crossing's: on a tube crumpled on a sphere (its 29 x 46 mm cells at 5 mm) two creases'
///   diagonals closed 0.3 mm a frame, each particle moved by the mean of its 20-odd
///   corrections, a tenth of their pair's, and crossed (then the fail-safe put them back, every
///   frame from the 111th on);
/// - a squeezed pair's: the same tube with other last bits in its coordinates had an edge-edge
///   pair closing from 4.1 to 2.0 mm over 16 frames, held by pushes a tenth of its own among
///   the near-zero ones of pairs just inside the thickness, and crossing from frame 97 (the
///   fail-safe put particles back in 144 of 240 frames). Weighted by length, a deep pair's push
///   outweighs the shallow ones around it, while corrections that agree still move the particle
///   by what each asks (the mean of equal corrections is any of them), and the result stays
///   within their hull (no more than the largest).
#[inline]
pub fn correction_of(delta: &[u32], i: usize, thickness: f32) -> Option<Vec3> {
    let base = CORRECTION_WORDS as usize * i;
    match mean_at(delta, base + CROSSED_WORD, FIXED_SCALE) {
        Some(d) => Some(d),
        // The weighted mean in thicknesses (the sum over its weight), then in metres.
        None => mean_at(delta, base, RELATIVE_SCALE).map(|mean| mean * thickness),
    }
}

/// Where a pass's cloth pairs put their responses: the pushes (`delta`: fixed-point
/// displacement sums and counts, `CORRECTION_WORDS` per particle) and, with a `friction` coefficient
/// above 0, the friction (`velocity_changes`: fixed-point velocity-change sums and counts),
/// from the velocities `v`. `rest` is the cloth's rest shape (per particle, xyz), which its
/// own pairs are measured against (`touched_at_rest_vertex_face`); a collider's pairs never
/// read it.
pub struct PairResponse<'a> {
    pub thickness: f32,
    pub friction: f32,
    pub v: &'a [Vec4],
    pub rest: &'a [Vec4],
    pub delta: &'a mut [u32],
    pub velocity_changes: &'a mut [u32],
}

impl<'a> PairResponse<'a> {
    /// The response of a cloth's own pairs, at its self-collision thickness and friction
    /// (`self_params`).
    #[inline]
    pub fn of_cloth(
        self_params: &ColliderParams,
        (v, rest): (&'a [Vec4], &'a [Vec4]),
        (delta, velocity_changes): (&'a mut [u32], &'a mut [u32]),
    ) -> Self {
        PairResponse {
            thickness: self_params.thickness,
            friction: self_params.friction,
            v,
            rest,
            delta,
            velocity_changes,
        }
    }

    /// Point `i`'s velocity: a particle's (`weight` > 0, it moves in response), else `unmoved`.
    /// (A method, not a closure: rust-gpu cannot compile closures that capture slices.)
    #[inline]
    fn velocity(&self, i: u32, weight: f32, unmoved: Vec3) -> Vec3 {
        if weight > 0.0 { self.v[i as usize].xyz() } else { unmoved }
    }

    /// The friction of a pair that touches (`contact`) between the points `ids` (pin weights
    /// `w`): a point that moves in response (w > 0) is a particle, whose velocity is loaded
    /// here (few of the pairs a pass tests touch); one that does not moves at `unmoved` (a
    /// collider's feature, whose index is not a particle's, at its own velocity; a pinned
    /// particle at rest), and nothing is added to it.
    #[inline]
    fn add_friction(&mut self, ids: UVec4, w: Vec4, contact: &PairContact, unmoved: [Vec3; 4]) {
        if self.friction <= 0.0 {
            return;
        }
        let v = [
            self.velocity(ids.x, w.x, unmoved[0]),
            self.velocity(ids.y, w.y, unmoved[1]),
            self.velocity(ids.z, w.z, unmoved[2]),
            self.velocity(ids.w, w.w, unmoved[3]),
        ];
        if let Some(dv) = pair_friction(contact, v, w, self.friction) {
            if w.x > 0.0 {
                accumulate_scaled(self.velocity_changes, ids.x, dv[0], VELOCITY_SCALE);
            }
            if w.y > 0.0 {
                accumulate_scaled(self.velocity_changes, ids.y, dv[1], VELOCITY_SCALE);
            }
            if w.z > 0.0 {
                accumulate_scaled(self.velocity_changes, ids.z, dv[2], VELOCITY_SCALE);
            }
            if w.w > 0.0 {
                accumulate_scaled(self.velocity_changes, ids.w, dv[3], VELOCITY_SCALE);
            }
        }
    }
}

/// The buffers self-contact reads: the tree (nodes, node boxes, leaf boxes in tree order, the
/// sorted triangles' corners) and the positions now and at the substep's start.
pub type SelfTree<'a> = (&'a [BvhNode], &'a [Aabb], &'a [Aabb], &'a [UVec4]);

/// What a tree walk does with each leaf whose box meets the query box.
pub trait LeafVisitor {
    fn visit(&mut self, leaf: u32);
}

/// Visits every leaf of a tree of `leaf_count` leaves whose box meets `lo..=hi`, in batches
/// between stretches of the walk (`PairWalk::all`).
pub fn walk_overlapping<V: LeafVisitor>(
    tree: (&[BvhNode], &[Aabb], &[Aabb]),
    leaf_count: u32,
    query: (Vec3, Vec3),
    visitor: &mut V,
) {
    walk_in_batches(PairWalk::all(leaf_count), tree, query, visitor)
}

/// `walk_overlapping` over the leaves after `leaf` (in tree order) only, handed to the visitor
/// in batches between stretches of the walk (`PairWalk`).
pub fn walk_overlapping_after<V: LeafVisitor>(
    leaf: u32,
    tree: (&[BvhNode], &[Aabb], &[Aabb]),
    leaf_count: u32,
    query: (Vec3, Vec3),
    visitor: &mut V,
) {
    walk_in_batches(PairWalk::new(leaf, tree.0, leaf_count), tree, query, visitor)
}

/// Runs `walk` with the query box `query`, handing its leaves to `visitor` in batches between
/// stretches of the walk.
#[inline]
pub fn walk_in_batches<V: LeafVisitor>(
    mut walk: PairWalk,
    tree: (&[BvhNode], &[Aabb], &[Aabb]),
    query: (Vec3, Vec3),
    visitor: &mut V,
) {
    let mut found = [0u32; WALK_BATCH];
    while !walk.done() {
        let count = walk.next_batch(tree, query, &mut found);
        let mut k = 0;
        while k < count {
            visitor.visit(found[k]);
            k += 1;
        }
    }
}

/// The parameters (`s` on `a`-`b`, `t` on `c`-`d`, both in [0, 1]) of the closest points of
/// two segments (Ericson, Real-Time Collision Detection 5.1.9); degenerate segments count as
/// points.
pub fn closest_between_segments(a: Vec3, b: Vec3, c: Vec3, d: Vec3) -> (f32, f32) {
    let (d1, d2, r) = (b - a, d - c, a - c);
    let (aa, ee, f) = (d1.dot(d1), d2.dot(d2), d2.dot(r));
    let tiny = 1e-20;
    if aa <= tiny && ee <= tiny {
        return (0.0, 0.0);
    }
    if aa <= tiny {
        return (0.0, (f * (1.0 / ee)).clamp(0.0, 1.0));
    }
    let cc = d1.dot(r);
    if ee <= tiny {
        return ((-cc * (1.0 / aa)).clamp(0.0, 1.0), 0.0);
    }
    let bb = d1.dot(d2);
    let denom = aa * ee - bb * bb;
    let mut s = if denom > 0.0 { ((bb * f - cc * ee) * (1.0 / denom)).clamp(0.0, 1.0) } else { 0.0 };
    let mut t = (bb * s + f) * (1.0 / ee);
    if t < 0.0 {
        t = 0.0;
        s = (-cc * (1.0 / aa)).clamp(0.0, 1.0);
    } else if t > 1.0 {
        t = 1.0;
        s = ((bb - cc) * (1.0 / aa)).clamp(0.0, 1.0);
    }
    (s, t)
}

/// The vector from the closest point of segment `c`-`d` to that of `a`-`b`
/// (`closest_between_segments`): its length is how far apart the segments are.
#[inline]
pub fn segments_offset(a: Vec3, b: Vec3, c: Vec3, d: Vec3) -> Vec3 {
    let (s, t) = closest_between_segments(a, b, c, d);
    (a + (b - a) * s) - (c + (d - c) * t)
}

/// The correction of edge `a`-`b` against edge `c`-`d` (their ends `then`, at the substep's
/// start, and `now`; `w` their pin weights): none unless the edges come within `thickness`, or
/// crossed when `undo_crossing` (the vector between their closest points reversed while both
/// stayed inside their edges); then they are pushed apart along the direction they were apart
/// at the start, to `thickness`, split by weight. Returns the four ends' displacements, where
/// the edges touch (for friction) and 1 when they crossed, 0 when they came within `thickness`
/// (`PairCorrection::crossed`). The
/// crossing test is a heuristic (edges sliding past each other can reverse that vector too):
/// a collider's edges use proximity alone, since on a dense scan its false crossings, each
/// pushed in full, drove a cloth unstable (the dragon); the cloth's own keep it.
pub fn edge_pair_correction(
    then: [Vec3; 4],
    now: [Vec3; 4],
    w: Vec4,
    thickness: f32,
    undo_crossing: bool,
) -> Option<([Vec3; 4], PairContact, u32)> {
    let [a, b, c, d] = now;
    let (s, t) = closest_between_segments(a, b, c, d);
    let gap = (a + (b - a) * s) - (c + (d - c) * t);
    let distance = gap.length();
    let [a0, b0, c0, d0] = then;
    let gap0 = (a0 + (b0 - a0) * s) - (c0 + (d0 - c0) * t);
    // The direction to keep: how the edges were apart at the start; if they touched then, the
    // normal of the two edges (oriented by the gap now), or the gap now.
    let cross = (b - a).cross(d - c);
    let scale = (b - a).length_squared().max((d - c).length_squared());
    let dir = if gap0.length_squared() > 1e-12 * scale {
        gap0
    } else if cross.length_squared() > 1e-12 * scale * scale {
        if cross.dot(gap) >= 0.0 { cross } else { -cross }
    } else {
        gap
    };
    let dir2 = dir.length_squared();
    if dir2 <= 0.0 {
        return None;
    }
    let length = dir2.sqrt();
    let height_l = gap.dot(dir); // height x |dir|
    let target_l = thickness * length;
    let inside = s > 0.0 && s < 1.0 && t > 0.0 && t < 1.0;
    let crossed = undo_crossing && height_l < 0.0 && inside;
    if !(distance < thickness || crossed) || height_l >= target_l {
        return None;
    }
    let (ga, gb, gc, gd) = (1.0 - s, s, -(1.0 - t), -t);
    let denom = w.x * ga * ga + w.y * gb * gb + w.z * gc * gc + w.w * gd * gd;
    if denom <= 0.0 {
        return None;
    }
    let k = (target_l - height_l) * (1.0 / (dir2 * denom));
    let ends = [dir * (w.x * ga * k), dir * (w.y * gb * k), dir * (w.z * gc * k), dir * (w.w * gd * k)];
    Some((ends, PairContact { coefficients: [ga, gb, gc, gd], normal: dir }, crossed as u32))
}

/// Bit `VERTEX_OWNED_BIT << k` of a triangle's `owned` bits: the triangle is the first to have
/// its corner k (bits 0-2 are the edges it owns), so each particle's vertex-triangle
/// pairs are searched from one triangle.
pub const VERTEX_OWNED_BIT: u32 = 8;

/// The bits of a collider triangle's owned edges and corners in its `features` word (w).
pub const OWNED_FEATURE_BITS: u32 = 0b111_111;

/// Set in a collider triangle's `features` word (w) where, within half the self-colliding
/// cloths' longest edge, the surface wraps round (a rod, a wire, a thin rim: the host's
/// `collider_curl`) or turns over many small folds into a ridge a cell sags onto (a rounded
/// edge: `collider_crease`): each of the vertices and edges it owns is tested against the cloth
/// whatever its fold (`sharp_for`), as if folded shut.
pub const CURLED_BIT: u32 = 64;

/// Bits `COVERED_SHIFT..` of a curled collider triangle's `features` word (laid out as its
/// owned bits): the features it owns that lie within `ColliderParams::cover_reach` of a kept
/// feature of its kind of a curled triangle, which is tested at every pass (the host's
/// `collider_cover`). A cloth face or edge the kept feature holds at the thickness at a pass's
/// end stays the thickness less that reach from the covered one, on the same side. What the
/// covered one's own test would add is its share of a particle's averaged corrections and its
/// swept test of a face passing it within a pass (a vertex's): the kept one, that reach away,
/// and the frame's fail-safe stand for those. A wire of 512 sides lying under the cloth tested
/// each of its 1024 side triangles' edges (1.2 m long) at every pass, 650 ms of a frame on
/// lavapipe.
pub const COVERED_SHIFT: u32 = 7;

/// The largest `ColliderParams::cover_reach`, in thicknesses, at which the covered features
/// are skipped: the cloth kept the thickness from the kept features keeps at least the rest of
/// it from the covered ones (a thickness changed at run time below twice the reach the host
/// measured with tests them all again).
pub const COVER_LIMIT: f32 = 0.5;

/// A collider triangle's `features` word as the passes take it: its covered features'
/// (`COVERED_SHIFT`) owned bits cleared while the collider's covers hold
/// (`ColliderParams::cover_reach`).
#[inline]
pub fn tested_features(feature: UVec4, collider: &ColliderParams) -> UVec4 {
    let reach = collider.cover_reach;
    let covers_hold = feature.w & CURLED_BIT != 0 && reach > 0.0 && reach <= COVER_LIMIT * collider.thickness;
    if !covers_hold {
        return feature;
    }
    let covered = (feature.w >> COVERED_SHIFT) & OWNED_FEATURE_BITS;
    UVec4::new(feature.x, feature.y, feature.z, feature.w & !covered)
}

/// `x`, `y` or `z` for `k` = 0, 1 or 2 (a branch, not an indexed private array: those are
/// slow on llvmpipe).
#[inline]
fn pick<T: Copy>(x: T, y: T, z: T, k: u32) -> T {
    if k == 0 {
        x
    } else if k == 1 {
        y
    } else {
        z
    }
}

/// Corner `k` of a triangle's three positions (`pick`, not an index: see there).
#[inline]
fn corner([a, b, c]: [Vec3; 3], k: usize) -> Vec3 {
    pick(a, b, c, k as u32)
}

/// Component `k` (0, 1 or 2) of `v`.
#[inline]
fn component_f(v: Vec3, k: u32) -> f32 {
    pick(v.x, v.y, v.z, k)
}

/// Component `k` (0, 1 or 2) of `v`.
#[inline]
fn component(v: UVec4, k: u32) -> u32 {
    pick(v.x, v.y, v.z, k)
}

/// A cloth triangle as the pair tests see it: its corners' particles (xyz), their positions at
/// the pass's end (`now`) and start (`then`), and their pin weights. Loaded once per triangle
/// and pair: on llvmpipe a load of a per-lane address is a loop over the lanes, and the tests
/// of one triangle pair would otherwise load each corner several times.
#[derive(Copy, Clone)]
pub(crate) struct Corners {
    ids: UVec4,
    now: [Vec3; 3],
    then: [Vec3; 3],
    weights: Vec3,
}

impl Corners {
    #[inline]
    pub(crate) fn load(ids: UVec4, (x, x_prev): (&[Vec4], &[Vec4])) -> Self {
        let (a, b, c) = (x[ids.x as usize], x[ids.y as usize], x[ids.z as usize]);
        Corners {
            ids,
            now: [a.xyz(), b.xyz(), c.xyz()],
            then: [x_prev[ids.x as usize].xyz(), x_prev[ids.y as usize].xyz(), x_prev[ids.z as usize].xyz()],
            weights: Vec3::new(a.w, b.w, c.w),
        }
    }

    #[inline]
    fn weight(&self, k: u32) -> f32 {
        component_f(self.weights, k)
    }

    #[inline]
    fn has(&self, id: u32) -> bool {
        self.ids.x == id || self.ids.y == id || self.ids.z == id
    }

    /// The box of the whole triangle over the pass.
    #[inline]
    fn swept_box3(&self) -> (Vec3, Vec3) {
        let (n, t) = (self.now, self.then);
        (n[0].min(n[1]).min(n[2]).min(t[0]).min(t[1]).min(t[2]), n[0].max(n[1]).max(n[2]).max(t[0]).max(t[1]).max(t[2]))
    }

    /// The box of corners `k` and `m` over the pass (a corner's own when `k == m`).
    #[inline]
    fn swept_box(&self, k: usize, m: usize) -> (Vec3, Vec3) {
        let (now_k, then_k, now_m, then_m) =
            (corner(self.now, k), corner(self.then, k), corner(self.now, m), corner(self.then, m));
        (now_k.min(then_k).min(now_m).min(then_m), now_k.max(then_k).max(now_m).max(then_m))
    }

    /// The box swept by segment `segment` of `segments` equal ones of the edge from corner `k`
    /// to `m` (the part between the same fractions of it at the pass's start and end).
    #[inline]
    fn segment_box(&self, (k, m): (usize, usize), (segment, segments): (u32, u32)) -> (Vec3, Vec3) {
        let step = 1.0 / segments as f32;
        let (s0, s1) = (segment as f32 * step, (segment + 1) as f32 * step);
        // Indexed, not `corner`: see `collider_vertex_face` (only collider features take it).
        let (then, now) = (self.then[m] - self.then[k], self.now[m] - self.now[k]);
        let ends = [self.then[k] + then * s0, self.then[k] + then * s1, self.now[k] + now * s0, self.now[k] + now * s1];
        (ends[0].min(ends[1]).min(ends[2]).min(ends[3]), ends[0].max(ends[1]).max(ends[2]).max(ends[3]))
    }
}

/// Whether particle `p` lies within `thickness` of the triangle of particles `face` (xyz) in
/// the cloth's rest shape `rest`. Such a pair is the cloth's own shape, not a contact: on a
/// grid a vertex lies 0.71 of an edge from the diagonal across the next cell, and a thickness
/// over that, pushed apart at every pass with the velocity that drove it in lost, held a
/// falling 64^2 cloth in the air (0.908 m above the ground after 60 frames at 20 mm against
/// 0.206 m without self-collision). So the cloth's pairs that touched at rest answer only a
/// crossing, as position-based solvers filter particles within their radius at rest (FleX's
/// self-collide filter). Squared lengths, no square root: the GPU's and the CPU's agree.
#[inline]
pub fn touched_at_rest_vertex_face(rest: &[Vec4], p: u32, face: UVec4, thickness: f32) -> bool {
    let p = rest[p as usize].xyz();
    let (a, b, c) = (rest[face.x as usize].xyz(), rest[face.y as usize].xyz(), rest[face.z as usize].xyz());
    let (q, _) = closest_with_weights(p, a, b, c);
    (p - q).length_squared() < thickness * thickness
}

/// Whether the edges of particles `ids` (x-y against z-w) lie within `thickness` of each other
/// in the cloth's rest shape `rest` (see `touched_at_rest_vertex_face`).
#[inline]
pub fn touched_at_rest_edges(rest: &[Vec4], ids: UVec4, thickness: f32) -> bool {
    let (a, b) = (rest[ids.x as usize].xyz(), rest[ids.y as usize].xyz());
    let (c, d) = (rest[ids.z as usize].xyz(), rest[ids.w as usize].xyz());
    segments_offset(a, b, c, d).length_squared() < thickness * thickness
}

/// Corner `k` of `vertex` against triangle `face` (skipped when it is one of the face's, and
/// unless it crossed when the two touched at rest).
#[inline]
fn vertex_face(vertex: &Corners, k: usize, face: &Corners, out: &mut PairResponse) {
    let id = component(vertex.ids, k as u32);
    if face.has(id) {
        return;
    }
    let weights = (vertex.weight(k as u32), face.weights);
    if let Some(c) =
        pair_correction((corner(vertex.then, k), corner(vertex.now, k)), face.then, face.now, weights, out.thickness)
    {
        // Loaded only for the few pairs that touch.
        if c.crossed == 0 && touched_at_rest_vertex_face(out.rest, id, face.ids, out.thickness) {
            return;
        }
        add_correction(out.delta, id, c.vertex, c.crossed, out.thickness);
        add_correction(out.delta, face.ids.x, c.corners[0], c.crossed, out.thickness);
        add_correction(out.delta, face.ids.y, c.corners[1], c.crossed, out.thickness);
        add_correction(out.delta, face.ids.z, c.corners[2], c.crossed, out.thickness);
        let w = Vec4::new(weights.0, face.weights.x, face.weights.y, face.weights.z);
        out.add_friction(UVec4::new(id, face.ids.x, face.ids.y, face.ids.z), w, &c.contact, [Vec3::ZERO; 4]);
    }
}

/// The ends of edge `k` of triangle `e` (corners k and k + 1) and of edge `m` of triangle `f`,
/// at the pass's start and end: what `edge_pair_correction` takes.
#[inline]
fn edge_ends(e: &Corners, k: usize, f: &Corners, m: usize) -> ([Vec3; 4], [Vec3; 4]) {
    let (k1, m1) = ((k + 1) % 3, (m + 1) % 3);
    (
        [corner(e.then, k), corner(e.then, k1), corner(f.then, m), corner(f.then, m1)],
        [corner(e.now, k), corner(e.now, k1), corner(f.now, m), corner(f.now, m1)],
    )
}

/// Edge `k` of triangle `e` (corners k and k + 1) against edge `m` of triangle `f` (skipped
/// when they share a particle, and unless they crossed when they touched at rest).
#[inline]
fn edge_edge(e: &Corners, k: usize, f: &Corners, m: usize, out: &mut PairResponse) {
    let (k1, m1) = ((k + 1) % 3, (m + 1) % 3);
    let ids = [
        component(e.ids, k as u32),
        component(e.ids, k1 as u32),
        component(f.ids, m as u32),
        component(f.ids, m1 as u32),
    ];
    if ids[0] == ids[2] || ids[0] == ids[3] || ids[1] == ids[2] || ids[1] == ids[3] {
        return;
    }
    let (then, now) = edge_ends(e, k, f, m);
    let w = Vec4::new(e.weight(k as u32), e.weight(k1 as u32), f.weight(m as u32), f.weight(m1 as u32));
    if let Some((d, contact, crossed)) = edge_pair_correction(then, now, w, out.thickness, true) {
        let pair = UVec4::new(ids[0], ids[1], ids[2], ids[3]);
        if crossed == 0 && touched_at_rest_edges(out.rest, pair, out.thickness) {
            return;
        }
        add_correction(out.delta, ids[0], d[0], crossed, out.thickness);
        add_correction(out.delta, ids[1], d[1], crossed, out.thickness);
        add_correction(out.delta, ids[2], d[2], crossed, out.thickness);
        add_correction(out.delta, ids[3], d[3], crossed, out.thickness);
        out.add_friction(pair, w, &contact, [Vec3::ZERO; 4]);
    }
}

/// Whether a box `(lo, hi)` meets another grown by `reach` on every side.
#[inline]
pub(crate) fn within(a: (Vec3, Vec3), b: (Vec3, Vec3), reach: f32) -> bool {
    let r = Vec3::splat(reach);
    a.0.cmple(b.1 + r).all() && a.1.cmpge(b.0 - r).all()
}

/// A triangle's pairs with the triangles after it (in the tree's leaf order) that one walk
/// reaches, in both directions: the corners each owns against the other triangle
/// (vertex-triangle) and the edges each owns against the edges the other owns (edge-edge). So
/// every pair of triangles is handled once, by the first of the two, and every vertex-triangle
/// and edge-edge pair once (each particle and edge belongs to the one triangle that owns it).
/// Each test first checks its primitives' swept boxes, one grown by the thickness: a pair
/// within the thickness at the pass's end, or crossing on the way (motion is linear over a
/// pass), has meeting boxes; most pairs a walk reaches fail this, at a fraction of the exact
/// test's cost.
pub(crate) struct TrianglePairs<'a> {
    leaf: u32,
    pub(crate) mine: Corners,
    /// Bits of the corners (`VERTEX_OWNED_BIT << k`) and edges (`1 << k`, edge k from corner k
    /// to corner k + 1) this triangle owns.
    pub(crate) owned: u32,
    /// This triangle's swept box grown by the thickness.
    reach_lo: Vec3,
    reach_hi: Vec3,
    sorted: &'a [UVec4],
    owned_bits: &'a [u32],
    x: &'a [Vec4],
    x_prev: &'a [Vec4],
    pub(crate) out: PairResponse<'a>,
}

impl<'a> TrianglePairs<'a> {
    /// The pairs of sorted leaf `leaf` (whose corners and owned bits the tables give).
    #[inline]
    pub(crate) fn of(
        leaf: u32,
        (leaf_bounds, sorted, owned_bits): (&'a [Aabb], &'a [UVec4], &'a [u32]),
        (x, x_prev): (&'a [Vec4], &'a [Vec4]),
        out: PairResponse<'a>,
    ) -> Self {
        let ids = sorted[leaf as usize];
        let (reach_lo, reach_hi) = triangle_query(&leaf_bounds[leaf as usize], out.thickness);
        TrianglePairs {
            leaf,
            mine: Corners::load(ids, (x, x_prev)),
            owned: owned_bits[ids.w as usize],
            reach_lo,
            reach_hi,
            sorted,
            owned_bits,
            x,
            x_prev,
            out,
        }
    }
}

/// The corners `corners` marks (bit k: corner k) of triangle `vertices` against triangle
/// `face`.
#[inline]
fn corners_against(vertices: &Corners, corners: u32, face: &Corners, out: &mut PairResponse) {
    let face_box = face.swept_box3();
    let mut k = 0;
    while k < 3 {
        if corners & (1 << k) != 0 && within(vertices.swept_box(k, k), face_box, out.thickness) {
            vertex_face(vertices, k, face, out);
        }
        k += 1;
    }
}

/// The primitive pairs of a pair of triangles `a`, `b` as bits: `a`'s corner k against `b`'s
/// face (bit k), `b`'s corner k against `a`'s face (bit 3 + k), `a`'s edge k against `b`'s edge
/// m (bit `PAIR_EDGES_SHIFT + 3k + m`). `pair_mask` sets those the triangles own; a frame's
/// pair list keeps those that can touch within the frame (`self_pairs`).
pub const PAIR_EDGES_SHIFT: u32 = 6;

/// The primitive pairs (`PAIR_EDGES_SHIFT`) of triangles owning `a_owned` and `b_owned`
/// (`VERTEX_OWNED_BIT`): each owned corner against the other's face, each owned edge against
/// the other's owned edges.
#[inline]
pub fn pair_mask(a_owned: u32, b_owned: u32) -> u32 {
    let corners = ((a_owned >> 3) & 7) | (((b_owned >> 3) & 7) << 3);
    let mut edges = 0;
    let mut k = 0;
    while k < 3 {
        if a_owned & (1 << k) != 0 {
            edges |= (b_owned & 7) << (3 * k);
        }
        k += 1;
    }
    corners | (edges << PAIR_EDGES_SHIFT)
}

/// Triangles `a` and `b` against each other, both ways, in the primitive pairs `mask` holds
/// (`pair_mask`). `a` is always the earlier of the two in the tree's leaf order, so a pair
/// gives the same result however it was found.
#[inline]
pub(crate) fn triangle_pair(a: &Corners, b: &Corners, mask: u32, out: &mut PairResponse) {
    corners_against(a, mask & 7, b, out);
    corners_against(b, (mask >> 3) & 7, a, out);
    let mut k = 0;
    while k < 3 {
        let edges = (mask >> (PAIR_EDGES_SHIFT + 3 * k as u32)) & 7;
        if edges != 0 {
            let edge = a.swept_box(k, (k + 1) % 3);
            let mut m = 0;
            while m < 3 {
                if edges & (1 << m) != 0 && within(edge, b.swept_box(m, (m + 1) % 3), out.thickness) {
                    edge_edge(a, k, b, m, out);
                }
                m += 1;
            }
        }
        k += 1;
    }
}

impl LeafVisitor for TrianglePairs<'_> {
    fn visit(&mut self, leaf: u32) {
        if leaf <= self.leaf {
            return; // the earlier triangle of a pair handles it (and a triangle's own corners and edges share its particles)
        }
        let ids = self.sorted[leaf as usize];
        let theirs = Corners::load(ids, (self.x, self.x_prev));
        triangle_pair(&self.mine, &theirs, pair_mask(self.owned, self.owned_bits[ids.w as usize]), &mut self.out);
    }
}

/// The box sorted leaf `leaf`'s pairs are searched in: its triangle's swept box (over the
/// pass), grown by the thickness. A pair within the thickness at the pass's end, or crossing
/// on the way (motion is linear over a pass), has swept boxes that meet once grown by it.
#[inline]
pub(crate) fn triangle_query(bounds: &Aabb, thickness: f32) -> (Vec3, Vec3) {
    let reach = Vec3::splat(thickness);
    (bounds.min.xyz() - reach, bounds.max.xyz() + reach)
}

/// Sorted leaf `leaf`'s pairs (its triangle's owned corners and edges) through the tree.
#[allow(clippy::too_many_arguments)]
pub fn self_triangle_contact_at(
    leaf: u32,
    self_params: &ColliderParams,
    (nodes, aabbs, leaf_bounds, sorted): SelfTree<'_>,
    owned: &[u32],
    (x, x_prev): (&[Vec4], &[Vec4]),
    out: PairResponse,
) {
    let tables = (leaf_bounds, sorted, owned);
    let mut pairs = TrianglePairs::of(leaf, tables, (x, x_prev), out);
    pairs.walk_after((nodes, aabbs, leaf_bounds), self_params.leaf_count)
}

impl TrianglePairs<'_> {
    /// The pairs with every later leaf whose box meets this triangle's query box, through the
    /// tree.
    #[inline]
    pub(crate) fn walk_after(&mut self, tree: (&[BvhNode], &[Aabb], &[Aabb]), leaf_count: u32) {
        let query = (self.reach_lo, self.reach_hi);
        walk_overlapping_after(self.leaf, tree, leaf_count, query, self)
    }
}

/// The baseline `self_triangle_contact_at` must equal, without the tree: sorted leaf `leaf`'s
/// triangle against every later leaf whose box meets its query box.
pub fn self_triangle_contact_brute_force_at(
    leaf: u32,
    self_params: &ColliderParams,
    (leaf_bounds, sorted): (&[Aabb], &[UVec4]),
    owned: &[u32],
    (x, x_prev): (&[Vec4], &[Vec4]),
    mut out: PairResponse,
) {
    let ids = sorted[leaf as usize];
    let mine = Corners::load(ids, (x, x_prev));
    let (lo, hi) = triangle_query(&leaf_bounds[leaf as usize], out.thickness);
    let mut other = leaf + 1;
    while other < self_params.leaf_count {
        if box_meets(&leaf_bounds[other as usize], lo, hi) {
            let theirs = sorted[other as usize];
            let mask = pair_mask(owned[ids.w as usize], owned[theirs.w as usize]);
            triangle_pair(&mine, &Corners::load(theirs, (x, x_prev)), mask, &mut out);
        }
        other += 1;
    }
}

/// A collider triangle's features (the vertices and edges it owns) against the cloth
/// triangles one walk reaches: each owned vertex against the cloth triangle's face, each owned
/// edge against the edges the cloth triangle owns. The collider does not move in response
/// (weight 0): the cloth's particles take the whole correction.
struct ColliderFeaturePairs<'a> {
    /// The collider triangle in the world at the pass's start and end (weights 0).
    feature: Corners,
    /// The features this walk tests: owned, sharp enough for the cloth, and (when the triangle
    /// walks once per feature) the walk's own.
    owned: u32,
    /// How far the surface folds at each of its edges (`fold`) and at each corner (the sharper
    /// of the two edges at it: a spike's tip folds every edge around it, a smooth body's
    /// vertex none): an edge pushes, and a vertex corrects, only a cloth edge or face its fold
    /// could bring within half the thickness (`sharp_for`).
    folds: Vec3,
    vertex_folds: Vec3,
    /// The feature's corners' velocities over the pass.
    velocities: [Vec3; 3],
    sorted: &'a [UVec4],
    owned_bits: &'a [u32],
    x: &'a [Vec4],
    x_prev: &'a [Vec4],
    /// The collider's thickness and friction, the cloth's velocities, its corrections' sums
    /// and its friction's.
    out: PairResponse<'a>,
    pushes: &'a mut [u32],
    /// The largest push its vertices gave a cloth face (m; `Health::collider_feature_push_bits`
    /// takes it in thicknesses).
    largest_push: f32,
    /// Whether one of its edges pushed a cloth edge (`pushes`): the pass then runs its boxes
    /// and refit again (`arm_second_refit`).
    edge_pushed: bool,
    /// The walk's segment of its edge (`(k, m)`, of `segments`; 1 for a whole edge or a
    /// vertex): a cloth triangle whose box meets an earlier segment's (grown by the thickness)
    /// was tested there.
    edge: (usize, usize),
    segment: (u32, u32),
    leaf_bounds: &'a [Aabb],
}

impl ColliderFeaturePairs<'_> {
    /// Whether an earlier segment of the walk's edge reached cloth triangle `leaf`.
    #[inline]
    fn met_before(&self, leaf: u32) -> bool {
        let bounds = &self.leaf_bounds[leaf as usize];
        let reach = Vec3::splat(self.out.thickness);
        let mut earlier = 0;
        while earlier < self.segment.0 {
            let (lo, hi) = self.feature.segment_box(self.edge, (earlier, self.segment.1));
            if box_meets(bounds, lo - reach, hi + reach) {
                return true;
            }
            earlier += 1;
        }
        false
    }
}

/// Collider corner `k` of `feature` (moving at `velocity`) against cloth triangle `face` (into
/// the cloth's own mean), with the collider's friction; returns how far it pushed the face
/// (`PairCorrection::push`; 0 for none).
#[inline]
fn collider_vertex_face(
    feature: &Corners,
    (k, velocity): (usize, Vec3),
    face: &Corners,
    out: &mut PairResponse,
) -> f32 {
    let weights = (0.0, face.weights);
    let limits = (out.thickness, COLLIDER_CROSSING_DEPTH * out.thickness);
    // Indexed, not `corner`: the collider features' kernel then carried its walk's state,
    // slices and all, as one phi (`tests/engine.rs`, no_kernel_holds_a_pointer_as_data).
    if let Some(c) = pair_correction_within((feature.then[k], feature.now[k]), face.then, face.now, weights, limits) {
        add_correction(out.delta, face.ids.x, c.corners[0], c.crossed, out.thickness);
        add_correction(out.delta, face.ids.y, c.corners[1], c.crossed, out.thickness);
        add_correction(out.delta, face.ids.z, c.corners[2], c.crossed, out.thickness);
        let ids = UVec4::new(0, face.ids.x, face.ids.y, face.ids.z);
        let w = Vec4::new(0.0, face.weights.x, face.weights.y, face.weights.z);
        out.add_friction(ids, w, &c.contact, [velocity, Vec3::ZERO, Vec3::ZERO, Vec3::ZERO]);
        return c.push;
    }
    0.0
}

/// Collider edge `k` of `feature` against edge `m` of cloth triangle `cloth`; returns whether
/// it pushed the cloth edge.
#[inline]
fn collider_edge_edge(
    (feature, velocities): (&Corners, [Vec3; 3]),
    (k, fold): (usize, f32),
    cloth: &Corners,
    m: usize,
    out: &mut PairResponse,
    pushes: &mut [u32],
) -> bool {
    let (k1, m1) = ((k + 1) % 3, (m + 1) % 3);
    let thickness = out.thickness;
    if !sharp_for(fold, (cloth.now[m1] - cloth.now[m]).length_squared(), thickness) {
        return false;
    }
    // Indexed, not `edge_ends`: see `collider_vertex_face`.
    let (then, now) = (
        [feature.then[k], feature.then[k1], cloth.then[m], cloth.then[m1]],
        [feature.now[k], feature.now[k1], cloth.now[m], cloth.now[m1]],
    );
    let w = Vec4::new(0.0, 0.0, cloth.weight(m as u32), cloth.weight(m1 as u32));
    if let Some((d, contact, _)) = edge_pair_correction(then, now, w, thickness, false) {
        let (a, b) = (component(cloth.ids, m as u32), component(cloth.ids, m1 as u32));
        push_out(pushes, a, d[2], COLLIDER_PUSH_LIMIT * thickness);
        push_out(pushes, b, d[3], COLLIDER_PUSH_LIMIT * thickness);
        let ends = [
            pick(velocities[0], velocities[1], velocities[2], k as u32),
            pick(velocities[0], velocities[1], velocities[2], k1 as u32),
        ];
        out.add_friction(UVec4::new(0, 0, a, b), w, &contact, [ends[0], ends[1], Vec3::ZERO, Vec3::ZERO]);
        return true;
    }
    false
}

impl LeafVisitor for ColliderFeaturePairs<'_> {
    fn visit(&mut self, leaf: u32) {
        if self.segment.0 > 0 && self.met_before(leaf) {
            return;
        }
        let ids = self.sorted[leaf as usize];
        let cloth = Corners::load(ids, (self.x, self.x_prev));
        let cloth_owned = self.owned_bits[ids.w as usize];
        let (feature, thickness) = (&self.feature, self.out.thickness);
        let face_box = cloth.swept_box3();
        let face_length2 = longest_side2(cloth.now[0], cloth.now[1], cloth.now[2]);
        let mut k = 0;
        while k < 3 {
            if self.owned & (VERTEX_OWNED_BIT << k) != 0
                && sharp_for(component_f(self.vertex_folds, k as u32), face_length2, thickness)
                && within(feature.swept_box(k, k), face_box, thickness)
            {
                let velocity = pick(self.velocities[0], self.velocities[1], self.velocities[2], k as u32);
                let push = collider_vertex_face(feature, (k, velocity), &cloth, &mut self.out);
                self.largest_push = self.largest_push.max(push);
            }
            if self.owned & (1 << k) != 0 {
                let edge = (k, component_f(self.folds, k as u32));
                let edge_box = feature.swept_box(k, (k + 1) % 3);
                let mut m = 0;
                while m < 3 {
                    if cloth_owned & (1 << m) != 0 && within(edge_box, cloth.swept_box(m, (m + 1) % 3), thickness) {
                        let pushed =
                            collider_edge_edge((feature, self.velocities), edge, &cloth, m, &mut self.out, self.pushes);
                        self.edge_pushed = self.edge_pushed || pushed;
                    }
                    m += 1;
                }
            }
            k += 1;
        }
    }
}

/// Where a (possibly deforming) collider's vertex `local` moves over the pass: its frame-start
/// position `previous` lerped to `local` at the pass's start and end fractions of the frame,
/// each placed by the pose then.
#[inline]
fn collider_point(previous: Vec3, local: Vec3, motion: &SubstepMotion) -> (Vec3, Vec3) {
    let step = local - previous;
    (to_world(&motion.start, previous + step * motion.from), to_world(&motion.end, previous + step * motion.to))
}

/// The fold (`fold`) at edge `k` of a collider triangle (`corners` at the pass's end) whose
/// neighbour across it has apex `across`.
#[inline]
fn edge_fold(
    (k, across): (usize, u32),
    corners: [Vec3; 3],
    (vertices, previous): (&[Vec4], &[Vec4]),
    motion: &SubstepMotion,
) -> f32 {
    if across == NO_NEIGHBOUR {
        return FOLDED_SHUT;
    }
    let o = across as usize;
    let far = collider_point(previous[o].xyz(), vertices[o].xyz(), motion).1;
    fold(corners[k], corners[(k + 1) % 3], corners[(k + 2) % 3], far)
}

/// Collider triangle `triangle` (its owned vertices and edges, `feature.w`; the apexes of its
/// neighbours across its edges, `feature.xyz`, `NO_NEIGHBOUR` for none), moving with the
/// collider over the pass `motion`, against the cloth's faces and edges: a spike's tip or a
/// ridge keeps the thickness from every cloth triangle and edge, on the side it came from, so
/// it cannot poke through a cloth cell between particles. Returns whether one of its edges
/// pushed a cloth edge (`pushes`, which move particles before the pass's pairs).
/// `cloth_leaf`: `EVERY_CLOTH_LEAF` walks the cloth's tree; a sorted leaf of it tests that
/// cloth triangle alone, as the walk would have (`feature_walks`, the same pass from the
/// cloth's side).
#[allow(clippy::too_many_arguments)]
pub fn collider_feature_contact_at(
    triangle: u32,
    feature: UVec4,
    (vertices, previous, indices): (&[Vec4], &[Vec4], &[u32]),
    motion: &SubstepMotion,
    self_params: &ColliderParams,
    ((nodes, aabbs, leaf_bounds, sorted), cloth_leaf): (SelfTree<'_>, u32),
    cloth_owned: &[u32],
    (x, x_prev): (&[Vec4], &[Vec4]),
    (out, pushes, health): (PairResponse, &mut [u32], &mut Health),
) -> bool {
    let thickness = out.thickness;
    let owned = feature.w & OWNED_FEATURE_BITS;
    if owned == 0 {
        return false;
    }
    let i = 3 * triangle as usize;
    let (ia, ib, ic) = (indices[i] as usize, indices[i + 1] as usize, indices[i + 2] as usize);
    let a = collider_point(previous[ia].xyz(), vertices[ia].xyz(), motion);
    let b = collider_point(previous[ib].xyz(), vertices[ib].xyz(), motion);
    let c = collider_point(previous[ic].xyz(), vertices[ic].xyz(), motion);
    let corners = [a.1, b.1, c.1];
    let moving = Corners { ids: UVec4::ZERO, now: corners, then: [a.0, b.0, c.0], weights: Vec3::ZERO };
    let (lo, hi) = moving.swept_box3();
    let reach = Vec3::splat(thickness);
    let (lo, hi) = (lo - reach, hi + reach);
    let leaves = self_params.leaf_count;
    if !meets_cloth(aabbs, leaves, (lo, hi)) {
        return false; // away from the whole cloth (the tree's root): no folds to measure
    }
    // The folds at the pass's end (a deforming collider's change); folded shut where the
    // surface wraps round or forms a ridge at the cloth's scale (`CURLED_BIT`).
    let mesh = (vertices, previous);
    let folds = if feature.w & CURLED_BIT != 0 {
        Vec3::splat(FOLDED_SHUT)
    } else {
        Vec3::new(
            edge_fold((0, feature.x), corners, mesh, motion),
            edge_fold((1, feature.y), corners, mesh, motion),
            edge_fold((2, feature.z), corners, mesh, motion),
        )
    };
    let vertex_folds = vertex_folds(folds);
    // The features sharp enough for the cloth's longest edge (at the frame's start, grown by
    // `EDGE_GROWTH2`); none (most of a smooth body): nothing this triangle could test.
    let longest2 = grown_longest_edge2(self_params);
    let sharp = sharp_features(owned, folds, (longest2, thickness), 1.0);
    if sharp == 0 {
        return false;
    }
    // Each corner's velocity over the pass (the pose's motion and the mesh's deformation).
    let per_second = 1.0 / motion.h;
    let velocities = [(a.1 - a.0) * per_second, (b.1 - b.0) * per_second, (c.1 - c.0) * per_second];
    let mut pairs = ColliderFeaturePairs {
        feature: moving,
        owned: sharp,
        folds,
        vertex_folds,
        velocities,
        sorted,
        owned_bits: cloth_owned,
        x,
        x_prev,
        out,
        pushes,
        largest_push: 0.0,
        edge_pushed: false,
        edge: (0, 0),
        segment: (0, 1),
        leaf_bounds,
    };
    // A triangle much larger than the cloth's edges (a ground plane, a box's side) would reach
    // every cloth triangle over it, though its features (its rim, its corners) lie far from
    // most: then each sharp feature walks the tree with its own box (a 6 m ground's one walk
    // tested the whole pile, 2048 triangles, in one thread). Otherwise one walk tests them all.
    // Both ways go through the one call of the walk below, which inlines large: a second call
    // made the kernel's SPIR-V 1.7x the size.
    // An edge much longer than the cloth's edges walks in segments of about that length, each
    // with its own box: the box of a whole long slanted edge holds far more cloth than lies
    // near the edge (a 1.9 m edge of a tall cone under the cloth hanging around it: one thread
    // tested most of the cloth, 10 ms a pass on an H100).
    let one_by_one = spans_many_cloth_edges(hi - lo, longest2);
    let mut feature: u32 = 0;
    let mut segment: u32 = 0;
    // The feature's segments, and whether it comes near the cloth at all (set at its first).
    let (mut segments, mut feature_near) = (1, true);
    while feature < 6 {
        let (bit, (k, m)) = if feature < 3 {
            (1 << feature, (feature as usize, (feature as usize + 1) % 3))
        } else {
            (VERTEX_OWNED_BIT << (feature - 3), (feature as usize - 3, feature as usize - 3))
        };
        if segment == 0 && one_by_one {
            let whole = pairs.feature.swept_box(k, m);
            segments = if k != m { edge_segments(whole, longest2) } else { 1 };
            feature_near = meets_cloth(aabbs, leaves, (whole.0 - reach, whole.1 + reach));
        }
        let (walk, query) = if one_by_one {
            let (flo, fhi) = pairs.feature.segment_box((k, m), (segment, segments));
            (bit, (flo - reach, fhi + reach))
        } else {
            (sharp, (lo, hi))
        };
        // A segment, or a whole feature, away from the whole cloth (the tree's root) has
        // nothing to walk: a 6 m ground's rim in 32 segments set up 128 empty walks a pass, and
        // testing each segment's box one after another still took the H100 27 us a pass.
        if sharp & walk != 0 && feature_near && meets_cloth(aabbs, leaves, query) {
            (pairs.owned, pairs.edge, pairs.segment) = (walk, (k, m), (segment, segments));
            let tree = (nodes, aabbs, leaf_bounds);
            let walk = if cloth_leaf == EVERY_CLOTH_LEAF { PairWalk::all(leaves) } else { PairWalk::one(cloth_leaf) };
            walk_in_batches(walk, tree, query, &mut pairs);
        }
        segment += 1;
        if segment >= segments || sharp & walk == 0 || !feature_near {
            segment = 0;
            feature = if one_by_one { feature + 1 } else { 6 };
        }
    }
    if pairs.largest_push > 0.0 {
        let thicknesses = pairs.largest_push * (1.0 / thickness);
        atomics::max(&mut health.collider_feature_push_bits, thicknesses.to_bits());
    }
    pairs.edge_pushed
}

/// `collider_feature_contact_at`'s `cloth_leaf` that walks the whole cloth's tree.
pub const EVERY_CLOTH_LEAF: u32 = u32::MAX;

/// Whether a collider triangle whose swept box (grown by the thickness) has `extent` spans
/// many cloth edges (`cloth_edge2`, the longest squared): then its features walk the cloth's
/// tree one by one, each with its own box (`collider_feature_contact_at`).
#[inline]
pub fn spans_many_cloth_edges(extent: Vec3, cloth_edge2: f32) -> bool {
    let longest = extent.max_element();
    longest * longest > FEATURE_WALK_EDGES * FEATURE_WALK_EDGES * cloth_edge2
}

/// Whether box `(lo, hi)` meets the cloth's tree's root box (`aabbs[0]`; a tree of one leaf
/// has no internal node to ask, so yes).
#[inline]
fn meets_cloth(aabbs: &[Aabb], leaf_count: u32, (lo, hi): (Vec3, Vec3)) -> bool {
    leaf_count <= 1 || box_meets(&aabbs[0], lo, hi)
}

/// The segments a collider edge whose swept box is `(lo, hi)` walks in: about
/// `SEGMENT_CLOTH_EDGES` cloth edges (`cloth_edge2`, the longest squared) each, at most
/// `MAX_EDGE_SEGMENTS`.
#[inline]
pub fn edge_segments((lo, hi): (Vec3, Vec3), cloth_edge2: f32) -> u32 {
    let longest = (hi - lo).max_element();
    let span = SEGMENT_CLOTH_EDGES * cloth_edge2.sqrt();
    if span.is_nan() || span <= 0.0 {
        return 1;
    }
    let segments = (longest * (1.0 / span)).ceil();
    if segments >= MAX_EDGE_SEGMENTS as f32 {
        MAX_EDGE_SEGMENTS
    } else if segments >= 1.0 {
        segments as u32
    } else {
        1
    }
}

/// The longest cloth edges a collider edge's segment spans (`edge_segments`).
pub const SEGMENT_CLOTH_EDGES: f32 = 1.0;

/// The most segments an edge walks in (`edge_segments`): each segment's walk first tests the
/// boxes of those before it for every cloth triangle it reaches.
pub const MAX_EDGE_SEGMENTS: u32 = 32;

/// Cloth edges a collider triangle must span before its features walk one by one: a walk per
/// feature repeats the loads of the cloth triangles near two features (a corner and its edges),
/// which on a dense collider cost more than the few extra triangles one walk tests.
pub const FEATURE_WALK_EDGES: f32 = 4.0;

#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(64)))]
pub fn collider_feature_contact(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] push: &ContactPush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &SimParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] self_params: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] collider: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] pose: &ColliderPose,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] vertices: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] previous: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] indices: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] features: &[UVec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] nodes: &[BvhNode],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] aabbs: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] leaf_bounds: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] sorted: &[UVec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 12)] owned: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 13)] x: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 14)] x_prev: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 15)] v: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 16)] delta: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 17)] velocity_changes: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 18)] pushes: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 19)] sharp: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 20)] sharp_args: &DispatchArgs,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 21)] health: &mut Health,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 22)] features_found: &mut DispatchArgs,
) {
    // One thread per triangle the frame listed as possibly sharp (`sharp_features`), or, with
    // the frame's pair lists, per listed triangle within the cloth's reach (`feature_reach`).
    if id.x >= sharp_args._pad {
        return;
    }
    let triangle = sharp[id.x as usize];
    let motion = substep_motion(params, pose, push);
    let tree = (nodes, aabbs, leaf_bounds, sorted);
    let mesh = (vertices, previous, indices);
    let mine = tested_features(features[triangle as usize], collider);
    // `rest`: a collider's pairs never read it (only the cloth's own pairs are measured at rest).
    let out = PairResponse {
        thickness: collider.thickness,
        friction: collider.friction,
        v,
        rest: x,
        delta,
        velocity_changes,
    };
    let pushed = collider_feature_contact_at(
        triangle,
        mine,
        mesh,
        &motion,
        self_params,
        (tree, EVERY_CLOTH_LEAF),
        owned,
        (x, x_prev),
        (out, pushes, health),
    );
    if pushed {
        arm_second_refit(self_params, features_found);
    }
}

/// Arms the pass's second run of the cloth's triangle boxes and tree refit, and of the pushes
/// that move particles before it (`features_found`: their indirect dispatch over the cloth's
/// triangles, which the host empties before each pass's collider features). Only a pass whose
/// collider edges pushed a cloth edge runs them: a ground plane's rim is always sharp, and
/// armed for the whole frame whenever a collider listed a possibly sharp triangle, every pass
/// of the pile refit its tree twice for a rim 3 m away.
#[inline]
pub fn arm_second_refit(self_params: &ColliderParams, features_found: &mut DispatchArgs) {
    features_found.x = self_params.leaf_count.div_ceil(WORKGROUP_SIZE);
}

/// How deep beyond a cloth face a collider vertex may be and still count as having crossed it
/// in a pass, in thicknesses (`pair_correction_within`).
pub const COLLIDER_CROSSING_DEPTH: f32 = 2.0;

/// The most a collider edge pushes a particle along each axis in one pass, in thicknesses
/// (`push_out`).
pub const COLLIDER_PUSH_LIMIT: f32 = 1.0;

/// A collider triangle's edge with no single neighbour across it (a boundary or a
/// non-manifold edge): always sharp (`fold`).
pub const NO_NEIGHBOUR: u32 = u32::MAX;

/// The `fold` of an edge folded shut, its two half-planes on one side (also a boundary's, a
/// degenerate triangle's, a surface that wraps round's: `CURLED_BIT`): always sharp.
pub const FOLDED_SHUT: f32 = 2.0;

/// How far from flat the surface folds at the edge from `a` to `b` of the triangle with apex
/// `apex`, whose neighbour across it has apex `across`: 1 + cos of the angle between the two
/// half-planes (0 flat, 1 at a right angle, 2 folded shut); convex and concave alike, so no
/// winding is assumed. About fold^2 / 2 for a fold of a small angle. Degenerate triangles
/// count as folded shut.
#[inline]
pub fn fold(a: Vec3, b: Vec3, apex: Vec3, across: Vec3) -> f32 {
    let edge = b - a;
    let length2 = edge.length_squared();
    if length2 <= 0.0 {
        return FOLDED_SHUT;
    }
    let off_edge = |p: Vec3| {
        let r = p - a;
        r - edge * (r.dot(edge) * (1.0 / length2))
    };
    let (u, w) = (off_edge(apex), off_edge(across));
    let norms = (u.length_squared() * w.length_squared()).sqrt();
    if norms <= 0.0 {
        return FOLDED_SHUT;
    }
    1.0 + u.dot(w) * (1.0 / norms)
}

/// Whether a collider edge folded by `fold` can come near a cloth edge of squared length
/// `cloth_length2` that lies across it: a cloth edge of length L over a ridge of angle `f`,
/// its particles at the thickness `t` from the faces (their contact), dips by about L f / 4
/// towards the ridge; the edge pushes when that reaches half the thickness (f >= 2 t / L,
/// i.e. fold >= 2 t^2 / L^2). The same for a collider vertex (the sharper of its triangle's
/// edges at it) under a cloth face (L its longest edge). Flatter features are left to the
/// particles' contact: tested at the full thickness every pass, the nearly flat vertices and
/// edges of a tessellated smooth body held the cloth above the faces its contact holds it to,
/// without friction (the cloth on the bunny slid off: 0 particles resting after 2 s), and the
/// garment's skirt, gathered in layers on the body's rounded top, crossed itself in 58 of 120
/// frames. An edge folded shut (a boundary, a fin, a degenerate triangle: 2) always counts.
#[inline]
pub fn sharp_for(fold: f32, cloth_length2: f32, thickness: f32) -> bool {
    fold >= FOLDED_SHUT || fold * cloth_length2 >= 2.0 * thickness * thickness
}

/// A collider triangle's folds at its corners from those at its edges (`folds`, edge k from
/// corner k to k + 1): corner k takes the sharper of edges k and k + 2.
#[inline]
pub fn vertex_folds(folds: Vec3) -> Vec3 {
    folds.max(Vec3::new(folds.z, folds.x, folds.y))
}

/// Which of the features in `owned` (a collider triangle's owned edges and corners, bits as
/// `collider_features`) are sharp (`sharp_for`) for a cloth whose longest squared edge and
/// thickness are `cloth`, with its edges folded by `folds`, each fold taken `scale` times.
#[inline]
pub fn sharp_features(owned: u32, folds: Vec3, (cloth_length2, thickness): (f32, f32), scale: f32) -> u32 {
    let corners = vertex_folds(folds);
    let mut sharp = 0;
    let mut k = 0;
    while k < 3 {
        if owned & (1 << k) != 0 && sharp_for(component_f(folds, k) * scale, cloth_length2, thickness) {
            sharp |= 1 << k;
        }
        if owned & (VERTEX_OWNED_BIT << k) != 0 && sharp_for(component_f(corners, k) * scale, cloth_length2, thickness)
        {
            sharp |= VERTEX_OWNED_BIT << k;
        }
        k += 1;
    }
    sharp
}

/// Words per particle of the collider edges' pushes: the largest push along +x, +y, +z and
/// along -x, -y, -z (fixed point, `FIXED_SCALE`).
pub const PUSH_WORDS: u32 = 6;

/// Records collider-edge push `d` (m) on particle `i`: per axis direction, the largest so far,
/// at most `limit`. These pushes are not averaged with the particle's other corrections: in
/// one mean with a collider vertex's push up against a cloth face, the pushes sideways from
/// the edges around it diluted it and a spike's tip went through. So the particle moves by the
/// per-axis extremes of the edge pushes (the largest when they agree, all of them when they are
/// orthogonal; integer maxima, so any order gives the same result), before the pass's pairs,
/// then by the mean of its pair corrections (its own pairs and the collider's vertices). Bounded by a thickness per
/// axis and pass, and proximity alone (`edge_pair_correction`): larger edge pushes made the
/// cloth on the dense dragon scan unstable (frame 73-75 with limits of 2 and 3 thicknesses).
#[inline]
pub fn push_out(pushes: &mut [u32], i: u32, d: Vec3, limit: f32) {
    let base = (PUSH_WORDS * i) as usize;
    let mut axis = 0;
    while axis < 3 {
        let value = component_f(d, axis as u32).clamp(-limit, limit) * FIXED_SCALE;
        if value > 0.0 {
            atomics::max(&mut pushes[base + axis], value as u32);
        } else if value < 0.0 {
            atomics::max(&mut pushes[base + 3 + axis], (-value) as u32);
        }
        axis += 1;
    }
}

/// The collider edges' push on particle `i` (m).
#[inline]
fn collider_push(pushes: &[u32], i: usize) -> Vec3 {
    let base = PUSH_WORDS as usize * i;
    let axis = |k: usize| (pushes[base + k] as f32 - pushes[base + 3 + k] as f32) * (1.0 / FIXED_SCALE);
    Vec3::new(axis(0), axis(1), axis(2))
}

/// Counts particle `index` in the frame's self-contacts when a pass corrected it (its own
/// pairs or a collider feature).
#[inline]
pub fn count_self_contact(index: u32, (delta, pushes): (&[u32], &[u32]), health: &mut Health) {
    let i = index as usize;
    let base = PUSH_WORDS as usize * i;
    let pushed =
        (pushes[base] | pushes[base + 1] | pushes[base + 2]) | (pushes[base + 3] | pushes[base + 4] | pushes[base + 5]);
    let corrections = CORRECTION_WORDS as usize * i;
    let corrected = delta[corrections + 3] | delta[corrections + CROSSED_WORD + 3];
    if corrected > 0 || pushed != 0 {
        atomics::add(&mut health.self_contacts, 1);
    }
}

/// Moves particle `x[i]` by `d` and removes the velocity that points against that displacement
/// (inelastic: the contact stops the approach, adds no speed).
#[inline]
fn displace(i: usize, x: &mut [Vec4], v: &mut [Vec4], d: Vec3) {
    let length2 = d.length_squared();
    if length2 <= 0.0 {
        return;
    }
    x[i] = (x[i].xyz() + d).extend(x[i].w);
    wake_particle(&mut v[i]);
    // v minus its component against d, without normalising d (no square root: a reciprocal
    // of one rounds differently on the GPU).
    let vi = v[i].xyz();
    let approach = vi.dot(d);
    if approach < 0.0 {
        v[i] = (vi - d * (approach * (1.0 / length2))).extend(v[i].w);
    }
}

/// The mean of particle `i`'s fixed-point sums (words `4i..4i + 3`, `scale` units per unit),
/// or `None` when nothing was added.
#[inline]
pub fn mean_of(sums: &[u32], i: usize, scale: f32) -> Option<Vec3> {
    mean_at(sums, 4 * i, scale)
}

/// The mean of the fixed-point sum at words `base..base + 3` (`scale` units per unit) over its
/// count or weight (word `base + 3`), or `None` when nothing was added.
#[inline]
fn mean_at(sums: &[u32], base: usize, scale: f32) -> Option<Vec3> {
    let count = sums[base + 3];
    if count == 0 {
        return None;
    }
    // The mean in integers (exact on both sides), then scaled by a power of two (exact).
    let mean = |word: u32| ((word as i32) / count as i32) as f32;
    Some(Vec3::new(mean(sums[base]), mean(sums[base + 1]), mean(sums[base + 2])) * (1.0 / scale))
}

/// Moves particle `index` by the mean of its corrections (its own pairs and the collider's
/// vertices; `correction_of` at the cloth's `thickness`), after changing its velocity by the
/// mean of its pairs' friction.
pub fn apply_self_contact_at(
    (index, thickness): (u32, f32),
    x: &mut [Vec4],
    v: &mut [Vec4],
    (delta, velocity_changes): (&[u32], &[u32]),
) {
    let i = index as usize;
    if x[i].w == 0.0 {
        return;
    }
    if let Some(dv) = mean_of(velocity_changes, i, VELOCITY_SCALE) {
        v[i] = (v[i].xyz() + dv).extend(v[i].w);
        wake_particle(&mut v[i]);
    }
    if let Some(d) = correction_of(delta, i, thickness) {
        displace(i, x, v, d);
    }
}

/// Empties a pass's walkers (their indirect dispatch, `self_pairs::add_walker`; the host wrote
/// it so before the pass) once the collider edges' pushes move particles: the pass's second run
/// of the triangles' boxes finds them anew from where the pushes left them.
#[inline]
pub fn forget_walkers(walk_args: &mut DispatchArgs) {
    walk_args.x = 0;
    walk_args._pad = 0;
}

/// Moves particle `index` by the collider edges' push. Applied before the pass's own pair
/// search, which sweeps it with the rest of the pass's motion: a push that carried a particle
/// through a layer of cloth above it is then a crossing the pairs undo (applied after their
/// mean, the pairs never saw it).
pub fn apply_collider_push_at(index: u32, x: &mut [Vec4], v: &mut [Vec4], pushes: &[u32]) {
    let i = index as usize;
    if x[i].w == 0.0 {
        return;
    }
    displace(i, x, v, collider_push(pushes, i));
}

#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(256)))]
pub fn apply_self_contact(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &SimParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] x: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] v: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] delta: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] velocity_changes: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] pushes: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] start: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] health: &mut Health,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] self_params: &ColliderParams,
) {
    if id.x >= params.particle_count {
        return;
    }
    count_self_contact(id.x, (delta, pushes), health);
    apply_self_contact_at((id.x, self_params.thickness), x, v, (delta, velocity_changes));
    // The next pass sweeps from here.
    start[id.x as usize] = x[id.x as usize];
}

/// Each thread pushes particles `id, id + threads, ...`: dispatched like the pass's second run
/// of the triangles' boxes (`arm_second_refit`), over the cloth's triangles when a collider
/// edge pushed in the pass and over none when none did (a zero push moves nothing). The pass's
/// walkers, found by the first run before the pushes moved their triangles, are emptied
/// (`forget_walkers`): the second run finds them again.
#[spirv(compute(threads(256)))]
pub fn apply_collider_pushes(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(num_workgroups)] groups: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &SimParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] x: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] v: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] pushes: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] walk_args: &mut DispatchArgs,
) {
    if id.x == 0 {
        forget_walkers(walk_args);
    }
    let threads = groups.x * WORKGROUP_SIZE;
    let mut i = id.x;
    while i < params.particle_count {
        apply_collider_push_at(i, x, v, pushes);
        i += threads;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The standard scene's thickness (m).
    const THICKNESS: f32 = 0.005;
    const FLAT: [Vec3; 3] = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 1.0)];

    #[test]
    fn closest_point_weights_rebuild_the_point() {
        for p in
            [Vec3::new(0.2, 0.5, 0.3), Vec3::new(-1.0, 0.0, -1.0), Vec3::new(2.0, 1.0, 0.1), Vec3::new(0.6, -1.0, 0.6)]
        {
            let (q, w) = closest_with_weights(p, FLAT[0], FLAT[1], FLAT[2]);
            let rebuilt = FLAT[0] * w.x + FLAT[1] * w.y + FLAT[2] * w.z;
            assert!((q - rebuilt).length() < 1e-6 && (w.x + w.y + w.z - 1.0).abs() < 1e-6, "{p}: {q} {w}");
        }
    }

    #[test]
    fn a_vertex_within_the_thickness_is_pushed_out_and_the_face_back() {
        let p = Vec3::new(0.2, 0.001, 0.2);
        let c = pair_correction((p, p), FLAT, FLAT, (1.0, Vec3::ONE), 0.005).unwrap();
        let total_gap =
            (p + c.vertex).y - (FLAT[0].y + c.corners[0].y * 0.6 + c.corners[1].y * 0.2 + c.corners[2].y * 0.2);
        assert!(c.vertex.y > 0.0 && c.corners.iter().all(|d| d.y <= 0.0));
        assert!((total_gap - 0.005).abs() < 1e-6, "gap after {total_gap}");
        // Momentum-like balance: the vertex's push equals the corners' weighted pushes.
        let corners: f32 = c.corners.iter().map(|d| d.y).sum();
        assert!((c.vertex.y + corners).abs() < 1e-6);
        // Far away, or a pinned pair: nothing.
        assert!(pair_correction((p + Vec3::Y, p + Vec3::Y), FLAT, FLAT, (1.0, Vec3::ONE), 0.005).is_none());
        assert!(pair_correction((p, p), FLAT, FLAT, (0.0, Vec3::ZERO), 0.005).is_none());
    }

    #[test]
    fn a_vertex_that_crossed_the_face_goes_back_to_its_side() {
        let (p0, p1) = (Vec3::new(0.2, 0.01, 0.2), Vec3::new(0.2, -0.03, 0.2));
        let c = pair_correction((p0, p1), FLAT, FLAT, (1.0, Vec3::ZERO), 0.005).unwrap();
        assert!(((p1 + c.vertex).y - 0.005).abs() < 1e-6, "{:?}", c);
        // Beside the face it crossed nothing.
        let (p0, p1) = (Vec3::new(2.0, 0.01, 2.0), Vec3::new(2.0, -0.03, 2.0));
        assert!(pair_correction((p0, p1), FLAT, FLAT, (1.0, Vec3::ZERO), 0.005).is_none());
    }

    /// A collider's vertex (weight 0) counts a crossing deeper than `COLLIDER_CROSSING_DEPTH`
    /// only when it passed through the face itself within the pass: through a face pulled past
    /// a tip, yes at any depth; beside a face that only tilted over a vertex deep under it, no.
    #[test]
    fn a_collider_vertex_deep_past_a_face_counts_only_if_it_passed_through_it() {
        let limits = (0.005, COLLIDER_CROSSING_DEPTH * 0.005);
        let weights = (0.0, Vec3::ONE);
        let tip = Vec3::new(0.2, 0.0, 0.2);
        // The face pulled 3 cm down past a tip 3 mm under it.
        let then = FLAT.map(|c| c + Vec3::Y * 0.003);
        let now = FLAT.map(|c| c - Vec3::Y * 0.027);
        assert!(passed_through((tip, tip), then, now));
        let c = pair_correction_within((tip, tip), then, now, weights, limits).unwrap();
        assert!((c.push - 0.032).abs() < 1e-5, "pushed {} m", c.push);
        // The same while the face slides 70 cm along x, the tip ending beside it: it passed
        // through the face early in the pass (at 10 %, 7 cm along).
        let slid = FLAT.map(|c| c + Vec3::new(0.7, -0.027, 0.0));
        assert!(passed_through((tip, tip), then, slid));
        // A face tilting about its edge b-c over a vertex 10 cm under where it was: the vertex
        // changes sides of the face's plane beside the face, never through it.
        let deep = Vec3::new(0.9, -0.1, -0.3);
        let tilted = [Vec3::new(0.0, -0.6, 0.0), FLAT[1], FLAT[2]];
        assert!(!passed_through((deep, deep), FLAT, tilted));
        assert!(pair_correction_within((deep, deep), FLAT, tilted, weights, limits).is_none());
        // Shallow crossings over the face need no sweep; crossing beside it is nothing.
        let (p0, p1) = (Vec3::new(2.0, 0.01, 2.0), Vec3::new(2.0, -0.03, 2.0));
        assert!(!passed_through((p0, p1), FLAT, FLAT));
    }

    /// A long edge walks in segments of about `SEGMENT_CLOTH_EDGES` cloth edges, at most
    /// `MAX_EDGE_SEGMENTS`; together their boxes hold the edge's swept box, each far smaller.
    #[test]
    fn a_long_edge_walks_in_segments_whose_boxes_cover_it() {
        let slanted = Corners {
            ids: UVec4::ZERO,
            then: [Vec3::ZERO, Vec3::new(0.46, 1.86, 0.1), Vec3::X],
            now: [Vec3::new(0.0, -0.01, 0.0), Vec3::new(0.46, 1.85, 0.1), Vec3::X],
            weights: Vec3::ZERO,
        };
        let whole = slanted.swept_box(0, 1);
        let cloth_edge2 = 0.044f32 * 0.044;
        let segments = edge_segments(whole, cloth_edge2);
        assert_eq!(segments, (1.87f32 / (SEGMENT_CLOTH_EDGES * 0.044)).ceil().min(MAX_EDGE_SEGMENTS as f32) as u32);
        assert_eq!(edge_segments(whole, 1e-8), MAX_EDGE_SEGMENTS);
        assert_eq!(edge_segments(whole, 100.0), 1);
        let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for segment in 0..segments {
            let (a, b) = slanted.segment_box((0, 1), (segment, segments));
            assert!((b - a).y <= 1.87 / segments as f32 + 0.011, "segment {segment}: {a} {b}");
            (lo, hi) = (lo.min(a), hi.max(b));
        }
        assert!((lo - whole.0).abs().max_element() < 1e-6 && (hi - whole.1).abs().max_element() < 1e-6);
    }

    #[test]
    fn fixed_point_sums_are_order_independent_and_the_mean_is_applied() {
        let words = CORRECTION_WORDS as usize;
        let (mut a, mut b) = (vec![0u32; words], vec![0u32; words]);
        let ds = [Vec3::new(1e-3, -2e-3, 3e-7), Vec3::new(-4e-4, 5e-3, 0.0), Vec3::new(7e-6, 0.0, -1e-3)];
        for d in ds {
            add_correction(&mut a, 0, d, 0, THICKNESS);
        }
        for d in ds.iter().rev() {
            add_correction(&mut b, 0, *d, 0, THICKNESS);
        }
        assert_eq!(a, b);
        let mut x = vec![Vec4::new(0.0, 0.0, 0.0, 1.0)];
        let mut v = vec![Vec4::new(0.0, -1.0, 0.0, 0.0)];
        apply_self_contact_at((0, THICKNESS), &mut x, &mut v, (&a, &[0; 4]));
        // The mean weighted by length (1 + 32 per thickness, whole steps, at most 33).
        let weight = |d: Vec3| (1 + (d.length() / THICKNESS * 32.0) as u32).min(33) as f32;
        let mean = ds.iter().map(|&d| d * weight(d)).sum::<Vec3>() / ds.iter().map(|&d| weight(d)).sum::<f32>();
        assert!((x[0].truncate() - mean).length() < 1e-7, "{} against {mean}", x[0]);
        assert!(v[0].truncate().dot(mean.normalize()) >= -1e-6, "approach velocity removed: {}", v[0]);
    }

    /// A particle whose corrections include one undoing a crossing moves by those alone: a
    /// crossing's 3 mm in one mean with twenty 0.1 mm pushes the other way would move it 0.05 mm.
    #[test]
    fn a_crossing_s_correction_is_not_diluted_by_the_pushes_around_it() {
        let mut delta = vec![0u32; CORRECTION_WORDS as usize];
        let undo = Vec3::new(0.0, 3e-3, 0.0);
        add_correction(&mut delta, 0, undo, 1, THICKNESS);
        for _ in 0..20 {
            add_correction(&mut delta, 0, Vec3::new(0.0, -1e-4, 0.0), 0, THICKNESS);
        }
        assert_eq!((delta[3] > 0, delta[7]), (true, 1), "the pushes and the crossing apart");
        let moved = correction_of(&delta, 0, THICKNESS).unwrap();
        assert!((moved - undo).length() < 1e-7, "{moved}");
        // Without the crossing, the mean of all: of two equal pushes, half of each.
        let mut pushes = vec![0u32; CORRECTION_WORDS as usize];
        add_correction(&mut pushes, 0, Vec3::X * 1e-3, 0, THICKNESS);
        add_correction(&mut pushes, 0, Vec3::Y * 1e-3, 0, THICKNESS);
        assert!((correction_of(&pushes, 0, THICKNESS).unwrap() - Vec3::new(5e-4, 5e-4, 0.0)).length() < 1e-7);
    }

    /// A squeezed pair's push is not diluted by the shallow pushes around it: 1.5 mm in one
    /// plain mean with nineteen 0.05 mm pushes (pairs just inside the thickness) moved the
    /// particle 0.12 mm, against the pair's closing by 0.3 mm a frame (the second tube of the
    /// fortieth session's sweep crossed so); weighted by their lengths (10 against 1 each),
    /// 0.55 mm. Pushes that agree move it by what each asks, and none moves it farther than the
    /// largest.
    #[test]
    fn a_squeezed_pair_s_push_outweighs_the_shallow_pushes_around_it() {
        let mut delta = vec![0u32; CORRECTION_WORDS as usize];
        let deep = Vec3::new(0.0, 1.5e-3, 0.0);
        add_correction(&mut delta, 0, deep, 0, THICKNESS);
        for _ in 0..19 {
            add_correction(&mut delta, 0, Vec3::new(0.0, 5e-5, 0.0), 0, THICKNESS);
        }
        let moved = correction_of(&delta, 0, THICKNESS).unwrap();
        let plain = (deep.y + 19.0 * 5e-5) / 20.0;
        assert!(moved.y > 4.0 * plain && moved.y < deep.y, "{moved} against a plain mean of {plain}");
        let mut agreeing = vec![0u32; CORRECTION_WORDS as usize];
        for _ in 0..7 {
            add_correction(&mut agreeing, 0, deep, 0, THICKNESS);
        }
        assert!((correction_of(&agreeing, 0, THICKNESS).unwrap() - deep).length() < 1e-7);
        // Three hundred pushes three thicknesses long (past a collider feature's deepest) still
        // sum exactly; one that long weighs no more than a thickness's: with one push the
        // thickness long the other way, they meet halfway.
        let mut far = vec![0u32; CORRECTION_WORDS as usize];
        let long = Vec3::new(0.0, 0.0, -3.0 * THICKNESS);
        for _ in 0..300 {
            add_correction(&mut far, 0, long, 0, THICKNESS);
        }
        assert!((correction_of(&far, 0, THICKNESS).unwrap() - long).length() < 1e-7);
        let mut capped = vec![0u32; CORRECTION_WORDS as usize];
        add_correction(&mut capped, 0, long, 0, THICKNESS);
        add_correction(&mut capped, 0, Vec3::new(0.0, 0.0, THICKNESS), 0, THICKNESS);
        let met = correction_of(&capped, 0, THICKNESS).unwrap();
        assert!((met - Vec3::new(0.0, 0.0, -THICKNESS)).length() < 1e-7, "{met}");
    }

    /// Coulomb on the pair's relative velocity: a sliding vertex pressed onto a face loses
    /// `friction` x its approach speed of its tangential speed, or all of it once that covers
    /// it; the normal speed and the total momentum (equal masses) are untouched; nothing while
    /// the pair separates, without friction, or when every particle is pinned.
    #[test]
    fn friction_slows_a_pressed_pair_s_sliding_by_the_coefficient_times_its_approach() {
        let p = Vec3::new(0.2, 0.004, 0.2);
        let c = pair_correction((p, p), FLAT, FLAT, (1.0, Vec3::ONE), 0.005).unwrap();
        let w = Vec4::ONE;
        let g = Vec4::from_array(c.contact.coefficients);
        let relative = |v: [Vec3; 4]| v[0] * g.x + v[1] * g.y + v[2] * g.z + v[3] * g.w;
        // The vertex slides along +x at 1 m/s and sinks at 0.5 m/s; the face is still.
        let v = [Vec3::new(1.0, -0.5, 0.0), Vec3::ZERO, Vec3::ZERO, Vec3::ZERO];
        let dv = pair_friction(&c.contact, v, w, 0.4).unwrap();
        let after = relative([v[0] + dv[0], v[1] + dv[1], v[2] + dv[2], v[3] + dv[3]]);
        assert!((after.x - (1.0 - 0.4 * 0.5)).abs() < 1e-6, "{after}");
        assert!((after.y - -0.5).abs() < 1e-6 && after.z.abs() < 1e-6, "{after}");
        let momentum: Vec3 = dv.iter().copied().sum();
        assert!(momentum.length() < 1e-6, "{momentum}");
        // Pressed harder than it slides: it sticks.
        let dv = pair_friction(&c.contact, v, w, 3.0).unwrap();
        let after = relative([v[0] + dv[0], v[1] + dv[1], v[2] + dv[2], v[3] + dv[3]]);
        assert!(after.x.abs() < 1e-6 && (after.y - -0.5).abs() < 1e-6, "{after}");
        // Separating, frictionless or pinned: nothing.
        let rising = [Vec3::new(1.0, 0.5, 0.0), Vec3::ZERO, Vec3::ZERO, Vec3::ZERO];
        assert!(pair_friction(&c.contact, rising, w, 0.4).is_none());
        assert!(pair_friction(&c.contact, v, w, 0.0).is_none());
        assert!(pair_friction(&c.contact, v, Vec4::ZERO, 0.4).is_none());
        // Edge against edge: crossing edges, the upper one sliding along the lower.
        let then = [
            Vec3::new(-1.0, 0.004, 0.0),
            Vec3::new(1.0, 0.004, 0.0),
            Vec3::new(0.0, 0.0, -1.0),
            Vec3::new(0.0, 0.0, 1.0),
        ];
        let (_, contact, _) = edge_pair_correction(then, then, w, 0.005, true).unwrap();
        let slide = Vec3::new(0.0, -0.1, 1.0);
        let dv = pair_friction(&contact, [slide, slide, Vec3::ZERO, Vec3::ZERO], w, 0.5).unwrap();
        let g = Vec4::from_array(contact.coefficients);
        let after = (slide + dv[0]) * g.x + (slide + dv[1]) * g.y + dv[2] * g.z + dv[3] * g.w;
        assert!((after.z - (1.0 - 0.5 * 0.1)).abs() < 1e-5 && (after.y - -0.1).abs() < 1e-6, "{after}");
    }

    #[test]
    fn a_fold_measures_how_far_from_flat_the_surface_turns_at_an_edge() {
        let (a, b) = (Vec3::ZERO, Vec3::X);
        let apex = Vec3::new(0.5, 0.0, 1.0);
        // Coplanar, on opposite sides: flat; either winding of the neighbour alike.
        assert!(fold(a, b, apex, Vec3::new(0.3, 0.0, -2.0)).abs() < 1e-6);
        assert!(fold(b, a, apex, Vec3::new(0.3, 0.0, -2.0)).abs() < 1e-6);
        // A right angle, up or down (convex or concave): 1; folded shut: 2.
        assert!((fold(a, b, apex, Vec3::new(0.5, 1.0, 0.0)) - 1.0).abs() < 1e-6);
        assert!((fold(a, b, apex, Vec3::new(0.5, -1.0, 0.0)) - 1.0).abs() < 1e-6);
        assert!((fold(a, b, apex, Vec3::new(0.9, 0.0, 3.0)) - 2.0).abs() < 1e-6);
        // A fold of angle f: 1 - cos f (about f^2 / 2).
        let f = 0.1f32;
        let across = Vec3::new(0.5, -f.sin(), -f.cos());
        assert!((fold(a, b, apex, across) - (1.0 - f.cos())).abs() < 1e-6);
        assert!((fold(a, b, apex, across) - f * f / 2.0).abs() < 0.01 * f * f);
        // Degenerate: folded shut (always tested).
        assert_eq!(fold(a, a, apex, across), 2.0);
        assert_eq!(fold(a, b, Vec3::new(0.3, 0.0, 0.0), across), 2.0);
    }

    #[test]
    fn an_edge_pushes_a_cloth_edge_only_where_its_fold_could_bring_it_within_half_the_thickness() {
        // Cloth edges of 2 cm, thickness 5 mm: folds of at least 2 t / L = 0.5 rad push.
        let (length2, t) = (0.02f32 * 0.02, 0.005);
        let fold_of = |angle: f32| 1.0 - angle.cos();
        assert!(sharp_for(fold_of(0.55), length2, t));
        assert!(!sharp_for(fold_of(0.45), length2, t));
        // A coarser cloth needs a flatter fold to dip as far; a boundary (2) always pushes.
        assert!(sharp_for(fold_of(0.3), 4.0 * length2, t));
        assert!(sharp_for(2.0, 1e-6, t));
    }

    /// A pair is measured at rest by its closest points: a vertex 0.3 from a face's edge (off
    /// the face, in its plane) and two edges 0.3 apart touch at rest under a thickness of 0.31
    /// and not of 0.29; where the pair lies now does not enter.
    #[test]
    fn a_pair_touched_at_rest_by_the_distance_of_its_rest_shape() {
        let rest = [
            Vec4::new(0.0, 0.0, 0.0, 1.0),
            Vec4::new(1.0, 0.0, 0.0, 1.0),
            Vec4::new(0.0, 0.0, 1.0, 1.0),
            Vec4::new(0.5, 0.0, -0.3, 1.0), // 0.3 beyond edge 0-1, in the face's plane
            Vec4::new(0.5, 0.0, -1.0, 1.0),
        ];
        let face = UVec4::new(0, 1, 2, 0);
        assert!(touched_at_rest_vertex_face(&rest, 3, face, 0.31));
        assert!(!touched_at_rest_vertex_face(&rest, 3, face, 0.29));
        // Edge 0-1 against edge 3-4, which points away from it: 0.3 apart at its end.
        assert!(touched_at_rest_edges(&rest, UVec4::new(0, 1, 3, 4), 0.31));
        assert!(!touched_at_rest_edges(&rest, UVec4::new(0, 1, 3, 4), 0.29));
        assert!(!touched_at_rest_edges(&rest, UVec4::new(0, 2, 3, 4), 0.31), "0.58 apart");
    }
}
