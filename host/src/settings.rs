//! How a model runs: frame length, substeps, integrator, normals, blow-up limit, timing.

use crate::cloth::Cloth;
use crate::error::{Error, Result};
use crate::motion::Sleep;
use crate::programs::cloth::FramePlan;
use crate::programs::contact::Crowded;
use crate::programs::self_contact::FeatureWalks;
use crate::stability::{self, BoundInputs, DEFAULT_SAFETY, Stability};
use drape_types::{Health, SimParams, integrator};

/// The most particles whose frame the automatic `SimSettings::one_workgroup_substeps` runs in
/// one workgroup on a GPU: one a lane. Measured on an H200 (the swinging cloth, GPU span a
/// frame, stagewise -> one workgroup): 16^2 154 -> 78 µs, 32^2 265 -> 217, but 48^2 390 -> 728
/// and 64^2 535 -> 1574 (one multiprocessor's arithmetic outgrows the dispatches it spares).
pub const ONE_WORKGROUP_PARTICLES: u32 = 32 * 32;

/// Time integration scheme.
#[non_exhaustive]
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Integrator {
    /// Classical RK4 (4th order; 4 dispatches per substep).
    Rk4,
    /// Semi-implicit Euler, the paper's eq. 3 (1st order; 2 dispatches per substep).
    SemiImplicitEuler,
}

impl Integrator {
    pub(crate) fn id(self) -> u32 {
        match self {
            Integrator::Rk4 => integrator::RK4,
            Integrator::SemiImplicitEuler => integrator::SEMI_IMPLICIT_EULER,
        }
    }
}

/// How a simulation runs. Start from `SimSettings::default()` and change fields with the
/// `with_*` methods (more fields will come).
#[derive(Copy, Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct SimSettings {
    /// Simulated time per frame (s).
    pub frame_dt: f32,
    /// Substeps per frame; `None` = automatic from the stability bound.
    pub substeps: Option<u32>,
    /// Fraction of the stability bound that automatic substeps use.
    pub safety: f32,
    pub integrator: Integrator,
    /// Compute vertex normals every frame.
    pub normals: bool,
    /// A structural spring longer than this many rest lengths counts as a blow-up.
    pub max_stretch: f32,
    /// Time every pass with GPU timestamp queries (costs ~tens of µs per pass on lavapipe).
    pub timestamps: bool,
    /// Automatic substeps are also enough that no particle moves more than the contact
    /// thickness per substep (`motion`), and self-collision runs as many passes per frame as
    /// that needs (off: one per substep); no effect on a cloth without contact.
    pub contact_substeps: bool,
    /// When a still cloth stops running (`None`: never).
    pub sleep: Option<Sleep>,
    /// Parts of a cloth sleep on their own under `sleep`'s policy (tiles of
    /// `drape_kernels::tiles::TILE_PARTICLES` particles), while the rest of it moves.
    pub tile_sleep: bool,
    /// Self-collision ends each frame by checking the cloth for triangles that intersect (and did
    /// not at the frame's start), and puts their particles back where the frame started
    /// (`drape_kernels::self_failsafe`); no effect on a cloth without self-collision.
    pub self_failsafe: bool,
    /// A fast self-colliding cloth's pair lists are built again halfway through a frame
    /// (`motion::ClothMotion::list_windows`): the same pairs, fewer of its triangles walking the
    /// tree; off, once per frame.
    pub self_list_windows: bool,
    /// The narrow phase over candidate lists hands its crowded particles (a walk of the tree, or
    /// a list of `drape_kernels::crowded::CROWDED_LIST` leaves or more) to a pass that runs a
    /// workgroup per particle, its lanes sharing the tests (`drape_kernels::crowded`): the same
    /// contacts, bit for bit. `None` (automatic): counted every frame, and on a GPU handed over
    /// while a frame has many (`controls::CROWDED_ON` a substep; a dense collider such as the
    /// bunny), not while it has few (`CROWDED_OFF`; the pass and its barrier cost more than
    /// they save); never on a CPU driver (lavapipe), where a workgroup's lanes run one after
    /// another.
    pub crowded_contact: Option<bool>,
    /// A frame whose substeps run nothing between their stages (no collider, no
    /// self-collision) runs them in one workgroup, one dispatch for the frame
    /// (`drape_kernels::substeps`): the same frame, bit for bit on lavapipe. `None` (automatic):
    /// on a GPU for a cloth of at most `ONE_WORKGROUP_PARTICLES` particles, where a dispatch
    /// and its barrier cost more than a stage's arithmetic on one multiprocessor, if the GPU
    /// runs workgroups of `SUBSTEPS_THREADS` (on is an error where it does not); never on a
    /// CPU driver, where a workgroup's lanes run on one core (lavapipe, 64^2: 36 ms a frame
    /// against 19).
    pub one_workgroup_substeps: Option<bool>,
    /// Which side walks a self-collision pass's collider vertices and edges against the cloth:
    /// each listed sharp collider triangle walks the cloth's tree, or each cloth triangle walks
    /// the collider's (`drape_kernels::feature_walks`). The same frame, bit for bit. Automatic
    /// (the default): the cloth's side when the collider lists more sharp triangles than
    /// `drape_kernels::feature_walks::CLOTH_SIDE_RATIO` per cloth triangle (a scanned collider),
    /// frame by frame.
    pub feature_walks: FeatureWalks,
    /// The device is a GPU (`on_device`): the automatic `crowded_contact` may hand crowded
    /// particles over; on a CPU driver it only counts them.
    pub(crate) device_is_gpu: bool,
    /// The most invocations the device runs in one workgroup (along x, and in all): the
    /// automatic `one_workgroup_substeps` needs `SUBSTEPS_THREADS`.
    pub(crate) device_max_workgroup: u32,
}

