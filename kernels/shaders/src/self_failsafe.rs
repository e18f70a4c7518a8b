//! Self-collision's fail-safe: the frame's end is checked for cloth triangles that intersect
//! each other or a triangle collider's (those the frame listed as possibly sharp), and the
//! particles of any pair that did not at the frame's start are put back where the frame found
//! them (relative to the collider's surface, where it moved: `surface_motion`).
//!
//! The passes (`self_contact`) push pairs within the thickness apart, each particle by the mean
//! of its corrections. Where the cloth is squeezed (a layer pressed between the ground and the
//! layers on it), those corrections disagree, the mean leaves a pair closer each pass, and two
//! layers can pass through each other (the pile scene: 2 of 600 frames). So, as Bridson et al.
//! (2002) follow their repulsions with a collision check, every frame ends with one:
//! - each triangle's box over the frame (start to end) refits the self-collision tree (with the
//!   frame's lists, only where a triangle walks in the check: `failsafe_box_at`);
//! - every pair of triangles that share no particle and whose boxes at the frame's end meet is
//!   tested for intersection there (an edge of one through the other: `triangles_cross`), and a
//!   pair that crosses at the end but did not at the start is found;
//! - each triangle collider's triangles that the frame listed as possibly sharp for the cloth
//!   (`sharp_features`: those whose vertices and edges the passes test against the cloth's
//!   faces) are tested against the cloth's triangles at the end the same way, the collider
//!   where the frame ends (`check_collider_triangle_at`): a needle's tip that a cell slipped
//!   over within a pass ends the pass on the wrong side, where no later pass sees it cross;
//! - the particles of both triangles of each pair found (of the cloth's triangle, for a
//!   collider's) go back to their positions at the frame's start, at rest; for a collider
//!   triangle that moved over the frame, to those positions carried as its surface moved
//!   (`surface_motion`), unless that carries them more than `CARRY_REACH` of their triangle's
//!   sides; for a pair of the cloth's own near a collider that moved (`triangle_carrier_at`),
//!   all six carried as that collider's surface nearest one of them moved (by its pose and its
//!   vertices), within the same reach.
//!
//! Why a pair of the cloth's is carried: where it started the frame may lie inside a collider
//! that moved since. Two layers pressed together on a turning body (the layers scene at a
//! body friction of 1.5) crossed in a few frames; put back where they started in the world,
//! the inner layer's particles lay up to 1.8 mm inside the turned body, and the contact, which
//! keeps a particle on the side of a face it is found on, held them inside from then on (99 of
//! 150 frames with a cloth edge through the body). Every particle of the pair takes the same
//! motion, that of one triangle's frame, so the pair stays as it started against itself, and
//! against that body where it moves rigidly or deforms smoothly.
//!
//! The state's end, not the straight path from its start: on a cloth folding over itself at
//! 5-7 cm a frame (the 64^2 swing from frame 30), that path ran two layers a thickness apart
//! through each other where the substeps' path went round, and continuous collision detection
//! over it put the whole cloth back in 10 of 40 frames (no frame of it ended crossed). So a
//! layer that passed wholly through another within a frame, leaving no triangle through
//! another, is not undone here; a cloth is connected, so one that passes through where it is
//! joined to the rest leaves triangles crossed, and those are.
//!
//! Every particle back at the start leaves its triangles as they were at the start; a pair with
//! some particles back and others moved is a new state, so the check runs again
//! (`ROLLBACK_ROUNDS` rounds, each after the first dispatched only when the round before put a
//! particle back). If the last round still finds a pair, the whole cloth goes back: the frame's
//! start has no new crossing, so the frame's end has none either (against colliders that did
//! not move). Near a collider that moved, the whole cloth goes back carried by one particle's
//! carrier (`CarrierOut::choice`): put back in the world, the layers on a body turned by its
//! vertices lay inside it (109 of 150 frames crossed the body).
//!
//! A collider triangle is checked only when the frame listed it as possibly sharp for the cloth:
//! where the surface folds too little to reach into a cloth cell, only a particle can cross it,
//! which the triangle contact's sweeps stop; a cloth edge through such a face is not checked.
//!
//! The frame's start: each particle's anchor (`self_pairs::anchor_at`) holds it.

use crate::atomics;
use crate::contact::{LeafKind, traverse};
use crate::lbvh::{PairWalk, REFIT_THREADS, refit_from_leaf};
use crate::pose::{to_local, to_world};
use crate::self_contact::{
    FIXED_SCALE, LeafVisitor, accumulate, collapsed, longest_side2, mean_of, walk_in_batches, walk_overlapping, within,
};
use crate::self_pairs::{
    ANCHOR_WORDS, FRAME_START_WORD, LIST_ENTRY_WORDS, LIST_OVERFLOWED, SELF_LIST_CAPACITY, escaped_at, list_reach,
    may_touch,
};
use crate::self_pass_tree::widen_to_leaf_at;
use drape_types::glam::{UVec3, UVec4, Vec3, Vec4, Vec4Swizzles};
use drape_types::{
    Aabb, BvhNode, CarrierPush, ColliderParams, ColliderPose, DispatchArgs, FailsafePush, Health, NO_LEAF, RigidPose,
    SelfPassPush, SimParams, SphereLeaf, Triangle,
};
use spirv_std::spirv;

/// How near (a share of the thickness) two triangles' boxes at the frame's end must come to be
/// tested (and the reach of the walks).
pub const SEPARATION: f32 = 1e-3;

/// Rounds of check and roll-back in a frame (the last puts the whole cloth back if it still
/// finds a pair). A round that does not run costs its three empty indirect dispatches, and one
/// more per triangle collider (its collider check). A needle's tip through a cell takes rounds:
/// each put back leaves the ring of triangles around it through the needle. With 4, the 64^2
/// needle's cloth went back whole once in 120 frames (4203 particles in all); with 6, never
/// (129 particles).
pub const ROLLBACK_ROUNDS: u32 = 6;

/// Words of the fail-safe's counters: per round, the pairs found and the particles that went
/// back.
pub const FAILSAFE_COUNTER_WORDS: u32 = 2 * ROLLBACK_ROUNDS;

/// Where particle `i` was when the lists in force were built (its anchor's start: the frame's,
/// or its last window's).
#[inline]
fn listed_start(anchors: &[Vec4], i: u32) -> Vec3 {
    anchors[(ANCHOR_WORDS * i) as usize].xyz()
}

/// Where particle `i` started the frame (its anchor's `FRAME_START_WORD`).
#[inline]
pub fn frame_start_of(anchors: &[Vec4], i: u32) -> Vec3 {
    anchors[(ANCHOR_WORDS * i + FRAME_START_WORD) as usize].xyz()
}

/// A triangle at the frame's end: its particles (xyz; the triangle in w) and where its corners
/// ended. Where they started is loaded only when needed (a pair that crosses at the end, a box
/// over the frame): a load of a per-lane address is a loop over the lanes on llvmpipe.
#[derive(Copy, Clone)]
pub struct EndTriangle {
    pub ids: UVec4,
    pub now: [Vec3; 3],
}

