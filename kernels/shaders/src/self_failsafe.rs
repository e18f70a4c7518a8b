//! Self-collision's fail-safe: the frame's end is checked against its start, and the particles
//! of any pair that crossed are put back where the frame found them.
//!
//! The passes (`self_contact`) push pairs within the thickness apart, each particle by the mean
//! of its corrections. Where the cloth is squeezed (a layer pressed between the ground and the
//! layers on it), those corrections disagree, the mean leaves a pair closer each pass, and two
//! layers can pass through each other (the pile scene: 2 of 600 frames). So, as Bridson et al.
//! (2002) follow their repulsions with a collision check, every frame ends with one:
//! - each triangle's box over the frame (start to end) refits the self-collision tree;
//! - every vertex-face and edge-edge pair (sharing no particle) whose boxes meet is swept
//!   linearly from the frame's start to its end by additive continuous collision detection (Li,
//!   Kaufman and Jiang 2021, "Codimensional Incremental Potential Contact", algorithm 1):
//!   conservative advancement that never steps past a contact, so a pair that comes within
//!   `SEPARATION` of touching is always found (and one it cannot clear in `ACCD_STEPS` steps is
//!   counted as found);
//! - the particles of the pairs found go back to their positions at the frame's start, at rest.
//!
//! Every particle back at the start leaves its pairs as they were at the start; a pair with one
//! particle back and the others moved is a new motion, so the check runs again
//! (`ROLLBACK_ROUNDS` rounds, each after the first dispatched only when the round before put a
//! particle back; from the second on, a pair found puts its two triangles back whole,
//! `whole_triangles_in`). If the last round still finds a pair, the whole cloth goes back: the
//! frame's start has no crossing, so the frame's end has none either.
//!
//! The frame's start: each particle's anchor (`self_pairs::anchor_at`) holds it.

use crate::atomics;
use crate::lbvh::{PairWalk, box_meets};
use crate::self_contact::{
    LeafVisitor, PAIR_EDGES_SHIFT, closest_between_segments, closest_with_weights, longest_side2, pair_mask,
    walk_in_batches,
};
use crate::self_pairs::{ANCHOR_WORDS, LIST_ENTRY_WORDS, LIST_OVERFLOWED, SELF_LIST_CAPACITY, escaped_at, may_touch};
use drape_types::glam::{UVec3, UVec4, Vec3, Vec4, Vec4Swizzles};
use drape_types::{Aabb, BvhNode, ColliderParams, DispatchArgs, FailsafePush, Health, SelfPassPush, SimParams};
#[cfg(target_arch = "spirv")]
use spirv_std::num_traits::Float;
use spirv_std::spirv;

/// How close (a share of the thickness) a swept pair may come before it counts as crossing: far
/// above the rounding of the distances (f32 positions of a cloth a metre across round at 6e-8
/// m), far below the thickness the passes keep.
pub const SEPARATION: f32 = 1e-3;

/// Steps of conservative advancement a pair gets: one that has not cleared the frame by then
/// (it grazes within a hair over a long slide) counts as crossing. A pair apart by more than
/// its relative motion clears in one.
pub const ACCD_STEPS: u32 = 64;

/// Rounds of check and roll-back in a frame (the last puts the whole cloth back if it still
/// finds a pair). The dragon's impact (64^2 cloth, 30 frames) needed up to 6 rounds particle by
/// particle; with triangles put back whole from the second round, 4 (3 put the whole cloth back
/// once). A round that does not run costs its three empty indirect dispatches.
pub const ROLLBACK_ROUNDS: u32 = 4;

/// Words of the fail-safe's counters: per round, the pairs found and the particles that went
/// back.
pub const FAILSAFE_COUNTER_WORDS: u32 = 2 * ROLLBACK_ROUNDS;

/// Where particle `i` started the frame: its anchor's position.
#[inline]
pub fn frame_start_of(anchors: &[Vec4], i: u32) -> Vec3 {
    anchors[(ANCHOR_WORDS * i) as usize].xyz()
}

/// A triangle over the frame: its particles (xyz; the triangle in w), where its corners started
/// (`then`) and ended (`now`).
#[derive(Copy, Clone)]
pub struct SweptTriangle {
    pub ids: UVec4,
    pub then: [Vec3; 3],
    pub now: [Vec3; 3],
}

