//! What a cloth's motion decides for its next frames: how many substeps its contact needs, how
//! many self-collision passes, and whether it sleeps.
//!
//! - **Contact substeps.** Self-collision and sphere contact are found within the contact
//!   thickness at each substep's end, with a start-side test for what crossed during it; a
//!   particle that moves much more than the thickness in one substep can pass a feature that
//!   neither test sees (an edge against an edge). Triangle contact needs no bound: it sweeps each
//!   particle's path against the moving triangles; but a self-colliding cloth also meets the
//!   triangle colliders' vertices and edges by proximity, so while one moves, its motion against
//!   the cloth's counts too (up to `MOVING_FEATURE_SUBSTEPS_LIMIT`). The stability bound knows
//!   nothing of motion, so a frame's substeps are at least enough that the last frame's fastest
//!   particle, plus the fastest surface point this frame of the colliders that may meet the
//!   cloth (`ClothMotion::may_meet`: a self-colliding cloth reports its box every frame; a
//!   collider moving elsewhere changes nothing), moves at most `CONTACT_REACH` thicknesses per
//!   substep. Raised at once; the motion's need comes down to the most of the last
//!   `MOTION_HOLD` frames', a collider vertex's push only after `LOWER_AFTER` frames that need
//!   fewer.
//! - **Self-collision passes.** While a cloth does not touch itself, its passes follow the same
//!   need of its pairs and the collider features, from the last frame alone
//!   (`ClothMotion::self_passes`); while it does, it runs one every substep.
//! - **Sleeping.** A cloth whose fastest particle moves slower than `Sleep::speed` over the last
//!   substep of each of `Sleep::frames` frames sleeps: its frame runs nothing (listed as
//!   skipped), so it cannot drift. Motion, not velocity: a particle resting on a collider ends
//!   each substep with the g h its contact has yet to cancel, but stays where it is. A collider
//!   that moves wakes it when its swept box comes within reach of where the cloth lies (known
//!   when the solver could read the cloth back as it fell asleep; otherwise any moving collider). Any change
//!   that could move it wakes it: a collider that moves or deforms, a force, parameter, pin or
//!   state change.

use drape_types::Health;
use glam::{Vec3, Vec4};

/// Thicknesses a particle may move per substep, relative to the contact it is in.
pub const CONTACT_REACH: f32 = 1.0;
/// The frames whose motion the substeps follow: the most any of the last `MOTION_HOLD` frames'
/// motion needs (the particles', the self-collision pairs', a moving collider's). The need is
/// measured, not scaled by the substeps run, so it does not swing with the count: a short
/// hold only spans the frames of one slap of a fold. Held for 30 frames (as a push still is),
/// the icosphere's 64^2 cloth ran 38 of its 120 frames at 20 substeps where its pairs asked
/// for 10 after 10 of them.
pub const MOTION_HOLD: usize = 4;
/// Frames a collider vertex's pushes must need fewer substeps before their count comes down.
/// A push is measured at the substeps run (it shrinks with the substep's square), and a cloth
/// resting on a spike's tip pushes only where a substep let it sag: lowered at once, the next
/// frame would sag through again.
pub const LOWER_AFTER: u32 = 30;
/// The fewest self-collision passes a frame runs (fewer when it has fewer substeps). Each pass
/// is also one Jacobi iteration of the contacts it finds: a settled pile of 32 x 8 particles
/// crossed itself (1 crossing from frame 164 on) with 1-2 passes per frame where 3 kept it
/// clean, even though its motion needs only one. That was before a cloth touching itself ran
/// a pass at every substep (`ClothMotion::self_contact`); since, the floor only spans frames
/// that found no contact, and 2 (not 4) left every scene free of intersections in every frame
/// (pile, pile 48, garment, swing, bunny, dragon, icosphere).
pub const MIN_SELF_PASSES: u32 = 2;

/// The fewest passes a frame with its lists built twice runs (`ClothMotion::list_windows`):
/// each list build costs about two passes' walks of every triangle.
pub const WINDOW_PASSES: u32 = 4;
/// The share of a frame's triangle-passes that walked the tree above which its next frames
/// build their lists twice (`ClothMotion::list_windows`), and the share of a frame with its
/// lists built twice below which they stop. Halving the horizon cuts the walked share far more
/// than the prediction's error (a quarter): the bunny walked 2.2 % of its triangle-passes in a
/// frame of 20 passes with two builds and 27 % in the next with one. With an off share of 5 %
/// (and 2.5 %) the bunny and the pile switched at every other frame (20 switches in the bunny's
/// 60 frames), each frame with one build walking over a fifth again.
pub const WINDOWS_ON: f32 = 0.2;
pub const WINDOWS_OFF: f32 = 0.005;

