//! What the host changes between frames: parameters (gravity, wind, stiffness, damping, `dt`),
//! collider poses, deformed collider leaves, pins. Setters check the value and only note it;
//! the next frame starts with the writes that bring the GPU (or CPU) buffers up to date, so a
//! change re-records nothing, allocates nothing on the GPU, and never waits on the queue. Both
//! the GPU `Simulation` and the `CpuSimulation` drive their frames through this.

use crate::error::{Error, Result};
use crate::graph::{Handle, Step};
use crate::model::{ClothId, ColliderId};
use crate::motion::{
    ClothMotion, FEATURE_SUBSTEPS_LIMIT, FeatureContact, MOVING_FEATURE_SUBSTEPS_LIMIT, Proximity, SELF_SUBSTEPS_LIMIT,
};
use crate::program::SolverProgram;
use crate::programs::cloth::FramePlan;
use crate::programs::contact::Crowded;
use crate::programs::self_contact::{SelfContactBuffers, lists_pay};
use crate::settings::SimSettings;
use crate::stability::{BoundInputs, Stability};
use drape_kernels::pose::to_world;
use drape_types::{ColliderParams, ColliderPose, Health, RigidPose, SimParams};
use glam::{Quat, Vec3, Vec4};

/// A particle's pin change, applied at the start of the next frame.
#[derive(Copy, Clone, Debug, PartialEq)]
enum PinChange {
    /// Pin where it is.
    Here,
    /// Pin at this position (moves it there: an animated pin when set every frame).
    At(Vec3),
    Unpin,
}

/// What a collider starts with: its parameters, pose, and what deforming it writes (spheres or
/// mesh vertices) with its starting contents.
pub(crate) struct ColliderStart {
    pub params: ColliderParams,
    pub pose: RigidPose,
    pub deformable: &'static str,
    pub contents: Vec<Vec4>,
    /// Its contact sweeps each particle's path against the moving leaves (triangles: CCD), so
    /// any substep length is safe for it.
    pub swept_contact: bool,
}

/// Where a collider's leaves reach in its own frame: their box and the largest distance from
/// the frame's origin (what a turn moves the surface by, per radian).
#[derive(Copy, Clone, Debug)]
struct Extent {
    low: Vec3,
    high: Vec3,
    /// The farthest any leaf reaches from the box's centre: a turn by `angle` about any axis
    /// through the centre moves no point of the collider farther than `radius x angle`.
    radius: f32,
}

impl Extent {
    /// The extent of spheres (w = radius) or vertices (w = 0).
    fn of(leaves: &[Vec4]) -> Self {
        let (low, high) = leaves.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), l| {
            let (centre, r) = (l.truncate(), l.w.max(0.0));
            (lo.min(centre - Vec3::splat(r)), hi.max(centre + Vec3::splat(r)))
        });
        let middle = 0.5 * (low + high);
        let radius = leaves.iter().map(|l| (l.truncate() - middle).length() + l.w.max(0.0)).fold(0.0, f32::max);
        Extent { low, high, radius }
    }

    fn centre(&self) -> Vec3 {
        if self.low.cmple(self.high).all() { 0.5 * (self.low + self.high) } else { Vec3::ZERO }
    }
}

/// One collider's host-side values.
struct ColliderControl {
    params: ColliderParams,
    params_dirty: bool,
    /// The pose the last frame ended at, and the one the next frame ends at.
    end_of_last_frame: RigidPose,
    target: RigidPose,
    /// What the GPU's pose buffer holds.
    written: ColliderPose,
    /// What deforming it writes (spheres or mesh vertices) and how many.
    deformable: (&'static str, u32),
    /// New spheres or vertices (collider frame) for the next frame: written, then the LBVH is
    /// refit.
    deformed: Option<Vec<Vec4>>,
    /// `deformed` is a teleport: its leaves stand there from the frame's start instead of
    /// sweeping there from `current`.
    deformation_jumps: bool,
    /// The spheres or vertices the GPU holds (what a frame that deforms sweeps from).
    current: Vec<Vec4>,
    /// Whether the last frame's leaves swept (so the next one, if it does not deform, resets
    /// them to standing still).
    sweeping: bool,
    /// `current`'s extent (kept with it, so a moving collider's speed and swept box cost no
    /// pass over its leaves).
    extent: Extent,
    /// Its contact needs no substep bound (`ColliderStart::swept_contact`).
    swept_contact: bool,
    /// Its features' covers (`collider_cover`); `None` without.
    covers: Option<Covers>,
    /// How fast its surface moved at most in the last frame planned (m/s; 0 standing still):
    /// what a blow-up's message names when a collider outran the cloth.
    frame_speed: f32,
}

/// The shape a collider's features' covers were measured on, their reach there, and the
/// farthest any vertex of the shape the GPU holds lies from it (measured when that shape
/// arrived, so a frame that does not deform reads no vertex).
struct Covers {
    shape: Vec<Vec4>,
    measured: f32,
    current_drift: f32,
}

impl Covers {
    /// The farthest any vertex of `vertices` lies from the measured shape.
    fn drift(&self, vertices: &[Vec4]) -> f32 {
        self.shape.iter().zip(vertices).map(|(a, b)| a.truncate().distance(b.truncate())).fold(0.0, f32::max)
    }
}

impl ColliderControl {
    /// Sets the covers' reach for the next frame (`ColliderParams::cover_reach`), which sweeps
    /// from the shape the GPU holds to the `deformed` one if any: the measured reach grown by
    /// twice the farthest any vertex lies from the measured shape at either end (a covered
    /// feature's ends and every point of its cover lie no farther, in between too), so a
    /// collider that deforms a little keeps them; the passes drop them beyond `COVER_LIMIT` of
    /// the thickness. The frame leaves the GPU holding the deformed shape, whose drift it keeps.
    fn update_cover_reach(&mut self) {
        let Some(covers) = &mut self.covers else {
            return;
        };
        let incoming = self.deformed.as_deref().map(|vertices| covers.drift(vertices));
        let farthest = incoming.map_or(covers.current_drift, |d| d.max(covers.current_drift));
        covers.current_drift = incoming.unwrap_or(covers.current_drift);
        let reach = covers.measured + 2.0 * farthest;
        let reach = if reach.is_finite() { reach } else { 0.0 };
        if reach != self.params.cover_reach {
            self.params.cover_reach = reach;
            self.params_dirty = true;
        }
    }
}

/// One cloth's host-side values.
pub(crate) struct ClothControl {
    pub params: SimParams,
    /// The substeps the frame runs: the stability bound's, raised for contact (`motion`).
    pub stability: Stability,
    /// The stability bound's choice alone.
    base_stability: Stability,
    /// What the stability bound needs of the cloth beyond its parameters.
    bound: BoundInputs,
    /// Self-collision thickness (m), if on.
    self_collision: Option<f32>,
    /// Friction between the cloth's layers under self-collision.
    self_friction: f32,
    /// The shortest height of the cloth's triangles at the start: whether pair lists pay at
    /// the thickness (`self_contact::lists_pay`).
    shortest_height: f32,
    /// The cloth's triangles (what its walked share is of).
    triangles: u32,
    pub motion: ClothMotion,
    params_dirty: bool,
    /// The self-collision's thickness or friction changed since the GPU last had them.
    self_dirty: bool,
    /// Frames the self-collision tree has been refit since it was last built (`None`: not
    /// built yet), and whether the frame about to run builds it (`SelfTreeSchedule`).
    self_tree: SelfTreeSchedule,
    pins: Vec<(u32, PinChange)>,
    /// A change that may move the whole cloth happened: the next frame starts with every tile
    /// awake (`programs::tiles`).
    tiles_woken: bool,
    /// Moving colliders' boxes the tiles were last handed (0: none, nothing to write).
    tiles_moving: usize,
    /// Under the automatic choice (`SimSettings::crowded_contact`), the narrow phase hands its
    /// crowded particles to a workgroup each: the last frames had enough of them
    /// (`observe_crowded`).
    crowded_handed_over: bool,
}

/// Crowded particles per substep (`Health::crowded_contacts`, summed over the cloth's
/// colliders) from which the automatic choice hands them to a workgroup each, and below which
/// it stops. On an H100 the crowded pass and
/// its barrier cost about 10 µs a substep: the icosphere's 25 crowded particles a substep made
/// its frame 0.61 -> 0.73 ms, the bunny's 800 made it 2.06 -> 1.33 ms.
pub const CROWDED_ON: u32 = 64;
pub const CROWDED_OFF: u32 = 16;

impl ClothControl {
    /// What the cloth's structural springs hold, for a blow-up's diagnosis
    /// (`stability::diagnosis::StructuralHold`; `None` for a grid).
    pub(crate) fn structural_hold(&self) -> Option<crate::stability::diagnosis::StructuralHold> {
        self.bound.hold
    }

