//! One frame of a cloth: per substep the integration stages (and the contact, if any), then the
//! vertex normals and the blow-up check.

use super::contact::{
    CONTACT_LABEL, ColliderBuffers, ContactBuffers, Crowded, EULER_UPDATE_CONTACT_LABEL, RK4_UPDATE_CONTACT_LABEL,
};
use super::self_contact::{
    FeatureWalks, SelfContactBuffers, SelfContactCloth, pass_due, reach_filter_pays, window_ends,
};
use super::tiles::TileBuffers;
use crate::cloth::{Cloth, ClothTopology};
use crate::graph::{BufferId, Dispatch, Handle, Kernel, Resources, Step};
use crate::kernels::integrate::{
    INTEGRATE_STAGE, INTEGRATE_STAGE_SPRINGS, INTEGRATE_SUBSTEPS, INTEGRATE_SUBSTEPS_SPRINGS,
};
use crate::kernels::normals::{CHECK_HEALTH, CHECK_HEALTH_SPRINGS, MESH_NORMALS_AND_HEALTH, NORMALS_AND_HEALTH};
use drape_types::{Health, ParticleSprings, SimParams, Spring, StagePush, SubstepsPush, integrator};
use glam::Vec4;

/// The spring list of a cloth that is not a grid (`SpringTopology`).
pub struct SpringBuffers {
    pub particles: Handle<ParticleSprings>,
    pub springs: Handle<Spring>,
    pub vertex_triangle_offsets: Handle<u32>,
    pub vertex_triangles: Handle<u32>,
}

/// The buffers of one cloth.
pub struct ClothBuffers {
    pub particles: u32,
    pub params: Handle<SimParams>,
    /// State: positions (w = pin weight) and velocities.
    pub x: Handle<Vec4>,
    pub v: Handle<Vec4>,
    /// Ping-pong intermediate states of the Runge-Kutta stages.
    pub xa: Handle<Vec4>,
    pub va: Handle<Vec4>,
    pub xb: Handle<Vec4>,
    pub vb: Handle<Vec4>,
    /// Weighted sums of the stage derivatives.
    pub acc_x: Handle<Vec4>,
    pub acc_v: Handle<Vec4>,
    /// Positions at the start of the substep.
    pub x_prev: Handle<Vec4>,
    pub normals: Handle<Vec4>,
    /// Triangle list of the cloth (3 u32 per triangle), for renderers.
    pub indices: Handle<u32>,
    /// Blow-up detector, read by the host after every frame.
    pub health: Handle<Health>,
    /// The spring list (`None`: a grid, whose kernels derive its springs).
    pub springs: Option<SpringBuffers>,
    /// Self-collision (`None`: off, nothing declared or run).
    pub self_contact: Option<SelfContactBuffers>,
    /// Tile sleeping (`None`: off, nothing declared or run).
    pub tiles: Option<TileBuffers>,
}

impl ClothBuffers {
    pub fn declare(resources: &mut Resources, name: &str, cloth: &Cloth) -> Self {
        let particles = cloth.params.particle_count;
        let triangles = cloth.triangles.len() as u32;
        let springs = match &cloth.topology {
            ClothTopology::Grid => None,
            ClothTopology::Springs(s) => Some(SpringBuffers {
                particles: resources.device(format!("{name}: particle springs"), particles),
                springs: resources.device(format!("{name}: springs"), s.springs.len().max(1) as u32),
                vertex_triangle_offsets: resources.device(format!("{name}: vertex triangle offsets"), particles + 1),
                vertex_triangles: resources
                    .device(format!("{name}: vertex triangles"), s.vertex_triangles.len().max(1) as u32),
            }),
        };
        let mut vec4s = |what: &str| resources.device::<Vec4>(format!("{name}: {what}"), particles);
        let (x, v, xa, va, xb, vb) =
            (vec4s("x"), vec4s("v"), vec4s("x stage a"), vec4s("v stage a"), vec4s("x stage b"), vec4s("v stage b"));
        let (acc_x, acc_v, x_prev, normals) = (vec4s("acc x"), vec4s("acc v"), vec4s("x prev"), vec4s("normals"));
        ClothBuffers {
            particles,
            params: resources.device(format!("{name}: params"), 1),
            x,
            v,
            xa,
            va,
            xb,
            vb,
            acc_x,
            acc_v,
            x_prev,
            normals,
            indices: resources.device(format!("{name}: triangle indices"), 3 * triangles),
            health: resources.readback(format!("{name}: health")),
            springs,
            self_contact: cloth
                .self_collision
                .map(|_| SelfContactBuffers::declare(resources, name, particles, triangles)),
            tiles: None,
        }
    }

