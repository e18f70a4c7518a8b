//! A cloth's self-collision pairs listed once per frame (the broad phase), tested at every pass
//! (the narrow phase), as the collider's contact does (`candidates`):
//! - **at the frame's start** each particle gets an anchor: where it is, where its velocity
//!   takes it by the frame's end, and a slop (`anchor_at`). The tree is built over each
//!   triangle's box at the start grown by its corners' slops, with the box of its corners'
//!   motions beside it (`RelativeMotion`), and every triangle
//!   lists the later triangles (tree order) it could touch within the frame, with the primitive
//!   pairs (vertex-face, edge-edge) that could: those whose distance at the frame's start,
//!   less their relative predicted motion and their slops, is below the thickness
//!   (`list_self_pairs_at`). On a cloth lying flat that leaves its neighbours out: a vertex is
//!   an edge's length from the faces around it, while the walk's boxes meet.
//! - **at each pass** a triangle whose corners all stayed within their slop of their predicted
//!   path (`escaped_at`) tests only its list, skipping partners that escaped; one that escaped
//!   walks the tree (refit to the pass) for its later leaves and for the earlier ones that do not
//!   walk themselves, and one whose list overflowed walks for its later leaves
//!   (`walk_self_pairs_at`, `listed_self_pairs_at`). Each pair of triangles is so handled once, always with the earlier leaf
//!   first, and gives the walk's result: a primitive pair left out of a list stays apart by more
//!   than the thickness over the whole frame while its corners stay within their slops.
//!
//! A frame's lists may also be built again after a pass (`anchor_window_at`, the host's
//! `window_start_steps`): each particle is anchored from where it is then over the rest of the
//! window, the tree (its topology and Morton box the frame's) refit to the new start boxes, and
//! the passes' spans measured in the window. A fast cloth leaves its predicted region within a
//! frame (half the bunny's drape walked the tree in each pass); from halfway its prediction is
//! twice as close. The pairs found stay the tree walk's, so the results are those of lists
//! built once (the bunny's 60 frames equal bit for bit).
//!
//! The bound: a corner's position is within its slop of its predicted path at every pass's
//! ends (checked) and so in between (both move linearly within a pass); a point of a face or an
//! edge is a weighted mean of its corners, so it is within the largest of their slops of its
//! own predicted path; and two predicted paths part by at most the largest difference of their
//! corners' predicted motions.

use crate::atomics;
use crate::lbvh::{PairBoxes, PairWalk, REFIT_THREADS, WALK_BATCH};
use crate::self_contact::{
    Corners, PairResponse, SelfTree, TrianglePairs, closest_with_weights, collapsed, frame_of, longest_side2,
    pair_mask, place_cloth_triangle, segments_offset, self_triangle_contact_at, triangle_pair, triangle_query,
};
use drape_types::glam::{UVec3, UVec4, Vec3, Vec4, Vec4Swizzles};
use drape_types::{
    Aabb, BvhNode, ColliderParams, DispatchArgs, Health, SelfAnchorPush, SelfListPush, SelfPassPush, SimParams,
    WalkNode,
};
use spirv_std::spirv;

/// Pairs of triangles one triangle's list holds at most (`LIST_ENTRY_WORDS` each).
pub const SELF_LIST_CAPACITY: u32 = 24;
/// Words of a list's entry: the later leaf, the primitive pairs' bits (`self_contact::pair_mask`),
/// the smallest gap of those pairs and their smallest distance at the list's start (f32 bits,
/// `pairs_that_may_touch`; a pass bounds the pairs' distance by them, `gap_by`).
pub const LIST_ENTRY_WORDS: u32 = 4;
/// A list's count when its pairs did not fit (the triangle walks the tree at every pass).
pub const LIST_OVERFLOWED: u32 = u32::MAX;
/// A particle's slop: this share of the thickness, plus `SLOP_MOTION` of its velocity's motion
/// over the frame. Larger slops list more pairs; smaller
/// ones send more triangles walking. Neither changes a result.
pub const SLOP_THICKNESS: f32 = 0.5;
pub const SLOP_MOTION: f32 = 0.05;
/// How much nearer than the thickness a listed pair's bound must come (the distances are
/// rounded; the margin keeps the bound conservative).
const REACH_MARGIN: f32 = 1.01;
const REACH_ABSOLUTE: f32 = 1e-5;

/// Words per particle of the anchors (`anchor_at`): the prediction (words 0-2, which a window's
/// re-anchoring rewrites, `anchor_window_at`) and where the particle started the frame
/// (`FRAME_START_WORD`, the fail-safe's start).
pub const ANCHOR_WORDS: u32 = 4;
/// The anchors' word holding where the particle started the frame (xyz).
pub const FRAME_START_WORD: u32 = 3;
/// The anchors' word holding gravity's share of the predicted path over the span (xyz; the same
/// for every particle).
pub const FALL_WORD: u32 = 2;

/// Particle `i`'s anchor for a frame of `frame_time` seconds (words `ANCHOR_WORDS * i..` of
/// `anchors`): its position and slop, its velocity's motion over the frame and gravity's: its
/// predicted path is `start + motion t + fall t^2` at fraction t of the frame.
#[inline]
pub fn anchor_at(i: u32, (x, v): (&[Vec4], &[Vec4]), frame: (f32, Vec3, f32), anchors: &mut [Vec4]) {
    anchor_window_at(i, (x, v), frame, anchors);
    anchors[(ANCHOR_WORDS * i + FRAME_START_WORD) as usize] = x[i as usize];
}

/// Particle `i`'s prediction over a window of `frame_time` seconds from where it is now (words
/// 0-2 of its anchor, as `anchor_at`; its frame start stays).
#[inline]
pub fn anchor_window_at(i: u32, (x, v): (&[Vec4], &[Vec4]), window: (f32, Vec3, f32), anchors: &mut [Vec4]) {
    let anchor = Anchor::predict(i, (x, v), window);
    let base = (ANCHOR_WORDS * i) as usize;
    anchors[base] = anchor.start.extend(anchor.slop);
    anchors[base + 1] = anchor.motion.extend(0.0);
    anchors[base + FALL_WORD as usize] = anchor.fall.extend(0.0);
}

/// Anchors of particles `lane, lane + stride, ...` over `window` (`anchor_at`), and their
/// bounds at their starts and at their predicted ends over the whole `frame` (the Morton box
/// of the frame's tree: the same whichever window the anchors span).
pub fn anchor_particles(
    (x, v): (&[Vec4], &[Vec4]),
    (window, frame): ((f32, Vec3, f32), (f32, Vec3, f32)),
    anchors: &mut [Vec4],
    count: u32,
    (lane, stride): (u32, u32),
) -> Aabb {
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    let mut i = lane;
    while i < count {
        anchor_at(i, (x, v), window, anchors);
        let whole = Anchor::predict(i, (x, v), frame);
        let end = whole.at(1.0);
        lo = lo.min(whole.start).min(end);
        hi = hi.max(whole.start).max(end);
        i += stride;
    }
    Aabb { min: lo.extend(0.0), max: hi.extend(0.0) }
}

/// A particle's anchor (`anchor_at`).
#[derive(Copy, Clone)]
struct Anchor {
    start: Vec3,
    motion: Vec3,
    fall: Vec3,
    slop: f32,
}

impl Anchor {
    /// Particle `i`'s prediction over `frame_time` seconds from where it is now.
    #[inline]
    fn predict(i: u32, (x, v): (&[Vec4], &[Vec4]), (frame_time, gravity, thickness): (f32, Vec3, f32)) -> Self {
        let i = i as usize;
        let motion = v[i].xyz() * frame_time;
        let slop = SLOP_THICKNESS * thickness + SLOP_MOTION * motion.length();
        // Gravity's share of the motion: the same for every particle, so it parts no pair.
        let fall = gravity * (0.5 * frame_time * frame_time);
        Anchor { start: x[i].xyz(), motion, fall, slop }
    }

    #[inline]
    fn load(i: u32, anchors: &[Vec4]) -> Self {
        let base = (ANCHOR_WORDS * i) as usize;
        let (a, m, f) = (anchors[base], anchors[base + 1], anchors[base + 2]);
        Anchor { start: a.xyz(), motion: m.xyz(), fall: f.xyz(), slop: a.w }
    }

    /// The predicted position at fraction `t` of the frame.
    #[inline]
    fn at(&self, t: f32) -> Vec3 {
        self.start + self.motion * t + self.fall * (t * t)
    }

    /// Whether `p`, at fraction `t` of the frame, is within the slop and `beyond` of the
    /// predicted path.
    #[inline]
    fn holds(&self, p: Vec3, t: f32, beyond: f32) -> bool {
        let reach = self.slop + beyond;
        (p - self.at(t)).length_squared() <= reach * reach
    }

    /// How far `p`, at fraction `t` of the frame, is from the predicted path.
    #[inline]
    fn stray(&self, p: Vec3, t: f32) -> f32 {
        (p - self.at(t)).length()
    }
}

/// How far apart a list takes two still primitives to be near: the thickness and both ends'
/// slops at rest (`SLOP_THICKNESS` each).
#[inline]
pub fn list_reach(thickness: f32) -> f32 {
    thickness * (1.0 + 2.0 * SLOP_THICKNESS)
}

/// A triangle's corners' particles and anchors.
#[derive(Copy, Clone)]
struct AnchoredTriangle {
    ids: [u32; 3],
    corners: [Anchor; 3],
}

/// Boxes of some of a triangle's corners: at the frame's start grown by their slops, and of
/// their predicted motions (what `moving_boxes_meet` takes).
type MovingBoxes = ((Vec3, Vec3), (Vec3, Vec3));

impl AnchoredTriangle {
    #[inline]
    fn load(ids: UVec4, anchors: &[Vec4]) -> Self {
        let corners = [Anchor::load(ids.x, anchors), Anchor::load(ids.y, anchors), Anchor::load(ids.z, anchors)];
        AnchoredTriangle { ids: [ids.x, ids.y, ids.z], corners }
    }

