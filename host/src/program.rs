//! A simulation's work as data: the buffers of its cloth and colliders, the initial contents of
//! each, the LBVH builds and the frame's steps. The GPU `Simulation` and the `CpuSimulation`
//! both run exactly this.

use crate::cloth::Cloth;
use crate::controls::Controls;
use crate::error::Result;
use crate::graph::{BufferId, Resources, Step};
use crate::lbvh::collider_params;
use crate::programs::cloth::{ClothBuffers, FramePlan, frame_steps};
use crate::programs::contact::{ColliderBuffers, ContactMode};
use crate::sim::{Collider, SimSettings};
use drape_types::{ColliderParams, ColliderPose, RigidPose, SimParams};

pub(crate) struct ClothProgram {
    pub resources: Resources,
    pub cloth: ClothBuffers,
    pub colliders: Vec<ColliderBuffers>,
    /// Buffer contents to upload before anything runs.
    pub initial: Vec<(BufferId, Vec<u8>)>,
    pub frame: Vec<Step>,
}

impl ClothProgram {
    /// The program of `cloth` colliding with `colliders` under `settings`, and the host-side
    /// controls holding its starting values (what both simulations start from).
    pub fn with_controls(cloth: &Cloth, settings: SimSettings, colliders: &[Collider]) -> Result<(Self, Controls)> {
        let (params, stability) = settings.resolve(cloth)?;
        let (program, collider_start) = Self::new(cloth, &params, settings.plan(&params, &stability), colliders)?;
        Ok((program, Controls::new(params, settings, stability, &collider_start)))
    }

    /// The program, and each collider's starting parameters and pose.
    fn new(
        cloth: &Cloth,
        params: &SimParams,
        plan: FramePlan,
        colliders: &[Collider],
    ) -> Result<(Self, Vec<(ColliderParams, RigidPose)>)> {
        let mut resources = Resources::new();
        let triangles = cloth.triangles();
        let buffers = ClothBuffers::declare(&mut resources, "cloth", params.particle_count, triangles.len() as u32);
        let bytes = |data: &[glam::Vec4]| bytemuck::cast_slice::<_, u8>(data).to_vec();
        let mut initial = vec![(buffers.params.id(), bytemuck::bytes_of(params).to_vec())];
        // Stage buffers start as copies of the state so pinned particles read sane values.
        for h in [buffers.x, buffers.xa, buffers.xb, buffers.x_prev] {
            initial.push((h.id(), bytes(&cloth.positions)));
        }
        initial.push((buffers.v.id(), bytes(&cloth.velocities)));
        initial.push((buffers.indices.id(), bytemuck::cast_slice::<_, u8>(&triangles).to_vec()));
        let mut collider_buffers = Vec::with_capacity(colliders.len());
        let mut collider_start = Vec::with_capacity(colliders.len());
        for (i, c) in colliders.iter().enumerate() {
            let params = collider_params(&c.spheres, c.thickness, c.friction)?;
            let name = if i == 0 { "collider".to_string() } else { format!("collider {i}") };
            let mode = if c.use_bvh { ContactMode::Bvh } else { ContactMode::BruteForce };
            let b = ColliderBuffers::declare(&mut resources, &name, params.leaf_count, buffers.particles, mode);
            initial.push((b.lbvh.tree.collider.id(), bytemuck::bytes_of(&params).to_vec()));
            initial.push((b.lbvh.spheres.id(), bytes(&c.spheres)));
            let pose = ColliderPose { previous: c.pose, current: c.pose };
            initial.push((b.pose.id(), bytemuck::bytes_of(&pose).to_vec()));
            collider_buffers.push(b);
            collider_start.push((params, c.pose));
        }
        let frame = frame_steps(plan, &buffers, &collider_buffers);
        Ok((ClothProgram { resources, cloth: buffers, colliders: collider_buffers, initial, frame }, collider_start))
    }

    /// Every collider's LBVH build, in one list.
    pub fn build_steps(&self) -> Vec<Step> {
        self.colliders.iter().flat_map(|c| c.lbvh.build_steps()).collect()
    }

    /// Every collider's refit (what a frame that deforms colliders may add).
    pub fn refit_steps(&self) -> Vec<Step> {
        self.colliders.iter().flat_map(|c| c.lbvh.refit_steps()).collect()
    }
}