    /// Follows the last frame's crowded particles (`crowded` particle-substeps over its
    /// `substeps`) under the automatic choice; returns whether the choice changed.
    fn observe_crowded(&mut self, crowded: u32, substeps: u32) -> bool {
        let per_substep = crowded / substeps.max(1);
        let was = self.crowded_handed_over;
        self.crowded_handed_over = if was { per_substep >= CROWDED_OFF } else { per_substep >= CROWDED_ON };
        self.crowded_handed_over != was
    }
}

impl ClothControl {
    /// Adopts new params and the bound's stability; returns whether the substep count changed.
    fn adopt(&mut self, params: SimParams, base: Stability, settings: &SimSettings) -> bool {
        if let Some(warning) = base.warning() {
            log::warn!("{warning}");
        }
        (self.params, self.base_stability) = (params, base);
        self.apply_contact(settings)
    }

    /// Whether the cloth's self-collision runs pair lists (`self_contact::lists_pay`).
    fn self_lists(&self) -> bool {
        self.self_collision.is_some_and(|t| lists_pay(self.shortest_height, t))
    }

    /// The base stability raised to what contact needs now; returns whether the count changed.
    fn apply_contact(&mut self, settings: &SimSettings) -> bool {
        let stability = settings.with_contact(&self.base_stability, self.motion.contact_substeps);
        let changed = stability.substeps != self.stability.substeps;
        self.stability = stability;
        self.params.substep = stability.substep;
        self.params_dirty = true;
        changed
    }
}

/// Host-side values of a solver and the writes that publish them.
pub(crate) struct Controls {
    pub settings: SimSettings,
    pub cloths: Vec<ClothControl>,
    colliders: Vec<ColliderControl>,
    /// A cloth's schedule changed (substeps, self-collision passes, sleep) since the frame was
    /// last planned.
    replan: bool,
    /// Frames begun (`begin_frame`): the number of the frame being planned, from 1.
    frames_begun: u64,
}

/// Cloth `c`'s frame schedule under `settings`.
fn plan_of(settings: &SimSettings, c: &ClothControl) -> FramePlan {
    // A cloth in contact with itself iterates its contacts every substep; one that is not runs
    // the passes its last frame's motion asks for.
    let passes = (!c.motion.self_contact).then_some(c.motion.self_passes);
    let plan = settings.plan(&c.params, &c.stability, c.motion.asleep, passes);
    let self_lists = c.self_lists();
    let self_windows = if self_lists && c.motion.list_windows && settings.self_list_windows { 2 } else { 1 };
    let crowded =
        if plan.crowded == Crowded::Counted && c.crowded_handed_over { Crowded::HandedOver } else { plan.crowded };
    FramePlan { self_lists, self_windows, self_rebuild: c.self_tree.rebuild, crowded, ..plan }
}

fn invalid(name: &'static str, problem: String) -> Error {
    Error::InvalidParameter { name, problem }
}

fn finite_vec(name: &'static str, v: Vec3) -> Result<()> {
    if v.is_finite() { Ok(()) } else { Err(invalid(name, format!("must be finite, got {v}"))) }
}

fn non_negative(name: &'static str, values: &[f32]) -> Result<()> {
    match values.iter().find(|v| !(v.is_finite() && **v >= 0.0)) {
        Some(v) => Err(invalid(name, format!("must be finite and >= 0, got {v}"))),
        None => Ok(()),
    }
}

/// What a cloth starts with: its resolved parameters, its stability bound's choice and inputs,
/// and its self-collision thickness and friction between its layers (`None`: off) with its
/// triangles' shortest height.
/// The last element: the cloth's triangles' shortest height and their count.
pub(crate) type ClothStart = (SimParams, Stability, BoundInputs, Option<(f32, f32)>, (f32, u32));

impl Controls {
    pub fn new(cloths: Vec<ClothStart>, settings: SimSettings, colliders: Vec<ColliderStart>) -> Self {
        let cloths = cloths
            .into_iter()
            .map(|(params, stability, bound, self_collision, (shortest_height, triangles))| ClothControl {
                params,
                stability,
                base_stability: stability,
                bound,
                self_collision: self_collision.map(|(thickness, _)| thickness),
                self_friction: self_collision.map_or(0.0, |(_, friction)| friction),
                shortest_height,
                triangles,
                motion: ClothMotion::new(),
                params_dirty: false,
                self_dirty: false,
                self_tree: SelfTreeSchedule::new(),
                pins: Vec::new(),
                tiles_woken: false,
                tiles_moving: 0,
                crowded_handed_over: false,
            })
            .collect();
        let colliders = colliders
            .into_iter()
            .map(|ColliderStart { params, pose, deformable, contents, swept_contact }| ColliderControl {
                covers: (params.cover_reach > 0.0).then(|| Covers {
                    shape: contents.clone(),
                    measured: params.cover_reach,
                    current_drift: 0.0,
                }),
                params,
                deformable: (deformable, contents.len() as u32),
                extent: Extent::of(&contents),
                swept_contact,
                current: contents,
                sweeping: false,
                params_dirty: false,
                end_of_last_frame: pose,
                target: pose,
                written: ColliderPose { previous: pose, current: pose, sweep: glam::Vec4::ZERO },
                deformed: None,
                deformation_jumps: false,
                frame_speed: 0.0,
            })
            .collect();
        Controls { settings, cloths, colliders, replan: false, frames_begun: 0 }
    }

    /// Reads cloth `cloth`'s blow-up detector after frame `frame` (`settings::check_health`),
    /// with the collider whose surface moved fastest in the frame, which a blow-up may name.
    pub(crate) fn check_health(&self, health: &drape_types::Health, frame: u64, cloth: usize) -> crate::Result<()> {
        let collider = self.fastest_collider();
        crate::settings::check_health(health, frame, cloth, &self.settings, (&self.cloths[cloth], collider))
    }

    /// The collider whose surface moved fastest in the last frame planned, if any moved.
    fn fastest_collider(&self) -> Option<crate::stability::diagnosis::ColliderMotion> {
        self.colliders
            .iter()
            .enumerate()
            .filter(|(_, c)| c.frame_speed > 0.0)
            .max_by(|a, b| a.1.frame_speed.total_cmp(&b.1.frame_speed))
            .map(|(index, c)| crate::stability::diagnosis::ColliderMotion { index, speed: c.frame_speed })
    }

    /// Each cloth's frame schedule for the current values.
    pub fn plans(&self) -> Vec<FramePlan> {
        self.cloths.iter().map(|c| plan_of(&self.settings, c)).collect()
    }