    /// The boxes of corners `k` and `m` (one corner's when `k == m`).
    #[inline]
    fn boxes_of(&self, k: usize, m: usize) -> MovingBoxes {
        let (a, b) = (self.corners[k], self.corners[m]);
        let start = (
            (a.start - Vec3::splat(a.slop)).min(b.start - Vec3::splat(b.slop)),
            (a.start + Vec3::splat(a.slop)).max(b.start + Vec3::splat(b.slop)),
        );
        (start, (a.motion.min(b.motion), a.motion.max(b.motion)))
    }

    /// The boxes of the whole triangle.
    #[inline]
    fn boxes3(&self) -> MovingBoxes {
        let ((lo, hi), (motion_lo, motion_hi)) = self.boxes_of(0, 1);
        let c = self.corners[2];
        let slop = Vec3::splat(c.slop);
        ((lo.min(c.start - slop), hi.max(c.start + slop)), (motion_lo.min(c.motion), motion_hi.max(c.motion)))
    }

    /// Whether the triangle is too small for a list to pay: its shortest height (a corner to
    /// the opposite edge, on a flat cloth the distance from a vertex to the faces beside it) is
    /// within the thickness and two slops, so its neighbours' primitives would fill the list at
    /// rest. It walks the tree at every pass instead (as a triangle whose list overflowed);
    /// without this, a 128^2 cloth of 1 m (7.8 mm edges) at 5 mm spent more on its lists than
    /// its walks cost.
    #[inline]
    fn too_small_for(&self, thickness: f32) -> bool {
        let [a, b, c] = self.corners;
        let area2 = (b.start - a.start).cross(c.start - a.start).length_squared(); // (2 area)^2
        let reach = list_reach(thickness);
        // height = 2 area / longest side, compared squared and without a division.
        area2 < reach * reach * longest_side2(a.start, b.start, c.start)
    }

    #[inline]
    fn has(&self, id: u32) -> bool {
        self.ids[0] == id || self.ids[1] == id || self.ids[2] == id
    }

    #[inline]
    fn largest_slop(&self) -> f32 {
        self.corners[0].slop.max(self.corners[1].slop).max(self.corners[2].slop)
    }
}

/// Cloth triangle `t`'s box at the frame's start, each corner grown by its slop (the frame's
/// tree is built over these; with `triangle_motion_at` they bound where the triangle can be
/// relative to another over the frame, `RelativeMotion`).
#[inline]
pub fn triangle_start_at(t: u32, anchors: &[Vec4], indices: &[u32]) -> Aabb {
    let i = 3 * t as usize;
    let ids = UVec4::new(indices[i], indices[i + 1], indices[i + 2], t);
    aabb_of(AnchoredTriangle::load(ids, anchors).boxes3().0)
}

/// The box of the predicted motions over the frame of triangle `ids`' corners (xyz; gravity's
/// share, the same for every particle, left out): every point of the triangle moves by a
/// weighted mean of them.
#[inline]
pub fn triangle_motion_at(ids: UVec4, anchors: &[Vec4]) -> Aabb {
    aabb_of(AnchoredTriangle::load(ids, anchors).boxes3().1)
}

#[inline]
fn aabb_of((lo, hi): (Vec3, Vec3)) -> Aabb {
    Aabb { min: lo.extend(0.0), max: hi.extend(0.0) }
}

/// The frame's tree as a list's walk tests it: a subtree may hold a triangle that comes within
/// the thickness of the query's in the frame when its start box, moved by any fraction t of
/// the frame of any difference between its motions and the query's, meets the query's start
/// box grown by the thickness. Two points' predicted paths differ by (start difference) +
/// t (motion difference) (gravity's share is common), and each point stays within its slop of
/// its path, which the start boxes include. Neighbours on a cloth move alike, so this finds
/// about the triangles near the query at the frame's start, where boxes swept over the frame
/// (a free edge moving 4-7 cm a frame, 3-4 triangles) met 2-3x as many.
#[derive(Copy, Clone)]
struct RelativeMotion<'a> {
    /// Internal nodes' start boxes and motion boxes, packed (`WalkNode`), and their frames.
    walk_nodes: &'a [WalkNode],
    frames: (Quantizer, Quantizer),
    /// Leaves' start boxes and motion boxes (tree order).
    leaf_bounds: &'a [Aabb],
    leaf_motions: &'a [Aabb],
    /// The query triangle's start box and motion box, and the thickness.
    query: MovingBoxes,
    thickness: f32,
}

impl RelativeMotion<'_> {
    /// Whether a start box `start` whose motions lie in `motion` meets the query (the test a
    /// list's primitive pairs start with, on the triangles' boxes).
    #[inline]
    fn meets(&self, start: &Aabb, motion: &Aabb) -> bool {
        let theirs = ((start.min.xyz(), start.max.xyz()), (motion.min.xyz(), motion.max.xyz()));
        moving_boxes_meet(self.query, theirs, self.thickness)
    }
}

impl PairBoxes for RelativeMotion<'_> {
    /// The node's start box and motion box, each holding the node's own.
    type NodeBoxes = MovingBoxes;

    #[inline]
    fn node_boxes(&self, node: u32) -> MovingBoxes {
        unpack_walk_node(&self.walk_nodes[node as usize], self.frames)
    }

    #[inline]
    fn node_meets(&self, boxes: &MovingBoxes) -> bool {
        moving_boxes_meet(self.query, *boxes, self.thickness)
    }

    #[inline]
    fn leaf_meets(&self, leaf: u32) -> bool {
        self.meets(&self.leaf_bounds[leaf as usize], &self.leaf_motions[leaf as usize])
    }

    /// One load of the packed node for its boxes and links.
    #[inline]
    fn step(&self, _nodes: &[BvhNode], index: u32) -> (bool, u32, u32) {
        let packed = self.walk_nodes[index as usize];
        let enters = self.node_meets(&unpack_walk_node(&packed, self.frames));
        (enters, packed.motions_and_links.z, packed.motions_and_links.w)
    }
}

/// A 16-bit fixed-point frame over a box (`WalkNode`): coordinates are steps of 1/65534 of its
/// extent from its min. A box is written with its min rounded down and its max up, and read
/// back grown by `margin` steps, which covers f32's rounding of coordinates as large as the
/// box's (far from the origin a step is finer than an f32 there): the box read back holds the
/// box written, so a walk over read-back boxes enters every node it would have.
#[derive(Copy, Clone, Debug)]
pub struct Quantizer {
    lo: Vec3,
    step: Vec3,
    margin: Vec3,
}

const QUANTA: f32 = 65534.0;

impl Quantizer {
    /// The frame over `root` (a tree's root box, which holds every node's).
    #[inline]
    pub fn over(root: &Aabb) -> Self {
        let (lo, hi) = (root.min.xyz(), root.max.xyz());
        let step = ((hi - lo) * (1.0 / QUANTA)).max(Vec3::splat(1e-30));
        // Per axis: an axis the boxes barely span has fine steps, which its own rounding
        // needs many of, and another's must not take as many of its own.
        let largest = lo.abs().max(hi.abs());
        let margin = Vec3::splat(2.0) + (largest * (4.0 * f32::EPSILON) / step).ceil();
        Quantizer { lo, step, margin }
    }

    #[inline]
    fn steps(&self, v: Vec3) -> Vec3 {
        ((v - self.lo) / self.step).clamp(Vec3::ZERO, Vec3::splat(65535.0))
    }

    /// `v` in steps, rounded down.
    #[inline]
    pub fn below(&self, v: Vec3) -> UVec3 {
        let s = self.steps(v).floor();
        UVec3::new(s.x as u32, s.y as u32, s.z as u32)
    }

    /// `v` in steps, rounded up.
    #[inline]
    pub fn above(&self, v: Vec3) -> UVec3 {
        let s = self.steps(v).ceil();
        UVec3::new(s.x as u32, s.y as u32, s.z as u32)
    }

    /// A min written as `q` (`below`), read back at or under the min written.
    #[inline]
    pub fn min_of(&self, q: UVec3) -> Vec3 {
        self.lo + (Vec3::new(q.x as f32, q.y as f32, q.z as f32) - self.margin) * self.step
    }

    /// A max written as `q` (`above`), read back at or over the max written.
    #[inline]
    pub fn max_of(&self, q: UVec3) -> Vec3 {
        self.lo + (Vec3::new(q.x as f32, q.y as f32, q.z as f32) + self.margin) * self.step
    }
}

/// Internal node `i` of the frame's tree packed for the lists' walk (`WalkNode`): its start
/// box (`aabbs`) and motion box (`motion_aabbs`) over the root's, its left child and escape.
#[inline]
pub fn pack_walk_node_at(
    i: u32,
    nodes: &[BvhNode],
    (aabbs, motion_aabbs): (&[Aabb], &[Aabb]),
    walk_nodes: &mut [WalkNode],
) {
    let (start, motion) = (Quantizer::over(&aabbs[0]), Quantizer::over(&motion_aabbs[0]));
    let (b, m) = (aabbs[i as usize], motion_aabbs[i as usize]);
    let (lo, hi) = (start.below(b.min.xyz()), start.above(b.max.xyz()));
    let (mlo, mhi) = (motion.below(m.min.xyz()), motion.above(m.max.xyz()));
    let node = nodes[i as usize];
    walk_nodes[i as usize] = WalkNode {
        boxes: UVec4::new(lo.x | (lo.y << 16), lo.z | (hi.x << 16), hi.y | (hi.z << 16), mlo.x | (mlo.y << 16)),
        motions_and_links: UVec4::new(mlo.z | (mhi.x << 16), mhi.y | (mhi.z << 16), node.left, node.escape),
    };
}