impl SweptTriangle {
    #[inline]
    pub fn load(ids: UVec4, x: &[Vec4], anchors: &[Vec4]) -> Self {
        SweptTriangle {
            ids,
            then: [frame_start_of(anchors, ids.x), frame_start_of(anchors, ids.y), frame_start_of(anchors, ids.z)],
            now: [x[ids.x as usize].xyz(), x[ids.y as usize].xyz(), x[ids.z as usize].xyz()],
        }
    }

    #[inline]
    fn id(&self, k: usize) -> u32 {
        if k == 0 {
            self.ids.x
        } else if k == 1 {
            self.ids.y
        } else {
            self.ids.z
        }
    }

    #[inline]
    fn has(&self, id: u32) -> bool {
        self.ids.x == id || self.ids.y == id || self.ids.z == id
    }

    /// The box of corners `k` and `m` over the frame (one corner's when `k == m`).
    #[inline]
    fn swept_box(&self, k: usize, m: usize) -> (Vec3, Vec3) {
        let lo = self.now[k].min(self.then[k]).min(self.now[m]).min(self.then[m]);
        let hi = self.now[k].max(self.then[k]).max(self.now[m]).max(self.then[m]);
        (lo, hi)
    }

    /// The box of the whole triangle over the frame.
    #[inline]
    pub fn box3(&self) -> (Vec3, Vec3) {
        let (n, t) = (self.now, self.then);
        (n[0].min(n[1]).min(n[2]).min(t[0]).min(t[1]).min(t[2]), n[0].max(n[1]).max(n[2]).max(t[0]).max(t[1]).max(t[2]))
    }

    /// The box of the triangle at the frame's start.
    #[inline]
    fn start_box(&self) -> (Vec3, Vec3) {
        let t = self.then;
        (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]))
    }
}

/// The squared distance from `p` to triangle (`a`, `b`, `c`); a collapsed triangle's is the
/// distance to its sides.
#[inline]
pub fn point_triangle_distance2(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> f32 {
    let area2 = (b - a).cross(c - a).length_squared();
    let longest = longest_side2(a, b, c);
    if area2 > 1e-8 * longest * longest {
        let (q, _) = closest_with_weights(p, a, b, c);
        return (p - q).length_squared();
    }
    segment_distance2(p, p, a, b).min(segment_distance2(p, p, b, c)).min(segment_distance2(p, p, c, a))
}

/// The squared distance between segments `a`-`b` and `c`-`d`.
#[inline]
pub fn segment_distance2(a: Vec3, b: Vec3, c: Vec3, d: Vec3) -> f32 {
    let (s, t) = closest_between_segments(a, b, c, d);
    ((a + (b - a) * s) - (c + (d - c) * t)).length_squared()
}

/// The squared distance of a pair of four points: vertex 0 against triangle 1-2-3 (`edges`
/// false) or edge 0-1 against edge 2-3.
#[inline]
fn pair_distance2(p: [Vec3; 4], edges: bool) -> f32 {
    if edges { segment_distance2(p[0], p[1], p[2], p[3]) } else { point_triangle_distance2(p[0], p[1], p[2], p[3]) }
}

/// Whether a pair of four points (`then` at the frame's start, `now` at its end; vertex 0
/// against triangle 1-2-3, or edge 0-1 against edge 2-3 with `edges`) comes within
/// `separation` of touching on the straight path between (additive CCD). A pair that starts
/// closer than twice `separation` only must not come within half its start's distance (a pair
/// already touching at the start cannot be helped, and is left alone).
pub fn pair_meets(then: [Vec3; 4], now: [Vec3; 4], edges: bool, separation: f32) -> bool {
    let mut motion = [now[0] - then[0], now[1] - then[1], now[2] - then[2], now[3] - then[3]];
    // Distances do not change when every point moves alike: only the motion relative to the
    // mean counts.
    let mean = (motion[0] + motion[1] + motion[2] + motion[3]) * 0.25;
    let mut k = 0;
    while k < 4 {
        motion[k] -= mean;
        k += 1;
    }
    let lengths = [motion[0].length(), motion[1].length(), motion[2].length(), motion[3].length()];
    // The fastest that the pair's distance can shrink (per unit of the frame).
    let bound = if edges {
        lengths[0].max(lengths[1]) + lengths[2].max(lengths[3])
    } else {
        lengths[0] + lengths[1].max(lengths[2]).max(lengths[3])
    };
    if bound <= 0.0 {
        return false;
    }
    let d2 = pair_distance2(then, edges);
    if d2 <= 0.0 {
        return false;
    }
    let xi = separation.min(0.5 * d2.sqrt());
    let gap = |d2: f32| (d2 - xi * xi) * (1.0 / (d2.sqrt() + xi)); // the distance less xi
    let mut t = 0.0;
    let mut step = 0.9 * gap(d2) * (1.0 / bound);
    let mut i = 0;
    while i < ACCD_STEPS {
        if t + step >= 1.0 {
            return false; // clears the frame
        }
        t += step;
        let at = [
            then[0] + (now[0] - then[0]) * t,
            then[1] + (now[1] - then[1]) * t,
            then[2] + (now[2] - then[2]) * t,
            then[3] + (now[3] - then[3]) * t,
        ];
        let d2 = pair_distance2(at, edges);
        if d2 <= xi * xi {
            return true;
        }
        step = 0.9 * gap(d2) * (1.0 / bound);
        i += 1;
    }
    true
}

/// What a pair that crossed marks: its particles (`flags`, 1 = go back), or with
/// `whole_triangles` every corner of its two triangles; and the round's count of pairs found.
pub struct Found<'a> {
    pub flags: &'a mut [u32],
    pub pairs: &'a mut u32,
    pub whole_triangles: bool,
}

