//! The CPU twin of `Simulation`: the same program (buffers, LBVH build, frame steps) run by the
//! CPU executor with the kernels' own functions.

use crate::cloth::Cloth;
use crate::cpu::CpuExecutor;
use crate::error::Result;
use crate::program::ClothProgram;
use crate::sim::{Collider, SimSettings, check_collision, check_health};
use crate::stability::Stability;
use drape_types::{CollisionStatus, Health, SimParams};
use glam::Vec4;

/// A cloth simulation on the CPU with the kernels' own functions.
pub struct CpuSimulation {
    executor: CpuExecutor,
    program: ClothProgram,
    params: SimParams,
    settings: SimSettings,
    stability: Stability,
    frames_done: u64,
}

impl CpuSimulation {
    pub fn new(cloth: &Cloth, settings: SimSettings) -> Result<Self> {
        Self::with_collider(cloth, settings, None)
    }

    /// Like `Simulation::with_collider`, with the LBVH built by the CPU executor.
    pub fn with_collider(cloth: &Cloth, settings: SimSettings, collider: Option<&Collider>) -> Result<Self> {
        let (params, stability) = settings.resolve(cloth)?;
        let program = ClothProgram::new(cloth, &params, settings.plan(&params, &stability), collider)?;
        let mut executor = CpuExecutor::new(&program.resources);
        for (id, data) in &program.initial {
            executor.upload_bytes(*id, data)?;
        }
        if let Some(c) = &program.collider {
            executor.run(&c.lbvh.build_steps())?;
        }
        Ok(CpuSimulation { executor, program, params, settings, stability, frames_done: 0 })
    }

    /// Runs one frame; `Error::Unstable` on blow-up, like the GPU.
    pub fn step(&mut self) -> Result<()> {
        self.executor.run(&self.program.frame)?;
        self.frames_done += 1;
        let health: Health = self.executor.read(self.program.cloth.health, 1)?[0];
        check_health(&health, self.frames_done, &self.settings, &self.stability)?;
        check_collision(&self.collision_status(), self.frames_done)
    }

    /// Collision counters of the last frame.
    pub fn collision_status(&self) -> CollisionStatus {
        self.program
            .collider
            .as_ref()
            .and_then(|c| self.executor.read(c.contact.status, 1).ok())
            .map(|s| s[0])
            .unwrap_or_default()
    }

    fn vec4s(&self, buffer: crate::graph::Handle<Vec4>) -> Vec<Vec4> {
        self.executor.read(buffer, self.params.particle_count as usize).unwrap_or_default()
    }
    pub fn positions(&self) -> Vec<Vec4> {
        self.vec4s(self.program.cloth.x)
    }
    pub fn velocities(&self) -> Vec<Vec4> {
        self.vec4s(self.program.cloth.v)
    }
    pub fn normals(&self) -> Vec<Vec4> {
        self.vec4s(self.program.cloth.normals)
    }
    pub fn params(&self) -> &SimParams {
        &self.params
    }
    pub fn stability(&self) -> &Stability {
        &self.stability
    }
}
