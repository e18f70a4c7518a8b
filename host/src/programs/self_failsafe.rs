//! Self-collision's fail-safe as a sub-graph over handles (`drape_kernels::self_failsafe`): at
//! the frame's end, the self-collision tree refit to each triangle's box over the frame, every
//! pair of triangles tested for intersection at the end (and each triangle collider's sharp
//! triangles against the cloth's), and the particles of the pairs that cross there (and did not
//! at the start) put back where the frame found them (with the collider that carries them, for
//! those near a collider that moved: each collider's carriers pass, before the first round);
//! the rounds after the first run only when the one before put a particle back (indirect
//! dispatches the roll-back writes).

use super::contact::{ColliderBuffers, ColliderLeaves};
use super::empty_dispatch;
use super::self_contact::{SelfContactBuffers, SelfContactCloth};
use crate::graph::{Dispatch, Handle, Resources, Step};
use crate::kernels::self_failsafe::{
    FAILSAFE_BOXES, FAILSAFE_BOXES_AND_REFIT, FAILSAFE_CHECK, FAILSAFE_COLLIDER_CHECK, FAILSAFE_ROLL_BACK,
    WIDEN_FAILSAFE_TREE,
};
use crate::kernels::self_pass_tree::DERIVE_PASS_TREE;
use drape_kernels::WORKGROUP_SIZE;
use drape_kernels::self_failsafe::CARRIER_FRAME_WORDS;
use drape_kernels::self_failsafe::{
    CHECK_THREADS, FAILSAFE_COUNTER_WORDS, LAST_ROUND, LIST_CHECK_BEYOND, ROLLBACK_ROUNDS, SUBSTEPS_SHIFT, WINDOWED,
    WITH_LISTS,
};
use drape_types::{CarrierPush, DispatchArgs, FailsafePush, SelfPassPush};
use glam::Vec4;

/// The timing table's line of the fail-safe's refits of the tree (every round's).
pub const FAILSAFE_REFIT_LABEL: &str = "self: fail-safe refit";
/// The timing table's line of the fail-safe's check (every round's).
pub const FAILSAFE_CHECK_LABEL: &str = "self: fail-safe check";
/// The timing table's line of the fail-safe's check of the colliders' sharp triangles (every
/// round's).
pub const FAILSAFE_COLLIDER_CHECK_LABEL: &str = "self: fail-safe collider check";
/// The timing table's line of the fail-safe's roll-back (every round's).
pub const FAILSAFE_ROLL_BACK_LABEL: &str = "self: fail-safe roll-back";
/// The timing table's line of the fail-safe's carriers passes (every collider's).
pub const FAILSAFE_CARRIERS_LABEL: &str = "self: fail-safe carriers";

/// The buffers of one cloth's fail-safe.
pub struct FailsafeBuffers {
    /// Per particle: `GO_BACK` when a pair found in the round puts it back, `CARRIED` when a
    /// moving collider's triangle found carries it.
    pub flags: Handle<u32>,
    /// Per particle: the fixed-point sum of its carries and their count (4 words;
    /// `drape_kernels::self_failsafe::surface_motion`), cleared as the roll-back
    /// reads them.
    pub carried: Handle<u32>,
    /// Per particle: which collider that moved carries it this frame, if any
    /// (`drape_kernels::self_failsafe::triangle_carrier_at`).
    pub carriers: Handle<u32>,
    /// Per particle with a carrier: the frames its carrier's surface carries it by
    /// (`CARRIER_FRAME_WORDS`), written with its carrier.
    pub carrier_frames: Handle<Vec4>,
    /// The particle whose carrier carries the whole cloth when the last round puts it all back
    /// (`drape_kernels::self_failsafe::CarrierOut::choice`; 0 for none).
    pub carrier_choice: Handle<u32>,
    /// Per round: the pairs found and the particles put back (`FAILSAFE_COUNTER_WORDS`).
    pub counters: Handle<u32>,
    /// The check's and the roll-back's dispatches of rounds 1, 2, ... (the roll-back of the round
    /// before writes them); the last pair is the last round's spare (it dispatches nothing).
    pub rounds: Vec<(Handle<DispatchArgs>, Handle<DispatchArgs>)>,
    /// The first round's refit of the tree, with the frame's lists: raised by the boxes where a
    /// triangle walks in the check (`drape_kernels::self_failsafe::failsafe_box_at`), else none.
    pub refit: Handle<DispatchArgs>,
}