    /// Whether the frame must be planned again (a cloth's substeps, self-collision passes or
    /// sleep changed); clears it.
    pub fn take_replan(&mut self) -> bool {
        std::mem::take(&mut self.replan)
    }

    /// Wakes every cloth (a change that may move them all).
    pub fn wake_all(&mut self) {
        for c in &mut self.cloths {
            self.replan |= c.motion.wake();
            c.tiles_woken = true;
        }
    }

    /// Puts cloth `index`'s motion history back (a restored state): its substeps and sleep
    /// follow; its tiles wake unless their state came back too (`tiles_restored`).
    pub fn restore_motion(&mut self, index: usize, motion: ClothMotion, tiles_restored: bool) {
        let settings = self.settings;
        if let Some(c) = self.cloths.get_mut(index) {
            c.motion = motion;
            // Its place was the saved frame's, numbered by the solver that ran it.
            c.motion.forget_place();
            c.apply_contact(&settings);
            c.tiles_woken = !tiles_restored;
            self.replan = true;
        }
    }

    /// Cloths that sleep without a known resting place (they just fell asleep): their indices.
    pub fn asleep_unplaced(&self) -> Vec<usize> {
        (0..self.cloths.len())
            .filter(|&i| self.cloths[i].motion.asleep && self.cloths[i].motion.resting_bounds.is_none())
            .collect()
    }

    /// Where sleeping cloth `index` lies (its positions, read back).
    pub fn rest_at(&mut self, index: usize, positions: &[Vec4]) {
        if let Some(c) = self.cloths.get_mut(index) {
            c.motion.rest_at(positions);
        }
    }

    /// Wakes one cloth (a change that could move it: its place is not known until its next
    /// frame is read).
    pub fn wake(&mut self, cloth: ClothId) -> Result<()> {
        let c = self.cloth_mut(cloth)?;
        c.tiles_woken = true;
        c.motion.forget_place();
        let woke = c.motion.wake();
        self.replan |= woke;
        Ok(())
    }

    /// `cloth` was given `velocities` (its start, a teleport): awake, and its next frame
    /// planned for their speed.
    pub fn set_moving(&mut self, cloth: ClothId, velocities: &[Vec4]) -> Result<()> {
        self.wake(cloth)?;
        let speed = velocities.iter().map(|v| v.truncate().length()).fold(0.0, f32::max);
        self.cloth_mut(cloth)?.motion.set_moving(speed);
        Ok(())
    }

    /// After frame `frame` (numbered as `begin_frame` plans them, from 1): cloth `index`'s
    /// health check (its speed drives contact substeps and sleep, its box which moving
    /// colliders may meet it).
    pub fn observe(&mut self, index: usize, health: &Health, frame: u64) {
        let sleep = self.settings.sleep;
        if let Some(c) = self.cloths.get_mut(index) {
            let (substep, substep_count) = (c.stability.substep, c.stability.substeps);
            log::trace!(
                "cloth {index}: fastest particle {} m/s, moving at {} m/s over the last substep, {} self-contact \
                 corrections, fastest pair that may touch {} m over the frame (closing {} m), {} self-collision walks, \
                 {} full lists, largest collider vertex push {} thicknesses, {} particles put back by the fail-safe{} ({} \
                 carried with a moving collider, {} cloth triangles through a collider's), {} crowded contacts",
                crate::motion::max_speed(health),
                crate::motion::max_motion(health, substep),
                health.self_contacts,
                f32::from_bits(health.self_pair_motion_bits),
                f32::from_bits(health.self_pair_approach_bits),
                health.self_walks,
                health.self_full_lists,
                f32::from_bits(health.collider_feature_push_bits),
                health.self_rollbacks,
                if health.self_rollback_all != 0 { " (the whole cloth)" } else { "" },
                health.self_rollbacks_carried,
                health.self_rollback_collider_pairs,
                health.crowded_contacts
            );
            if health.self_rollback_all != 0 {
                log::warn!(
                    "cloth {index}: self-collision's fail-safe put the whole cloth back where the frame started (a \
                     crossing its rounds could not undo by parts); it lost the frame's motion"
                );
            }
            let (self_contact, windows) = (c.motion.self_contact, c.motion.list_windows);
            let pairs_listed = c.self_lists();
            // The share of the frame's triangle-passes that walked the tree (with lists): the
            // escaped triangles' and the full lists' (which walk at every pass).
            let passes = plan_of(&self.settings, c).self_passes.max(1);
            let walked = pairs_listed.then(|| {
                let walks = health.self_walks as f32 + health.self_full_lists as f32 * passes as f32;
                walks / (c.triangles.max(1) as f32 * passes as f32)
            });
            c.motion.observe(health, (substep, c.stability.substeps), sleep, (pairs_listed, walked, passes));
            c.motion.locate(health, frame);
            if c.motion.list_windows != windows && self.settings.self_list_windows {
                log::debug!(
                    "cloth {index}: self-collision lists built {} a frame ({:.1} % of the last frame's triangle-passes \
                     walked the tree)",
                    if c.motion.list_windows { "twice" } else { "once" },
                    100.0 * walked.unwrap_or(0.0)
                );
            }
            // Its passes follow whether it touches itself; its lists' windows, how much walked.
            self.replan |= c.self_collision.is_some()
                && (c.motion.self_contact != self_contact || c.motion.list_windows != windows);
            let automatic = self.settings.crowded_contact.is_none() && self.settings.device_is_gpu;
            if automatic && c.observe_crowded(health.crowded_contacts, substep_count) {
                log::debug!(
                    "cloth {index}: crowded particles {} a workgroup each ({} particle-substeps in the last frame)",
                    if c.crowded_handed_over { "handed to" } else { "no longer handed to" },
                    health.crowded_contacts
                );
                self.replan = true;
            }
        }
    }

    pub fn cloth(&self, id: ClothId) -> Result<&ClothControl> {
        let count = self.cloths.len();
        self.cloths.get(id.0).ok_or_else(|| no_such("cloth", id.0, count))
    }

    fn cloth_mut(&mut self, id: ClothId) -> Result<&mut ClothControl> {
        let count = self.cloths.len();
        self.cloths.get_mut(id.0).ok_or_else(|| no_such("cloth", id.0, count))
    }

    /// Gravity of every cloth.
    pub fn set_gravity(&mut self, gravity: Vec3) -> Result<()> {
        finite_vec("gravity", gravity)?;
        for c in &mut self.cloths {
            c.params.gravity = gravity.extend(0.0);
            c.params_dirty = true;
        }
        self.wake_all();
        Ok(())
    }

    /// The external force (wind) on every cloth.
    pub fn set_external_force(&mut self, force: Vec3) -> Result<()> {
        finite_vec("external_force", force)?;
        for c in &mut self.cloths {
            c.params.external_force = force.extend(0.0);
            c.params_dirty = true;
        }
        self.wake_all();
        Ok(())
    }

    /// New spring stiffnesses of `cloth`; returns whether a substep count changed.
    pub fn set_stiffness(&mut self, cloth: ClothId, k_struct: f32, k_shear: f32, k_bend: f32) -> Result<bool> {
        non_negative("stiffness", &[k_struct, k_shear, k_bend])?;
        let mut params = self.cloth(cloth)?.params;
        (params.k_struct, params.k_shear, params.k_bend) = (k_struct, k_shear, k_bend);
        let settings = self.settings;
        self.restabilise(cloth, params, settings)
    }

    /// New spring-axis and velocity damping of `cloth`; returns whether a substep count changed.
    pub fn set_damping(&mut self, cloth: ClothId, spring: f32, velocity: f32) -> Result<bool> {
        non_negative("damping", &[spring, velocity])?;
        let mut params = self.cloth(cloth)?.params;
        (params.spring_damping, params.velocity_damping) = (spring, velocity);
        let settings = self.settings;
        self.restabilise(cloth, params, settings)
    }