    /// What the self-collision passes bind of this cloth.
    pub fn self_contact_cloth(&self) -> SelfContactCloth {
        SelfContactCloth { params: self.params, x: self.x, v: self.v, indices: self.indices, health: self.health }
    }

    /// What every integration stage binds first (`kernels::integrate`): the state, the stage's
    /// `input` and `output`, the sums and the substep's start.
    pub fn stage_bindings(
        &self,
        input: (Handle<Vec4>, Handle<Vec4>),
        output: (Handle<Vec4>, Handle<Vec4>),
    ) -> Vec<BufferId> {
        vec![
            self.params.id(),
            self.x.id(),
            self.v.id(),
            input.0.id(),
            input.1.id(),
            output.0.id(),
            output.1.id(),
            self.acc_x.id(),
            self.acc_v.id(),
            self.x_prev.id(),
        ]
    }

    /// What a spring-list cloth's kernels bind last: its particles' spring ranges and the
    /// springs (`None` for a grid).
    pub fn spring_bindings(&self) -> Option<[BufferId; 2]> {
        self.springs.as_ref().map(|list| [list.particles.id(), list.springs.id()])
    }

    fn stage(
        &self,
        label: &'static str,
        stage: u32,
        input: (Handle<Vec4>, Handle<Vec4>),
        output: (Handle<Vec4>, Handle<Vec4>),
    ) -> Step {
        let push = StagePush { stage, _pad: [0; 3] };
        let kernel: &'static Kernel = if self.springs.is_some() { &INTEGRATE_STAGE_SPRINGS } else { &INTEGRATE_STAGE };
        let mut bindings = self.stage_bindings(input, output);
        bindings.extend(self.spring_bindings().into_iter().flatten());
        Step::run_with(label, kernel, bindings, bytemuck::cast(push), Dispatch::Threads(self.particles))
    }

    /// The frame's `substeps` substeps in one workgroup (`drape_kernels::substeps`): the stages'
    /// math and buffers, a workgroup barrier between stages instead of a dispatch.
    fn substeps_in_one_workgroup(&self, substeps: u32) -> Step {
        let push = SubstepsPush { substeps, _pad: [0; 3] };
        let kernel: &'static Kernel =
            if self.springs.is_some() { &INTEGRATE_SUBSTEPS_SPRINGS } else { &INTEGRATE_SUBSTEPS };
        // The stage bindings with A as input and B as output: the kernel's A and B pairs.
        let mut bindings = self.stage_bindings((self.xa, self.va), (self.xb, self.vb));
        bindings.extend(self.spring_bindings().into_iter().flatten());
        Step::run_with(SUBSTEPS_LABEL, kernel, bindings, bytemuck::cast(push), Dispatch::Workgroups(1))
    }

    /// The frame's last pass: the blow-up check, with the vertex normals in the same dispatch
    /// when `normals` (both read the final state; neither reads what the other writes).
    fn frame_end(&self, normals: bool) -> Step {
        let threads = Dispatch::Threads(self.particles);
        let state = [self.params.id(), self.x.id(), self.v.id(), self.x_prev.id()];
        let mut bindings = state.to_vec();
        let kernel: &'static Kernel = match (&self.springs, normals) {
            (None, false) => &CHECK_HEALTH,
            (None, true) => {
                bindings.push(self.normals.id());
                &NORMALS_AND_HEALTH
            }
            (Some(list), false) => {
                bindings.extend([list.particles.id(), list.springs.id()]);
                &CHECK_HEALTH_SPRINGS
            }
            (Some(list), true) => {
                bindings.extend([
                    list.particles.id(),
                    list.springs.id(),
                    list.vertex_triangle_offsets.id(),
                    list.vertex_triangles.id(),
                    self.indices.id(),
                    self.normals.id(),
                ]);
                &MESH_NORMALS_AND_HEALTH
            }
        };
        bindings.push(self.health.id());
        Step::run(if normals { NORMALS_AND_HEALTH_LABEL } else { "health check" }, kernel, bindings, threads)
    }
}

