//! Cloth-vs-collider contact after each substep: a culling pass against the collider's root box
//! writes the traversal's indirect dispatch (zero workgroups when they cannot touch), then every
//! particle walks the LBVH. The brute-force mode tests every sphere instead.

use super::cloth::ClothBuffers;
use super::spheres::SphereBvh;
use crate::graph::{Dispatch, Handle, Resources, Step};
use crate::kernels::collide::{COLLIDE, COLLIDE_BRUTE_FORCE, CULL_COLLISION};
use drape_types::{ColliderPose, CollisionStatus, ContactPush, DispatchArgs};

/// Label of the collision traversal pass.
pub const COLLIDE_LABEL: &str = "collide (BVH)";
/// Label of the culling pass.
pub const CULL_LABEL: &str = "collide: cull";

/// How a frame collides a cloth with a collider.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum ContactMode {
    /// Cull against the root box, then traverse the LBVH (indirect dispatch).
    Bvh,
    /// Test every sphere for every particle (baseline for benchmarks and tests).
    BruteForce,
}

/// One collider as a cloth frame sees it: its LBVH (built in the collider's own frame), its
/// pose at the frame's start and end, and the contact's buffers.
pub struct ColliderBuffers {
    pub lbvh: SphereBvh,
    pub pose: Handle<ColliderPose>,
    pub contact: ContactBuffers,
}

impl ColliderBuffers {
    /// Buffers of a collider with `leaves` leaves; `name` prefixes their debug names.
    pub fn declare(resources: &mut Resources, name: &str, leaves: u32, mode: ContactMode) -> Self {
        ColliderBuffers {
            lbvh: SphereBvh::declare(resources, name, leaves),
            pose: resources.device(format!("{name}: pose"), 1),
            contact: ContactBuffers::declare(resources, &format!("{name} contact"), mode),
        }
    }

    /// The contact passes of substep `span.0` of `span.1`.
    pub fn substep_steps(&self, cloth: &ClothBuffers, span: (u32, u32), out: &mut Vec<Step>) {
        self.contact.substep_steps(cloth, &self.lbvh, self.pose, span, out);
    }
}

/// The contact's own buffers (one cloth against one collider).
pub struct ContactBuffers {
    pub mode: ContactMode,
    pub args: Handle<DispatchArgs>,
    /// Counters the host reads after every frame.
    pub status: Handle<CollisionStatus>,
}

impl ContactBuffers {
    pub fn declare(resources: &mut Resources, name: &str, mode: ContactMode) -> Self {
        ContactBuffers {
            mode,
            args: resources.device(format!("{name}: dispatch args"), 1),
            status: resources.readback(format!("{name}: status")),
        }
    }

    /// The contact passes of substep `substep` of `substeps`, against the collider whose LBVH
    /// (in its own frame) is `collider` and whose frame-start and frame-end poses are in `pose`.
    fn substep_steps(
        &self,
        cloth: &ClothBuffers,
        collider: &SphereBvh,
        pose: Handle<ColliderPose>,
        (substep, substeps): (u32, u32),
        out: &mut Vec<Step>,
    ) {
        let (c, tree) = (collider, &collider.tree);
        let span = ContactPush {
            from: substep as f32 / substeps as f32,
            to: (substep + 1) as f32 / substeps as f32,
            _pad: [0; 2],
        };
        let push: [u32; 4] = bytemuck::cast(span);
        match self.mode {
            ContactMode::Bvh => {
                out.push(Step::run_with(
                    CULL_LABEL,
                    &CULL_COLLISION,
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
                ));
                out.push(Step::run_with(
                    COLLIDE_LABEL,
                    &COLLIDE,
                    vec![
                        cloth.params.id(),
                        tree.collider.id(),
                        pose.id(),
                        tree.nodes.id(),
                        tree.aabbs.id(),
                        c.sorted.id(),
                        cloth.x.id(),
                        cloth.v.id(),
                        cloth.x_prev.id(),
                        self.status.id(),
                    ],
                    push,
                    Dispatch::Indirect(self.args),
                ));
            }
            ContactMode::BruteForce => out.push(Step::run_with(
                "collide (brute force)",
                &COLLIDE_BRUTE_FORCE,
                vec![
                    cloth.params.id(),
                    tree.collider.id(),
                    pose.id(),
                    c.sorted.id(),
                    cloth.x.id(),
                    cloth.v.id(),
                    cloth.x_prev.id(),
                ],
                push,
                Dispatch::Threads(cloth.particles),
            )),
        }
    }
}