impl EndTriangle {
    #[inline]
    pub fn load(ids: UVec4, x: &[Vec4]) -> Self {
        EndTriangle { ids, now: [x[ids.x as usize].xyz(), x[ids.y as usize].xyz(), x[ids.z as usize].xyz()] }
    }

    /// Where its corners started the frame.
    #[inline]
    pub fn start(&self, anchors: &[Vec4]) -> [Vec3; 3] {
        let ids = self.ids;
        [frame_start_of(anchors, ids.x), frame_start_of(anchors, ids.y), frame_start_of(anchors, ids.z)]
    }

    #[inline]
    fn shares_a_particle(&self, other: &EndTriangle) -> bool {
        let (a, b) = (self.ids, other.ids);
        a.x == b.x
            || a.x == b.y
            || a.x == b.z
            || a.y == b.x
            || a.y == b.y
            || a.y == b.z
            || a.z == b.x
            || a.z == b.y
            || a.z == b.z
    }

    /// The box of the triangle at the frame's end.
    #[inline]
    pub fn end_box(&self) -> (Vec3, Vec3) {
        box_of(self.now)
    }

    /// The box of the whole triangle over the frame.
    #[inline]
    pub fn frame_box(&self, anchors: &[Vec4]) -> (Vec3, Vec3) {
        let ((now_lo, now_hi), (start_lo, start_hi)) = (box_of(self.now), box_of(self.start(anchors)));
        (now_lo.min(start_lo), now_hi.max(start_hi))
    }
}

/// The box of a triangle's corners.
#[inline]
fn box_of(c: [Vec3; 3]) -> (Vec3, Vec3) {
    (c[0].min(c[1]).min(c[2]), c[0].max(c[1]).max(c[2]))
}

/// The bound on the rounding error of `orient`'s f32 determinant, relative to its permanent (the
/// sum of its products' magnitudes): Shewchuk's orient3d bound, (7 + 56u) u with u = 2^-24,
/// rounded up.
pub const ORIENT_ERROR: f32 = 1e-6;

/// The sign of the orientation of `d` against the plane of `a`, `b`, `c` (1, -1, or 0), where
/// f32 can tell it: 0 on the plane and wherever the determinant is within its rounding error
/// (`ORIENT_ERROR`), so near-coplanar points never get a sign that rounding gave them. With the
/// plain f32 sign, two triangles of a cloth lying flat on a box (their corners 1e-7 m apart in
/// height), whose boxes touch at a corner, took random signs and crossed: the fail-safe put the
/// whole cloth back at its landing on a cube. A tolerance in metres did as badly the other way
/// (the pile's upright strip, 1e-7 off its plane, counted as touching).
#[inline]
fn orient(a: Vec3, b: Vec3, c: Vec3, d: Vec3) -> i32 {
    let (u, v, w) = (b - a, c - a, d - a);
    let o = u.cross(v).dot(w);
    let permanent = ((u.y * v.z).abs() + (u.z * v.y).abs()) * w.x.abs()
        + ((u.z * v.x).abs() + (u.x * v.z).abs()) * w.y.abs()
        + ((u.x * v.y).abs() + (u.y * v.x).abs()) * w.z.abs();
    let error = ORIENT_ERROR * permanent;
    if o > error {
        1
    } else if o < -error {
        -1
    } else {
        0
    }
}

/// Whether segment `p`-`q` passes through triangle (`a`, `b`, `c`), as far as f32 can tell: its
/// ends on opposite sides of the plane and its line inside the three edges, each orientation
/// beyond its rounding error (`orient`). The f32 twin of
/// `metrics::intersections::segment_crosses_triangle`, which is exact and counts touching too;
/// they differ only where an orientation is within f32's error. There this one says no: a
/// segment nearly in the plane of a cloth triangle lying flat beside it (the cloth on a box's
/// top, its heights a few f32 steps apart) has all three edge orientations within their error,
/// and counted as touching, the fail-safe put the whole cloth back at its landing. Two
/// triangles that truly cross meet along a segment whose ends are where edges pass through, so
/// a crossing is missed only when all of those pass within f32's error of an edge or a plane.
#[inline]
pub fn segment_crosses(p: Vec3, q: Vec3, a: Vec3, b: Vec3, c: Vec3) -> bool {
    if orient(a, b, c, p) * orient(a, b, c, q) >= 0 {
        return false;
    }
    let (e0, e1, e2) = (orient(p, q, a, b), orient(p, q, b, c), orient(p, q, c, a));
    (e0 > 0 && e1 > 0 && e2 > 0) || (e0 < 0 && e1 < 0 && e2 < 0)
}

/// Whether triangles `t` and `u` intersect: an edge of one through the other.
#[inline]
pub fn triangles_cross(t: [Vec3; 3], u: [Vec3; 3]) -> bool {
    segment_crosses(t[0], t[1], u[0], u[1], u[2])
        || segment_crosses(t[1], t[2], u[0], u[1], u[2])
        || segment_crosses(t[2], t[0], u[0], u[1], u[2])
        || segment_crosses(u[0], u[1], t[0], t[1], t[2])
        || segment_crosses(u[1], u[2], t[0], t[1], t[2])
        || segment_crosses(u[2], u[0], t[0], t[1], t[2])
}

/// What a pair that crossed marks: the particles of both its triangles (`flags`, 1 = go back),
/// the sums of the carries of those carried (`carried`, `self_contact::accumulate`'s words),
/// and the round's count of pairs found.
pub struct Found<'a> {
    pub flags: &'a mut [u32],
    pub pairs: &'a mut u32,
    pub carried: &'a mut [u32],
}

/// `flags` of a particle that goes back where the frame found it.
pub const GO_BACK: u32 = 1;
/// `flags` of a particle carried with a moving collider: where it started the frame, moved as
/// the collider's surface under it moved (`surface_motion`; the mean of those of every moving
/// collider triangle that found it, summed as fixed-point integers in `carried`, so the order of
/// the threads changes nothing). The largest flag wins, so a particle both a pair of the
/// cloth's and a moving collider's triangle found is carried: the cloth cannot push the
/// collider out of its way.
pub const CARRIED: u32 = 2;

impl Found<'_> {
    #[inline]
    fn mark(&mut self, a: UVec4, b: UVec4) {
        let corners = [a.x, a.y, a.z, b.x, b.y, b.z];
        let mut k = 0;
        while k < 6 {
            atomics::max(&mut self.flags[corners[k] as usize], GO_BACK);
            k += 1;
        }
        atomics::add(self.pairs, 1);
    }

    /// Marks the particles `ids` of a cloth triangle to be carried by `moves` (each corner's
    /// carry), adding them to their sums in `carried`.
    #[inline]
    fn carry(&mut self, ids: UVec4, moves: [Vec3; 3]) {
        let corners = [ids.x, ids.y, ids.z];
        let mut k = 0;
        while k < 3 {
            accumulate(self.carried, corners[k], moves[k]);
            atomics::max(&mut self.flags[corners[k] as usize], CARRIED);
            k += 1;
        }
    }

    /// `carry`, counting the pair found (a cloth triangle and a collider's).
    #[inline]
    fn mark_carried(&mut self, ids: UVec4, moves: [Vec3; 3]) {
        self.carry(ids, moves);
        atomics::add(self.pairs, 1);
    }

    /// Marks a pair of the cloth's triangles, `a` and `b`, to be carried by `moves` (each
    /// corner's carry, `a`'s then `b`'s).
    #[inline]
    fn mark_pair_carried(&mut self, (a, b): (UVec4, UVec4), moves: ([Vec3; 3], [Vec3; 3])) {
        self.carry(a, moves.0);
        self.carry(b, moves.1);
        atomics::add(self.pairs, 1);
    }
}

