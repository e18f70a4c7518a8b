//! Cloth-vs-collider contact after each substep, for any leaf kind: a culling pass against the
//! collider's root box writes the indirect dispatch of the next passes (zero workgroups when
//! they cannot touch), the leaf kind's detect pass writes each particle's earliest contact, and
//! the respond pass applies them. With candidate lists (the default) detect and respond are one
//! pass over the lists, and for a cloth's first collider that pass runs inside the integrator's
//! last stage, with no culling pass (`update_contact_step`). The brute-force mode detects by
//! testing every leaf instead.

use super::cloth::ClothBuffers;
use super::lbvh::LbvhBuffers;
use super::spheres::SphereBvh;
use super::triangles::TriangleBvh;
use crate::graph::{BufferId, Dispatch, Handle, Kernel, Resources, Step};
use crate::kernels::contact::{CULL_CONTACT, RESPOND_CONTACTS};
use drape_kernels::crowded::CROWDED_LIST;
use drape_types::{
    BroadPhasePush, ColliderPose, CollisionStatus, Contact, ContactPush, ContactQuery, DispatchArgs, MAX_CANDIDATES,
};

/// Label of the skipped contact passes of a cloth without colliders.
pub const CONTACT_LABEL: &str = "contact";
/// Label of the detect pass through the LBVH.
pub const DETECT_LABEL: &str = "contact: detect (BVH)";
/// Label of the brute-force detect pass.
pub const DETECT_BRUTE_FORCE_LABEL: &str = "contact: detect (brute force)";
/// Label of the culling pass.
pub const CULL_LABEL: &str = "contact: cull";
/// Label of the respond pass.
pub const RESPOND_LABEL: &str = "contact: respond";

/// How a frame collides a cloth with a collider.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum ContactMode {
    /// A broad phase once per frame gives each particle a short candidate list from one LBVH
    /// walk; every substep tests the lists (a particle that leaves its query box walks the LBVH
    /// instead), inside the integrator's last stage for a cloth's first collider, else after a
    /// cull against the root box.
    Lists,
    /// Cull against the root box, then traverse the LBVH every substep (indirect dispatch).
    Bvh,
    /// Test every leaf for every particle (baseline for benchmarks and tests).
    BruteForce,
}

/// Label of the broad phase.
pub const BROAD_PHASE_LABEL: &str = "contact: broad phase";
/// Label of the narrow-phase detect pass over candidate lists.
pub const DETECT_CANDIDATES_LABEL: &str = "contact: detect+respond (lists)";
/// Label of the crowded pass (a workgroup per crowded particle, `drape_kernels::crowded`).
pub const CROWDED_LABEL: &str = "contact: crowded particles (a workgroup each)";
/// Label of RK4's last stage fused with the narrow phase over candidate lists.
pub const RK4_UPDATE_CONTACT_LABEL: &str = "rk4: k4 + update + contact (lists)";
/// Label of semi-implicit Euler's commit fused with the narrow phase over candidate lists.
pub const EULER_UPDATE_CONTACT_LABEL: &str = "euler: commit + contact (lists)";