/// When a still cloth sleeps.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Sleep {
    /// Fastest particle motion over a frame's last substep (distance / substep, m/s) under which
    /// the frame counts as still.
    pub speed: f32,
    /// Consecutive still frames before the cloth sleeps.
    pub frames: u32,
}

impl Default for Sleep {
    fn default() -> Self {
        // A settled pile of cloth still jitters at 0.005-0.03 m/s (stacked layers pushing each
        // other apart); 0.05 m/s is under a millimetre per frame.
        Sleep { speed: 0.05, frames: 30 }
    }
}

/// The largest particle speed (m/s) a frame's health check saw.
pub fn max_speed(health: &Health) -> f32 {
    f32::from_bits(health.max_speed_bits)
}

/// The self-colliding cloth's box over the frame (`Health::self_scene_low`), where the frame
/// wrote one.
fn scene_of(health: &Health) -> Option<(Vec3, Vec3)> {
    let (lo, hi) = (health.self_scene_low, health.self_scene_high);
    let (low, high) = (Vec3::new(lo[0], lo[1], lo[2]), Vec3::new(hi[0], hi[1], hi[2]));
    (lo[3] == 1.0 && low.is_finite() && high.is_finite() && low.cmple(high).all()).then_some((low, high))
}

/// The largest distance a particle moved over the frame's last substep, per second (m/s).
pub fn max_motion(health: &Health, substep: f32) -> f32 {
    f32::from_bits(health.max_moved_bits) / substep
}

/// One cloth's motion history: what its next frames' substeps, self-collision passes and sleep
/// follow from. Part of a `ClothState`, so a restored state replays the same schedule.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ClothMotion {
    /// Fastest particle at the end of the last frame (m/s).
    last_speed: f32,
    /// What its self-collision passes had to resolve over the last frame, when its pair lists
    /// measured it (m): of two of its primitives that may have touched, the largest relative
    /// motion while the cloth touched itself (`Health::self_pair_motion_bits`: its layers slide
    /// over each other's faces and folds), else the largest approach
    /// (`Health::self_pair_approach_bits`: a pair sliding past another never closes).
    pair_motion: Option<f32>,
    /// The largest push a collider vertex gave one of its faces in a self-collision pass of the
    /// last frame (thicknesses; `Health::collider_feature_push_bits`), and the substeps that
    /// frame ran.
    feature_push: f32,
    substeps_run: u32,
    /// Substeps the frame runs for its contact: the most of `motion_needs` and `push_substeps`.
    pub(crate) contact_substeps: u32,
    /// The substeps each of the last `MOTION_HOLD` frames' motion needed, oldest overwritten
    /// first (`motion_slot` is the next to write).
    motion_needs: [u32; MOTION_HOLD],
    motion_slot: usize,
    /// Substeps the collider vertices' pushes need now, and frames they have needed fewer.
    push_substeps: u32,
    /// Self-collision passes the last frame's motion asks of the next while the cloth does not
    /// touch itself: its pairs' and the collider features' need (as `contact_substeps`, without
    /// the sphere colliders', which the passes do not test), from the last frame alone. The
    /// substeps keep the most of the last `MOTION_HOLD` frames' needs (a changed count re-plans
    /// the frame and moves the stability margin); the passes need no such hold: over the 64^2
    /// swing's 60 frames the held count ran a pass every substep (14) where its pairs' approach
    /// asked for 4-10.
    pub(crate) self_passes: u32,
    /// Frames the pushes have needed fewer than `push_substeps`.
    frames_needing_fewer: u32,
    still_frames: u32,
    pub(crate) asleep: bool,
    /// The last frame's self-collision corrected a particle (or no frame has run yet): the
    /// next runs a self-collision pass every substep, since each pass is also an iteration of
    /// the contacts (a settled, stiff pile crossed itself with 5 passes in 18 substeps).
    pub(crate) self_contact: bool,
    /// The frame's self-collision lists are built twice, the second time after the pass
    /// halfway through it (`FramePlan::self_windows`): on once the triangles that walked the
    /// tree (they left the region their lists predicted) reach `WINDOWS_ON` of the
    /// triangle-passes in a frame of at least `WINDOW_PASSES` passes, off once they fall under
    /// `WINDOWS_OFF` (the windows themselves lower it) or the passes do.
    pub(crate) list_windows: bool,
    /// Where the sleeping cloth lies (its particles' box), when the solver could read it: a
    /// collider moving outside it (grown by the contact reach) does not wake the cloth.
    pub(crate) resting_bounds: Option<(Vec3, Vec3)>,
    /// Where the self-colliding cloth was at the start of the last frame observed and where its
    /// velocities carried it over that frame (`Health::self_scene_low`), and that frame's
    /// number: which moving colliders may meet it (`may_meet`). `None`: not known (no
    /// self-collision, or no frame observed yet).
    scene: Option<((Vec3, Vec3), u64)>,
}