/// `carriers` of a particle no moving collider carries; collider `k` (the model's order) is
/// `k + 1`.
pub const NO_CARRIER: u32 = 0;

/// Words (`Vec4`) per particle of its carrier's frames (`Carriers::frames`): three points of
/// the carrying surface where the frame started them, then where it ended them (world; the
/// `then` and `now` of `surface_motion`).
pub const CARRIER_FRAME_WORDS: u32 = 6;

/// Which collider carries each particle this frame (`triangle_carrier_at`), and how: its
/// carrier's frames (`CARRIER_FRAME_WORDS` per particle, written with its carrier).
#[derive(Copy, Clone)]
pub struct Carriers<'a> {
    pub carriers: &'a [u32],
    pub frames: &'a [Vec4],
}

impl Carriers<'_> {
    /// The particle among the corners of `a` and `b` whose carrier carries the whole pair: the
    /// largest carrier, of those the lowest particle, so the pair goes with one surface
    /// whatever the order of the threads; `None` when no corner has a carrier.
    #[inline]
    fn of_pair(self, a: UVec4, b: UVec4) -> Option<u32> {
        let corners = [a.x, a.y, a.z, b.x, b.y, b.z];
        let (mut best, mut chosen) = (NO_CARRIER, u32::MAX);
        let mut k = 0;
        while k < 6 {
            let carrier = self.carriers[corners[k] as usize];
            if carrier > best || (carrier == best && corners[k] < chosen) {
                (best, chosen) = (carrier, corners[k]);
            }
            k += 1;
        }
        if best == NO_CARRIER { None } else { Some(chosen) }
    }

    /// Particle `i`'s carrier triangle where the frame started and ended (`carrier_frames`).
    #[inline]
    fn frames_of(self, i: u32) -> ([Vec3; 3], [Vec3; 3]) {
        carrier_frames(self.frames, i)
    }
}

/// Particle `i`'s carrier triangle where the frame started and where it ended, from `frames`
/// (`CARRIER_FRAME_WORDS` per particle).
#[inline]
fn carrier_frames(frames: &[Vec4], i: u32) -> ([Vec3; 3], [Vec3; 3]) {
    let base = (CARRIER_FRAME_WORDS * i) as usize;
    let then = [frames[base].xyz(), frames[base + 1].xyz(), frames[base + 2].xyz()];
    let now = [frames[base + 3].xyz(), frames[base + 4].xyz(), frames[base + 5].xyz()];
    (then, now)
}

/// How particle `i`'s carrier carries point `p`: `surface_motion` by its frames.
#[inline]
fn carry_by_frames(frames: &[Vec4], i: u32, p: Vec3) -> Vec3 {
    let (then, now) = carrier_frames(frames, i);
    surface_motion(p, then, now)
}

/// How a cloth triangle's corners `start` (where the frame started) move with a collider
/// triangle's surface from `then` to `now`: each corner's `surface_motion`.
#[inline]
fn corners_motion(start: [Vec3; 3], (then, now): ([Vec3; 3], [Vec3; 3])) -> [Vec3; 3] {
    [surface_motion(start[0], then, now), surface_motion(start[1], then, now), surface_motion(start[2], then, now)]
}

/// The leaf (tree order) of a collider where the frame ends nearest to where particle `i`
/// started the frame, within the collider's thickness plus how far its surface moved
/// (`ColliderPose::sweep`); `NO_LEAF` when none is. Only there can going back where the frame
/// started put the particle inside the collider, or within its thickness on its wrong side:
/// farther out, the surface did not reach it.
#[inline]
fn nearest_leaf<K: LeafKind>(
    i: u32,
    (collider, pose): (&ColliderParams, &ColliderPose),
    (nodes, aabbs, leaves): (&[BvhNode], &[Aabb], &[K::Leaf]),
    anchors: &[Vec4],
) -> u32 {
    let start = to_local(&pose.current, frame_start_of(anchors, i));
    let reach = ColliderParams { thickness: collider.thickness + pose.sweep.x, ..*collider };
    traverse::<K>(&reach, nodes, aabbs, leaves, start, start).leaf
}

/// A choice key that names no particle (`choice_key`).
const NO_CHOICE: u32 = u32::MAX;

/// Bits of `CarrierOut::choice` below its collider part: the particle.
const CHOICE_PARTICLE_BITS: u32 = 24;

/// Where a carriers pass writes: each particle's carrier and frames (`Carriers`), and the
/// whole cloth's choice, the particle whose carrier carries the whole cloth when the fail-safe
/// puts it all back: of the last collider with a carrier (the largest carrier), the lowest
/// particle (`choice_key`; the smallest key wins, kept complemented by an atomic maximum, so
/// thread order changes nothing and 0, where the frame starts it, means none).
pub struct CarrierOut<'a> {
    pub carriers: &'a mut [u32],
    pub frames: &'a mut [Vec4],
    pub choice: &'a mut u32,
}

/// The whole cloth's choice key of particle `i` carried by collider `slot`: the collider's
/// distance from the last slot above the particle (24 bits: a particle past 2^24, or a slot past
/// 255, is not chosen; the fail-safe then puts the whole cloth back in the world).
#[inline]
fn choice_key(slot: u32, i: u32) -> u32 {
    if slot > 255 || i >= 1 << CHOICE_PARTICLE_BITS {
        return NO_CHOICE;
    }
    ((255 - slot) << CHOICE_PARTICLE_BITS) | i
}

/// The particle a whole cloth's choice (`CarrierOut::choice`) names, if any.
#[inline]
pub fn chosen_particle(choice: u32) -> Option<u32> {
    if choice == 0 { None } else { Some(!choice & ((1 << CHOICE_PARTICLE_BITS) - 1)) }
}

/// Particle `i`'s carrier `slot + 1` and its frames `then` and `now` (each collider's pass runs
/// after the one before, so the last collider near a particle carries it), and the whole
/// cloth's choice.
#[inline]
fn set_carrier(i: u32, slot: u32, (then, now): ([Vec3; 3], [Vec3; 3]), out: CarrierOut) {
    let CarrierOut { carriers, frames, choice } = out;
    atomics::max(choice, !choice_key(slot, i));
    carriers[i as usize] = slot + 1;
    let base = (CARRIER_FRAME_WORDS * i) as usize;
    let mut k = 0;
    while k < 3 {
        frames[base + k] = then[k].extend(0.0);
        frames[base + 3 + k] = now[k].extend(0.0);
        k += 1;
    }
}