impl FailsafeBuffers {
    pub fn declare(resources: &mut Resources, name: &str, particles: u32) -> Self {
        let rounds = (1..=ROLLBACK_ROUNDS)
            .map(|r| {
                (
                    resources.device(format!("{name}: fail-safe round {r} check dispatch"), 1),
                    resources.device(format!("{name}: fail-safe round {r} roll-back dispatch"), 1),
                )
            })
            .collect();
        FailsafeBuffers {
            flags: resources.device(format!("{name}: fail-safe flags"), particles),
            carried: resources.device(format!("{name}: fail-safe carries"), 4 * particles),
            carriers: resources.device(format!("{name}: fail-safe carriers"), particles),
            carrier_frames: resources
                .device(format!("{name}: fail-safe carrier frames"), CARRIER_FRAME_WORDS * particles),
            carrier_choice: resources.device(format!("{name}: fail-safe carrier choice"), 1),
            counters: resources.device(format!("{name}: fail-safe counters"), FAILSAFE_COUNTER_WORDS),
            rounds,
            refit: resources.device(format!("{name}: fail-safe refit dispatch"), 1),
        }
    }

    /// The frame's fail-safe, after its last self-collision pass and before anything reads the
    /// frame's end; `lists`: the frame built pair lists (the check takes them), `windowed`: more
    /// than once (`drape_kernels::self_failsafe::WINDOWED`); `substeps`: the frame's;
    /// `colliders`: the model's, in its order (each may carry particles, and each triangle
    /// collider's sharp triangles are checked too).
    pub fn frame_end_steps(
        &self,
        (own, cloth): (&SelfContactBuffers, &SelfContactCloth),
        ((lists, windowed), substeps): ((bool, bool), u32),
        colliders: &[&ColliderBuffers],
        steps: &mut Vec<Step>,
    ) {
        let t = &own.tree;
        steps.push(Step::fill(self.flags, 0));
        steps.push(Step::fill(self.carried, 0));
        steps.push(Step::fill(self.counters, 0));
        steps.push(Step::fill(self.carriers, 0));
        steps.push(Step::fill(self.carrier_choice, 0));
        for &(check, roll_back) in &self.rounds {
            steps.push(empty_dispatch(check));
            steps.push(empty_dispatch(roll_back));
        }
        steps.push(empty_dispatch(self.refit));
        for (slot, collider) in colliders.iter().enumerate() {
            steps.push(self.carriers_step((own, cloth), collider, slot as u32));
        }
        let boxes_push = FailsafePush { flags: if windowed { WINDOWED } else { 0 }, ..Default::default() };
        // Both boxes kernels bind the frame's triangles, then what the boxes write.
        let frame = [t.collider.id(), own.sorted.id(), cloth.x.id(), own.anchors.id(), cloth.indices.id()];
        let written = [t.sorted_bounds.id(), own.escaped.id(), own.strays.id()];
        let walks = [own.tree_every_pass.id(), self.refit.id()];
        let bindings = [&frame[..], &written, &[t.refit_flags()], &walks].concat();
        let boxes = Step::run_with(
            "self: fail-safe boxes",
            &FAILSAFE_BOXES,
            bindings,
            bytemuck::cast(boxes_push),
            Dispatch::Threads(t.leaves),
        );
        steps.push(boxes);
        if lists && !windowed {
            // Only where a triangle walks in the check (`LIST_CHECK_BEYOND`), or the colliders'
            // check walks the tree: the lists' tree over the frame bounds every triangle that
            // does not walk, and only those that do climb.
            self.derived_tree_steps(own, steps);
        } else {
            // A windowed frame's last lists do not start where the frame did.
            let refit = if lists { Dispatch::Indirect(self.refit) } else { Dispatch::Threads(t.leaves) };
            steps.extend(t.refit_other_steps_over(FAILSAFE_REFIT_LABEL, (t.sorted_bounds, t.aabbs), refit));
        }
        let particles = own.particles();
        for round in 0..ROLLBACK_ROUNDS {
            let last = if round + 1 == ROLLBACK_ROUNDS { LAST_ROUND } else { 0 };
            let push = FailsafePush {
                round,
                flags: last | if lists { WITH_LISTS } else { 0 } | substeps << SUBSTEPS_SHIFT,
                check_groups: t.leaves.div_ceil(CHECK_THREADS),
                rollback_groups: particles.div_ceil(WORKGROUP_SIZE),
            };
            let (check, roll_back) = if round == 0 {
                (Dispatch::Threads(t.leaves), Dispatch::Threads(particles))
            } else {
                // The particles put back moved: where their triangles ended against their
                // predicted regions, and their boxes, again, and the tree refit to them (one
                // carried back may lie outside its triangle's box of the round before), in one
                // dispatch (the check before cleared the refit's flags).
                let (check, roll_back) = self.rounds[round as usize - 1];
                let climb = [t.nodes.id(), t.parents.id(), t.refit_flags(), t.aabbs.id()];
                steps.push(Step::run_with(
                    FAILSAFE_REFIT_LABEL,
                    &FAILSAFE_BOXES_AND_REFIT,
                    [&frame[..], &written, &walks, &climb].concat(),
                    bytemuck::cast(boxes_push),
                    Dispatch::Indirect(check),
                ));
                (Dispatch::Indirect(check), Dispatch::Indirect(roll_back))
            };
            steps.push(Step::run_with(
                FAILSAFE_CHECK_LABEL,
                &FAILSAFE_CHECK,
                vec![
                    t.collider.id(),
                    t.nodes.id(),
                    t.aabbs.id(),
                    t.sorted_bounds.id(),
                    own.sorted.id(),
                    cloth.x.id(),
                    own.anchors.id(),
                    own.escaped.id(),
                    own.strays.id(),
                    own.lists.id(),
                    own.counts.id(),
                    self.carriers.id(),
                    self.carrier_frames.id(),
                    self.flags.id(),
                    self.counters.id(),
                    self.carried.id(),
                    t.refit_flags(),
                ],
                bytemuck::cast(push),
                check,
            ));
            for (index, collider) in colliders.iter().enumerate() {
                steps.extend(self.collider_check_step((own, cloth), (collider, index), push, check));
            }
            let (next_check, next_roll_back) = self.rounds[round as usize];
            steps.push(Step::run_with(
                FAILSAFE_ROLL_BACK_LABEL,
                &FAILSAFE_ROLL_BACK,
                vec![
                    cloth.params.id(),
                    cloth.x.id(),
                    cloth.v.id(),
                    own.anchors.id(),
                    self.carried.id(),
                    self.flags.id(),
                    self.counters.id(),
                    next_check.id(),
                    next_roll_back.id(),
                    cloth.health.id(),
                    self.carrier_frames.id(),
                    self.carrier_choice.id(),
                ],
                bytemuck::cast(push),
                roll_back,
            ));
        }
    }