impl Default for SimSettings {
    fn default() -> Self {
        SimSettings {
            frame_dt: 1.0 / 60.0,
            substeps: None,
            safety: DEFAULT_SAFETY,
            integrator: Integrator::Rk4,
            normals: true,
            max_stretch: 10.0,
            timestamps: true,
            contact_substeps: true,
            sleep: Some(Sleep::default()),
            tile_sleep: true,
            self_failsafe: true,
            self_list_windows: true,
            crowded_contact: None,
            one_workgroup_substeps: None,
            feature_walks: FeatureWalks::Automatic,
            device_is_gpu: true,
            device_max_workgroup: u32::MAX,
        }
    }
}

impl SimSettings {
    /// Simulated time per frame (s).
    pub fn with_frame_dt(mut self, frame_dt: f32) -> Self {
        self.frame_dt = frame_dt;
        self
    }
    /// Substeps per frame; `None` = automatic from the stability bound.
    pub fn with_substeps(mut self, substeps: Option<u32>) -> Self {
        self.substeps = substeps;
        self
    }
    /// Fraction of the stability bound that automatic substeps use, in (0, 1].
    pub fn with_safety(mut self, safety: f32) -> Self {
        self.safety = safety;
        self
    }
    pub fn with_integrator(mut self, integrator: Integrator) -> Self {
        self.integrator = integrator;
        self
    }
    /// Compute vertex normals every frame.
    pub fn with_normals(mut self, normals: bool) -> Self {
        self.normals = normals;
        self
    }
    /// The structural stretch (length / rest) that counts as a blow-up.
    pub fn with_max_stretch(mut self, max_stretch: f32) -> Self {
        self.max_stretch = max_stretch;
        self
    }
    /// Time every pass with GPU timestamp queries.
    pub fn with_timestamps(mut self, timestamps: bool) -> Self {
        self.timestamps = timestamps;
        self
    }
    /// Follow the motion: raise automatic substeps so no particle moves more than the contact
    /// thickness per substep, and run self-collision only as many passes per frame as that
    /// takes (off: a pass every substep, substeps from the stability bound alone).
    pub fn with_contact_substeps(mut self, on: bool) -> Self {
        self.contact_substeps = on;
        self
    }
    /// When a still cloth sleeps (`None`: never).
    pub fn with_sleep(mut self, sleep: Option<Sleep>) -> Self {
        self.sleep = sleep;
        self
    }
    /// Whether parts of a cloth (tiles) sleep on their own, under the `sleep` policy.
    pub fn with_tile_sleep(mut self, on: bool) -> Self {
        self.tile_sleep = on;
        self
    }
    /// Which side walks the self-collision passes' collider features (`feature_walks`).
    pub fn with_feature_walks(mut self, walks: FeatureWalks) -> Self {
        self.feature_walks = walks;
        self
    }
    /// Whether crowded particles' contact is shared by a workgroup each (`None`: automatic,
    /// see `crowded_contact`).
    pub fn with_crowded_contact(mut self, on: Option<bool>) -> Self {
        self.crowded_contact = on;
        self
    }
    /// Whether a frame's substeps run in one workgroup when nothing runs between their stages
    /// (`None`: automatic, see `one_workgroup_substeps`).
    pub fn with_one_workgroup_substeps(mut self, on: Option<bool>) -> Self {
        self.one_workgroup_substeps = on;
        self
    }
    /// Whether the device runs a workgroup as wide as the one-workgroup integrator's.
    fn one_workgroup_fits(&self) -> bool {
        self.device_max_workgroup >= drape_kernels::substeps::SUBSTEPS_THREADS
    }