/// Particle `i` (of `count`) against triangle collider `slot` (its tree in its frame and its
/// mesh: `vertices` where the frame ends, `previous` where it started, `indices`, and the
/// tree's `order` of them), when the collider moved (`ColliderPose::sweep`): if it started the
/// frame near the collider (`nearest_leaf`), the collider carries it, by the nearest triangle's
/// frames where the frame started and ended it (placed by the pose then and now), so a rigid
/// motion carries it rigidly and a deformation with that triangle.
pub fn triangle_carrier_at(
    (i, count, slot): (u32, u32, u32),
    (collider, pose): (&ColliderParams, &ColliderPose),
    (nodes, aabbs, leaves): (&[BvhNode], &[Aabb], &[Triangle]),
    (vertices, previous, indices, order): (&[Vec4], &[Vec4], &[u32], &[u32]),
    anchors: &[Vec4],
    out: CarrierOut,
) {
    if i >= count || pose.sweep.x <= 0.0 {
        return;
    }
    let leaf = nearest_leaf::<crate::triangles::Triangles>(i, (collider, pose), (nodes, aabbs, leaves), anchors);
    if leaf == NO_LEAF {
        return;
    }
    let t = 3 * order[leaf as usize] as usize;
    let ids = [indices[t] as usize, indices[t + 1] as usize, indices[t + 2] as usize];
    let frames = (placed(&pose.previous, previous, ids), placed(&pose.current, vertices, ids));
    set_carrier(i, slot, frames, out);
}

/// `triangle_carrier_at` for a sphere collider: the nearest sphere's centre and two points a
/// metre from it, where the frame started it (its centre less its sweep, placed by the pose
/// then) and where it ends it (placed by the pose now), so a deforming collider's sphere carries
/// the particle with its own motion too.
pub fn sphere_carrier_at(
    (i, count, slot): (u32, u32, u32),
    (collider, pose): (&ColliderParams, &ColliderPose),
    (nodes, aabbs, leaves): (&[BvhNode], &[Aabb], &[SphereLeaf]),
    anchors: &[Vec4],
    out: CarrierOut,
) {
    if i >= count || pose.sweep.x <= 0.0 {
        return;
    }
    let leaf = nearest_leaf::<crate::spheres::Spheres>(i, (collider, pose), (nodes, aabbs, leaves), anchors);
    if leaf == NO_LEAF {
        return;
    }
    let sphere = leaves[leaf as usize];
    let (then, now) = (sphere.sphere.xyz() - sphere.sweep.xyz(), sphere.sphere.xyz());
    let at = |p: &RigidPose, c: Vec3| [to_world(p, c), to_world(p, c + Vec3::X), to_world(p, c + Vec3::Y)];
    set_carrier(i, slot, (at(&pose.previous, then), at(&pose.current, now)), out);
}

/// How far (a share of the triangle's shortest side) the fail-safe carries a cloth triangle's
/// corners with a moving collider at most (`gentle`).
pub const CARRY_REACH: f32 = 0.5;

/// Whether carrying a cloth triangle whose corners started the frame at `start` by `moves`
/// keeps it whole: each corner moves at most `CARRY_REACH` of its shortest side. Its
/// neighbours stay where the frame left them, so a longer carry stretches its edges past what
/// the next round can mend: under a star prism spinning at 12 rad/s (its points 9 cm a frame,
/// over 5 cm cells) each round carried a ring of cells whose edges then crossed the next ring,
/// and the crossings grew from 52 to 672 in four frames. There the collider outruns the
/// substeps, and the frame is left as the passes left it.
#[inline]
pub fn gentle(start: [Vec3; 3], moves: [Vec3; 3]) -> bool {
    let shortest2 = (start[1] - start[0])
        .length_squared()
        .min((start[2] - start[1]).length_squared())
        .min((start[0] - start[2]).length_squared());
    let reach2 = CARRY_REACH * CARRY_REACH * shortest2;
    moves[0].length_squared() <= reach2 && moves[1].length_squared() <= reach2 && moves[2].length_squared() <= reach2
}

/// How far a collider triangle that moved from `then` to `now` over the frame carries point `p`
/// (where it was then): `p` in the triangle's frame then (its first corner, its two edges from
/// there and their cross product: `p = a + u ab + v ac + w n`), placed in its frame now. A
/// rigid motion carries it rigidly, however far it lies from the triangle (the far corners of
/// a coarse cloth cell a collider's vertex went through); a deformation stretches the frame
/// with the triangle, and the offset off its plane with its area. No square root: both sides
/// compute the same bits. A triangle with no area: its centroid's motion.
#[inline]
pub fn surface_motion(p: Vec3, then: [Vec3; 3], now: [Vec3; 3]) -> Vec3 {
    let [a, b, c] = then;
    let (ab, ac) = (b - a, c - a);
    let normal = ab.cross(ac);
    if collapsed(normal.length_squared(), longest_side2(a, b, c)) {
        return (now[0] + now[1] + now[2] - (a + b + c)) * (1.0 / 3.0);
    }
    let d = p - a;
    let scale = 1.0 / normal.length_squared();
    let (u, v, w) = (d.cross(ac).dot(normal) * scale, ab.cross(d).dot(normal) * scale, d.dot(normal) * scale);
    let (ab1, ac1) = (now[1] - now[0], now[2] - now[0]);
    now[0] + ab1 * u + ac1 * v + ab1.cross(ac1) * w - p
}

/// Triangles `a` and `b` at the frame's end: found when they share no particle, cross there and
/// did not at the start (a pair that started crossed, e.g. a garment mesh that intersects
/// itself, cannot be helped by going back, and is left alone). A pair with a carrier
/// (`Carriers::of_pair`) is carried with it when that keeps both triangles whole (`gentle`).
#[inline]
pub fn check_triangle_pair(
    (a, b): (&EndTriangle, &EndTriangle),
    (anchors, carriers): (&[Vec4], Carriers),
    separation: f32,
    found: &mut Found,
) {
    if a.shares_a_particle(b) || !within(a.end_box(), b.end_box(), separation) {
        return;
    }
    let (start_a, start_b) = (a.start(anchors), b.start(anchors));
    if !triangles_cross(a.now, b.now) || triangles_cross(start_a, start_b) {
        return;
    }
    let Some(carrier) = carriers.of_pair(a.ids, b.ids) else {
        found.mark(a.ids, b.ids);
        return;
    };
    let frames = carriers.frames_of(carrier);
    let (moves_a, moves_b) = (corners_motion(start_a, frames), corners_motion(start_b, frames));
    if gentle(start_a, moves_a) && gentle(start_b, moves_b) {
        found.mark_pair_carried((a.ids, b.ids), (moves_a, moves_b));
    } else {
        found.mark(a.ids, b.ids);
    }
}

/// How far beyond its slops (a share of the thickness) each corner of a triangle may end the
/// frame for the check to take its list alone (`frame_box_at`). A pair the lists leave out
/// has a gap (its predicted distance over the frame, at least) of the thickness and its
/// corners' slops; its ends, each within its slop and under half the thickness more of its
/// predicted end, stay apart, and one pair of triangles crosses another only where some of its
/// vertex-face or edge-edge pairs meet: neither predicted nor ended paths can take them through
/// each other (`a_pair_left_out_cannot_cross_within_half_a_thickness_beyond_the_slops`, where
/// they do from a whole thickness beyond). A triangle the passes' contact pushed a little off
/// its prediction (the settling standard scene: hundreds a frame) is checked by its list, not
/// by a walk of the whole tree, and where none ends farther the tree is not refit.
pub const LIST_CHECK_BEYOND: f32 = 0.5;