/// A collider's leaves as contact sees them: the LBVH over them, the leaves in its order, and
/// the detect kernels of their kind. Each leaf kind implements it in its own file.
pub trait ContactLeaves {
    fn tree(&self) -> &LbvhBuffers;
    /// The leaves in the tree's order (what the detect passes read).
    fn sorted_leaves(&self) -> BufferId;
    /// Detect through the LBVH (`kernels::contact::DETECT_BINDINGS`).
    fn detect_kernel(&self) -> &'static Kernel;
    /// Detect by testing every leaf (`kernels::contact::DETECT_BRUTE_FORCE_BINDINGS`).
    fn detect_brute_force_kernel(&self) -> &'static Kernel;
    /// The broad phase over the LBVH (`kernels::contact::BROAD_PHASE_BINDINGS`).
    fn broad_phase_kernel(&self) -> &'static Kernel;
    /// Detect over candidate lists (`kernels::contact::DETECT_CANDIDATES_BINDINGS`).
    fn detect_candidates_kernel(&self) -> &'static Kernel;
    /// The crowded particles the narrow phase hands over, a workgroup each
    /// (`kernels::contact::DETECT_CROWDED_BINDINGS`).
    fn detect_crowded_kernel(&self) -> &'static Kernel;
    /// The integrator's last stage and detect over candidate lists in one pass
    /// (`kernels::contact::UPDATE_CONTACT_BINDINGS`, `..._SPRINGS_BINDINGS` for a spring-list
    /// cloth).
    fn update_contact_kernel(&self, springs: bool) -> &'static Kernel;
    /// Which particles of a self-colliding cloth the collider carries when the fail-safe puts
    /// them back, and by which frames (`kernels::self_failsafe::FAILSAFE_CARRIERS_*`): the kind's
    /// kernel and its bindings between the tree's boxes and the cloth's anchors (its leaves, and
    /// what places them where the frame started and ended).
    fn failsafe_carriers(&self) -> (&'static Kernel, Vec<BufferId>);
    /// Builds the tree from the leaves' input.
    fn build_steps(&self) -> Vec<Step>;
    /// Refits the tree after the input moved (same leaves).
    fn refit_steps(&self) -> Vec<Step>;
    /// What the host writes to deform the collider before a refit (spheres, mesh vertices).
    fn deformable(&self) -> Handle<glam::Vec4>;
    /// Where the kind keeps the deformable input at the frame's start, when its leaves sweep
    /// from there to the current input over the frame (continuous contact with a deforming
    /// collider); `None` when the leaves stand at the current input all frame.
    fn swept_from(&self) -> Option<Handle<glam::Vec4>> {
        None
    }
}

/// A collider's leaves, of one of the leaf kinds.
pub enum ColliderLeaves {
    Spheres(SphereBvh),
    Triangles(TriangleBvh),
}

impl ColliderLeaves {
    pub fn kind(&self) -> &dyn ContactLeaves {
        match self {
            ColliderLeaves::Spheres(s) => s,
            ColliderLeaves::Triangles(t) => t,
        }
    }

    pub fn leaves(&self) -> u32 {
        self.kind().tree().leaves
    }
}

/// The push constants of work spanning substeps `first..end` of a frame of `substeps`: the
/// fractions of the frame where it starts and ends (what the colliders' poses interpolate at).
pub fn substep_span(first: u32, end: u32, substeps: u32) -> ContactPush {
    ContactPush { from: first as f32 / substeps as f32, to: end as f32 / substeps as f32, crowded: 0, hand_over: 0 }
}

/// What a frame's narrow phase over candidate lists does with its crowded particles (those
/// that walk the tree, and lists of `CROWDED_LIST` leaves or more; `drape_kernels::crowded`).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Crowded {
    /// Nothing: each lane answers its own, uncounted.
    Ignored,
    /// Each lane answers its own; they are counted in the cloth's health
    /// (`Health::crowded_contacts`), for the host to choose.
    Counted,
    /// Counted, and handed to the crowded pass, a workgroup each.
    HandedOver,
}

/// The push constants of substep `substep` of `substeps`'s narrow phase over candidate lists
/// and its crowded pass (`crowded`: what it does with its crowded particles).
pub fn narrow_phase_push(substep: u32, substeps: u32, crowded: Crowded) -> ContactPush {
    let longest = if crowded == Crowded::Ignored { 0 } else { CROWDED_LIST };
    let hand_over = u32::from(crowded == Crowded::HandedOver);
    ContactPush { crowded: longest, hand_over, ..substep_span(substep, substep + 1, substeps) }
}