impl Found<'_> {
    #[inline]
    fn mark(&mut self, ids: [u32; 4], (a, b): (UVec4, UVec4)) {
        let mut k = 0;
        while k < 4 {
            atomics::max(&mut self.flags[ids[k] as usize], 1);
            k += 1;
        }
        if self.whole_triangles {
            let corners = [a.x, a.y, a.z, b.x, b.y, b.z];
            k = 0;
            while k < 6 {
                atomics::max(&mut self.flags[corners[k] as usize], 1);
                k += 1;
            }
        }
        atomics::add(self.pairs, 1);
    }
}

/// Whether round `round`'s pairs put back every corner of their two triangles: the first round
/// puts back only the particles of the pairs found; a pair found after that is one the particles
/// put back made (one of them back, the others moved on), and putting their triangles back
/// whole ends those chains in fewer rounds (the dragon's impact: particle by particle, up to 6
/// rounds; a chain longer than the rounds puts the whole cloth back).
#[inline]
pub fn whole_triangles_in(round: u32) -> bool {
    round > 0
}

/// Whether two boxes meet once one is grown by `reach`.
#[inline]
fn near(a: (Vec3, Vec3), b: (Vec3, Vec3), reach: f32) -> bool {
    let r = Vec3::splat(reach);
    a.0.cmple(b.1 + r).all() && a.1.cmpge(b.0 - r).all()
}

/// Whether triangles `a` and `b` can come within `reach` over the frame at all: the gap between
/// their boxes at the start, against the most their corners move relative to the six's mean
/// (the pairs of a cloth moving as a whole, however fast, are cleared here).
#[inline]
fn may_meet(a: &SweptTriangle, b: &SweptTriangle, reach: f32) -> bool {
    let mut mean = Vec3::ZERO;
    let mut k = 0;
    while k < 3 {
        mean += (a.now[k] - a.then[k]) + (b.now[k] - b.then[k]);
        k += 1;
    }
    mean *= 1.0 / 6.0;
    let mut ra: f32 = 0.0;
    let mut rb: f32 = 0.0;
    k = 0;
    while k < 3 {
        ra = ra.max((a.now[k] - a.then[k] - mean).length());
        rb = rb.max((b.now[k] - b.then[k] - mean).length());
        k += 1;
    }
    near(a.start_box(), b.start_box(), reach + ra + rb)
}

