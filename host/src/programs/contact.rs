//! Cloth-vs-collider contact after each substep: a culling pass against the collider's root box
//! writes the traversal's indirect dispatch (zero workgroups when they cannot touch), then every
//! particle walks the LBVH. The brute-force mode tests every sphere instead.

use super::cloth::ClothBuffers;
use super::lbvh::LbvhBuffers;
use crate::graph::{Dispatch, Handle, Resources, Step};
use crate::kernels::collide::{COLLIDE, COLLIDE_BRUTE_FORCE, CULL_COLLISION};
use drape_types::{CollisionStatus, DispatchArgs};

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

    /// The contact passes of one substep.
    pub fn substep_steps(&self, cloth: &ClothBuffers, collider: &LbvhBuffers, out: &mut Vec<Step>) {
        let c = collider;
        match self.mode {
            ContactMode::Bvh => {
                out.push(Step::run(
                    CULL_LABEL,
                    &CULL_COLLISION,
                    vec![
                        cloth.params.id(),
                        c.collider.id(),
                        c.aabbs.id(),
                        c.sorted.id(),
                        cloth.x.id(),
                        cloth.x_prev.id(),
                        self.args.id(),
                        self.status.id(),
                    ],
                    Dispatch::Workgroups(1),
                ));
                out.push(Step::run(
                    COLLIDE_LABEL,
                    &COLLIDE,
                    vec![
                        cloth.params.id(),
                        c.collider.id(),
                        c.nodes.id(),
                        c.aabbs.id(),
                        c.sorted.id(),
                        cloth.x.id(),
                        cloth.v.id(),
                        cloth.x_prev.id(),
                        self.status.id(),
                    ],
                    Dispatch::Indirect(self.args),
                ));
            }
            ContactMode::BruteForce => out.push(Step::run(
                "collide (brute force)",
                &COLLIDE_BRUTE_FORCE,
                vec![cloth.params.id(), c.collider.id(), c.sorted.id(), cloth.x.id(), cloth.v.id(), cloth.x_prev.id()],
                Dispatch::Threads(cloth.particles),
            )),
        }
    }
}
