//! An LBVH over spheres (the paper's voxel spheres): the sphere leaf kind's passes around the
//! generic build, box per sphere before it, spheres gathered into the tree's order after it;
//! contact detects through it with the sphere kind's detect kernels. A deforming collider
//! rewrites `spheres` (same count) and refits; its spheres sweep from `previous` over the frame.

use super::contact::ContactLeaves;
use super::lbvh::LbvhBuffers;
use crate::graph::{BufferId, Dispatch, Handle, Kernel, Resources, Step};
use crate::kernels::spheres::{
    BROAD_PHASE_SPHERES, DETECT_SPHERES, DETECT_SPHERES_BRUTE_FORCE, DETECT_SPHERES_CANDIDATES, DETECT_SPHERES_CROWDED,
    GATHER_SPHERES, SPHERE_BOUNDS, UPDATE_CONTACT_SPHERES, UPDATE_CONTACT_SPHERES_SPRINGS,
};
use drape_types::SphereLeaf;
use glam::Vec4;

/// A sphere collider's buffers: its spheres (input and tree order) and its LBVH.
pub struct SphereBvh {
    /// Spheres in input order (xyz centre, w radius) at the frame's end: what the host writes.
    pub spheres: Handle<Vec4>,
    /// The same at the frame's start (equal to `spheres` unless the collider deforms): the
    /// spheres sweep from these to `spheres` over the frame (centres and radii).
    pub previous: Handle<Vec4>,
    /// Spheres in the tree's leaf order, with their sweeps: what the traversal reads.
    pub sorted: Handle<SphereLeaf>,
    pub tree: LbvhBuffers,
}

impl SphereBvh {
    pub fn declare(resources: &mut Resources, name: &str, leaves: u32) -> Self {
        SphereBvh {
            spheres: resources.device(format!("{name}: spheres"), leaves),
            previous: resources.device(format!("{name}: previous spheres"), leaves),
            sorted: resources.device(format!("{name}: sorted spheres"), leaves),
            tree: LbvhBuffers::declare(resources, name, leaves),
        }
    }

    pub fn leaves(&self) -> u32 {
        self.tree.leaves
    }

    fn bounds_step(&self) -> Step {
        let t = &self.tree;
        Step::run(
            "sphere boxes",
            &SPHERE_BOUNDS,
            vec![t.collider.id(), self.spheres.id(), self.previous.id(), t.bounds.id()],
            Dispatch::Threads(t.leaves),
        )
    }

    fn gather_step(&self) -> Step {
        let t = &self.tree;
        Step::run(
            "gather spheres",
            &GATHER_SPHERES,
            vec![t.collider.id(), self.spheres.id(), self.previous.id(), t.order.id(), self.sorted.id()],
            Dispatch::Threads(t.leaves),
        )
    }
}

impl ContactLeaves for SphereBvh {
    fn tree(&self) -> &LbvhBuffers {
        &self.tree
    }
    fn sorted_leaves(&self) -> BufferId {
        self.sorted.id()
    }
    fn detect_kernel(&self) -> &'static Kernel {
        &DETECT_SPHERES
    }
    fn build_steps(&self) -> Vec<Step> {
        self.tree.build_around(self.bounds_step(), self.gather_step())
    }
    fn refit_steps(&self) -> Vec<Step> {
        self.tree.refit_around(self.bounds_step(), self.gather_step())
    }
    fn deformable(&self) -> Handle<Vec4> {
        self.spheres
    }
    fn swept_from(&self) -> Option<Handle<Vec4>> {
        Some(self.previous)
    }
    fn detect_brute_force_kernel(&self) -> &'static Kernel {
        &DETECT_SPHERES_BRUTE_FORCE
    }
    fn broad_phase_kernel(&self) -> &'static Kernel {
        &BROAD_PHASE_SPHERES
    }
    fn detect_candidates_kernel(&self) -> &'static Kernel {
        &DETECT_SPHERES_CANDIDATES
    }
    fn failsafe_carriers(&self) -> (&'static Kernel, Vec<BufferId>) {
        (&crate::kernels::self_failsafe::FAILSAFE_CARRIERS_SPHERES, vec![self.sorted.id()])
    }
    fn detect_crowded_kernel(&self) -> &'static Kernel {
        &DETECT_SPHERES_CROWDED
    }
    fn update_contact_kernel(&self, springs: bool) -> &'static Kernel {
        if springs { &UPDATE_CONTACT_SPHERES_SPRINGS } else { &UPDATE_CONTACT_SPHERES }
    }
}