    /// New simulated time per frame; returns whether a substep count changed. Checked for every
    /// cloth before any changes.
    pub fn set_frame_dt(&mut self, frame_dt: f32) -> Result<bool> {
        let settings = SimSettings { frame_dt, ..self.settings };
        let resolved =
            self.cloths.iter().map(|c| settings.resolve_params(&c.params, &c.bound)).collect::<Result<Vec<_>>>()?;
        let mut changed = false;
        for (c, (params, stability)) in self.cloths.iter_mut().zip(resolved) {
            changed |= c.adopt(params, stability, &settings);
        }
        self.settings = settings;
        self.wake_all();
        Ok(changed)
    }

    /// Chooses `cloth`'s substep for `params` under `settings` (automatic substeps follow the
    /// stability bound) and adopts both if valid.
    fn restabilise(&mut self, cloth: ClothId, params: SimParams, settings: SimSettings) -> Result<bool> {
        let bound = &self.cloth(cloth)?.bound;
        let (resolved, stability) = settings.resolve_params(&params, bound)?;
        let changed = self.cloth_mut(cloth)?.adopt(resolved, stability, &settings);
        self.wake(cloth)?;
        Ok(changed)
    }

    /// Sets `cloth`'s self-collision thickness (m) and the friction between its layers; an
    /// error for a cloth built without self-collision (its tree and buffers are made with the
    /// model).
    pub fn set_self_collision(&mut self, cloth: ClothId, thickness: f32, friction: f32) -> Result<()> {
        if !(thickness.is_finite() && thickness > 0.0) {
            return Err(invalid("self-collision thickness", format!("must be finite and > 0, got {thickness}")));
        }
        non_negative("self-collision friction", &[friction])?;
        let c = self.cloth_mut(cloth)?;
        if c.self_collision.is_none() {
            return Err(invalid(
                "self-collision",
                format!(
                    "cloth {} was built without it: turn it on with ClothBuilder::self_collision(Some(thickness)) \
                     before building the model",
                    cloth.0
                ),
            ));
        }
        (c.self_collision, c.self_friction, c.self_dirty) = (Some(thickness), friction, true);
        // The passes follow the thickness.
        self.replan = true;
        self.wake(cloth)
    }

    fn collider(&mut self, id: ColliderId) -> Result<&mut ColliderControl> {
        let count = self.colliders.len();
        self.colliders.get_mut(id.0).ok_or_else(|| no_such("collider", id.0, count))
    }

    pub fn set_contact(&mut self, id: ColliderId, thickness: f32, friction: f32) -> Result<()> {
        let checked = crate::lbvh::collider_params(&[Vec4::ZERO], thickness, friction)?;
        let c = self.collider(id)?;
        c.params.thickness = checked.thickness;
        c.params.friction = checked.friction;
        c.params_dirty = true;
        self.wake_all();
        Ok(())
    }

    /// Where collider `id` is at the end of the next frame (it moves there from where the last
    /// frame left it over the frame's substeps).
    pub fn set_collider_pose(&mut self, id: ColliderId, pose: RigidPose) -> Result<()> {
        check_pose(&pose)?;
        let c = self.collider(id)?;
        // The shorter way round: interpolation between q and -q would pass through zero.
        let previous = c.end_of_last_frame.rotation;
        let q = if previous.dot(pose.rotation) < 0.0 { -pose.rotation } else { pose.rotation };
        c.target = RigidPose { rotation: q.normalize(), translation: pose.translation.truncate().extend(0.0) };
        Ok(())
    }

    /// Puts collider `id` at `pose` without sweeping there: the next frame starts and ends at it
    /// (a restored state's place; the cloths' sleep is the state's).
    pub fn place_collider(&mut self, id: ColliderId, pose: RigidPose) -> Result<()> {
        check_pose(&pose)?;
        let c = self.collider(id)?;
        let pose =
            RigidPose { rotation: pose.rotation.normalize(), translation: pose.translation.truncate().extend(0.0) };
        (c.end_of_last_frame, c.target) = (pose, pose);
        Ok(())
    }

    /// `place_collider`, waking every cloth: the collider may now lie where a sleeping cloth
    /// rests.
    pub fn teleport_collider(&mut self, id: ColliderId, pose: RigidPose) -> Result<()> {
        self.place_collider(id, pose)?;
        self.wake_all();
        Ok(())
    }

    /// Where each collider is (the end of the last frame, or its teleport target).
    pub fn collider_poses(&self) -> Vec<RigidPose> {
        self.colliders.iter().map(|c| c.end_of_last_frame).collect()
    }

    /// New spheres of sphere collider `id` in its own frame (a deforming collider), where the
    /// next frame ends them: same count.
    pub fn set_collider_spheres(&mut self, id: ColliderId, spheres: &[Vec4]) -> Result<()> {
        if let Some(s) = spheres.iter().find(|s| !s.is_finite() || s.w < 0.0) {
            return Err(invalid("collider spheres", format!("centres must be finite and radii >= 0, got {s}")));
        }
        self.deform(id, "spheres", spheres.to_vec())
    }

    /// New vertex positions of mesh collider `id` in its own frame (a deforming body: the same
    /// triangles).
    pub fn set_collider_vertices(&mut self, id: ColliderId, vertices: &[Vec3]) -> Result<()> {
        if let Some(v) = vertices.iter().find(|v| !v.is_finite()) {
            return Err(invalid("collider vertices", format!("must be finite, got {v}")));
        }
        self.deform(id, "vertices", vertices.iter().map(|v| v.extend(0.0)).collect())
    }

    /// New spheres of sphere collider `id`, standing there from the next frame's start (a
    /// teleport: no sweep), waking every cloth.
    pub fn teleport_collider_spheres(&mut self, id: ColliderId, spheres: &[Vec4]) -> Result<()> {
        self.set_collider_spheres(id, spheres)?;
        self.jump_deformation(id)
    }

    /// New vertex positions of mesh collider `id`, standing there from the next frame's start
    /// (a teleport: no sweep), waking every cloth.
    pub fn teleport_collider_vertices(&mut self, id: ColliderId, vertices: &[Vec3]) -> Result<()> {
        self.set_collider_vertices(id, vertices)?;
        self.jump_deformation(id)
    }

    fn jump_deformation(&mut self, id: ColliderId) -> Result<()> {
        self.collider(id)?.deformation_jumps = true;
        self.wake_all();
        Ok(())
    }

    fn deform(&mut self, id: ColliderId, what: &'static str, data: Vec<Vec4>) -> Result<()> {
        let c = self.collider(id)?;
        let (kind, count) = c.deformable;
        if kind != what {
            return Err(invalid("collider", format!("collider {} is made of {kind}, not {what}", id.0)));
        }
        if data.len() != count as usize {
            return Err(invalid("collider", format!("expected {count} {what}, got {}", data.len())));
        }
        (c.deformed, c.deformation_jumps) = (Some(data), false);
        Ok(())
    }

    pub fn pin(&mut self, cloth: ClothId, particle: u32, at: Option<Vec3>) -> Result<()> {
        if let Some(p) = at {
            finite_vec("pin position", p)?;
        }
        let c = self.particle_of(cloth, particle)?;
        c.pins.push((particle, at.map_or(PinChange::Here, PinChange::At)));
        self.wake(cloth)
    }

    pub fn unpin(&mut self, cloth: ClothId, particle: u32) -> Result<()> {
        self.particle_of(cloth, particle)?.pins.push((particle, PinChange::Unpin));
        self.wake(cloth)
    }