/// A packed node's start box and motion box (`pack_walk_node_at`), each holding the node's own.
#[inline]
fn unpack_walk_node(packed: &WalkNode, (start, motion): (Quantizer, Quantizer)) -> MovingBoxes {
    let (b, r) = (packed.boxes, packed.motions_and_links);
    let low = |w: u32| w & 0xffff;
    let lo = UVec3::new(low(b.x), b.x >> 16, low(b.y));
    let hi = UVec3::new(b.y >> 16, low(b.z), b.z >> 16);
    let mlo = UVec3::new(low(b.w), b.w >> 16, low(r.x));
    let mhi = UVec3::new(r.x >> 16, low(r.y), r.y >> 16);
    ((start.min_of(lo), start.max_of(hi)), (motion.min_of(mlo), motion.max_of(mhi)))
}

/// Whether the bound says a pair of primitives whose *gap* (their distance at the frame's
/// start less the largest difference of their points' predicted motions) is `gap`, and whose
/// points stray at most `strays` (together) from their predicted paths, may come within
/// `thickness` in the frame: with the slops at the frame's start, with the strays measured at
/// a pass (`listed_self_pairs_at`).
#[inline]
pub(crate) fn may_touch(gap: f32, strays: f32, thickness: f32) -> bool {
    gap - strays < thickness * REACH_MARGIN + REACH_ABSOLUTE
}

/// A primitive pair the bound keeps: its gap (its distance at the frame's start less the
/// largest difference of its points' predicted motions), that motion and its approach
/// (`PairMotion`).
#[derive(Copy, Clone)]
struct KeptPair {
    gap: f32,
    /// Its distance at the frame's start.
    distance: f32,
    motion: PairMotion,
}

/// A primitive pair the bound leaves out.
const LEFT_OUT: KeptPair =
    KeptPair { gap: f32::INFINITY, distance: f32::INFINITY, motion: PairMotion { motion: 0.0, approach: 0.0 } };

/// The gap of a list entry's pairs by fraction `to` of the list's span (their distance less their
/// relative predicted motion up to then), from their smallest gap over the span (`gap`, at its
/// end) and their smallest distance at its start: each pair's predicted distance falls at most
/// linearly (its ends' relative predicted paths are straight: gravity's share is every
/// particle's), so the smallest of them, a minimum of falling lines, stays above the chord
/// between its ends. A pass ending at `to` tests only the pairs this lets come within the
/// thickness; at the span's end it is the gap itself.
#[inline]
pub fn gap_by(to: f32, gap: f32, distance: f32) -> f32 {
    gap + (1.0 - to) * (distance - gap)
}

/// The largest of the relative motions `moves` (a pair's points move by weighted means of them).
#[inline]
fn longest(moves: [Vec3; 4]) -> f32 {
    moves[0].length().max(moves[1].length()).max(moves[2].length()).max(moves[3].length())
}

/// A primitive pair's `KeptPair` when the bound keeps it (`may_touch` with the slops), else
/// `LEFT_OUT`, from `offset` (the vector between its closest points at the frame's start) and
/// the relative predicted motions of its ends (`moves`: of the vertex from each corner of the
/// face, a vertex-face pair repeating one, or of each end of one edge from each of the other's;
/// each point of the pair moves by a weighted mean of them, so the longest of them is the
/// pair's motion). The gap takes the whole motion, in any direction: the
/// passes also undo crossings of pairs that never came near (a vertex passing round a face's
/// edge to end under it), and the lists keep what a walk over the passes' boxes finds.
#[inline]
fn kept_pair(offset: Vec3, moves: [Vec3; 4], (slops, thickness): (f32, f32)) -> KeptPair {
    let (distance, motion) = (offset.length(), longest(moves));
    let gap = distance - motion;
    if !may_touch(gap, slops, thickness) {
        return LEFT_OUT;
    }
    KeptPair { gap, distance, motion: PairMotion { motion, approach: approach(offset, (distance, motion), moves) } }
}

/// How far a pair apart by `offset` (`distance` long) at the frame's start closes along that
/// direction over the frame, at most `motion`: each end moves linearly, and a point of the
/// pair by a weighted mean of its ends' `moves`, so no further than the most of them (a
/// separating axis). A free corner whipping past the cloth closes little of its speed on the
/// faces it passes: the 64^2 swing, which never touches itself, ran 28 substeps where the
/// bound takes 14 when its passes followed the whole motion. It bounds the closing over the
/// frame, not where a pass ends: a pair converging sideways may cross within a pass, which the
/// passes' start-side tests and the fail-safe undo (so a cloth touching itself plans from the
/// whole motion, `motion::ClothMotion`).
#[inline]
fn approach(offset: Vec3, (distance, motion): (f32, f32), moves: [Vec3; 4]) -> f32 {
    if distance <= 0.0 {
        return motion;
    }
    let axis = offset * (1.0 / distance);
    // An end closes by minus its move along the axis.
    let least = axis.dot(moves[0]).min(axis.dot(moves[1])).min(axis.dot(moves[2])).min(axis.dot(moves[3]));
    // (Not `(-least).clamp(..)`: a pair only sliding would give -0.0, whose bits win the
    // health record's integer max.)
    if least < 0.0 { (-least).min(motion) } else { 0.0 }
}

/// Whether points in boxes `a` and `b` (`MovingBoxes`) may come within `thickness` at some
/// fraction of the frame (the bound's cheap first test, `RelativeMotion`'s for primitives).
#[inline]
fn moving_boxes_meet(a: MovingBoxes, b: MovingBoxes, thickness: f32) -> bool {
    let reach = Vec3::splat(thickness * REACH_MARGIN + REACH_ABSOLUTE);
    let (((a_lo, a_hi), (a_motion_lo, a_motion_hi)), ((b_lo, b_hi), (b_motion_lo, b_motion_hi))) = (a, b);
    let moved_lo = (b_motion_lo - a_motion_hi).min(Vec3::ZERO);
    let moved_hi = (b_motion_hi - a_motion_lo).max(Vec3::ZERO);
    (a_lo - reach - moved_hi).cmple(b_hi).all() && (a_hi + reach - moved_lo).cmpge(b_lo).all()
}

/// Corner `k` of `vertex` against the face of `face`, at the frame's start (never when the
/// corner is one of the face's: the pass skips those): `kept_pair`.
#[inline]
fn vertex_face_pair(vertex: &AnchoredTriangle, k: usize, face: &AnchoredTriangle, thickness: f32) -> KeptPair {
    if face.has(vertex.ids[k]) || !moving_boxes_meet(vertex.boxes_of(k, k), face.boxes3(), thickness) {
        return LEFT_OUT;
    }
    let p = vertex.corners[k];
    let [a, b, c] = face.corners;
    let area2 = (b.start - a.start).cross(c.start - a.start).length_squared();
    let side2 = longest_side2(a.start, b.start, c.start);
    let moves = [p.motion - a.motion, p.motion - b.motion, p.motion - c.motion, p.motion - c.motion];
    if collapsed(area2, side2) {
        // No closest point to measure from a collapsed face: kept.
        let motion = longest(moves);
        let gap = f32::NEG_INFINITY;
        return KeptPair { gap, distance: gap, motion: PairMotion { motion, approach: motion } };
    }
    let (q, _) = closest_with_weights(p.start, a.start, b.start, c.start);
    kept_pair(p.start - q, moves, (p.slop + face.largest_slop(), thickness))
}

/// Edge `k` of `e` against edge `m` of `f`, at the frame's start (never when they share a
/// particle: the pass skips those): `kept_pair`.
#[inline]
fn edges_pair(e: &AnchoredTriangle, k: usize, f: &AnchoredTriangle, m: usize, thickness: f32) -> KeptPair {
    let (ea, eb, fa, fb) = (e.ids[k], e.ids[(k + 1) % 3], f.ids[m], f.ids[(m + 1) % 3]);
    if ea == fa || ea == fb || eb == fa || eb == fb {
        return LEFT_OUT;
    }
    if !moving_boxes_meet(e.boxes_of(k, (k + 1) % 3), f.boxes_of(m, (m + 1) % 3), thickness) {
        return LEFT_OUT;
    }
    let (a, b) = (e.corners[k], e.corners[(k + 1) % 3]);
    let (c, d) = (f.corners[m], f.corners[(m + 1) % 3]);
    let offset = segments_offset(a.start, b.start, c.start, d.start);
    let moves = [a.motion - c.motion, a.motion - d.motion, b.motion - c.motion, b.motion - d.motion];
    let slops = a.slop.max(b.slop) + c.slop.max(d.slop);
    kept_pair(offset, moves, (slops, thickness))
}

/// The largest relative predicted motion and the largest approach over the frame of the
/// primitive pairs a list kept (`KeptPair`): what the passes must resolve
/// (`Health::self_pair_motion_bits`, `Health::self_pair_approach_bits`).
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct PairMotion {
    pub motion: f32,
    pub approach: f32,
}

impl PairMotion {
    /// The motion over a window scaled to the frame (`SelfListPush::to_frame`).
    #[inline]
    pub fn per_frame(self, to_frame: f32) -> PairMotion {
        PairMotion { motion: self.motion * to_frame, approach: self.approach * to_frame }
    }

    #[inline]
    fn max(self, other: PairMotion) -> PairMotion {
        PairMotion { motion: self.motion.max(other.motion), approach: self.approach.max(other.approach) }
    }
}

