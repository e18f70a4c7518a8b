//! A cloth's self-collision as a sub-graph over handles: an LBVH over the cloth's own triangles
//! (built by the generic builder at the frame's start, from a Morton box the GPU measures;
//! refit every substep) and, each substep after the collider's response, the vertex-triangle
//! pass and the application of its summed corrections (`drape_kernels::self_contact`).

use super::lbvh::LbvhBuffers;
use crate::graph::{Dispatch, Handle, Resources, Step};
use crate::kernels::self_contact::{
    APPLY_SELF_CONTACT, CLOTH_TRIANGLE_BOUNDS, GATHER_CLOTH_TRIANGLES, SELF_CONTACT, SELF_SCENE_BOUNDS,
};
use drape_types::{ColliderParams, SimParams};
use glam::{UVec4, Vec4};

/// The buffers of one cloth's self-collision.
pub struct SelfContactBuffers {
    pub tree: LbvhBuffers,
    /// Each sorted leaf's corners (xyz) and triangle (w).
    pub sorted: Handle<UVec4>,
    /// Per particle: the summed corrections (3 fixed-point words) and their count.
    pub delta: Handle<u32>,
    particles: u32,
}

/// What the self-collision passes of one cloth read and write.
pub struct SelfContactCloth {
    pub params: Handle<SimParams>,
    pub x: Handle<Vec4>,
    pub v: Handle<Vec4>,
    pub x_prev: Handle<Vec4>,
    pub indices: Handle<u32>,
}

impl SelfContactBuffers {
    pub fn declare(resources: &mut Resources, name: &str, particles: u32, triangles: u32) -> Self {
        let name = format!("{name} self-collision");
        SelfContactBuffers {
            tree: LbvhBuffers::declare(resources, &name, triangles),
            sorted: resources.device(format!("{name}: sorted triangles"), triangles),
            delta: resources.device(format!("{name}: corrections"), 4 * particles),
            particles,
        }
    }

    /// The tree's parameters before the first frame (the Morton box is the GPU's to write).
    pub fn initial_params(triangles: u32, thickness: f32) -> ColliderParams {
        ColliderParams { leaf_count: triangles, thickness, ..Default::default() }
    }

    fn triangle_bounds(&self, cloth: &SelfContactCloth) -> Step {
        let t = &self.tree;
        Step::run(
            "self: triangle boxes",
            &CLOTH_TRIANGLE_BOUNDS,
            vec![t.collider.id(), cloth.x.id(), cloth.x_prev.id(), cloth.indices.id(), t.bounds.id()],
            Dispatch::Threads(t.leaves),
        )
    }

    /// At the frame's start: the Morton box, then the whole build over the triangles' boxes,
    /// then the triangles' corners in the tree's order.
    pub fn frame_start_steps(&self, cloth: &SelfContactCloth, steps: &mut Vec<Step>) {
        let t = &self.tree;
        steps.push(Step::run(
            "self: cloth bounds",
            &SELF_SCENE_BOUNDS,
            vec![cloth.params.id(), cloth.x.id(), t.collider.id()],
            Dispatch::Workgroups(1),
        ));
        let gather = Step::run(
            "self: gather triangles",
            &GATHER_CLOTH_TRIANGLES,
            vec![t.collider.id(), cloth.indices.id(), t.order.id(), self.sorted.id()],
            Dispatch::Threads(t.leaves),
        );
        steps.extend(t.build_around(self.triangle_bounds(cloth), gather));
    }

    /// Every substep, after the collider's response: refit to where the triangles are now, find
    /// the pairs, apply the corrections.
    pub fn substep_steps(&self, cloth: &SelfContactCloth, steps: &mut Vec<Step>) {
        let t = &self.tree;
        steps.push(self.triangle_bounds(cloth));
        steps.extend(t.refit_steps());
        steps.push(Step::fill(self.delta, 0));
        steps.push(Step::run(
            "self: vertex-triangle",
            &SELF_CONTACT,
            vec![
                cloth.params.id(),
                t.collider.id(),
                t.nodes.id(),
                t.aabbs.id(),
                t.sorted_bounds.id(),
                self.sorted.id(),
                cloth.x.id(),
                cloth.x_prev.id(),
                self.delta.id(),
            ],
            Dispatch::Threads(self.particles),
        ));
        steps.push(Step::run(
            "self: apply",
            &APPLY_SELF_CONTACT,
            vec![cloth.params.id(), cloth.x.id(), cloth.v.id(), self.delta.id()],
            Dispatch::Threads(self.particles),
        ));
    }
}