    fn particle_of(&mut self, cloth: ClothId, particle: u32) -> Result<&mut ClothControl> {
        let c = self.cloth_mut(cloth)?;
        let n = c.params.particle_count;
        if particle >= n {
            return Err(invalid("particle", format!("index {particle}, but cloth {} has {n} particles", cloth.0)));
        }
        Ok(c)
    }

    /// The frame's steps when a substep count changed.
    pub fn frame_steps(&self, program: &SolverProgram) -> Vec<Step> {
        program.frame_steps(&self.plans())
    }

    /// The writes (and refits) the next frame starts with; empty when nothing changed. Marks
    /// everything published.
    pub fn begin_frame(&mut self, program: &SolverProgram) -> Vec<Step> {
        self.frames_begun += 1;
        let moving = self.plan_motion();
        for c in self.cloths.iter_mut().filter(|c| c.self_collision.is_some() && !c.motion.asleep) {
            self.replan |= c.self_tree.next_frame();
        }
        let mut steps = Vec::new();
        for (c, buffers) in self.cloths.iter_mut().zip(&program.cloths) {
            if std::mem::take(&mut c.params_dirty) {
                steps.push(Step::write(buffers.params, 0, &[c.params]));
            }
            if let (true, Some(s), Some(thickness)) =
                (std::mem::take(&mut c.self_dirty), &buffers.self_contact, c.self_collision)
            {
                // The whole record: its Morton box and longest edge are the frame start's to write.
                let params = SelfContactBuffers::params(s.tree.leaves, thickness, c.self_friction);
                steps.push(Step::write(s.tree.collider, 0, &[params]));
            }
            pin_writes(&mut c.pins, buffers.x, buffers.v, &mut steps);
            if let Some(tiles) = &buffers.tiles {
                if std::mem::take(&mut c.tiles_woken) {
                    steps.extend(tiles.wake_steps());
                }
                if !moving.is_empty() || c.tiles_moving != 0 {
                    steps.extend(tiles.moving_writes(&moving));
                    c.tiles_moving = moving.len();
                }
            }
        }
        for (c, buffers) in self.colliders.iter_mut().zip(&program.colliders) {
            c.update_cover_reach();
            if std::mem::take(&mut c.params_dirty) {
                steps.push(Step::write(buffers.tree().collider, 0, &[c.params]));
            }
            // The vertices are written below when it deforms or stops deforming.
            let reshaped = c.deformed.is_some() || c.sweeping;
            let sweep = glam::Vec4::new(c.frame_sweep(), if reshaped { 1.0 } else { 0.0 }, 0.0, 0.0);
            let pose = ColliderPose { previous: c.end_of_last_frame, current: c.target, sweep };
            if pose != c.written {
                steps.push(Step::write(buffers.pose, 0, &[pose]));
                c.written = pose;
            }
            c.end_of_last_frame = c.target;
            let leaves = buffers.leaves.kind();
            if let Some(data) = c.deformed.take() {
                // Leaves that sweep go from what the GPU holds to the new input over the frame;
                // teleported ones stand at the new input from its start.
                let jumps = std::mem::take(&mut c.deformation_jumps);
                if let Some(from) = leaves.swept_from() {
                    steps.push(Step::write(from, 0, if jumps { &data } else { &c.current }));
                    c.sweeping = !jumps;
                }
                steps.push(Step::write(leaves.deformable(), 0, &data));
                steps.extend(leaves.refit_steps());
                c.extent = Extent::of(&data);
                c.current = data;
            } else if std::mem::take(&mut c.sweeping) {
                // It stopped deforming: its leaves stand still again.
                if let Some(from) = leaves.swept_from() {
                    steps.push(Step::write(from, 0, &c.current));
                    steps.extend(leaves.refit_steps());
                }
            }
        }
        steps
    }

    /// Each cloth's contact substeps, self-collision passes and sleep for the frame about to run
    /// (`motion`), from the last frame's speeds and the colliders' motion this frame; returns the
    /// moving colliders' swept boxes, grown by their contact reach (what wakes the tiles near
    /// them).
    fn plan_motion(&mut self) -> Vec<(Vec3, Vec3)> {
        let (settings, frames_begun) = (self.settings, self.frames_begun);
        // Each moving collider's surface speed and swept box, grown by its contact reach.
        let moving: Vec<(f32, bool, (Vec3, Vec3))> = self
            .colliders
            .iter_mut()
            .filter_map(|c| {
                let motion = c.frame_motion(settings.frame_dt);
                c.frame_speed = motion.map_or(0.0, |(speed, _)| speed);
                let (speed, (lo, hi)) = motion?;
                let reach = Vec3::splat(c.params.thickness);
                Some((speed, c.swept_contact, (lo - reach, hi + reach)))
            })
            .collect();
        // Triangle contact sweeps each particle's path against the moving triangles (CCD): any
        // substep length is safe. Sphere contact and self-collision test proximity at substep
        // ends only.
        let collider_thickness =
            self.colliders.iter().filter(|c| !c.swept_contact).map(|c| c.params.thickness).reduce(f32::min);
        // A triangle collider's vertices and edges against a self-colliding cloth's faces and
        // edges (`drape_kernels::self_contact`) are found by proximity too.
        let feature_thickness =
            self.colliders.iter().filter(|c| c.swept_contact).map(|c| c.params.thickness).reduce(f32::min);
        for c in &mut self.cloths {
            // The moving colliders that may meet this cloth over the frame: only their surface
            // speed moves its contact substeps.
            let lightest = c.bound.profile.lightest_inverse_mass(&c.params);
            let acceleration =
                c.params.gravity.truncate().length() + c.params.external_force.truncate().length() * lightest;
            let meeting: Vec<(f32, bool)> = moving
                .iter()
                .filter(|m| c.motion.may_meet(m.2, (frames_begun, settings.frame_dt), acceleration))
                .map(|m| (m.0, m.1))
                .collect();
            let collider_speed = meeting.iter().map(|m| m.0).fold(0.0, f32::max);
            let triangle_speed = meeting.iter().filter(|m| m.1).map(|m| m.0).fold(0.0, f32::max);
            let most = SELF_SUBSTEPS_LIMIT * c.base_stability.substeps;
            let features_most = (
                FEATURE_SUBSTEPS_LIMIT * c.base_stability.substeps,
                MOVING_FEATURE_SUBSTEPS_LIMIT * c.base_stability.substeps,
            );
            let proximity = Proximity {
                collider: collider_thickness,
                self_collision: c.self_collision.map(|t| (t, most)),
                collider_features: c.self_collision.and(feature_thickness).map(|thickness| FeatureContact {
                    thickness,
                    speed: triangle_speed,
                    most: features_most,
                }),
            };
            let near = moving.iter().any(|&(_, _, bounds)| c.motion.near(bounds));
            let passes = plan_of(&settings, c).self_passes;
            let change = c.motion.plan_frame(proximity, (collider_speed, near), settings.frame_dt, settings.sleep);
            if change.substeps {
                self.replan |= c.apply_contact(&settings);
                log::debug!(
                    "contact needs {} substeps per frame: running {} (stability bound {})",
                    c.motion.contact_substeps,
                    c.stability.substeps,
                    c.base_stability.substeps
                );
            }
            if change.sleep {
                log::debug!("cloth {}", if c.motion.asleep { "falls asleep" } else { "wakes" });
            }
            // The self-collision passes are encoded in the frame: those of a cloth that does not
            // touch itself follow its last frame's motion (`ClothMotion::self_passes`).
            let planned = plan_of(&settings, c).self_passes;
            if c.self_collision.is_some() && planned != passes {
                log::debug!(
                    "self-collision runs {planned} passes per frame (its motion needs {})",
                    c.motion.self_passes
                );
                self.replan = true;
            }
            self.replan |= change.sleep;
        }
        moving.into_iter().map(|(_, _, bounds)| bounds).collect()
    }
}

impl ColliderControl {
    /// How the collider moves over the coming frame, from the last frame's end pose to the
    /// target and from its leaves to the deformed ones: None when it stands still, else the
    /// fastest point of its surface (m/s) and the world box its leaves sweep.
    fn frame_motion(&self, frame_dt: f32) -> Option<(f32, (Vec3, Vec3))> {
        let (from, to) = (self.end_of_last_frame, self.target);
        let (moved, turn) = self.pose_motion();
        let angle = 2.0 * turn.w.abs().min(1.0).acos();
        let (mut low, mut high) = (self.extent.low, self.extent.high);
        if let Some(next) = &self.deformed {
            let extent = Extent::of(next);
            (low, high) = (low.min(extent.low), high.max(extent.high));
        }
        let deformed = self.leaves_motion();
        if moved == 0.0 && angle == 0.0 && deformed == 0.0 {
            return None;
        }
        // The turn moves a point at distance r from the centre by at most r x angle.
        let speed = (moved + angle * self.extent.radius + deformed) / frame_dt;
        let mut world = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for pose in [from, to] {
            for corner in 0..8 {
                let c = Vec3::new(
                    if corner & 1 == 0 { low.x } else { high.x },
                    if corner & 2 == 0 { low.y } else { high.y },
                    if corner & 4 == 0 { low.z } else { high.z },
                );
                let p = to_world(&pose, c);
                world = (world.0.min(p), world.1.max(p));
            }
        }
        Some((speed, world))
    }