/// The primitive pairs of `mask` (`self_contact::pair_mask`) between triangles `a` (the
/// earlier) and `b` that may touch within the frame, the smallest of their gaps and of their
/// distances at the frame's start (what a pass compares with the strays it measures:
/// `listed_self_pairs_at`, `gap_by`) and their largest motion and approach (`PairMotion`).
#[inline]
fn pairs_that_may_touch(
    a: &AnchoredTriangle,
    b: &AnchoredTriangle,
    mask: u32,
    thickness: f32,
) -> (u32, (f32, f32), PairMotion) {
    let mut kept = 0;
    let mut smallest = f32::INFINITY;
    let mut closest = f32::INFINITY;
    let mut fastest = PairMotion::default();
    // Written out pair by pair, so every corner index is a constant: one indexed by a loop's
    // counter keeps both triangles in memory, and llvmpipe loads from there lane by lane.
    macro_rules! pair {
        ($bit:literal, $pair:expr) => {
            if mask & (1 << $bit) != 0 {
                let pair = $pair;
                if pair.gap < f32::INFINITY {
                    kept |= 1 << $bit;
                    smallest = smallest.min(pair.gap);
                    closest = closest.min(pair.distance);
                    fastest = fastest.max(pair.motion);
                }
            }
        };
    }
    // Bits 0-2: a's corners against b's face; 3-5: b's against a's; 6 + 3 m + k: a's edge m
    // against b's edge k (`self_contact::pair_mask`).
    pair!(0, vertex_face_pair(a, 0, b, thickness));
    pair!(1, vertex_face_pair(a, 1, b, thickness));
    pair!(2, vertex_face_pair(a, 2, b, thickness));
    pair!(3, vertex_face_pair(b, 0, a, thickness));
    pair!(4, vertex_face_pair(b, 1, a, thickness));
    pair!(5, vertex_face_pair(b, 2, a, thickness));
    pair!(6, edges_pair(a, 0, b, 0, thickness));
    pair!(7, edges_pair(a, 0, b, 1, thickness));
    pair!(8, edges_pair(a, 0, b, 2, thickness));
    pair!(9, edges_pair(a, 1, b, 0, thickness));
    pair!(10, edges_pair(a, 1, b, 1, thickness));
    pair!(11, edges_pair(a, 1, b, 2, thickness));
    pair!(12, edges_pair(a, 2, b, 0, thickness));
    pair!(13, edges_pair(a, 2, b, 1, thickness));
    pair!(14, edges_pair(a, 2, b, 2, thickness));
    (kept, (smallest, closest), fastest)
}

/// What a list keeps of sorted leaves `leaf` and `other` (`leaf` < `other`): the primitive pairs
/// that may touch within the frame, their smallest gap and their smallest distance at the
/// frame's start (`pairs_that_may_touch`; no mask bits: none), without the tree. The baseline a
/// list's walk must equal.
pub fn listed_pair_bound(
    (leaf, other): (u32, u32),
    thickness: f32,
    (sorted, owned, anchors): (&[UVec4], &[u32], &[Vec4]),
) -> (u32, (f32, f32)) {
    let (mine, theirs) = (sorted[leaf as usize], sorted[other as usize]);
    let mask = pair_mask(owned[mine.w as usize], owned[theirs.w as usize]);
    let (a, b) = (AnchoredTriangle::load(mine, anchors), AnchoredTriangle::load(theirs, anchors));
    let (kept, gaps, _) = pairs_that_may_touch(&a, &b, mask, thickness);
    (kept, gaps)
}

/// Sorted leaf `leaf`'s list for the frame (`lists[LIST_ENTRY_WORDS * SELF_LIST_CAPACITY * leaf..]`, count in
/// `counts[leaf]`): the later leaves that may come within the thickness in the frame
/// (`RelativeMotion`), with the primitive pairs that may touch, found by one walk of the frame's
/// tree (built over the start boxes, `motions` its motion boxes: internal nodes', leaves'; the
/// internal nodes' read packed, `walk_nodes`: `pack_walk_node_at`).
/// Returns the largest motion and approach over the frame of the primitive pairs it found
/// (listed or not: `PairMotion`).
#[allow(clippy::too_many_arguments)]
pub fn list_self_pairs_at(
    leaf: u32,
    self_params: &ColliderParams,
    (nodes, aabbs, leaf_bounds, sorted): SelfTree<'_>,
    (motion_aabbs, leaf_motions): (&[Aabb], &[Aabb]),
    walk_nodes: &[WalkNode],
    owned: &[u32],
    anchors: &[Vec4],
    (lists, counts): (&mut [u32], &mut [u32]),
) -> PairMotion {
    let thickness = self_params.thickness;
    let ids = sorted[leaf as usize];
    let mine = AnchoredTriangle::load(ids, anchors);
    if mine.too_small_for(thickness) {
        counts[leaf as usize] = LIST_OVERFLOWED;
        return PairMotion::default();
    }
    let mine_owned = owned[ids.w as usize];
    let (start, motion) = (&leaf_bounds[leaf as usize], &leaf_motions[leaf as usize]);
    let query = ((start.min.xyz(), start.max.xyz()), (motion.min.xyz(), motion.max.xyz()));
    let frames = (Quantizer::over(&aabbs[0]), Quantizer::over(&motion_aabbs[0]));
    let boxes = RelativeMotion { walk_nodes, frames, leaf_bounds, leaf_motions, query, thickness };
    let mut walk = PairWalk::new(leaf, nodes, self_params.leaf_count);
    let mut found = [0u32; WALK_BATCH];
    let base = (LIST_ENTRY_WORDS * SELF_LIST_CAPACITY * leaf) as usize;
    let mut count = 0;
    let mut full = false;
    let mut fastest = PairMotion::default();
    while !walk.done() && !full {
        let batch = walk.next_batch_in(nodes, boxes, &mut found);
        let mut j = 0;
        while j < batch {
            let other = found[j];
            let theirs = sorted[other as usize];
            let mask = pair_mask(mine_owned, owned[theirs.w as usize]);
            let (kept, (gap, distance), motion) =
                pairs_that_may_touch(&mine, &AnchoredTriangle::load(theirs, anchors), mask, thickness);
            fastest = fastest.max(motion);
            if kept != 0 {
                if count == SELF_LIST_CAPACITY {
                    full = true;
                } else {
                    let entry = base + (LIST_ENTRY_WORDS * count) as usize;
                    lists[entry] = other;
                    lists[entry + 1] = kept;
                    lists[entry + 2] = gap.to_bits();
                    lists[entry + 3] = distance.to_bits();
                    count += 1;
                }
            }
            j += 1;
        }
    }
    counts[leaf as usize] = if full { LIST_OVERFLOWED } else { count };
    fastest
}

/// Whether a cloth triangle that keeps to its predicted region over the lists' span (its
/// corners within their slops of their predicted paths, gravity's share left out) may come
/// within `thickness` of a point of the box `(lo, hi)`: one walk of the span's tree (its start
/// boxes and motion boxes, as `list_self_pairs_at` walks it), over every leaf, stopping at the
/// first that may. The box stands still over the span; the caller grows it by gravity's share
/// of the cloth's predicted paths (`ANCHOR_WORDS` word 2 of any particle: the same for all),
/// which parts a cloth from a collider as it parts no two of its triangles. Run between the
/// lists and the span's first pass, whose refits overwrite the start boxes.
pub fn lists_tree_reaches(
    (lo, hi): (Vec3, Vec3),
    thickness: f32,
    leaf_count: u32,
    (nodes, aabbs, leaf_bounds): (&[BvhNode], &[Aabb], &[Aabb]),
    (motion_aabbs, leaf_motions): (&[Aabb], &[Aabb]),
    walk_nodes: &[WalkNode],
) -> bool {
    let frames = (Quantizer::over(&aabbs[0]), Quantizer::over(&motion_aabbs[0]));
    let query = ((lo, hi), (Vec3::ZERO, Vec3::ZERO));
    let boxes = RelativeMotion { walk_nodes, frames, leaf_bounds, leaf_motions, query, thickness };
    let mut walk = PairWalk::all(leaf_count);
    let mut found = [0u32; WALK_BATCH];
    let mut reaches = false;
    while !walk.done() && !reaches {
        reaches = walk.next_batch_in(nodes, boxes, &mut found) > 0;
    }
    reaches
}

/// Records a list's largest motion and approach (`list_self_pairs_at`) in the frame's health
/// record (`Health::self_pair_motion_bits`, `Health::self_pair_approach_bits`, float maxima on
/// the bits).
#[inline]
pub fn note_pair_motion(fastest: PairMotion, health: &mut Health) {
    if fastest.motion > 0.0 {
        atomics::max(&mut health.self_pair_motion_bits, fastest.motion.to_bits());
    }
    if fastest.approach > 0.0 {
        atomics::max(&mut health.self_pair_approach_bits, fastest.approach.to_bits());
    }
}

/// Counts a leaf whose list is full (it walks at every pass of the frame) in the frame's
/// health record; its walks need the tree refit at every pass (`tree_every_pass`).
#[inline]
pub fn count_full_list(leaf: u32, counts: &[u32], health: &mut Health, tree_every_pass: &mut u32) {
    if counts[leaf as usize] == LIST_OVERFLOWED {
        atomics::add(&mut health.self_full_lists, 1);
        atomics::max(tree_every_pass, 1);
    }
}

/// Raises a pass's refit of the tree to every leaf (`pass_refit`: the refit's indirect
/// dispatch, which the host empties before the pass) from triangle `t`'s run of the pass's
/// boxes: when it is the pass's first walker (`note_escape`), or when it is triangle 0 and the
/// frame's passes walk the tree whoever escapes (`tree_every_pass`: a list overflowed, a
/// collider listed a possibly sharp triangle). One thread raises it at most for each reason. A
/// pass where no one walks leaves the tree as it was: nothing reads it before the next refit.
#[inline]
pub fn note_pass_tree(
    (t, first_walker): (u32, bool),
    tree_every_pass: bool,
    leaf_count: u32,
    pass_refit: &mut DispatchArgs,
) {
    if first_walker || (t == 0 && tree_every_pass) {
        atomics::max(&mut pass_refit.x, leaf_count.div_ceil(REFIT_THREADS));
    }
}

/// Whether triangle `t` left its predicted region in the pass spanning fractions `from..to` of
/// the frame: a corner more than its slop (and `beyond`: 0 for a pass) from its predicted path
/// at the pass's start (`x_prev`) or end (`x`); and the farthest its corners strayed from their
/// paths there (so, as they move linearly over the pass, anywhere in it: what
/// `listed_self_pairs_at` compares with a listed pair's gap).
#[inline]
pub fn escaped_at(
    t: u32,
    (x, x_prev): (&[Vec4], &[Vec4]),
    anchors: &[Vec4],
    indices: &[u32],
    (span, beyond): (&SelfPassPush, f32),
) -> (bool, f32) {
    let i = 3 * t as usize;
    let mut escaped = false;
    let mut stray = 0.0f32;
    let mut k = 0;
    while k < 3 {
        let p = indices[i + k];
        let anchor = Anchor::load(p, anchors);
        let (then, now) = (x_prev[p as usize].xyz(), x[p as usize].xyz());
        escaped = escaped || !anchor.holds(then, span.from, beyond) || !anchor.holds(now, span.to, beyond);
        stray = stray.max(anchor.stray(then, span.from)).max(anchor.stray(now, span.to));
        k += 1;
    }
    (escaped, stray)
}