/// One collider's buffers: its LBVH (built in the collider's own frame) and its pose at the
/// frame's start and end. Every cloth's contact with it reads them.
pub struct ColliderBuffers {
    pub leaves: ColliderLeaves,
    pub pose: Handle<ColliderPose>,
    /// Per triangle of a triangle collider, its neighbours' apexes and the vertices and edges
    /// it owns (`self_contact::collider_features`), and the triangle count: what a
    /// self-colliding cloth tests against its faces and edges.
    pub features: Option<(Handle<glam::UVec4>, u32)>,
}

impl ColliderBuffers {
    /// Buffers of a collider with `leaves` (declared by its leaf kind); `name` prefixes their
    /// debug names.
    pub fn declare(resources: &mut Resources, name: &str, leaves: ColliderLeaves) -> Self {
        ColliderBuffers { leaves, pose: resources.device(format!("{name}: pose"), 1), features: None }
    }

    pub fn tree(&self) -> &LbvhBuffers {
        self.leaves.kind().tree()
    }
}

/// The broad phase's output: each particle's query box and candidate list.
pub struct CandidateLists {
    pub queries: Handle<ContactQuery>,
    /// `MAX_CANDIDATES` leaf indices per particle.
    pub candidates: Handle<u32>,
    /// The particles a substep's narrow phase hands to the crowded pass (`FramePlan::crowded`,
    /// `drape_kernels::crowded`), and that pass's indirect dispatch.
    pub crowded: Handle<u32>,
    pub crowded_args: Handle<DispatchArgs>,
}

/// A contact's search (`ContactMode`) with the buffers it needs.
pub enum Search {
    Lists(CandidateLists),
    Bvh,
    BruteForce,
}

/// The contact's own buffers (one cloth against one collider).
pub struct ContactBuffers {
    pub search: Search,
    pub args: Handle<DispatchArgs>,
    /// Each particle's contact of the current substep (detect writes, respond reads).
    pub contacts: Handle<Contact>,
    /// Counters the host reads after every frame.
    pub status: Handle<CollisionStatus>,
}

impl ContactBuffers {
    pub fn declare(resources: &mut Resources, name: &str, particles: u32, mode: ContactMode) -> Self {
        let search = match mode {
            ContactMode::Lists => Search::Lists(CandidateLists {
                queries: resources.device(format!("{name}: query boxes"), particles),
                candidates: resources.device(format!("{name}: candidate lists"), particles * MAX_CANDIDATES),
                crowded: resources.device(format!("{name}: crowded particles"), particles),
                crowded_args: resources.device(format!("{name}: crowded dispatch"), 1),
            }),
            ContactMode::Bvh => Search::Bvh,
            ContactMode::BruteForce => Search::BruteForce,
        };
        ContactBuffers {
            search,
            args: resources.device(format!("{name}: dispatch args"), 1),
            contacts: resources.device(format!("{name}: contacts"), particles),
            status: resources.readback(format!("{name}: status")),
        }
    }

    /// What runs once at the start of a frame of `substeps` substeps of `cloth` against
    /// `collider`, before its substeps: the broad phase in `ContactMode::Lists`.
    pub fn frame_start_steps(
        &self,
        cloth: &ClothBuffers,
        collider: &ColliderBuffers,
        substeps: u32,
        out: &mut Vec<Step>,
    ) {
        let Search::Lists(lists) = &self.search else { return };
        let (leaves, tree) = (collider.leaves.kind(), collider.tree());
        let push: [u32; 4] = bytemuck::cast(BroadPhasePush { substeps, _pad: [0; 3] });
        out.push(Step::run_with(
            BROAD_PHASE_LABEL,
            leaves.broad_phase_kernel(),
            vec![
                cloth.params.id(),
                tree.collider.id(),
                collider.pose.id(),
                tree.nodes.id(),
                tree.aabbs.id(),
                tree.sorted_bounds.id(),
                leaves.sorted_leaves(),
                cloth.x.id(),
                cloth.v.id(),
                lists.queries.id(),
                lists.candidates.id(),
                self.status.id(),
            ],
            push,
            Dispatch::Threads(cloth.particles),
        ));
    }