    /// Both ways the first round refits the tree (`frame_end_steps`): derived from the lists'
    /// tree and widened by the walkers, or climbed from every leaf (a windowed frame, or one
    /// without lists). A frame of the other kind than the first records the other, whose
    /// kernels and bindings must be bound from the start.
    pub fn first_refit_steps_either_way(&self, own: &SelfContactBuffers) -> Vec<Step> {
        let t = &own.tree;
        let mut steps = Vec::new();
        self.derived_tree_steps(own, &mut steps);
        let climbed = (t.sorted_bounds, t.aabbs);
        steps.extend(t.refit_other_steps_over(FAILSAFE_REFIT_LABEL, climbed, Dispatch::Indirect(self.refit)));
        steps
    }

    /// The first round's tree where the frame's lists span it (`drape_kernels::self_failsafe::
    /// widen_failsafe_tree_at`): each internal node's box derived from the lists' tree over the
    /// whole frame, past the slops by the check's reach (`LIST_CHECK_BEYOND`), then the climbs
    /// of the triangles that walk; both over the refit's dispatch.
    fn derived_tree_steps(&self, own: &SelfContactBuffers, steps: &mut Vec<Step>) {
        let t = &own.tree;
        let frame = SelfPassPush { from: 0.0, to: 1.0, find_walkers: 0, beyond: LIST_CHECK_BEYOND };
        steps.push(Step::run_with(
            FAILSAFE_REFIT_LABEL,
            &DERIVE_PASS_TREE,
            vec![t.collider.id(), own.span_aabbs.id(), own.motion_aabbs.id(), own.anchors.id(), t.aabbs.id()],
            bytemuck::cast(frame),
            Dispatch::Indirect(self.refit),
        ));
        steps.push(Step::run(
            FAILSAFE_REFIT_LABEL,
            &WIDEN_FAILSAFE_TREE,
            vec![
                t.collider.id(),
                own.sorted.id(),
                own.escaped.id(),
                t.parents.id(),
                t.sorted_bounds.id(),
                t.aabbs.id(),
            ],
            Dispatch::Indirect(self.refit),
        ));
    }