/// `SelfPassPush::find_walkers`: the run finds the pass's walkers (the host emptied their
/// dispatch before the pass; the collider edges' pushes empty it again before the second run,
/// `self_contact::forget_walkers`).
pub const FIND_WALKERS: u32 = 1;

/// Records whether triangle `t` (sorted leaf `leaf`) escaped its region in the pass and how far
/// it strayed (`escaped_at`), and lists it as a walker when it did. Returns whether it is the
/// pass's first walker (the one to raise the pass's refit: `note_pass_tree`).
#[inline]
pub fn note_escape(
    (t, leaf): (u32, u32),
    (out, stray): (bool, f32),
    (escaped, strays): (&mut [u32], &mut [f32]),
    (walkers, walk_args): (&mut [u32], &mut DispatchArgs),
) -> bool {
    escaped[t as usize] = out as u32;
    strays[t as usize] = stray;
    out && add_walker(leaf, walkers, walk_args) == 0
}

/// The box of cloth triangle `t` (corners `indices[3t..3t + 3]`) over the pass: at the
/// positions `x_prev` and `x`, so a particle the triangle swept through finds it.
#[inline]
pub fn cloth_triangle_bounds_at(t: u32, (x, x_prev): (&[Vec4], &[Vec4]), indices: &[u32]) -> Aabb {
    let i = 3 * t as usize;
    let (ia, ib, ic) = (indices[i] as usize, indices[i + 1] as usize, indices[i + 2] as usize);
    let (a, b, c) = (x[ia].xyz(), x[ib].xyz(), x[ic].xyz());
    let (a0, b0, c0) = (x_prev[ia].xyz(), x_prev[ib].xyz(), x_prev[ic].xyz());
    let lo = a.min(b).min(c).min(a0).min(b0).min(c0);
    let hi = a.max(b).max(c).max(a0).max(b0).max(c0);
    Aabb { min: lo.extend(0.0), max: hi.extend(0.0) }
}

/// Whether sorted leaf `leaf` walks the tree in this pass: it escaped, or its list overflowed.
#[inline]
fn walks(leaf: u32, sorted: &[UVec4], escaped: &[u32], counts: &[u32]) -> bool {
    escaped[sorted[leaf as usize].w as usize] != 0 || counts[leaf as usize] == LIST_OVERFLOWED
}

/// Threads per workgroup of the tests of the pairs the walkers queued (`test_queued_pairs`).
pub const QUEUE_THREADS: u32 = 64;
/// Words of a queued pair: its earlier leaf and its later leaf (tree order).
pub const QUEUED_PAIR_WORDS: u32 = 2;
/// Pairs a pass's queue holds per triangle of the cloth. A walker whose pairs find the queue
/// full tests them itself, as it did before the queue: the same pairs, the same sums.
pub const QUEUED_PAIRS_PER_TRIANGLE: u32 = 8;
/// The most pairs a pass's queue holds whatever the cloth's size: its tests' indirect dispatch
/// stays within 65,535 workgroups, the least `maxComputeWorkGroupCount` Vulkan allows (a cloth
/// of more than 524,287 triangles has a smaller share per triangle).
pub const QUEUED_PAIRS_MOST: u32 = 65_535 * QUEUE_THREADS;

/// Walker `leaf`'s pairs in a pass (it escaped its region; a triangle whose list overflowed walks
/// for its later leaves in `listed_self_pairs_at`, in its own thread): found through the tree
/// with the later leaves and the earlier leaves that do not walk themselves (one walk over
/// both; only the later ones for a walker that did not escape), and queued for
/// `test_queued_pairs`, earlier leaf first.
/// A walk's pairs are tested by as many threads as there are pairs: a triangle that escaped at
/// speed sweeps a box that meets hundreds of others, and one thread testing them one after
/// another set the length of the whole dispatch on a GPU (138 µs a pass on the H200), while its
/// neighbours' lanes waited on llvmpipe. The queue takes a batch's pairs with one atomic; past
/// its capacity (`QUEUED_PAIRS_PER_TRIANGLE`, `QUEUED_PAIRS_MOST`) the walker tests them itself. Each correction
/// is summed in fixed point, so who tests a pair, and in which order, changes nothing.
#[allow(clippy::too_many_arguments)]
pub fn walk_self_pairs_at(
    leaf: u32,
    self_params: &ColliderParams,
    (nodes, aabbs, leaf_bounds, sorted): SelfTree<'_>,
    owned: &[u32],
    (x, x_prev): (&[Vec4], &[Vec4]),
    (escaped, counts): (&[u32], &[u32]),
    (queue, queue_args): (&mut [u32], &mut DispatchArgs),
    mut out: PairResponse,
) {
    let leaf_count = self_params.leaf_count;
    let mine_escaped = escaped[sorted[leaf as usize].w as usize] != 0;
    let query = triangle_query(&leaf_bounds[leaf as usize], out.thickness);
    let mut walk = if mine_escaped { PairWalk::all(leaf_count) } else { PairWalk::new(leaf, nodes, leaf_count) };
    let capacity = queue.len() as u32 / QUEUED_PAIR_WORDS;
    let mut found = [0u32; WALK_BATCH];
    while !walk.done() {
        let count = walk.next_batch((nodes, aabbs, leaf_bounds), query, &mut found);
        // The leaves it pairs with, kept in place: every later one, and an earlier one that
        // does not walk when this one escaped (a walking earlier leaf finds the pair itself).
        let mut kept = 0;
        let mut j = 0;
        while j < count {
            let other = found[j];
            if other > leaf || (mine_escaped && other < leaf && !walks(other, sorted, escaped, counts)) {
                found[kept] = other;
                kept += 1;
            }
            j += 1;
        }
        if kept == 0 {
            continue;
        }
        let first = atomics::add(&mut queue_args._pad, kept as u32);
        let end = (first + kept as u32).min(capacity);
        if end > first {
            atomics::max(&mut queue_args.x, end.div_ceil(QUEUE_THREADS));
        }
        let mut k = 0;
        while k < kept {
            let other = found[k];
            let slot = first + k as u32;
            let pair = (leaf.min(other), leaf.max(other));
            if slot < capacity {
                let at = (QUEUED_PAIR_WORDS * slot) as usize;
                queue[at] = pair.0;
                queue[at + 1] = pair.1;
            } else {
                leaf_pair(pair, (sorted, owned), (x, x_prev), &mut out);
            }
            k += 1;
        }
    }
}

/// Queued pair `i` of a pass (`walk_self_pairs_at`): `leaf_pair`.
#[inline]
pub fn test_queued_pair_at(
    i: u32,
    tables: (&[UVec4], &[u32]),
    sweep: (&[Vec4], &[Vec4]),
    queue: &[u32],
    out: &mut PairResponse,
) {
    let at = (QUEUED_PAIR_WORDS * i) as usize;
    leaf_pair((queue[at], queue[at + 1]), tables, sweep, out);
}

/// Sorted leaves `earlier` < `later` against each other, the earlier's triangle first, as every
/// way of finding the pair tests it (`self_contact::triangle_pair`).
#[inline]
fn leaf_pair(
    (earlier, later): (u32, u32),
    (sorted, owned): (&[UVec4], &[u32]),
    (x, x_prev): (&[Vec4], &[Vec4]),
    out: &mut PairResponse,
) {
    let (a, b) = (sorted[earlier as usize], sorted[later as usize]);
    let (mine, theirs) = (Corners::load(a, (x, x_prev)), Corners::load(b, (x, x_prev)));
    triangle_pair(&mine, &theirs, pair_mask(owned[a.w as usize], owned[b.w as usize]), out);
}

/// How many pairs a pass's walkers queued that the queue holds (`walk_self_pairs_at`).
#[inline]
pub fn queued_pairs(queue: &[u32], queue_args: &DispatchArgs) -> u32 {
    queue_args._pad.min(queue.len() as u32 / QUEUED_PAIR_WORDS)
}

/// Sorted leaf `leaf`'s pairs in a pass from its list, skipping partners that escaped; through
/// the tree, with the later leaves, when its list is full (here, in leaf order: on a cloth whose
/// triangles are all too small for lists every lane walks, as it would without them); nothing
/// when it escaped (`walk_self_pairs_at` handles it).
#[allow(clippy::too_many_arguments)]
pub fn listed_self_pairs_at(
    leaf: u32,
    self_params: &ColliderParams,
    (nodes, aabbs, leaf_bounds, sorted): SelfTree<'_>,
    owned: &[u32],
    (x, x_prev): (&[Vec4], &[Vec4]),
    (escaped, strays): (&[u32], &[f32]),
    (lists, counts): (&[u32], &[u32]),
    span: &SelfPassPush,
    out: PairResponse,
) {
    let count = counts[leaf as usize];
    if count == 0 || escaped[sorted[leaf as usize].w as usize] != 0 {
        return;
    }
    let mut pairs = TrianglePairs::of(leaf, (leaf_bounds, sorted, owned), (x, x_prev), out);
    if count == LIST_OVERFLOWED {
        pairs.walk_after((nodes, aabbs, leaf_bounds), self_params.leaf_count);
        return;
    }
    let base = (LIST_ENTRY_WORDS * SELF_LIST_CAPACITY * leaf) as usize;
    let my_stray = strays[sorted[leaf as usize].w as usize];
    let mut j = 0;
    while j < count as usize {
        let entry = base + LIST_ENTRY_WORDS as usize * j;
        let ids = sorted[lists[entry] as usize];
        // The pair's gap by the pass's end less how far both strayed in this pass: still apart
        // by the thickness in all of the pass (the list's bound with the strays for the slops),
        // nothing to test.
        let (gap, distance) = (f32::from_bits(lists[entry + 2]), f32::from_bits(lists[entry + 3]));
        let near = may_touch(gap_by(span.to, gap, distance), my_stray + strays[ids.w as usize], self_params.thickness);
        if escaped[ids.w as usize] == 0 && near {
            let theirs = Corners::load(ids, (x, x_prev));
            triangle_pair(&pairs.mine, &theirs, lists[entry + 1], &mut pairs.out);
        }
        j += 1;
    }
}

