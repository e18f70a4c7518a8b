//! The CPU twin of `Simulation`: the same program (buffers, LBVH build, frame steps) and the
//! same runtime controls, run by the CPU executor with the kernels' own functions.

use crate::cloth::Cloth;
use crate::controls::Controls;
use crate::cpu::CpuExecutor;
use crate::error::Result;
use crate::program::ClothProgram;
use crate::sim::{Collider, SimSettings, check_collision, check_health, teleported};
use crate::stability::Stability;
use drape_types::{CollisionStatus, Health, SimParams};
use glam::Vec4;

/// A cloth simulation on the CPU with the kernels' own functions.
pub struct CpuSimulation {
    executor: CpuExecutor,
    program: ClothProgram,
    controls: Controls,
    frames_done: u64,
}

impl CpuSimulation {
    pub fn new(cloth: &Cloth, settings: SimSettings) -> Result<Self> {
        Self::with_colliders(cloth, settings, &[])
    }

    /// Like `Simulation::with_collider`, with the LBVH built by the CPU executor.
    pub fn with_collider(cloth: &Cloth, settings: SimSettings, collider: Option<&Collider>) -> Result<Self> {
        Self::with_colliders(cloth, settings, collider.map(std::slice::from_ref).unwrap_or(&[]))
    }

    /// Like `Simulation::with_colliders`.
    pub fn with_colliders(cloth: &Cloth, settings: SimSettings, colliders: &[Collider]) -> Result<Self> {
        let (program, controls) = ClothProgram::with_controls(cloth, settings, colliders)?;
        let mut executor = CpuExecutor::new(&program.resources);
        for (id, data) in &program.initial {
            executor.upload_bytes(*id, data)?;
        }
        executor.run(&program.build_steps())?;
        Ok(CpuSimulation { executor, program, controls, frames_done: 0 })
    }

    /// Runs one frame; `Error::Unstable` on blow-up, like the GPU.
    pub fn step(&mut self) -> Result<()> {
        let leading = self.controls.begin_frame(&self.program);
        self.executor.run(&leading)?;
        self.executor.run(&self.program.frame)?;
        self.frames_done += 1;
        let health: Health = self.executor.read(self.program.cloth.health, 1)?[0];
        check_health(&health, self.frames_done, &self.controls.settings, &self.controls.stability)?;
        for c in &self.program.colliders {
            check_collision(&self.executor.read(c.contact.status, 1)?[0], self.frames_done)?;
        }
        Ok(())
    }

    fn replan(&mut self, substeps_changed: bool) -> Result<()> {
        if substeps_changed {
            self.program.frame = self.controls.frame_steps(&self.program);
        }
        Ok(())
    }

    /// Collision counters of the last frame (all colliders together).
    pub fn collision_status(&self) -> CollisionStatus {
        let mut total = CollisionStatus::default();
        for c in &self.program.colliders {
            if let Ok(s) = self.executor.read(c.contact.status, 1) {
                total.overflows += s[0].overflows;
                total.ran += s[0].ran;
                total.skipped += s[0].skipped;
            }
        }
        total
    }

    /// Teleports the cloth (see `Simulation::set_state`).
    pub fn set_state(&mut self, positions: &[glam::Vec3], velocities: &[glam::Vec3]) -> Result<()> {
        let (x, v) = teleported(&self.positions(), positions, velocities)?;
        self.executor.upload(self.program.cloth.x, &x)?;
        self.executor.upload(self.program.cloth.v, &v)
    }

    fn vec4s(&self, buffer: crate::graph::Handle<Vec4>) -> Vec<Vec4> {
        self.executor.read(buffer, self.controls.params.particle_count as usize).unwrap_or_default()
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
        &self.controls.params
    }
    pub fn stability(&self) -> &Stability {
        &self.controls.stability
    }
}

crate::controls::runtime_setters!(CpuSimulation);
