//! A simulation's work as data: the buffers of its cloth (and collider), the initial contents
//! of each, the LBVH build and the frame's steps. The GPU `Simulation` and the `CpuSimulation`
//! both run exactly this.

use crate::cloth::Cloth;
use crate::error::Result;
use crate::graph::{BufferId, Resources, Step};
use crate::lbvh::collider_params;
use crate::programs::cloth::{ClothBuffers, FramePlan, frame_steps};
use crate::programs::contact::{ContactBuffers, ContactMode};
use crate::programs::lbvh::LbvhBuffers;
use crate::sim::Collider;
use drape_types::SimParams;

/// One collider: its LBVH and contact buffers.
pub(crate) struct ColliderProgram {
    pub lbvh: LbvhBuffers,
    pub contact: ContactBuffers,
}

pub(crate) struct ClothProgram {
    pub resources: Resources,
    pub cloth: ClothBuffers,
    pub collider: Option<ColliderProgram>,
    /// Buffer contents to upload before anything runs.
    pub initial: Vec<(BufferId, Vec<u8>)>,
    pub frame: Vec<Step>,
}

impl ClothProgram {
    pub fn new(cloth: &Cloth, params: &SimParams, plan: FramePlan, collider: Option<&Collider>) -> Result<Self> {
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
        let collider = match collider {
            Some(c) => {
                let params = collider_params(&c.spheres, c.thickness, c.friction)?;
                let lbvh = LbvhBuffers::declare(&mut resources, "collider", params.leaf_count);
                let mode = if c.use_bvh { ContactMode::Bvh } else { ContactMode::BruteForce };
                let contact = ContactBuffers::declare(&mut resources, "contact", mode);
                initial.push((lbvh.collider.id(), bytemuck::bytes_of(&params).to_vec()));
                initial.push((lbvh.spheres.id(), bytes(&c.spheres)));
                Some(ColliderProgram { lbvh, contact })
            }
            None => None,
        };
        let frame = frame_steps(plan, &buffers, collider.as_ref().map(|c| (&c.contact, &c.lbvh)));
        Ok(ClothProgram { resources, cloth: buffers, collider, initial, frame })
    }
}