/// Each particle's prediction over the window that starts now, of `push.substeps` substeps
/// (`anchor_window_at`; its frame start stays): a frame's lists built again after a pass.
#[spirv(compute(threads(256)))]
pub fn anchor_window(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] push: &SelfAnchorPush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &SimParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] self_params: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] x: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] v: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] anchors: &mut [Vec4],
) {
    if id.x >= params.particle_count {
        return;
    }
    anchor_window_at(id.x, (x, v), frame_of(params, self_params, push.window_substeps), anchors);
}

/// Each triangle's box at the frame's start with its corners' slops (what the frame's tree is
/// built over).
#[spirv(compute(threads(256)))]
pub fn cloth_triangle_starts(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] self_params: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] anchors: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] indices: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] bounds: &mut [Aabb],
) {
    if id.x >= self_params.leaf_count {
        return;
    }
    bounds[id.x as usize] = triangle_start_at(id.x, anchors, indices);
}

/// Sorted leaf `s` where the tree keeps its order (a refit, or a window's lists): its triangle
/// and leaf (`sorted`, `leaf_of`), its start box (`sorted_bounds`, the refit's leaf box) and its
/// motion box (`leaf_motions`) from one load of its corners' anchors: what
/// `triangle_start_at`, the tree's gather and `self_contact::gather_cloth_triangle` write
/// there, word for word, in one pass instead of three.
#[inline]
pub fn regather_cloth_triangle(
    s: u32,
    (indices, order, anchors): (&[u32], &[u32], &[Vec4]),
    (sorted, leaf_of, sorted_bounds, leaf_motions): (&mut [UVec4], &mut [u32], &mut [Aabb], &mut [Aabb]),
) {
    let triangle = place_cloth_triangle(s, (indices, order), (sorted, leaf_of));
    let (start, motion) = AnchoredTriangle::load(triangle, anchors).boxes3();
    sorted_bounds[s as usize] = aabb_of(start);
    leaf_motions[s as usize] = aabb_of(motion);
}

#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(256)))]
pub fn regather_cloth_triangles(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] self_params: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] indices: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] order: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] anchors: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] sorted: &mut [UVec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] leaf_of: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] sorted_bounds: &mut [Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] leaf_motions: &mut [Aabb],
) {
    if id.x >= self_params.leaf_count {
        return;
    }
    regather_cloth_triangle(id.x, (indices, order, anchors), (sorted, leaf_of, sorted_bounds, leaf_motions));
}

/// Each triangle's box over the pass (push: the pass's span of the frame), written straight
/// into the tree's leaf order (`leaf_of`) for the refit, and, in the pass's last run, whether it
/// escaped its region, how far it strayed (`escaped_at`) and the pass's walkers.
#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(256)))]
pub fn cloth_triangle_bounds(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] span: &SelfPassPush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] self_params: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] x: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] x_prev: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] indices: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] anchors: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] leaf_of: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] leaf_bounds: &mut [Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] escaped: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] strays: &mut [f32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] walkers: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] walk_args: &mut DispatchArgs,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] tree_every_pass: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 12)] pass_refit: &mut DispatchArgs,
) {
    let triangles = (x, x_prev, indices, anchors, leaf_of);
    let out = (leaf_bounds, escaped, strays, walkers, walk_args);
    triangle_bounds_at((id.x, span), self_params, triangles, out, (tree_every_pass[0], pass_refit));
}

/// `cloth_triangle_bounds`' thread for triangle `t` (nothing past the cloth's triangles).
#[allow(clippy::type_complexity)]
#[inline]
pub fn triangle_bounds_at(
    (t, span): (u32, &SelfPassPush),
    self_params: &ColliderParams,
    (x, x_prev, indices, anchors, leaf_of): (&[Vec4], &[Vec4], &[u32], &[Vec4], &[u32]),
    (leaf_bounds, escaped, strays, walkers, walk_args): (
        &mut [Aabb],
        &mut [u32],
        &mut [f32],
        &mut [u32],
        &mut DispatchArgs,
    ),
    (tree_every_pass, pass_refit): (u32, &mut DispatchArgs),
) {
    if t >= self_params.leaf_count {
        return;
    }
    let leaf = leaf_of[t as usize];
    leaf_bounds[leaf as usize] = cloth_triangle_bounds_at(t, (x, x_prev), indices);
    if span.find_walkers != FIND_WALKERS {
        return;
    }
    let escape = escaped_at(t, (x, x_prev), anchors, indices, (span, 0.0));
    let first_walker = note_escape((t, leaf), escape, (escaped, strays), (walkers, walk_args));
    note_pass_tree((t, first_walker), tree_every_pass != 0, self_params.leaf_count, pass_refit);
}

/// Threads per workgroup of the walks (`walk_self_pairs`): as many as the lists' (a pass's
/// walkers are at most the cloth's triangles, so the walk's indirect dispatch never needs more
/// workgroups than the lists' direct one, which the engine checks against the device's limit).
pub const WALK_THREADS: u32 = 64;

/// Appends sorted leaf `leaf` to the pass's walkers; the walk's indirect dispatch covers them
/// (`walk_args`: x workgroups, the count in `_pad`; the host writes {0, 1, 1, 0} before).
/// Returns its slot among them.
#[inline]
pub fn add_walker(leaf: u32, walkers: &mut [u32], walk_args: &mut DispatchArgs) -> u32 {
    atomics::append_for_dispatch(leaf, walkers, walk_args, WALK_THREADS)
}

/// One thread per internal node of the frame's tree: the node packed for the lists' walk, and
/// its start box kept apart (`span_aabbs`) for the passes' trees, whose boxes overwrite
/// `aabbs` (`self_pass_tree`).
#[spirv(compute(threads(256)))]
pub fn pack_walk_nodes(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] self_params: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] nodes: &[BvhNode],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] aabbs: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] motion_aabbs: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] walk_nodes: &mut [WalkNode],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] span_aabbs: &mut [Aabb],
) {
    if id.x + 1 < self_params.leaf_count {
        pack_walk_node_at(id.x, nodes, (aabbs, motion_aabbs), walk_nodes);
        span_aabbs[id.x as usize] = aabbs[id.x as usize];
    }
}

#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(64)))]
pub fn list_self_pairs(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] push: &SelfListPush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] self_params: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] nodes: &[BvhNode],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] aabbs: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] leaf_bounds: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] sorted: &[UVec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] owned: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] anchors: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] motion_aabbs: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] leaf_motions: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] walk_nodes: &[WalkNode],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] lists: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] counts: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 12)] health: &mut Health,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 13)] tree_every_pass: &mut u32,
) {
    if id.x >= self_params.leaf_count {
        return;
    }
    let tree = (nodes, aabbs, leaf_bounds, sorted);
    let motions = (motion_aabbs, leaf_motions);
    let motion = list_self_pairs_at(id.x, self_params, tree, motions, walk_nodes, owned, anchors, (lists, counts));
    count_full_list(id.x, counts, health, tree_every_pass);
    note_pair_motion(motion.per_frame(push.to_frame), health);
}

#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(64)))]
pub fn listed_self_pairs(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] span: &SelfPassPush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] self_params: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] nodes: &[BvhNode],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] aabbs: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] leaf_bounds: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] sorted: &[UVec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] owned: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] x: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] x_prev: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] v: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] escaped: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] strays: &[f32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] lists: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 12)] counts: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 13)] delta: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 14)] velocity_changes: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 15)] rest_shape: &[Vec4],
) {
    if id.x >= self_params.leaf_count {
        return;
    }
    let tree = (nodes, aabbs, leaf_bounds, sorted);
    let out = PairResponse::of_cloth(self_params, (v, rest_shape), (delta, velocity_changes));
    let (escaped, lists) = ((escaped, strays), (lists, counts));
    listed_self_pairs_at(id.x, self_params, tree, owned, (x, x_prev), escaped, lists, span, out);
}

/// Every triangle's pairs through the tree (a cloth too fine for lists at its thickness).
#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(64)))]
pub fn self_triangle_contact(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] self_params: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] nodes: &[BvhNode],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] aabbs: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] leaf_bounds: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] sorted: &[UVec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] owned: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] x: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] x_prev: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] v: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] delta: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] velocity_changes: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] rest_shape: &[Vec4],
) {
    if id.x >= self_params.leaf_count {
        return;
    }
    let tree = (nodes, aabbs, leaf_bounds, sorted);
    let out = PairResponse::of_cloth(self_params, (v, rest_shape), (delta, velocity_changes));
    self_triangle_contact_at(id.x, self_params, tree, owned, (x, x_prev), out);
}

#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(64)))]
pub fn walk_self_pairs(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] self_params: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] nodes: &[BvhNode],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] aabbs: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] leaf_bounds: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] sorted: &[UVec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] owned: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] x: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] x_prev: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] v: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] escaped: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] counts: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] walkers: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 12)] walk_args: &DispatchArgs,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 13)] delta: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 14)] velocity_changes: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 15)] queue: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 16)] queue_args: &mut DispatchArgs,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 17)] health: &mut Health,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 18)] rest_shape: &[Vec4],
) {
    if id.x >= walk_args._pad {
        return;
    }
    let tree = (nodes, aabbs, leaf_bounds, sorted);
    let out = PairResponse::of_cloth(self_params, (v, rest_shape), (delta, velocity_changes));
    let leaf = walkers[id.x as usize];
    walk_self_pairs_at(leaf, self_params, tree, owned, (x, x_prev), (escaped, counts), (queue, queue_args), out);
    if counts[leaf as usize] != LIST_OVERFLOWED {
        atomics::add(&mut health.self_walks, 1); // (a full list is counted once, for the frame)
    }
}