    /// An error where `one_workgroup_substeps` is on and the device cannot run its workgroup.
    pub(crate) fn check_device(&self) -> Result<()> {
        if self.one_workgroup_substeps == Some(true) && !self.one_workgroup_fits() {
            return Err(Error::InvalidParameter {
                name: "one_workgroup_substeps",
                problem: format!(
                    "this device runs at most {} invocations in a workgroup and the one-workgroup integrator needs {}; \
                     leave it automatic (--one-workgroup-substeps auto) or turn it off",
                    self.device_max_workgroup,
                    drape_kernels::substeps::SUBSTEPS_THREADS
                ),
            });
        }
        Ok(())
    }

    /// Whether these settings run on a GPU (false: a CPU driver, or the CPU twin): where the
    /// automatic `crowded_contact` may hand crowded particles over.
    pub fn device_is_gpu(&self) -> bool {
        self.device_is_gpu
    }
    /// These settings on a device that `is_gpu` (or a CPU driver, where the automatic
    /// `crowded_contact` never hands crowded particles over).
    pub(crate) fn on_device(mut self, is_gpu: bool, max_workgroup: u32) -> Self {
        self.device_is_gpu = is_gpu;
        self.device_max_workgroup = max_workgroup;
        self
    }
    /// Whether self-collision's frames end with the check for crossed pairs (and put their
    /// particles back).
    pub fn with_self_failsafe(mut self, on: bool) -> Self {
        self.self_failsafe = on;
        self
    }
    /// Whether a fast self-colliding cloth's pair lists are built again within a frame.
    pub fn with_self_list_windows(mut self, on: bool) -> Self {
        self.self_list_windows = on;
        self
    }
    /// The sleep policy of a cloth's tiles (`None`: they do not sleep).
    pub(crate) fn tile_policy(&self) -> Option<Sleep> {
        self.sleep.filter(|_| self.tile_sleep)
    }

    /// The stability bound of `cloth` and the substeps these settings choose for it (what a
    /// solver of a model with this cloth will use), or why the settings do not fit it.
    pub fn stability(&self, cloth: &Cloth) -> Result<Stability> {
        Ok(self.resolve(cloth)?.1)
    }

    /// Checks the settings and chooses the substep for `cloth`; returns the params to upload
    /// and what later bounds of the cloth need.
    pub(crate) fn resolve(&self, cloth: &Cloth) -> Result<(SimParams, Stability, BoundInputs)> {
        let bad = |name: &'static str, problem: String| Err(Error::InvalidParameter { name, problem });
        let n = cloth.params.particle_count as usize;
        if cloth.positions.len() != n || cloth.velocities.len() != n {
            return bad("cloth", format!("state arrays must hold the cloth's {n} particles"));
        }
        let grid = cloth.params.rows as usize * cloth.params.cols as usize;
        if cloth.topology == crate::cloth::ClothTopology::Grid && grid != n {
            return bad("cloth", format!("a grid cloth needs rows x cols = {n} particles, has {grid}"));
        }
        if let crate::cloth::ClothTopology::Springs(s) = &cloth.topology
            && (s.particles.len() != n || s.vertex_triangle_offsets.len() != n + 1)
        {
            return bad("cloth", format!("the spring list must describe the cloth's {n} particles"));
        }
        if cloth.triangles.iter().flatten().any(|&i| i as usize >= n) {
            return bad("cloth", format!("a triangle refers to a particle beyond the cloth's {n}"));
        }
        if !cloth.positions.iter().chain(&cloth.velocities).all(|p| p.is_finite()) {
            return bad("cloth", "positions and velocities must be finite".into());
        }
        let inputs = BoundInputs::of(cloth);
        let (params, stability) = self.resolve_params(&cloth.params, &inputs)?;
        Ok((params, stability, inputs))
    }