/// Whether a triangle with corners `corners` is wide enough at `thickness` for another's edge to
/// pierce it far from every one of its vertices and edges: its inradius (twice its area over its
/// perimeter) reaches the thickness and two slops. A pair of triangles crossed that deep has no
/// vertex-face or edge-edge pair within a list's reach, so lists built where it already crossed
/// leave it out (`a_wide_triangle_pierced_deep_has_no_pair_listed`); a narrower triangle's
/// crossing always has an edge pair within its inradius. The standard 64^2 cloth's triangles
/// (6.7 mm) are not at 5 mm; a 32^2 cloth of the same size (14 mm) is.
#[inline]
pub fn pierceable_deep(corners: [Vec3; 3], thickness: f32) -> bool {
    let [a, b, c] = corners;
    let twice_area = (b - a).cross(c - a).length();
    let perimeter = (b - a).length() + (c - b).length() + (a - c).length();
    twice_area >= list_reach(thickness) * perimeter
}

/// `FailsafePush::flags` of the boxes: the frame built its lists again within it (windows), so
/// the last lists start where a pair may already have crossed since the frame's start.
pub const WINDOWED: u32 = 4;

/// Sorted leaf `s`'s box over the frame (its corners at the frame's start and now); with the
/// frame's lists, also whether its triangle ended the frame beyond its predicted region (a
/// corner over `LIST_CHECK_BEYOND` of the `thickness` beyond its slop: it walks in the
/// check) and how far its corners strayed from their predicted ends (into `escaped` and
/// `strays`, free after the frame's last pass; `self_pairs::escaped_at` at the frame's end).
/// In a `windowed` frame a triangle that the last lists' start found `pierceable_deep` walks
/// too: a pair that crossed within the frame before those lists, deep, is not in them.
/// Returns the box and whether it walks.
pub fn frame_box_at(
    s: u32,
    sorted: &[UVec4],
    (x, anchors): (&[Vec4], &[Vec4]),
    (indices, thickness, windowed): (&[u32], f32, bool),
    (escaped, strays): (&mut [u32], &mut [f32]),
) -> (Aabb, bool) {
    let ids = sorted[s as usize];
    let end = SelfPassPush { from: 1.0, to: 1.0, find_walkers: 0, beyond: 0.0 };
    let (out, stray) = escaped_at(ids.w, (x, x), anchors, indices, (&end, LIST_CHECK_BEYOND * thickness));
    let listed = [listed_start(anchors, ids.x), listed_start(anchors, ids.y), listed_start(anchors, ids.z)];
    let out = out || (windowed && pierceable_deep(listed, thickness));
    escaped[ids.w as usize] = out as u32;
    strays[ids.w as usize] = stray;
    let (lo, hi) = EndTriangle::load(ids, x).frame_box(anchors);
    (Aabb { min: lo.extend(0.0), max: hi.extend(0.0) }, out)
}

/// `failsafe_boxes`' thread for sorted leaf `s` (of `self_params.leaf_count`): its box over the
/// frame and whether it walks (`frame_box_at`), and the check's refit of the tree raised to
/// every leaf (`refit`, emptied by the host before) by each leaf that walks and, when the
/// frame's passes walk the tree whoever escapes (`tree_every_pass`: a list overflowed, a
/// collider listed sharp triangles, whose check walks it too), by the first leaf. Without
/// lists the host refits the tree every frame.
#[inline]
pub fn failsafe_box_at(
    (s, push): (u32, &FailsafePush),
    self_params: &ColliderParams,
    (sorted, x, anchors, indices): (&[UVec4], &[Vec4], &[Vec4], &[u32]),
    (leaf_bounds, escaped, strays): (&mut [Aabb], &mut [u32], &mut [f32]),
    (tree_every_pass, refit): (u32, &mut DispatchArgs),
) {
    let frame = (indices, self_params.thickness, push.flags & WINDOWED != 0);
    let (bounds, walks) = frame_box_at(s, sorted, (x, anchors), frame, (escaped, strays));
    leaf_bounds[s as usize] = bounds;
    if walks || (s == 0 && tree_every_pass != 0) {
        atomics::max(&mut refit.x, self_params.leaf_count.div_ceil(REFIT_THREADS));
    }
}

/// A leaf's pairs with the leaves its walk reaches: the later ones, and with `take_earlier` (it
/// ended the frame outside its predicted region) the earlier ones that do not walk.
struct FramePairs<'a> {
    leaf: u32,
    mine: EndTriangle,
    sorted: &'a [UVec4],
    x: &'a [Vec4],
    anchors: &'a [Vec4],
    carriers: Carriers<'a>,
    /// Which leaves walk; the earlier ones that do not are taken when `take_earlier`.
    walkers: Walkers<'a>,
    take_earlier: bool,
    separation: f32,
    found: Found<'a>,
}

/// Which leaves walk in the check: those that ended the frame beyond their predicted region by
/// over `LIST_CHECK_BEYOND` of the thickness (`escaped`, per triangle: `frame_box_at`) and
/// those whose list was full (`counts`).
#[derive(Copy, Clone)]
pub struct Walkers<'a> {
    pub escaped: &'a [u32],
    pub counts: &'a [u32],
}

impl Walkers<'_> {
    #[inline]
    fn walks(&self, leaf: u32, sorted: &[UVec4]) -> bool {
        self.escaped[sorted[leaf as usize].w as usize] != 0 || self.counts[leaf as usize] == LIST_OVERFLOWED
    }
}

impl FramePairs<'_> {
    #[inline]
    fn pair(&mut self, leaf: u32) {
        let theirs = EndTriangle::load(self.sorted[leaf as usize], self.x);
        // By value: a reference to a struct of slices is a pointer held as data (`tests/engine.rs`).
        let starts = (self.anchors, self.carriers);
        check_triangle_pair((&self.mine, &theirs), starts, self.separation, &mut self.found);
    }
}

impl LeafVisitor for FramePairs<'_> {
    fn visit(&mut self, leaf: u32) {
        let earlier_taken = self.take_earlier && !self.walkers.walks(leaf, self.sorted);
        if leaf == self.leaf || (leaf < self.leaf && !earlier_taken) {
            return;
        }
        self.pair(leaf);
    }
}