/// What a cloth frame does.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct FramePlan {
    pub substeps: u32,
    /// `integrator::RK4` or `integrator::SEMI_IMPLICIT_EULER`.
    pub integrator: u32,
    pub normals: bool,
    /// The cloth sleeps: its frame runs nothing (`motion`).
    pub asleep: bool,
    /// Self-collision passes in the frame (1..=substeps; `self_contact::pass_due` spreads
    /// them): at least as many as the cloth's motion needs (`motion`, `self_contact::passes_for`),
    /// not one per substep.
    pub self_passes: u32,
    /// Self-collision tests the frame's pair lists (`self_contact::lists_pay`), or walks the
    /// tree for every triangle at every pass.
    pub self_lists: bool,
    /// The frame's self-collision lists are built this many times: at its start and again
    /// after the pass that ends each window (`self_contact::window_ends`), each predicting over
    /// its window (1: the whole frame).
    pub self_windows: u32,
    /// The frame builds the self-collision tree anew (else it refits the last one:
    /// `self_contact::SELF_TREE_REBUILD_FRAMES`).
    pub self_rebuild: bool,
    /// Self-collision ends the frame with its fail-safe (`self_failsafe`).
    pub self_failsafe: bool,
    /// What the narrow phase over candidate lists does with its crowded particles (many leaves
    /// to test, or a walk of the tree): hands them to a pass that runs a workgroup per particle
    /// (`drape_kernels::crowded`; `SimSettings::crowded_contact`), or counts them, or nothing.
    /// The same contacts.
    pub crowded: Crowded,
    /// The frame's substeps may run in one workgroup, one dispatch for them all, when nothing
    /// else runs between their stages (no collider, no self-collision): `drape_kernels::substeps`,
    /// `SimSettings::one_workgroup_substeps`. The same frame.
    pub one_workgroup: bool,
    /// Which side walks the self-collision passes' collider features
    /// (`SimSettings::feature_walks`). The same frame.
    pub feature_walks: FeatureWalks,
}

/// The timing table's line of a frame's substeps run in one workgroup.
pub const SUBSTEPS_LABEL: &str = "substeps in one workgroup";

/// The timing table's line of the frame's last pass with vertex normals on.
pub const NORMALS_AND_HEALTH_LABEL: &str = "normals + health check";

/// The timing table's line for a sleeping cloth's frame.
pub const ASLEEP_LABEL: &str = "cloth asleep (all passes)";