    /// Checks the settings and chooses the substep for a cloth's `params`.
    pub(crate) fn resolve_params(&self, params: &SimParams, inputs: &BoundInputs) -> Result<(SimParams, Stability)> {
        let bad = |name: &'static str, problem: String| Err(Error::InvalidParameter { name, problem });
        if !(self.frame_dt.is_finite() && self.frame_dt > 0.0) {
            return bad("frame_dt", format!("must be finite and > 0, got {}", self.frame_dt));
        }
        if !(self.safety > 0.0 && self.safety <= 1.0) {
            return bad("safety", format!("must be in (0, 1], got {}", self.safety));
        }
        if self.substeps == Some(0) || self.substeps.is_some_and(|s| s > 100_000) {
            return bad("substeps", format!("must be in 1..=100000, got {:?}", self.substeps));
        }
        if self.max_stretch.is_nan() || self.max_stretch <= 1.0 {
            return bad("max_stretch", format!("must be > 1, got {}", self.max_stretch));
        }
        let stability =
            stability::choose_for(params, inputs, self.integrator.id(), self.frame_dt, self.substeps, self.safety);
        if stability.substeps > 100_000 {
            return bad(
                "stiffness/mass",
                format!(
                    "the stability bound {:.3e} s needs {} substeps per frame; lower the stiffness or raise the mass",
                    stability.max_substep, stability.substeps
                ),
            );
        }
        let mut params = *params;
        params.integrator = self.integrator.id();
        params.substep = stability.substep;
        Ok((params, stability))
    }

    /// The frame a cloth runs: `stability`'s substeps, and `motion_passes` self-collision passes
    /// (what its motion needs, `motion`; at least `MIN_SELF_PASSES`) when contact substeps are
    /// on, else (or for `None`: a cloth in contact with itself) one per substep.
    pub(crate) fn plan(
        &self,
        params: &SimParams,
        stability: &Stability,
        asleep: bool,
        motion_passes: Option<u32>,
    ) -> FramePlan {
        let substeps = stability.substeps;
        let self_passes = match motion_passes {
            Some(needed) if self.contact_substeps => {
                crate::programs::self_contact::passes_for(substeps, needed.max(crate::motion::MIN_SELF_PASSES))
            }
            _ => substeps,
        };
        FramePlan {
            substeps,
            integrator: params.integrator,
            normals: self.normals,
            asleep,
            self_passes,
            self_lists: false,
            self_windows: 1,
            self_rebuild: true,
            self_failsafe: self.self_failsafe,
            crowded: match self.crowded_contact {
                Some(true) => Crowded::HandedOver,
                Some(false) => Crowded::Ignored,
                None => Crowded::Counted,
            },
            feature_walks: self.feature_walks,
            one_workgroup: self.one_workgroup_substeps.unwrap_or(
                self.device_is_gpu && params.particle_count <= ONE_WORKGROUP_PARTICLES && self.one_workgroup_fits(),
            ),
        }
    }

    /// `base` (the stability bound's choice) raised to the substeps contact needs, when
    /// substeps are automatic and contact substeps are on.
    pub(crate) fn with_contact(&self, base: &Stability, contact_substeps: u32) -> Stability {
        if self.substeps.is_some() || !self.contact_substeps || contact_substeps <= base.substeps {
            return *base;
        }
        let substep = self.frame_dt / contact_substeps as f32;
        Stability { substeps: contact_substeps, substep, ratio: substep / base.max_substep, ..*base }
    }
}

/// Reads cloth `cloth`'s blow-up detector and turns a blow-up into an error naming its cause.
pub(crate) fn check_health(
    health: &Health,
    frame: u64,
    cloth: usize,
    settings: &SimSettings,
    (control, collider): (&crate::controls::ClothControl, Option<stability::diagnosis::ColliderMotion>),
) -> Result<()> {
    let stretch = f32::from_bits(health.max_stretch_bits);
    let detail = if health.non_finite > 0 {
        format!("{} particles have non-finite position or velocity", health.non_finite)
    } else if stretch.is_nan() || stretch > settings.max_stretch {
        format!("a spring stretched to {stretch:.1}x its rest length (limit {})", settings.max_stretch)
    } else {
        return Ok(());
    };
    let stability = &control.stability;
    let speed = control.motion.last_speed();
    let integrator = settings.integrator.id();
    let cloth_springs = (&control.params, control.structural_hold());
    let cause =
        stability::diagnosis::cause(cloth_springs, stability, integrator, (settings.max_stretch, speed), collider);
    Err(Error::Unstable {
        cloth,
        frame,
        detail,
        cause,
        substep: stability.substep,
        bound: stability.max_substep,
        suggested_substeps: stability.min_stable_substeps().max(stability.substeps * 2),
        automatic_substeps: settings.substeps.is_none(),
    })
}