    /// Whether this contact's substep passes can run inside the integrator's last stage
    /// (`update_contact_step`): with candidate lists, whose narrow phase reads only each
    /// particle's own motion.
    pub fn fuses_with_update(&self) -> bool {
        matches!(self.search, Search::Lists(_))
    }

    /// The integrator's last stage of substep `substep` of `substeps` of `cloth` (its first
    /// bindings `stage`, `ClothBuffers::stage_bindings`) and this contact's narrow phase against
    /// `collider`, in one pass (`fuses_with_update`; `None` otherwise): what the stage and
    /// `substep_steps` would do, without the culling pass and two barriers.
    pub fn update_contact_step(
        &self,
        label: &'static str,
        cloth: &ClothBuffers,
        stage: Vec<BufferId>,
        collider: &ColliderBuffers,
        (substep, substeps, crowded): (u32, u32, Crowded),
    ) -> Option<Step> {
        let Search::Lists(lists) = &self.search else { return None };
        let (leaves, tree) = (collider.leaves.kind(), collider.tree());
        let (mut bindings, springs) = (stage, cloth.spring_bindings());
        bindings.extend([
            tree.collider.id(),
            collider.pose.id(),
            tree.nodes.id(),
            tree.aabbs.id(),
            leaves.sorted_leaves(),
            lists.queries.id(),
            lists.candidates.id(),
            self.contacts.id(),
            self.status.id(),
            lists.crowded.id(),
            lists.crowded_args.id(),
            cloth.health.id(),
        ]);
        // A spring-list cloth's two bindings come last (`UPDATE_CONTACT_SPRINGS_BINDINGS`).
        bindings.extend(springs.into_iter().flatten());
        let push: [u32; 4] = bytemuck::cast(narrow_phase_push(substep, substeps, crowded));
        Some(Step::run_with(
            label,
            leaves.update_contact_kernel(springs.is_some()),
            bindings,
            push,
            Dispatch::Threads(cloth.particles),
        ))
    }

    /// With crowded particles handed over (`Crowded::HandedOver`; candidate lists only): the
    /// write that empties the crowded pass's dispatch, before a substep's narrow phase.
    pub fn crowded_reset_step(&self, crowded: Crowded) -> Option<Step> {
        match &self.search {
            Search::Lists(lists) if crowded == Crowded::HandedOver => Some(super::empty_dispatch(lists.crowded_args)),
            _ => None,
        }
    }

    /// With crowded particles handed over (`Crowded::HandedOver`; candidate lists only): the
    /// crowded pass of substep `substep` of `substeps` of `cloth` against `collider`, after its
    /// narrow phase (a workgroup per particle handed over, `drape_kernels::crowded`).
    pub fn crowded_step(
        &self,
        cloth: &ClothBuffers,
        collider: &ColliderBuffers,
        (substep, substeps, crowded): (u32, u32, Crowded),
    ) -> Option<Step> {
        let Search::Lists(lists) = &self.search else { return None };
        if crowded != Crowded::HandedOver {
            return None;
        }
        let push: [u32; 4] = bytemuck::cast(narrow_phase_push(substep, substeps, crowded));
        Some(Step::run_with(
            CROWDED_LABEL,
            collider.leaves.kind().detect_crowded_kernel(),
            self.narrow_phase_bindings(cloth, collider, lists),
            push,
            Dispatch::Indirect(lists.crowded_args),
        ))
    }

    /// The bindings the narrow phase over `lists` (`DETECT_CANDIDATES_BINDINGS`, less the
    /// cloth's health) and the crowded pass (`DETECT_CROWDED_BINDINGS`) share.
    fn narrow_phase_bindings(
        &self,
        cloth: &ClothBuffers,
        collider: &ColliderBuffers,
        lists: &CandidateLists,
    ) -> Vec<BufferId> {
        let (leaves, tree) = (collider.leaves.kind(), collider.tree());
        vec![
            cloth.params.id(),
            tree.collider.id(),
            collider.pose.id(),
            tree.nodes.id(),
            tree.aabbs.id(),
            leaves.sorted_leaves(),
            lists.queries.id(),
            lists.candidates.id(),
            cloth.x.id(),
            cloth.x_prev.id(),
            cloth.v.id(),
            self.contacts.id(),
            self.status.id(),
            lists.crowded.id(),
            lists.crowded_args.id(),
        ]
    }