/// The contact a cloth is in that finds its pairs by proximity at substep ends (so a substep
/// must not move them much more than the thickness): the thinnest such collider contact
/// (sphere colliders; triangle contact sweeps each particle's path), and self-collision's
/// thickness with the most substeps it may ask for (`SELF_SUBSTEPS_LIMIT`).
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub(crate) struct Proximity {
    pub collider: Option<f32>,
    pub self_collision: Option<(f32, u32)>,
    /// The triangle colliders' vertices and edges against the cloth's faces and edges, when
    /// they are tested (with self-collision).
    pub collider_features: Option<FeatureContact>,
}

/// A self-colliding cloth's contact with the triangle colliders' vertices and edges, found by
/// proximity: the thinnest such collider's thickness, the fastest surface point of those that
/// move this frame (m/s; 0 when none does), and the most substeps they may ask for: for a
/// vertex's push (`FEATURE_SUBSTEPS_LIMIT`) and for a moving collider's motion
/// (`MOVING_FEATURE_SUBSTEPS_LIMIT`).
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub(crate) struct FeatureContact {
    pub thickness: f32,
    pub speed: f32,
    pub most: (u32, u32),
}

/// Self-collision raises a frame's substeps to at most this many times the stability bound's.
/// Beyond, a pass may move a pair more than the thickness; its start-side tests still undo a
/// face or an edge crossed within a pass, and the fail-safe (`self_failsafe`) any crossing left
/// at the frame's end. A budget: on the bunny the cloth's fastest pairs that may touch moved
/// up to 34 cm in a frame (a free corner whipping past the cloth at 20 m/s), which asked for 68
/// substeps where the bound takes 10, with a pass at each. At 1 (no raise) the cloth on the
/// bunny went through it in 17 of 120 frames and on the dragon in 10 of 40, and the fail-safe put
/// particles of the pile back in 299 of 600 frames (the whole cloth once); at 2, none of that.
pub const SELF_SUBSTEPS_LIMIT: u32 = 2;

/// The push (in thicknesses) a collider vertex may give a cloth face per pass: more, and the
/// next frames run more substeps (`substeps_for_push`). A push within the thickness corrects
/// a face that came near the vertex; beyond it, the face passed the vertex within the pass.
/// That happens where a spike's tip holds the cloth up through the particles of one cell. The
/// cell is pulled down by the whole hanging cloth, about 2e4 m/s^2 under a 28-degree cone's tip,
/// so about 2.8 cm per 1.67 ms substep, and a face that far past the tip is not always put back
/// (passing it near an edge of the face, crossing the planes of both faces at that edge). Under
/// a constant pull the push shrinks with the square of the substep.
pub const FEATURE_PUSH_REACH: f32 = 1.0;

/// Collider features' pushes raise a frame's substeps to at most this many times the stability
/// bound's. The cone's 64^2 cloth was pierced at 18 and 24 substeps (4-11 mm pushes per pass at
/// 24) and held at 30 and 40 (the bound takes 10).
pub const FEATURE_SUBSTEPS_LIMIT: u32 = 4;

/// A moving triangle collider's motion against a self-colliding cloth raises a frame's substeps
/// to at most this many times the stability bound's. Its edges find the cloth's by proximity
/// alone, so the budget decides how fast a collider can move through the cloth without cutting
/// it. A star prism spinning under the falling 32^2 cloth (the bound takes 5; 90 frames): with
/// 4 (20 substeps), held at 6 rad/s (its points at 2.8 m/s) and cut in 82 of 90 frames at 8
/// rad/s (3.8 m/s); with fixed substeps, 8 rad/s held at 30, 40 and 60. With 8, both hold (up
/// to 40 substeps); at 12 rad/s (5.6 m/s) 40 cut it too.
pub const MOVING_FEATURE_SUBSTEPS_LIMIT: u32 = 8;

/// Substeps under which a collider vertex's push stays within `FEATURE_PUSH_REACH`, from the
/// last frame's largest push `push` at `substeps_run` substeps (the push scales with the square
/// of the substep); `None` for no push.
fn substeps_for_push(push: f32, substeps_run: u32) -> Option<u32> {
    let scale = (push / FEATURE_PUSH_REACH).sqrt();
    if push > 0.0 { whole_substeps(substeps_run.max(1) as f32 * scale) } else { None }
}