/// The steps of one frame of `cloth`, colliding with each of `colliders` (with the contact
/// buffers of that pair) after every substep.
pub fn frame_steps(
    plan: FramePlan,
    cloth: &ClothBuffers,
    colliders: &[(&ColliderBuffers, &ContactBuffers)],
) -> Vec<Step> {
    if plan.asleep {
        return vec![Step::Skip { label: ASLEEP_LABEL }];
    }
    let a = (cloth.xa, cloth.va);
    let b = (cloth.xb, cloth.vb);
    let mut steps = vec![Step::fill(cloth.health, 0)];
    // Which tiles sleep, before anything reads the velocities' flags.
    if let Some(tiles) = &cloth.tiles {
        steps.push(tiles.decide_step(cloth.v, cloth.health));
    }
    for (collider, contact) in colliders {
        steps.push(Step::fill(contact.status, 0));
        contact.frame_start_steps(cloth, collider, plan.substeps, &mut steps);
    }
    // The substeps whose passes end the self-collision lists' windows (the last: the frame's).
    let window_ends = window_ends(plan.substeps, plan.self_passes, if plan.self_lists { plan.self_windows } else { 1 });
    let mut window = (0, window_ends.first().map_or(plan.substeps, |end| end + 1));
    // Whether each span of the lists marks the colliders' listed triangles out of the cloth's
    // reach (never when every cloth triangle walks for every listed one).
    let passes = plan.self_passes.clamp(1, plan.substeps.max(1));
    let reach = reach_filter_pays(plan.self_lists, passes, window_ends.len() as u32)
        && plan.feature_walks != FeatureWalks::FromCloth;
    if let Some(s) = &cloth.self_contact {
        let tree = (plan.self_lists, plan.self_rebuild);
        s.frame_start_steps(&cloth.self_contact_cloth(), (window.1, plan.substeps), tree, &mut steps);
        for (index, (collider, _)) in colliders.iter().enumerate() {
            s.sharp_feature_steps((collider, index), (plan.feature_walks, cloth.health, reach), &mut steps);
        }
    }
    // The substep after the last self-collision pass: where the next pass's sweep begins.
    let mut pass_from = 0;
    // Nothing runs between the stages: one dispatch for the frame's substeps.
    let one_workgroup = plan.one_workgroup && colliders.is_empty() && cloth.self_contact.is_none();
    if one_workgroup {
        steps.push(cloth.substeps_in_one_workgroup(plan.substeps));
    }
    let stagewise_substeps = if one_workgroup { 0 } else { plan.substeps };
    // The first collider's narrow phase runs inside the last stage when it can (one pass
    // instead of the stage, a culling pass and a detect pass); the others after it.
    let fused = colliders.first().filter(|(_, contact)| contact.fuses_with_update());
    let separate = &colliders[usize::from(fused.is_some())..];
    for substep in 0..stagewise_substeps {
        // The crowded pass's queue emptied before the stages (its write waits on the last
        // substep's crowded pass with the stages' own barrier).
        if let Some((_, contact)) = fused {
            steps.extend(contact.crowded_reset_step(plan.crowded));
        }
        // Stage s reads the previous stage's output: A and B swap roles each stage.
        let (last, (input, output), fused_label) = if plan.integrator == integrator::SEMI_IMPLICIT_EULER {
            steps.push(cloth.stage("euler: evaluate", 0, b, a));
            ("euler: commit", (b, a), EULER_UPDATE_CONTACT_LABEL)
        } else {
            steps.push(cloth.stage("rk4: k1", 0, b, a));
            steps.push(cloth.stage("rk4: k2", 1, a, b));
            steps.push(cloth.stage("rk4: k3", 2, b, a));
            ("rk4: k4 + update", (a, b), RK4_UPDATE_CONTACT_LABEL)
        };
        let at = (substep, plan.substeps, plan.crowded);
        let update_contact = fused.and_then(|(collider, contact)| {
            let stage = cloth.stage_bindings(input, output);
            contact.update_contact_step(fused_label, cloth, stage, collider, at)
        });
        steps.push(update_contact.unwrap_or_else(|| cloth.stage(last, 3, input, output)));
        if let Some((collider, contact)) = fused {
            steps.extend(contact.crowded_step(cloth, collider, at));
        }
        for (collider, contact) in separate {
            contact.substep_steps(cloth, collider, at, &mut steps);
        }
        if let Some(s) = &cloth.self_contact
            && pass_due(substep, plan.substeps, plan.self_passes)
        {
            let own = cloth.self_contact_cloth();
            let span = (pass_from, substep, plan.substeps);
            let features = colliders
                .iter()
                .enumerate()
                .flat_map(|(index, (collider, _))| s.collider_feature_steps(&own, (collider, index), (span, reach)))
                .collect();
            s.windowed_substep_steps(&own, (span, window, plan.self_lists), features, &mut steps);
            pass_from = substep + 1;
            // A window ends here and another follows: its lists, from where the cloth is now.
            if window_ends.contains(&substep) && substep + 1 < plan.substeps {
                let next_end = window_ends.iter().find(|&&end| end > substep).map_or(plan.substeps, |end| end + 1);
                window = (substep + 1, next_end - (substep + 1));
                s.window_start_steps(&own, (window.1, plan.substeps), &mut steps);
                // The listed collider triangles out of the cloth's reach over the new window.
                for (index, (collider, _)) in colliders.iter().enumerate().filter(|_| reach) {
                    steps.extend(s.out_of_reach_steps((collider, index), cloth.health));
                }
            }
        }
    }
    // A skipped pass is listed once, not once per substep.
    if colliders.is_empty() {
        steps.push(Step::Skip { label: CONTACT_LABEL });
    }
    if let Some(s) = cloth.self_contact.as_ref().filter(|_| plan.self_failsafe) {
        let collider_buffers: Vec<_> = colliders.iter().map(|(collider, _)| *collider).collect();
        let frame = ((plan.self_lists, window_ends.len() > 1), plan.substeps);
        s.failsafe.frame_end_steps((s, &cloth.self_contact_cloth()), frame, &collider_buffers, &mut steps);
    }
    if !plan.normals {
        steps.push(Step::Skip { label: "normals" });
    }
    steps.push(cloth.frame_end(plan.normals));
    if let Some(tiles) = &cloth.tiles {
        steps.push(tiles.measure_step(cloth.x));
    }
    steps
}