    /// How far any point of the collider's surface moves over the coming frame at most (m,
    /// `ColliderPose::sweep`): its box centre's motion, the turn about the centre (a point r
    /// from it moves at most 2 sin(angle / 2) r: twice the turn quaternion's vector part, exact
    /// for small turns, where an angle through `acos` rounds to 0), its leaves' own motion, and
    /// that motion turned; 0 when it stands still.
    fn frame_sweep(&self) -> f32 {
        let (moved, turn) = self.pose_motion();
        let chord = 2.0 * Vec3::new(turn.x, turn.y, turn.z).length();
        let deformed = self.leaves_motion();
        moved + chord * (self.extent.radius + deformed) + deformed
    }

    /// Its pose's motion over the coming frame: how far its box centre moves, and the turn.
    /// Any point's motion is the centre's plus the turn about the centre (a collider placed far
    /// from its own origin and spun about its middle moves slowly).
    fn pose_motion(&self) -> (f32, Quat) {
        let (from, to) = (self.end_of_last_frame, self.target);
        let centre = self.extent.centre();
        let moved = (to_world(&to, centre) - to_world(&from, centre)).length();
        (moved, Quat::from_vec4(to.rotation) * Quat::from_vec4(from.rotation).conjugate())
    }

    /// How far its leaves move over the coming frame in its own frame at most (the deformed
    /// input against what the GPU holds; 0 when it is not deformed).
    fn leaves_motion(&self) -> f32 {
        if self.deformation_jumps {
            return 0.0;
        }
        self.deformed.as_ref().map_or(0.0, |next| {
            next.iter()
                .zip(&self.current)
                .map(|(a, b)| (a.truncate() - b.truncate()).length() + (a.w - b.w).abs())
                .fold(0.0, f32::max)
        })
    }
}

fn no_such(kind: &str, index: usize, count: usize) -> Error {
    Error::InvalidParameter {
        name: "id",
        problem: format!("{kind} {index}, but the model has {count} {kind}s; use the ids its builder returned"),
    }
}

fn check_pose(pose: &RigidPose) -> Result<()> {
    let rotation = Quat::from_vec4(pose.rotation);
    if rotation.is_finite() && pose.translation.is_finite() && (rotation.length() - 1.0).abs() < 1e-3 {
        return Ok(());
    }
    let (r, t) = (pose.rotation, pose.translation);
    Err(invalid(
        "collider pose",
        format!(
            "the rotation must be a unit quaternion and the translation finite, got rotation (x, y, z, w) = \
             ({}, {}, {}, {}) of length {} and translation ({}, {}, {}): normalise the quaternion \
             (`Quat::normalize`), or build it with `Quat::from_axis_angle` from a unit axis",
            r.x,
            r.y,
            r.z,
            r.w,
            rotation.length(),
            t.x,
            t.y,
            t.z
        ),
    ))
}

/// The writes of a cloth's pending pin changes (the last change of each particle wins; one
/// write range per particle).
fn pin_writes(pins: &mut Vec<(u32, PinChange)>, x: Handle<Vec4>, v: Handle<Vec4>, steps: &mut Vec<Step>) {
    let latest: std::collections::BTreeMap<u32, PinChange> = pins.drain(..).collect();
    for (particle, change) in latest {
        // w is the pin weight: 0 pinned, 1 free. A pinned particle's velocity is zero.
        let w_offset = (particle as usize * size_of::<Vec4>() + 3 * size_of::<f32>()) as u64;
        match change {
            PinChange::Here => {
                steps.push(Step::Write { buffer: x.id(), offset: w_offset, bytes: 0f32.to_le_bytes().to_vec() });
                steps.push(Step::write(v, particle, &[Vec4::ZERO]));
            }
            PinChange::At(p) => {
                steps.push(Step::write(x, particle, &[p.extend(0.0)]));
                steps.push(Step::write(v, particle, &[Vec4::ZERO]));
            }
            PinChange::Unpin => {
                steps.push(Step::Write { buffer: x.id(), offset: w_offset, bytes: 1f32.to_le_bytes().to_vec() })
            }
        }
    }
}

/// The runtime setters of a solver type with `controls: Controls`, `program: SolverProgram` and
/// `fn replan(&mut self, substeps_changed: bool) -> Result<()>`: one definition for the GPU
/// solver and its CPU twin. Each takes effect at the start of the next frame.
macro_rules! runtime_setters {
    ($solver:ty) => {
        impl $solver {
            /// Sets gravity (m/s^2) of every cloth.
            pub fn set_gravity(&mut self, gravity: glam::Vec3) -> $crate::Result<()> {
                self.controls.set_gravity(gravity)
            }

            /// Sets the constant external force on every free particle of every cloth (N), e.g.
            /// wind.
            pub fn set_external_force(&mut self, force: glam::Vec3) -> $crate::Result<()> {
                self.controls.set_external_force(force)
            }

            /// Sets `cloth`'s spring stiffnesses (N/m); automatic substeps follow the stability
            /// bound.
            pub fn set_stiffness(
                &mut self,
                cloth: $crate::ClothId,
                k_struct: f32,
                k_shear: f32,
                k_bend: f32,
            ) -> $crate::Result<()> {
                let changed = self.controls.set_stiffness(cloth, k_struct, k_shear, k_bend)?;
                self.replan(changed)
            }

            /// Sets `cloth`'s spring-axis damping and velocity damping (N s/m); automatic
            /// substeps follow the stability bound.
            pub fn set_damping(&mut self, cloth: $crate::ClothId, spring: f32, velocity: f32) -> $crate::Result<()> {
                let changed = self.controls.set_damping(cloth, spring, velocity)?;
                self.replan(changed)
            }

            /// Sets the simulated time of each following frame (s); automatic substeps are
            /// chosen again from the stability bound (fixed ones keep their count).
            pub fn set_frame_dt(&mut self, frame_dt: f32) -> $crate::Result<()> {
                let changed = self.controls.set_frame_dt(frame_dt)?;
                self.replan(changed)
            }

            /// Sets `cloth`'s self-collision thickness (m) and the Coulomb friction between its
            /// layers; an error for a cloth built without self-collision.
            pub fn set_self_collision(
                &mut self,
                cloth: $crate::ClothId,
                thickness: f32,
                friction: f32,
            ) -> $crate::Result<()> {
                self.controls.set_self_collision(cloth, thickness, friction)
            }

            /// Sets `collider`'s contact thickness (m) and Coulomb friction coefficient.
            pub fn set_contact(
                &mut self,
                collider: $crate::ColliderId,
                thickness: f32,
                friction: f32,
            ) -> $crate::Result<()> {
                self.controls.set_contact(collider, thickness, friction)
            }

            /// Moves `collider`: the next frame ends with it at `rotation`, `translation` (its
            /// frame in the world). Over the frame it moves there from where the last frame left
            /// it, substep by substep, so it sweeps the cloth instead of jumping through it. A
            /// collider not moved in a frame stays where it is.
            pub fn set_collider_pose(
                &mut self,
                collider: $crate::ColliderId,
                rotation: glam::Quat,
                translation: glam::Vec3,
            ) -> $crate::Result<()> {
                self.controls.set_collider_pose(collider, $crate::rigid_pose(rotation, translation))
            }

            /// Puts `collider` at `rotation`, `translation` without sweeping there (a respawn, a
            /// cut in an animation): the next frame starts and ends with it there, and every
            /// cloth wakes. Sphere contact pushes out a particle it now holds; triangle contact
            /// keeps each particle on the side it finds it, so teleport a mesh clear of the
            /// cloth.
            pub fn teleport_collider(
                &mut self,
                collider: $crate::ColliderId,
                rotation: glam::Quat,
                translation: glam::Vec3,
            ) -> $crate::Result<()> {
                self.controls.teleport_collider(collider, $crate::rigid_pose(rotation, translation))
            }

            /// `set_collider_spheres` without the sweep: the spheres stand at their new place
            /// from the next frame's start (as `teleport_collider` puts a pose), and every cloth
            /// wakes.
            pub fn teleport_collider_spheres(
                &mut self,
                collider: $crate::ColliderId,
                spheres: &[glam::Vec4],
            ) -> $crate::Result<()> {
                self.controls.teleport_collider_spheres(collider, spheres)
            }

            /// `set_collider_vertices` without the sweep: the vertices stand at their new place
            /// from the next frame's start (as `teleport_collider` puts a pose), and every cloth
            /// wakes.
            pub fn teleport_collider_vertices(
                &mut self,
                collider: $crate::ColliderId,
                vertices: &[glam::Vec3],
            ) -> $crate::Result<()> {
                self.controls.teleport_collider_vertices(collider, vertices)
            }

            /// Deforms sphere collider `collider`: new spheres in its own frame, as many as it was
            /// built with, where the next frame ends them. The next frame writes them and refits
            /// the LBVH on the GPU (same tree); over its substeps each sphere sweeps there from
            /// where the last frame left it, centre and radius (contact follows it and takes its
            /// surface's motion, as it does a deforming mesh's).
            pub fn set_collider_spheres(
                &mut self,
                collider: $crate::ColliderId,
                spheres: &[glam::Vec4],
            ) -> $crate::Result<()> {
                self.controls.set_collider_spheres(collider, spheres)
            }

            /// Deforms mesh collider `collider` (a skinned or simulated body): new positions of
            /// its vertices in its own frame, the same triangles. The next frame writes them and
            /// refits the LBVH on the GPU.
            pub fn set_collider_vertices(
                &mut self,
                collider: $crate::ColliderId,
                vertices: &[glam::Vec3],
            ) -> $crate::Result<()> {
                self.controls.set_collider_vertices(collider, vertices)
            }

            /// Pins particle `particle` of `cloth` where it is (`None`) or at `position` (moving
            /// it there: call every frame for an animated pin).
            pub fn pin(
                &mut self,
                cloth: $crate::ClothId,
                particle: u32,
                position: Option<glam::Vec3>,
            ) -> $crate::Result<()> {
                self.controls.pin(cloth, particle, position)
            }

            /// Frees particle `particle` of `cloth`.
            pub fn unpin(&mut self, cloth: $crate::ClothId, particle: u32) -> $crate::Result<()> {
                self.controls.unpin(cloth, particle)
            }

            /// `cloth`'s current parameters (what its kernels read).
            pub fn params(&self, cloth: $crate::ClothId) -> $crate::Result<&drape_types::SimParams> {
                Ok(&self.controls.cloth(cloth)?.params)
            }

            /// `cloth`'s stability bound and substeps (the next frame's: raised while contact
            /// needs more, `motion`).
            pub fn stability(&self, cloth: $crate::ClothId) -> $crate::Result<&$crate::Stability> {
                Ok(&self.controls.cloth(cloth)?.stability)
            }

            /// Whether `cloth` sleeps (its frames run nothing until something wakes it).
            pub fn asleep(&self, cloth: $crate::ClothId) -> $crate::Result<bool> {
                Ok(self.controls.cloth(cloth)?.motion.asleep)
            }

            pub fn settings(&self) -> &$crate::SimSettings {
                &self.controls.settings
            }
        }
    };
}
pub(crate) use runtime_setters;

/// When a self-colliding cloth's tree is built and when refit.
#[derive(Copy, Clone, Debug)]
pub(crate) struct SelfTreeSchedule {
    /// Frames refit since the last build (`None`: never built).
    age: Option<u32>,
    /// The frame about to run builds the tree.
    pub rebuild: bool,
}

impl SelfTreeSchedule {
    pub fn new() -> Self {
        SelfTreeSchedule { age: None, rebuild: true }
    }