/// `substeps` (a count the motion asks for) rounded up, in 1..=100000; `None` when not finite.
fn whole_substeps(substeps: f32) -> Option<u32> {
    substeps.is_finite().then(|| (substeps.ceil() as u32).clamp(1, 100_000))
}

/// Substeps that move `motion` (m over a frame) at most `CONTACT_REACH` thicknesses each.
fn substeps_for(motion: f32, thickness: f32) -> Option<u32> {
    if thickness > 0.0 { whole_substeps(motion / (CONTACT_REACH * thickness)) } else { None }
}

/// What a frame's start changed of a cloth's schedule.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub(crate) struct Change {
    pub substeps: bool,
    pub sleep: bool,
}

impl ClothMotion {
    pub(crate) fn new() -> Self {
        ClothMotion { contact_substeps: 1, self_passes: 1, push_substeps: 1, self_contact: true, ..Default::default() }
    }

    /// After a frame of `substeps` substeps of `substep` s: its health check's speed and motion,
    /// its colliders' pushes, and the motion of its self-collision pairs when `pairs_listed` (the
    /// frame ran pair lists).
    pub(crate) fn observe(
        &mut self,
        health: &Health,
        (substep, substeps): (f32, u32),
        sleep: Option<Sleep>,
        (pairs_listed, walked, passes): (bool, Option<f32>, u32),
    ) {
        if self.asleep {
            return; // a sleeping frame ran nothing; its health is the last awake frame's
        }
        self.list_windows = match walked {
            Some(share) if passes >= WINDOW_PASSES => {
                if self.list_windows {
                    share >= WINDOWS_OFF
                } else {
                    share >= WINDOWS_ON
                }
            }
            _ => false,
        };
        self.last_speed = max_speed(health);
        self.feature_push = f32::from_bits(health.collider_feature_push_bits);
        self.substeps_run = substeps;
        self.self_contact = health.self_contacts > 0;
        let pairs = if self.self_contact { health.self_pair_motion_bits } else { health.self_pair_approach_bits };
        self.pair_motion = pairs_listed.then(|| f32::from_bits(pairs));
        match sleep {
            Some(s) if max_motion(health, substep) < s.speed => self.still_frames += 1,
            _ => self.still_frames = 0,
        }
    }

    /// The cloth was set moving at `speed` (m/s: its initial or teleported velocities): the next
    /// frame's contact substeps and self-collision passes count on it, not on the last frame.
    pub(crate) fn set_moving(&mut self, speed: f32) {
        if speed.is_finite() {
            self.last_speed = self.last_speed.max(speed);
        }
    }

    /// The fastest particle at the end of the last frame observed (m/s).
    pub(crate) fn last_speed(&self) -> f32 {
        self.last_speed
    }

    /// Wakes the cloth; returns whether it was asleep.
    pub(crate) fn wake(&mut self) -> bool {
        self.still_frames = 0;
        self.resting_bounds = None;
        std::mem::take(&mut self.asleep)
    }

