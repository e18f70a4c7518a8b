//! An LBVH over a triangle mesh (the collider's true surface): the triangle leaf kind's passes
//! around the generic build, a box per triangle before it, the corners gathered into the
//! tree's order after it; contact detects through it with the triangle kind's detect kernels.
//! A deforming collider rewrites `vertices` (same triangles) and refits.

use super::contact::ContactLeaves;
use super::lbvh::LbvhBuffers;
use crate::graph::{BufferId, Dispatch, Handle, Kernel, Resources, Step};
use crate::kernels::triangles::{
    BROAD_PHASE_TRIANGLES, DETECT_TRIANGLES, DETECT_TRIANGLES_BRUTE_FORCE, DETECT_TRIANGLES_CANDIDATES,
    DETECT_TRIANGLES_CROWDED, GATHER_TRIANGLES, TRIANGLE_BOUNDS, UPDATE_CONTACT_TRIANGLES,
    UPDATE_CONTACT_TRIANGLES_SPRINGS,
};
use drape_types::Triangle;
use glam::Vec4;

/// A triangle collider's buffers: its mesh (what the host writes), the triangles in the tree's
/// order, and its LBVH.
pub struct TriangleBvh {
    /// Vertex positions (xyz, w unused) at the frame's end.
    pub vertices: Handle<Vec4>,
    /// The same at the frame's start (equal to `vertices` unless the collider deforms): the
    /// leaves sweep from these to `vertices` over the frame.
    pub previous: Handle<Vec4>,
    /// 3 vertex indices per triangle.
    pub indices: Handle<u32>,
    /// Triangles in the tree's leaf order: what the traversal reads; then, leaf by leaf, how
    /// each one's corners moved over the frame (`drape_kernels::triangles::corner_motions_at`,
    /// the contact's surface motion on a deforming collider).
    pub sorted: Handle<Triangle>,
    pub tree: LbvhBuffers,
}

impl TriangleBvh {
    pub fn declare(resources: &mut Resources, name: &str, vertices: u32, triangles: u32) -> Self {
        TriangleBvh {
            vertices: resources.device(format!("{name}: vertices"), vertices),
            previous: resources.device(format!("{name}: previous vertices"), vertices),
            indices: resources.device(format!("{name}: triangle indices"), 3 * triangles),
            sorted: resources.device(format!("{name}: sorted triangles"), 2 * triangles),
            tree: LbvhBuffers::declare(resources, name, triangles),
        }
    }

    fn bounds_step(&self) -> Step {
        let t = &self.tree;
        Step::run(
            "triangle boxes",
            &TRIANGLE_BOUNDS,
            vec![t.collider.id(), self.vertices.id(), self.previous.id(), self.indices.id(), t.bounds.id()],
            Dispatch::Threads(t.leaves),
        )
    }

    fn gather_step(&self) -> Step {
        let t = &self.tree;
        Step::run(
            "gather triangles",
            &GATHER_TRIANGLES,
            vec![
                t.collider.id(),
                self.vertices.id(),
                self.previous.id(),
                self.indices.id(),
                t.order.id(),
                self.sorted.id(),
            ],
            Dispatch::Threads(t.leaves),
        )
    }
}

impl ContactLeaves for TriangleBvh {
    fn tree(&self) -> &LbvhBuffers {
        &self.tree
    }
    fn sorted_leaves(&self) -> BufferId {
        self.sorted.id()
    }
    fn detect_kernel(&self) -> &'static Kernel {
        &DETECT_TRIANGLES
    }
    fn build_steps(&self) -> Vec<Step> {
        self.tree.build_around(self.bounds_step(), self.gather_step())
    }
    fn refit_steps(&self) -> Vec<Step> {
        self.tree.refit_around(self.bounds_step(), self.gather_step())
    }
    fn deformable(&self) -> Handle<Vec4> {
        self.vertices
    }
    fn swept_from(&self) -> Option<Handle<Vec4>> {
        Some(self.previous)
    }
    fn detect_brute_force_kernel(&self) -> &'static Kernel {
        &DETECT_TRIANGLES_BRUTE_FORCE
    }
    fn broad_phase_kernel(&self) -> &'static Kernel {
        &BROAD_PHASE_TRIANGLES
    }
    fn detect_candidates_kernel(&self) -> &'static Kernel {
        &DETECT_TRIANGLES_CANDIDATES
    }
    fn failsafe_carriers(&self) -> (&'static Kernel, Vec<BufferId>) {
        let leaves =
            [self.sorted.id(), self.vertices.id(), self.previous.id(), self.indices.id(), self.tree.order.id()];
        (&crate::kernels::self_failsafe::FAILSAFE_CARRIERS_TRIANGLES, leaves.to_vec())
    }
    fn detect_crowded_kernel(&self) -> &'static Kernel {
        &DETECT_TRIANGLES_CROWDED
    }
    fn update_contact_kernel(&self, springs: bool) -> &'static Kernel {
        if springs { &UPDATE_CONTACT_TRIANGLES_SPRINGS } else { &UPDATE_CONTACT_TRIANGLES }
    }
}