/// Triangles `a` and `b` (sharing no pair the other triangle handles: `mask`, `pair_mask`)
/// swept over the frame: each owned corner against the other's face, each owned edge against
/// the other's owned edges; the pairs that meet are marked.
pub fn sweep_triangle_pair(a: &SweptTriangle, b: &SweptTriangle, mask: u32, separation: f32, found: &mut Found) {
    if !may_meet(a, b, separation) {
        return;
    }
    corners_against(a, mask & 7, b, separation, found);
    corners_against(b, (mask >> 3) & 7, a, separation, found);
    let mut k = 0;
    while k < 3 {
        let edges = (mask >> (PAIR_EDGES_SHIFT + 3 * k as u32)) & 7;
        let k1 = (k + 1) % 3;
        let mut m = 0;
        while m < 3 {
            let m1 = (m + 1) % 3;
            let ids = [a.id(k), a.id(k1), b.id(m), b.id(m1)];
            let shares = ids[0] == ids[2] || ids[0] == ids[3] || ids[1] == ids[2] || ids[1] == ids[3];
            if edges & (1 << m) != 0 && !shares && near(a.swept_box(k, k1), b.swept_box(m, m1), separation) {
                let then = [a.then[k], a.then[k1], b.then[m], b.then[m1]];
                let now = [a.now[k], a.now[k1], b.now[m], b.now[m1]];
                if pair_meets(then, now, true, separation) {
                    found.mark(ids, (a.ids, b.ids));
                }
            }
            m += 1;
        }
        k += 1;
    }
}

/// The corners of `vertices` in `corners` (bit k: corner k) against the face of `face`.
#[inline]
fn corners_against(vertices: &SweptTriangle, corners: u32, face: &SweptTriangle, separation: f32, found: &mut Found) {
    let face_box = face.box3();
    let mut k = 0;
    while k < 3 {
        let id = vertices.id(k);
        if corners & (1 << k) != 0 && !face.has(id) && near(vertices.swept_box(k, k), face_box, separation) {
            let then = [vertices.then[k], face.then[0], face.then[1], face.then[2]];
            let now = [vertices.now[k], face.now[0], face.now[1], face.now[2]];
            if pair_meets(then, now, false, separation) {
                found.mark([id, face.ids.x, face.ids.y, face.ids.z], (vertices.ids, face.ids));
            }
        }
        k += 1;
    }
}

/// Sorted leaf `s`'s box over the frame (its corners at the frame's start and now); with the
/// frame's lists, also whether its triangle ended the frame outside its predicted region and
/// how far its corners strayed from their predicted ends (into `escaped` and `strays`, free
/// after the frame's last pass; `self_pairs::escaped_at` at the frame's end).
pub fn frame_box_at(
    s: u32,
    sorted: &[UVec4],
    (x, anchors): (&[Vec4], &[Vec4]),
    indices: &[u32],
    (escaped, strays): (&mut [u32], &mut [f32]),
) -> Aabb {
    let ids = sorted[s as usize];
    let end = SelfPassPush { from: 1.0, to: 1.0, find_walkers: 0, _pad: 0 };
    let (out, stray) = escaped_at(ids.w, (x, x), anchors, indices, &end);
    escaped[ids.w as usize] = out as u32;
    strays[ids.w as usize] = stray;
    let (lo, hi) = SweptTriangle::load(ids, x, anchors).box3();
    Aabb { min: lo.extend(0.0), max: hi.extend(0.0) }
}

/// A leaf's pairs with the leaves its walk reaches: the later ones, and with `earlier` (it
/// ended the frame outside its predicted region) the earlier ones that do not walk.
struct FramePairs<'a> {
    leaf: u32,
    mine: SweptTriangle,
    mine_owned: u32,
    sorted: &'a [UVec4],
    owned: &'a [u32],
    x: &'a [Vec4],
    anchors: &'a [Vec4],
    /// Which leaves walk; the earlier ones that do not are taken when `take_earlier`.
    walkers: Walkers<'a>,
    take_earlier: bool,
    separation: f32,
    found: Found<'a>,
}

/// Which leaves walk in the check: those that ended the frame outside their predicted region
/// (`escaped`, per triangle) and those whose list was full (`counts`).
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
    fn pair(&mut self, leaf: u32, mask_of: Option<u32>) {
        let ids = self.sorted[leaf as usize];
        let theirs = SweptTriangle::load(ids, self.x, self.anchors);
        // The earlier leaf first, as the passes do.
        if leaf < self.leaf {
            let mask = pair_mask(self.owned[ids.w as usize], self.mine_owned);
            sweep_triangle_pair(&theirs, &self.mine, mask, self.separation, &mut self.found);
        } else {
            let mask = match mask_of {
                Some(mask) => mask,
                None => pair_mask(self.mine_owned, self.owned[ids.w as usize]),
            };
            sweep_triangle_pair(&self.mine, &theirs, mask, self.separation, &mut self.found);
        }
    }
}