/// One thread per pair a pass's walkers queued (`walk_self_pairs_at`): its test
/// (`test_queued_pair_at`), summed into the pass's corrections.
#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(64)))]
pub fn test_queued_pairs(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] self_params: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] sorted: &[UVec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] owned: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] x: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] x_prev: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] v: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] queue: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] queue_args: &DispatchArgs,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] delta: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] velocity_changes: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] rest_shape: &[Vec4],
) {
    if id.x >= queued_pairs(queue, queue_args) {
        return;
    }
    let mut out = PairResponse::of_cloth(self_params, (v, rest_shape), (delta, velocity_changes));
    test_queued_pair_at(id.x, (sorted, owned), (x, x_prev), queue, &mut out);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::self_contact::OWNED_FEATURE_BITS;
    use crate::self_failsafe::{LIST_CHECK_BEYOND, pierceable_deep, triangles_cross};
    use drape_types::LEAF_BIT;

    /// A packed node's boxes read back hold the boxes written, near the origin and far from it,
    /// for roots large and small, flat and of zero extent (a cloth at rest has no motion), no
    /// looser than a few steps of their own axis, and its links come back whole.
    #[test]
    fn packed_nodes_hold_their_boxes() {
        let mut next = crate::test_random::unit_floats(0x9E37_79B9_7F4A_7C15);
        for case in 0..4000 {
            let centre = [0.0, 1.0, 1000.0, -3.0e4][case % 4];
            let size = [1.0, 1e-3, 40.0, 0.0][(case / 4) % 4];
            // Some roots nearly flat in z (a cloth lying flat moves little across itself).
            let depth = [1.0, 1e-7][(case / 16) % 2];
            let corner = |u: f32| Vec3::new(centre, -centre, centre * 0.5) + Vec3::new(1.0, 1.0, depth) * (size * u);
            let (root_lo, root_hi) = (corner(-1.0), corner(1.0));
            let within = |t: f32| root_lo + (root_hi - root_lo) * t;
            let (a, b) = (within(next()), within(next()));
            let (c, d) = (within(next()), within(next()));
            let node = |lo: Vec3, hi: Vec3| Aabb { min: lo.min(hi).extend(0.0), max: lo.max(hi).extend(0.0) };
            let root = node(root_lo, root_hi);
            let (start, motion) = ([root, node(a, b)], [root, node(c, d)]);
            let nodes = [BvhNode::default(), BvhNode { left: 7, right: 9, escape: LEAF_BIT | 12, leaf_escape: 3 }];
            let mut packed = [WalkNode::default(); 2];
            pack_walk_node_at(1, &nodes, (&start, &motion), &mut packed);
            let frames = (Quantizer::over(&start[0]), Quantizer::over(&motion[0]));
            let ((lo, hi), (motion_lo, motion_hi)) = unpack_walk_node(&packed[1], frames);
            let holds = |lo: Vec3, hi: Vec3, b: &Aabb| lo.cmple(b.min.xyz()).all() && hi.cmpge(b.max.xyz()).all();
            assert!(holds(lo, hi, &start[1]), "case {case}: start {:?} read as {lo} {hi}", start[1]);
            assert!(
                holds(motion_lo, motion_hi, &motion[1]),
                "case {case}: motion {:?} read as {motion_lo} {motion_hi}",
                motion[1]
            );
            // Looser by the rounding and the margin alone: a few steps, or f32's own resolution
            // there (about 6e-5 m at 1 km).
            let loose = (hi - lo) - (start[1].max - start[1].min).xyz();
            let allowed =
                frames.0.step * (2.0 * (frames.0.margin + 1.0)) + Vec3::splat(4.0 * centre.abs() * f32::EPSILON);
            assert!(loose.cmple(allowed).all(), "case {case}: {loose} over {allowed}");
            if centre.abs() <= 1.0 && size >= 1e-3 {
                assert!(loose.max_element() <= 2e-3 * size, "case {case}: {loose} for a box of {size} m");
            }
            assert_eq!((packed[1].motions_and_links.z, packed[1].motions_and_links.w), (7, LEAF_BIT | 12));
        }
    }

    /// Anchors at 5 mm (no gravity) of a vertex (particle 3) at `vertex` moving by `motion`
    /// over the frame above a still face (particles 0..3) in the plane y = 0.
    fn vertex_over_face(vertex: Vec3, motion: Vec3) -> (AnchoredTriangle, AnchoredTriangle) {
        let (x, v) = (
            [
                Vec4::new(0.0, 0.0, 0.0, 1.0),
                Vec4::new(0.1, 0.0, 0.0, 1.0),
                Vec4::new(0.0, 0.0, 0.1, 1.0),
                vertex.extend(1.0),
            ],
            [Vec4::ZERO, Vec4::ZERO, Vec4::ZERO, (motion * 60.0).extend(0.0)],
        );
        let mut anchors = [Vec4::ZERO; 4 * ANCHOR_WORDS as usize];
        for i in 0..4 {
            anchor_at(i, (&x, &v), (1.0 / 60.0, Vec3::ZERO, 0.005), &mut anchors);
        }
        (
            AnchoredTriangle::load(UVec4::new(3, 3, 3, 1), &anchors),
            AnchoredTriangle::load(UVec4::new(0, 1, 2, 0), &anchors),
        )
    }

    /// A vertex 8 mm over a face: sliding 10 cm along it, the pair is kept (the distance less
    /// the whole motion is below the thickness) with a motion of 10 cm and no approach; falling
    /// 3 cm through it as well, it closes 3 cm; rising, nothing.
    #[test]
    fn a_sliding_pair_moves_but_does_not_approach() {
        let over = Vec3::new(0.02, 0.008, 0.02);
        let (vertex, face) = vertex_over_face(over, Vec3::new(0.1, 0.0, 0.0));
        let slide = vertex_face_pair(&vertex, 0, &face, 0.005);
        assert!(slide.gap < 0.0, "kept: {}", slide.gap);
        assert!((slide.motion.motion - 0.1).abs() < 1e-6 && slide.motion.approach == 0.0, "{:?}", slide.motion);
        let (vertex, face) = vertex_over_face(over, Vec3::new(0.1, -0.03, 0.0));
        let fall = vertex_face_pair(&vertex, 0, &face, 0.005);
        assert!((fall.motion.approach - 0.03).abs() < 1e-6, "{}", fall.motion.approach);
        let (vertex, face) = vertex_over_face(over, Vec3::new(0.1, 0.03, 0.0));
        assert_eq!(vertex_face_pair(&vertex, 0, &face, 0.005).motion.approach.to_bits(), 0);
    }

    /// A vertex 3 cm over a face falls 6 cm through it over the frame: its list entry's gap by a
    /// pass's end (`gap_by`) never exceeds the vertex's distance from the face at any time of
    /// the pass, so in 10 passes the first ones (the vertex still over 5 mm away) skip the pair
    /// and those around its crossing test it; at the frame's end it is the list's gap itself.
    #[test]
    fn a_pass_tests_a_listed_pair_only_when_it_may_have_come_near() {
        let (vertex, face) = vertex_over_face(Vec3::new(0.02, 0.03, 0.02), Vec3::new(0.0, -0.06, 0.0));
        let (kept, (gap, distance), _) = pairs_that_may_touch(&vertex, &face, 1, 0.005);
        assert_eq!(kept, 1);
        assert!((distance - 0.03).abs() < 1e-6 && (gap + 0.03).abs() < 1e-6, "{distance} {gap}");
        let tested: Vec<bool> = (1..=10)
            .map(|pass| {
                let to = pass as f32 / 10.0;
                let bound = gap_by(to, gap, distance);
                for k in 0..=100 {
                    let s = to * k as f32 / 100.0;
                    let height = (0.03 - 0.06 * s).abs();
                    assert!(bound <= height + 1e-6, "pass {pass}: {bound} over the distance {height} at {s}");
                }
                may_touch(bound, 0.0, 0.005)
            })
            .collect();
        assert_eq!(tested, [false, false, false, false, true, true, true, true, true, true]);
        assert_eq!(gap_by(1.0, gap, distance).to_bits(), gap.to_bits());
        // Whatever the pairs (each distance falling linearly at its own motion), the smallest
        // distance at any time stays at or above the chord of the smallest at both ends.
        let mut next = crate::test_random::unit_floats(0x2545_F491_4F6C_DD1D);
        for case in 0..2000 {
            let pairs: Vec<(f32, f32)> = (0..1 + case % 15).map(|_| (0.1 * next(), 0.2 * next())).collect();
            let smallest_at = |s: f32| pairs.iter().map(|&(d, m)| d - m * s).fold(f32::INFINITY, f32::min);
            let (start, end) = (smallest_at(0.0), smallest_at(1.0));
            for k in 0..=20 {
                let s = k as f32 / 20.0;
                assert!(gap_by(s, end, start) <= smallest_at(s) + 1e-6, "case {case} at {s}: {pairs:?}");
            }
        }
    }

    /// Random pairs of triangles with their lists' bound over a frame, and their corners ended
    /// off their predicted ends by up to `excess` beyond their slops (each in a random
    /// direction, half the tries toward the other triangle): a pair the bound leaves out never
    /// crosses at the frame's end (when it did not at its start) while each triangle's excess
    /// stays within half the thickness (`LIST_CHECK_BEYOND`), so the fail-safe's check may take
    /// such a triangle's list alone. Beyond, pairs left out do cross (from a whole thickness
    /// in these pairs; 700 of 19,640 at two): the test can fail.
    #[test]
    fn a_pair_left_out_cannot_cross_within_half_a_thickness_beyond_the_slops() {
        let thickness = 0.005;
        fn unit(next: &mut impl FnMut() -> f32) -> Vec3 {
            Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * 2.0
        }
        let g = Vec3::new(0.0, -9.81, 0.0);
        // A pair's triangles (first three particles, last three) and whether the bound keeps
        // it: the anchors and the bound as the lists take them.
        let bound = |x: &[Vec4; 6], v: &[Vec4; 6]| {
            let mut anchors = [Vec4::ZERO; 6 * ANCHOR_WORDS as usize];
            for i in 0..6 {
                anchor_at(i, (x, v), (1.0 / 60.0, g, thickness), &mut anchors);
            }
            let sorted = [UVec4::new(0, 1, 2, 0), UVec4::new(3, 4, 5, 1)];
            let owned = [OWNED_FEATURE_BITS, OWNED_FEATURE_BITS];
            let (kept, _) = listed_pair_bound((0, 1), thickness, (&sorted, &owned, &anchors));
            let pair = (AnchoredTriangle::load(sorted[0], &anchors), AnchoredTriangle::load(sorted[1], &anchors));
            (kept, pair)
        };
        let starts = |t: &AnchoredTriangle| t.corners.map(|c| c.start);
        // Over random pairs moved apart to just where the bound leaves them out, each triangle's
        // corners ended off their predicted ends by up to their slops plus `excess`, half of
        // the tries toward the other triangle: the pairs left out, and those that crossed.
        let crossings_left_out = |excess: f32, seed: u64| {
            let mut next = crate::test_random::unit_floats(seed);
            let (mut left_out, mut crossed) = (0, 0);
            for _ in 0..4000 {
                // Two triangles about 4 cm across, moving up to 0.9 m/s.
                let mut x = [Vec4::ZERO; 6];
                let mut v = [Vec4::ZERO; 6];
                for i in 0..6 {
                    x[i] = (unit(&mut next) * 0.025).extend(1.0);
                    v[i] = (unit(&mut next) * 0.5).extend(0.0);
                }
                let apart = unit(&mut next).normalize_or(Vec3::X);
                let moved = |x: &[Vec4; 6], by: f32| {
                    let mut y = *x;
                    for p in &mut y[3..] {
                        *p += (apart * by).extend(0.0);
                    }
                    y
                };
                // The least offset (to 0.05 mm) that the bound leaves out, from 0 to 10 cm.
                let (mut near, mut far) = (0.0f32, 0.1f32);
                if bound(&moved(&x, far), &v).0 != 0 {
                    continue;
                }
                while far - near > 5e-5 {
                    let mid = 0.5 * (near + far);
                    if bound(&moved(&x, mid), &v).0 != 0 { near = mid } else { far = mid }
                }
                let y = moved(&x, far);
                let (kept, (a, b)) = bound(&y, &v);
                if kept != 0 || a.too_small_for(thickness) || b.too_small_for(thickness) {
                    continue; // a triangle too small for lists always walks
                }
                if triangles_cross(starts(&a), starts(&b)) {
                    continue;
                }
                let centre = |t: &AnchoredTriangle| t.corners.iter().map(|c| c.at(1.0)).sum::<Vec3>() / 3.0;
                let (centre_a, centre_b) = (centre(&a), centre(&b));
                for attempt in 0..8 {
                    left_out += 1;
                    let mut end = |t: &AnchoredTriangle, toward: Vec3| {
                        t.corners.map(|c| {
                            let off = if attempt % 2 == 0 {
                                (toward - c.at(1.0) + unit(&mut next) * 0.003).normalize_or(Vec3::X)
                            } else {
                                unit(&mut next).normalize_or(Vec3::X)
                            };
                            c.at(1.0) + off * ((c.slop + excess) * (0.75 + 0.25 * next()))
                        })
                    };
                    let (end_a, end_b) = (end(&a, centre_b), end(&b, centre_a));
                    if triangles_cross(end_a, end_b) {
                        crossed += 1;
                    }
                }
            }
            (left_out, crossed)
        };
        let (left_out, crossed) = crossings_left_out(LIST_CHECK_BEYOND * thickness, 0x9E37_79B9_7F4A_7C15);
        assert!(left_out > 10_000, "too few pairs left out to test: {left_out}");
        assert_eq!(crossed, 0, "of {left_out} pairs left out, {crossed} crossed within half a thickness beyond");
        let (left_out, crossed) = crossings_left_out(2.0 * thickness, 0x9E37_79B9_7F4A_7C15);
        assert!(crossed > 0, "of {left_out} pairs left out, none crossed two thicknesses beyond");
    }

    /// A triangle 10 cm across pierced by two edges of another (standing across it, 4-8 cm out
    /// on both sides), each through a point about 2 cm or more from its edges, both at rest:
    /// every vertex-face and edge-edge pair lies beyond a list's reach (the thickness and two
    /// slops, 1 cm), so lists built there leave the crossed pair out. Such a triangle is `pierceable_deep` (the
    /// fail-safe walks it in a frame whose lists were built again within it); the standard
    /// 64^2 cloth's triangles (2.3 cm legs) are not at 5 mm, a 32^2 cloth's (4.7 cm) are.
    #[test]
    fn a_wide_triangle_pierced_deep_has_no_pair_listed() {
        let thickness = 0.005;
        let x = [
            Vec4::new(0.0, 0.0, 0.0, 1.0),
            Vec4::new(0.1, 0.0, 0.0, 1.0),
            Vec4::new(0.0, 0.0, 0.1, 1.0),
            Vec4::new(0.03, -0.04, 0.03, 1.0),
            Vec4::new(0.03, 0.04, 0.03, 1.0),
            Vec4::new(0.03, 0.08, 0.07, 1.0),
        ];
        let v = [Vec4::ZERO; 6];
        let mut anchors = [Vec4::ZERO; 6 * ANCHOR_WORDS as usize];
        for i in 0..6 {
            anchor_at(i, (&x, &v), (1.0 / 60.0, Vec3::ZERO, thickness), &mut anchors);
        }
        let sorted = [UVec4::new(0, 1, 2, 0), UVec4::new(3, 4, 5, 1)];
        let owned = [OWNED_FEATURE_BITS, OWNED_FEATURE_BITS];
        let (kept, _) = listed_pair_bound((0, 1), thickness, (&sorted, &owned, &anchors));
        let corners = |k: usize| [x[3 * k].xyz(), x[3 * k + 1].xyz(), x[3 * k + 2].xyz()];
        assert!(triangles_cross(corners(0), corners(1)), "the edge must pierce the face");
        assert_eq!(kept, 0, "no pair of the crossed triangles is within a list's reach");
        assert!(pierceable_deep(corners(0), thickness));
        let leg = |l: f32| [Vec3::ZERO, Vec3::new(l, 0.0, 0.0), Vec3::new(0.0, 0.0, l)];
        assert!(!pierceable_deep(leg(1.5 / 64.0), thickness) && pierceable_deep(leg(1.5 / 32.0), thickness));
    }

    /// A still vertex over a face one of whose corners (the third) rises 2 cm toward it: the
    /// pair closes by that corner's move along the normal, whichever corner moves.
    #[test]
    fn a_face_s_rising_corner_is_its_approach() {
        let (x, v) = (
            [
                Vec4::new(0.0, 0.0, 0.0, 1.0),
                Vec4::new(0.1, 0.0, 0.0, 1.0),
                Vec4::new(0.0, 0.0, 0.1, 1.0),
                Vec4::new(0.02, 0.008, 0.02, 1.0),
            ],
            [Vec4::ZERO, Vec4::ZERO, Vec4::new(0.0, 1.2, 0.0, 0.0), Vec4::ZERO],
        );
        let mut anchors = [Vec4::ZERO; 4 * ANCHOR_WORDS as usize];
        for i in 0..4 {
            anchor_at(i, (&x, &v), (1.0 / 60.0, Vec3::ZERO, 0.005), &mut anchors);
        }
        let (vertex, face) = (
            AnchoredTriangle::load(UVec4::new(3, 3, 3, 1), &anchors),
            AnchoredTriangle::load(UVec4::new(0, 1, 2, 0), &anchors),
        );
        let pair = vertex_face_pair(&vertex, 0, &face, 0.005);
        assert!(
            (pair.motion.approach - 0.02).abs() < 1e-6 && (pair.motion.motion - 0.02).abs() < 1e-6,
            "{:?}",
            pair.motion
        );
    }

    /// Two crossed edges 8 mm apart (one along x at y = 0.008, one along z at y = 0): sliding
    /// past each other along x, no approach; the upper one sinking 3 cm, 3 cm.
    #[test]
    fn crossed_edges_approach_only_when_they_close() {
        let pair = |motion: Vec3| {
            let x = [
                Vec4::new(-0.05, 0.008, 0.0, 1.0),
                Vec4::new(0.05, 0.008, 0.0, 1.0),
                Vec4::new(0.0, 0.0, 0.0, 1.0), // a third corner, far, for each triangle
                Vec4::new(0.0, 0.0, -0.05, 1.0),
                Vec4::new(0.0, 0.0, 0.05, 1.0),
                Vec4::new(0.5, 0.0, 0.0, 1.0),
            ];
            let m = (motion * 60.0).extend(0.0);
            let v = [m, m, m, Vec4::ZERO, Vec4::ZERO, Vec4::ZERO];
            let mut anchors = [Vec4::ZERO; 6 * ANCHOR_WORDS as usize];
            for i in 0..6 {
                anchor_at(i, (&x, &v), (1.0 / 60.0, Vec3::ZERO, 0.005), &mut anchors);
            }
            let e = AnchoredTriangle::load(UVec4::new(0, 1, 2, 0), &anchors);
            let f = AnchoredTriangle::load(UVec4::new(3, 4, 5, 1), &anchors);
            edges_pair(&e, 0, &f, 0, 0.005)
        };
        let slide = pair(Vec3::new(0.04, 0.0, 0.0));
        assert!(
            slide.gap < 0.0 && (slide.motion.motion - 0.04).abs() < 1e-6,
            "kept: {} {}",
            slide.gap,
            slide.motion.motion
        );
        assert_eq!(slide.motion.approach.to_bits(), 0);
        let sink = pair(Vec3::new(0.04, -0.03, 0.0));
        assert!((sink.motion.approach - 0.03).abs() < 1e-6, "{}", sink.motion.approach);
    }
}