    /// Schedules the frame about to run (one that runs: not asleep); returns whether its plan
    /// changed (build instead of refit, or back).
    pub fn next_frame(&mut self) -> bool {
        let age = match self.age {
            Some(age) if age + 1 < crate::programs::self_contact::SELF_TREE_REBUILD_FRAMES => age + 1,
            _ => 0,
        };
        self.age = Some(age);
        let rebuild = age == 0;
        std::mem::replace(&mut self.rebuild, rebuild) != rebuild
    }
}

#[cfg(test)]
mod tests {
    use super::{ColliderStart, Controls, SelfTreeSchedule};
    use crate::model::ColliderId;
    use crate::programs::self_contact::SELF_TREE_REBUILD_FRAMES;
    use crate::settings::SimSettings;
    use drape_kernels::self_contact::COVER_LIMIT;
    use drape_types::{ColliderParams, RigidPose};
    use glam::{Vec3, Vec4};

    /// A collider deformed at run time has its covers' reach grown by twice the farthest any
    /// vertex moved from the shape they were measured on (`collider_cover`): unchanged for the
    /// same vertices, grown for a small move, and past `COVER_LIMIT` of the thickness (where
    /// the passes drop them) for a large one.
    #[test]
    fn deforming_a_collider_grows_its_covers_reach_by_twice_its_drift() {
        let params = ColliderParams { leaf_count: 1, thickness: 0.005, cover_reach: 0.00125, ..Default::default() };
        let contents = vec![Vec4::ZERO, Vec4::X, Vec4::Y];
        let start =
            ColliderStart { params, pose: RigidPose::IDENTITY, deformable: "vertices", contents, swept_contact: true };
        let mut controls = Controls::new(Vec::new(), SimSettings::default(), vec![start]);
        assert!(!controls.colliders[0].params_dirty);
        // One frame: `begin_frame`'s update, then what the frame's deformation leaves (the
        // shape the GPU holds after it).
        let frame = |controls: &mut Controls, vertices: Option<&[Vec3]>| {
            let c = &mut controls.colliders[0];
            c.params_dirty = false;
            if let Some(v) = vertices {
                c.deformed = Some(v.iter().map(|p| p.extend(0.0)).collect());
            }
            c.update_cover_reach();
            let seen = (c.params.cover_reach, c.params_dirty);
            if let Some(data) = c.deformed.take() {
                c.current = data;
            }
            seen
        };
        assert_eq!(frame(&mut controls, None), (0.00125, false), "standing");
        assert_eq!(frame(&mut controls, Some(&[Vec3::ZERO, Vec3::X, Vec3::Y])), (0.00125, false), "the same shape");
        let nudged = frame(&mut controls, Some(&[Vec3::ZERO, Vec3::X, Vec3::new(0.0, 1.0, 0.0001)]));
        assert!((nudged.0 - 0.00145).abs() < 1e-7 && nudged.1, "moved 0.1 mm: {nudged:?}");
        let bent = frame(&mut controls, Some(&[Vec3::ZERO, Vec3::X, Vec3::Z])).0;
        assert!(bent > COVER_LIMIT * 0.005, "moved 1.4 m: reach {bent}");
        // Back to the measured shape: the frame sweeps from the bent one, then it stands.
        assert_eq!(frame(&mut controls, Some(&[Vec3::ZERO, Vec3::X, Vec3::Y])).0, bent, "sweeping back");
        assert_eq!(frame(&mut controls, None), (0.00125, true), "standing on the measured shape again");
        // Through the public setter: the deformation is noted, the reach follows at the frame.
        controls.set_collider_vertices(ColliderId(0), &[Vec3::ZERO, Vec3::X, Vec3::Z]).unwrap();
        assert!(frame(&mut controls, None).0 > COVER_LIMIT * 0.005);
    }