/// Sorted leaf `leaf`'s pairs at the frame's end (`check_triangle_pair`). Without the frame's
/// lists (`with_lists` false), with every later leaf whose box meets its box at the end, through
/// the tree (refit to the boxes over the frame, which hold the boxes at the end in every round).
/// With them, as a pass takes them (`self_pairs::listed_self_pairs_at`, `walk_self_pairs_at`): a
/// leaf that ended the frame within `LIST_CHECK_BEYOND` of the thickness beyond its predicted
/// region tests its list, but for partners that did not, and the entries whose gap less both
/// triangles' strays keeps them a thickness apart (a pair a list leaves out cannot cross at the
/// frame's end while its corners end that near their predicted ends: `LIST_CHECK_BEYOND`); one
/// whose list was full walks for the later leaves; one that ended farther walks for the later
/// leaves and the earlier ones that do not walk.
#[allow(clippy::too_many_arguments)]
pub fn check_frame_at(
    leaf: u32,
    self_params: &ColliderParams,
    (nodes, aabbs, leaf_bounds, sorted): (&[BvhNode], &[Aabb], &[Aabb], &[UVec4]),
    (x, anchors, carriers): (&[Vec4], &[Vec4], Carriers),
    (with_lists, walkers, entries, strays): (bool, Walkers, &[u32], &[f32]),
    found: Found,
) {
    let ids = sorted[leaf as usize];
    let mine = EndTriangle::load(ids, x);
    let separation = SEPARATION * self_params.thickness;
    // Which way the leaf goes, decided before any struct of slices is built: one built before a
    // branch and used after it is a pointer-holding phi, which NVIDIA's compiler crashes on
    // (`tests/engine.rs`).
    let escaped = with_lists && walkers.escaped[ids.w as usize] != 0;
    let count = walkers_count(with_lists, walkers, leaf);
    if with_lists && !escaped && count != LIST_OVERFLOWED {
        let take_earlier = false;
        let mut pairs =
            FramePairs { leaf, mine, sorted, x, anchors, carriers, walkers, take_earlier, separation, found };
        let base = (LIST_ENTRY_WORDS * SELF_LIST_CAPACITY * leaf) as usize;
        let my_stray = strays[ids.w as usize];
        let mut j = 0;
        while j < count as usize {
            let entry = base + LIST_ENTRY_WORDS as usize * j;
            let other = entries[entry];
            let theirs = sorted[other as usize].w as usize;
            let gap = f32::from_bits(entries[entry + 2]);
            if walkers.escaped[theirs] == 0 && may_touch(gap, my_stray + strays[theirs], self_params.thickness) {
                pairs.pair(other);
            }
            j += 1;
        }
        return;
    }
    let (lo, hi) = mine.end_box();
    let query = (lo - Vec3::splat(separation), hi + Vec3::splat(separation));
    let walk = if escaped {
        PairWalk::all(self_params.leaf_count)
    } else {
        PairWalk::new(leaf, nodes, self_params.leaf_count)
    };
    let take_earlier = escaped;
    let mut pairs = FramePairs { leaf, mine, sorted, x, anchors, carriers, walkers, take_earlier, separation, found };
    walk_in_batches(walk, (nodes, aabbs, leaf_bounds), query, &mut pairs);
}

/// Leaf `leaf`'s list count with the frame's lists (0 without: the counts are stale then).
#[inline]
fn walkers_count(with_lists: bool, walkers: Walkers, leaf: u32) -> u32 {
    if with_lists { walkers.counts[leaf as usize] } else { 0 }
}

/// The brute-force baseline of `check_frame_at` without lists: sorted leaf `leaf` against every
/// later leaf.
pub fn check_frame_brute_force_at(
    leaf: u32,
    self_params: &ColliderParams,
    sorted: &[UVec4],
    (x, anchors, carriers): (&[Vec4], &[Vec4], Carriers),
    mut found: Found,
) {
    let mine = EndTriangle::load(sorted[leaf as usize], x);
    let separation = SEPARATION * self_params.thickness;
    let mut other = leaf + 1;
    while other < self_params.leaf_count {
        let theirs = EndTriangle::load(sorted[other as usize], x);
        check_triangle_pair((&mine, &theirs), (anchors, carriers), separation, &mut found);
        other += 1;
    }
}

/// A collider triangle (its corners where the frame ends) against the cloth triangles whose
/// boxes over the frame meet its box.
struct ColliderFramePairs<'a> {
    corners: [Vec3; 3],
    /// Its corners where the frame started (`corners` for a triangle that did not move), and
    /// whether it moved.
    corners_then: ([Vec3; 3], bool),
    /// Their box (`box_of`).
    bounds: (Vec3, Vec3),
    sorted: &'a [UVec4],
    x: &'a [Vec4],
    anchors: &'a [Vec4],
    separation: f32,
    found: Found<'a>,
    /// Counts the pairs found (`Health::self_rollback_collider_pairs`; atomically, through the
    /// pointer: a count kept in the visitor makes it a value the walk's loop carries, a
    /// pointer-holding phi, `tests/engine.rs`).
    health: &'a mut Health,
}

impl LeafVisitor for ColliderFramePairs<'_> {
    fn visit(&mut self, leaf: u32) {
        let cloth = EndTriangle::load(self.sorted[leaf as usize], self.x);
        if !within(cloth.end_box(), self.bounds, self.separation) || !triangles_cross(cloth.now, self.corners) {
            return;
        }
        let start = cloth.start(self.anchors);
        let (then, moved) = self.corners_then;
        if triangles_cross(start, then) {
            return; // crossed at the frame's start too: going back cannot help
        }
        if !moved {
            self.found.mark(cloth.ids, cloth.ids);
        } else {
            let moves = corners_motion(start, (then, self.corners));
            if !gentle(start, moves) {
                return;
            }
            self.found.mark_carried(cloth.ids, moves);
        }
        atomics::add(&mut self.health.self_rollback_collider_pairs, 1);
    }
}

/// Collider triangle `triangle` (`indices` into its mesh's local `vertices`, placed by its
/// pose where the frame ends) against the cloth's triangles at the frame's end: a cloth
/// triangle that crosses it there, and did not where both started the frame, has its particles
/// marked to go back. That is a collider's vertex or edge through a cloth cell (a needle's tip
/// that a cell slipped over within a pass, which no later pass sees again, as it starts on the
/// wrong side), or a cloth edge through the collider's face. Going back undoes only what the
/// cloth's own motion did, so where the triangle moved over the frame (its collider's pose, or
/// its corners as the collider deforms: `previous` against `vertices`), "back" is relative to
/// its surface: the particles go where they started, carried as the surface under them moved
/// (`surface_motion`). Put back in the world instead, a cloth would lie where the collider now
/// is (a star prism spinning at 6 rad/s put the whole cloth back in 42 of 90 frames and left 20
/// times the crossings); carried, the garment's coarse skirt (10 around) no longer hangs
/// through its turning body.
pub fn check_collider_triangle_at(
    triangle: u32,
    (vertices, previous, indices, pose): (&[Vec4], &[Vec4], &[u32], &ColliderPose),
    self_params: &ColliderParams,
    (nodes, aabbs, leaf_bounds, sorted): (&[BvhNode], &[Aabb], &[Aabb], &[UVec4]),
    (x, anchors): (&[Vec4], &[Vec4]),
    (found, health): (Found, &mut Health),
) {
    let i = 3 * triangle as usize;
    let (ia, ib, ic) = (indices[i] as usize, indices[i + 1] as usize, indices[i + 2] as usize);
    let ids = [ia, ib, ic];
    let (corners, corners_then) = (placed(&pose.current, vertices, ids), placed(&pose.previous, previous, ids));
    let moved = corners_then[0] != corners[0] || corners_then[1] != corners[1] || corners_then[2] != corners[2];
    let separation = SEPARATION * self_params.thickness;
    let reach = Vec3::splat(separation);
    let (lo, hi) = box_of(corners);
    let mut pairs = ColliderFramePairs {
        corners,
        corners_then: (corners_then, moved),
        bounds: (lo, hi),
        sorted,
        x,
        anchors,
        separation,
        found,
        health,
    };
    walk_overlapping((nodes, aabbs, leaf_bounds), self_params.leaf_count, (lo - reach, hi + reach), &mut pairs);
}