impl LeafVisitor for FramePairs<'_> {
    fn visit(&mut self, leaf: u32) {
        let earlier_taken = self.take_earlier && !self.walkers.walks(leaf, self.sorted);
        if leaf == self.leaf || (leaf < self.leaf && !earlier_taken) {
            return;
        }
        self.pair(leaf, None);
    }
}

/// Sorted leaf `leaf`'s pairs swept over the frame. Without the frame's lists (`with_lists`
/// false),
/// with every later leaf through the tree (refit to the frame's boxes). With them, as a pass
/// takes them (`self_pairs::listed_self_pairs_at`, `walk_self_pairs_at`): a leaf that ended the
/// frame inside its predicted region tests its list, but for partners that did not, and the
/// entries whose gap less both triangles' strays keeps them a thickness apart (a pair a list
/// leaves out stays a thickness apart while its corners stay within their slops of their
/// predicted paths, which they do on the straight way from the start to an end within them:
/// the straight way differs from the predicted one by gravity's share, the same for every
/// particle); one whose list was full walks for the later leaves; one that ended outside walks
/// for the later leaves and the earlier ones that do not walk. A walk whose stack overflowed
/// may have missed pairs: its triangle's particles are marked, to be safe.
#[allow(clippy::too_many_arguments)]
pub fn check_frame_at(
    leaf: u32,
    self_params: &ColliderParams,
    (nodes, aabbs, leaf_bounds, sorted): (&[BvhNode], &[Aabb], &[Aabb], &[UVec4]),
    owned: &[u32],
    (x, anchors): (&[Vec4], &[Vec4]),
    (with_lists, walkers, entries, strays): (bool, Walkers, &[u32], &[f32]),
    found: Found,
) {
    let ids = sorted[leaf as usize];
    let mine = SweptTriangle::load(ids, x, anchors);
    let separation = SEPARATION * self_params.thickness;
    let (lo, hi) = mine.box3();
    let query = (lo - Vec3::splat(separation), hi + Vec3::splat(separation));
    let mine_owned = owned[ids.w as usize];
    let take_earlier = false;
    let mut pairs =
        FramePairs { leaf, mine, mine_owned, sorted, owned, x, anchors, walkers, take_earlier, separation, found };
    let tree = (nodes, aabbs, leaf_bounds);
    let mut walk = PairWalk::new(leaf, self_params.leaf_count);
    if with_lists {
        let count = walkers.counts[leaf as usize];
        if walkers.escaped[ids.w as usize] != 0 {
            pairs.take_earlier = true;
            walk = PairWalk::all(self_params.leaf_count);
        } else if count != LIST_OVERFLOWED {
            let base = (LIST_ENTRY_WORDS * SELF_LIST_CAPACITY * leaf) as usize;
            let my_stray = strays[ids.w as usize];
            let mut j = 0;
            while j < count as usize {
                let entry = base + LIST_ENTRY_WORDS as usize * j;
                let other = entries[entry];
                let theirs = sorted[other as usize].w as usize;
                let gap = f32::from_bits(entries[entry + 2]);
                if walkers.escaped[theirs] == 0 && may_touch(gap, my_stray + strays[theirs], self_params.thickness) {
                    pairs.pair(other, Some(entries[entry + 1]));
                }
                j += 1;
            }
            return;
        }
    }
    if walk_in_batches(walk, tree, query, &mut pairs) {
        pairs.found.mark([ids.x, ids.y, ids.z, ids.x], (ids, ids));
    }
}

/// The brute-force baseline of `check_frame_at` without lists: sorted leaf `leaf` against every
/// later leaf whose frame box meets its own.
pub fn check_frame_brute_force_at(
    leaf: u32,
    self_params: &ColliderParams,
    sorted: &[UVec4],
    owned: &[u32],
    (x, anchors): (&[Vec4], &[Vec4]),
    found: Found,
) {
    let ids = sorted[leaf as usize];
    let mine = SweptTriangle::load(ids, x, anchors);
    let separation = SEPARATION * self_params.thickness;
    let mine_owned = owned[ids.w as usize];
    // No leaf walks (the walkers are only read with `take_earlier`).
    let walkers = Walkers { escaped: owned, counts: owned };
    let take_earlier = false;
    let mut pairs =
        FramePairs { leaf, mine, mine_owned, sorted, owned, x, anchors, walkers, take_earlier, separation, found };
    let (my_lo, my_hi) = mine.box3();
    let mut other = leaf + 1;
    while other < self_params.leaf_count {
        let (lo, hi) = SweptTriangle::load(sorted[other as usize], x, anchors).box3();
        let theirs = Aabb { min: lo.extend(0.0), max: hi.extend(0.0) };
        if box_meets(&theirs, my_lo - Vec3::splat(separation), my_hi + Vec3::splat(separation)) {
            pairs.visit(other);
        }
        other += 1;
    }
}