    /// The contact passes of substep `substep` of `substeps` of `cloth` against `collider`
    /// (`crowded`: what the narrow phase over lists does with its crowded particles).
    pub fn substep_steps(
        &self,
        cloth: &ClothBuffers,
        collider: &ColliderBuffers,
        (substep, substeps, crowded): (u32, u32, Crowded),
        out: &mut Vec<Step>,
    ) {
        let (leaves, pose, buffers) = (collider.leaves.kind(), collider.pose, collider);
        let tree = leaves.tree();
        let span = substep_span(substep, substep + 1, substeps);
        let push: [u32; 4] = bytemuck::cast(span);
        let (params, collider) = (cloth.params.id(), tree.collider.id());
        let dispatch = match &self.search {
            Search::Lists(lists) => {
                out.extend(self.crowded_reset_step(crowded));
                out.push(self.cull_step(cloth, tree, pose, push));
                let narrow: [u32; 4] = bytemuck::cast(narrow_phase_push(substep, substeps, crowded));
                let mut bindings = self.narrow_phase_bindings(cloth, buffers, lists);
                bindings.push(cloth.health.id());
                out.push(Step::run_with(
                    DETECT_CANDIDATES_LABEL,
                    leaves.detect_candidates_kernel(),
                    bindings,
                    narrow,
                    Dispatch::Indirect(self.args),
                ));
                out.extend(self.crowded_step(cloth, buffers, (substep, substeps, crowded)));
                // The pass responds too: no respond pass (one dispatch and barrier fewer).
                return;
            }
            Search::Bvh => {
                out.push(self.cull_step(cloth, tree, pose, push));
                out.push(Step::run_with(
                    DETECT_LABEL,
                    leaves.detect_kernel(),
                    vec![
                        params,
                        collider,
                        pose.id(),
                        tree.nodes.id(),
                        tree.aabbs.id(),
                        leaves.sorted_leaves(),
                        cloth.x.id(),
                        cloth.x_prev.id(),
                        self.contacts.id(),
                    ],
                    push,
                    Dispatch::Indirect(self.args),
                ));
                Dispatch::Indirect(self.args)
            }
            Search::BruteForce => {
                out.push(Step::run_with(
                    DETECT_BRUTE_FORCE_LABEL,
                    leaves.detect_brute_force_kernel(),
                    vec![
                        params,
                        collider,
                        pose.id(),
                        leaves.sorted_leaves(),
                        cloth.x.id(),
                        cloth.x_prev.id(),
                        self.contacts.id(),
                    ],
                    push,
                    Dispatch::Threads(cloth.particles),
                ));
                Dispatch::Threads(cloth.particles)
            }
        };
        out.push(Step::run_with(
            RESPOND_LABEL,
            &RESPOND_CONTACTS,
            vec![params, collider, pose.id(), self.contacts.id(), cloth.x.id(), cloth.v.id()],
            push,
            dispatch,
        ));
    }
    /// The culling pass: the cloth's swept bounds against the collider's root box write the
    /// detect and respond passes' indirect dispatch.
    fn cull_step(&self, cloth: &ClothBuffers, tree: &LbvhBuffers, pose: Handle<ColliderPose>, push: [u32; 4]) -> Step {
        Step::run_with(
            CULL_LABEL,
            &CULL_CONTACT,
            vec![
                cloth.params.id(),
                tree.collider.id(),
                pose.id(),
                tree.aabbs.id(),
                tree.sorted_bounds.id(),
                cloth.x.id(),
                cloth.x_prev.id(),
                self.args.id(),
                self.status.id(),
            ],
            push,
            Dispatch::Workgroups(1),
        )
    }
}