/// The corners `ids` of a collider's local `points`, placed in the world by pose `at`.
#[inline]
fn placed(at: &RigidPose, points: &[Vec4], [a, b, c]: [usize; 3]) -> [Vec3; 3] {
    [to_world(at, points[a].xyz()), to_world(at, points[b].xyz()), to_world(at, points[c].xyz())]
}

/// `FailsafePush::flags`: this round is the last (a pair it finds puts the whole cloth back).
pub const LAST_ROUND: u32 = 1;
/// `FailsafePush::flags`: the frame built pair lists (`check_frame_at` takes them).
pub const WITH_LISTS: u32 = 2;
/// `FailsafePush::flags` from this bit up: the frame's substeps (the roll-back's frame time is
/// that many of `SimParams::substep`).
pub const SUBSTEPS_SHIFT: u32 = 8;

/// Particle `i` after a round of checks: if a pair marked it, back to where the frame started
/// (or, carried by a moving collider, to there carried by the mean of its carries: `carried`,
/// which it clears), at rest (its sleep flag kept): a carried particle at rest against what
/// carried it, moving as its carry over the frame (of `substep` s substeps, `SUBSTEPS_SHIFT`).
/// On the last round, when the round found any pair, every particle back to where the frame
/// started, at rest; near a collider that moved (`choice`, `CarrierOut`), all carried by the
/// chosen particle's carrier and at rest against it: one affine map for the whole cloth keeps
/// it as free of crossings as it started, and off the collider where it moves rigidly. Each
/// particle carried by its own carrier instead, the layers at friction 2.1 ended 20 frames with
/// layers through each other. Pinned particles stay (their motion is the caller's). Counts the particles
/// that moved back (into the round's counter and the frame's health); the first of a round
/// that is not the last dispatches the next round (`next_check`, `next_rollback`).
///
/// At rest against the carrier, not in the world: a particle that a turning body carries and
/// that went back at rest in the world was dragged by the body's friction again in the next
/// frame. The layers scene at a body friction of 1.5 put 1845 particles back in 98 of 150
/// frames that way, 981 in 68 moving with their carrier; an edge stretched beyond 1.3 times
/// its length after 43 and after 28 of the first 110 frames.
#[allow(clippy::too_many_arguments)]
pub fn roll_back_at(
    i: u32,
    (push, substep): (&FailsafePush, f32),
    (x, v): (&mut [Vec4], &mut [Vec4]),
    (anchors, carried, (carrier_frames, choice)): (&[Vec4], &mut [u32], (&[Vec4], u32)),
    flags: &mut [u32],
    counters: &mut [u32],
    (next_check, next_rollback): (&mut DispatchArgs, &mut DispatchArgs),
    health: &mut Health,
) {
    let flag = flags[i as usize];
    flags[i as usize] = 0;
    let round = push.round;
    let last = push.flags & LAST_ROUND != 0;
    let everything = last && counters[(2 * round) as usize] != 0;
    let carry = if flag >= CARRIED { take_carry(carried, i) } else { Vec3::ZERO };
    let p = x[i as usize];
    if !(flag != 0 || everything) || p.w <= 0.0 {
        return;
    }
    let start = frame_start_of(anchors, i);
    let (carry, carried_back) = if everything {
        match chosen_particle(choice) {
            Some(chosen) => (carry_by_frames(carrier_frames, chosen, start), true),
            None => (Vec3::ZERO, false),
        }
    } else {
        (carry, flag >= CARRIED)
    };
    let target = start + carry;
    if p.xyz() == target {
        return;
    }
    x[i as usize] = target.extend(p.w);
    let frame_time = substep * (push.flags >> SUBSTEPS_SHIFT) as f32;
    let carried_along = if frame_time <= 0.0 { Vec3::ZERO } else { carry * (1.0 / frame_time) };
    v[i as usize] = carried_along.extend(v[i as usize].w);
    atomics::add(&mut health.self_rollbacks, 1);
    if carried_back {
        atomics::add(&mut health.self_rollbacks_carried, 1);
    }
    if atomics::add(&mut counters[(2 * round + 1) as usize], 1) == 0 && !last {
        next_check.x = push.check_groups;
        next_rollback.x = push.rollback_groups;
    }
}

/// Particle `i`'s carry (the mean of its sums in `carried`), its sums cleared for the next
/// round.
#[inline]
fn take_carry(carried: &mut [u32], i: u32) -> Vec3 {
    let carry = mean_of(carried, i as usize, FIXED_SCALE).unwrap_or(Vec3::ZERO);
    let base = 4 * i as usize;
    carried[base] = 0;
    carried[base + 1] = 0;
    carried[base + 2] = 0;
    carried[base + 3] = 0;
    carry
}

/// The health's record of a whole cloth put back (the last round found a pair).
#[inline]
pub fn note_everything(push: &FailsafePush, counters: &[u32], health: &mut Health) {
    if push.flags & LAST_ROUND != 0 && counters[(2 * push.round) as usize] != 0 {
        health.self_rollback_all = 1;
    }
}

/// Threads per workgroup of the boxes and the check (a round's boxes run again, with its
/// check's dispatch, after a roll-back).
pub const CHECK_THREADS: u32 = 64;

/// One thread per sorted leaf (push constants: `FailsafePush`, its flags `WINDOWED` or 0): the
/// leaf's box over the frame, and where it ended against its predicted region
/// (`failsafe_box_at`), and the tree's refit flags cleared (each round's boxes
/// then refit the tree: a particle carried back lies where neither its start nor its end
/// was, outside the box the round before gave its triangle, where a walk would miss it).
#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(64)))]
pub fn failsafe_boxes(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] push: &FailsafePush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] self_params: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] sorted: &[UVec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] x: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] anchors: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] indices: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] leaf_bounds: &mut [Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] escaped: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] strays: &mut [f32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] refit_flags: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] tree_every_pass: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] refit: &mut DispatchArgs,
) {
    if id.x < self_params.leaf_count {
        let frame = (sorted, x, anchors, indices);
        let out = (leaf_bounds, escaped, strays);
        failsafe_box_at((id.x, push), self_params, frame, out, (tree_every_pass[0], refit));
    }
    if id.x + 1 < self_params.leaf_count {
        refit_flags[id.x as usize] = 0;
    }
}

/// The first round's tree, where the frame's lists span the whole frame: each internal node's
/// box derived from the lists' tree over the frame, past the slops by `LIST_CHECK_BEYOND`
/// (`self_pass_tree::derive_pass_tree`, dispatched before this), holds the box over the frame
/// of every triangle that did not walk (its corners started at their anchors' starts and ended
/// within that of their predicted ends); each that walks climbs to the root widening the nodes
/// above it (`self_pass_tree::widen_to_leaf_at`): one thread per sorted leaf `s`, over the
/// refit's dispatch (raised where one walks, or where the colliders' check walks the tree).
#[inline]
pub fn widen_failsafe_tree_at(
    s: u32,
    leaf_count: u32,
    (sorted, escaped): (&[UVec4], &[u32]),
    (parents, leaf_bounds): (&[u32], &[Aabb]),
    aabbs: &mut [u32],
) {
    if s < leaf_count && escaped[sorted[s as usize].w as usize] != 0 {
        widen_to_leaf_at(s, leaf_count, parents, leaf_bounds, aabbs);
    }
}