/// `FailsafePush::flags`: this round is the last (a pair it finds puts the whole cloth back).
pub const LAST_ROUND: u32 = 1;
/// `FailsafePush::flags`: the frame built pair lists (`check_frame_at` takes them).
pub const WITH_LISTS: u32 = 2;

/// Particle `i` after a round of checks: if a pair marked it, back to where the frame started,
/// at rest (its sleep flag kept); on the last round, every particle when the round found any
/// pair. Pinned particles stay (their motion is the caller's). Counts the particles that moved
/// back (into the round's counter and the frame's health); the first of a round that is not the
/// last dispatches the next round (`next_check`, `next_rollback`).
#[allow(clippy::too_many_arguments)]
pub fn roll_back_at(
    i: u32,
    push: &FailsafePush,
    (x, v): (&mut [Vec4], &mut [Vec4]),
    anchors: &[Vec4],
    flags: &mut [u32],
    counters: &mut [u32],
    (next_check, next_rollback): (&mut DispatchArgs, &mut DispatchArgs),
    health: &mut Health,
) {
    let flagged = flags[i as usize] != 0;
    flags[i as usize] = 0;
    let round = push.round;
    let last = push.flags & LAST_ROUND != 0;
    let everything = last && counters[(2 * round) as usize] != 0;
    let p = x[i as usize];
    if !(flagged || everything) || p.w <= 0.0 {
        return;
    }
    let start = frame_start_of(anchors, i);
    if p.xyz() == start {
        return;
    }
    x[i as usize] = start.extend(p.w);
    v[i as usize] = Vec3::ZERO.extend(v[i as usize].w);
    atomics::add(&mut health.self_rollbacks, 1);
    if atomics::add(&mut counters[(2 * round + 1) as usize], 1) == 0 && !last {
        next_check.x = push.check_groups;
        next_rollback.x = push.rollback_groups;
    }
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

/// One thread per sorted leaf: the leaf's box over the frame, and where it ended against its
/// predicted region (`frame_box_at`; the first round's boxes then refit the tree, a later
/// round's only shrink inside it).
#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(64)))]
pub fn failsafe_boxes(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] self_params: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] sorted: &[UVec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] x: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] anchors: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] indices: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] leaf_bounds: &mut [Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] escaped: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] strays: &mut [f32],
) {
    if id.x < self_params.leaf_count {
        leaf_bounds[id.x as usize] = frame_box_at(id.x, sorted, (x, anchors), indices, (escaped, strays));
    }
}

/// One thread per sorted leaf: its pairs swept over the frame (`check_frame_at`); push
/// constants: `FailsafePush` (the round).
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
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] owned: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] x: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] anchors: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] escaped: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] strays: &[f32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] lists: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] counts: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 12)] flags: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 13)] counters: &mut [u32],
) {
    if id.x >= self_params.leaf_count {
        return;
    }
    let whole_triangles = whole_triangles_in(push.round);
    let found = Found { flags, pairs: &mut counters[(2 * push.round) as usize], whole_triangles };
    let with_lists = (push.flags & WITH_LISTS != 0, Walkers { escaped, counts }, lists, strays);
    let tree = (nodes, aabbs, leaf_bounds, sorted);
    check_frame_at(id.x, self_params, tree, owned, (x, anchors), with_lists, found);
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
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] flags: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] counters: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] next_check: &mut DispatchArgs,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] next_rollback: &mut DispatchArgs,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] health: &mut Health,
) {
    if id.x == 0 {
        note_everything(push, counters, health);
    }
    if id.x < params.particle_count {
        roll_back_at(id.x, push, (x, v), anchors, flags, counters, (next_check, next_rollback), health);
    }
}