    /// Which particles collider `collider` (the model's `slot`-th) carries this frame, when it
    /// moved (`drape_kernels::self_failsafe::triangle_carrier_at`, `sphere_carrier_at`).
    fn carriers_step(
        &self,
        (own, cloth): (&SelfContactBuffers, &SelfContactCloth),
        collider: &ColliderBuffers,
        slot: u32,
    ) -> Step {
        let (leaves, tree) = (collider.leaves.kind(), collider.tree());
        let push = CarrierPush { slot, _pad: [0; 3] };
        let (kernel, leaf_bindings) = leaves.failsafe_carriers();
        let mut bindings =
            vec![cloth.params.id(), tree.collider.id(), collider.pose.id(), tree.nodes.id(), tree.aabbs.id()];
        bindings.extend(leaf_bindings);
        bindings.extend([own.anchors.id(), self.carriers.id(), self.carrier_frames.id(), self.carrier_choice.id()]);
        Step::run_with(
            FAILSAFE_CARRIERS_LABEL,
            kernel,
            bindings,
            bytemuck::cast(push),
            Dispatch::Threads(own.particles()),
        )
    }

    /// A round's check of triangle collider `collider` (the model's `index`-th): its triangles
    /// listed as possibly sharp this frame against the cloth's at the frame's end, dispatched as
    /// the round's own check (`drape_kernels::self_failsafe::failsafe_collider_check`); `None`
    /// for a sphere collider, whose spheres are smooth.
    fn collider_check_step(
        &self,
        (own, cloth): (&SelfContactBuffers, &SelfContactCloth),
        (collider, index): (&ColliderBuffers, usize),
        push: FailsafePush,
        dispatch: Dispatch,
    ) -> Option<Step> {
        let (ColliderLeaves::Triangles(mesh), Some(Some(sharp))) = (&collider.leaves, own.sharp.get(index)) else {
            return None;
        };
        let t = &own.tree;
        Some(Step::run_with(
            FAILSAFE_COLLIDER_CHECK_LABEL,
            &FAILSAFE_COLLIDER_CHECK,
            vec![
                t.collider.id(),
                collider.pose.id(),
                mesh.vertices.id(),
                mesh.previous.id(),
                mesh.indices.id(),
                sharp.list.id(),
                sharp.args.id(),
                t.nodes.id(),
                t.aabbs.id(),
                t.sorted_bounds.id(),
                own.sorted.id(),
                cloth.x.id(),
                own.anchors.id(),
                self.flags.id(),
                self.counters.id(),
                self.carried.id(),
                cloth.health.id(),
            ],
            bytemuck::cast(push),
            dispatch,
        ))
    }
}