    /// Records where the sleeping cloth lies (`positions` read back once it fell asleep).
    pub(crate) fn rest_at(&mut self, positions: &[Vec4]) {
        let (lo, hi) = positions
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| (lo.min(p.truncate()), hi.max(p.truncate())));
        self.resting_bounds = (lo.cmple(hi).all()).then_some((lo, hi));
    }

    /// Whether a collider moving through `bounds` (its swept box, grown by the contact reach)
    /// can touch this cloth: yes unless the cloth sleeps at a known place away from it.
    pub(crate) fn near(&self, (lo, hi): (Vec3, Vec3)) -> bool {
        match self.resting_bounds {
            Some((rest_lo, rest_hi)) => lo.cmple(rest_hi).all() && hi.cmpge(rest_lo).all(),
            None => true,
        }
    }

    /// Frame `frame`'s health reported where the cloth was (`Health::self_scene_low`; frames
    /// are numbered as they are planned, from 1). A sleeping cloth's is its last awake frame's,
    /// where it still lies.
    pub(crate) fn locate(&mut self, health: &Health, frame: u64) {
        if let Some(scene) = scene_of(health) {
            self.scene = Some((scene, frame));
        }
    }

    /// The cloth may have been moved (its state set, a pin moved): where it is is not known
    /// until a frame reports it.
    pub(crate) fn forget_place(&mut self) {
        self.scene = None;
    }

    /// Whether a collider sweeping through `bounds` over frame `frame`, about to run (its swept
    /// box, grown by its contact reach), may meet the cloth: yes unless the cloth's last known
    /// box (`locate`), grown by twice as far as its fastest particle, and an acceleration of
    /// `acceleration` (m/s^2: gravity and the external force), could carry it from there by
    /// this frame's end, lies apart from it. A collider that may not moves the cloth's
    /// substeps no more than one at rest (a moving collider anywhere in the scene used to raise
    /// every self-colliding cloth's substeps up to 8 times).
    pub(crate) fn may_meet(&self, (lo, hi): (Vec3, Vec3), (frame, frame_dt): (u64, f32), acceleration: f32) -> bool {
        let Some(((cloth_lo, cloth_hi), located)) = self.scene else {
            return true;
        };
        // The frames from the located one (its box predicts it, not what its contact did) to
        // this one's end.
        let t = frame_dt * (frame.saturating_sub(located) + 1) as f32;
        let reach = 2.0 * (self.last_speed * t + 0.5 * acceleration * t * t);
        if !reach.is_finite() {
            return true;
        }
        let (cloth_lo, cloth_hi) = (cloth_lo - Vec3::splat(reach), cloth_hi + Vec3::splat(reach));
        lo.cmple(cloth_hi).all() && hi.cmpge(cloth_lo).all()
    }

    /// At a frame's start: the contact the cloth is in that tests proximity (`Proximity`), the
    /// colliders' fastest surface speed this frame, whether a moving collider comes near the
    /// cloth, the frame's length and the sleep policy.
    pub(crate) fn plan_frame(
        &mut self,
        proximity: Proximity,
        (collider_speed, collider_near): (f32, bool),
        frame_dt: f32,
        sleep: Option<Sleep>,
    ) -> Change {
        let mut change = Change::default();
        if collider_near {
            change.sleep |= self.wake();
        }
        if let Some(s) = sleep
            && !self.asleep
            && self.still_frames >= s.frames
        {
            self.asleep = true;
            change.sleep = true;
        }
        // The fastest particle's and the colliders' motion over the frame; for self-collision
        // the fastest pair's that may touch, when the lists measured it (a particle whipping
        // through the air, 20 m/s at a free corner of the cloth on the bunny, touches nothing).
        let particle_motion = (self.last_speed + collider_speed) * frame_dt;
        let self_motion = self.pair_motion.unwrap_or(particle_motion);
        let collider = proximity.collider.and_then(|t| substeps_for(particle_motion, t));
        let self_collision =
            proximity.self_collision.and_then(|(t, most)| Some(substeps_for(self_motion, t)?.min(most.max(1))));
        // The features: the largest push a collider vertex gave (it passed a face), and, while
        // a collider moves, its motion against the cloth's (its edges find the cloth's by
        // proximity alone: a star prism spinning at 6 rad/s, its knife edges at 2.8 m/s, cut
        // the falling 32^2 cloth at its 11 substeps and held it at 15).
        let features = proximity.collider_features.map(|f| {
            let pushed = substeps_for_push(self.feature_push, self.substeps_run).map(|n| n.min(f.most.0.max(1)));
            let motion = (self.last_speed + f.speed) * frame_dt;
            let moving = if f.speed > 0.0 { substeps_for(motion, f.thickness) } else { None };
            (pushed, moving.map(|n| n.min(f.most.1.max(1))))
        });
        let (pushed, moving) = features.unwrap_or((None, None));
        // The passes test the cloth's pairs and the collider features, not the sphere colliders.
        let passes = self_collision.max(pushed).max(moving);
        self.self_passes = passes.unwrap_or(1);
        // The motion's need, held as the most of the last frames'.
        self.motion_needs[self.motion_slot] = collider.max(self_collision).max(moving).unwrap_or(1);
        self.motion_slot = (self.motion_slot + 1) % MOTION_HOLD;
        let motion = self.motion_needs.iter().copied().max().unwrap_or(1);
        // The pushes' need: raised at once, lowered after `LOWER_AFTER` frames that need fewer.
        let push = pushed.unwrap_or(1);
        if push >= self.push_substeps {
            (self.push_substeps, self.frames_needing_fewer) = (push, 0);
        } else {
            self.frames_needing_fewer += 1;
            if self.frames_needing_fewer >= LOWER_AFTER {
                (self.push_substeps, self.frames_needing_fewer) = (push, 0);
            }
        }
        let needed = motion.max(self.push_substeps).max(1);
        change.substeps = needed != self.contact_substeps;
        self.contact_substeps = needed;
        change
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A frame's health whose fastest particle has `speed` and moves at it (substep 1 ms).
    fn health(speed: f32) -> Health {
        Health { max_speed_bits: speed.to_bits(), max_moved_bits: (speed * H).to_bits(), ..Default::default() }
    }

    const H: f32 = 1e-3;

    /// Contact with a sphere collider of `thickness`.
    fn collider(thickness: f32) -> Proximity {
        Proximity { collider: Some(thickness), ..Default::default() }
    }

    /// A frame's health that reports the cloth's box `lo..hi` (self-collision's scene box).
    fn health_in(lo: Vec3, hi: Vec3, speed: f32) -> Health {
        Health { self_scene_low: lo.extend(1.0).into(), self_scene_high: hi.extend(1.0).into(), ..health(speed) }
    }

    /// A collider may meet the cloth unless the cloth's last box, grown by twice its reach
    /// since, lies apart from the collider's swept box; the reach grows with the frames planned
    /// since the box was observed; an unknown box, or one not written, meets everything.
    #[test]
    fn a_collider_meets_the_cloth_only_within_its_reach() {
        let dt = 1.0 / 60.0;
        let collider = |x: f32| (Vec3::new(x, 0.0, 0.0), Vec3::new(x + 0.1, 0.1, 0.1));
        let mut m = ClothMotion::new();
        assert!(m.may_meet(collider(5.0), (1, dt), 9.81), "no frame observed: the cloth may be anywhere");
        m.observe(&health(3.0), (H, 10), None, (false, None, 10));
        m.locate(&health(3.0), 1);
        assert!(m.may_meet(collider(5.0), (2, dt), 9.81), "a frame without self-collision's box");
        // Frame 1 located at 3 m/s: by frame 2's end, two frames' reach, 2 x (0.1 + 0.005) m.
        let located = health_in(Vec3::ZERO, Vec3::ONE, 3.0);
        m.observe(&located, (H, 10), None, (false, None, 10));
        m.locate(&located, 1);
        assert!(m.may_meet(collider(1.15), (2, dt), 9.81));
        assert!(!m.may_meet(collider(1.3), (2, dt), 9.81));
        // Frame 4, with no news of the cloth since frame 1 (frames in flight): four frames' reach.
        assert!(m.may_meet(collider(1.3), (4, dt), 9.81));
        assert!(!m.may_meet(collider(1.6), (4, dt), 9.81));
        assert!(m.may_meet(collider(1.6), (4, dt), f32::INFINITY), "no bound on the acceleration");
        m.forget_place();
        assert!(m.may_meet(collider(5.0), (2, dt), 9.81), "a cloth moved by hand may be anywhere");
    }

    #[test]
    fn fast_motion_raises_substeps_at_once_and_keeps_the_last_frames_peak() {
        let mut m = ClothMotion::new();
        m.observe(&health(2.9), (H, 10), None, (false, None, 10));
        // 2.9 m/s over 1/60 s is 48 mm: ten 5 mm substeps.
        assert_eq!(
            m.plan_frame(collider(0.005), (0.0, false), 1.0 / 60.0, None),
            Change { substeps: true, sleep: false }
        );
        assert_eq!(m.contact_substeps, 10);
        // Then 1.44 m/s (24 mm, five substeps) and 0.1 m/s (one): the peak stays for
        // `MOTION_HOLD` frames, then the highest need after it.
        m.observe(&health(1.44), (H, 10), None, (false, None, 10));
        assert!(!m.plan_frame(collider(0.005), (0.0, false), 1.0 / 60.0, None).substeps);
        m.observe(&health(0.1), (H, 10), None, (false, None, 10));
        for _ in 2..MOTION_HOLD {
            assert!(!m.plan_frame(collider(0.005), (0.0, false), 1.0 / 60.0, None).substeps);
        }
        assert_eq!(m.contact_substeps, 10);
        assert!(m.plan_frame(collider(0.005), (0.0, false), 1.0 / 60.0, None).substeps);
        assert_eq!(m.contact_substeps, 5);
        assert!(m.plan_frame(collider(0.005), (0.0, false), 1.0 / 60.0, None).substeps);
        assert_eq!(m.contact_substeps, 1);
        // Without contact, motion needs nothing.
        m.observe(&health(100.0), (H, 10), None, (false, None, 10));
        m.plan_frame(Proximity::default(), (0.0, false), 1.0 / 60.0, None);
        assert_eq!(m.contact_substeps, 1);
    }

    /// Self-collision's substeps follow the fastest pair its lists found may touch, not the
    /// fastest particle (which it falls back on without lists), up to its limit: the pairs'
    /// approach while the cloth does not touch itself, their whole motion while it does.
    #[test]
    fn self_collision_follows_its_pairs_motion_up_to_its_limit() {
        let self_only = Proximity { self_collision: Some((0.005, 20)), ..Default::default() };
        let mut m = ClothMotion::new();
        // A corner whipping through the air at 20 m/s; the fastest pair that may touch moves
        // 38 mm over the frame and closes 18 mm: four 5 mm substeps.
        let mut h = health(20.0);
        h.self_pair_motion_bits = 0.038f32.to_bits();
        h.self_pair_approach_bits = 0.018f32.to_bits();
        m.observe(&h, (H, 10), None, (true, None, 10));
        m.plan_frame(self_only, (0.0, false), 1.0 / 60.0, None);
        assert_eq!(m.contact_substeps, 4);
        // Touching itself (a correction in the frame): the whole 38 mm, eight substeps.
        m.observe(&Health { self_contacts: 1, ..h }, (H, 10), None, (true, None, 10));
        m.plan_frame(self_only, (0.0, false), 1.0 / 60.0, None);
        assert_eq!(m.contact_substeps, 8);
        // Without lists: the fastest particle, 20 m/s over 1/60 s (333 mm), stopped at 20.
        m.observe(&h, (H, 10), None, (false, None, 10));
        m.plan_frame(self_only, (0.0, false), 1.0 / 60.0, None);
        assert_eq!(m.contact_substeps, 20);
        // A sphere collider's contact is not limited: 67 substeps.
        let both = Proximity { collider: Some(0.005), ..self_only };
        m.plan_frame(both, (0.0, false), 1.0 / 60.0, None);
        assert_eq!(m.contact_substeps, 67);
    }

    /// The passes follow the last frame's need alone, while the substeps keep the most of the
    /// last `MOTION_HOLD` frames' (`Controls` re-plans the frame when the passes a plan makes of
    /// the need change).
    #[test]
    fn self_passes_follow_the_last_frame_while_the_substeps_are_held() {
        let self_only = Proximity { self_collision: Some((0.005, 20)), ..Default::default() };
        let closing = |metres: f32| Health {
            self_pair_motion_bits: metres.to_bits(),
            self_pair_approach_bits: metres.to_bits(),
            ..health(1.0)
        };
        let mut m = ClothMotion::new();
        // Pairs closing 40 mm over the frame: eight 5 mm passes, and as many substeps.
        m.observe(&closing(0.04), (H, 10), None, (true, None, 10));
        let change = m.plan_frame(self_only, (0.0, false), 1.0 / 60.0, None);
        assert!(change.substeps, "{change:?}");
        assert_eq!((m.contact_substeps, m.self_passes), (8, 8));
        // Then 10 mm: two passes at once; the substeps stay.
        m.observe(&closing(0.01), (H, 10), None, (true, None, 10));
        let change = m.plan_frame(self_only, (0.0, false), 1.0 / 60.0, None);
        assert!(!change.substeps, "{change:?}");
        assert_eq!((m.contact_substeps, m.self_passes), (8, 2));
        // Then 60 mm: twelve at once, both.
        m.observe(&closing(0.06), (H, 10), None, (true, None, 10));
        let change = m.plan_frame(self_only, (0.0, false), 1.0 / 60.0, None);
        assert!(change.substeps, "{change:?}");
        assert_eq!((m.contact_substeps, m.self_passes), (12, 12));
    }

    /// A collider vertex that pushed a cloth face more than the thickness in a pass (the face
    /// passed it) raises the substeps by the square root of the push, up to the features' limit;
    /// pushes within the thickness keep what lowers them within it.
    #[test]
    fn a_collider_vertex_pushing_past_the_thickness_raises_substeps_up_to_its_limit() {
        let features = feature_contact(0.0);
        let pushed = |push: f32| Health { collider_feature_push_bits: push.to_bits(), ..health(0.1) };
        let mut m = ClothMotion::new();
        // A push of 2.25 thicknesses at 10 substeps: 15 keep it within one.
        m.observe(&pushed(2.25), (H, 10), None, (true, None, 10));
        assert!(m.plan_frame(features, (0.0, false), 1.0 / 60.0, None).substeps);
        assert_eq!(m.contact_substeps, 15);
        // 25 thicknesses at 10 substeps would take 50: stopped at the limit.
        m.observe(&pushed(25.0), (H, 10), None, (true, None, 10));
        m.plan_frame(features, (0.0, false), 1.0 / 60.0, None);
        assert_eq!(m.contact_substeps, 40);
        // Within the thickness at 40 substeps (0.64): 32 keep it, once enough frames needed fewer.
        m.observe(&pushed(0.64), (H, 40), None, (true, None, 10));
        for _ in 0..LOWER_AFTER {
            m.plan_frame(features, (0.0, false), 1.0 / 60.0, None);
        }
        assert_eq!(m.contact_substeps, 32);
        // Without collider features tested, the push asks for nothing.
        let mut m = ClothMotion::new();
        m.observe(&pushed(25.0), (H, 10), None, (true, None, 10));
        m.plan_frame(Proximity::default(), (0.0, false), 1.0 / 60.0, None);
        assert_eq!(m.contact_substeps, 1);
    }

    /// Triangle colliders' features at 5 mm, moving at `speed`, up to 40 substeps for their
    /// pushes and 80 for their motion.
    fn feature_contact(speed: f32) -> Proximity {
        let f = FeatureContact { thickness: 0.005, speed, most: (40, 80) };
        Proximity { collider_features: Some(f), ..Default::default() }
    }

    /// A moving triangle collider's features (found by proximity) move at most a thickness per
    /// substep against the cloth: its fastest surface point at 2.8 m/s and the cloth's at 0.1
    /// m/s over 1/60 s (48 mm) ask 10 substeps of a 5 mm thickness, up to the features' limit.
    /// At rest they ask nothing, whatever else moves (a sphere collider's speed is not theirs),
    /// and a cloth they are not tested against asks nothing.
    #[test]
    fn a_moving_collider_raises_substeps_for_its_features_up_to_their_limit() {
        let mut m = ClothMotion::new();
        m.observe(&health(0.1), (H, 10), None, (true, None, 10));
        m.plan_frame(feature_contact(0.0), (2.8, true), 1.0 / 60.0, None);
        assert_eq!(m.contact_substeps, 1);
        assert!(m.plan_frame(feature_contact(2.8), (2.8, true), 1.0 / 60.0, None).substeps);
        assert_eq!(m.contact_substeps, 10);
        m.plan_frame(feature_contact(28.0), (28.0, true), 1.0 / 60.0, None);
        assert_eq!(m.contact_substeps, 80, "the motion's own limit, above the pushes' (40)");
        let mut m = ClothMotion::new();
        m.plan_frame(Proximity::default(), (28.0, true), 1.0 / 60.0, None);
        assert_eq!(m.contact_substeps, 1);
    }

    #[test]
    fn a_still_cloth_sleeps_and_a_moving_collider_wakes_it() {
        let sleep = Some(Sleep { speed: 0.01, frames: 3 });
        let mut m = ClothMotion::new();
        for _ in 0..3 {
            m.observe(&health(0.001), (H, 10), sleep, (false, None, 10));
            assert!(!m.plan_frame(Proximity::default(), (0.0, false), 1.0 / 60.0, sleep).sleep || m.asleep);
        }
        assert!(m.asleep);
        // A sleeping frame's (stale) health does not count.
        m.observe(&health(5.0), (H, 10), sleep, (false, None, 10));
        assert!(m.asleep);
        assert_eq!(
            m.plan_frame(Proximity::default(), (0.2, true), 1.0 / 60.0, sleep),
            Change { substeps: false, sleep: true }
        );
        assert!(!m.asleep);
        // One fast frame restarts the count.
        m.observe(&health(0.5), (H, 10), sleep, (false, None, 10));
        m.plan_frame(Proximity::default(), (0.0, false), 1.0 / 60.0, sleep);
        assert!(!m.asleep);
    }

    /// Lists are built twice a frame once a fifth of a frame's triangle-passes walked the tree
    /// (in a frame of at least `WINDOW_PASSES` passes), and once a frame again when under
    /// `WINDOWS_OFF` walk, or the passes fall below it, or the frame ran no lists.
    #[test]
    fn list_windows_follow_the_walked_share_with_hysteresis() {
        let mut m = ClothMotion::new();
        let frame = |m: &mut ClothMotion, walked: Option<f32>, passes: u32| {
            m.observe(&health(1.0), (H, 10), None, (walked.is_some(), walked, passes));
            m.list_windows
        };
        assert!(!frame(&mut m, Some(0.19), 10));
        assert!(!frame(&mut m, Some(0.5), WINDOW_PASSES - 1), "too few passes to split");
        assert!(frame(&mut m, Some(WINDOWS_ON), WINDOW_PASSES));
        assert!(frame(&mut m, Some(0.01), 10), "on until under WINDOWS_OFF");
        assert!(!frame(&mut m, Some(0.004), 10));
        assert!(frame(&mut m, Some(0.3), 10));
        assert!(!frame(&mut m, None, 10), "a frame without lists");
    }
}