    /// A small cloth with nothing between its stages runs its substeps in one workgroup on a
    /// GPU that runs workgroups of `SUBSTEPS_THREADS`, not on one that runs narrower ones (nor on
    /// a CPU driver); asking for it there is an error that names the limit and the way out.
    #[test]
    fn substeps_run_in_one_workgroup_only_where_the_device_fits_it() {
        use crate::{ClothBuilder, Error, Model};
        use drape_kernels::substeps::SUBSTEPS_THREADS;
        let cloth = ClothBuilder::new(16, 16).build().unwrap();
        let plan = |forced: Option<bool>, gpu: bool, max_workgroup: u32| {
            let settings = SimSettings::default().with_one_workgroup_substeps(forced);
            let model = Model::single(&cloth, &[], settings).unwrap();
            crate::program::SolverProgram::with_controls_on(&model, gpu, max_workgroup)
                .map(|(_, controls)| controls.plans()[0].one_workgroup)
        };
        assert!(plan(None, true, SUBSTEPS_THREADS).unwrap(), "a GPU that fits it");
        assert!(!plan(None, true, SUBSTEPS_THREADS / 2).unwrap(), "a GPU with narrower workgroups");
        assert!(!plan(None, false, u32::MAX).unwrap(), "a CPU driver");
        assert!(plan(Some(true), false, u32::MAX).unwrap(), "forced on a CPU driver");
        match plan(Some(true), true, 256) {
            Err(Error::InvalidParameter { name, problem }) => {
                assert_eq!(name, "one_workgroup_substeps");
                assert!(problem.contains("256") && problem.contains("auto"), "{problem}");
            }
            other => panic!("forced on a narrow device: {other:?}"),
        }
    }

    /// The automatic choice hands a cloth's crowded particles to a workgroup each once a frame
    /// has `CROWDED_ON` a substep, keeps doing so while frames have `CROWDED_OFF`, and stops
    /// below (replanning the frame at each change); on a CPU driver it only counts them, and a
    /// forced choice does not follow the frames.
    #[test]
    fn crowded_particles_are_handed_over_while_frames_have_many() {
        use super::{CROWDED_OFF, CROWDED_ON};
        use crate::programs::contact::Crowded;
        use crate::{ClothBuilder, Collider, Mesh, Model};
        use drape_types::Health;
        let cloth = ClothBuilder::new(8, 8).build().unwrap();
        let ball = Collider::mesh(&Mesh::icosphere(0.3, 2), 0.005);
        let controls = |crowded: Option<bool>, gpu: bool| {
            let settings = SimSettings::default().with_crowded_contact(crowded);
            let model = Model::single(&cloth, std::slice::from_ref(&ball), settings).unwrap();
            crate::program::SolverProgram::with_controls_on(&model, gpu, u32::MAX).unwrap().1
        };
        let mut gpu = controls(None, true);
        let substeps = gpu.cloths[0].stability.substeps;
        let frame = |controls: &mut Controls, per_substep: u32| {
            let health = Health { crowded_contacts: per_substep * substeps, ..Health::default() };
            controls.observe(0, &health, 1);
            (controls.plans()[0].crowded, controls.take_replan())
        };
        assert_eq!(gpu.plans()[0].crowded, Crowded::Counted, "the first frame counts");
        assert_eq!(frame(&mut gpu, CROWDED_ON - 1), (Crowded::Counted, false), "a few");
        assert_eq!(frame(&mut gpu, CROWDED_ON), (Crowded::HandedOver, true), "many");
        assert_eq!(frame(&mut gpu, CROWDED_OFF), (Crowded::HandedOver, false), "fewer, not few");
        assert_eq!(frame(&mut gpu, CROWDED_OFF - 1), (Crowded::Counted, true), "few");
        let mut cpu = controls(None, false);
        assert_eq!(frame(&mut cpu, 10 * CROWDED_ON), (Crowded::Counted, false), "a CPU driver only counts");
        let mut on = controls(Some(true), true);
        assert_eq!(frame(&mut on, 0), (Crowded::HandedOver, false), "forced on");
        let mut off = controls(Some(false), true);
        assert_eq!(frame(&mut off, 10 * CROWDED_ON), (Crowded::Ignored, false), "forced off");
    }

    /// A solver's program sets a triangle collider's cover reach (a quarter thickness) where
    /// its curled features cover others (a wire of 512 sides under a self-colliding cloth),
    /// and not where nothing measures them (the same cloth without self-collision).
    #[test]
    fn a_fine_wire_under_a_self_colliding_cloth_gets_its_covers() {
        use crate::{ClothBuilder, Collider, Mesh, Model};
        let (vertices, triangles) = crate::collider_cover::tube(0.003, 512, 1.2, 2);
        let wire = Collider::mesh(&Mesh::from_parts(vertices, triangles).unwrap(), 0.005);
        let reach = |self_collision: Option<f32>| {
            let cloth = ClothBuilder::new(16, 16).size(1.0).self_collision(self_collision).build().unwrap();
            let model = Model::single(&cloth, std::slice::from_ref(&wire), SimSettings::default()).unwrap();
            let (_, controls) = crate::program::SolverProgram::with_controls(&model).unwrap();
            controls.colliders[0].params.cover_reach
        };
        assert_eq!(reach(Some(0.005)), crate::collider_cover::COVER_SHARE * 0.005);
        assert_eq!(reach(None), 0.0);
    }

    /// The first frame builds the tree (the constructor's plan already says so: no replan),
    /// the next `SELF_TREE_REBUILD_FRAMES - 1` refit it, then it is built again; the plan
    /// changes (a replan) exactly where build and refit alternate.
    #[test]
    fn the_self_tree_is_built_every_few_frames_and_refit_between() {
        let mut schedule = SelfTreeSchedule::new();
        assert!(schedule.rebuild, "the first frame's plan builds");
        let mut builds = Vec::new();
        let mut replans = Vec::new();
        for frame in 0..3 * SELF_TREE_REBUILD_FRAMES {
            if schedule.next_frame() {
                replans.push(frame);
            }
            if schedule.rebuild {
                builds.push(frame);
            }
        }
        let n = SELF_TREE_REBUILD_FRAMES;
        assert_eq!(builds, vec![0, n, 2 * n]);
        assert_eq!(replans, vec![1, n, n + 1, 2 * n, 2 * n + 1]);
    }
}