/// A later round's boxes and refit in one dispatch (the round's check dispatch, only when the
/// round before put a particle back): each sorted leaf's box over the frame and whether it walks
/// (`failsafe_box_at`), then its climb of the tree's refit (`lbvh::refit_from_leaf`; the
/// flag's release orders a leaf's box before its sibling's climb reads it, as it does a node's).
/// The refit's flags were cleared by the round before's check (`failsafe_check`).
#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(64)))]
pub fn failsafe_boxes_and_refit(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] push: &FailsafePush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] self_params: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] sorted: &[UVec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] x: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] anchors: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] indices: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] leaf_bounds: &mut [Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] escaped: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] strays: &mut [f32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] tree_every_pass: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] refit: &mut DispatchArgs,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] nodes: &[BvhNode],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] parents: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 12)] refit_flags: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 13)] aabbs: &mut [u32],
) {
    let n = self_params.leaf_count;
    if id.x < n {
        let frame = (sorted, x, anchors, indices);
        let out = (&mut *leaf_bounds, escaped, strays);
        failsafe_box_at((id.x, push), self_params, frame, out, (tree_every_pass[0], refit));
        if n >= 2 {
            refit_from_leaf(id.x, n, nodes, parents, leaf_bounds, refit_flags, aabbs);
        }
    }
}

/// `widen_failsafe_tree_at` for each sorted leaf.
#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(256)))]
pub fn widen_failsafe_tree(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] self_params: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] sorted: &[UVec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] escaped: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] parents: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] leaf_bounds: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] aabbs: &mut [u32],
) {
    widen_failsafe_tree_at(id.x, self_params.leaf_count, (sorted, escaped), (parents, leaf_bounds), aabbs);
}

/// One thread per sorted leaf: its pairs at the frame's end (`check_frame_at`), and the tree's
/// refit flags cleared for the next round; push constants: `FailsafePush` (the round).
#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(64)))]
pub fn failsafe_check(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] push: &FailsafePush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] self_params: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] nodes: &[BvhNode],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] aabbs: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] leaf_bounds: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] sorted: &[UVec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] x: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] anchors: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] escaped: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] strays: &[f32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] lists: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] counts: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] carriers: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 12)] carrier_frames: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 13)] flags: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 14)] counters: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 15)] carried: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 16)] refit_flags: &mut [u32],
) {
    // The next round's refit climbs in its boxes' dispatch (`failsafe_boxes_and_refit`), which
    // cannot clear its own flags.
    if id.x + 1 < self_params.leaf_count {
        refit_flags[id.x as usize] = 0;
    }
    if id.x >= self_params.leaf_count {
        return;
    }
    let found = Found { flags, pairs: &mut counters[(2 * push.round) as usize], carried };
    let with_lists = (push.flags & WITH_LISTS != 0, Walkers { escaped, counts }, lists, strays);
    let tree = (nodes, aabbs, leaf_bounds, sorted);
    let carriers = Carriers { carriers, frames: carrier_frames };
    check_frame_at(id.x, self_params, tree, (x, anchors, carriers), with_lists, found);
}

/// A triangle collider's triangles listed as possibly sharp for the cloth this frame
/// (`sharp_features`; count in `sharp_args._pad`) against the cloth's at the frame's end
/// (`check_collider_triangle_at`), each thread taking every `check_groups x CHECK_THREADS`-th:
/// dispatched like the round's check (after the first round, only when the round before put a
/// particle back); push constants: `FailsafePush` (the round).
#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(64)))]
pub fn failsafe_collider_check(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] push: &FailsafePush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] self_params: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] pose: &ColliderPose,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] vertices: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] previous: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] indices: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] sharp: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] sharp_args: &DispatchArgs,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] nodes: &[BvhNode],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] aabbs: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] leaf_bounds: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] sorted: &[UVec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] x: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 12)] anchors: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 13)] flags: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 14)] counters: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 15)] carried: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 16)] health: &mut Health,
) {
    let stride = push.check_groups * CHECK_THREADS;
    let mut listed = id.x;
    while listed < sharp_args._pad {
        let pairs = &mut counters[(2 * push.round) as usize];
        let found = Found { flags: &mut *flags, pairs, carried: &mut *carried };
        let tree = (nodes, aabbs, leaf_bounds, sorted);
        check_collider_triangle_at(
            sharp[listed as usize],
            (vertices, previous, indices, pose),
            self_params,
            tree,
            (x, anchors),
            (found, &mut *health),
        );
        listed += stride;
    }
}

/// One thread per particle: its carrier among a triangle collider's (`triangle_carrier_at`),
/// before the first round's check; push constants: `CarrierPush` (the collider's slot).
#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(64)))]
pub fn failsafe_carriers_triangles(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] push: &CarrierPush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &SimParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] collider: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] pose: &ColliderPose,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] nodes: &[BvhNode],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] aabbs: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] leaves: &[Triangle],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] vertices: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] previous: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] indices: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] order: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] anchors: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] carriers: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 12)] carrier_frames: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 13)] carrier_choice: &mut u32,
) {
    triangle_carrier_at(
        (id.x, params.particle_count, push.slot),
        (collider, pose),
        (nodes, aabbs, leaves),
        (vertices, previous, indices, order),
        anchors,
        CarrierOut { carriers, frames: carrier_frames, choice: carrier_choice },
    );
}

/// One thread per particle: its carrier among a sphere collider's (`sphere_carrier_at`);
/// push constants: `CarrierPush`.
#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(64)))]
pub fn failsafe_carriers_spheres(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] push: &CarrierPush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &SimParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] collider: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] pose: &ColliderPose,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] nodes: &[BvhNode],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] aabbs: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] leaves: &[SphereLeaf],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] anchors: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] carriers: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] carrier_frames: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] carrier_choice: &mut u32,
) {
    sphere_carrier_at(
        (id.x, params.particle_count, push.slot),
        (collider, pose),
        (nodes, aabbs, leaves),
        anchors,
        CarrierOut { carriers, frames: carrier_frames, choice: carrier_choice },
    );
}

/// One thread per particle: `roll_back_at`; push constants: `FailsafePush`.
#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(256)))]
pub fn failsafe_roll_back(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] push: &FailsafePush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &SimParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] x: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] v: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] anchors: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] carried: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] flags: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] counters: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] next_check: &mut DispatchArgs,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] next_rollback: &mut DispatchArgs,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] health: &mut Health,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] carrier_frames: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] carrier_choice: &u32,
) {
    if id.x == 0 {
        note_everything(push, counters, health);
    }
    if id.x < params.particle_count {
        let starts = (anchors, carried, (carrier_frames, *carrier_choice));
        let push = (push, params.substep);
        roll_back_at(id.x, push, (x, v), starts, flags, counters, (next_check, next_rollback), health);
    }
}
